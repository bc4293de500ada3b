/* test_sph_friction.c — the basal friction of the flow column (sq_sph_collider_desc.
 * column_friction: Coulomb μ_k and Voellmy ξ, as in the depth-averaged avalanche models) against
 * analytic sliding on an inclined plane (the terrain is flat, gravity is tilted by the slope angle θ, so the plane
 * is unbounded and has no kinks):
 *   - Coulomb: a snow block launched at v0 down a plane gentler than its friction angle
 *     (tan θ < μ_k) decelerates at g (μ_k cos θ − sin θ) — the momentum balance of the whole
 *     block, whatever it does inside, as long as its base slides — and its centre of mass runs
 *     out v0² / (2 g (μ_k cos θ − sin θ));
 *   - Voellmy: a uniform layer of depth h (periodic along and across the slope) with μ_k and ξ
 *     approaches the Voellmy speed sqrt(ξ h (sin θ − μ_k cos θ)) as v_T tanh(g' t / v_T),
 *     g' = g (sin θ − μ_k cos θ). */
#include "sq_test.h"
#include "squall/sph.h"

SQ_LABEL(physics)

static sq_context *make_ctx(void)
{
    sq_context *ctx = NULL;
    sq_context_desc cd = {.threads = 0, .log_level = SQ_LOG_WARN};
    if (sq_context_create(&cd, &ctx) != SQ_OK) return NULL;
    return ctx;
}

static sq_sph *make_plane(sq_context *ctx, double th_deg, double dx, const double lo[3],
                          const double hi[3], int periodic_x, double mu, double xi, size_t cap)
{
    const double th = th_deg * M_PI / 180.0;
    sq_sph_desc d;
    memset(&d, 0, sizeof d);
    d.spacing_m = dx;
    d.rest_density_kgm3 = 300.0;
    SQ_CHECK_OK(sq_sph_rheology_preset("s2-avalanche", &d.rheology));
    d.gravity_mps2[0] = 9.81 * sin(th); /* down the slope: +x */
    d.gravity_mps2[2] = -9.81 * cos(th);
    d.max_speed_mps = 25.0;
    d.speed_of_sound_mps = 80.0;
    d.artificial_viscosity = 0.1;
    for (int a = 0; a < 3; a++) {
        d.domain_min_m[a] = lo[a];
        d.domain_max_m[a] = hi[a];
    }
    d.boundary[SQ_SPH_FACE_YMIN] = d.boundary[SQ_SPH_FACE_YMAX] = SQ_SPH_BOUNDARY_PERIODIC;
    d.boundary[SQ_SPH_FACE_XMIN] = d.boundary[SQ_SPH_FACE_XMAX] =
        periodic_x ? SQ_SPH_BOUNDARY_PERIODIC : SQ_SPH_BOUNDARY_OPEN;
    d.boundary[SQ_SPH_FACE_ZMIN] = d.boundary[SQ_SPH_FACE_ZMAX] = SQ_SPH_BOUNDARY_OPEN;
    d.max_particles = cap;
    sq_sph *s = NULL;
    SQ_CHECK_OK(sq_sph_create(ctx, &d, &s));
    if (!s) return NULL;
    const float h[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    sq_sph_terrain_desc td;
    memset(&td, 0, sizeof td);
    td.origin_m[0] = lo[0];
    td.origin_m[1] = lo[1];
    td.spacing_m[0] = hi[0] - lo[0];
    td.spacing_m[1] = hi[1] - lo[1];
    td.nx = td.ny = 2;
    td.heights_m = h;
    td.contact.friction = mu;
    td.contact.column_friction = true;
    td.contact.turbulent_friction_mps2 = xi;
    SQ_CHECK_OK(sq_sph_set_terrain(s, &td));
    return s;
}

/* Coulomb: a 1.5 m layer (periodic 6 x 3 m, so that it slides as a whole; a finite block
 * spreads and its stopped tail holds less than the kinetic friction) launched at 10 m/s down a
 * 10° plane with μ_k = 0.4 must stop after v0² / (2 g (μ_k cos θ − sin θ)) = 23.1 m.
 * dx = 0.5 m (3 particles deep): the column friction acts on the depth-averaged column, and
 * the sanitizer build runs this in seconds, not minutes. */
SQ_TEST(coulomb_layer_runout_on_an_inclined_plane)
{
    sq_context *ctx = make_ctx();
    const double dx = 0.5, mu = 0.4, th = 10.0 * M_PI / 180.0, v0 = 10.0;
    const double lo[3] = {0.0, 0.0, -1.0}, hi[3] = {6.0, 3.0, 4.0};
    sq_sph *s = make_plane(ctx, 10.0, dx, lo, hi, 1, mu, 0.0, 2000);
    const double blo[3] = {0.0, 0.0, 0.01}, bhi[3] = {6.0, 3.0, 1.51}, vel[3] = {v0, 0.0, 0.0};
    size_t n = 0;
    SQ_CHECK_OK(sq_sph_add_block(s, blo, bhi, vel, &n));
    const double decel = 9.81 * (mu * cos(th) - sin(th)), t_stop = v0 / decel;
    /* the distance: the mean velocity integrated (the periodic positions wrap) */
    double t = 0.0, dist = 0.0, vprev = v0, vmid = 0.0, worst = 0.0;
    const double dt = 0.05;
    for (int f = 0; f < 200 && t < t_stop + 1.0; f++) {
        SQ_CHECK_OK(sq_sph_step(s, dt));
        t += dt;
        const sq_sph_view v = sq_sph_particles(s);
        double vm = 0.0;
        for (size_t i = 0; i < v.count; i++) vm += v.vx[i];
        vm /= (double)v.count;
        dist += 0.5 * (vprev + vm) * dt;
        vprev = vm;
        const double va = fmax(v0 - decel * t, 0.0);
        worst = fmax(worst, fabs(vm - va) / v0);
        if (fabs(t - 0.5 * t_stop) < 0.5 * dt) vmid = vm;
    }
    const double runout = v0 * v0 / (2.0 * decel);
    printf("coulomb: %zu particles; mean speed at t_stop/2 = %.2f s: %.3f m/s (analytic %.3f); "
           "largest speed difference %.3f of v0; the layer ran %.3f m (analytic %.3f m, "
           "%+.2f %%)\n", n, 0.5 * t_stop, vmid, 0.5 * v0, worst, dist, runout,
           100.0 * (dist / runout - 1.0));
    SQ_CHECK(worst < 0.03);
    SQ_CHECK_REL(dist, runout, 0.02);
    sq_sph_destroy(s);
    sq_context_destroy(ctx);
}

/* Voellmy: a 2 m layer (periodic 6 x 3 m, dx = 0.5 m: 4 particles deep) on a 30° plane with μ_k = 0.2 and ξ = 500 m/s²
 * approaches sqrt(ξ h (sin θ − μ_k cos θ)) = 18.1 m/s. */
SQ_TEST(voellmy_layer_reaches_the_voellmy_speed)
{
    sq_context *ctx = make_ctx();
    const double dx = 0.5, mu = 0.2, xi = 500.0, h = 2.0, th = 30.0 * M_PI / 180.0;
    const double lo[3] = {0.0, 0.0, -1.0}, hi[3] = {6.0, 3.0, 6.0};
    sq_sph *s = make_plane(ctx, 30.0, dx, lo, hi, 1, mu, xi, 2000);
    const double blo[3] = {0.0, 0.0, 0.01}, bhi[3] = {6.0, 3.0, h + 0.01};
    size_t n = 0;
    SQ_CHECK_OK(sq_sph_add_block(s, blo, bhi, NULL, &n));
    const double vT = sqrt(xi * h * (sin(th) - mu * cos(th)));
    const double gp = 9.81 * (sin(th) - mu * cos(th));
    double t = 0.0, vm = 0.0, worst = 0.0;
    for (int f = 0; f < 100; f++) {
        SQ_CHECK_OK(sq_sph_step(s, 0.1));
        t += 0.1;
        const sq_sph_view v = sq_sph_particles(s);
        vm = 0.0;
        for (size_t i = 0; i < v.count; i++) vm += v.vx[i];
        vm /= (double)v.count;
        const double expect = vT * tanh(gp * t / vT);
        if (t > 6.0 - 1e-9) worst = fmax(worst, fabs(vm / expect - 1.0));
        if (getenv("VERB")) printf("t %.1f v %.3f expect %.3f\n", t, vm, expect);
    }
    printf("voellmy: %zu particles; mean speed after %.1f s %.2f m/s, the Voellmy block %.2f m/s "
           "(terminal %.2f m/s); worst relative difference from 6 s on %.3f\n", n, t, vm,
           vT * tanh(gp * t / vT), vT, worst);
    SQ_CHECK(worst < 0.03);
    SQ_CHECK_REL(vm, vT * tanh(gp * t / vT), 0.02);
    sq_sph_destroy(s);
    sq_context_destroy(ctx);
}
