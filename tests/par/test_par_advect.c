/* test_par_advect.c — MacCormack advection (with Selle's limiter) of the velocity and of
 * scalars on a MAC grid split in slabs over the ranks of `mpirun -np N`
 * (sq_grid_desc.decompose) gives the one-rank answer. Every rank advects its slab of a
 * velocity field and two scalars (a hill and a pillar across the slab faces, inflow of wind
 * and of scalar 0 on the west face) for several steps, the slabs are gathered on rank 0 and
 * compared with an undivided grid advected from the same fields:
 *   - split along a non-periodic axis (x), the samples are placed by their global index and
 *     every value read is the one rank reads, so the result must be bit-identical, at a CFL
 *     number below 1 and at ~2.5 (a wider halo, 2 ceil(D) + 3 planes);
 *   - split along a periodic axis (y, odd slab widths): one rank places the samples near the
 *     seam at positions n - 1/2 .. and wraps the traces that cross it, while a slab's halo
 *     samples across the seam lie at -1/2 ..; the fractions then differ in the last bit
 *     (1 ulp of n ~ 4e-6 cells). Semi-Lagrangian, that stays at 1e-5..1e-4 of the range
 *     after several steps; MacCormack's reverting limiter turns such a last-bit difference
 *     into a switch between the first- and second-order value at a few samples. Criterion:
 *     at most 5 % of the samples differ by more than 1e-5 of the field's range and none by
 *     more than 2e-2 of it (measured: 0.03-3 % and <= 8e-3); a wrong halo plane or offset
 *     moves O(1) values along a whole slab face;
 *   - the fields changed (the test tests something) and the slabs exchanged bytes;
 *   - a step too long for the thinnest slab's halo fails on every rank with one message.
 * Run under mpirun by tests/CMakeLists.txt (2 and 4 ranks); alone it compares one rank with
 * itself. */
#include <stdint.h>

#include "sq_test.h"
#include "squall/grid.h"
#include "squall/par.h"
#include "par_gather.h"

SQ_LABEL(unit)

static sq_dims G;
static int variant; /* 0: inflow/outflow along x, split x; 1: periodic x and y, split y */
static const sq_advect_scheme scheme = SQ_ADVECT_MACCORMACK;

static sq_grid_desc base_desc(void)
{
    sq_grid_desc d;
    memset(&d, 0, sizeof d);
    d.cells = G;
    d.cell_size_m = 2.0;
    if (variant == 0) {
        d.boundary[SQ_FACE_XMIN] = SQ_BOUNDARY_INFLOW;
        d.boundary[SQ_FACE_XMAX] = SQ_BOUNDARY_OUTFLOW;
    } else {
        for (int f = 0; f < 4; f++) d.boundary[f] = SQ_BOUNDARY_PERIODIC;
    }
    d.boundary[SQ_FACE_ZMIN] = SQ_BOUNDARY_NO_SLIP;
    d.boundary[SQ_FACE_ZMAX] = SQ_BOUNDARY_OPEN;
    d.scalar_count = 2;
    d.scalar_nonnegative = 1; /* scalar 0 as dust, scalar 1 signed */
    d.advection = scheme;
    return d;
}

static bool solid_at(int i, int j, int k)
{
    if (variant == 1) {
        const int t = i;
        i = j;
        j = t;
    }
    const bool hill = i >= 16 && i < 24 && j >= 6 && j < 18 && k < 4 + (i & 1);
    const bool pillar = i >= 9 && i <= 10 && j >= 10 && j < 13 && k < 10;
    return hill || pillar;
}

/* value of component c (0..2 velocity, 3..4 scalars) at sample (i,j,k), a function of the
 * global index: smooth plus a hashed ripple (limiter active) */
static float value0(int c, int i, int j, int k)
{
    const double x = i, y = j, z = k;
    const uint32_t hsh = ((uint32_t)i * 73856093u) ^ ((uint32_t)j * 19349663u) ^
                         ((uint32_t)k * 83492791u) ^ ((uint32_t)c * 2654435761u);
    const double noise = (double)((hsh >> 8) & 1023) / 1023.0 - 0.5;
    const double sp = variant == 0 ? 4.0 : 1.5; /* periodic: a slower mean wind */
    switch (c) {
    case 0: return (float)(sp + sin(0.3 * x) * cos(0.2 * y) + 0.5 * noise);
    case 1: return (float)((variant == 1 ? 2.0 : 0.0) + 0.8 * cos(0.25 * x + 0.4 * z) + 0.5 * noise);
    case 2: return (float)(0.6 * sin(0.2 * x + 0.3 * y) + 0.5 * noise);
    case 3: return (float)(exp(-0.02 * ((x - 14) * (x - 14) + (y - 12) * (y - 12))) + 0.2 * (noise > 0.3));
    default: return (float)(sin(0.4 * x + 0.1 * z) + 0.3 * noise);
    }
}

static void setup(sq_grid *g, const int lo[3], sq_dims n)
{
    par_fill(g, lo, n, 5, value0, solid_at);
    if (sq_grid_get_desc(g).boundary[SQ_FACE_XMIN] == SQ_BOUNDARY_INFLOW) /* slab 0 only */
        SQ_CHECK_OK(sq_grid_set_inflow_uniform(g, SQ_FACE_XMIN, 4.0, 0.3, 0.0));
    SQ_CHECK_OK(sq_grid_set_scalar_inflow(g, 0, 1.0));
    sq_grid_apply_boundary(g);
}

static void advance(sq_grid *g, double dt, int steps)
{
    for (int s = 0; s < steps; s++) {
        SQ_CHECK_OK(sq_grid_advect_velocity(g, dt));
        SQ_CHECK_OK(sq_grid_advect_scalars(g, dt));
    }
}

typedef struct result {
    double max_diff[5], range[5], change[5];
    double off[5]; /* share of samples that differ from one rank's by more than 1e-5 of the range */
    uint64_t bytes;
} result;

static double last_cfl(const sq_grid *g)
{
    sq_grid_stats st;
    sq_grid_get_stats(g, &st);
    return st.last_cfl;
}

static result run(double dt, int steps)
{
    result res;
    memset(&res, 0, sizeof res);
    sq_context *ctx = NULL;
    sq_context_desc cd = {.threads = 1, .seed = 7};
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    sq_grid_desc d = base_desc();
    d.decompose = true;
    sq_grid *dist = NULL, *ref = NULL;
    SQ_CHECK_OK(sq_grid_create(ctx, &d, &dist));
    int lo[3];
    sq_dims global;
    SQ_CHECK_OK(sq_grid_get_block(dist, lo, &global));
    setup(dist, lo, sq_grid_get_info(dist).cells);
    advance(dist, dt, steps);
    res.bytes = sq_grid_bytes_exchanged(dist);
    sq_grid_desc r = base_desc();
    SQ_CHECK_OK(sq_grid_create(ctx, &r, &ref));
    const int z[3] = {0, 0, 0};
    setup(ref, z, G);
    advance(ref, dt, steps);
    for (int c = 0; c < 5; c++) {
        float *a = par_gather(dist, c, G);
        int gm[3];
        par_lattice_dims(G, c, gm);
        const sq_field3 *f = par_field_of(ref, c);
        double lo_v = 1e30, hi_v = -1e30;
        for (int k = 0; k < gm[2]; k++)
            for (int j = 0; j < gm[1]; j++)
                for (int i = 0; i < gm[0]; i++) {
                    const double x = a[(size_t)i + (size_t)gm[0] * ((size_t)j + (size_t)gm[1] * k)];
                    const double y = *sq_field3_at(f, i, j, k);
                    const double dd = fabs(x - y);
                    if (!(dd <= res.max_diff[c])) res.max_diff[c] = isfinite(dd) ? dd : INFINITY;
                    const double ch = fabs(y - (double)value0(c, i, j, k));
                    res.change[c] = ch > res.change[c] ? ch : res.change[c];
                    lo_v = y < lo_v ? y : lo_v;
                    hi_v = y > hi_v ? y : hi_v;
                }
        res.range[c] = hi_v - lo_v;
        size_t nd = 0;
        for (int k = 0; k < gm[2]; k++)
            for (int j = 0; j < gm[1]; j++)
                for (int i = 0; i < gm[0]; i++) {
                    const double x = a[(size_t)i + (size_t)gm[0] * ((size_t)j + (size_t)gm[1] * k)];
                    nd += !(fabs(x - (double)*sq_field3_at(f, i, j, k)) <= 1e-5 * res.range[c]);
                }
        res.off[c] = (double)nd / ((double)gm[0] * gm[1] * gm[2]);
        free(a);
    }
    if (sq_par_rank() == 0)
        printf("%d ranks, variant %d, dt %g x %d, CFL %.2f: max |q - q_1| u %.3g v %.3g w %.3g "
               "s0 %.3g s1 %.3g (off by > 1e-5 of the range: %.2g %.2g %.2g %.2g %.2g); %llu "
               "bytes exchanged by rank 0\n",
               sq_par_size(), variant, dt, steps, last_cfl(ref), res.max_diff[0],
               res.max_diff[1], res.max_diff[2], res.max_diff[3], res.max_diff[4], res.off[0],
               res.off[1], res.off[2], res.off[3], res.off[4], (unsigned long long)res.bytes);
    sq_grid_destroy(dist);
    sq_grid_destroy(ref);
    sq_context_destroy(ctx);
    return res;
}

/* bit-identical after `steps` steps, the fields moved, halo bytes sent when split */
static void check_exact(const result *a, double min_change)
{
    static const char *const name[5] = {"u", "v", "w", "scalar 0", "scalar 1"};
    for (int c = 0; c < 5; c++) {
        SQ_CHECK_MSG(a->max_diff[c] == 0.0, "%s differs from one rank's by %.3g", name[c], a->max_diff[c]);
        SQ_CHECK_MSG(a->change[c] > min_change, "%s changed by %.3g only", name[c], a->change[c]);
    }
    SQ_CHECK(sq_par_size() == 1 || a->bytes > 0);
}

SQ_TEST(advection_bit_identical)
{
    SQ_CHECK_OK(sq_par_init(NULL, NULL));
    G = (sq_dims){40, 24, 16};
    variant = 0;
    const result a = run(0.12, 6); /* CFL ~0.6 */
    check_exact(&a, 0.1);
    const result b = run(0.7, 3); /* CFL ~2.5: 2 ceil(D) + 3 = 7 planes of halo */
    check_exact(&b, 0.3);
    sq_par_finalize();
}

SQ_TEST(advection_agrees_periodic_odd)
{
    SQ_CHECK_OK(sq_par_init(NULL, NULL));
    G = (sq_dims){22, 37, 12};
    variant = 1;
    for (int t = 0; t < 2; t++) {
        const result a = t == 0 ? run(0.2, 6) : run(1.2, 3); /* CFL ~0.6 and ~2.2 */
        for (int c = 0; c < 5; c++) {
            SQ_CHECK_MSG(a.max_diff[c] <= 2e-2 * a.range[c], "field %d differs by %.3g (range %.3g)",
                         c, a.max_diff[c], a.range[c]);
            SQ_CHECK_MSG(a.off[c] <= 0.05, "field %d: %.3g of the samples differ by more than 1e-5 of "
                         "the range", c, a.off[c]);
            SQ_CHECK_MSG(a.change[c] > 0.1, "field %d changed by %.3g only", c, a.change[c]);
        }
        if (sq_par_size() == 1)
            for (int c = 0; c < 5; c++) SQ_CHECK(a.max_diff[c] == 0.0);
    }
    sq_par_finalize();
}

/* A step that moves the wind more cells than the thinnest slab can hold as halo fails on
 * every rank (the halo width is chosen from the global largest speed, so all ranks agree
 * without waiting for each other), naming the width, the slab and the way out. */
SQ_TEST(advection_halo_too_wide)
{
    SQ_CHECK_OK(sq_par_init(NULL, NULL));
    G = (sq_dims){40, 24, 16};
    variant = 0;
    sq_context *ctx = NULL;
    sq_context_desc cd = {.threads = 1};
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    sq_grid_desc d = base_desc();
    d.decompose = true;
    sq_grid *g = NULL;
    SQ_CHECK_OK(sq_grid_create(ctx, &d, &g));
    int lo[3];
    sq_dims global;
    SQ_CHECK_OK(sq_grid_get_block(g, lo, &global));
    setup(g, lo, sq_grid_get_info(g).cells);
    /* 40 cells over 2 ranks: slabs of 20 hold 2 ceil(D) + 3 <= 20 planes, D <= 8 */
    if (sq_par_size() >= 2)
        SQ_CHECK_ERR(sq_grid_advect_velocity(g, 4.0), SQ_ERR_UNSTABLE, "use fewer ranks or a smaller step");
    else
        SQ_CHECK_OK(sq_grid_advect_velocity(g, 4.0)); /* one rank: no halo, no limit */
    sq_grid_destroy(g);
    sq_context_destroy(ctx);
    sq_par_finalize();
}
