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
#include <string.h>

#include "solvers/grid/grid_internal.h"
#include "squall/par.h"

#define MOD "grid"

struct sq__grid_halo {
    sq_par_block b;
    int parity;       /* (lo x + lo y + lo z) & 1: global red-black colour of local cell 0 */
    bool inner[6];    /* face toward a neighbouring slab */
    int nb[6];        /* its rank (-1: no inner face) */
    sq_boundary boundary[6]; /* the whole grid's faces (swapped in for the coarse levels) */
    bool periodic[3];
    unsigned char *buf; /* 2 send + 2 receive planes of the largest face, 4 bytes a cell */
    size_t plane_bytes;
    uint64_t bytes_exchanged;
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
                const size_t p = (size_t)(n[ta] + 2) * (size_t)(n[tb] + 2);
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
    h->buf = (unsigned char *)sq_alloc(ctx, 4 * h->plane_bytes);
    if (!h->buf) {
        sq_free(ctx, h);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    sq_log(ctx, SQ_LOG_DEBUG, MOD, "rank %d of %d: cells %d..%d of %d along %c", rank, size,
           b.lo[ax], b.lo[ax] + n[ax] - 1, ncell[ax], "xy"[ax]);
    *out = h;
    return SQ_OK;
}

void sq__grid_dist_free(sq_context *ctx, sq__grid_halo *h)
{
    if (!h) return;
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
