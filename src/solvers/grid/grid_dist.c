/* grid_dist.c — the MAC grid split over the ranks of a distributed run (squall/par.h,
 * sq_grid_desc.decompose) in slabs along the longer horizontal axis (x when nx >= ny), one per
 * rank, each at least 4 cells thick (the multigrid's smallest axis).
 *
 * Each rank's sq_grid is its slab: a grid of the slab's cells whose origin is the slab's
 * corner. A face toward a neighbouring slab (an inner face) is described to the serial code as
 * an OPEN face (velocities on it are kept, never clipped or zeroed), and this file makes it
 * behave as the inside of the lattice:
 *   - the cell flags' ghost plane holds the neighbour's flags (solid or fluid), so the Poisson
 *     links across the face are the one-rank links (coefficient 1 between fluid cells) and the
 *     face velocity next to a solid neighbour is zero on both sides;
 *   - the ghost planes of the pressure and of the level-0 work vectors are the neighbour's edge
 *     planes, refreshed after every red-black half-sweep, prolongation and vector update
 *     (sq__grid_halo_cells), so the operator, the residual and the fine smoother are the
 *     one-rank ones (the colours follow the global cell index);
 *   - dot products and norms are summed over the ranks (sq__grid_dist_sum).
 * The coarse multigrid levels are the slab's own (its coarse ghosts are zero: a block-Jacobi
 * coarse correction), so the preconditioner, and the CG iteration count, depend on the rank
 * count; the projection is converged to the same relative residual, and its answer agrees with
 * one rank's to that tolerance. The face velocity on an inner face is held by both slabs and
 * updated identically by both (same pressures, same flags).
 * Closed fluid regions are pinned only where they lie inside one slab; a region that reaches
 * an inner face is treated as open (a global domain without outflow/open faces is solved
 * unpinned; CG converges on the compatible singular system, the pressure's constant differs). */
#include <float.h>
#include <string.h>

#include "solvers/grid/grid_internal.h"
#include "squall/par.h"

#define MOD "grid"

/* Ghost fills of several arrays that travel in one message per neighbour (see
 * sq__grid_dist_batch_begin); more arrays than this flush early. */
#define HALO_BATCH 8
/* The widened copy holds up to this many scalars, widened in one exchange. */
#define WIDE_SCALARS 8

struct sq__grid_halo {
    sq_par_block b;
    int parity;       /* (lo x + lo y + lo z) & 1: global red-black colour of local cell 0 */
    bool inner[6];    /* face toward a neighbouring slab */
    int nb[6];        /* its rank (-1: no inner face) */
    sq_boundary boundary[6]; /* the whole grid's faces (swapped in for the coarse levels) */
    bool periodic[3];
    unsigned char *buf; /* 2 send + 2 receive regions of HALO_BATCH planes of the largest face,
                           4 bytes a cell */
    size_t plane_bytes;
    /* the ghost fills recorded since the open batch began (sq__grid_dist_batch_begin), and
     * whether the shared faces are to be synced with them */
    int batch_depth, npend;
    bool pend_faces;
    struct {
        float *o;
        ptrdiff_t sy, sz;
        int L;
    } pend[HALO_BATCH];
    uint64_t bytes_exchanged;
    /* advection: the slab widened along the split axis (see sq__grid_dist_widen) */
    int ax;              /* the split axis */
    bool gperiodic[3];   /* the whole grid's periodic axes */
    sq_grid *wide;       /* the widened copy, NULL until the first advection */
    int width, cap;      /* planes taken from each neighbour now; allocated for cap */
    int wscalars;        /* the copy's scalar arrays (the grid's scalars, 3 to WIDE_SCALARS) */
    unsigned char *xbuf; /* 2 send + 2 receive buffers of xside bytes */
    size_t xside;
};

sq_result sq__grid_dist_setup(sq_context *ctx, sq_grid_desc *d, sq__grid_halo **out)
{
    *out = NULL;
    const int size = sq_par_size(), rank = sq_par_rank();
    if (!d->decompose || size <= 1) return SQ_OK;
    const int ax = d->cells.nx >= d->cells.ny ? 0 : 1;
    int split[3] = {0, 0, 0}, per[3];
    split[ax] = 1;
    for (int a = 0; a < 3; a++) per[a] = d->boundary[2 * a] == SQ_BOUNDARY_PERIODIC;
    sq_par_block b;
    const int ncell[3] = {d->cells.nx, d->cells.ny, d->cells.nz};
    sq_result r = sq_par_decompose(d->cells, split, per, 4, size, rank, &b);
    if (r != SQ_OK)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "cells = %dx%dx%d: the grid cannot be split over %d ranks (slabs along %c "
                        "of at least 4 cells: at most %d ranks); run with fewer ranks (mpirun -np)",
                        d->cells.nx, d->cells.ny, d->cells.nz, size, "xy"[ax], ncell[ax] / 4);
    sq__grid_halo *h = (sq__grid_halo *)sq_alloc_zero(ctx, sizeof *h);
    if (!h) return SQ_ERR_OUT_OF_MEMORY;
    h->b = b;
    for (int f = 0; f < 6; f++) h->boundary[f] = d->boundary[f];
    for (int a = 0; a < 3; a++) h->periodic[a] = per[a] != 0;
    h->parity = (b.lo[0] + b.lo[1] + b.lo[2]) & 1;
    h->ax = ax;
    for (int a = 0; a < 3; a++) h->gperiodic[a] = per[a] != 0;
    const int n[3] = {b.n.nx, b.n.ny, b.n.nz};
    size_t plane = 0;
    for (int a = 0; a < 3; a++) {
        const int ta = a == 0 ? 1 : 0, tb = a == 2 ? 1 : 2;
        for (int s = 0; s < 2; s++) {
            const int f = 2 * a + s;
            h->inner[f] = b.grid[a] > 1 && b.neighbour[f] >= 0;
            h->nb[f] = h->inner[f] ? b.neighbour[f] : -1;
            if (h->inner[f]) {
                d->boundary[f] = SQ_BOUNDARY_OPEN;
                /* the largest plane of any lattice, ghosts included */
                const size_t p = (size_t)(n[ta] + 3) * (size_t)(n[tb] + 3);
                if (p > plane) plane = p;
            }
        }
        /* a split periodic axis: both ends are inner faces */
        if (b.grid[a] > 1 && d->boundary[2 * a] == SQ_BOUNDARY_PERIODIC)
            d->boundary[2 * a] = d->boundary[2 * a + 1] = SQ_BOUNDARY_OPEN;
    }
    for (int a = 0; a < 3; a++) d->origin_m[a] += (double)b.lo[a] * d->cell_size_m;
    d->cells = b.n;
    h->plane_bytes = plane * sizeof(float);
    h->buf = (unsigned char *)sq_alloc(ctx, 4 * (HALO_BATCH + 1) * h->plane_bytes);
    if (!h->buf) {
        sq_free(ctx, h);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    sq_log(ctx, SQ_LOG_DEBUG, MOD, "rank %d of %d: cells %d..%d of %d along %c", rank, size,
           b.lo[ax], b.lo[ax] + n[ax] - 1, ncell[ax], "xy"[ax]);
    *out = h;
    return SQ_OK;
}

static void wide_free(sq_context *ctx, sq_grid *w, int ns);

void sq__grid_dist_free(sq_context *ctx, sq__grid_halo *h)
{
    if (!h) return;
    wide_free(ctx, h->wide, h->wscalars);
    sq_free(ctx, h->xbuf);
    sq_free(ctx, h->buf);
    sq_free(ctx, h);
}

int sq__grid_dist_parity(const sq_grid *g) { return g->halo ? g->halo->parity : 0; }

bool sq__grid_dist_inner(const sq_grid *g, int face) { return g->halo && g->halo->inner[face]; }

/* Packs (unpack = false) plane `at` along axis a of a padded cell-lattice array into buf, or
 * unpacks buf into it; the plane's tangential range includes the ghosts. */
static void plane_copy(const sq_grid *g, unsigned char *o, size_t elem, int a, int at,
                       unsigned char *buf, bool unpack)
{
    const ptrdiff_t st[3] = {1, g->sy, g->sz};
    const int ta = a == 0 ? 1 : 0, tb = a == 2 ? 1 : 2;
    size_t t = 0;
    for (int q = -1; q <= g->n[tb]; q++)
        for (int p = -1; p <= g->n[ta]; p++, t += elem) {
            const ptrdiff_t c = (ptrdiff_t)at * st[a] + (ptrdiff_t)p * st[ta] + (ptrdiff_t)q * st[tb];
            unsigned char *x = o + c * (ptrdiff_t)elem;
            if (unpack)
                memcpy(x, buf + t, elem);
            else
                memcpy(buf + t, x, elem);
        }
}

void sq__grid_halo_cells(sq_grid *g, void *base, size_t elem)
{
    sq__grid_halo *h = g->halo;
    if (!h) return;
    unsigned char *o = (unsigned char *)base + sq__cidx(g, 0, 0, 0) * (ptrdiff_t)elem;
    for (int a = 0; a < 3; a++) {
        if (!h->inner[2 * a] && !h->inner[2 * a + 1]) continue;
        const int ta = a == 0 ? 1 : 0, tb = a == 2 ? 1 : 2;
        const size_t bytes = (size_t)(g->n[ta] + 2) * (size_t)(g->n[tb] + 2) * elem;
        unsigned char *sb[2] = {h->buf, h->buf + h->plane_bytes};
        unsigned char *rb[2] = {h->buf + 2 * h->plane_bytes, h->buf + 3 * h->plane_bytes};
        const int nb[2] = {h->nb[2 * a], h->nb[2 * a + 1]};
        for (int s = 0; s < 2; s++)
            if (nb[s] >= 0) plane_copy(g, o, elem, a, s ? g->n[a] - 1 : 0, sb[s], false);
        const void *const sbuf[2] = {sb[0], sb[1]};
        void *const rbuf[2] = {rb[0], rb[1]};
        const size_t by[2] = {nb[0] >= 0 ? bytes : 0, nb[1] >= 0 ? bytes : 0};
        (void)sq_par_exchange_pair(nb, sbuf, by, rbuf, by); /* sizes checked at setup */
        h->bytes_exchanged += by[0] + by[1];
        for (int s = 0; s < 2; s++)
            if (nb[s] >= 0) plane_copy(g, o, elem, a, s ? g->n[a] : -1, rb[s], true);
    }
}

static size_t planes_copy(unsigned char *o, ptrdiff_t sy, ptrdiff_t sz, size_t elem, const int m[3],
                          int a, int p0, int cnt, unsigned char *buf, bool unpack);
static void lat_layout(const int n[3], int L, int m[3], ptrdiff_t *sy, ptrdiff_t *sz);

/* Exchanges the ghost planes along the split axis of the recorded arrays, all in one message
 * per neighbour (the arrays' planes one after another, in the order they were recorded). */
static void halo_flush(sq_grid *g)
{
    sq__grid_halo *h = g->halo;
    const int a = h->ax, np = h->npend;
    const bool faces = h->pend_faces;
    h->npend = 0;
    h->pend_faces = false;
    if (np == 0 && !faces) return;
    const int nb[2] = {h->nb[2 * a], h->nb[2 * a + 1]};
    const size_t region = (HALO_BATCH + 1) * h->plane_bytes;
    unsigned char *sb[2] = {h->buf, h->buf + region};
    unsigned char *rb[2] = {h->buf + 2 * region, h->buf + 3 * region};
    size_t by[2] = {0, 0};
    for (int e = 0; e < np; e++) {
        int m[3];
        ptrdiff_t y, z;
        lat_layout(g->n, h->pend[e].L, m, &y, &z);
        const bool face = h->pend[e].L - 1 == a;
        unsigned char *ob = (unsigned char *)h->pend[e].o;
        /* to the minus side: my first sample past the shared face (face lattice) or cell 0;
         * to the plus side: my last cell, or the face before the shared one */
        if (nb[0] >= 0)
            by[0] += planes_copy(ob, h->pend[e].sy, h->pend[e].sz, 4, m, a, face ? 1 : 0, 1,
                                 sb[0] + by[0], false);
        if (nb[1] >= 0)
            by[1] += planes_copy(ob, h->pend[e].sy, h->pend[e].sz, 4, m, a, face ? m[a] - 2 : m[a] - 1,
                                 1, sb[1] + by[1], false);
    }
    /* the shared faces: face 0 of the velocity normal to the split travels to the minus
     * neighbour, whose face n it replaces (with its tangential ghosts: it is applied after
     * the local ghost fills) */
    size_t rby[2] = {by[0], by[1]};
    sq_field3 *fv = &g->vel[a];
    int mf[3];
    ptrdiff_t fy, fz;
    lat_layout(g->n, a + 1, mf, &fy, &fz);
    if (faces && nb[0] >= 0)
        by[0] += planes_copy((unsigned char *)fv->origin, fv->sy, fv->sz, 4, mf, a, 0, 1, sb[0] + by[0], false);
    if (faces && nb[1] >= 0) rby[1] += (size_t)(mf[(a + 1) % 3] + 2) * (size_t)(mf[(a + 2) % 3] + 2) * 4;
    const void *const sbuf[2] = {sb[0], sb[1]};
    void *const rbuf[2] = {rb[0], rb[1]};
    (void)sq_par_exchange_pair(nb, sbuf, by, rbuf, rby); /* planes fit buf (setup) */
    h->bytes_exchanged += by[0] + by[1];
    size_t off[2] = {0, 0};
    for (int e = 0; e < np; e++) {
        int m[3];
        ptrdiff_t y, z;
        lat_layout(g->n, h->pend[e].L, m, &y, &z);
        unsigned char *ob = (unsigned char *)h->pend[e].o;
        if (nb[0] >= 0)
            off[0] += planes_copy(ob, h->pend[e].sy, h->pend[e].sz, 4, m, a, -1, 1, rb[0] + off[0], true);
        if (nb[1] >= 0)
            off[1] += planes_copy(ob, h->pend[e].sy, h->pend[e].sz, 4, m, a, m[a], 1, rb[1] + off[1], true);
    }
    if (faces && nb[1] >= 0)
        planes_copy((unsigned char *)fv->origin, fv->sy, fv->sz, 4, mf, a, mf[a] - 1, 1, rb[1] + off[1], true);
}

void sq__grid_dist_halo_lattice(sq_grid *g, float *o, ptrdiff_t sy, ptrdiff_t sz, int L)
{
    sq__grid_halo *h = g->halo;
    if (!h) return;
    if (h->npend == HALO_BATCH) halo_flush(g);
    h->pend[h->npend].o = o;
    h->pend[h->npend].sy = sy;
    h->pend[h->npend].sz = sz;
    h->pend[h->npend].L = L;
    h->npend++;
    if (h->batch_depth == 0) halo_flush(g);
}

void sq__grid_dist_batch_begin(sq_grid *g)
{
    if (g->halo) g->halo->batch_depth++;
}

void sq__grid_dist_batch_end(sq_grid *g)
{
    sq__grid_halo *h = g->halo;
    if (!h) return;
    if (h->batch_depth > 0) h->batch_depth--;
    if (h->batch_depth == 0) halo_flush(g);
}

void sq__grid_dist_face_links(sq_grid *g, float *o, ptrdiff_t sy, ptrdiff_t sz, int L)
{
    sq__grid_halo *h = g->halo;
    if (!h) return;
    const int a = h->ax;
    int m[3];
    ptrdiff_t y, z;
    lat_layout(g->n, L, m, &y, &z);
    const int n = g->n[a]; /* faces 0 .. n, links 0 .. n-1 inside */
    const int nb[2] = {h->nb[2 * a], h->nb[2 * a + 1]};
    unsigned char *sb[2] = {h->buf, h->buf + h->plane_bytes};
    unsigned char *rb[2] = {h->buf + 2 * h->plane_bytes, h->buf + 3 * h->plane_bytes};
    unsigned char *ob = (unsigned char *)o;
    size_t by[2] = {0, 0};
    if (nb[0] >= 0) by[0] = planes_copy(ob, sy, sz, 4, m, a, 0, 1, sb[0], false);
    if (nb[1] >= 0) by[1] = planes_copy(ob, sy, sz, 4, m, a, n - 1, 1, sb[1], false);
    const void *const sbuf[2] = {sb[0], sb[1]};
    void *const rbuf[2] = {rb[0], rb[1]};
    (void)sq_par_exchange_pair(nb, sbuf, by, rbuf, by);
    h->bytes_exchanged += by[0] + by[1];
    if (nb[0] >= 0) planes_copy(ob, sy, sz, 4, m, a, -1, 1, rb[0], true);
    if (nb[1] >= 0) planes_copy(ob, sy, sz, 4, m, a, n, 1, rb[1], true);
}

void sq__grid_dist_frame(const sq_grid *g, int n0[3], int lo[3])
{
    const sq__grid_halo *h = g->halo;
    n0[0] = h ? h->b.global.nx : g->n[0];
    n0[1] = h ? h->b.global.ny : g->n[1];
    n0[2] = h ? h->b.global.nz : g->n[2];
    for (int a = 0; a < 3; a++) lo[a] = h ? h->b.lo[a] : 0;
}

void sq__grid_dist_global_bc(sq_grid *g)
{
    sq__grid_halo *h = g->halo;
    if (!h) return;
    for (int f = 0; f < 6; f++) {
        const sq_boundary t = g->d.boundary[f];
        g->d.boundary[f] = h->boundary[f];
        h->boundary[f] = t;
    }
    for (int a = 0; a < 3; a++) {
        const bool t = g->periodic[a];
        g->periodic[a] = h->periodic[a];
        h->periodic[a] = t;
    }
}

void sq__grid_dist_sum_f32(sq_grid *g, float *v, size_t n)
{
    if (!g->halo) return;
    /* an allreduce moves about twice the data per rank (reduce-scatter + allgather) */
    for (size_t o = 0; o < n; o += 1u << 28) {
        const size_t m = n - o < (1u << 28) ? n - o : (1u << 28);
        sq_par_sum_f32(v + o, (int)m);
    }
    g->halo->bytes_exchanged += 2 * n * sizeof(float);
}

void sq__grid_dist_sync_faces(sq_grid *g)
{
    sq__grid_halo *h = g->halo;
    if (!h) return;
    if (h->batch_depth > 0) { /* with the batch's ghost planes */
        h->pend_faces = true;
        return;
    }
    for (int a = 0; a < 3; a++) {
        if (!h->inner[2 * a] && !h->inner[2 * a + 1]) continue;
        sq_field3 *f = &g->vel[a];
        const int ta = a == 0 ? 1 : 0, tb = a == 2 ? 1 : 2;
        const int m[3] = {f->n.nx, f->n.ny, f->n.nz};
        const ptrdiff_t st[3] = {1, f->sy, f->sz};
        const size_t cnt = (size_t)m[ta] * (size_t)m[tb];
        float *sb = (float *)(void *)h->buf, *rb = (float *)(void *)(h->buf + 2 * h->plane_bytes);
        const int nb[2] = {h->nb[2 * a], h->nb[2 * a + 1]};
        /* face 0 travels to the minus neighbour, whose face n it replaces */
        if (nb[0] >= 0) {
            size_t t = 0;
            for (int q = 0; q < m[tb]; q++)
                for (int p = 0; p < m[ta]; p++)
                    sb[t++] = f->origin[(ptrdiff_t)p * st[ta] + (ptrdiff_t)q * st[tb]];
        }
        const void *const sbuf[2] = {sb, sb};
        void *const rbuf[2] = {rb, rb};
        const size_t sby[2] = {nb[0] >= 0 ? cnt * sizeof(float) : 0, 0};
        const size_t rby[2] = {0, nb[1] >= 0 ? cnt * sizeof(float) : 0};
        (void)sq_par_exchange_pair(nb, sbuf, sby, rbuf, rby);
        h->bytes_exchanged += sby[0];
        if (nb[1] >= 0) {
            float *o = f->origin + (ptrdiff_t)(m[a] - 1) * st[a];
            size_t t = 0;
            for (int q = 0; q < m[tb]; q++)
                for (int p = 0; p < m[ta]; p++) o[(ptrdiff_t)p * st[ta] + (ptrdiff_t)q * st[tb]] = rb[t++];
        }
    }
}

void sq__grid_dist_sum(const sq_grid *g, double *v, int n)
{
    if (g->halo) sq_par_sum_f64(v, n);
}

bool sq__grid_dist_any(const sq_grid *g, bool v)
{
    if (!g->halo) return v;
    int64_t x = v ? 1 : 0;
    sq_par_sum_i64(&x, 1);
    return x != 0;
}

sq_result sq_grid_get_block(const sq_grid *g, int lo[3], sq_dims *global)
{
    if (!g) return sq__fail(NULL, SQ_ERR_INVALID_ARG, MOD, "sq_grid_get_block: grid is NULL");
    for (int a = 0; a < 3; a++) lo[a] = g->halo ? g->halo->b.lo[a] : 0;
    *global = g->halo ? g->halo->b.global : (sq_dims){g->n[0], g->n[1], g->n[2]};
    return SQ_OK;
}

uint64_t sq_grid_bytes_exchanged(const sq_grid *g) { return g && g->halo ? g->halo->bytes_exchanged : 0; }

void sq__grid_dist_max(const sq_grid *g, double *v, int n)
{
    if (g->halo) sq_par_max_f64(v, n);
}

/* ---- advection: the widened slab ------------------------------------------------------------
 * The semi-Lagrangian trace of a step that moves samples up to D cells along the split axis
 * reads D + 1 cells away; MacCormack's reverse step reads the forward estimate as far again,
 * which was traced from the velocity another D/2 + 1 cells on. The slab's fields have one
 * ghost layer, so instead of widening every field of the solver (and every kernel's
 * indexing) the advection runs on a copy of the slab widened by W = 2 ceil(D) + 3 planes of
 * each neighbour (a per-step extended copy): the velocity, the cell flags and each batch of
 * scalars are copied in, the neighbours' planes arrive by non-blocking exchange while the
 * slab's own planes are copied, the unchanged kernels run on the copy (placing samples by
 * their global index, grid_advect.c's lat), and the slab's samples are copied back. The
 * copy's samples near its ends are wrong (their traces leave it) but no slab sample reads
 * them; the kernels skip the samples no slab sample needs (sq_grid.own_only). Cost: up to
 * 2 (ceil(D) + 2) planes of extra work per slab and a copy of the advection's arrays. */

/* lattice L's sample counts and padded strides for cells n */
static void lat_layout(const int n[3], int L, int m[3], ptrdiff_t *sy, ptrdiff_t *sz)
{
    for (int a = 0; a < 3; a++) m[a] = n[a] + (L - 1 == a ? 1 : 0);
    *sy = m[0] + 2;
    *sz = *sy * (ptrdiff_t)(m[1] + 2);
}

static void wide_free(sq_context *ctx, sq_grid *w, int ns)
{
    if (!w) return;
    for (int c = 0; c < 3; c++) sq_free(ctx, w->vel[c].base);
    if (w->scalar)
        for (int q = 0; q < ns; q++) sq_free(ctx, w->scalar[q].base);
    sq_free(ctx, w->scalar);
    sq_free(ctx, w->flags);
    sq_free(ctx, w->scratch_block);
    for (int q = 4; q < SQ__SCRATCH; q++) sq_free(ctx, w->scratch[q]);
    sq_free(ctx, w);
}

/* padded samples of the largest lattice of cells n */
static size_t wide_count(const int n[3])
{
    size_t m = 0;
    for (int L = 0; L < 4; L++) {
        int e[3];
        ptrdiff_t sy, sz;
        lat_layout(n, L, e, &sy, &sz);
        const size_t c = (size_t)sz * (size_t)(e[2] + 2);
        m = c > m ? c : m;
    }
    return m;
}

/* Allocates the copy for `cap` planes a side (arrays of the largest layout). */
static sq_result wide_alloc(sq_grid *g, int cap)
{
    sq__grid_halo *h = g->halo;
    sq_context *ctx = g->ctx;
    wide_free(ctx, h->wide, h->wscalars);
    sq_free(ctx, h->xbuf);
    h->wide = NULL;
    h->xbuf = NULL;
    h->cap = 0;
    const int ns = g->d.scalar_count < 3 ? 3 : g->d.scalar_count < WIDE_SCALARS ? g->d.scalar_count : WIDE_SCALARS;
    h->wscalars = ns;
    sq_grid *w = (sq_grid *)sq_alloc_zero(ctx, sizeof *w);
    if (!w) return SQ_ERR_OUT_OF_MEMORY;
    int n[3] = {g->n[0], g->n[1], g->n[2]};
    n[h->ax] += (h->inner[2 * h->ax] ? cap : 0) + (h->inner[2 * h->ax + 1] ? cap : 0);
    const size_t count = wide_count(n);
    w->scratch_count = count;
    bool ok = true;
    for (int c = 0; c < 3; c++) ok = ok && (w->vel[c].base = (float *)sq_alloc_zero(ctx, count * sizeof(float)));
    w->scalar = (sq_field3 *)sq_alloc_zero(ctx, (size_t)ns * sizeof(sq_field3));
    ok = ok && w->scalar;
    for (int q = 0; q < ns && ok; q++) ok = (w->scalar[q].base = (float *)sq_alloc_zero(ctx, count * sizeof(float)));
    ok = ok && (w->flags = (uint8_t *)sq_alloc_zero(ctx, count));
    ok = ok && (w->scratch_block = (float *)sq_alloc_zero(ctx, 4 * count * sizeof(float)));
    for (int q = 0; q < 4 && ok; q++) w->scratch[q] = w->scratch_block + (size_t)q * count;
    for (int q = 4; q < SQ__SCRATCH && ok; q++) ok = (w->scratch[q] = (float *)sq_alloc_zero(ctx, count * sizeof(float)));
    /* a side's message: cap planes of the 3 velocity components and the flags, or of the
     * copy's scalars (the largest plane: n + 3 samples a tangential axis, ghosts included) */
    const int ta = h->ax == 0 ? 1 : 0, tb = h->ax == 2 ? 1 : 2;
    const size_t plane = (size_t)(g->n[ta] + 3) * (size_t)(g->n[tb] + 3);
    const size_t per = 3 * sizeof(float) + 1 > ns * sizeof(float) ? 3 * sizeof(float) + 1 : ns * sizeof(float);
    h->xside = (size_t)cap * plane * per;
    h->xbuf = ok ? (unsigned char *)sq_alloc(ctx, 4 * h->xside) : NULL;
    if (!ok || !h->xbuf) {
        wide_free(ctx, w, ns);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    w->ctx = ctx;
    h->wide = w;
    h->cap = cap;
    return SQ_OK;
}

/* Lays the copy out for `width` planes a side and refreshes what it borrows from the slab. */
static void wide_layout(sq_grid *g, int width)
{
    sq__grid_halo *h = g->halo;
    sq_grid *w = h->wide;
    const int ax = h->ax, wlo = h->inner[2 * ax] ? width : 0, whi = h->inner[2 * ax + 1] ? width : 0;
    h->width = width;
    w->own_only = true;
    w->own_ax = ax;
    w->own_lo = wlo;
    w->own_hi = wlo + g->n[ax];
    w->d = g->d;
    w->h = g->h;
    for (int a = 0; a < 3; a++) {
        w->n[a] = g->n[a] + (a == ax ? wlo + whi : 0);
        w->periodic[a] = a == ax ? h->gperiodic[a] : g->periodic[a];
        w->lat_n[a] = a == ax ? (ax == 0 ? h->b.global.nx : ax == 1 ? h->b.global.ny : h->b.global.nz) : g->n[a];
        w->lat_shift[a] = a == ax ? h->b.lo[a] - wlo : 0;
    }
    int m[3];
    lat_layout(w->n, SQ__L_CELL, m, &w->sy, &w->sz);
    w->cell_count = (size_t)w->sz * (size_t)(m[2] + 2);
    for (int c = 0; c < 3 + h->wscalars; c++) {
        sq_field3 *f = c < 3 ? &w->vel[c] : &w->scalar[c - 3];
        lat_layout(w->n, c < 3 ? c + 1 : SQ__L_CELL, m, &f->sy, &f->sz);
        f->n = (sq_dims){m[0], m[1], m[2]};
        f->ghost = 1;
        f->count = (size_t)f->sz * (size_t)(m[2] + 2);
        f->origin = f->base + 1 + f->sy + f->sz;
    }
    /* borrowed (the kernels read them through fill_ghosts on the copy's other faces) */
    w->plane_sum = g->plane_sum;
    for (int f = 0; f < 6; f++) {
        w->inflow[f] = g->inflow[f];
        w->inflow_n[f][0] = g->inflow_n[f][0];
        w->inflow_n[f][1] = g->inflow_n[f][1];
        for (int q = 0; q < SQ_GRID_MAX_SCALARS; q++) w->scalar_inflow_data[f][q] = g->scalar_inflow_data[f][q];
    }
    memcpy(w->scalar_inflow, g->scalar_inflow, sizeof w->scalar_inflow);
}

/* One array to widen: the slab's (origin of sample 0, strides) and the copy's, lattice L. */
typedef struct wide_arr {
    unsigned char *src, *dst;
    ptrdiff_t sy, sz, dsy, dsz;
    int L;
    size_t elem;
} wide_arr;

/* Packs (unpack false) or unpacks planes p0 .. p0+cnt-1 along axis a of an array (origin o,
 * strides), tangential samples -1 .. m[t] (ghosts included). */
static size_t planes_copy(unsigned char *o, ptrdiff_t sy, ptrdiff_t sz, size_t elem, const int m[3],
                          int a, int p0, int cnt, unsigned char *buf, bool unpack)
{
    const ptrdiff_t st[3] = {1, sy, sz};
    const int ta = a == 0 ? 1 : 0, tb = a == 2 ? 1 : 2;
    size_t t = 0;
    for (int p = p0; p < p0 + cnt; p++)
        for (int q = -1; q <= m[tb]; q++)
            for (int r = -1; r <= m[ta]; r++, t += elem) {
                unsigned char *x = o + ((ptrdiff_t)p * st[a] + (ptrdiff_t)r * st[ta] + (ptrdiff_t)q * st[tb]) * (ptrdiff_t)elem;
                if (unpack)
                    memcpy(x, buf + t, elem);
                else
                    memcpy(buf + t, x, elem);
            }
    return t;
}

/* Fills the copy's arrays: the slab's planes (ghosts included) copied while the neighbours'
 * travel (non-blocking), then the neighbours' planes, then the copy's outer ghost planes on
 * inner sides (zero gradient; never read by the slab's samples). */
static void wide_fill(sq_grid *g, const wide_arr *arr, int na)
{
    sq__grid_halo *h = g->halo;
    const int a = h->ax, W = h->width, n = g->n[a];
    const int wlo = h->inner[2 * a] ? W : 0;
    const int nb[2] = {h->nb[2 * a], h->nb[2 * a + 1]};
    unsigned char *sb[2] = {h->xbuf, h->xbuf + h->xside};
    unsigned char *rb[2] = {h->xbuf + 2 * h->xside, h->xbuf + 3 * h->xside};
    size_t by[2] = {0, 0};
    for (int s = 0; s < 2; s++) {
        if (nb[s] < 0) continue;
        for (int f = 0; f < na; f++) {
            int m[3];
            ptrdiff_t y, z;
            lat_layout(g->n, arr[f].L, m, &y, &z);
            /* minus side: my first W cells (faces 1..W); plus side: my last W cells/faces */
            const int p0 = s ? n - W : (arr[f].L - 1 == a ? 1 : 0);
            by[s] += planes_copy(arr[f].src, arr[f].sy, arr[f].sz, arr[f].elem, m, a, p0, W,
                                 sb[s] + by[s], false);
        }
    }
    sq_par_exchange x;
    const void *const sbuf[2] = {sb[0], sb[1]};
    void *const rbuf[2] = {rb[0], rb[1]};
    (void)sq_par_exchange_begin(nb, sbuf, by, rbuf, by, &x); /* sizes agree by construction */
    h->bytes_exchanged += by[0] + by[1];
    for (int f = 0; f < na; f++) { /* the slab's own planes, while the halo travels */
        const wide_arr *e = &arr[f];
        int m[3];
        ptrdiff_t y, z;
        lat_layout(g->n, e->L, m, &y, &z);
        const size_t row = (size_t)(m[0] + 2) * e->elem;
        const int dx = a == 0 ? wlo : 0, dy = a == 1 ? wlo : 0, dz = a == 2 ? wlo : 0;
        for (int k = -1; k <= m[2]; k++)
            for (int j = -1; j <= m[1]; j++)
                memcpy(e->dst + ((ptrdiff_t)(j + dy) * e->dsy + (ptrdiff_t)(k + dz) * e->dsz + dx - 1) * (ptrdiff_t)e->elem,
                       e->src + ((ptrdiff_t)j * e->sy + (ptrdiff_t)k * e->sz - 1) * (ptrdiff_t)e->elem, row);
    }
    sq_par_exchange_end(&x);
    size_t off[2] = {0, 0};
    for (int f = 0; f < na; f++) {
        const wide_arr *e = &arr[f];
        int m[3], mw[3];
        ptrdiff_t y, z;
        lat_layout(g->n, e->L, m, &y, &z);
        lat_layout(h->wide->n, e->L, mw, &y, &z);
        const bool face = e->L - 1 == a;
        if (nb[0] >= 0) /* the minus neighbour's last W planes: copy planes 0 .. W-1 */
            off[0] += planes_copy(e->dst, e->dsy, e->dsz, e->elem, m, a, 0, W, rb[0] + off[0], true);
        if (nb[1] >= 0) /* the plus neighbour's first: after my last cell (face) */
            off[1] += planes_copy(e->dst, e->dsy, e->dsz, e->elem, m, a, wlo + n + (face ? 1 : 0), W,
                                  rb[1] + off[1], true);
        /* outer ghost planes of the copy on inner sides: the nearest plane */
        const ptrdiff_t st[3] = {1, e->dsy, e->dsz};
        const int ta = a == 0 ? 1 : 0, tb = a == 2 ? 1 : 2;
        for (int s = 0; s < 2; s++) {
            if (nb[s] < 0) continue;
            const int gp = s ? mw[a] : -1, ip = s ? mw[a] - 1 : 0;
            for (int q = -1; q <= m[tb]; q++)
                for (int r = -1; r <= m[ta]; r++) {
                    const ptrdiff_t t = (ptrdiff_t)r * st[ta] + (ptrdiff_t)q * st[tb];
                    memcpy(e->dst + (t + (ptrdiff_t)gp * st[a]) * (ptrdiff_t)e->elem,
                           e->dst + (t + (ptrdiff_t)ip * st[a]) * (ptrdiff_t)e->elem, e->elem);
                }
        }
    }
}

sq_grid *sq__grid_dist_wide(sq_grid *g) { return g->halo ? g->halo->wide : g; }

sq_result sq__grid_dist_widen(sq_grid *g, float dt, sq_grid **out)
{
    sq__grid_halo *h = g->halo;
    *out = NULL;
    const int a = h->ax;
    /* the largest speed along the split axis, ghosts included (non-finite values are the
     * stability check's business) */
    const sq_field3 *u = &g->vel[a];
    float vm = 0.0f;
    for (size_t i = 0; i < u->count; i++) {
        const float v = fabsf(u->base[i]);
        vm = v > vm && v <= FLT_MAX ? v : vm;
    }
    double D = (double)vm * (double)dt / (double)g->h;
    sq__grid_dist_max(g, &D, 1);
    D = D < 1e6 ? D : 1e6;
    const int W = 2 * (int)ceil(D) + 3;
    const int n0 = a == 0 ? h->b.global.nx : a == 1 ? h->b.global.ny : h->b.global.nz;
    const int thinnest = n0 / sq_par_size();
    if (W > thinnest)
        return sq__fail(g->ctx, SQ_ERR_UNSTABLE, MOD,
                        "advection: a step of %g s moves the wind up to %.3g cells along %c; its "
                        "halo of 2 ceil(%.3g) + 3 = %d planes is more than the thinnest slab "
                        "(%d cells of %d over %d ranks): use fewer ranks or a smaller step",
                        (double)dt, D, "xyz"[a], D, W, thinnest, n0, sq_par_size());
    if (W > h->cap) {
        /* headroom: a gusting wind does not reallocate every step */
        int cap = W + 2 < thinnest ? W + 2 : thinnest;
        sq_result r = wide_alloc(g, cap);
        if (sq__grid_dist_any(g, r != SQ_OK))
            return r != SQ_OK ? r
                              : sq__fail(g->ctx, SQ_ERR_OUT_OF_MEMORY, MOD,
                                         "advection: another rank has no memory for its halo");
    }
    wide_layout(g, W);
    sq_grid *w = h->wide;
    /* a sample's trace reaches ceil(D) + 1 cells: the second pass at the slab's samples reads
     * the first within that, the first pass reads the copy within that again (W) */
    w->trace_margin = (int)ceil(D) + 2;
    wide_arr arr[4];
    for (int c = 0; c < 3; c++)
        arr[c] = (wide_arr){(unsigned char *)g->vel[c].origin, (unsigned char *)w->vel[c].origin,
                            g->vel[c].sy, g->vel[c].sz, w->vel[c].sy, w->vel[c].sz, c + 1, sizeof(float)};
    arr[3] = (wide_arr){g->flags + sq__cidx(g, 0, 0, 0), w->flags + sq__cidx(w, 0, 0, 0), g->sy, g->sz,
                        w->sy, w->sz, SQ__L_CELL, 1};
    wide_fill(g, arr, 4);
    *out = w;
    return SQ_OK;
}

int sq__grid_dist_wide_scalars(const sq_grid *g) { return g->halo ? g->halo->wscalars : 0; }

void sq__grid_dist_widen_scalars(sq_grid *g, int s0, int count)
{
    sq_grid *w = g->halo->wide;
    wide_arr arr[WIDE_SCALARS];
    const int n = count < g->halo->wscalars ? count : g->halo->wscalars;
    for (int q = 0; q < n; q++)
        arr[q] = (wide_arr){(unsigned char *)g->scalar[s0 + q].origin, (unsigned char *)w->scalar[q].origin,
                            g->sy, g->sz, w->sy, w->sz, SQ__L_CELL, sizeof(float)};
    wide_fill(g, arr, n);
}

void sq__grid_dist_narrow(const sq_grid *g, const float *wide, int L, float *slab)
{
    const sq__grid_halo *h = g->halo;
    const int a = h->ax, wlo = h->inner[2 * a] ? h->width : 0;
    int m[3], mw[3];
    ptrdiff_t sy, sz, wsy, wsz;
    lat_layout(g->n, L, m, &sy, &sz);
    lat_layout(h->wide->n, L, mw, &wsy, &wsz);
    const int dx = a == 0 ? wlo : 0, dy = a == 1 ? wlo : 0, dz = a == 2 ? wlo : 0;
    for (int k = 0; k < m[2]; k++)
        for (int j = 0; j < m[1]; j++)
            memcpy(slab + (ptrdiff_t)j * sy + (ptrdiff_t)k * sz,
                   wide + (ptrdiff_t)(j + dy) * wsy + (ptrdiff_t)(k + dz) * wsz + dx,
                   (size_t)m[0] * sizeof(float));
}

/* ---- the whole grid from the slabs (outputs) ------------------------------------------------ */
/* root < 0: into whole on every rank; else into whole on rank root only (NULL elsewhere). */
static sq_result gather_grid(const sq_grid *g, sq_grid *whole, int root)
{
    sq__grid_halo *h = g ? g->halo : NULL;
    const bool here = root < 0 || !h || sq_par_rank() == root;
    if (!g || (here && (!whole || whole->halo)))
        return sq__fail(g ? g->ctx : NULL, SQ_ERR_INVALID_ARG, MOD,
                        "sq_grid_gather: the slab and a whole (not decomposed) grid are needed");
    int n0[3], lo[3];
    sq__grid_dist_frame(g, n0, lo);
    if (here && (whole->n[0] != n0[0] || whole->n[1] != n0[1] || whole->n[2] != n0[2] ||
        whole->d.scalar_count != g->d.scalar_count))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "sq_grid_gather: whole grid %dx%dx%d with %d scalars; the grid is "
                        "%dx%dx%d with %d", whole->n[0], whole->n[1], whole->n[2],
                        whole->d.scalar_count, n0[0], n0[1], n0[2], g->d.scalar_count);
    const int nf = 3 + g->d.scalar_count, size = h ? sq_par_size() : 1, rank = h ? sq_par_rank() : 0;
    /* every rank's block (a pure function of the rank) */
    sq_par_block bl[64];
    const sq_par_block *b = bl;
    sq_par_block *heap = NULL;
    if (size > 64) {
        heap = (sq_par_block *)sq_alloc(g->ctx, (size_t)size * sizeof *heap);
        if (!heap) return SQ_ERR_OUT_OF_MEMORY;
        b = heap;
    }
    sq_par_block *bw = heap ? heap : bl;
    if (h) {
        int split[3] = {0, 0, 0}, per[3];
        split[h->ax] = 1;
        for (int a = 0; a < 3; a++) per[a] = h->gperiodic[a];
        const sq_dims gd = {n0[0], n0[1], n0[2]};
        for (int q = 0; q < size; q++) (void)sq_par_decompose(gd, split, per, 4, size, q, &bw[q]);
    } else {
        memset(bw, 0, sizeof *bw);
        bw[0].n = (sq_dims){n0[0], n0[1], n0[2]};
    }
    int64_t counts[64], *cnt = counts;
    if (size > 64) cnt = (int64_t *)sq_alloc(g->ctx, (size_t)size * sizeof(int64_t));
    size_t total = 0;
    for (int q = 0; q < size; q++) {
        const int nq[3] = {b[q].n.nx, b[q].n.ny, b[q].n.nz};
        total += wide_count(nq); /* >= any lattice's samples */
    }
    float *mine = NULL, *all = NULL;
    if (cnt) {
        mine = (float *)sq_alloc(g->ctx, wide_count(g->n) * sizeof(float));
        all = here ? (float *)sq_alloc(g->ctx, total * sizeof(float)) : NULL;
    }
    sq_result r = cnt && mine && (all || !here) ? SQ_OK : SQ_ERR_OUT_OF_MEMORY;
    if (h && sq__grid_dist_any(g, r != SQ_OK) && r == SQ_OK) r = SQ_ERR_OUT_OF_MEMORY;
    for (int c = 0; c < nf && r == SQ_OK; c++) {
        const int L = c < 3 ? c + 1 : SQ__L_CELL;
        const sq_field3 *f = c < 3 ? &g->vel[c] : &g->scalar[c - 3];
        sq_field3 *F = !here ? NULL : c < 3 ? &whole->vel[c] : &whole->scalar[c - 3];
        int m[3];
        ptrdiff_t y, z;
        for (int q = 0; q < size; q++) {
            const int nq[3] = {b[q].n.nx, b[q].n.ny, b[q].n.nz};
            lat_layout(nq, L, m, &y, &z);
            cnt[q] = (int64_t)m[0] * m[1] * m[2];
        }
        lat_layout(g->n, L, m, &y, &z);
        size_t t = 0;
        for (int k = 0; k < m[2]; k++)
            for (int j = 0; j < m[1]; j++, t += (size_t)m[0])
                memcpy(mine + t, sq_field3_at(f, 0, j, k), (size_t)m[0] * sizeof(float));
        if (h && root < 0) {
            r = sq_par_allgather_f32(mine, cnt, all);
            h->bytes_exchanged += (uint64_t)cnt[rank] * sizeof(float) * (uint64_t)(size - 1);
        } else if (h) {
            r = sq_par_gather_f32(mine, cnt, all);
            if (rank != root) h->bytes_exchanged += (uint64_t)cnt[rank] * sizeof(float);
        } else {
            memcpy(all, mine, t * sizeof(float));
        }
        size_t off = 0;
        for (int q = 0; q < size && r == SQ_OK && here; q++) {
            const int nq[3] = {b[q].n.nx, b[q].n.ny, b[q].n.nz};
            lat_layout(nq, L, m, &y, &z);
            for (int k = 0; k < m[2]; k++)
                for (int j = 0; j < m[1]; j++, off += (size_t)m[0])
                    memcpy(sq_field3_at(F, b[q].lo[0], j + b[q].lo[1], k + b[q].lo[2]), all + off,
                           (size_t)m[0] * sizeof(float));
        }
    }
    sq_free(g->ctx, mine);
    sq_free(g->ctx, all);
    if (cnt != counts) sq_free(g->ctx, cnt);
    sq_free(g->ctx, heap);
    if (here) {
        whole->vel_version++;
        whole->trace_valid = false;
    }
    return r;
}

sq_result sq_grid_gather(const sq_grid *g, sq_grid *whole) { return gather_grid(g, whole, -1); }

sq_result sq_grid_gather_root(const sq_grid *g, sq_grid *whole) { return gather_grid(g, whole, 0); }
