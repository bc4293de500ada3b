/* wrf_internal.h — the WRF reader's pieces (include/squall/wrf.h): the open series
 * (wrf_open.c), the map projection through PROJ (wrf_proj.c), reading one stored time with its
 * value checks (wrf_read.c) and the pure derivation kernels (wrf_derive.c). */
#ifndef SQ_WRF_INTERNAL_H
#define SQ_WRF_INTERNAL_H

#include <stdbool.h>
#include <stdint.h>

#include "core/core_internal.h"
#include "squall/wrf.h"

/* WRF constants (share/module_model_constants.F; wrf-python uses the same values). */
#define SQ__WRF_G 9.81
#define SQ__WRF_RD 287.0
#define SQ__WRF_CP 1004.5
#define SQ__WRF_T0 300.0
#define SQ__WRF_P0 100000.0
#define SQ__WRF_EARTH_RADIUS_M 6370000.0
#define SQ__WRF_RHO_WATER 1000.0 /* condensate volume: liquid */
#define SQ__WRF_RHO_ICE 917.0    /* condensate volume: ice, snow, graupel (as CALVIS) */
/* Mixing ratios from here up to 0 are clamped; below it they are an error. */
#define SQ__WRF_NEGATIVE_Q_LIMIT (-1.0e-4)

/* The variables the reader uses. */
typedef enum wrf_var {
    WV_PH, WV_PHB, WV_P, WV_PB, WV_T, WV_QVAPOR, WV_U, WV_V, WV_W, WV_HGT,
    WV_QCLOUD, WV_QICE, WV_QSNOW, WV_QRAIN, WV_QGRAUP, WV_QNICE, WV_QNRAIN, WV_CLDFRA,
    WV_COUNT
} wrf_var;

/* One stored time as read from the file (sizes n = nx*ny*nz, ns = nx*ny*(nz+1)). Mixing ratios
 * are clamped >= 0 on reading. Absent species are NULL. */
typedef struct sq__wrf_raw {
    float *ph, *phb;            /* ns: geopotential perturbation and base, m2 s-2 */
    float *p, *pb, *t, *qv;     /* n: Pa, Pa, K (theta - 300), kg/kg */
    float *q[SQ_WRF_SPECIES_COUNT]; /* n: kg/kg */
    float *qni, *qnr;           /* n: number mixing ratios, kg-1 */
    float *cldfra;              /* n: cloud fraction, clamped to [0, 1] */
    float *u;                   /* nx+1 per row: (k*ny + j)*(nx+1) + i */
    float *v;                   /* ny+1 rows: (k*(ny+1) + j)*nx + i */
    float *w;                   /* ns */
    float *hgt;                 /* nx*ny */
} sq__wrf_raw;

/* Derived fields of one time (see sq_wrf_state for meaning and units). */
typedef struct sq__wrf_fields {
    int index;                  /* stored time index held; -1 = none */
    float *z, *agl, *p, *theta, *t, *rho, *qv, *u, *v, *w;
    float *q[SQ_WRF_SPECIES_COUNT];
    float *ni, *nr;
    float *cldfra;              /* n: cloud fraction (or NULL) */
    bool cldfra_flag;           /* every value 0 or 1: a cloud flag, not a fraction */
    float *zw;                  /* ns */
    float *hgt;                 /* nx*ny */
    void *block;                /* the one allocation behind the pointers */
} sq__wrf_fields;

/* Derives every field of out from raw (pure; nt OpenMP threads; nothing allocated). */
void sq__wrf_derive(int nx, int ny, int nz, const sq__wrf_raw *raw, sq__wrf_fields *out, int nt);
/* out = (1 - a) f0 + a f1 for every field present. */
void sq__wrf_lerp(int nx, int ny, int nz, const sq__wrf_fields *f0, const sq__wrf_fields *f1,
                  double a, sq__wrf_fields *out, int nt);

typedef struct wrf_file {
    char *path;
    int ncid;
    int time_count;
    int varid[WV_COUNT];        /* -1 when absent */
    bool var_time[WV_COUNT];    /* the variable has a leading Time dimension */
    int varid_times, varid_xlat, varid_xlong;
    bool latlon_has_time;
} wrf_file;

typedef struct wrf_entry {
    int file, local;            /* file and its time index */
    double unix_s;
    char text[SQ_WRF_TIME_STRLEN];
} wrf_entry;

struct sq_wrf {
    sq_context *ctx;
    sq_wrf_info info;
    wrf_file *files;
    int file_count;
    wrf_entry *entries;         /* info.time_count, sorted by time */
    double *times_s;
    const char **time_ptrs;
    char title[128];
    char proj_string[512];
    char *crs_wkt;              /* sq_alloc'd copy */
    /* projection (wrf_proj.c) */
    void *pj_ctx;               /* PJ_CONTEXT */
    void *pj_fwd;               /* PJ: lon, lat (deg) -> projected x, y (m) */
    /* grid geometry, owned */
    float *lat, *lon;           /* nx*ny */
    float *xw, *yw;             /* nx, ny: world coordinates */
    float *hgt0;                /* nx*ny: HGT of the first stored time (the world's terrain) */
    /* reading */
    sq__wrf_raw raw;
    void *raw_block;
    sq__wrf_fields slot[2];     /* derived fields of two stored times */
    sq__wrf_fields out;         /* interpolated */
    int64_t clamped;            /* negative mixing ratios clamped so far */
};

/* wrf_proj.c: builds the PROJ string and CRS from info's projection parameters, projects the
 * file's XLAT/XLONG (w->lat, w->lon), fits the regular grid (crs_offset_m, xw, yw), checks the
 * fit and fills centre and north rotation. path names the file in messages. */
sq_result sq__wrf_proj_setup(sq_wrf *w, const char *path);
void sq__wrf_proj_free(sq_wrf *w);

/* wrf_read.c: reads stored time `index` into w->raw (checked) and derives it into dst. */
sq_result sq__wrf_load(sq_wrf *w, int index, sq__wrf_fields *dst);
sq_result sq__wrf_alloc_buffers(sq_wrf *w);
/* Reads HGT of the first stored time into w->hgt0 (the world's terrain). */
sq_result sq__wrf_read_hgt0(sq_wrf *w);
void sq__wrf_free_buffers(sq_wrf *w);

/* Reads a float variable's hyperslab [start, start+count) of ndims dims into dst and checks every
 * value (finite, not the fill value); errors name the file, the variable and the place. */
sq_result sq__wrf_get_floats(sq_wrf *w, const wrf_file *f, int varid, const char *name,
                             const size_t *start, const size_t *count, int ndims, float *dst);

#endif
