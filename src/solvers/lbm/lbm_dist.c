/* lbm_dist.c — the lattice split over the ranks of a distributed run (squall/par.h) in slabs
 * along z, one per rank.
 *
 * A slab's faces toward its neighbours behave as the faces of a periodic axis do in the serial
 * solver (lbm_kernels.c): before an odd step the populations about to leave are copied into the
 * neighbours' ghost planes (FILL, the last of the axes, its planes padded in x and y so edges
 * and corners travel too); right after an odd step the populations that left into the ghost
 * planes are moved onto the neighbours' edge planes (FOLD). The fold is done at once (not
 * lazily as the periodic fold) so that every interior population equals the one-rank solver's
 * between steps, whatever is asked of the lattice next; it travels while the slab's interior
 * planes are updated (sq__lbm_dist_sweep). Each transfer is 5 populations of one
 * padded plane per neighbour: 20 (nx+2)(ny+2) bytes each way.
 *
 * Why z: a slab is a contiguous run of the global x-fastest arrays (the gathers need no
 * packing), x rows stay whole (the row kernels and their classes are unchanged), the wind's
 * reference plane lies in one slab, and z is the axis with the fewest boundary links (ground
 * and sky). The price: at most nz/2 ranks (docs/mpi.md). */
#include <string.h>

#include "lbm_internal.h"
#include "squall/par.h"

sq_result sq__lbm_dist_setup(sq_lbm *l, const sq_lbm_desc *d)
{
    const int size = sq_par_size(), rank = sq_par_rank();
    const int split[3] = {0, 0, 1};
    const int per[3] = {l->periodic[0], l->periodic[1], l->periodic[2]};
    sq_par_block b;
    const sq_result r = sq_par_decompose(d->cells, split, per, 2, size, rank, &b);
    if (r != SQ_OK)
        return sq__fail(l->ctx, r, "lbm",
                        "cells = %dx%dx%d: the lattice cannot be split over %d ranks (slabs "
                        "along z of at least 2 planes: at most %d ranks); run with fewer ranks "
                        "(mpirun -np)",
                        d->cells.nx, d->cells.ny, d->cells.nz, size, d->cells.nz / 2);
    l->zdist = true;
    l->nranks = size;
    l->nzg = d->cells.nz;
    l->kz0 = b.lo[2];
    l->nz = b.n.nz;
    l->znb[0] = b.neighbour[4];
    l->znb[1] = b.neighbour[5];
    l->plane_rank = (int *)sq_alloc(l->ctx, (size_t)l->nzg * sizeof(int));
    l->rank_cells = (int64_t *)sq_alloc(l->ctx, (size_t)size * sizeof(int64_t));
    if (!l->plane_rank || !l->rank_cells) return SQ_ERR_OUT_OF_MEMORY;
    for (int q = 0; q < size; q++) {
        sq_par_block o;
        (void)sq_par_decompose(d->cells, split, per, 2, size, q, &o);
        l->rank_cells[q] = (int64_t)o.n.nx * o.n.ny * o.n.nz;
        for (int z = o.lo[2]; z < o.lo[2] + o.n.nz; z++) l->plane_rank[z] = q;
    }
    const int64_t plane = (int64_t)l->nx * l->ny;
    const int64_t padded = (int64_t)(l->nx + 2) * (l->ny + 2);
    l->gsolid = (uint8_t *)sq_alloc_zero(l->ctx, (size_t)(plane * l->nzg));
    l->lmacro = (float *)sq_alloc_zero(l->ctx, (size_t)(4 * plane * l->nz) * sizeof(float));
    l->nbr = (double *)sq_alloc_zero(l->ctx, (size_t)(8 * plane) * sizeof(double));
    l->zbuf = (float *)sq_alloc(l->ctx, (size_t)(20 * padded) * sizeof(float));
    if (!l->gsolid || !l->lmacro || !l->nbr || !l->zbuf) return SQ_ERR_OUT_OF_MEMORY;
    sq_log(l->ctx, SQ_LOG_DEBUG, "lbm", "rank %d of %d: planes %d..%d of %d", rank, size,
           l->kz0, l->kz0 + l->nz - 1, l->nzg);
    return SQ_OK;
}

void sq__lbm_dist_free(sq_lbm *l)
{
    sq_free(l->ctx, l->plane_rank);
    sq_free(l->ctx, l->rank_cells);
    sq_free(l->ctx, l->gsolid);
    sq_free(l->ctx, l->lmacro);
    sq_free(l->ctx, l->nbr);
    sq_free(l->ctx, l->zbuf);
}

/* The slots of the populations travelling up / down: natural layout (FOLD) slot i holds f_i;
 * swapped layout (FILL) slot i holds f*_opp(i). */
static void travel_slots(int mode, int up[5], int dn[5])
{
    int nu = 0, nd = 0;
    for (int i = 1; i < SQ_LBM_Q; i++) {
        const int cz = mode == SQ_LBM_Z_FOLD ? sq__lbm_c[i][2] : -sq__lbm_c[i][2];
        if (cz > 0) up[nu++] = i;
        if (cz < 0) dn[nd++] = i;
    }
}

void sq__lbm_z_exchange_begin(sq_lbm *l, int mode)
{
    const int64_t P = l->sz, S = l->stride;
    const int nz = l->nz;
    int up[5], dn[5];
    travel_slots(mode, up, dn);
    /* planes (slab-local z) sent up / down */
    const int src_up = mode == SQ_LBM_Z_FILL ? nz - 1 : nz;
    const int src_dn = mode == SQ_LBM_Z_FILL ? 0 : -1;
    float *const sdn = l->zbuf, *const sup = l->zbuf + 5 * P;
    float *const rlo = l->zbuf + 10 * P, *const rhi = l->zbuf + 15 * P;
    const size_t bytes = (size_t)(5 * P) * sizeof(float);
    for (int q = 0; q < 5; q++) {
        if (l->znb[1] >= 0)
            memcpy(sup + q * P, l->f + up[q] * S + (int64_t)(src_up + 1) * P,
                   (size_t)P * sizeof(float));
        if (l->znb[0] >= 0)
            memcpy(sdn + q * P, l->f + dn[q] * S + (int64_t)(src_dn + 1) * P,
                   (size_t)P * sizeof(float));
    }
    const void *sb[2] = {sdn, sup};
    void *rb[2] = {rlo, rhi};
    const size_t nb[2] = {bytes, bytes};
    l->zx_mode = mode;
    (void)sq_par_exchange_begin(l->znb, sb, nb, rb, nb, &l->zx);
}

void sq__lbm_z_exchange_end(sq_lbm *l)
{
    sq_par_exchange_end(&l->zx);
    const int64_t P = l->sz, S = l->stride;
    const int nz = l->nz, mode = l->zx_mode;
    int up[5], dn[5];
    travel_slots(mode, up, dn);
    /* where what comes from below / above lands */
    const int dst_lo = mode == SQ_LBM_Z_FILL ? -1 : 0;
    const int dst_hi = mode == SQ_LBM_Z_FILL ? nz : nz - 1;
    const float *const rlo = l->zbuf + 10 * P, *const rhi = l->zbuf + 15 * P;
    for (int q = 0; q < 5; q++) {
        if (l->znb[0] >= 0)
            memcpy(l->f + up[q] * S + (int64_t)(dst_lo + 1) * P, rlo + q * P,
                   (size_t)P * sizeof(float));
        if (l->znb[1] >= 0)
            memcpy(l->f + dn[q] * S + (int64_t)(dst_hi + 1) * P, rhi + q * P,
                   (size_t)P * sizeof(float));
    }
}

void sq__lbm_z_exchange(sq_lbm *l, int mode)
{
    sq__lbm_z_exchange_begin(l, mode);
    sq__lbm_z_exchange_end(l);
}

/* An odd step writes into the ghost planes only from the edge planes, and what arrives from
 * the neighbours lands in slots of the edge planes that no cell of this slab touches in this
 * step: the edge planes are updated first, their fold travels while the interior is updated.
 * (Before an odd step the fill waits for the inflow layer's reset, see sq__lbm_boundaries: not
 * overlapped.) */
void sq__lbm_dist_sweep(sq_lbm *l, int parity, const sq__lbm_kparams *p)
{
    const int nz = l->nz;
    if (parity == 0 || nz < 3) {
        sq__lbm_sweep(l, parity, p);
        if (parity == 1) sq__lbm_z_exchange(l, SQ_LBM_Z_FOLD);
        return;
    }
    sq__lbm_sweep_planes(l, parity, p, 0, 1);
    sq__lbm_sweep_planes(l, parity, p, nz - 1, nz);
    sq__lbm_z_exchange_begin(l, SQ_LBM_Z_FOLD);
    sq__lbm_sweep_planes(l, parity, p, 1, nz - 1);
    sq__lbm_z_exchange_end(l);
}

void sq__lbm_dist_gather_macro(sq_lbm *l)
{
    const int64_t loc = (int64_t)l->nx * l->ny * l->nz;
    const int64_t glob = (int64_t)l->nx * l->ny * l->nzg;
    for (int a = 0; a < 4; a++)
        (void)sq_par_allgather_f32(l->lmacro + a * loc, l->rank_cells, l->macro + a * glob);
}
