/* squall/core.h — context, result codes, last-error text, logging, aligned allocation,
 * memory budget checks, feature queries. Everything in libsquall hangs off an sq_context. */
#ifndef SQ_CORE_H
#define SQ_CORE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(SQ_BUILDING_LIBRARY) && defined(__GNUC__)
#define SQ_API __attribute__((visibility("default")))
#else
#define SQ_API
#endif

#if defined(__GNUC__)
#define SQ_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define SQ_PRINTF(a, b)
#endif

#define SQ_VERSION_MAJOR 0
#define SQ_VERSION_MINOR 1
#define SQ_VERSION_PATCH 0
#define SQ_VERSION_STRING "0.1.0"

/* Result codes: SQ_OK = 0, failures are small negative numbers. The human-readable reason is
 * in sq_last_error() on the failing thread. */
typedef enum sq_result {
    SQ_OK = 0,
    SQ_ERR_INVALID_ARG = -1, /* a desc field, argument or input value breaks a rule */
    SQ_ERR_OUT_OF_MEMORY = -2,
    SQ_ERR_IO = -3,          /* file missing, unreadable, unwritable */
    SQ_ERR_PARSE = -4,       /* malformed file (YAML, PNG, NetCDF) */
    SQ_ERR_UNSTABLE = -5,    /* numerical blow-up: names step, place and field */
    SQ_ERR_UNSUPPORTED = -6, /* feature not compiled in or not offered by the platform */
    SQ_ERR_GL = -7,          /* OpenGL / EGL failure */
    SQ_ERR_TOO_LARGE = -8,   /* request exceeds memory or an implementation limit */
    SQ_ERR_EXISTS = -9,      /* output exists and overwrite was not requested */
    SQ_ERR_NOT_FOUND = -10,  /* unknown preset, layer, key */
    SQ_ERR_INTERNAL = -11,
    SQ_ERR_CANCELLED = -12,  /* sq_context_cancel was called (Ctrl-C): a clean stop */
    SQ_ERR_NO_SPACE = -13    /* an output could not be written: the disk or quota is full */
} sq_result;

/* The enumerator name of r ("SQ_ERR_INVALID_ARG"); "SQ_ERR_UNKNOWN" for another value.
 * Static storage. */
SQ_API const char *sq_result_name(sq_result r);

/* The reason for the last failure on this thread ("" if none). Valid until the next failure. */
SQ_API const char *sq_last_error(void);
SQ_API void sq_clear_error(void);
/* Sets this thread's last-error text (printf-style) and returns r: for callbacks and
 * applications that report through the same channel. */
SQ_API sq_result sq_set_error(sq_result r, const char *fmt, ...) SQ_PRINTF(2, 3);

typedef enum sq_log_level {
    SQ_LOG_DEFAULT = 0, /* = SQ_LOG_INFO */
    SQ_LOG_DEBUG = 1,
    SQ_LOG_INFO = 2,
    SQ_LOG_WARN = 3,
    SQ_LOG_ERROR = 4,
    SQ_LOG_NONE = 5
} sq_log_level;

/* module: a short tag ("lbm", "scene"); msg: one line without trailing newline. */
typedef void (*sq_log_fn)(void *user, sq_log_level level, const char *module, const char *msg);

typedef struct sq_context_desc {
    int threads;               /* worker threads for kernels; 0 = OMP_NUM_THREADS when set,
                                * else all cores available to the process */
    sq_log_fn log;             /* NULL = silent */
    void *log_user;
    sq_log_level log_level;    /* messages below this level are dropped; 0 = INFO */
    uint64_t memory_limit_bytes; /* 0 = 80 % of physical memory; requests above are refused */
    uint64_t seed;             /* default seed for reproducible randomness; 0 is a valid seed */
    /* Polled by long stages (set-up loops over millions of particles, ...): returning true
     * stops them with SQ_ERR_CANCELLED. NULL = never. Must be safe to call from the thread that
     * uses the context (e.g. read a flag a signal handler sets). */
    bool (*interrupt)(void *user);
    void *interrupt_user;
} sq_context_desc;

typedef struct sq_context sq_context;

/* Creates a context from desc (NULL = all defaults): threads, logger, memory limit, seed.
 * Everything else in libsquall takes one; it must outlive every object made with it.
 * SQ_ERR_INVALID_ARG for a negative thread count. *out is NULL on failure. */
SQ_API sq_result sq_context_create(const sq_context_desc *desc, sq_context **out);
/* Destroys the context (NULL accepted). Objects made with it must be destroyed before. */
SQ_API void sq_context_destroy(sq_context *ctx);
/* Worker threads the kernels use (desc.threads, or for 0 OMP_NUM_THREADS or the cores). */
SQ_API int sq_context_threads(const sq_context *ctx);
/* The context's default seed (desc.seed). */
SQ_API uint64_t sq_context_seed(const sq_context *ctx);
/* The memory limit in bytes requests are checked against (desc.memory_limit_bytes, or 80 %
 * of physical memory for 0). */
SQ_API uint64_t sq_context_memory_limit(const sq_context *ctx);

/* 64-byte aligned allocation through the context. NULL on failure (error text set).
 * sq_alloc_zero clears the memory. sq_free accepts NULL. */
SQ_API void *sq_alloc(sq_context *ctx, size_t bytes);
SQ_API void *sq_alloc_zero(sq_context *ctx, size_t bytes);
SQ_API void sq_free(sq_context *ctx, void *p);
/* Bytes currently allocated through the context and the peak. */
SQ_API uint64_t sq_context_bytes_in_use(const sq_context *ctx);
SQ_API uint64_t sq_context_bytes_peak(const sq_context *ctx);

/* Cancellation: asks every long operation on ctx (scene building, stepping, sub-steps, terrain
 * generation, the reference renderer) to stop at its next check, within about a second, with
 * SQ_ERR_CANCELLED. Async-signal-safe: a SIGINT/SIGTERM handler may call it. The request stays
 * until sq_context_cancel_clear. */
SQ_API void sq_context_cancel(sq_context *ctx);
SQ_API bool sq_context_cancelled(const sq_context *ctx);
SQ_API void sq_context_cancel_clear(sq_context *ctx);

/* The input files read through ctx (scene file, heightmap, DEM, mesh, WRF file ...), recorded
 * by the io layer when it opens them, by identity (device and inode, symlinks followed): the
 * output layer refuses to write any of them (sq_output_check_inputs). */
SQ_API int sq_context_input_count(const sq_context *ctx);
SQ_API const char *sq_context_input_path(const sq_context *ctx, int i);
SQ_API const char *sq_context_input_what(const sq_context *ctx, int i);

/* ---- checkpoint records ---------------------------------------------------------------------
 * A scene's phenomena and their solvers save their complete state (what a step depends on) as a
 * sequence of tagged records and restore it by reading the same records in the same order; the
 * checkpoint file (squall/io.h, sq_checkpoint_*) wraps the stream with a header and checksum.
 * sq_state_get refuses a record whose tag or size differs from the one asked for, naming both. */
typedef struct sq_state_writer sq_state_writer;
typedef struct sq_state_reader sq_state_reader;
/* Appends a record: tag (a short name, copied) and bytes of data. SQ_ERR_INVALID_ARG for an
 * empty or too long tag; once a write of the stream failed, that error (SQ_ERR_IO,
 * SQ_ERR_NO_SPACE) is returned by every later put. */
SQ_API sq_result sq_state_put(sq_state_writer *w, const char *tag, const void *data, size_t bytes);
/* Reads the next record into data, which must have this tag and exactly this size:
 * SQ_ERR_INVALID_ARG naming both records otherwise (a checkpoint of another scene or build). */
SQ_API sq_result sq_state_get(sq_state_reader *r, const char *tag, void *data, size_t bytes);
/* The next record's tag and size without consuming it (for variable-size records). */
SQ_API sq_result sq_state_peek(sq_state_reader *r, const char **tag, uint64_t *bytes);

/* Refuses, before anything is allocated, a request whose total size exceeds the memory limit.
 * what: e.g. "lattice 512x512x512"; the message names it and the bytes needed. */
SQ_API sq_result sq_context_check_memory(sq_context *ctx, uint64_t bytes, const char *what);

/* SQ_ERR_CANCELLED ("interrupted during <what>", logged under module) if the context's
 * interrupt callback asks to stop, else SQ_OK. ctx may be NULL (never interrupted). */
SQ_API sq_result sq_context_poll_interrupt(sq_context *ctx, const char *module, const char *what);

/* Logs one line through the context's log callback if level passes its log_level (ctx may be
 * NULL: dropped). module is a short tag ("lbm", "scene"). */
SQ_API void sq_log(sq_context *ctx, sq_log_level level, const char *module, const char *fmt, ...)
    SQ_PRINTF(4, 5);

/* Compiled-in features: "openmp", "gl", "png", "mp4", "netcdf", "yaml". */
SQ_API bool sq_has_feature(const char *name);
/* Space-separated list of compiled-in features. */
SQ_API const char *sq_features(void);
SQ_API const char *sq_version(void);

/* Physical memory of the machine in bytes (0 if unknown). */
SQ_API uint64_t sq_physical_memory_bytes(void);

/* Monotonic wall clock in seconds. */
SQ_API double sq_time_now(void);

#ifdef __cplusplus
}
#endif
#endif
