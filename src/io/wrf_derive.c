/* wrf_derive.c — physical fields on the WRF mass grid from the raw history variables (formulas of
 * include/squall/wrf.h and docs/wrf.md; checked against wrf-python's own output in
 * ../shared/reference/wrf_format.md). Pure kernels over arrays: computed in double, stored as
 * float (WRF writes float). */
#include <math.h>

#include "io/wrf_internal.h"

/* Poisson exponent R_d / c_p. */
#define KAPPA (SQ__WRF_RD / SQ__WRF_CP)
/* Below this many values a loop runs on one thread: waking a team costs more than the work (and
 * on an oversubscribed machine a late thread stalls the barrier: 40 ms instead of 0.3 ms measured
 * for the 2 160-point sample). */
#define PARALLEL_MIN 65536

/* Heights of the w-levels (cell faces): zstag = (PH + PHB) / g. */
static void derive_zw(size_t ns, const float *ph, const float *phb, float *zw, int nt)
{
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(ns >= PARALLEL_MIN))
    for (size_t c = 0; c < ns; c++) zw[c] = (float)(((double)ph[c] + (double)phb[c]) / SQ__WRF_G);
}

/* One level k of the thermodynamic fields and condensate concentrations. */
static void derive_level(int nx, int ny, int k, const sq__wrf_raw *r, sq__wrf_fields *o)
{
    const size_t plane = (size_t)nx * (size_t)ny;
    const size_t base = (size_t)k * plane;
    for (size_t c = 0; c < plane; c++) {
        const size_t n = base + c;
        /* geopotential height: mean of the faces below and above (wrf-python "z") */
        const double zb = ((double)r->ph[n] + (double)r->phb[n]) / SQ__WRF_G;
        const double zt = ((double)r->ph[n + plane] + (double)r->phb[n + plane]) / SQ__WRF_G;
        const double z = 0.5 * (zb + zt);
        o->z[n] = (float)z;
        o->agl[n] = (float)(z - (double)r->hgt[c]);
        /* pressure, potential temperature, temperature */
        const double p = (double)r->p[n] + (double)r->pb[n];
        const double theta = (double)r->t[n] + SQ__WRF_T0;
        const double tk = theta * pow(p / SQ__WRF_P0, KAPPA);
        o->p[n] = (float)p;
        o->theta[n] = (float)theta;
        o->t[n] = (float)tk;
        /* moist air density with the virtual temperature T (1 + 0.608 qv) */
        const double qv = (double)r->qv[n];
        const double rho = p / (SQ__WRF_RD * tk * (1.0 + 0.608 * qv));
        o->rho[n] = (float)rho;
        o->qv[n] = (float)qv;
        /* volume per kg of dry air (UPP CALVIS): air plus liquid plus ice */
        double q[SQ_WRF_SPECIES_COUNT];
        for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++) q[s] = r->q[s] ? (double)r->q[s][n] : 0.0;
        const double vol = (1.0 + qv) / rho + (q[SQ_WRF_CLOUD] + q[SQ_WRF_RAIN]) / SQ__WRF_RHO_WATER +
                           (q[SQ_WRF_ICE] + q[SQ_WRF_SNOW] + q[SQ_WRF_GRAUPEL]) / SQ__WRF_RHO_ICE;
        for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++)
            if (o->q[s]) o->q[s][n] = (float)(1000.0 * q[s] / vol);
        if (o->ni) o->ni[n] = (float)((double)r->qni[n] / vol);
        if (o->nr) o->nr[n] = (float)((double)r->qnr[n] / vol);
        /* staggered winds to the mass point */
        const int i = (int)(c % (size_t)nx), j = (int)(c / (size_t)nx);
        const size_t iu = ((size_t)k * (size_t)ny + (size_t)j) * (size_t)(nx + 1) + (size_t)i;
        const size_t iv = ((size_t)k * (size_t)(ny + 1) + (size_t)j) * (size_t)nx + (size_t)i;
        o->u[n] = (float)(0.5 * ((double)r->u[iu] + (double)r->u[iu + 1]));
        o->v[n] = (float)(0.5 * ((double)r->v[iv] + (double)r->v[iv + (size_t)nx]));
        o->w[n] = (float)(0.5 * ((double)r->w[n] + (double)r->w[n + plane]));
    }
}

void sq__wrf_derive(int nx, int ny, int nz, const sq__wrf_raw *raw, sq__wrf_fields *out, int nt)
{
    const size_t plane = (size_t)nx * (size_t)ny;
    derive_zw(plane * (size_t)(nz + 1), raw->ph, raw->phb, out->zw, nt);
    for (size_t c = 0; c < plane; c++) out->hgt[c] = raw->hgt[c];
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(plane * (size_t)nz >= PARALLEL_MIN))
    for (int k = 0; k < nz; k++) derive_level(nx, ny, k, raw, out);
    /* cloud fraction as read; a flag when it holds nothing between 0 and 1 */
    out->cldfra_flag = false;
    if (raw->cldfra && out->cldfra) {
        const size_t n = plane * (size_t)nz;
        bool flag = true;
        for (size_t c = 0; c < n; c++) {
            const float v = raw->cldfra[c];
            out->cldfra[c] = v;
            flag = flag && (v == 0.0f || v == 1.0f);
        }
        out->cldfra_flag = flag;
    }
}

static void lerp_array(size_t n, const float *a, const float *b, double w, float *o, int nt)
{
    if (!a || !b || !o) return;
    const float wa = (float)(1.0 - w), wb = (float)w;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(n >= PARALLEL_MIN))
    for (size_t c = 0; c < n; c++) o[c] = wa * a[c] + wb * b[c];
}

void sq__wrf_lerp(int nx, int ny, int nz, const sq__wrf_fields *f0, const sq__wrf_fields *f1,
                  double a, sq__wrf_fields *o, int nt)
{
    const size_t plane = (size_t)nx * (size_t)ny, n = plane * (size_t)nz;
    lerp_array(n, f0->z, f1->z, a, o->z, nt);
    lerp_array(n, f0->agl, f1->agl, a, o->agl, nt);
    lerp_array(n, f0->p, f1->p, a, o->p, nt);
    lerp_array(n, f0->theta, f1->theta, a, o->theta, nt);
    lerp_array(n, f0->t, f1->t, a, o->t, nt);
    lerp_array(n, f0->rho, f1->rho, a, o->rho, nt);
    lerp_array(n, f0->qv, f1->qv, a, o->qv, nt);
    lerp_array(n, f0->u, f1->u, a, o->u, nt);
    lerp_array(n, f0->v, f1->v, a, o->v, nt);
    lerp_array(n, f0->w, f1->w, a, o->w, nt);
    for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++) lerp_array(n, f0->q[s], f1->q[s], a, o->q[s], nt);
    lerp_array(n, f0->ni, f1->ni, a, o->ni, nt);
    lerp_array(n, f0->nr, f1->nr, a, o->nr, nt);
    lerp_array(n, f0->cldfra, f1->cldfra, a, o->cldfra, nt);
    o->cldfra_flag = f0->cldfra_flag && f1->cldfra_flag;
    lerp_array(plane * (size_t)(nz + 1), f0->zw, f1->zw, a, o->zw, nt);
    lerp_array(plane, f0->hgt, f1->hgt, a, o->hgt, nt);
    o->index = -1;
}
