/* grid_project.c — pressure projection on the MAC grid (SPEC §1.4, eqs 2.7–2.8):
 *     A phi = -h (div u*) h,    u = u* - grad phi,    phi = p dt / rho  (m^2/s),
 * where (A phi)_c = sum over the cell's links of coef * (phi_c - phi_nb): coef 1 between fluid
 * cells, 0 against solid cells and walls (dp/dn = 0), 2 towards an outflow/open face (p = 0 on
 * the face, half a cell away). Closed fluid regions get one pinned cell (see grid.c).
 *
 * Solvers:
 *  - MGPCG (default): flexible (Polak-Ribiere) conjugate gradients preconditioned by one
 *    multigrid V-cycle;
 *  - MULTIGRID: plain V-cycles;
 *  - JACOBI: the thesis's fixed sweep count (S0 uses 40), for comparison.
 * Multigrid: cell-centred, coarsening by 2 on every axis longer than 2 cells (ceil(n/2): odd
 * sizes end with a one-cell block, so any size >= 4 works; sizes divisible by 8 coarsen
 * cleanly), restriction = sum of the children, prolongation = trilinear (orders 1 + 2 > 2, the
 * condition for grid-independent V-cycle convergence on cell-centred grids; the coarse
 * correction is first extended into solid cells by their fluid neighbours' mean and into
 * ghosts by mirroring: + for walls, - for p = 0 faces), coarse operator = rediscretisation by
 * aggregation (coarse link = sum of the fine links across the coarse face / block length,
 * which is the standard 7-point operator for uniform blocks and follows solids and open
 * faces), red-black Gauss-Seidel smoothing (red-black before, black-red after), a few
 * symmetric sweeps on the <= 2x2x2 coarsest grid. The finest grid keeps one byte per cell (the
 * diagonal) and no link coefficients: its vectors are zero in solid cells and non-periodic
 * ghosts, so closed links and links to p = 0 faces add nothing to the plain 7-point sums (see
 * nbsum0). Level-0 kernels are branch-free row loops (vectorised; a red-black half-sweep
 * updates the whole row and keeps its colour's cells); reductions are per-plane sums of
 * 8-lane partial sums, added in plane order. */
#include <string.h>

#include "solvers/grid/grid_internal.h"

#define MOD "grid"
#define COARSEST_SWEEPS 8

static const float inv_lut[16] = {0.0f,        1.0f,        1.0f / 2.0f,  1.0f / 3.0f,
                                  1.0f / 4.0f, 1.0f / 5.0f, 1.0f / 6.0f,  1.0f / 7.0f,
                                  1.0f / 8.0f, 1.0f / 9.0f, 1.0f / 10.0f, 1.0f / 11.0f,
                                  1.0f / 12.0f, 1.0f / 13.0f, 1.0f / 14.0f, 1.0f / 15.0f};

/* ---- hierarchy ------------------------------------------------------------------------------ */
static int coarsen(const int nf[3], int nc[3], int b[3])
{
    int any = 0;
    for (int a = 0; a < 3; a++) {
        b[a] = nf[a] > 2 ? 2 : 1;
        nc[a] = (nf[a] + b[a] - 1) / b[a];
        any |= b[a] == 2;
    }
    return any;
}

static uint64_t padded3(const int n[3])
{
    return (uint64_t)(n[0] + 2) * (uint64_t)(n[1] + 2) * (uint64_t)(n[2] + 2);
}

uint64_t sq__grid_multigrid_bytes(const int n[3])
{
    int nf[3] = {n[0], n[1], n[2]}, nc[3], b[3];
    uint64_t bytes = 0;
    for (int l = 1; l < SQ__MG_MAX_LEVELS && coarsen(nf, nc, b); l++) {
        bytes += padded3(nc) * 8 * sizeof(float);
        memcpy(nf, nc, sizeof nf);
    }
    return bytes;
}

void sq__grid_free_multigrid(sq_grid *g)
{
    for (int l = 1; l < SQ__MG_MAX_LEVELS; l++) {
        sq__mg_level *L = &g->mg[l];
        sq_free(g->ctx, L->x);
        sq_free(g->ctx, L->rhs);
        sq_free(g->ctx, L->res);
        for (int a = 0; a < 3; a++) sq_free(g->ctx, L->c[a]);
        sq_free(g->ctx, L->inv_diag);
        sq_free(g->ctx, L->ext_w);
        memset(L, 0, sizeof *L);
    }
    g->mg_levels = 0;
}

static inline ptrdiff_t lidx(const sq__mg_level *L, int i, int j, int k)
{
    return (ptrdiff_t)(i + 1) + (ptrdiff_t)(j + 1) * L->sy + (ptrdiff_t)(k + 1) * L->sz;
}

static sq_result alloc_levels(sq_grid *g)
{
    sq__mg_level *L0 = &g->mg[0];
    for (int a = 0; a < 3; a++) L0->n[a] = g->n[a];
    L0->sy = g->sy;
    L0->sz = g->sz;
    L0->count = g->cell_count;
    int n0[3], lo[3]; /* a decomposed grid's coarse levels are the whole grid's (grid_dist.c) */
    sq__grid_dist_frame(g, n0, lo);
    int l = 1;
    for (; l < SQ__MG_MAX_LEVELS; l++) {
        sq__mg_level *L = &g->mg[l];
        if (!coarsen(l == 1 ? n0 : g->mg[l - 1].n, L->n, L->b)) break;
        L->sy = L->n[0] + 2;
        L->sz = L->sy * (L->n[1] + 2);
        L->count = (size_t)padded3(L->n);
        const size_t bytes = L->count * sizeof(float);
        L->x = (float *)sq_alloc_zero(g->ctx, bytes);
        L->rhs = (float *)sq_alloc_zero(g->ctx, bytes);
        L->res = (float *)sq_alloc_zero(g->ctx, bytes);
        for (int a = 0; a < 3; a++) L->c[a] = (float *)sq_alloc_zero(g->ctx, bytes);
        L->inv_diag = (float *)sq_alloc_zero(g->ctx, bytes);
        L->ext_w = (float *)sq_alloc_zero(g->ctx, bytes);
        if (!L->x || !L->rhs || !L->res || !L->c[0] || !L->c[1] || !L->c[2] || !L->inv_diag ||
            !L->ext_w)
            return SQ_ERR_OUT_OF_MEMORY;
    }
    g->mg_levels = l;
    return SQ_OK;
}

/* Link coefficient of the finer level f between cell (i,j,k) and its +e_a neighbour (i may be
 * -1 along a: the link across the low boundary). Level 0 derives it from the cell flags. */
/* Level 0 in a decomposed grid: turns the global fine cell x into the slab's local index and
 * says whether this slab holds it (low: the axis whose index -1, the link across the global
 * low boundary, belongs to the first slab; -1 for none). Other slabs' links count 0 here and
 * are summed over the ranks (sq__grid_build_multigrid). */
static bool held0(const sq_grid *g, int x[3], int low)
{
    int n0[3], lo[3];
    sq__grid_dist_frame(g, n0, lo);
    for (int d = 0; d < 3; d++) {
        x[d] -= lo[d];
        if (x[d] >= g->n[d]) return false;
        if (x[d] < 0 && !(d == low && x[d] == -1 && lo[d] == 0)) return false;
    }
    return true;
}

static float fine_link(const sq_grid *g, int l, int a, int i, int j, int k)
{
    if (l == 0) {
        int x[3] = {i, j, k};
        if (!held0(g, x, a)) return 0.0f;
        i = x[0];
        j = x[1];
        k = x[2];
        ptrdiff_t c = sq__cidx(g, i, j, k);
        const ptrdiff_t st[3] = {1, g->sy, g->sz};
        return (float)sq__link_coef(g->flags[c], g->flags[c + st[a]]);
    }
    const sq__mg_level *L = &g->mg[l];
    return L->c[a][lidx(L, i, j, k)];
}

static float fine_reaction(const sq_grid *g, int l, int i, int j, int k)
{
    if (l == 0) {
        int x[3] = {i, j, k};
        if (!held0(g, x, -1)) return 0.0f;
        return (g->links[sq__cidx(g, x[0], x[1], x[2])] & 0x40) ? 1.0f : 0.0f;
    }
    const sq__mg_level *L = &g->mg[l];
    return L->res[lidx(L, i, j, k)];
}

sq_result sq__grid_build_multigrid(sq_grid *g)
{
    if (g->mg_levels == 0) {
        sq_result r = alloc_levels(g);
        if (r != SQ_OK) {
            sq__grid_free_multigrid(g);
            return sq__fail(g->ctx, r, MOD, "out of memory building the multigrid hierarchy");
        }
    }
    int n0[3], lo[3];
    sq__grid_dist_frame(g, n0, lo);
    for (int l = 1; l < g->mg_levels; l++) {
        sq__mg_level *L = &g->mg[l];
        const sq__mg_level *F = &g->mg[l - 1];
        const int *fn = l == 1 ? n0 : F->n; /* the finer level's (global) cells */
        for (int a = 0; a < 3; a++) memset(L->c[a], 0, L->count * sizeof(float));
        memset(L->res, 0, L->count * sizeof(float));
        memset(L->x, 0, L->count * sizeof(float));
        memset(L->rhs, 0, L->count * sizeof(float));
        /* links: for coarse cell I along a in -1..n-1, the fine interface lies between fine
         * cell min(b I + b - 1, nf - 1) (or -1) and the next one */
        for (int a = 0; a < 3; a++) {
            const int ta = a == 0 ? 1 : 0, tb = a == 2 ? 1 : 2;
            for (int K = 0; K < L->n[tb]; K++)
                for (int J = 0; J < L->n[ta]; J++)
                    for (int I = -1; I < L->n[a]; I++) {
                        int fi = I < 0 ? -1 : L->b[a] * I + L->b[a] - 1;
                        if (fi > fn[a] - 1) fi = fn[a] - 1;
                        double sum = 0.0;
                        for (int q = L->b[tb] * K; q < L->b[tb] * K + L->b[tb] && q < fn[tb]; q++)
                            for (int p = L->b[ta] * J; p < L->b[ta] * J + L->b[ta] && p < fn[ta];
                                 p++) {
                                int x[3];
                                x[a] = fi;
                                x[ta] = p;
                                x[tb] = q;
                                sum += (double)fine_link(g, l - 1, a, x[0], x[1], x[2]);
                            }
                        int X[3];
                        X[a] = I;
                        X[ta] = J;
                        X[tb] = K;
                        L->c[a][lidx(L, X[0], X[1], X[2])] = (float)(sum / L->b[a]);
                    }
        }
        /* reaction (pins) */
        for (int K = 0; K < L->n[2]; K++)
            for (int J = 0; J < L->n[1]; J++)
                for (int I = 0; I < L->n[0]; I++) {
                    double react = 0.0;
                    for (int k = L->b[2] * K; k < L->b[2] * (K + 1) && k < fn[2]; k++)
                        for (int j = L->b[1] * J; j < L->b[1] * (J + 1) && j < fn[1]; j++)
                            for (int i = L->b[0] * I; i < L->b[0] * (I + 1) && i < fn[0]; i++)
                                react += (double)fine_reaction(g, l - 1, i, j, k);
                    L->res[lidx(L, I, J, K)] = (float)react;
                }
        /* a decomposed grid: every slab added its own links and pins (small integers over
         * b: exact in float) */
        if (l == 1)
            for (int a = 0; a < 4; a++) sq__grid_dist_sum_f32(g, a < 3 ? L->c[a] : L->res, L->count);
        /* the diagonal */
        for (int K = 0; K < L->n[2]; K++)
            for (int J = 0; J < L->n[1]; J++)
                for (int I = 0; I < L->n[0]; I++) {
                    ptrdiff_t c = lidx(L, I, J, K);
                    const double react = L->res[c];
                    double diag = react + (double)L->c[0][c] + (double)L->c[0][c - 1] +
                                  (double)L->c[1][c] + (double)L->c[1][c - L->sy] +
                                  (double)L->c[2][c] + (double)L->c[2][c - L->sz];
                    L->inv_diag[c] = diag > 1e-12 ? (float)(1.0 / diag) : 0.0f;
                }
    }
    /* the reaction terms were kept in res only while building */
    for (int l = 1; l < g->mg_levels; l++) {
        sq__mg_level *L = &g->mg[l];
        memset(L->res, 0, L->count * sizeof(float));
        memset(L->ext_w, 0, L->count * sizeof(float));
        for (int k = 0; k < L->n[2]; k++)
            for (int j = 0; j < L->n[1]; j++)
                for (int i = 0; i < L->n[0]; i++) {
                    const ptrdiff_t c = lidx(L, i, j, k);
                    if (L->inv_diag[c] != 0.0f) continue;
                    int m = 0;
                    const int x[3] = {i, j, k};
                    const ptrdiff_t st[3] = {1, L->sy, L->sz};
                    for (int a = 0; a < 3; a++) {
                        if (x[a] > 0 && L->inv_diag[c - st[a]] != 0.0f) m++;
                        if (x[a] < L->n[a] - 1 && L->inv_diag[c + st[a]] != 0.0f) m++;
                    }
                    L->ext_w[c] = m ? 1.0f / (float)m : 0.0f;
                }
    }
    return SQ_OK;
}

/* ---- shared helpers -------------------------------------------------------------------------- */
static void exchange(const sq_grid *g, float *o, const int n[3], ptrdiff_t sy, ptrdiff_t sz)
{
    const ptrdiff_t st[3] = {1, sy, sz};
    for (int a = 0; a < 3; a++) {
        if (!g->periodic[a]) continue;
        const int ta = a == 0 ? 1 : 0, tb = a == 2 ? 1 : 2;
        for (int q = -1; q <= n[tb]; q++)
            for (int p = -1; p <= n[ta]; p++) {
                float *row = o + (ptrdiff_t)p * st[ta] + (ptrdiff_t)q * st[tb];
                row[-st[a]] = row[(ptrdiff_t)(n[a] - 1) * st[a]];
                row[(ptrdiff_t)n[a] * st[a]] = row[0];
            }
    }
}

static bool any_periodic(const sq_grid *g)
{
    return g->periodic[0] || g->periodic[1] || g->periodic[2];
}

/* After level-0 array x (padded base) changed: its periodic ghosts and, in a decomposed grid,
 * the ghosts of the inner faces (grid_dist.c; collective). */
static void sync0(sq_grid *g, float *x)
{
    if (any_periodic(g)) exchange(g, x + sq__cidx(g, 0, 0, 0), g->n, g->sy, g->sz);
    sq__grid_halo_cells(g, x, sizeof(float));
}

/* Per-plane partial sums of slots 0 and 1 (n = 1 or 2), over every rank of a decomposed grid. */
static void sum_planes(sq_grid *g, int n, double *out)
{
    for (int s = 0; s < n; s++) out[s] = sq__grid_sum_planes(g, s);
    sq__grid_dist_sum(g, out, n);
}

static double sum_plane0(sq_grid *g)
{
    double v;
    sum_planes(g, 1, &v);
    return v;
}

/* origin of cell (0,0,0) inside a padded level array */
static float *org(const sq__mg_level *L, float *base) { return base + lidx(L, 0, 0, 0); }

/* ---- level 0 (byte links) ---------------------------------------------------------------------- */
/* Sum of the 6 neighbours. Level-0 vectors are kept zero in solid cells and in the ghost cells
 * of non-periodic faces (the smoother writes 0 into solid cells, the work vectors start zeroed,
 * the pressure's ghosts are cleared before each solve and refilled after it; periodic ghosts
 * are copies), so the closed links (coefficient 0: solids, walls) and the links to p = 0 faces
 * (coefficient 2, counted in the diagonal only) contribute 0 without a mask. */
static inline float nbsum0(const float *x, ptrdiff_t c, ptrdiff_t sy, ptrdiff_t sz)
{
    return ((x[c - 1] + x[c + 1]) + (x[c - sy] + x[c + sy])) + (x[c - sz] + x[c + sz]);
}

/* 1 / diag (0 for a solid cell), the same value as inv_lut[d] */
static inline float inv_diag0(uint8_t d)
{
    const float inv = 1.0f / (float)(d + (d == 0)); /* no division by zero */
    return sq__fsel(d != 0, inv, 0.0f);
}

enum { ROW = 256 }; /* row chunk of the level-0 kernels */

/* One half-sweep of plane k of x (padded, level-0 layout): the cells of one colour (i+j+k+par0
 * even: par0 = 0 red) get x = (b + sum of neighbours) / diag. from_zero: x = 0 before the sweep
 * (neighbours are not read; the other colour is written by the next half-sweep). Returns sum
 * b.x over the plane's rows when dot (b = 0 in solid cells). */
static double smooth_plane(const sq_grid *g, float *x, const float *b, int k, int par0,
                           bool from_zero, bool dot)
{
    const int nx = g->n[0], ny = g->n[1];
    const ptrdiff_t sy = g->sy, sz = g->sz;
    const uint8_t *dg = g->diag;
    double acc = 0.0;
    float t[ROW];
    for (int j = 0; j < ny; j++) {
        const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
        const int par = (j + k + par0) & 1; /* cells with (i & 1) == par are updated */
        /* every cell of the row is computed (contiguous, vectorised) and this colour's cells
         * are kept: the other colour's values are what this colour reads */
        for (int i0 = 0; i0 < nx; i0 += ROW) {
            const int n = nx - i0 < ROW ? nx - i0 : ROW;
            const ptrdiff_t c0 = r0 + i0;
            float *xr = x + c0;
            if (from_zero) {
                for (int q = 0; q < n; q++)
                    xr[q] = sq__fsel(((i0 + q) & 1) == par, inv_diag0(dg[c0 + q]) * b[c0 + q],
                                     xr[q]);
            } else {
                for (int q = 0; q < n; q++) {
                    const ptrdiff_t c = c0 + q;
                    t[q] = inv_diag0(dg[c]) * (b[c] + nbsum0(x, c, sy, sz));
                }
                for (int q = 0; q < n; q++) xr[q] = sq__fsel(((i0 + q) & 1) == par, t[q], xr[q]);
            }
        }
        if (dot) acc += (double)sq__dotf(b + r0, x + r0, nx);
    }
    return acc;
}

/* x red (colour 0: i+j+k even) or black half-sweep. from_zero: the first half-sweep of a
 * V-cycle started from x = 0. dot: if not NULL, receives sum b.x over all cells after the
 * update (per plane, in plane order). */
static void smooth0_ex(sq_grid *g, float *x, const float *b, int colour, bool from_zero,
                       double *dot)
{
    const int nz = g->n[2];
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    double *ps = g->plane_sum;
    colour ^= sq__grid_dist_parity(g); /* a slab's colours follow the global cell index */
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++) ps[4 * k] = smooth_plane(g, x, b, k, colour, from_zero, dot != NULL);
    sync0(g, x);
    if (dot) *dot = sum_plane0(g);
}

/* Two half-sweeps, colour then the other colour, in one pass over memory: the second colour of
 * plane k - 1 follows the first of plane k (it reads the first colour of planes k - 2 .. k, all
 * final, and the first colour of plane k has read plane k - 1's second colour before it
 * changed), so each plane is still in the cache for its second half-sweep. The planes next to
 * another thread's chunk take their second half-sweep after a barrier. The same arithmetic in
 * the same order per cell as two smooth0_ex calls: bit-identical. Only for a grid whose
 * half-sweeps need no ghost exchange in between (no periodic axis, not decomposed); otherwise
 * it is the two calls. */
static void smooth0_pair(sq_grid *g, float *x, const float *b, int colour, bool from_zero,
                         double *dot)
{
    if (any_periodic(g) || g->halo != NULL) {
        smooth0_ex(g, x, b, colour, from_zero, NULL);
        smooth0_ex(g, x, b, colour ^ 1, false, dot);
        return;
    }
    const int nz = g->n[2];
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    const int nc = nt < nz / 4 ? nt : (nz / 4 > 1 ? nz / 4 : 1); /* chunks of >= 4 planes */
    double *ps = g->plane_sum;
    const bool want = dot != NULL;
    const int c1 = colour, c2 = colour ^ 1;
    SQ_OMP(omp parallel num_threads(nt))
    {
        SQ_OMP(omp for schedule(static))
        for (int t = 0; t < nc; t++) {
            const int k0 = (int)((int64_t)nz * t / nc), k1 = (int)((int64_t)nz * (t + 1) / nc);
            for (int k = k0; k < k1; k++) {
                smooth_plane(g, x, b, k, c1, from_zero, false);
                if (k - 1 > k0) ps[4 * (k - 1)] = smooth_plane(g, x, b, k - 1, c2, false, want);
            }
        }
        SQ_OMP(omp for schedule(static))
        for (int t = 0; t < nc; t++) { /* the chunk's end planes, after every first colour */
            const int k0 = (int)((int64_t)nz * t / nc), k1 = (int)((int64_t)nz * (t + 1) / nc);
            ps[4 * k0] = smooth_plane(g, x, b, k0, c2, false, want);
            if (k1 - 1 > k0) ps[4 * (k1 - 1)] = smooth_plane(g, x, b, k1 - 1, c2, false, want);
        }
    }
    if (dot) *dot = sum_plane0(g);
}

/* out = A x on fluid cells; returns sum x.out (per plane, in plane order) */
static double apply0(sq_grid *g, const float *x, float *out)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const ptrdiff_t sy = g->sy, sz = g->sz;
    const uint8_t *dg = g->diag;
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    double *ps = g->plane_sum;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++) {
        double acc = 0.0;
        for (int j = 0; j < ny; j++) {
            const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
            for (int i = 0; i < nx; i++) {
                const ptrdiff_t c = r0 + i;
                const float a = (float)dg[c] * x[c] - nbsum0(x, c, sy, sz);
                out[c] = sq__fsel(dg[c] != 0, a, 0.0f);
            }
            acc += (double)sq__dotf(out + r0, x + r0, nx); /* out = 0 in solid cells */
        }
        ps[4 * k] = acc;
    }
    return sum_plane0(g);
}

/* Fine residual b - A x summed over each coarse cell of level 1 into its rhs. A decomposed
 * grid's level 1 is the whole grid's: the slab (at global offset lo along x or y; z is never
 * split) adds its cells' residuals and the ranks sum the level (grid_dist.c). */
static void restrict0(sq_grid *g, const float *x, const float *b)
{
    sq__mg_level *C = &g->mg[1];
    const ptrdiff_t sy = g->sy, sz = g->sz;
    const uint8_t *dg = g->diag;
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    int n0[3], lo[3];
    sq__grid_dist_frame(g, n0, lo);
    const bool whole = g->halo == NULL;
    if (!whole) memset(C->rhs, 0, C->count * sizeof(float));
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int K = 0; K < C->n[2]; K++) {
        float t[ROW];
        if (whole)
            for (int J = 0; J < C->n[1]; J++) {
                float *cr = C->rhs + lidx(C, 0, J, K);
                for (int I = 0; I < C->n[0]; I++) cr[I] = 0.0f;
            }
        const int shx = C->b[0] - 1, shy = C->b[1] - 1; /* block 2: shift 1; block 1: 0 */
        const bool pairs = shx && !(lo[0] & 1); /* the slab's pairs are the coarse cells */
        for (int k = C->b[2] * K; k < C->b[2] * (K + 1) && k < nz; k++)
            for (int j = 0; j < ny; j++) {
                float *cr = C->rhs + lidx(C, 0, (j + lo[1]) >> shy, K);
                const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
                for (int i0 = 0; i0 < nx; i0 += ROW) {
                    const int n = nx - i0 < ROW ? nx - i0 : ROW;
                    for (int q = 0; q < n; q++) {
                        const ptrdiff_t c = r0 + i0 + q;
                        const float r = b[c] - ((float)dg[c] * x[c] - nbsum0(x, c, sy, sz));
                        t[q] = sq__fsel(dg[c] != 0, r, 0.0f);
                    }
                    if (pairs) { /* ROW is even: pairs never straddle chunks */
                        float *cc = cr + ((i0 + lo[0]) >> 1);
                        for (int q = 0; q + 1 < n; q += 2) cc[q >> 1] += t[q] + t[q + 1];
                        if (n & 1) cc[(n - 1) >> 1] += t[n - 1];
                    } else {
                        for (int q = 0; q < n; q++) cr[(i0 + q + lo[0]) >> shx] += t[q];
                    }
                }
            }
    }
    if (!whole) sq__grid_dist_sum_f32(g, C->rhs, C->count);
}

/* Trilinear prolongation weights along one axis for fine index i: parent P, the nearer other
 * coarse cell N (may be a ghost) and its weight wN (the parent gets 1 - wN). */
static inline void pweights(int i, int b, int nf, int *P, int *N, float *wN)
{
    if (b == 1) {
        *P = *N = i;
        *wN = 0.0f;
        return;
    }
    const int p = i >> 1;
    *P = p;
    if (2 * p + 1 >= nf) { /* a one-cell block at the end of an odd axis */
        *N = p;
        *wN = 0.0f;
        return;
    }
    *N = (i & 1) ? p + 1 : p - 1;
    *wN = 0.25f;
}

/* Extends a coarse correction into cells the trilinear stencil may touch: solid cells take the
 * mean of their fluid neighbours (dp/dn = 0), domain ghosts mirror the boundary cell (walls),
 * mirror it with the opposite sign (p = 0 on the face) or wrap (periodic). */
static void extend(sq_grid *g, sq__mg_level *L)
{
    float *x = L->x;
    const ptrdiff_t st[3] = {1, L->sy, L->sz};
    for (int k = 0; k < L->n[2]; k++)
        for (int j = 0; j < L->n[1]; j++)
            for (int i = 0; i < L->n[0]; i++) {
                const ptrdiff_t c = lidx(L, i, j, k);
                const float w = L->ext_w[c];
                if (w == 0.0f) continue;
                const int xx[3] = {i, j, k};
                float s = 0.0f;
                for (int a = 0; a < 3; a++) {
                    if (xx[a] > 0 && L->inv_diag[c - st[a]] != 0.0f) s += x[c - st[a]];
                    if (xx[a] < L->n[a] - 1 && L->inv_diag[c + st[a]] != 0.0f) s += x[c + st[a]];
                }
                x[c] = w * s;
            }
    for (int a = 0; a < 3; a++) {
        const int ta = a == 0 ? 1 : 0, tb = a == 2 ? 1 : 2;
        for (int side = 0; side < 2; side++) {
            const sq_boundary bc = g->d.boundary[2 * a + side];
            const int gi = side ? L->n[a] : -1, bi = side ? L->n[a] - 1 : 0;
            const int src = bc == SQ_BOUNDARY_PERIODIC ? (side ? 0 : L->n[a] - 1) : bi;
            const float sg =
                (bc == SQ_BOUNDARY_OUTFLOW || bc == SQ_BOUNDARY_OPEN) ? -1.0f : 1.0f;
            for (int q = -1; q <= L->n[tb]; q++)
                for (int p = -1; p <= L->n[ta]; p++) {
                    float *row = x + lidx(L, 0, 0, 0) + (ptrdiff_t)p * st[ta] + (ptrdiff_t)q * st[tb];
                    row[(ptrdiff_t)gi * st[a]] = sg * row[(ptrdiff_t)src * st[a]];
                }
        }
    }
}

/* x_f += trilinear interpolation of the (extended) correction of level lf + 1, on the fluid
 * cells of level lf (level 0: diag > 0, else inv_diag > 0). xf: padded base of the fine x. */
static void prolong(sq_grid *g, int lf, float *xf)
{
    sq__mg_level *C = &g->mg[lf + 1];
    const sq__mg_level *F = &g->mg[lf];
    extend(g, C);
    const uint8_t *dg = lf == 0 ? g->diag : NULL;
    const float *id = lf == 0 ? NULL : F->inv_diag;
    const float *xc = C->x;
    const int nf0 = F->n[0], nf1 = F->n[1], nf2 = F->n[2];
    /* a decomposed grid's level 0 is its slab at offset lo inside the whole grid (n0 cells),
     * whose level 1 this is (see restrict0) */
    int n0[3] = {nf0, nf1, nf2}, lo[3] = {0, 0, 0};
    if (lf == 0) sq__grid_dist_frame(g, n0, lo);
    const int nt = F->count > 32768 ? sq_context_threads(g->ctx) : 1;
    (void)nt; /* unused without OpenMP */
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nf2; k++) {
        int Pz, Nz, Py, Ny, Px, Nx;
        float wz, wy, wx;
        float yz[ROW + 2];
        pweights(k + lo[2], C->b[2], n0[2], &Pz, &Nz, &wz);
        for (int j = 0; j < nf1; j++) {
            pweights(j + lo[1], C->b[1], n0[1], &Py, &Ny, &wy);
            const float *r00 = xc + lidx(C, 0, Py, Pz), *r10 = xc + lidx(C, 0, Ny, Pz),
                        *r01 = xc + lidx(C, 0, Py, Nz), *r11 = xc + lidx(C, 0, Ny, Nz);
            const ptrdiff_t f0 = (ptrdiff_t)(j + 1) * F->sy + (ptrdiff_t)(k + 1) * F->sz + 1;
            if (C->b[0] == 2 && !(nf0 & 1) && !(n0[0] & 1) && !(lo[0] & 1)) {
                const int h = lo[0] >> 1; /* the slab's first coarse cell */
                r00 += h;
                r10 += h;
                r01 += h;
                r11 += h;
                /* pairs of children: the y-z interpolated coarse row yz[I] (I from -1), then
                 * child 2I takes 3/4 yz[I] + 1/4 yz[I-1], child 2I+1 3/4 yz[I] + 1/4 yz[I+1] */
                const float w00 = (1.0f - wy) * (1.0f - wz), w10 = wy * (1.0f - wz),
                            w01 = (1.0f - wy) * wz, w11 = wy * wz;
                for (int I0 = 0; 2 * I0 < nf0; I0 += ROW) {
                    const int nI = (nf0 / 2 - I0) < ROW ? nf0 / 2 - I0 : ROW;
                    for (int q = 0; q < nI + 2; q++) {
                        const int I = I0 - 1 + q;
                        yz[q] = w00 * r00[I] + w10 * r10[I] + w01 * r01[I] + w11 * r11[I];
                    }
                    const ptrdiff_t c0 = f0 + 2 * I0;
                    for (int q = 0; q < nI; q++) {
                        const ptrdiff_t c = c0 + 2 * q;
                        const bool act0 = dg ? dg[c] != 0 : id[c] != 0.0f;
                        const bool act1 = dg ? dg[c + 1] != 0 : id[c + 1] != 0.0f;
                        xf[c] += sq__fsel(act0, 0.75f * yz[q + 1] + 0.25f * yz[q], 0.0f);
                        xf[c + 1] += sq__fsel(act1, 0.75f * yz[q + 1] + 0.25f * yz[q + 2], 0.0f);
                    }
                }
                continue;
            }
            for (int i = 0; i < nf0; i++) {
                const ptrdiff_t c = f0 + i;
                if (dg ? dg[c] == 0 : id[c] == 0.0f) continue;
                pweights(i + lo[0], C->b[0], n0[0], &Px, &Nx, &wx);
                float a00 = r00[Px] + wx * (r00[Nx] - r00[Px]);
                float a10 = r10[Px] + wx * (r10[Nx] - r10[Px]);
                float a01 = r01[Px] + wx * (r01[Nx] - r01[Px]);
                float a11 = r11[Px] + wx * (r11[Nx] - r11[Px]);
                float b0 = a00 + wy * (a10 - a00), b1 = a01 + wy * (a11 - a01);
                xf[c] += b0 + wz * (b1 - b0);
            }
        }
    }
}

/* ---- coarse levels (float links) ------------------------------------------------------------ */
static void smooth_c(sq_grid *g, sq__mg_level *L, int colour)
{
    const ptrdiff_t sy = L->sy, sz = L->sz;
    float *x = L->x;
    const float *b = L->rhs, *cx = L->c[0], *cy = L->c[1], *cz = L->c[2], *id = L->inv_diag;
    const int nt = L->count > 32768 ? sq_context_threads(g->ctx) : 1;
    (void)nt; /* unused without OpenMP */
    const int nx = L->n[0];
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < L->n[2]; k++) {
        float t[ROW];
        for (int j = 0; j < L->n[1]; j++) {
            const ptrdiff_t r0 = lidx(L, 0, j, k);
            const int par = (j + k + colour) & 1;
            /* the whole row (vectorised), this colour's cells kept (as smooth0_ex) */
            for (int i0 = 0; i0 < nx; i0 += ROW) {
                const int n = nx - i0 < ROW ? nx - i0 : ROW;
                const ptrdiff_t c0 = r0 + i0;
                for (int q = 0; q < n; q++) {
                    const ptrdiff_t c = c0 + q;
                    const float sm = b[c] + cx[c - 1] * x[c - 1] + cx[c] * x[c + 1] +
                                     cy[c - sy] * x[c - sy] + cy[c] * x[c + sy] +
                                     cz[c - sz] * x[c - sz] + cz[c] * x[c + sz];
                    t[q] = id[c] * sm;
                }
                float *xr = x + c0;
                for (int q = 0; q < n; q++) xr[q] = sq__fsel(((i0 + q) & 1) == par, t[q], xr[q]);
            }
        }
    }
    if (any_periodic(g)) exchange(g, org(L, L->x), L->n, sy, sz);
}

static void restrict_c(sq_grid *g, int l)
{
    sq__mg_level *F = &g->mg[l], *C = &g->mg[l + 1];
    const ptrdiff_t sy = F->sy, sz = F->sz;
    const float *x = F->x, *b = F->rhs, *cx = F->c[0], *cy = F->c[1], *cz = F->c[2],
                *id = F->inv_diag;
    const int nt = F->count > 32768 ? sq_context_threads(g->ctx) : 1;
    (void)nt; /* unused without OpenMP */
    const int nx = F->n[0];
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int K = 0; K < C->n[2]; K++) {
        float t[ROW];
        for (int J = 0; J < C->n[1]; J++) {
            float *cr = C->rhs + lidx(C, 0, J, K);
            for (int I = 0; I < C->n[0]; I++) cr[I] = 0.0f;
        }
        for (int k = C->b[2] * K; k < C->b[2] * (K + 1) && k < F->n[2]; k++)
            for (int j = 0; j < F->n[1]; j++) {
                const ptrdiff_t r0 = lidx(F, 0, j, k);
                float *cr = C->rhs + lidx(C, 0, j >> (C->b[1] - 1), K);
                const int shx = C->b[0] - 1;
                for (int i0 = 0; i0 < nx; i0 += ROW) {
                    const int n = nx - i0 < ROW ? nx - i0 : ROW;
                    /* residual of the row (0 in inactive cells), vectorised */
                    for (int q = 0; q < n; q++) {
                        const ptrdiff_t c = r0 + i0 + q;
                        const bool act = id[c] != 0.0f;
                        const float ax = x[c] / sq__fsel(act, id[c], 1.0f) -
                                         (cx[c - 1] * x[c - 1] + cx[c] * x[c + 1] +
                                          cy[c - sy] * x[c - sy] + cy[c] * x[c + sy] +
                                          cz[c - sz] * x[c - sz] + cz[c] * x[c + sz]);
                        t[q] = sq__fsel(act, b[c] - ax, 0.0f);
                    }
                    if (shx) { /* ROW is even: pairs never straddle chunks */
                        float *cc = cr + (i0 >> 1);
                        for (int q = 0; q + 1 < n; q += 2) cc[q >> 1] += t[q] + t[q + 1];
                        if (n & 1) cc[(n - 1) >> 1] += t[n - 1];
                    } else {
                        for (int q = 0; q < n; q++) cr[i0 + q] += t[q];
                    }
                }
            }
    }
}

static void prolong_c(sq_grid *g, int l)
{
    sq__mg_level *F = &g->mg[l];
    prolong(g, l, F->x);
    if (any_periodic(g)) exchange(g, org(F, F->x), F->n, F->sy, F->sz);
}

/* V-cycle on coarse level l >= 1 from a zero guess; adds the work done to *work (in units of
 * fine-grid sweeps). */
static void vcycle_c(sq_grid *g, int l, double *work)
{
    sq__mg_level *L = &g->mg[l];
    const double w = (double)(L->n[0] * L->n[1] * L->n[2]) /
                     ((double)g->n[0] * (double)g->n[1] * (double)g->n[2]);
    memset(L->x, 0, L->count * sizeof(float));
    if (l == g->mg_levels - 1) {
        for (int s = 0; s < COARSEST_SWEEPS; s++) {
            smooth_c(g, L, 0);
            smooth_c(g, L, 1);
        }
        for (int s = 0; s < COARSEST_SWEEPS; s++) {
            smooth_c(g, L, 1);
            smooth_c(g, L, 0);
        }
        *work += w * 2 * COARSEST_SWEEPS;
        return;
    }
    const int nu = g->d.smoothing_sweeps;
    for (int s = 0; s < nu; s++) {
        smooth_c(g, L, 0);
        smooth_c(g, L, 1);
    }
    restrict_c(g, l);
    vcycle_c(g, l + 1, work);
    prolong_c(g, l);
    for (int s = 0; s < nu; s++) {
        smooth_c(g, L, 1);
        smooth_c(g, L, 0);
    }
    *work += w * 2 * nu;
}

/* One V-cycle on level 0 improving x for A x = b (x is modified in place), or, from_zero,
 * computing x = M b from x = 0 (x need not be initialised). dot: if not NULL, receives b.x. */
static void vcycle0(sq_grid *g, float *x, const float *b, bool from_zero, double *dot,
                    sq_grid_project_stats *st)
{
    const int nu = g->d.smoothing_sweeps;
    /* an odd periodic axis couples same-coloured cells across the wrap: start from real zeros */
    bool clean = true;
    int n0[3], lo[3]; /* a decomposed grid: the whole grid's axes */
    sq__grid_dist_frame(g, n0, lo);
    sq__grid_dist_global_bc(g);
    for (int a = 0; a < 3; a++)
        if (g->periodic[a] && (n0[a] & 1)) clean = false;
    sq__grid_dist_global_bc(g);
    if (from_zero && !clean) {
        memset(x, 0, g->cell_count * sizeof(float));
        from_zero = false;
    }
    for (int s = 0; s < nu; s++) smooth0_pair(g, x, b, 0, from_zero && s == 0, NULL);
    if (g->mg_levels > 1) {
        restrict0(g, x, b);
        /* a decomposed grid: every rank cycles the whole coarse hierarchy (the global faces'
         * boundaries) and takes its slab's part of the correction */
        sq__grid_dist_global_bc(g);
        vcycle_c(g, 1, &st->work_units);
        prolong(g, 0, x);
        sq__grid_dist_global_bc(g);
        sync0(g, x);
    }
    for (int s = 0; s < nu; s++) smooth0_pair(g, x, b, 1, false, s == nu - 1 ? dot : NULL);
    st->fine_sweeps += 2 * nu;
    st->work_units += 2 * nu;
}

/* ---- right-hand side and correction ------------------------------------------------------------ */
/* b = -h * (flux difference) on fluid cells; r = b - A phi. Returns |b|^2, |r|^2 via out. */
static void rhs_and_residual(sq_grid *g, const float *phi, float *b, float *r, double *bb,
                             double *rr)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const ptrdiff_t sy = g->sy, sz = g->sz;
    const uint8_t *dg = g->diag;
    const sq_field3 *U = &g->vel[0], *V = &g->vel[1], *W = &g->vel[2];
    const float h = g->h;
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    double *ps = g->plane_sum;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++) {
        double sb = 0.0, sr = 0.0;
        for (int j = 0; j < ny; j++) {
            const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
            const float *u = sq_field3_at(U, 0, j, k), *v0 = sq_field3_at(V, 0, j, k),
                        *v1 = sq_field3_at(V, 0, j + 1, k), *w0 = sq_field3_at(W, 0, j, k),
                        *w1 = sq_field3_at(W, 0, j, k + 1);
            float tb[ROW];
            for (int i0 = 0; i0 < nx; i0 += ROW) {
                const int n = nx - i0 < ROW ? nx - i0 : ROW;
                for (int q = 0; q < n; q++) {
                    const int i = i0 + q;
                    const ptrdiff_t c = r0 + i;
                    const bool fluid = dg[c] != 0;
                    const float bv =
                        sq__fsel(fluid, -h * (u[i + 1] - u[i] + v1[i] - v0[i] + w1[i] - w0[i]), 0.0f);
                    const float rv = bv - ((float)dg[c] * phi[c] - nbsum0(phi, c, sy, sz));
                    tb[q] = bv;
                    r[c] = sq__fsel(fluid, rv, 0.0f);
                }
                if (b) memcpy(b + r0 + i0, tb, (size_t)n * sizeof(float));
                sb += (double)sq__dotf(tb, tb, n);
                sr += (double)sq__dotf(r + r0 + i0, r + r0 + i0, n);
            }
        }
        ps[4 * k] = sb;
        ps[4 * k + 1] = sr;
    }
    double s2[2];
    sum_planes(g, 2, s2);
    *bb = s2[0];
    *rr = s2[1];
}

static double residual_norm2(sq_grid *g, const float *phi, const float *b)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const ptrdiff_t sy = g->sy, sz = g->sz;
    const uint8_t *dg = g->diag;
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    double *ps = g->plane_sum;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++) {
        double acc = 0.0;
        for (int j = 0; j < ny; j++) {
            const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
            float racc = 0.0f;
            for (int i = 0; i < nx; i++) {
                const ptrdiff_t c = r0 + i;
                if (!dg[c]) continue;
                float rv = b[c] - ((float)dg[c] * phi[c] - nbsum0(phi, c, sy, sz));
                racc += rv * rv;
            }
            acc += (double)racc;
        }
        ps[4 * k] = acc;
    }
    return sum_plane0(g);
}

/* Clears the ghost layer of a level-0 array on every non-periodic face (see nbsum0). */
static void zero_ghosts(sq_grid *g, float *o)
{
    const ptrdiff_t st[3] = {1, g->sy, g->sz};
    for (int a = 0; a < 3; a++) {
        if (g->periodic[a]) continue;
        const int ta = a == 0 ? 1 : 0, tb = a == 2 ? 1 : 2;
        for (int side = 0; side < 2; side++) {
            const ptrdiff_t gi = (ptrdiff_t)(side ? g->n[a] : -1) * st[a];
            for (int q = -1; q <= g->n[tb]; q++)
                for (int p = -1; p <= g->n[ta]; p++)
                    o[gi + (ptrdiff_t)p * st[ta] + (ptrdiff_t)q * st[tb]] = 0.0f;
        }
    }
}

/* phi ghosts: p = 0 on outflow/open faces (ghost = -interior), periodic copies, else mirror. */
static void pressure_ghosts(sq_grid *g, float *phi)
{
    const ptrdiff_t st[3] = {1, g->sy, g->sz};
    for (int a = 0; a < 3; a++) {
        const int ta = a == 0 ? 1 : 0, tb = a == 2 ? 1 : 2;
        for (int side = 0; side < 2; side++) {
            const sq_boundary bc = g->d.boundary[2 * a + side];
            const int gi = side ? g->n[a] : -1, bi = side ? g->n[a] - 1 : 0;
            for (int q = -1; q <= g->n[tb]; q++)
                for (int p = -1; p <= g->n[ta]; p++) {
                    float *row = phi + sq__cidx(g, 0, 0, 0) + (ptrdiff_t)p * st[ta] +
                                 (ptrdiff_t)q * st[tb];
                    float v;
                    if (bc == SQ_BOUNDARY_PERIODIC)
                        v = row[(ptrdiff_t)(side ? 0 : g->n[a] - 1) * st[a]];
                    else if (bc == SQ_BOUNDARY_OUTFLOW || bc == SQ_BOUNDARY_OPEN)
                        v = -row[(ptrdiff_t)bi * st[a]];
                    else
                        v = row[(ptrdiff_t)bi * st[a]];
                    row[(ptrdiff_t)gi * st[a]] = v;
                }
        }
    }
}

/* u -= grad phi / h on every free face (both cells fluid or an outflow/open ghost). */
static void correct_velocity(sq_grid *g, const float *phi)
{
    const uint8_t *fl = g->flags;
    const float ih = 1.0f / g->h;
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    for (int c = 0; c < 3; c++) {
        sq_field3 *f = &g->vel[c];
        const ptrdiff_t off = c == 0 ? 1 : c == 1 ? g->sy : g->sz;
        const int mx = f->n.nx, my = f->n.ny, mz = f->n.nz;
        SQ_OMP(omp parallel for schedule(static) num_threads(nt))
        for (int k = 0; k < mz; k++)
            for (int j = 0; j < my; j++) {
                float *u = sq_field3_at(f, 0, j, k);
                const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
                for (int i = 0; i < mx; i++) {
                    const ptrdiff_t hi = r0 + i, lo = hi - off;
                    const bool fixed = ((fl[lo] | fl[hi]) & SQ__CF_FIXED) != 0;
                    u[i] = sq__fsel(fixed, u[i], u[i] - (phi[hi] - phi[lo]) * ih);
                }
            }
    }
}

/* ---- solvers ----------------------------------------------------------------------------------- */
static float *cell_scratch(sq_grid *g, int s)
{
    return g->scratch[s];
}

static void solve_pcg(sq_grid *g, float *phi, sq_grid_project_stats *st)
{
    float *r = cell_scratch(g, 0), *z = cell_scratch(g, 1), *d = cell_scratch(g, 2),
          *q = cell_scratch(g, 3);
    const size_t n = g->cell_count;
    double bb, rr;
    rhs_and_residual(g, phi, NULL, r, &bb, &rr);
    if (rr > bb) { /* the warm start is worse than zero */
        memset(phi, 0, n * sizeof(float));
        rhs_and_residual(g, phi, NULL, r, &bb, &rr);
    }
    const double bn = sqrt(bb), tol = g->d.tolerance * bn;
    st->initial_residual = bn > 0.0 ? sqrt(rr) / bn : 0.0;
    st->residual = st->initial_residual;
    if (bn == 0.0) {
        memset(phi, 0, n * sizeof(float));
        st->converged = true;
        return;
    }
    if (sqrt(rr) <= tol) {
        st->converged = true;
        return;
    }
    /* ghosts and solid cells of the work vectors must hold finite values */
    memset(z, 0, n * sizeof(float)); /* d is a copy of z below; q = A d is written whole */
    double rho;
    vcycle0(g, z, r, true, &rho, st);
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    double *ps = g->plane_sum;
    memcpy(d, z, n * sizeof(float)); /* d = z (ghosts included) */
    for (int it = 0; it < g->d.max_iterations; it++) {
        const double dq = apply0(g, d, q);
        if (!(dq > 0.0)) break;
        const float alpha = (float)(rho / dq);
        /* phi += alpha d, r -= alpha q; also |r|^2 and r.z_old for the flexible beta */
        SQ_OMP(omp parallel for schedule(static) num_threads(nt))
        for (int k = 0; k < nz; k++) {
            double acc = 0.0, acz = 0.0;
            for (int j = 0; j < ny; j++) {
                const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
                for (int i = 0; i < nx; i++) {
                    const ptrdiff_t c = r0 + i;
                    phi[c] += alpha * d[c];
                    r[c] -= alpha * q[c];
                }
                acc += (double)sq__dotf(r + r0, r + r0, nx);
                acz += (double)sq__dotf(r + r0, z + r0, nx);
            }
            ps[4 * k] = acc;
            ps[4 * k + 1] = acz;
        }
        double s2[2];
        sum_planes(g, 2, s2);
        rr = s2[0];
        const double rz_old = s2[1];
        st->iterations = it + 1;
        st->residual = sqrt(rr) / bn;
        if (sqrt(rr) <= tol) {
            st->converged = true;
            break;
        }
        if (it + 1 >= g->d.max_iterations) break;
        double rho_new;
        vcycle0(g, z, r, true, &rho_new, st);
        /* Polak-Ribiere (flexible) beta: the V-cycle is only nearly symmetric */
        double bta = (rho_new - rz_old) / rho;
        const float beta = (float)(bta > 0.0 ? bta : 0.0);
        rho = rho_new;
        SQ_OMP(omp parallel for schedule(static) num_threads(nt))
        for (int k = 0; k < nz; k++)
            for (int j = 0; j < ny; j++) {
                const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
                for (int i = 0; i < nx; i++) d[r0 + i] = z[r0 + i] + beta * d[r0 + i];
            }
        sync0(g, d);
    }
}

static void solve_multigrid(sq_grid *g, float *phi, sq_grid_project_stats *st)
{
    float *b = cell_scratch(g, 0), *r = cell_scratch(g, 1);
    double bb, rr;
    rhs_and_residual(g, phi, b, r, &bb, &rr);
    if (rr > bb) {
        memset(phi, 0, g->cell_count * sizeof(float));
        rr = bb;
    }
    const double bn = sqrt(bb), tol = g->d.tolerance * bn;
    st->initial_residual = bn > 0.0 ? sqrt(rr) / bn : 0.0;
    st->residual = st->initial_residual;
    if (bn == 0.0) {
        memset(phi, 0, g->cell_count * sizeof(float));
        st->converged = true;
        return;
    }
    if (sqrt(rr) <= tol) {
        st->converged = true;
        return;
    }
    for (int it = 0; it < g->d.max_iterations; it++) {
        vcycle0(g, phi, b, false, NULL, st);
        rr = residual_norm2(g, phi, b);
        st->iterations = it + 1;
        st->residual = sqrt(rr) / bn;
        if (sqrt(rr) <= tol) {
            st->converged = true;
            break;
        }
    }
}

static void solve_jacobi(sq_grid *g, float *phi, sq_grid_project_stats *st)
{
    float *b = cell_scratch(g, 0), *r = cell_scratch(g, 1), *tmp = cell_scratch(g, 2);
    double bb, rr;
    rhs_and_residual(g, phi, b, r, &bb, &rr);
    const double bn = sqrt(bb);
    st->initial_residual = bn > 0.0 ? sqrt(rr) / bn : 0.0;
    if (bn == 0.0) {
        memset(phi, 0, g->cell_count * sizeof(float));
        st->residual = 0.0;
        st->converged = true;
        return;
    }
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const ptrdiff_t sy = g->sy, sz = g->sz;
    const uint8_t *dg = g->diag;
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    memcpy(tmp, phi, g->cell_count * sizeof(float));
    float *src = phi, *dst = tmp;
    for (int it = 0; it < g->d.jacobi_iterations; it++) {
        SQ_OMP(omp parallel for schedule(static) num_threads(nt))
        for (int k = 0; k < nz; k++)
            for (int j = 0; j < ny; j++) {
                const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
                for (int i = 0; i < nx; i++) {
                    const ptrdiff_t c = r0 + i;
                    dst[c] = inv_lut[dg[c]] * (b[c] + nbsum0(src, c, sy, sz));
                }
            }
        sync0(g, dst);
        float *t = src;
        src = dst;
        dst = t;
    }
    if (src != phi) memcpy(phi, src, g->cell_count * sizeof(float));
    st->iterations = g->d.jacobi_iterations;
    st->fine_sweeps = g->d.jacobi_iterations;
    st->work_units = g->d.jacobi_iterations;
    rr = residual_norm2(g, phi, b);
    st->residual = sqrt(rr) / bn;
    st->converged = st->residual <= g->d.tolerance;
}

sq_result sq__grid_project(sq_grid *g, float dt, sq_grid_project_stats *st)
{
    memset(st, 0, sizeof *st);
    sq__grid_dist_batch_begin(g); /* a decomposed grid: faces between slabs agree, and the */
    sq__grid_dist_sync_faces(g);  /* ghost planes: one message */
    sq__grid_enforce_velocity_ex(g, true);
    sq__grid_dist_batch_end(g);
    float *phi = g->p.base; /* padded, level-0 layout */
    const size_t n = g->cell_count;
    /* warm start: phi = p dt from the previous step */
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    const int planes = g->n[2] + 2;
    const ptrdiff_t sz = g->sz;
    if (g->d.cold_start) {
        memset(phi, 0, n * sizeof(float));
    } else {
        SQ_OMP(omp parallel for schedule(static) num_threads(nt))
        for (int k = 0; k < planes; k++)
            for (ptrdiff_t c = k * sz; c < (k + 1) * sz; c++) phi[c] *= dt;
    }
    zero_ghosts(g, g->p.origin);
    sync0(g, phi);
    switch (g->d.pressure) {
    case SQ_PRESSURE_JACOBI: solve_jacobi(g, phi, st); break;
    case SQ_PRESSURE_MULTIGRID: solve_multigrid(g, phi, st); break;
    default: solve_pcg(g, phi, st); break;
    }
    pressure_ghosts(g, phi);
    sq__grid_halo_cells(g, phi, sizeof(float)); /* inner faces: the neighbour's pressure */
    correct_velocity(g, phi);
    const float idt = 1.0f / dt;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < planes; k++)
        for (ptrdiff_t c = k * sz; c < (k + 1) * sz; c++) phi[c] *= idt;
    g->trace_valid = false;
    g->vel_version++;
    sq__grid_enforce_velocity(g);
    return SQ_OK;
}

sq_result sq_grid_project(sq_grid *g, double dt_s, sq_grid_project_stats *stats)
{
    sq_grid_project_stats st;
    memset(&st, 0, sizeof st);
    if (stats) *stats = st;
    if (!g) return sq__fail(NULL, SQ_ERR_INVALID_ARG, MOD, "sq_grid_project: grid is NULL");
    if (!(dt_s > 0.0) || !isfinite(dt_s))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD, "sq_grid_project: dt = %g s; must be > 0",
                        dt_s);
    /* a decomposed grid rebuilds its topology on every rank together (flags travel) */
    if (sq__grid_dist_any(g, g->topology_dirty)) {
        g->topology_dirty = true;
        sq_result r = sq__grid_update_topology(g);
        if (r != SQ_OK) return r;
    }
    double t0 = sq_time_now();
    sq_result r = sq__grid_project(g, (float)dt_s, &st);
    st.ms = (sq_time_now() - t0) * 1e3;
    g->stats.ms_project += st.ms;
    g->stats.project_calls++;
    g->stats.last_project = st;
    if (!st.converged)
        sq_log(g->ctx, SQ_LOG_DEBUG, MOD,
               "projection stopped after %d iterations at relative residual %.3g (tolerance %g)",
               st.iterations, st.residual, g->d.tolerance);
    if (stats) *stats = st;
    return r;
}
