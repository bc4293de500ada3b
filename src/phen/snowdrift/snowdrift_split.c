/* snowdrift_split.c — the snow model split in z slabs over the ranks of an MPI job (the wind
 * lattice's slabs: sq_par_decompose along z, at least 2 planes each). Each rank steps the
 * flakes of its own planes from its own wind; its arrays also hold the neighbouring slabs'
 * edge planes (the plane below its first and above its last), which the kernels read (cell
 * kinds, the deposit under a surface cell) and into which they write the flakes that cross a
 * slab face. Per step four hand-overs with the z neighbours (4 meetings):
 *   1. after transport: the flakes moved into a neighbour's edge plane (both directions);
 *   2. after landing: the flakes rolled or dropped into the plane below (downward), before
 *      the cells that filled up turn solid;
 *   3. after solidification: the kinds and deposits of the last plane (upward: the erosion
 *      above a slab face reads them);
 *   4. after erosion: the flakes eroded from the snow-solid cells of the plane below the
 *      slab (downward, as a decrement; an emptied cell turns fluid there too) and the kinds
 *      of the first plane (downward: the next transport reads them).
 * A cell is changed only by the slab that holds it or, when it is snow-solid, by the erosion of
 * the cell above it, so every hand-over is exact; the random streams are drawn per global cell
 * (sq__snow_kparams), so the flakes are the one-rank flakes bit for bit. */
#include <string.h>

#include "snowdrift_internal.h"
#include "squall/par.h"

struct sq__snow_slab {
    sq_context *ctx;
    sq__snow *s;      /* own planes plus the neighbours' edge planes */
    int lo, own, gnz; /* global first own plane, own planes, all planes */
    int below, above; /* 1: the local lattice holds the neighbour's edge plane there */
    int nb[2];        /* ranks below and above (-1: none) */
    uint64_t handed;  /* flakes handed to the neighbours since create */
    unsigned char *buf; /* 2 send + 2 receive planes of 5 bytes a cell */
    size_t plane;     /* cells of a plane */
};

sq_result sq__snow_slab_create(sq_context *ctx, sq_dims global, const sq__snow_params *params,
                               sq__snow_slab **out)
{
    *out = NULL;
    const int split[3] = {0, 0, 1};
    sq_par_block b;
    sq_result r = sq_par_decompose(global, split, NULL, 2, sq_par_size(), sq_par_rank(), &b);
    if (r != SQ_OK) return r;
    sq__snow_slab *sl = (sq__snow_slab *)sq_alloc_zero(ctx, sizeof *sl);
    if (!sl) return SQ_ERR_OUT_OF_MEMORY;
    sl->ctx = ctx;
    sl->lo = b.lo[2];
    sl->own = b.n.nz;
    sl->gnz = global.nz;
    sl->nb[0] = b.neighbour[4];
    sl->nb[1] = b.neighbour[5];
    sl->below = sl->nb[0] >= 0;
    sl->above = sl->nb[1] >= 0;
    sl->plane = (size_t)global.nx * (size_t)global.ny;
    const sq_dims local = {global.nx, global.ny, sl->own + sl->below + sl->above};
    r = sq__snow_create(ctx, local, params, &sl->s);
    sl->buf = r == SQ_OK ? (unsigned char *)sq_alloc(ctx, 4 * 5 * sl->plane) : NULL;
    if (r == SQ_OK && !sl->buf) r = SQ_ERR_OUT_OF_MEMORY;
    if (r != SQ_OK) {
        sq__snow_slab_destroy(sl);
        return r;
    }
    *out = sl;
    return SQ_OK;
}

void sq__snow_slab_destroy(sq__snow_slab *sl)
{
    if (!sl) return;
    sq_free(sl->ctx, sl->buf);
    sq__snow_destroy(sl->s);
    sq_free(sl->ctx, sl);
}

void sq__snow_slab_range(const sq__snow_slab *sl, int *lo, int *own, int *local0)
{
    *lo = sl->lo;
    *own = sl->own;
    *local0 = sl->below;
}

sq__snow *sq__snow_slab_snow(sq__snow_slab *sl) { return sl->s; }

uint64_t sq__snow_slab_handed(const sq__snow_slab *sl) { return sl->handed; }

/* One hand-over: send[s] (bytes[s]) to neighbour s (0 below, 1 above), recv[s] from it. */
static void hand(sq__snow_slab *sl, const size_t bytes[2], const size_t rbytes[2])
{
    const size_t p = 5 * sl->plane;
    const void *const sb[2] = {sl->buf, sl->buf + p};
    void *const rb[2] = {sl->buf + 2 * p, sl->buf + 3 * p};
    size_t by[2], rby[2];
    for (int s = 0; s < 2; s++) {
        by[s] = sl->nb[s] >= 0 ? bytes[s] : 0;
        rby[s] = sl->nb[s] >= 0 ? rbytes[s] : 0;
    }
    (void)sq_par_exchange_pair(sl->nb, sb, by, rb, rby); /* planes fit buf (create) */
}

static uint32_t *u32(unsigned char *b) { return (uint32_t *)(void *)b; }

sq_result sq__snow_slab_step(sq__snow_slab *sl, const float *ux, const float *uy, const float *uz,
                             const float *ustar)
{
    sq__snow *s = sl->s;
    const size_t P = sl->plane, pb = 5 * P;
    const int64_t sz = (int64_t)P;
    sq__snow_kparams kp;
    sq__snow_kparams_of(s, &kp);
    kp.k0 = sl->below;
    kp.k1 = sl->below + sl->own;
    kp.kz0 = sl->lo - sl->below;
    kp.gnz = sl->gnz;
    kp.wind0 = (int64_t)kp.k0 * (int64_t)P; /* the wind holds the own planes */
    const int top = s->nz - 1;            /* the plane above (when held) */
    const int64_t first = kp.k0 * sz, last = (int64_t)(kp.k1 - 1) * sz;
    unsigned char *sb[2] = {sl->buf, sl->buf + pb}, *rb[2] = {sl->buf + 2 * pb, sl->buf + 3 * pb};

    /* 1. snowfall (the slab holding the top), transport; the flakes that crossed go over */
    s->fallen += sq__snow_inject(&kp, sq__snow_flakes_per_top_cell(&s->p), s->kind, s->air);
    memset(s->air_next, 0, (size_t)s->n * sizeof(uint32_t));
    memset(s->changed, 0, (size_t)s->n);
    sq__snow_transport(&kp, ux, uy, uz, s->kind, s->air, s->air_next, s->land, &s->left);
    const size_t one[2] = {P * 4, P * 4};
    for (int q = 0; q < 2; q++)
        if (q ? sl->above : sl->below) {
            uint32_t *g = s->air_next + (q ? (int64_t)top * sz : 0);
            memcpy(sb[q], g, P * 4);
            for (size_t c = 0; c < P; c++) sl->handed += g[c];
            memset(g, 0, P * 4);
        }
    hand(sl, one, one);
    for (int q = 0; q < 2; q++)
        if (q ? sl->above : sl->below) {
            uint32_t *d = s->air_next + (q ? last : first);
            const uint32_t *in = u32(rb[q]);
            for (size_t c = 0; c < P; c++) d[c] += in[c];
        }

    /* 2. landing; the flakes rolled or dropped into the plane below go down, then the cells
     * that filled up turn solid */
    sq__snow_settle_land(&kp, s->kind, s->land, s->dep, s->air_next);
    if (sl->below) {
        memcpy(sb[0], s->air_next, P * 4);
        for (size_t c = 0; c < P; c++) sl->handed += s->air_next[c];
        memset(s->air_next, 0, P * 4);
    }
    const size_t down[2] = {P * 4, 0}, from_above[2] = {0, P * 4};
    hand(sl, down, from_above);
    if (sl->above) {
        const uint32_t *in = u32(rb[1]);
        for (size_t c = 0; c < P; c++) s->air_next[last + (int64_t)c] += in[c];
    }
    sq__snow_settle_solidify(&kp, s->p.threshold, s->kind, s->dep, s->air_next, s->changed);

    /* 3. the last plane's kinds and deposits to the slab above (its erosion reads them) */
    if (sl->above) {
        memcpy(sb[1], s->dep + last, P * 4);
        memcpy(sb[1] + P * 4, s->kind + last, P);
    }
    const size_t up[2] = {0, pb}, from_below[2] = {pb, 0};
    hand(sl, up, from_below);
    if (sl->below) {
        memcpy(s->dep, rb[0], P * 4);
        memcpy(s->kind, rb[0] + P * 4, P);
    }

    /* 4. erosion; what it took from the snow-solid cells below the slab goes down, with the
     * first plane's kinds */
    if (sl->below) memcpy(u32(sb[0]), s->dep, P * 4); /* the deposits before */
    s->eroded += sq__snow_erode(&kp, &s->p, ustar, s->kind, s->dep, s->air_next, s->changed);
    if (sl->below) {
        uint32_t *dec = u32(sb[0]);
        for (size_t c = 0; c < P; c++) dec[c] -= s->dep[c];
        memcpy(sb[0] + P * 4, s->kind + first, P);
    }
    const size_t down5[2] = {pb, 0}, from_above5[2] = {0, pb};
    hand(sl, down5, from_above5);
    if (sl->above) {
        const uint32_t *dec = u32(rb[1]);
        for (size_t c = 0; c < P; c++) {
            const int64_t b = last + (int64_t)c;
            if (dec[c] == 0) continue;
            s->dep[b] -= dec[c];
            if (s->dep[b] == 0) { /* the last flake eroded: back to air */
                s->changed[b] = 2;
                s->kind[b] = SQ_SNOW_AIR;
            }
        }
        memcpy(s->kind + (int64_t)top * sz, rb[1] + P * 4, P);
    }
    uint32_t *t = s->air;
    s->air = s->air_next;
    s->air_next = t;
    s->step++;
    return SQ_OK;
}

void sq__snow_slab_budget(const sq__snow_slab *sl, sq__snow_budget *out)
{
    const sq__snow *s = sl->s;
    memset(out, 0, sizeof *out);
    const int64_t c0 = (int64_t)sl->below * (int64_t)sl->plane;
    const int64_t c1 = c0 + (int64_t)sl->own * (int64_t)sl->plane;
    int64_t v[6] = {(int64_t)s->fallen, 0, 0, (int64_t)s->left, (int64_t)s->eroded, 0};
    for (int64_t c = c0; c < c1; c++) {
        v[1] += s->air[c];
        v[2] += s->dep[c];
        v[5] += s->kind[c] == SQ_SNOW_SOLID;
    }
    sq_par_sum_i64(v, 6);
    out->fallen = (uint64_t)v[0];
    out->airborne = (uint64_t)v[1];
    out->deposited = (uint64_t)v[2];
    out->left = (uint64_t)v[3];
    out->eroded = (uint64_t)v[4];
    out->solid_cells = v[5];
}
