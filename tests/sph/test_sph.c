/* test_sph.c — SPH physics against analytic solutions and conservation laws (SPEC §7):
 * a hydrostatic column, plane Poiseuille flow of power-law fluids (n = 0.5, 1.5) and of a
 * Newtonian fluid against ../shared/reference/analytic_flows.md, exact momentum conservation
 * in a periodic box, thread-count independence, Coulomb friction and restitution at the
 * terrain, box obstacles, open faces, and a Cross-rheology avalanche block on a slope. */
#include "sq_test.h"
#include "squall/rng.h"
#include "squall/sph.h"

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
