/* test_snowdrift.c — snow transport on the wind lattice (SPEC §5.6): exact integer budget,
 * mean flake displacement (u − u_g)Δt (S1 eqs 8–11), binomial splitting, the deposition
 * lookup rules, solidification feeding back into the wind, erosion by the friction velocity,
 * snowfall-rate conversion, symmetry without wind and asymmetry with it, thread-independence. */
#include <stdint.h>

#include "phen/snowdrift/snowdrift_internal.h"
#include "sq_test.h"

SQ_LABEL(physics)

static sq_context *make_ctx(int threads)
{
    sq_context *ctx = NULL;
    sq_context_desc cd = {.threads = threads};
    if (sq_context_create(&cd, &ctx) != SQ_OK) return NULL;
    return ctx;
}

/* A prescribed wind on an nx*ny*nz lattice (contiguous views like the LBM's). */
typedef struct wind {
    float *u[3];
    sq_field_view v[3];
} wind;

static void wind_make(wind *w, int nx, int ny, int nz)
{
    const size_t n = (size_t)nx * ny * nz;
    for (int a = 0; a < 3; a++) {
        w->u[a] = calloc(n, sizeof(float));
        w->v[a] = (sq_field_view){w->u[a], {nx, ny, nz}, 1, nx, (ptrdiff_t)nx * ny};
    }
}

static void wind_free(wind *w)
{
    for (int a = 0; a < 3; a++) free(w->u[a]);
}

static void check_budget(const sq__snow *s, int step)
{
    sq__snow_budget b;
    sq__snow_get_budget(s, &b);
    if (b.fallen != b.airborne + b.deposited + b.left)
        SQ_FAIL_AT("step %d: fallen %llu != airborne %llu + deposited %llu + left %llu", step,
                   (unsigned long long)b.fallen, (unsigned long long)b.airborne,
                   (unsigned long long)b.deposited, (unsigned long long)b.left);
}

/* ---- random numbers ---------------------------------------------------------------------- */

SQ_TEST(binomial_mean_and_variance)
{
    /* every branch: per-flake (n <= 32), inversion (small np), normal (large np), p > 1/2 */
    const struct {
        uint32_t n;
        double p;
    } cases[] = {{7, 0.3}, {32, 0.9}, {200, 0.02}, {5000, 0.003}, {5000, 0.4}, {100000, 0.77}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const int N = 20000;
        double s = 0, s2 = 0;
        for (int t = 0; t < N; t++) {
            sq__snow_rng r;
            sq__snow_rng_init(&r, 42, SQ_SNOW_RNG_TRANSPORT, (uint64_t)c, t);
            const double k = sq__snow_binomial(&r, cases[c].n, cases[c].p);
            s += k;
            s2 += k * k;
        }
        const double n = cases[c].n, p = cases[c].p;
        const double mean = s / N, var = s2 / N - mean * mean;
        const double m0 = n * p, v0 = n * p * (1 - p);
        printf("Binomial(%u, %g): mean %.4f (exact %.4f), variance %.3f (exact %.3f)\n",
               cases[c].n, p, mean, m0, var, v0);
        /* 5 standard errors of the mean; variance within 5 % (its relative s.e. ~ 1 %) */
        SQ_CHECK_NEAR(mean, m0, 5.0 * sqrt(v0 / N));
        SQ_CHECK_REL(var, v0, 0.05);
    }
}

/* ---- transport --------------------------------------------------------------------------- */

/* Mean displacement of n0 flakes per cell over a one-cell-per-source step in a uniform wind. */
static void displacement_case(uint32_t n0, int cells_per_axis)
{
    sq_context *ctx = make_ctx(0);
    const int m = cells_per_axis, nx = 3 * m, ny = 3 * m, nz = 3 * m;
    sq__snow_params p = {.dx_m = 2.0, .dt_s = 0.5, .fall_speed_mps = 1.2, .periodic = {1, 1}};
    sq__snow *s = NULL;
    SQ_CHECK_OK(sq__snow_create(ctx, (sq_dims){nx, ny, nz}, &p, &s));
    if (!s) return;
    wind w;
    wind_make(&w, nx, ny, nz);
    const double U[3] = {1.3, -2.1, 2.0}; /* m/s */
    const int64_t n = (int64_t)nx * ny * nz;
    for (int64_t c = 0; c < n; c++)
        for (int a = 0; a < 3; a++) w.u[a][c] = (float)U[a];
    /* flakes in the middle block only, so no flake reaches a face */
    uint64_t total = 0;
    double x0[3] = {0, 0, 0};
    for (int k = m; k < 2 * m; k++)
        for (int j = m; j < 2 * m; j++)
            for (int i = m; i < 2 * m; i++) {
                s->air[i + nx * (j + ny * k)] = n0;
                total += n0;
                x0[0] += (double)n0 * i;
                x0[1] += (double)n0 * j;
                x0[2] += (double)n0 * k;
            }
    s->fallen = total; /* placed by hand: count them as fallen for the budget */
    SQ_CHECK_OK(sq__snow_step(s, w.v, NULL, NULL));
    check_budget(s, 0);
    double x1[3] = {0, 0, 0};
    uint64_t seen = 0;
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                const uint32_t a = s->air[i + nx * (j + ny * k)];
                seen += a;
                x1[0] += (double)a * i;
                x1[1] += (double)a * j;
                x1[2] += (double)a * k;
            }
    SQ_CHECK(seen == total);
    const double expect[3] = {U[0] * 0.5 / 2.0, U[1] * 0.5 / 2.0, (U[2] - 1.2) * 0.5 / 2.0};
    for (int a = 0; a < 3; a++) {
        const double mean = (x1[a] - x0[a]) / (double)total;
        const double pr = fabs(expect[a]);
        const double se = sqrt(pr * (1 - pr) / (double)total);
        printf("n0=%u: axis %d mean displacement %.5f cells, (u - u_g) dt/dx = %.5f (s.e. %.1e)\n",
               n0, a, mean, expect[a], se);
        SQ_CHECK_NEAR(mean, expect[a], 5.0 * se + 1e-12);
    }
    wind_free(&w);
    sq__snow_destroy(s);
    sq_context_destroy(ctx);
}

SQ_TEST(mean_displacement_matches_wind_small_counts)
{
    displacement_case(9, 12); /* per-flake draws */
}

SQ_TEST(mean_displacement_matches_wind_large_counts)
{
    displacement_case(3000, 4); /* normal-approximation and inversion splits */
}

SQ_TEST(snowfall_rate_conversion)
{
    sq__snow_params p = {.dx_m = 0.5, .dt_s = 0.2, .snowfall_mmh = 6.0, .speedup = 500,
                         .threshold = 8, .snow_density_kgm3 = 120};
    const sq__snow_params r = sq__snow_params_resolve(&p);
    /* m = 120 · 0.125 / 8 = 1.875 kg; λ = 500 · 6/3600 · 0.25 · 0.2 / 1.875 */
    const double lambda = 500.0 * 6.0 / 3600.0 * 0.25 * 0.2 / 1.875;
    SQ_CHECK_REL(sq__snow_flakes_per_top_cell(&r), lambda, 1e-12);
    sq_context *ctx = make_ctx(0);
    sq__snow *s = NULL;
    SQ_CHECK_OK(sq__snow_create(ctx, (sq_dims){20, 10, 4}, &p, &s));
    if (!s) return;
    SQ_CHECK_REL(s->flake_mass_kg, 1.875, 1e-12);
    wind w;
    wind_make(&w, 20, 10, 4);
    const int steps = 400;
    for (int t = 0; t < steps; t++) SQ_CHECK_OK(sq__snow_step(s, w.v, NULL, NULL));
    sq__snow_budget b;
    sq__snow_get_budget(s, &b);
    const double expect = lambda * 200 * steps, se = sqrt(expect);
    printf("snowfall: %llu flakes fell, expected %.1f (lambda %.4f per top cell per step)\n",
           (unsigned long long)b.fallen, expect, lambda);
    SQ_CHECK_NEAR((double)b.fallen, expect, 5 * se);
    check_budget(s, steps);
    wind_free(&w);
    sq__snow_destroy(s);
    sq_context_destroy(ctx);
}

/* ---- deposition rules -------------------------------------------------------------------- */

SQ_TEST(deposition_lookup_rules)
{
    /* a 3x3x3 block: flakes landed in the centre cell (1,1,1) */
    sq__snow_kparams kp = {3, 3, 3, 0.1f, 0.1f, {false, false}, 7, 0, 1, 0, 3, 0, 3, 0};
    uint8_t kind[27], changed[27];
    uint32_t land[27], dep[27], air[27];
    const int c = 1 + 3 * (1 + 3 * 1), below = c - 9;
    /* (a) stable: the cell below is solid, whatever the diagonals */
    memset(kind, 0, sizeof kind);
    memset(land, 0, sizeof land);
    memset(dep, 0, sizeof dep);
    memset(air, 0, sizeof air);
    memset(changed, 0, sizeof changed);
    kind[below] = SQ_SNOW_STATIC;
    land[c] = 5;
    sq__snow_settle(&kp, 10, kind, land, dep, air, changed);
    SQ_CHECK(dep[c] == 5 && land[c] == 0);
    /* (b) roll-off: below free, some lower diagonals solid -> only free lower diagonals */
    memset(kind, 0, sizeof kind);
    memset(dep, 0, sizeof dep);
    for (int q = 0; q < 9; q++) kind[q] = SQ_SNOW_STATIC; /* the whole layer below ... */
    kind[below] = SQ_SNOW_AIR;                           /* ... but the hole under c */
    kind[0] = SQ_SNOW_AIR;                               /* and one free corner */
    kind[8] = SQ_SNOW_AIR;                               /* and the opposite corner */
    land[c] = 1000;
    sq__snow_settle(&kp, 10, kind, land, dep, air, changed);
    SQ_CHECK(dep[c] == 0);
    SQ_CHECK(air[0] + air[8] == 1000);
    SQ_CHECK(air[0] > 400 && air[8] > 400); /* uniform choice: 500 ± 16 */
    SQ_CHECK(air[below] == 0);
    /* (c) all 8 lower diagonals solid: drop into the hole below */
    memset(air, 0, sizeof air);
    kind[0] = kind[8] = SQ_SNOW_STATIC;
    land[c] = 7;
    sq__snow_settle(&kp, 10, kind, land, dep, air, changed);
    SQ_CHECK(air[below] == 7);
    /* (d) the threshold: more than 10 deposited flakes turn the cell solid and engulf its air */
    memset(kind, 0, sizeof kind);
    memset(air, 0, sizeof air);
    memset(changed, 0, sizeof changed);
    kind[below] = SQ_SNOW_STATIC;
    dep[c] = 10;
    air[c] = 3;
    land[c] = 1;
    sq__snow_settle(&kp, 10, kind, land, dep, air, changed);
    SQ_CHECK(kind[c] == SQ_SNOW_SOLID && changed[c] == 1);
    SQ_CHECK(dep[c] == 14 && air[c] == 0);
}

SQ_TEST(flakes_pile_up_and_block_the_wind)
{
    /* no wind, heavy snowfall on a small lattice with a wind solver attached: the ground layer
     * fills, turns solid in the LBM, and snow then rests on snow */
    sq_context *ctx = make_ctx(0);
    const int nx = 6, ny = 6, nz = 6;
    sq_lbm_desc ld;
    memset(&ld, 0, sizeof ld);
    ld.cells = (sq_dims){nx, ny, nz};
    ld.cell_size_m = 1;
    ld.dt_s = 0.1;
    ld.viscosity_m2s = 0.5;
    ld.bc[SQ_LBM_FACE_ZMIN] = SQ_LBM_BC_WALL;
    ld.bc[SQ_LBM_FACE_ZMAX] = SQ_LBM_BC_FREE_SLIP;
    sq_lbm *l = NULL;
    SQ_CHECK_OK(sq_lbm_create(ctx, &ld, &l));
    sq__snow_params p = {.dx_m = 1, .dt_s = 0.1, .snowfall_mmh = 10, .speedup = 20000,
                         .periodic = {1, 1}};
    sq__snow *s = NULL;
    SQ_CHECK_OK(sq__snow_create(ctx, (sq_dims){nx, ny, nz}, &p, &s));
    if (!l || !s) return;
    int t = 0;
    for (; t < 4000; t++) {
        SQ_CHECK_OK(sq_lbm_step(l, 1));
        sq_lbm_views v;
        SQ_CHECK_OK(sq_lbm_get_views(l, &v));
        SQ_CHECK_OK(sq__snow_step(s, v.u, NULL, l));
        check_budget(s, t);
        if (s->kind[3 + nx * (3 + ny * 1)] == SQ_SNOW_SOLID) break; /* second layer filled */
    }
    printf("second layer solid after %d steps\n", t);
    SQ_CHECK(t < 4000);
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            SQ_CHECK(s->kind[i + nx * j] == SQ_SNOW_SOLID);
            SQ_CHECK(sq_lbm_is_solid(l, i, j, 0));
        }
    sq__snow_destroy(s);
    sq_lbm_destroy(l);
    sq_context_destroy(ctx);
}

/* ---- erosion ----------------------------------------------------------------------------- */

SQ_TEST(erosion_above_threshold_only)
{
    sq_context *ctx = make_ctx(0);
    const int nx = 40, ny = 40, nz = 3;
    sq__snow_params p = {.dx_m = 1, .dt_s = 0.05, .ustar_threshold_mps = 0.3,
                         .saturation_time_s = 2.0, .saltation_kgm3 = 75, /* 5 flakes */
                         .erosion_efficiency = 0.8, .periodic = {1, 1}};
    sq__snow *s = NULL;
    SQ_CHECK_OK(sq__snow_create(ctx, (sq_dims){nx, ny, nz}, &p, &s));
    if (!s) return;
    const int64_t n = (int64_t)nx * ny * nz, layer = (int64_t)nx * ny;
    /* a snow-solid ground layer of 30 flakes per cell */
    for (int64_t c = 0; c < layer; c++) {
        s->kind[c] = SQ_SNOW_SOLID;
        s->dep[c] = 30;
    }
    s->fallen = 30 * (uint64_t)layer;
    float *us = calloc((size_t)n, sizeof(float));
    uint8_t *changed = calloc((size_t)n, 1);
    const sq__snow_params rp = sq__snow_params_resolve(&p);
    sq__snow_kparams kp = {nx, ny, nz, 0.05f, 0.05f, {true, true}, 3, 0, 2, 0, nz, 0, nz, 0};
    /* below the threshold: nothing moves */
    for (int64_t c = layer; c < 2 * layer; c++) us[c] = 0.29f;
    SQ_CHECK(sq__snow_erode(&kp, &rp, us, s->kind, s->dep, s->air, changed) == 0);
    /* above: the mean lifted count per surface cell is (Δt/t_sat)(C_sat − 0)·n_sat */
    for (int64_t c = layer; c < 2 * layer; c++) us[c] = 0.6f;
    const uint64_t lifted = sq__snow_erode(&kp, &rp, us, s->kind, s->dep, s->air, changed);
    const double csat = 0.8 * (1.0 - 0.09 / 0.36), e = 0.05 / 2.0 * csat * 5.0;
    printf("erosion: %llu flakes lifted from %lld cells, expected %.1f\n",
           (unsigned long long)lifted, (long long)layer, e * layer);
    /* stochastic rounding: per-cell variance <= 1/4 */
    SQ_CHECK_NEAR((double)lifted, e * layer, 5.0 * sqrt(0.25 * layer));
    uint64_t air = 0, dep = 0;
    for (int64_t c = 0; c < n; c++) {
        air += s->air[c];
        dep += s->dep[c];
    }
    SQ_CHECK(air == lifted && air + dep == s->fallen);
    /* a saturated saltation layer stops erosion (C_salt >= C_sat) */
    for (int64_t c = layer; c < 2 * layer; c++) s->air[c] = 5;
    SQ_CHECK(sq__snow_erode(&kp, &rp, us, s->kind, s->dep, s->air, changed) == 0);
    /* eroding the last flake of a snow cell turns it back into air */
    for (int64_t c = layer; c < 2 * layer; c++) s->air[c] = 0;
    s->dep[0] = 1;
    us[layer] = 50.0f;
    sq__snow_params fast = rp;
    fast.saturation_time_s = 1e-4; /* expected lift far above the one flake available */
    sq__snow_erode(&kp, &fast, us, s->kind, s->dep, s->air, changed);
    SQ_CHECK(s->dep[0] == 0 && s->kind[0] == SQ_SNOW_AIR && changed[0] == 2);
    free(us);
    free(changed);
    sq__snow_destroy(s);
    sq_context_destroy(ctx);
}

/* ---- budget, symmetry, asymmetry -------------------------------------------------------- */

/* A box obstacle of static cells in the middle of the ground, half-width hw, height h. */
static void place_box(sq__snow *s, sq_lbm *l, int cx, int cy, int hw, int h)
{
    for (int k = 0; k < h; k++)
        for (int j = cy - hw; j <= cy + hw; j++)
            for (int i = cx - hw; i <= cx + hw; i++) {
                sq__snow_set_static(s, i, j, k, true);
                if (l) sq_lbm_set_solid(l, i, j, k, true);
            }
}

SQ_TEST(budget_exact_every_step)
{
    /* sheared gusty wind, a box, strong erosion, a low threshold: every rule fires */
    sq_context *ctx = make_ctx(0);
    const int nx = 24, ny = 12, nz = 10;
    sq__snow_params p = {.dx_m = 1, .dt_s = 0.2, .snowfall_mmh = 5, .speedup = 30000,
                         .threshold = 4, .ustar_threshold_mps = 0.2, .periodic = {0, 1}};
    sq__snow *s = NULL;
    SQ_CHECK_OK(sq__snow_create(ctx, (sq_dims){nx, ny, nz}, &p, &s));
    if (!s) return;
    place_box(s, NULL, 12, 6, 2, 4);
    wind w;
    wind_make(&w, nx, ny, nz);
    float *us = calloc((size_t)nx * ny * nz, sizeof(float));
    sq_field_view usv = {us, {nx, ny, nz}, 1, nx, (ptrdiff_t)nx * ny};
    uint64_t eroded = 0;
    for (int t = 0; t < 600; t++) {
        for (int k = 0; k < nz; k++)
            for (int j = 0; j < ny; j++)
                for (int i = 0; i < nx; i++) {
                    const int64_t c = i + nx * (j + (int64_t)ny * k);
                    w.u[0][c] = (float)((1.0 + 0.4 * k) * (1.0 + 0.5 * sin(0.05 * t)));
                    w.u[1][c] = (float)(1.5 * sin(0.3 * i + 0.02 * t));
                    w.u[2][c] = (float)(0.8 * cos(0.4 * j));
                    us[c] = (float)(0.15 + 0.1 * (1.0 + sin(0.03 * t + 0.2 * i)));
                }
        SQ_CHECK_OK(sq__snow_step(s, w.v, &usv, NULL));
        check_budget(s, t);
    }
    sq__snow_budget b;
    sq__snow_get_budget(s, &b);
    eroded = b.eroded;
    printf("budget after 600 steps: fallen %llu = airborne %llu + deposited %llu + left %llu; "
           "eroded %llu, snow-solid cells %lld\n",
           (unsigned long long)b.fallen, (unsigned long long)b.airborne,
           (unsigned long long)b.deposited, (unsigned long long)b.left,
           (unsigned long long)eroded, (long long)b.solid_cells);
    SQ_CHECK(b.fallen > 1000 && b.left > 0 && b.deposited > 0 && b.airborne > 0);
    SQ_CHECK(eroded > 0 && b.solid_cells > 0);
    free(us);
    wind_free(&w);
    sq__snow_destroy(s);
    sq_context_destroy(ctx);
}

SQ_TEST(thread_count_does_not_change_snow)
{
    const int nx = 20, ny = 14, nz = 10;
    const int64_t n = (int64_t)nx * ny * nz;
    uint32_t *res[2];
    for (int th = 0; th < 2; th++) {
        sq_context *ctx = make_ctx(th + 1);
        sq__snow_params p = {.dx_m = 1, .dt_s = 0.2, .snowfall_mmh = 5, .speedup = 30000,
                             .threshold = 4, .ustar_threshold_mps = 0.2, .periodic = {1, 1},
                             .seed = 99};
        sq__snow *s = NULL;
        SQ_CHECK_OK(sq__snow_create(ctx, (sq_dims){nx, ny, nz}, &p, &s));
        if (!s) return;
        place_box(s, NULL, 10, 7, 2, 3);
        wind w;
        wind_make(&w, nx, ny, nz);
        float *us = calloc((size_t)n, sizeof(float));
        sq_field_view usv = {us, {nx, ny, nz}, 1, nx, (ptrdiff_t)nx * ny};
        for (int64_t c = 0; c < n; c++) {
            w.u[0][c] = (float)(2.0 * sin(0.1 * c));
            w.u[1][c] = (float)(1.0 * cos(0.07 * c));
            us[c] = 0.3f;
        }
        for (int t = 0; t < 200; t++) SQ_CHECK_OK(sq__snow_step(s, w.v, &usv, NULL));
        res[th] = malloc((size_t)n * 2 * sizeof(uint32_t));
        memcpy(res[th], s->air, (size_t)n * sizeof(uint32_t));
        memcpy(res[th] + n, s->dep, (size_t)n * sizeof(uint32_t));
        free(us);
        wind_free(&w);
        sq__snow_destroy(s);
        sq_context_destroy(ctx);
    }
    SQ_CHECK(memcmp(res[0], res[1], (size_t)n * 2 * sizeof(uint32_t)) == 0);
    free(res[0]);
    free(res[1]);
}

/* Deposits summed over the two halves x < cx and x > cx around a box at cx, above the ground
 * layer. */
static void halves(const sq__snow *s, int cx, double *lo, double *hi)
{
    *lo = *hi = 0;
    for (int k = 0; k < s->nz; k++)
        for (int j = 0; j < s->ny; j++)
            for (int i = 0; i < s->nx; i++) {
                const double d = s->dep[i + s->nx * (j + (int64_t)s->ny * k)];
                if (i < cx) *lo += d;
                if (i > cx) *hi += d;
            }
}

SQ_TEST(deposition_symmetric_without_wind)
{
    sq_context *ctx = make_ctx(0);
    const int nx = 25, ny = 25, nz = 12, cx = 12;
    /* a huge threshold keeps every cell open, so only the fall decides */
    sq__snow_params p = {.dx_m = 1, .dt_s = 0.5, .snowfall_mmh = 5, .speedup = 0.2,
                         .threshold = 1000000, .periodic = {1, 1}};
    sq__snow *s = NULL;
    SQ_CHECK_OK(sq__snow_create(ctx, (sq_dims){nx, ny, nz}, &p, &s));
    if (!s) return;
    place_box(s, NULL, cx, 12, 3, 5);
    wind w;
    wind_make(&w, nx, ny, nz);
    for (int t = 0; t < 300; t++) SQ_CHECK_OK(sq__snow_step(s, w.v, NULL, NULL));
    check_budget(s, 300);
    double lo, hi;
    halves(s, cx, &lo, &hi);
    /* without wind flakes fall straight down: the deposit halves differ only by Poisson noise */
    const double se = sqrt(lo + hi);
    printf("no wind: deposits left %.0f right %.0f (difference %.1f s.e.)\n", lo, hi,
           fabs(lo - hi) / se);
    SQ_CHECK(fabs(lo - hi) < 4.0 * se);
    /* the roof columns hold their footprint's share of all snow (airborne + deposited):
     * 7x7 of 25x25 columns */
    double roof = 0, total = 0;
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++)
            for (int k = 0; k < nz; k++) {
                const int64_t c = i + nx * (j + (int64_t)ny * k);
                const double d = (double)s->dep[c] + s->air[c];
                total += d;
                if (abs(i - cx) <= 3 && abs(j - 12) <= 3) roof += d;
            }
    const double f = 49.0 / 625.0;
    printf("no wind: roof columns hold %.5f of the snow (footprint share %.5f)\n", roof / total,
           f);
    SQ_CHECK_NEAR(roof / total, f, 4.0 * sqrt(f * (1 - f) / total));
    wind_free(&w);
    sq__snow_destroy(s);
    sq_context_destroy(ctx);
}

SQ_TEST(deposition_asymmetric_with_wind)
{
    /* the coupled model: LBM wind over a box (recycled x, ground wall, free-slip sky), snow
     * carried by it. Deposits on either side of the box then differ far beyond the noise. */
    sq_context *ctx = make_ctx(0);
    const int nx = 40, ny = 16, nz = 16, cx = 16;
    sq_lbm_desc ld;
    memset(&ld, 0, sizeof ld);
    ld.cells = (sq_dims){nx, ny, nz};
    ld.cell_size_m = 1;
    ld.viscosity_m2s = 0.05;
    ld.bc[SQ_LBM_FACE_XMIN] = ld.bc[SQ_LBM_FACE_XMAX] = SQ_LBM_BC_RECYCLE;
    ld.bc[SQ_LBM_FACE_ZMIN] = SQ_LBM_BC_WALL;
    ld.bc[SQ_LBM_FACE_ZMAX] = SQ_LBM_BC_FREE_SLIP;
    ld.wind.speed_mps = 5;
    ld.wind.ref_height_m = 8;
    sq_lbm *l = NULL;
    SQ_CHECK_OK(sq_lbm_create(ctx, &ld, &l));
    if (!l) return;
    const sq_lbm_info in = sq_lbm_get_info(l);
    const int sub = 5; /* snow step = 5 wind steps */
    sq__snow_params p = {.dx_m = 1, .dt_s = sub * in.dt_s, .snowfall_mmh = 5, .speedup = 1,
                         .threshold = 1000000, .fall_speed_mps = 1.0, .periodic = {1, 1}};
    sq__snow *s = NULL;
    SQ_CHECK_OK(sq__snow_create(ctx, (sq_dims){nx, ny, nz}, &p, &s));
    if (!s) return;
    place_box(s, l, cx, 8, 3, 5);
    SQ_CHECK_OK(sq_lbm_step(l, 1500)); /* let the flow around the box develop */
    for (int t = 0; t < 500; t++) {
        SQ_CHECK_OK(sq_lbm_step(l, sub));
        sq_lbm_views v;
        SQ_CHECK_OK(sq_lbm_get_views(l, &v));
        SQ_CHECK_OK(sq__snow_step(s, v.u, NULL, l));
    }
    check_budget(s, 500);
    /* compare the bands of 6 cells just upwind and just downwind of the box */
    double up = 0, down = 0;
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                const double d = s->dep[i + nx * (j + (int64_t)ny * k)];
                if (i >= cx - 9 && i < cx - 3) up += d;
                if (i > cx + 3 && i <= cx + 9) down += d;
            }
    const double se = sqrt(up + down);
    printf("wind 5 m/s: deposits in 6-cell bands windward %.0f, leeward %.0f (difference %.1f "
           "s.e.)\n",
           up, down, fabs(up - down) / se);
    SQ_CHECK(fabs(up - down) > 6.0 * se);
    sq__snow_destroy(s);
    sq_lbm_destroy(l);
    sq_context_destroy(ctx);
}

/* ---- the phenomenon (public API and plug-in) --------------------------------------------- */

#include "squall/plugin.h"
#include "squall/snowdrift.h"

static sq_world *village(sq_context *ctx)
{
    static sq_obstacle house;
    memset(&house, 0, sizeof house);
    house.kind = SQ_OBSTACLE_HOUSE;
    house.center_m = sq_v3(0.0f, 0.0f, NAN);
    house.size_m = sq_v3(8.0f, 6.0f, 4.0f);
    house.roof_m = 2.0f;
    sq_world_desc wd;
    memset(&wd, 0, sizeof wd);
    wd.terrain.kind = SQ_TERRAIN_FLAT;
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = 200.0f;
    wd.terrain.resolution[0] = wd.terrain.resolution[1] = 33;
    wd.obstacles = &house;
    wd.obstacle_count = 1;
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &wd, &w));
    return w;
}

SQ_TEST(phenomenon_snows_on_a_village)
{
    sq_context *ctx = make_ctx(0);
    sq_world *w = village(ctx);
    if (!w) return;
    sq_snowdrift_desc d;
    memset(&d, 0, sizeof d);
    d.cells[0] = 40;
    d.cells[1] = 24;
    d.cells[2] = 16;
    d.wind_speed_mps = 6;
    d.beaufort = 4;
    d.snowfall_mmh = 5;
    d.speedup = 20000; /* one flake is 15 kg of snow: time-lapse so that drifts appear */
    d.visual_flakes = 500;
    sq_snowdrift *s = NULL;
    SQ_CHECK_OK(sq_snowdrift_create(ctx, &d, w, &s));
    if (!s) {
        sq_world_destroy(ctx, w);
        return;
    }
    /* the house is solid for the wind: the cell at its centre, 2 m up */
    SQ_CHECK(sq_lbm_is_solid(s->lbm, 20, 12, (int)floor(2.0 - s->origin[2])));
    for (int f = 0; f < 25; f++) { /* 25 s: flakes need 15 s to fall from the top */
        SQ_CHECK_OK(sq_snowdrift_step(s, 1.0));
        sq_snowdrift_budget b;
        sq_snowdrift_get_budget(s, &b);
        SQ_CHECK(b.fallen_flakes == b.airborne_flakes + b.deposited_flakes + b.left_flakes);
    }
    sq_snowdrift_budget b;
    sq_snowdrift_get_budget(s, &b);
    printf("village: %llu flakes fell (%.1f kg), %llu deposited, depth mean %.4f m max %.3f m, "
           "snow every %d wind steps of %.4f s\n",
           (unsigned long long)b.fallen_flakes, b.fallen_kg,
           (unsigned long long)b.deposited_flakes, b.depth_mean_m, b.depth_max_m, s->sub,
           s->lbm_dt);
    SQ_CHECK(b.fallen_flakes > 0 && b.deposited_flakes > 0);
    SQ_CHECK_REL(b.fallen_kg, (double)b.fallen_flakes * b.flake_mass_kg, 1e-12);
    /* flake mass = 150 kg/m³ · 1 m³ / 10 */
    SQ_CHECK_REL(b.flake_mass_kg, 15.0, 1e-12);
    /* the plug-in publishes the snow cover and the falling flakes, metrics and fields */
    const sq_phen_plugin *pl = sq_plugin_find("snowdrift");
    SQ_CHECK(pl != NULL);
    if (pl) {
        sq_drawable dr[4];
        const int nd = pl->drawables(s, dr, 4);
        SQ_CHECK(nd == 2);
        /* the cover extends 24 columns beyond the 40 x 24 lattice on every side */
        SQ_CHECK(dr[0].kind == SQ_DRAWABLE_SURFACE && dr[0].u.surface.nx == 40 + 48 &&
                 dr[0].u.surface.ny == 24 + 48);
        SQ_CHECK(dr[1].kind == SQ_DRAWABLE_PARTICLES && dr[1].u.particles.count == 500);
        for (int f = 0; f < 500; f++) {
            const float *p = &dr[1].u.particles.position[3 * f];
            SQ_CHECK(p[0] >= -20.0f && p[0] <= 20.0f && p[1] >= -12.0f && p[1] <= 12.0f);
        }
        /* flakes seen smaller than draw.flake_min_mrad are drawn at it with alpha scaled by
         * (true/drawn radius)^2: projected area x opacity is kept */
        SQ_CHECK(dr[1].u.particles.radius_m == NULL); /* no camera observed yet */
        sq_camera cam;
        memset(&cam, 0, sizeof cam);
        cam.position_m = sq_v3(-60.0f, -40.0f, 12.0f);
        cam.target_m = sq_v3(0.0f, 0.0f, 2.0f);
        SQ_CHECK(pl->observe != NULL);
        if (pl->observe) pl->observe(s, &cam);
        SQ_CHECK(pl->drawables(s, dr, 4) == 2);
        const sq_particles_view *pv = &dr[1].u.particles;
        SQ_CHECK(pv->radius_m != NULL && pv->fade != NULL);
        int enlarged = 0, bad = 0;
        const double r0 = s->d.flake_radius_m, amin = s->d.flake_min_mrad * 1e-3;
        for (int f = 0; pv->radius_m && f < pv->count; f++) {
            const float *p = &pv->position[3 * f];
            const double dist = sqrt(pow(p[0] + 60.0, 2) + pow(p[1] + 40.0, 2) +
                                     pow(p[2] - 12.0, 2));
            const double r = pv->radius_m[f], a = pv->fade[f];
            bad += fabs(r - fmax(r0, amin * dist)) > 1e-5 * r;
            bad += fabs(a * r * r - r0 * r0) > 1e-5 * r0 * r0;
            enlarged += r > r0;
        }
        printf("flakes: %d of %d enlarged to the minimum angular size\n", enlarged, pv->count);
        SQ_CHECK(bad == 0 && enlarged > 0);
        sq_metric m[16];
        const int nm = pl->metrics(s, m, 16);
        SQ_CHECK(nm >= 6);
        for (int k = 0; k < nm; k++) SQ_CHECK(isfinite(m[k].value));
        sq_named_field fl[8];
        SQ_CHECK(pl->fields(s, fl, 8) == 5);
    }
    sq_snowdrift_destroy(s);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* The whole phenomenon (wind, surface u*, snow, visual flakes, tallies) gives the same bits on
 * 1 and 2 threads; the drawn snow cover and the exported depth agree with the budget. */
SQ_TEST(phenomenon_thread_count_does_not_change_anything)
{
    float *pos[2] = {NULL, NULL};
    uint32_t *snow[2] = {NULL, NULL};
    sq_snowdrift_budget bud[2];
    int64_t n = 0;
    int nfl = 0;
    for (int th = 0; th < 2; th++) {
        sq_context *ctx = make_ctx(th + 1);
        sq_world *w = village(ctx);
        if (!w) return;
        sq_snowdrift_desc d;
        memset(&d, 0, sizeof d);
        d.cells[0] = 48;
        d.cells[1] = 32;
        d.cells[2] = 24; /* 36864 cells: above the kernels' parallel threshold */
        d.wind_speed_mps = 7;
        d.beaufort = 4.5;
        d.snowfall_mmh = 5;
        d.speedup = 20000;
        d.visual_flakes = 5000;
        d.seed = 5;
        sq_snowdrift *s = NULL;
        SQ_CHECK_OK(sq_snowdrift_create(ctx, &d, w, &s));
        if (!s) {
            sq_world_destroy(ctx, w);
            return;
        }
        for (int f = 0; f < 15; f++) SQ_CHECK_OK(sq_snowdrift_step(s, 1.0 / 24.0));
        const sq_phen_plugin *pl = sq_plugin_find("snowdrift");
        sq_drawable dr[4];
        const int nd = pl ? pl->drawables(s, dr, 4) : 0;
        SQ_CHECK(nd == 2);
        sq_snowdrift_get_budget(s, &bud[th]);
        SQ_CHECK(bud[th].fallen_flakes == bud[th].airborne_flakes + bud[th].deposited_flakes +
                                              bud[th].left_flakes);
        n = s->snow->n;
        nfl = s->nflakes;
        snow[th] = malloc((size_t)n * 2 * sizeof(uint32_t));
        memcpy(snow[th], s->snow->air, (size_t)n * sizeof(uint32_t));
        memcpy(snow[th] + n, s->snow->dep, (size_t)n * sizeof(uint32_t));
        pos[th] = malloc((size_t)nfl * 3 * sizeof(float));
        memcpy(pos[th], s->fpos, (size_t)nfl * 3 * sizeof(float));
        if (nd == 2) {
            /* over the lattice the cover is ground + depth; beyond it the depth fades to
             * nothing at the outer ring (no seam); the mean exported depth = the budget's */
            const sq_surface_view *sv = &dr[0].u.surface;
            const int M = s->margin, nx = s->nx, ny = s->ny;
            SQ_CHECK(M >= 2 && sv->nx == nx + 2 * M && sv->ny == ny + 2 * M);
            sq_named_field fl[8];
            const int nf = pl->fields(s, fl, 8);
            SQ_CHECK(nf == 5);
            double sum = 0;
            int bad_in = 0, bad_out = 0;
            for (int jj = 0; jj < sv->ny; jj++)
                for (int ii = 0; ii < sv->nx; ii++) {
                    const int q = ii + sv->nx * jj, i = ii - M, j = jj - M;
                    if (i >= 0 && i < nx && j >= 0 && j < ny) {
                        const float dpt = s->depth[i + nx * j];
                        bad_in += sv->height_m[q] != s->ground_z[q] + dpt;
                        sum += dpt;
                    } else if (ii == 0 || jj == 0 || ii == sv->nx - 1 || jj == sv->ny - 1) {
                        bad_out += sv->height_m[q] != s->ground_z[q] || sv->coverage[q] != 0.0f;
                    }
                }
            SQ_CHECK(bad_in == 0 && bad_out == 0);
            SQ_CHECK_NEAR(sum / (nx * ny), bud[th].depth_mean_m, 1e-6);
            SQ_CHECK(nf == 5 && fl[4].data == s->depth);
        }
        sq_snowdrift_destroy(s);
        sq_world_destroy(ctx, w);
        sq_context_destroy(ctx);
    }
    printf("15 frames: %llu flakes fell, %llu deposited, %lld snow cells\n",
           (unsigned long long)bud[0].fallen_flakes, (unsigned long long)bud[0].deposited_flakes,
           (long long)bud[0].snow_cells);
    SQ_CHECK(bud[0].deposited_flakes > 0);
    SQ_CHECK(memcmp(snow[0], snow[1], (size_t)n * 2 * sizeof(uint32_t)) == 0);
    SQ_CHECK(memcmp(pos[0], pos[1], (size_t)nfl * 3 * sizeof(float)) == 0);
    SQ_CHECK(bud[0].depth_mean_m == bud[1].depth_mean_m &&
             bud[0].depth_max_m == bud[1].depth_max_m);
    for (int th = 0; th < 2; th++) {
        free(snow[th]);
        free(pos[th]);
    }
}

SQ_TEST(phenomenon_bad_desc_named)
{
    sq_context *ctx = make_ctx(0);
    sq_snowdrift *s = (sq_snowdrift *)1;
    sq_snowdrift_desc d;
    memset(&d, 0, sizeof d);
    d.threshold = -3;
    SQ_CHECK_ERR(sq_snowdrift_create(ctx, &d, NULL, &s), SQ_ERR_INVALID_ARG,
                 "snow.threshold = -3");
    SQ_CHECK(s == NULL);
    memset(&d, 0, sizeof d);
    d.roughness_m = 50;
    SQ_CHECK_ERR(sq_snowdrift_create(ctx, &d, NULL, &s), SQ_ERR_INVALID_ARG,
                 "wind.roughness_m = 50");
    memset(&d, 0, sizeof d);
    d.cells[0] = 2;
    SQ_CHECK_ERR(sq_snowdrift_create(ctx, &d, NULL, &s), SQ_ERR_INVALID_ARG, "domain.nx x ny x nz = 2x64x48");
    sq_context_destroy(ctx);
}
