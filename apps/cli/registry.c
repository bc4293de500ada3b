/* registry.c — the cases of `squall bench` and `squall validate`. One line per case;
 * implementations live in apps/cli/bench_<family>.c and apps/cli/validate_<family>.c. */
#include "cli.h"
#include "cases.h"

const sq_cli_case sq_cli_bench_cases[] = {
    {"stream", "STREAM triad memory bandwidth only", "", sq_bench_stream_case, NULL},
    {"render-volume", "GL ms per frame: 128^3 dust volume, 10^5 soft particles, neither",
     "--width 1280 --height 720 --size 128 --slices 128 --particles 100000",
     sq_bench_render_volume, NULL},
    {"grid", "MAC-grid fluid step: MacCormack advection + MGPCG projection + 2 scalars",
     "--grid 64|128", sq_bench_grid, NULL},
    {"lbm", "D3Q15 wind step: fused collide + stream (AA pattern), periodic box",
     "--size 128|256x128x128 --collision trt|bgk|smagorinsky", sq_bench_lbm, NULL},
    {"sandstorm", "full two-phase desert-sandstorm step (wind, projection to 1e-3, 4 dust bins)",
     "--grid 64|128|64x64x32 --world dunes|flat --spinup 10", sq_bench_sandstorm, NULL},
    {"sph", "SPH sub-step (sort, density, strain, forces, integrate): Cross snow and water",
     "--particles 65536|262144|1048576 --model cross|water|both", sq_bench_sph, NULL},
    {"snowdrift", "village-snowdrift frame (1/24 s): D3Q15 wind, u*, snow transport/deposition/"
     "erosion, flakes, drawables; per-stage ms",
     "--preset village-snowdrift --spinup 48", sq_bench_snowdrift, NULL},
    /* helpers: add bench cases here, e.g. {"lbm", "...", "--size 128|256x128x128", sq_bench_lbm, NULL}, */
    {NULL, NULL, NULL, NULL, NULL},
};

const sq_cli_case sq_cli_validate_cases[] = {
    {"lbm-cavity", "lid-driven cavity (D3Q15, TRT): centre-line profiles vs Ghia et al. 1982",
     "--re 100|400|1000 --n 64", NULL, sq_validate_lbm_cavity},
    {"dam-break", "SPH water-column collapse (n^2 = 2): surge front Z(T) vs Martin & Moyce 1952",
     "--a 0.25 --spacing 0.01 --t-end 0.6 --alpha 0.02 --kernel cubic|muller", NULL,
     sq_validate_dam_break},
    /* helpers: add validate cases here, e.g. {"lbm-cavity", "...", "--re 100 --n 64", NULL, sq_validate_lbm_cavity}, */
    {NULL, NULL, NULL, NULL, NULL},
};
