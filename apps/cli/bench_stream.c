/* bench_stream.c — `squall bench stream`: the machine's memory bandwidth alone. */
#include "cases.h"

int sq_bench_stream_case(const sq_bench_args *a)
{
    sq_json j;
    sq_json_begin(&j);
    sq_json_str(&j, "case", "stream");
    sq_json_int(&j, "threads", a->threads);
    sq_json_num(&j, "stream_gbps", a->stream_gbps);
    sq_json_end(&j, stdout);
    return 0;
}
