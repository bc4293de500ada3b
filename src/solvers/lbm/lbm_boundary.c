/* lbm_boundary.c — boundary conditions of the box faces (SPEC §5.4).
 *
 * Periodic/recycled axes are handled by the ghost exchange in lbm_kernels.c. Every other
 * population that enters an edge cell x from outside (direction i, coming from x − c_i) is a
 * "link", built once at create and evaluated before every sweep:
 * Populations are stored shifted (h = f − w); every rule below is invariant under the shift
 * (w_i = w_opp(i)).
 *   WALL       half-way bounce-back f_i(x) = f*_opp(i)(x) + 6 w_i ρ0 (c_i·u_wall)  (Ladd)
 *   FREE_SLIP  specular reflection: f_i(x) = f*_r(x_r), r = i with the normal component
 *              flipped, x_r the cell the mirrored population left from (COPY)
 *   INFLOW     equilibrium inlet layer: every cell on an inflow face is reset to
 *              feq(ρ0, u_in(h)) before each sweep (ρ0 = 1, the log-law wind
 *              u_in = shape(h) × wind) and receives feq_i(ρ0, u_in) from outside. Fixing the
 *              whole layer (not just the incoming populations) removes its non-equilibrium part
 *              and pins the density, which keeps the inlet stable at the near-zero viscosities
 *              of atmospheric flow (a bounce-back velocity inlet, an equilibrium inlet on the
 *              incoming populations alone, and a layer at the cells' own density all grew
 *              unstable with collision = smagorinsky at τ0 ≈ 0.5)
 *   OUTFLOW    zero-gradient: f_i(x) = f*_i of the interior cell next to the source (COPY)
 * A link crossing several non-periodic faces (edges, corners) takes the first of WALL,
 * FREE_SLIP, INFLOW, OUTFLOW among them. COPY links whose source cell is solid bounce back.
 *
 * Where the values live depends on the AA layout (see lbm_internal.h):
 *   incoming f_i(x):        natural: slot i of x          swapped: slot opp(i) of x − c_i
 *   outgoing f*_r(c):       natural: slot r of c + c_r    swapped: slot opp(r) of c */
#include <math.h>

#include "lbm_internal.h"

static int find_dir(int cx, int cy, int cz)
{
    for (int i = 0; i < SQ_LBM_Q; i++)
        if (sq__lbm_c[i][0] == cx && sq__lbm_c[i][1] == cy && sq__lbm_c[i][2] == cz) return i;
    return -1;
}

static int kind_rank(sq_lbm_bc b)
{
    switch (b) {
    case SQ_LBM_BC_WALL: return 0;
    case SQ_LBM_BC_FREE_SLIP: return 1;
    case SQ_LBM_BC_INFLOW: return 2;
    case SQ_LBM_BC_OUTFLOW: return 3;
    default: return 4;
    }
}

/* Builds (or counts, when out is NULL) the links. */
static int64_t enumerate_links(sq_lbm *l, sq__lbm_link *out)
{
    const int n[3] = {l->nx, l->ny, l->nz};
    const sq_lbm_desc *d = &l->desc;
    int64_t count = 0;
    for (int z = 0; z < n[2]; z++)
        for (int y = 0; y < n[1]; y++)
            for (int x = 0; x < n[0]; x++) {
                const int p[3] = {x, y, z};
                const bool edge = x == 0 || y == 0 || z == 0 || x == n[0] - 1 ||
                                  y == n[1] - 1 || z == n[2] - 1;
                if (!edge) continue;
                for (int i = 1; i < SQ_LBM_Q; i++) {
                    int s[3], crossed[3] = {-1, -1, -1};
                    bool outside = false;
                    for (int a = 0; a < 3; a++) {
                        s[a] = p[a] - sq__lbm_c[i][a];
                        if (s[a] >= 0 && s[a] < n[a]) continue;
                        if (sq__lbm_face_joined(l, a, s[a] >= n[a] ? 1 : 0)) {
                            /* a slab face: the source is in the ghost plane, filled from
                             * the neighbouring slab */
                            if (!(a == 2 && l->zdist)) s[a] = (s[a] + n[a]) % n[a];
                            continue;
                        }
                        crossed[a] = 2 * a + (s[a] >= n[a] ? 1 : 0);
                        outside = true;
                    }
                    if (!outside) continue;
                    /* the deciding face: the highest-priority kind among those crossed */
                    int face = -1;
                    for (int a = 0; a < 3; a++)
                        if (crossed[a] >= 0 &&
                            (face < 0 || kind_rank(d->bc[crossed[a]]) < kind_rank(d->bc[face])))
                            face = crossed[a];
                    sq_lbm_bc bc = d->bc[face];
                    sq__lbm_link lk = {(int32_t)sq__lbm_cell(l, x, y, z), 0, (uint8_t)i, 0, 0,
                                       (uint8_t)face, 0.0f};
                    if (bc == SQ_LBM_BC_FREE_SLIP) {
                        /* the mirrored population left from q = x − c_i with the free-slip
                         * normal components dropped; if q lies beyond another (inflow or
                         * outflow) face, that face decides instead */
                        int cr[3], q[3];
                        bool inside = true;
                        for (int a = 0; a < 3; a++) {
                            const bool mirror =
                                crossed[a] >= 0 && d->bc[crossed[a]] == SQ_LBM_BC_FREE_SLIP;
                            cr[a] = mirror ? -sq__lbm_c[i][a] : sq__lbm_c[i][a];
                            q[a] = mirror ? p[a] : p[a] - sq__lbm_c[i][a];
                            if (q[a] >= 0 && q[a] < n[a]) continue;
                            if (a == 2 && l->zdist && sq__lbm_z_joined(l, q[a] >= n[a]))
                                continue; /* the neighbouring slab's cell (ghost plane) */
                            if (l->periodic[a] && !(a == 2 && l->zdist))
                                q[a] = (q[a] + n[a]) % n[a];
                            else
                                inside = false;
                        }
                        if (inside) {
                            lk.kind = SQ_LBM_LINK_COPY;
                            lk.r = (uint8_t)find_dir(cr[0], cr[1], cr[2]);
                            lk.src = (int32_t)sq__lbm_cell(l, q[0], q[1], q[2]);
                            if (out) out[count] = lk;
                            count++;
                            continue;
                        }
                        face = -1;
                        for (int a = 0; a < 3; a++)
                            if (crossed[a] >= 0 && d->bc[crossed[a]] != SQ_LBM_BC_FREE_SLIP &&
                                (face < 0 ||
                                 kind_rank(d->bc[crossed[a]]) < kind_rank(d->bc[face])))
                                face = crossed[a];
                        bc = d->bc[face];
                        lk.face = (uint8_t)face;
                    }
                    if (bc == SQ_LBM_BC_WALL) {
                        /* wall velocity: the crossed walls' common velocity, else at rest */
                        double uw[3] = {0, 0, 0};
                        bool first = true, same = true;
                        for (int a = 0; a < 3; a++) {
                            if (crossed[a] < 0 || d->bc[crossed[a]] != SQ_LBM_BC_WALL) continue;
                            const double *v = d->wall_velocity_mps[crossed[a]];
                            if (first) {
                                uw[0] = v[0], uw[1] = v[1], uw[2] = v[2];
                                first = false;
                            } else if (v[0] != uw[0] || v[1] != uw[1] || v[2] != uw[2]) {
                                same = false;
                            }
                        }
                        double cu = 0;
                        if (same)
                            for (int a = 0; a < 3; a++) cu += sq__lbm_c[i][a] * uw[a] / l->units.u;
                        lk.kind = SQ_LBM_LINK_WALL;
                        lk.extra = (float)(6.0 * sq__lbm_w[i] * cu);
                    } else if (bc == SQ_LBM_BC_INFLOW) {
                        lk.kind = SQ_LBM_LINK_INFLOW;
                        lk.src = -1; /* set to the inflow-cell index in sq__lbm_links_build */
                    } else { /* OUTFLOW */
                        int q[3];
                        for (int a = 0; a < 3; a++) {
                            const bool joined = (s[a] < 0 || s[a] >= n[a]) &&
                                                a == 2 && sq__lbm_z_joined(l, s[a] >= n[a]);
                            q[a] = joined ? s[a] : s[a] < 0 ? 0 : s[a] >= n[a] ? n[a] - 1 : s[a];
                        }
                        lk.kind = SQ_LBM_LINK_COPY;
                        lk.r = (uint8_t)i;
                        lk.src = (int32_t)sq__lbm_cell(l, q[0], q[1], q[2]);
                    }
                    if (out) out[count] = lk;
                    count++;
                }
            }
    return count;
}

/* p: a cell of this slab (z local). */
static bool on_inflow_face(const sq_lbm *l, const int p[3])
{
    const int g[3] = {p[0], p[1], p[2] + l->kz0};
    const int n[3] = {l->nx, l->ny, l->zdist ? l->nzg : l->nz};
    for (int a = 0; a < 3; a++) {
        if (g[a] == 0 && l->desc.bc[2 * a] == SQ_LBM_BC_INFLOW) return true;
        if (g[a] == n[a] - 1 && l->desc.bc[2 * a + 1] == SQ_LBM_BC_INFLOW) return true;
    }
    return false;
}

sq_result sq__lbm_links_build(sq_lbm *l)
{
    /* the inflow layer */
    int64_t ni = 0;
    for (int pass = 0; pass < 2; pass++) {
        ni = 0;
        for (int z = 0; z < l->nz; z++)
            for (int y = 0; y < l->ny; y++)
                for (int x = 0; x < l->nx; x++) {
                    const int p[3] = {x, y, z};
                    if (!on_inflow_face(l, p)) continue;
                    if (pass == 1) l->inflow_cells[ni] = (int32_t)sq__lbm_cell(l, x, y, z);
                    ni++;
                }
        if (pass == 0 && ni > 0) {
            l->inflow_cells = (int32_t *)sq_alloc(l->ctx, (size_t)ni * sizeof(int32_t));
            l->inflow_shape = (float *)sq_alloc(l->ctx, (size_t)ni * sizeof(float));
            if (!l->inflow_cells || !l->inflow_shape)
                return SQ_ERR_OUT_OF_MEMORY;
        }
        if (ni == 0) break;
    }
    l->ninflow = ni;
    const int64_t n = enumerate_links(l, NULL);
    l->nlinks = n;
    l->links = NULL;
    if (n > 0) {
        l->links = (sq__lbm_link *)sq_alloc(l->ctx, (size_t)n * sizeof(sq__lbm_link));
        if (!l->links) return SQ_ERR_OUT_OF_MEMORY;
        enumerate_links(l, l->links);
        /* inflow links: the index of their receiving cell in the (sorted) inflow list */
        for (int64_t k = 0; k < n; k++) {
            sq__lbm_link *lk = &l->links[k];
            if (lk->kind != SQ_LBM_LINK_INFLOW) continue;
            int64_t lo = 0, hi = ni - 1;
            while (lo < hi) {
                const int64_t mid = (lo + hi) / 2;
                if (l->inflow_cells[mid] < lk->x)
                    lo = mid + 1;
                else
                    hi = mid;
            }
            lk->src = (int32_t)lo;
        }
    }
    l->inflow_dirty = true;
    return SQ_OK;
}

/* Log-law shape factors of the inflow cells: height above the highest solid cell below (or
 * above a WALL bottom face); uniform (1) where there is no ground below. */
void sq__lbm_inflow_shapes(sq_lbm *l)
{
    const double dx = l->units.dx, z0 = l->desc.wind.roughness_m;
    const double zr = l->desc.wind.ref_height_m;
    const bool wall_bottom = l->desc.bc[SQ_LBM_FACE_ZMIN] == SQ_LBM_BC_WALL;
    for (int64_t k = 0; k < l->ninflow; k++) {
        const int64_t c = l->inflow_cells[k];
        /* global height: the column below may run through other slabs (global flags) */
        const int z = (int)(c / l->sz) - 1 + l->kz0;
        const int y = (int)((c % l->sz) / l->sy) - 1, x = (int)(c % l->sy) - 1;
        int zg = wall_bottom ? -1 : -2;
        for (int q = z - 1; q >= 0; q--) {
            if (sq__lbm_gsolid(l, x, y, q)) {
                zg = q;
                break;
            }
        }
        l->inflow_shape[k] =
            zg == -2 ? 1.0f : (float)sq__lbm_log_shape((z - zg - 0.5) * dx, z0, zr);
    }
    l->inflow_dirty = false;
}

/* feq_i(1 + δρ, u) − w_i for all i (shifted like the stored populations). */
static void feq_shifted(double drho, const double u[3], float out[SQ_LBM_Q])
{
    const double rho = 1.0 + drho, usq = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
    for (int i = 0; i < SQ_LBM_Q; i++) {
        const double cu =
            sq__lbm_c[i][0] * u[0] + sq__lbm_c[i][1] * u[1] + sq__lbm_c[i][2] * u[2];
        out[i] = (float)(sq__lbm_w[i] * (drho + rho * (3.0 * cu + 4.5 * cu * cu - 1.5 * usq)));
    }
}

void sq__lbm_boundaries(sq_lbm *l)
{
    const int parity = (int)(l->step & 1);
    sq__lbm_fold_periodic(l, parity);
    /* slab faces before an odd step: filled after the inflow layer's reset (the neighbour
     * reads those cells' new populations) and before the links (which write the corners of
     * the ghost planes the cells of this slab read) */
    const bool fill = l->zdist && parity == 1;
    if (l->nlinks == 0 && l->ninflow == 0) {
        if (fill) sq__lbm_z_exchange(l, SQ_LBM_Z_FILL);
        return;
    }
    if (l->inflow_dirty) sq__lbm_inflow_shapes(l);
    float *const F = l->f;
    const int64_t S = l->stride;
    const uint8_t *const solid = l->solid;
    /* the inflow layer: every cell reset to feq(ρ0, shape·u_in) in the current layout */
    for (int64_t k = 0; k < l->ninflow; k++) {
        const int64_t c = l->inflow_cells[k];
        if (solid[c]) continue;
        const double s = (double)l->inflow_shape[k];
        const double u[3] = {s * l->inflow_u[0], s * l->inflow_u[1], s * l->inflow_u[2]};
        float h[SQ_LBM_Q];
        feq_shifted(0.0, u, h);
        for (int i = 0; i < SQ_LBM_Q; i++) {
            const int slot = parity == 0 ? i : sq__lbm_opp[i];
            F[(int64_t)slot * S + c] = h[i];
        }
    }
    if (fill) sq__lbm_z_exchange(l, SQ_LBM_Z_FILL);
    for (int64_t k = 0; k < l->nlinks; k++) {
        const sq__lbm_link lk = l->links[k];
        if (solid[lk.x]) continue;
        const int i = lk.i, o = sq__lbm_opp[i];
        const int64_t dst = parity == 0 ? (int64_t)i * S + lk.x : (int64_t)o * S + lk.x - l->off[i];
        const int64_t bb = parity == 0 ? (int64_t)o * S + lk.x - l->off[i] : (int64_t)i * S + lk.x;
        float v;
        if (lk.kind == SQ_LBM_LINK_WALL) {
            v = F[bb] + lk.extra;
        } else if (lk.kind == SQ_LBM_LINK_COPY) {
            if (solid[lk.src]) {
                v = F[bb];
            } else {
                const int r = lk.r;
                const int64_t src = parity == 0 ? (int64_t)r * S + lk.src + l->off[r]
                                                : (int64_t)sq__lbm_opp[r] * S + lk.src;
                v = F[src];
            }
        } else {
            /* the equilibrium the inflow cell was just reset to, entering from outside */
            const double s = (double)l->inflow_shape[lk.src];
            const double u[3] = {s * l->inflow_u[0], s * l->inflow_u[1], s * l->inflow_u[2]};
            const double usq = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
            const double cu =
                sq__lbm_c[i][0] * u[0] + sq__lbm_c[i][1] * u[1] + sq__lbm_c[i][2] * u[2];
            v = (float)(sq__lbm_w[i] * (3.0 * cu + 4.5 * cu * cu - 1.5 * usq));
        }
        F[dst] = v;
    }
}

/* After the populations were set directly in the natural layout (init_fields, injections),
 * makes the ghost layer consistent with them so that the boundary pass reproduces a sensible
 * state: on periodic axes the fold is undone (ghost = the opposite interior layer), so the fold
 * that follows is the identity; beyond non-periodic faces each ghost slot holds what its edge
 * cell would emit (its own f_r). */
void sq__lbm_prime_ghosts(sq_lbm *l)
{
    const int n[3] = {l->nx, l->ny, l->nz};
    float *const F = l->f;
    const int64_t S = l->stride;
    /* periodic axes first: the non-periodic slots written below include corner ghosts that
     * the unfold's padded ranges would otherwise overwrite */
    for (int a = 0; a < 3; a++) {
        /* slab faces: their fold is made right after each odd step; nothing to undo */
        if (!l->periodic[a] || (a == 2 && l->zdist)) continue;
        int lo[3], hi[3];
        for (int b = 0; b < 3; b++) {
            lo[b] = b < a ? -1 : 0;
            hi[b] = b < a ? n[b] + 1 : n[b];
        }
        for (int j = 1; j < SQ_LBM_Q; j++) {
            const int cj = sq__lbm_c[j][a];
            if (cj == 0) continue;
            const int dst = cj > 0 ? n[a] : -1, src = cj > 0 ? 0 : n[a] - 1;
            float *const fj = F + (int64_t)j * S;
            const int b1 = a == 0 ? 1 : 0, b2 = a == 2 ? 1 : 2; /* the other two axes */
            for (int u = lo[b2]; u < hi[b2]; u++)
                for (int v = lo[b1]; v < hi[b1]; v++) {
                    int pd[3], ps[3];
                    pd[b1] = ps[b1] = v;
                    pd[b2] = ps[b2] = u;
                    pd[a] = dst;
                    ps[a] = src;
                    fj[sq__lbm_cell(l, pd[0], pd[1], pd[2])] =
                        fj[sq__lbm_cell(l, ps[0], ps[1], ps[2])];
                }
        }
    }
    /* slab faces: as a periodic axis, unfolded (the neighbours' edge planes into the ghost
     * planes, the exchange made before an odd step) ... */
    if (l->zdist) sq__lbm_z_exchange(l, SQ_LBM_Z_FILL);
    for (int z = 0; z < n[2]; z++)
        for (int y = 0; y < n[1]; y++)
            for (int x = 0; x < n[0]; x++) {
                const int p[3] = {x, y, z};
                if (!(x == 0 || y == 0 || z == 0 || x == n[0] - 1 || y == n[1] - 1 ||
                      z == n[2] - 1))
                    continue;
                const int64_t c = sq__lbm_cell(l, x, y, z);
                for (int r = 1; r < SQ_LBM_Q; r++) {
                    bool out = false;
                    for (int a = 0; a < 3; a++) {
                        const int q = p[a] + sq__lbm_c[r][a];
                        if ((q < 0 || q >= n[a]) && !sq__lbm_face_joined(l, a, q >= n[a]))
                            out = true;
                    }
                    if (out) F[(int64_t)r * S + c + l->off[r]] = F[(int64_t)r * S + c];
                }
            }
    /* ... then folded at once, which carries what the edge cells emit across the faces of
     * other axes in the ghost planes onto the neighbours' edge planes */
    if (l->zdist) sq__lbm_z_exchange(l, SQ_LBM_Z_FOLD);
}
