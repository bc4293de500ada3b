/* error.c — result names and the thread-local last-error text. */
#include <stdio.h>
#include <string.h>

#include "core_internal.h"

static _Thread_local char sq__error_text[1024];

const char *sq_result_name(sq_result r)
{
    switch (r) {
    case SQ_OK: return "SQ_OK";
    case SQ_ERR_INVALID_ARG: return "SQ_ERR_INVALID_ARG";
    case SQ_ERR_OUT_OF_MEMORY: return "SQ_ERR_OUT_OF_MEMORY";
    case SQ_ERR_IO: return "SQ_ERR_IO";
    case SQ_ERR_PARSE: return "SQ_ERR_PARSE";
    case SQ_ERR_UNSTABLE: return "SQ_ERR_UNSTABLE";
    case SQ_ERR_UNSUPPORTED: return "SQ_ERR_UNSUPPORTED";
    case SQ_ERR_GL: return "SQ_ERR_GL";
    case SQ_ERR_TOO_LARGE: return "SQ_ERR_TOO_LARGE";
    case SQ_ERR_EXISTS: return "SQ_ERR_EXISTS";
    case SQ_ERR_NOT_FOUND: return "SQ_ERR_NOT_FOUND";
    case SQ_ERR_INTERNAL: return "SQ_ERR_INTERNAL";
    case SQ_ERR_CANCELLED: return "SQ_ERR_CANCELLED";
    case SQ_ERR_NO_SPACE: return "SQ_ERR_NO_SPACE";
    }
    return "SQ_ERR_UNKNOWN";
}

const char *sq_last_error(void) { return sq__error_text; }
void sq_clear_error(void) { sq__error_text[0] = 0; }

sq_result sq__failv(sq_context *ctx, sq_result r, const char *module, const char *fmt,
                    va_list ap)
{
    vsnprintf(sq__error_text, sizeof sq__error_text, fmt, ap);
    if (ctx) sq_log(ctx, SQ_LOG_ERROR, module, "%s", sq__error_text);
    return r;
}

sq_result sq__fail(sq_context *ctx, sq_result r, const char *module, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    sq__failv(ctx, r, module, fmt, ap);
    va_end(ap);
    return r;
}

sq_result sq__set_error(sq_result r, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(sq__error_text, sizeof sq__error_text, fmt, ap);
    va_end(ap);
    return r;
}

sq_result sq_set_error(sq_result r, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(sq__error_text, sizeof sq__error_text, fmt, ap);
    va_end(ap);
    return r;
}
