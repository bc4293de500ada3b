/* test_sph.c — SPH physics against analytic solutions and conservation laws (SPEC §7):
 * a hydrostatic column, plane Poiseuille flow of power-law fluids (n = 0.5, 1.5) and of a
 * Newtonian fluid against ../shared/reference/analytic_flows.md, exact momentum conservation
 * in a periodic box, thread-count and list-capacity independence, Coulomb friction and
 * restitution at the terrain, box obstacles, open faces, a Cross-rheology avalanche block
 * on a slope, and the terrain-following neighbour grid against the dense box grid. */
#include "sq_test.h"
#include "squall/rng.h"
#include "squall/sph.h"
#include "solvers/sph/sph_internal.h" /* sq__sph_uses_avx512 */

SQ_LABEL(physics)

static sq_context *make_ctx(int threads)
{
    sq_context *ctx = NULL;
    sq_context_desc cd = {.threads = threads, .log_level = SQ_LOG_WARN};
    if (sq_context_create(&cd, &ctx) != SQ_OK) return NULL;
    return ctx;
}

/* ---- plane Poiseuille flow ------------------------------------------------------------------
 * Channel 0 < z < 2 h_c between no-slip walls, periodic in x and y, driven by a body force G
 * (per volume) along x. Power law τ = K |γ̇|^(n−1) γ̇ (analytic_flows.md, with y = z − h_c):
 *     u(y) = n/(n+1) (G/K)^(1/n) (h_c^((n+1)/n) − |y|^((n+1)/n)).
 * Scales: h_c = 0.1 m, ρ₀ = 1000 kg/m³, wall shear rate 2 1/s, wall viscosity 10 Pa s, so
 * K = 10/2^(n−1), G = 200 Pa/m, Re = ρ u_c h_c/μ_w ≈ 1. 16 particles across the channel
 * (dx = h_c/8, H = 2 dx). The layer-averaged velocity is compared with the analytic profile at
 * the layer's mean height; errors are relative to the centreline speed u_c. */
typedef struct pois_result {
    double err_max, err_l2, uc;
    int layers;
} pois_result;

static pois_result run_poiseuille(sq_sph_rheology rh, double n, double t_end)
{
    pois_result res = {1e9, 1e9, 0.0, 0};
    sq_context *ctx = make_ctx(0);
    const double hc = 0.1, dx = hc / 8.0, rho0 = 1000.0, mu_w = 10.0, gw = 2.0;
    const double K = mu_w / pow(gw, n - 1.0), G = mu_w * gw / hc;
    const double uc = n / (n + 1.0) * pow(G / K, 1.0 / n) * pow(hc, (n + 1.0) / n);
    sq_sph_desc d;
    memset(&d, 0, sizeof d);
    d.spacing_m = dx;
    d.rest_density_kgm3 = rho0;
    d.rheology = rh;
    d.gravity_mps2[0] = G / rho0;
    d.max_speed_mps = uc;
    d.speed_of_sound_mps = 1.2;
    const double L = 6.0 * dx; /* three neighbour cells */
    d.domain_max_m[0] = d.domain_max_m[1] = L;
    d.domain_max_m[2] = 2.0 * hc;
    for (int f = 0; f < 4; f++) d.boundary[f] = SQ_SPH_BOUNDARY_PERIODIC;
    d.max_particles = 1000;
    sq_sph *s = NULL;
    SQ_CHECK_OK(sq_sph_create(ctx, &d, &s));
    const double lo[3] = {0, 0, 0}, hi[3] = {L, L, 2.0 * hc};
    size_t np = 0;
    SQ_CHECK_OK(sq_sph_add_block(s, lo, hi, NULL, &np));
    SQ_CHECK(np == 6 * 6 * 16);
    for (double t = 0.0; t < t_end - 1e-9; t += 0.1) {
        sq_result r = sq_sph_step(s, 0.1);
        SQ_CHECK_OK(r);
        if (r != SQ_OK) break;
    }
    const sq_sph_view v = sq_sph_particles(s);
    double su[16] = {0}, sz[16] = {0}, cn[16] = {0};
    for (size_t i = 0; i < v.count; i++) {
        int b = (int)(v.z[i] / dx);
        b = b < 0 ? 0 : b > 15 ? 15 : b;
        su[b] += v.vx[i];
        sz[b] += v.z[i];
        cn[b] += 1.0;
    }
    double emax = 0.0, e2 = 0.0;
    int nl = 0;
    for (int b = 0; b < 16; b++) {
        if (cn[b] == 0.0) continue;
        const double y = fabs(sz[b] / cn[b] - hc);
        const double ua = n / (n + 1.0) * pow(G / K, 1.0 / n) *
                          (pow(hc, (n + 1.0) / n) - pow(y, (n + 1.0) / n));
        const double e = (su[b] / cn[b] - ua) / uc;
        emax = fmax(emax, fabs(e));
        e2 += e * e;
        nl++;
    }
    res.err_max = emax;
    res.err_l2 = nl ? sqrt(e2 / nl) : 1e9;
    res.uc = uc;
    res.layers = nl;
    printf("poiseuille n = %.2f: u_c = %.5f m/s, %d layers, max error %.4f u_c, L2 error %.4f u_c\n",
           n, uc, nl, emax, res.err_l2);
    sq_sph_destroy(s);
    sq_context_destroy(ctx);
    return res;
}

/* Shear-thinning n = 0.5: μ = K|γ̇|^(−1/2) diverges at the centreline; it is capped at
 * 5 μ_w (which alone shifts u_c by (1/5)³/2 = 0.4 %, see sq_sph_rheology.mu_max_pa_s) to keep
 * the viscous time-step limit finite. From rest to steady state (~5 viscous times). */
SQ_TEST(poiseuille_power_law_n05)
{
    const double n = 0.5;
    sq_sph_rheology rh = {.kind = SQ_SPH_RHEOLOGY_POWER_LAW, .k = 10.0 / pow(2.0, n - 1.0),
                          .n = n, .mu_max_pa_s = 50.0, .shear_rate_min_per_s = 1e-6};
    const pois_result r = run_poiseuille(rh, n, 2.5);
    SQ_CHECK(r.layers == 16);
    SQ_CHECK(r.err_max < 0.03);
    SQ_CHECK(r.err_l2 < 0.02);
}

/* Shear-thickening n = 1.5 (μ → 0 at the centreline; the default floor 1e-3 1/s). */
SQ_TEST(poiseuille_power_law_n15)
{
    const double n = 1.5;
    sq_sph_rheology rh = {.kind = SQ_SPH_RHEOLOGY_POWER_LAW, .k = 10.0 / pow(2.0, n - 1.0),
                          .n = n};
    const pois_result r = run_poiseuille(rh, n, 2.0);
    SQ_CHECK(r.layers == 16);
    SQ_CHECK(r.err_max < 0.03);
    SQ_CHECK(r.err_l2 < 0.02);
}

/* Newtonian μ = 10 Pa s (n = 1 of the same formula: u = G/(2μ) y(2h_c − y)). */
SQ_TEST(poiseuille_newtonian)
{
    sq_sph_rheology rh = {.kind = SQ_SPH_RHEOLOGY_NEWTONIAN, .mu_pa_s = 10.0};
    const pois_result r = run_poiseuille(rh, 1.0, 2.0);
    SQ_CHECK(r.layers == 16);
    SQ_CHECK(r.err_max < 0.03);
    SQ_CHECK(r.err_l2 < 0.02);
}

/* ---- hydrostatic column ------------------------------------------------------------------
 * A 0.3 m water column (12 layers, dx = 2.5 cm, 6 x 6 columns) in a box with no-slip walls on
 * x and the floor (mirror images), periodic in y, μ = 5 Pa s. Gravity is ramped up smoothly
 * over 0.4 s (Adami et al. 2012) and held to t = 2 s. The reference is the weight of the
 * particles above each layer per unit area (exact momentum balance: it needs no assumption on
 * the compressed height), p_ref(z_i) = g m (N_above + ½ N_same)/A. Layers deeper than 1.5 H
 * (the top three are inside the kernel truncation of the free surface) must be within 2 %;
 * the column must be at rest: every particle slower than 2 % of sqrt(2 g h). */
SQ_TEST(hydrostatic_column)
{
    sq_context *ctx = make_ctx(0);
    const double dx = 0.025, h = 0.3, W = 6 * dx, g = 9.81;
    sq_sph_desc d;
    memset(&d, 0, sizeof d);
    d.spacing_m = dx;
    d.rheology.kind = SQ_SPH_RHEOLOGY_NEWTONIAN;
    d.rheology.mu_pa_s = 5.0;
    d.max_speed_mps = sqrt(2.0 * g * h);
    d.domain_max_m[0] = W;
    d.domain_max_m[1] = W;
    d.domain_max_m[2] = 1.5 * h;
    d.boundary[SQ_SPH_FACE_YMIN] = d.boundary[SQ_SPH_FACE_YMAX] = SQ_SPH_BOUNDARY_PERIODIC;
    d.max_particles = 1000;
    sq_sph *s = NULL;
    SQ_CHECK_OK(sq_sph_create(ctx, &d, &s));
    const double lo[3] = {0, 0, 0}, hi[3] = {W, W, h};
    size_t n = 0;
    SQ_CHECK_OK(sq_sph_add_block(s, lo, hi, NULL, &n));
    SQ_CHECK(n == 432);
    const double ramp = 0.4, frame = 0.025;
    for (int f = 1; f <= 80; f++) {
        const double t = f * frame;
        const double gf = t >= ramp ? 1.0 : 0.5 * (1.0 - cos(M_PI * t / ramp));
        const double gv[3] = {0.0, 0.0, -g * gf};
        SQ_CHECK_OK(sq_sph_set_gravity(s, gv));
        const sq_result r = sq_sph_step(s, frame);
        SQ_CHECK_OK(r);
        if (r != SQ_OK) break;
    }
    const sq_sph_view v = sq_sph_particles(s);
    const double m = sq_sph_get_info(s).particle_mass_kg, A = W * W;
    double ps[16] = {0}, pr[16] = {0}, zs[16] = {0}, cn[16] = {0};
    double vmax = 0.0, ztop = 0.0;
    for (size_t i = 0; i < v.count; i++) {
        double above = 0.0;
        for (size_t j = 0; j < v.count; j++) {
            const double dz = v.z[j] - v.z[i];
            above += dz > 0.5 * dx ? 1.0 : (fabs(dz) <= 0.5 * dx ? 0.5 : 0.0);
        }
        int b = (int)(v.z[i] / dx);
        b = b < 0 ? 0 : b > 15 ? 15 : b;
        ps[b] += v.pressure[i];
        pr[b] += g * m * above / A;
        zs[b] += v.z[i];
        cn[b] += 1.0;
        vmax = fmax(vmax, sqrt(v.vx[i] * v.vx[i] + v.vy[i] * v.vy[i] + v.vz[i] * v.vz[i]));
        ztop = fmax(ztop, v.z[i]);
    }
    const double H = sq_sph_get_info(s).support_radius_m;
    double worst = 0.0;
    int checked = 0;
    for (int b = 0; b < 16; b++) {
        if (cn[b] == 0.0) continue;
        const double z = zs[b] / cn[b], rel = (ps[b] - pr[b]) / pr[b];
        printf("  layer z = %.4f m: p = %8.2f Pa, weight above = %8.2f Pa, rel %+.4f\n", z,
               ps[b] / cn[b], pr[b] / cn[b], rel);
        if (ztop - z >= 1.5 * H) {
            worst = fmax(worst, fabs(rel));
            checked++;
        }
    }
    printf("hydrostatic: worst layer error %.4f over %d layers, max speed %.4f m/s\n", worst,
           checked, vmax);
    SQ_CHECK(checked >= 8);
    SQ_CHECK(worst < 0.02);
    SQ_CHECK(vmax < 0.02 * sqrt(2.0 * g * h));
    sq_sph_destroy(s);
    sq_context_destroy(ctx);
}

/* ---- momentum conservation ------------------------------------------------------------------
 * Fully periodic box, no body force, random velocities (Philox): every pair term (pressure,
 * viscous, artificial viscosity, XSPH) is antisymmetric, so the total momentum — summed in
 * double — may change only by float round-off. Checked for each viscous form, with the Cross
 * rheology (non-Newtonian path) and gradient correction. */
static double momentum_drift(sq_sph_viscous form, sq_sph_kernel kernel, double *scale)
{
    sq_context *ctx = make_ctx(0);
    const double dx = 0.05, L = 8 * dx;
    sq_sph_desc d;
    memset(&d, 0, sizeof d);
    d.spacing_m = dx;
    d.kernel = kernel;
    d.viscous = form;
    SQ_CHECK_OK(sq_sph_rheology_preset("s2-avalanche", &d.rheology));
    d.rheology.k = 3.0; /* so that μ really varies with the shear rate here */
    d.rest_density_kgm3 = 300.0;
    d.speed_of_sound_mps = 20.0;
    d.artificial_viscosity = 0.05;
    for (int a = 0; a < 3; a++) d.domain_max_m[a] = L;
    for (int f = 0; f < 6; f++) d.boundary[f] = SQ_SPH_BOUNDARY_PERIODIC;
    d.max_particles = 1000;
    sq_sph *s = NULL;
    SQ_CHECK_OK(sq_sph_create(ctx, &d, &s));
    float pos[3 * 512], vel[3 * 512];
    int k = 0;
    for (int c = 0; c < 8; c++)
        for (int b = 0; b < 8; b++)
            for (int a = 0; a < 8; a++, k++) {
                /* jittered lattice, velocities uniform in [-1, 1] m/s */
                pos[3 * k] = (float)((a + 0.5 + 0.2 * (sq_rng_uniform(7, 0, (uint64_t)k) - 0.5)) * dx);
                pos[3 * k + 1] = (float)((b + 0.5 + 0.2 * (sq_rng_uniform(7, 1, (uint64_t)k) - 0.5)) * dx);
                pos[3 * k + 2] = (float)((c + 0.5 + 0.2 * (sq_rng_uniform(7, 2, (uint64_t)k) - 0.5)) * dx);
                for (int e = 0; e < 3; e++)
                    vel[3 * k + e] = (float)(2.0 * sq_rng_uniform(7, 3 + (uint64_t)e, (uint64_t)k) - 1.0);
            }
    SQ_CHECK_OK(sq_sph_add_particles(s, 512, pos, vel));
    const double m = sq_sph_get_info(s).particle_mass_kg;
    double p0[3] = {0, 0, 0}, p1[3] = {0, 0, 0}, sc = 0.0;
    sq_sph_view v = sq_sph_particles(s);
    for (size_t i = 0; i < v.count; i++) {
        p0[0] += m * v.vx[i];
        p0[1] += m * v.vy[i];
        p0[2] += m * v.vz[i];
        sc += m * sqrt(v.vx[i] * v.vx[i] + v.vy[i] * v.vy[i] + v.vz[i] * v.vz[i]);
    }
    for (int f = 0; f < 20; f++) SQ_CHECK_OK(sq_sph_step(s, 2e-3));
    v = sq_sph_particles(s);
    double moved = 0.0;
    for (size_t i = 0; i < v.count; i++) {
        p1[0] += m * v.vx[i];
        p1[1] += m * v.vy[i];
        p1[2] += m * v.vz[i];
    }
    const sq_sph_stats st = sq_sph_get_stats(s);
    moved = st.steps;
    const double dp = sqrt((p1[0] - p0[0]) * (p1[0] - p0[0]) + (p1[1] - p0[1]) * (p1[1] - p0[1]) +
                           (p1[2] - p0[2]) * (p1[2] - p0[2]));
    printf("momentum: form %d kernel %d: %g sub-steps, |dP| = %.3g, sum m|v| = %.3g, ratio %.2e\n",
           (int)form, (int)kernel, moved, dp, sc, dp / sc);
    SQ_CHECK(st.steps >= 20);
    *scale = sc;
    sq_sph_destroy(s);
    sq_context_destroy(ctx);
    return dp;
}

SQ_TEST(momentum_conservation)
{
    const sq_sph_viscous forms[3] = {SQ_SPH_VISCOUS_MORRIS, SQ_SPH_VISCOUS_MULLER,
                                     SQ_SPH_VISCOUS_TENSOR};
    for (int f = 0; f < 3; f++)
        for (int kern = SQ_SPH_KERNEL_MULLER; kern <= SQ_SPH_KERNEL_CUBIC; kern++) {
            double sc = 0.0;
            const double dp = momentum_drift(forms[f], (sq_sph_kernel)kern, &sc);
            SQ_CHECK(dp < 1e-5 * sc);
        }
}

/* The same run with 1 and 2 threads is bit-identical (every pass writes only its own
 * particle; the only reductions are maxima). */
SQ_TEST(threads_bit_identical)
{
    static float out[2][3 * 16000];
    size_t count[2] = {0, 0};
    for (int t = 0; t < 2; t++) {
        sq_context *ctx = make_ctx(t + 1);
        sq_sph_desc d;
        memset(&d, 0, sizeof d);
        d.spacing_m = 0.04;
        SQ_CHECK_OK(sq_sph_rheology_preset("s2-avalanche", &d.rheology));
        d.rest_density_kgm3 = 300.0;
        d.gravity_mps2[0] = 3.0;
        d.gravity_mps2[2] = -9.81;
        d.domain_max_m[0] = 2.0;
        d.domain_max_m[1] = 1.0;
        d.domain_max_m[2] = 1.0;
        d.boundary[SQ_SPH_FACE_XMIN] = d.boundary[SQ_SPH_FACE_XMAX] = SQ_SPH_BOUNDARY_PERIODIC;
        d.max_particles = 16000;
        sq_sph *s = NULL;
        SQ_CHECK_OK(sq_sph_create(ctx, &d, &s));
        const double lo[3] = {0, 0, 0}, hi[3] = {2.0, 1.0, 0.45}; /* 50 x 25 x 11 */
        size_t n = 0;
        SQ_CHECK_OK(sq_sph_add_block(s, lo, hi, NULL, &n));
        SQ_CHECK(n >= 8192); /* above the serial threshold */
        for (int f = 0; f < 2; f++) SQ_CHECK_OK(sq_sph_step(s, 1e-3));
        const sq_sph_view v = sq_sph_particles(s);
        count[t] = v.count;
        for (size_t i = 0; i < v.count && i < 16000; i++) {
            out[t][3 * i] = v.x[i];
            out[t][3 * i + 1] = v.vx[i];
            out[t][3 * i + 2] = v.viscosity[i];
        }
        sq_sph_destroy(s);
        sq_context_destroy(ctx);
    }
    SQ_CHECK(count[0] == count[1]);
    SQ_CHECK(memcmp(out[0], out[1], sizeof(float) * 3 * count[0]) == 0);
}

/* A portable build on an AVX-512 CPU runs the AVX-512 passes, chosen at run time
 * (sph_passes_v4.c); SQ_SPH_ISA=portable forces the portable loops. The per-pair arithmetic is
 * the same and only the order of the sums over neighbours differs (16 lanes), so after a few
 * steps of a sheared avalanche block the two runs differ only by float rounding: |dx| below
 * 1e-4 of the spacing, relative density below 1e-4 (measured: ~1e-5 dx and ~4e-6 after 20
 * steps, docs/performance.md). They must differ at all — else both runs took the same loops.
 * Builds without run-time dispatch (native, sanitizers, a CPU without AVX-512) skip this. */
SQ_TEST(runtime_avx512_dispatch_agrees_with_portable_loops)
{
    unsetenv("SQ_SPH_ISA");
    const int v4 = sq__sph_uses_avx512();
    setenv("SQ_SPH_ISA", "portable", 1);
    const int portable = !sq__sph_uses_avx512();
    unsetenv("SQ_SPH_ISA");
    if (!v4 || !portable) {
        printf("no run-time choice of SPH loops in this build/CPU (AVX-512 %d): skipped\n", v4);
        return;
    }
    enum { NP = 9000 };
    static float out[2][4 * NP];
    size_t count[2] = {0, 0};
    const double dx = 0.04;
    for (int t = 0; t < 2; t++) {
        if (t == 1) setenv("SQ_SPH_ISA", "portable", 1);
        sq_context *ctx = make_ctx(1);
        sq_sph_desc d;
        memset(&d, 0, sizeof d);
        d.spacing_m = dx;
        SQ_CHECK_OK(sq_sph_rheology_preset("s2-avalanche", &d.rheology));
        d.rest_density_kgm3 = 300.0;
        d.gravity_mps2[0] = 3.0;
        d.gravity_mps2[2] = -9.81;
        d.domain_max_m[0] = 2.0;
        d.domain_max_m[1] = 1.0;
        d.domain_max_m[2] = 1.0;
        d.boundary[SQ_SPH_FACE_XMIN] = d.boundary[SQ_SPH_FACE_XMAX] = SQ_SPH_BOUNDARY_PERIODIC;
        d.max_particles = NP;
        sq_sph *s = NULL;
        SQ_CHECK_OK(sq_sph_create(ctx, &d, &s));
        unsetenv("SQ_SPH_ISA");
        if (!s) return;
        const double lo[3] = {0, 0, 0}, hi[3] = {2.0, 1.0, 0.28}; /* 50 x 25 x 7 */
        SQ_CHECK_OK(sq_sph_add_block(s, lo, hi, NULL, NULL));
        for (int f = 0; f < 5; f++) SQ_CHECK_OK(sq_sph_step(s, 1e-3));
        const sq_sph_view v = sq_sph_particles(s);
        count[t] = v.count;
        for (size_t i = 0; i < v.count; i++) { /* by id: a particle may change cell order */
            if (v.id[i] >= NP) continue;
            float *o = &out[t][4 * (size_t)v.id[i]];
            o[0] = v.x[i];
            o[1] = v.y[i];
            o[2] = v.z[i];
            o[3] = v.density[i];
        }
        sq_sph_destroy(s);
        sq_context_destroy(ctx);
    }
    SQ_CHECK(count[0] == count[1] && count[0] == 8750);
    double dpos = 0.0, drho = 0.0;
    for (size_t i = 0; i < count[0] && i < NP; i++) {
        for (int a = 0; a < 3; a++)
            dpos = fmax(dpos, fabs((double)out[0][4 * i + a] - (double)out[1][4 * i + a]));
        drho = fmax(drho, fabs((double)out[0][4 * i + 3] - (double)out[1][4 * i + 3]) /
                              (double)out[1][4 * i + 3]);
    }
    printf("AVX-512 vs portable loops after 5 steps: max |dx| = %.2e spacing, max |drho|/rho = "
           "%.2e\n", dpos / dx, drho);
    SQ_CHECK(dpos > 0.0 || drho > 0.0); /* the two runs took different loops */
    SQ_CHECK(dpos < 1e-4 * dx);
    SQ_CHECK(drho < 1e-4);
}

/* The neighbour-list capacity is storage only: a run that starts with room for 8 entries per
 * particle (so that the lists overflow, grow and the pass is redone, and the appends near the
 * end of a list take the one-at-a-time path) gives bit-identical particles to one with the
 * default room, mirror images at the walls included. */
SQ_TEST(list_capacity_does_not_change_results)
{
    static float out[2][3 * 4000];
    size_t count[2] = {0, 0};
    int cap[2] = {0, 0};
    for (int t = 0; t < 2; t++) {
        sq_context *ctx = make_ctx(1);
        sq_sph_desc d;
        memset(&d, 0, sizeof d);
        d.spacing_m = 0.05;
        SQ_CHECK_OK(sq_sph_rheology_preset("s2-avalanche", &d.rheology));
        d.rest_density_kgm3 = 300.0;
        d.gravity_mps2[0] = 3.0;
        d.gravity_mps2[2] = -9.81;
        d.domain_max_m[0] = 1.0;
        d.domain_max_m[1] = 0.6;
        d.domain_max_m[2] = 0.6;
        d.neighbour_capacity = t == 0 ? 8 : 0;
        d.max_particles = 4000;
        sq_sph *s = NULL;
        SQ_CHECK_OK(sq_sph_create(ctx, &d, &s));
        const double lo[3] = {0, 0, 0}, hi[3] = {0.6, 0.6, 0.3}; /* 12 x 12 x 6, on 5 walls */
        SQ_CHECK_OK(sq_sph_add_block(s, lo, hi, NULL, NULL));
        for (int f = 0; f < 3; f++) SQ_CHECK_OK(sq_sph_step(s, 1e-3));
        const sq_sph_view v = sq_sph_particles(s);
        count[t] = v.count;
        for (size_t i = 0; i < v.count && i < 4000; i++) {
            out[t][3 * i] = v.x[i];
            out[t][3 * i + 1] = v.vz[i];
            out[t][3 * i + 2] = v.density[i];
        }
        cap[t] = sq_sph_get_info(s).neighbour_capacity;
        SQ_CHECK(sq_sph_get_stats(s).max_neighbours > 8);
        sq_sph_destroy(s);
        sq_context_destroy(ctx);
    }
    SQ_CHECK(cap[0] > 8);          /* it grew */
    SQ_CHECK(cap[0] != cap[1]);    /* and the two runs really had different lists */
    SQ_CHECK(count[0] == count[1] && count[0] == 864);
    SQ_CHECK(memcmp(out[0], out[1], sizeof(float) * 3 * count[0]) == 0);
}

/* ---- colliders ------------------------------------------------------------------------------
 * One particle (no SPH neighbours, so only gravity and the contact act) on a planar heightfield
 * z = −x tan θ. Kinetic Coulomb friction gives the along-slope acceleration
 * a = g (sin θ − μ_k cos θ); with μ_k > tan θ the particle stays put. */
static sq_sph *single_particle_world(sq_context *ctx, double slope_deg, double friction,
                                     bool frictionless, double restitution, const float p0[3],
                                     const float v0[3])
{
    sq_sph_desc d;
    memset(&d, 0, sizeof d);
    d.spacing_m = 0.5; /* a coarse neighbour grid over the 40 m box */
    d.collision_radius_m = 0.025;
    d.speed_of_sound_mps = 50.0;
    d.gravity_mps2[2] = -9.81;
    d.domain_min_m[0] = -20.0;
    d.domain_min_m[1] = -2.0;
    d.domain_min_m[2] = -20.0;
    d.domain_max_m[0] = 20.0;
    d.domain_max_m[1] = 2.0;
    d.domain_max_m[2] = 20.0;
    d.max_particles = 4;
    sq_sph *s = NULL;
    if (sq_sph_create(ctx, &d, &s) != SQ_OK) return NULL;
    float hts[4 * 3];
    const double t = tan(slope_deg * M_PI / 180.0);
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 4; i++) hts[j * 4 + i] = (float)(-(-15.0 + 10.0 * i) * t);
    sq_sph_terrain_desc td;
    memset(&td, 0, sizeof td);
    td.origin_m[0] = -15.0;
    td.origin_m[1] = -2.0;
    td.spacing_m[0] = 10.0;
    td.spacing_m[1] = 2.0;
    td.nx = 4;
    td.ny = 3;
    td.heights_m = hts;
    td.contact.friction = friction;
    td.contact.frictionless = frictionless;
    td.contact.restitution = restitution;
    SQ_CHECK_OK(sq_sph_set_terrain(s, &td));
    SQ_CHECK_OK(sq_sph_add_particles(s, 1, p0, v0));
    return s;
}

SQ_TEST(terrain_coulomb_friction)
{
    sq_context *ctx = make_ctx(1);
    const double th = 30.0, g = 9.81, r = 0.025;
    const double n[3] = {sin(th * M_PI / 180.0), 0.0, cos(th * M_PI / 180.0)};
    /* start on the surface (at the collision radius along the normal), at rest */
    const float p0[3] = {(float)(r * n[0]), 0.0f, (float)(r * n[2])};
    double h, nn[3];
    for (int c = 0; c < 3; c++) {
        const double mu = c == 0 ? 0.2 : c == 1 ? 0.0 : 0.7;
        sq_sph *s = single_particle_world(ctx, th, mu, c == 1, 0.0, p0, NULL);
        SQ_CHECK(s != NULL);
        if (!s) continue;
        SQ_CHECK_OK(sq_sph_terrain_sample(s, 1.0, 0.5, &h, nn));
        SQ_CHECK_NEAR(h, -tan(th * M_PI / 180.0), 1e-5);
        SQ_CHECK_NEAR(nn[0], n[0], 1e-6);
        SQ_CHECK_NEAR(nn[2], n[2], 1e-6);
        const double T = 1.0;
        for (int f = 0; f < 10; f++) SQ_CHECK_OK(sq_sph_step(s, T / 10));
        const sq_sph_view v = sq_sph_particles(s);
        const double speed = sqrt(v.vx[0] * v.vx[0] + v.vz[0] * v.vz[0]);
        const double a = g * (sin(th * M_PI / 180.0) - mu * cos(th * M_PI / 180.0));
        /* the particle stays on the slope */
        sq_sph_terrain_sample(s, v.x[0], v.y[0], &h, nn);
        const double dist = (v.z[0] - h) * nn[2];
        printf("slope %.0f deg, mu_k %.1f: speed %.4f m/s after %.1f s (analytic %.4f), "
               "height above the surface %.4f m\n",
               th, mu, speed, T, a > 0 ? a * T : 0.0, dist);
        if (a > 0) {
            SQ_CHECK_REL(speed, a * T, 0.02);
            SQ_CHECK(v.vx[0] > 0.0f); /* downhill is +x */
        } else {
            SQ_CHECK(speed < 1e-3);
        }
        SQ_CHECK_NEAR(dist, r, 0.01);
        SQ_CHECK(fabs(v.vy[0]) < 1e-6);
        sq_sph_destroy(s);
    }
    sq_context_destroy(ctx);
}

/* A particle dropped on flat ground with restitution e rebounds with e times the impact speed;
 * with e = 0 it stays on the ground. */
SQ_TEST(terrain_restitution)
{
    sq_context *ctx = make_ctx(1);
    const float p0[3] = {0.0f, 0.0f, 1.0f};
    for (int c = 0; c < 2; c++) {
        const double e = c == 0 ? 0.5 : 0.0;
        sq_sph *s = single_particle_world(ctx, 0.0, 0.2, false, e, p0, NULL);
        SQ_CHECK(s != NULL);
        if (!s) continue;
        /* fall 1 m − r: impact speed sqrt(2 g (1 − r)) */
        const double vimp = sqrt(2.0 * 9.81 * (1.0 - 0.025));
        double vup = 0.0, zmax_after = 0.0;
        int bounced = 0;
        for (int f = 0; f < 200; f++) {
            SQ_CHECK_OK(sq_sph_step(s, 5e-3));
            const sq_sph_view v = sq_sph_particles(s);
            if (v.vz[0] > 0.0f && !bounced) {
                bounced = 1;
                vup = v.vz[0];
            }
            if (bounced) zmax_after = fmax(zmax_after, v.z[0]);
        }
        printf("restitution %.1f: rebound speed %.4f m/s (expected %.4f), apex %.4f m\n", e, vup,
               e * vimp, zmax_after);
        if (e > 0) {
            SQ_CHECK_REL(vup, e * vimp, 0.03);
            /* apex: r + e² (1 − r) */
            SQ_CHECK_REL(zmax_after, 0.025 + e * e * (1.0 - 0.025), 0.05);
        } else {
            SQ_CHECK(vup < 0.05);
            SQ_CHECK(zmax_after < 0.03);
        }
        sq_sph_destroy(s);
    }
    sq_context_destroy(ctx);
}

/* A particle thrown horizontally at a building stops at its face (e = 0, frictionless) or
 * comes back at the same speed (e = 1). */
SQ_TEST(box_obstacle)
{
    sq_context *ctx = make_ctx(1);
    for (int c = 0; c < 2; c++) {
        const double e = c == 0 ? 0.0 : 1.0;
        const float p0[3] = {0.0f, 0.0f, 5.0f}, v0[3] = {4.0f, 0.0f, 0.0f};
        sq_sph *s = single_particle_world(ctx, 0.0, 0.0, true, 0.0, p0, v0);
        SQ_CHECK(s != NULL);
        if (!s) continue;
        const double g0[3] = {0.0, 0.0, 0.0};
        SQ_CHECK_OK(sq_sph_set_gravity(s, g0));
        sq_sph_box_desc b;
        memset(&b, 0, sizeof b);
        b.min_m[0] = 1.0;
        b.min_m[1] = -1.0;
        b.min_m[2] = 0.0;
        b.max_m[0] = 3.0;
        b.max_m[1] = 1.0;
        b.max_m[2] = 10.0;
        b.contact.restitution = e;
        b.contact.frictionless = true;
        SQ_CHECK_OK(sq_sph_add_box_obstacle(s, &b));
        SQ_CHECK_OK(sq_sph_step(s, 0.5));
        const sq_sph_view v = sq_sph_particles(s);
        printf("box e = %.0f: x = %.4f m, vx = %.4f m/s\n", e, v.x[0], v.vx[0]);
        if (e == 0.0) {
            SQ_CHECK_NEAR(v.x[0], 1.0 - 0.025, 1e-4);
            SQ_CHECK_NEAR(v.vx[0], 0.0, 1e-6);
        } else {
            SQ_CHECK_NEAR(v.vx[0], -4.0, 1e-4);
            SQ_CHECK(v.x[0] < 1.0 - 0.025);
        }
        sq_sph_destroy(s);
    }
    sq_context_destroy(ctx);
}

/* Particles leaving through an open face are removed and counted; ids follow the survivors. */
SQ_TEST(open_face_removes_particles)
{
    sq_context *ctx = make_ctx(1);
    sq_sph_desc d;
    memset(&d, 0, sizeof d);
    d.spacing_m = 0.1;
    d.speed_of_sound_mps = 20.0;
    d.domain_max_m[0] = 2.0;
    d.domain_max_m[1] = 1.0;
    d.domain_max_m[2] = 1.0;
    d.boundary[SQ_SPH_FACE_XMAX] = SQ_SPH_BOUNDARY_OPEN;
    d.max_particles = 10;
    sq_sph *s = NULL;
    SQ_CHECK_OK(sq_sph_create(ctx, &d, &s));
    /* three isolated particles; the two fast ones leave through x = 2 m */
    const float p[9] = {1.5f, 0.5f, 0.5f, 1.0f, 0.2f, 0.2f, 0.5f, 0.8f, 0.8f};
    const float v[9] = {2.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 4.0f, 0.0f, 0.0f};
    SQ_CHECK_OK(sq_sph_add_particles(s, 3, p, v));
    SQ_CHECK_OK(sq_sph_step(s, 0.5));
    const sq_sph_view vw = sq_sph_particles(s);
    const sq_sph_stats st = sq_sph_get_stats(s);
    SQ_CHECK(vw.count == 1);
    SQ_CHECK(st.removed == 2);
    SQ_CHECK(vw.id[0] == 1);
    SQ_CHECK_NEAR(vw.x[0], 1.0, 1e-6);
    sq_sph_destroy(s);
    sq_context_destroy(ctx);
}

/* The thesis's Cross avalanche material (μ∞ = 1, μ₀ = 100 Pa s, n = 2, K = 3000 s) as a block
 * of snow (ρ₀ = 300 kg/m³) released on a 35° heightfield slope with μ_k = 0.2: it must flow
 * downhill as one mass, keep every particle, stay on the terrain, and its viscosities must lie
 * in [μ∞, μ₀]. Its centre of mass cannot outrun frictionless free sliding, g sin θ t²/2, and
 * must reach a fifth of it. */
SQ_TEST(cross_block_on_slope)
{
    sq_context *ctx = make_ctx(0);
    const double th = 35.0 * M_PI / 180.0, dx = 0.1, g = 9.81;
    sq_sph_desc d;
    memset(&d, 0, sizeof d);
    d.spacing_m = dx;
    d.rest_density_kgm3 = 300.0;
    SQ_CHECK_OK(sq_sph_rheology_preset("s2-avalanche", &d.rheology));
    d.gravity_mps2[2] = -g;
    d.max_speed_mps = 10.0;
    d.domain_min_m[0] = 0.0;
    d.domain_min_m[1] = 0.0;
    d.domain_min_m[2] = -8.0;
    d.domain_max_m[0] = 12.0;
    d.domain_max_m[1] = 1.2;
    d.domain_max_m[2] = 2.0;
    d.boundary[SQ_SPH_FACE_YMIN] = d.boundary[SQ_SPH_FACE_YMAX] = SQ_SPH_BOUNDARY_FREE_SLIP;
    d.boundary[SQ_SPH_FACE_XMAX] = SQ_SPH_BOUNDARY_OPEN;
    d.max_particles = 4000;
    sq_sph *s = NULL;
    SQ_CHECK_OK(sq_sph_create(ctx, &d, &s));
    float hts[2 * 13];
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 13; i++) hts[j * 13 + i] = (float)(-(double)i * tan(th));
    sq_sph_terrain_desc td;
    memset(&td, 0, sizeof td);
    td.spacing_m[0] = 1.0;
    td.spacing_m[1] = 1.2;
    td.nx = 13;
    td.ny = 2;
    td.heights_m = hts;
    SQ_CHECK_OK(sq_sph_set_terrain(s, &td));
    /* a block 1 m long, 1.2 m wide, 0.5 m deep resting on the slope near the top */
    float *pos = (float *)malloc(sizeof(float) * 3 * 4000);
    int n = 0;
    for (int k = 0; k < 5; k++)
        for (int j = 0; j < 12; j++)
            for (int i = 0; i < 10; i++) {
                const double u = 0.5 + (i + 0.5) * dx, w = (k + 0.5) * dx + 0.05;
                pos[3 * n] = (float)(u * cos(th) + w * sin(th)); /* u down the slope, w along the normal */
                pos[3 * n + 1] = (float)((j + 0.5) * dx);
                pos[3 * n + 2] = (float)(-u * sin(th) + w * cos(th));
                n++;
            }
    SQ_CHECK_OK(sq_sph_add_particles(s, (size_t)n, pos, NULL));
    free(pos);
    double x0 = 0.0;
    sq_sph_view v = sq_sph_particles(s);
    for (size_t i = 0; i < v.count; i++) x0 += v.x[i];
    x0 /= (double)v.count;
    const double T = 0.6;
    for (int f = 0; f < 6; f++) SQ_CHECK_OK(sq_sph_step(s, T / 6));
    v = sq_sph_particles(s);
    double x1 = 0.0, below = 1e9, mu_lo = 1e9, mu_hi = 0.0;
    for (size_t i = 0; i < v.count; i++) {
        x1 += v.x[i];
        double h, nn[3];
        sq_sph_terrain_sample(s, v.x[i], v.y[i], &h, nn);
        below = fmin(below, (v.z[i] - h) * nn[2]);
        mu_lo = fmin(mu_lo, v.viscosity[i]);
        mu_hi = fmax(mu_hi, v.viscosity[i]);
    }
    x1 /= (double)v.count;
    const double ds = (x1 - x0) / cos(th); /* along the slope */
    const double free_slide = 0.5 * g * sin(th) * T * T;
    const sq_sph_stats st = sq_sph_get_stats(s);
    printf("cross block: %zu particles, moved %.3f m along the slope in %.1f s (frictionless "
           "bound %.3f m), mu in [%.3f, %.3f] Pa s, lowest clearance %.4f m, %d sub-steps last "
           "frame (%s)\n",
           v.count, ds, T, free_slide, mu_lo, mu_hi, below, st.substeps, st.dt_limit);
    SQ_CHECK(v.count == 600);
    SQ_CHECK(ds > 0.2 * free_slide);
    SQ_CHECK(ds < free_slide);
    SQ_CHECK(mu_lo >= 1.0 - 1e-5 && mu_hi <= 100.0 + 1e-3);
    SQ_CHECK(below > 0.5 * 0.05); /* on the terrain: at least half the collision radius */
    sq_sph_destroy(s);
    sq_context_destroy(ctx);
}

/* The terrain-following neighbour grid (terrain_layer_m) finds the same neighbours as the dense
 * box grid: a Cross block released on a 35° slope with a 42 m drop moves the same way with both
 * (positions per particle id agree to rounding: only the summation order differs), the layered
 * grid is a fraction of the box's cells, and a particle thrown above the layer leaves the
 * domain through its open top. */
static void run_slope(double layer_m, double t_end, int *cells, size_t *count, float *xyz_by_id,
                      uint64_t *removed)
{
    sq_context *ctx = make_ctx(1);
    const double th = 35.0 * M_PI / 180.0, dx = 0.25, g = 9.81;
    sq_sph_desc d;
    memset(&d, 0, sizeof d);
    d.spacing_m = dx;
    d.rest_density_kgm3 = 300.0;
    SQ_CHECK_OK(sq_sph_rheology_preset("s2-avalanche", &d.rheology));
    d.gravity_mps2[2] = -g;
    d.max_speed_mps = 20.0;
    d.speed_of_sound_mps = 60.0;
    d.artificial_viscosity = 0.1;
    d.domain_min_m[0] = -4.0;
    d.domain_min_m[1] = -4.0;
    d.domain_min_m[2] = -45.0;
    d.domain_max_m[0] = 60.0;
    d.domain_max_m[1] = 10.0;
    d.domain_max_m[2] = 6.0;
    for (int f = 0; f < 6; f++) d.boundary[f] = SQ_SPH_BOUNDARY_OPEN;
    d.terrain_layer_m = layer_m;
    d.max_particles = 4000;
    sq_sph *s = NULL;
    SQ_CHECK_OK(sq_sph_create(ctx, &d, &s));
    float hts[2 * 65];
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 65; i++) hts[j * 65 + i] = (float)(-(double)(i - 4) * tan(th));
    sq_sph_terrain_desc td;
    memset(&td, 0, sizeof td);
    td.origin_m[0] = -4.0;
    td.origin_m[1] = -4.0;
    td.spacing_m[0] = 1.0;
    td.spacing_m[1] = 14.0;
    td.nx = 65;
    td.ny = 2;
    td.heights_m = hts;
    SQ_CHECK_OK(sq_sph_set_terrain(s, &td));
    float *pos = (float *)malloc(sizeof(float) * 3 * 4000);
    float vel[3 * 4000];
    memset(vel, 0, sizeof vel);
    int n = 0;
    for (int k = 0; k < 6; k++)
        for (int j = 0; j < 16; j++)
            for (int i = 0; i < 16; i++) {
                const double u = 1.0 + (i + 0.5) * dx, w = (k + 0.5) * dx + 0.05;
                pos[3 * n] = (float)(u * cos(th) + w * sin(th));
                pos[3 * n + 1] = (float)(1.0 + (j + 0.5) * dx);
                pos[3 * n + 2] = (float)(-u * sin(th) + w * cos(th));
                n++;
            }
    /* one particle far down the slope, thrown upward fast enough to leave a 4 m layer */
    pos[3 * n] = 40.0f;
    pos[3 * n + 1] = 3.0f;
    pos[3 * n + 2] = (float)(-40.0 * tan(th) + 0.3);
    vel[3 * n + 2] = 12.0f;
    n++;
    SQ_CHECK_OK(sq_sph_add_particles(s, (size_t)n, pos, vel));
    free(pos);
    for (int f = 0; f < 10; f++) SQ_CHECK_OK(sq_sph_step(s, 0.1 * t_end));
    const sq_sph_view v = sq_sph_particles(s);
    *count = v.count;
    for (size_t i = 0; i < v.count; i++)
        if (v.id[i] < 4000) {
            xyz_by_id[3 * v.id[i]] = v.x[i];
            xyz_by_id[3 * v.id[i] + 1] = v.y[i];
            xyz_by_id[3 * v.id[i] + 2] = v.z[i];
        }
    const sq_sph_info in = sq_sph_get_info(s);
    *cells = in.cells[0] * in.cells[1] * in.cells[2];
    *removed = sq_sph_get_stats(s).removed;
    sq_sph_destroy(s);
    sq_context_destroy(ctx);
}

SQ_TEST(terrain_following_grid_matches_the_box_grid)
{
    static float a[3 * 4000], b[3 * 4000];
    for (int run = 0; run < 2; run++) {
        const double t_end = run == 0 ? 0.05 : 1.0;
        for (int i = 0; i < 3 * 4000; i++) a[i] = b[i] = NAN;
        int ca = 0, cb = 0;
        size_t na = 0, nb = 0;
        uint64_t ra = 0, rb = 0;
        run_slope(0.0, t_end, &ca, &na, a, &ra);
        run_slope(4.0, t_end, &cb, &nb, b, &rb);
        double worst = 0.0, fa = -1e9, fb = -1e9;
        for (int id = 0; id < 1536; id++) {
            const double e = fabs((double)a[3 * id] - b[3 * id]) +
                             fabs((double)a[3 * id + 1] - b[3 * id + 1]) +
                             fabs((double)a[3 * id + 2] - b[3 * id + 2]);
            worst = fmax(worst, e);
            fa = fmax(fa, (double)a[3 * id]);
            fb = fmax(fb, (double)b[3 * id]);
        }
        printf("t = %.2f s: box grid %d cells, %zu particles, %llu removed; terrain-following "
               "%d cells, %zu particles, %llu removed; front x = %.3f / %.3f m; worst position "
               "difference %.2e m\n", t_end, ca, na, (unsigned long long)ra, cb, nb,
               (unsigned long long)rb, fa, fb, worst);
        if (run == 0) {
            /* a few dozen sub-steps: the same neighbours give the same motion to rounding */
            SQ_CHECK_MSG(worst < 1e-5, "worst difference %.3g m", worst);
        } else {
            SQ_CHECK(na == 1537 && ra == 0); /* the box holds the thrown particle */
            SQ_CHECK(nb == 1536 && rb == 1); /* the 4 m layer does not */
            SQ_CHECK(fa > 6.0);              /* the block slid */
            SQ_CHECK_NEAR(fb, fa, 0.01 * fa);
        }
        SQ_CHECK(cb * 4 < ca);
    }
}
