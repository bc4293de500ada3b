/* test_clouds.c — the clouds phenomenon (SPEC §8, issue 10) on analytic fields: cloud
 * segmentation against hand counts (6-connectivity, boundary cells, water paths), the particle
 * field carrying the extinction cross-section of the volume field (particles and volume show the
 * same cloud), structured particles conserving it, determinism for a seed, clouds drifting with
 * the wind, and a particle count beyond the memory limit refused before anything is allocated. */
#include "phen/clouds/clouds_internal.h"
#include "sq_test.h"
#include "squall/rng.h"

SQ_LABEL(physics)

static sq_context *ctx_new(uint64_t limit)
{
    sq_context_desc cd = {0};
    cd.log_level = SQ_LOG_NONE;
    cd.memory_limit_bytes = limit;
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    return ctx;
}

static sq_world *flat_world_e(sq_context *ctx, float exaggeration)
{
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_FLAT;
    wd.terrain.vertical_exaggeration = exaggeration;
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = 30000.0f;
    wd.terrain.resolution[0] = wd.terrain.resolution[1] = 33;
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &wd, &w));
    return w;
}

static sq_world *flat_world(sq_context *ctx) { return flat_world_e(ctx, 1.0f); }

/* A 6 x 5 x 4 grid (dx = dy = 1000 m, levels 100 m from z = 0) with hand-placed cloud water:
 *   A: cells (1,1,1), (2,1,1), (2,1,2)   -> 3 cells, all boundary, 2 columns
 *   B: cell (4,3,1), touching A nowhere; C: cell (3,2,1) touches A's (2,1,1) only along an edge
 *      (diagonal in x-y): separate with 6-connectivity.
 * Water 0.5 g/m³ in every cell except (2,1,2) with 0.2 g/m³ of ice; threshold 0.01. */
SQ_TEST(segmentation_hand_counts)
{
    sq_context *ctx = ctx_new(0);
    sq__cloud_grid g;
    memset(&g, 0, sizeof g);
    g.nx = 6;
    g.ny = 5;
    g.nz = 4;
    g.dx = g.dy = 1000.0f;
    sq_clouds_desc d;
    sq_clouds_desc_resolve(NULL, &d);
    sq__cloud_field f;
    SQ_CHECK_OK(sq__cloud_field_init(ctx, &f, &g, &d, 1.0f));
    const size_t cells = f.cells, cols = 30;
    float *z = calloc(cells, sizeof(float)), *zw = calloc(cells + cols, sizeof(float));
    float *q = calloc(cells, sizeof(float)), *qi = calloc(cells, sizeof(float));
    float *zero = calloc(cells, sizeof(float)), *ter = calloc(cols, sizeof(float));
    for (size_t c = 0; c < cells + cols; c++) zw[c] = 100.0f * (float)(c / cols);
    for (size_t c = 0; c < cells; c++) z[c] = 100.0f * (float)(c / cols) + 50.0f;
    q[sq__cell(&g, 1, 1, 1)] = 0.5f;
    q[sq__cell(&g, 2, 1, 1)] = 0.5f;
    qi[sq__cell(&g, 2, 1, 2)] = 0.2f;
    q[sq__cell(&g, 4, 3, 1)] = 0.5f;
    q[sq__cell(&g, 3, 2, 1)] = 0.5f;
    sq__cloud_frame fr;
    memset(&fr, 0, sizeof fr);
    fr.z_m = z;
    fr.z_w_m = zw;
    fr.conc[SQ_HYDRO_CLOUD] = q;
    fr.conc[SQ_HYDRO_ICE] = qi;
    fr.u = fr.v = fr.w = zero;
    fr.terrain_m = ter;
    sq__cloud_field_update(&f, &fr, 0.0, 0.0);
    sq__segmentation s;
    SQ_CHECK_OK(sq__segment_init(ctx, &s, &g));
    sq__segment_clouds(&s, &f, 0.01f);
    SQ_CHECK(s.clouds == 3);
    /* cloud 0 is met first in memory order: A at (1,1,1) */
    SQ_CHECK(s.info[0].cells == 3 && s.info[0].boundary_cells == 3);
    SQ_CHECK(f.label[sq__cell(&g, 2, 1, 2)] == 0 && f.label[sq__cell(&g, 3, 2, 1)] != 0);
    /* A's water paths over its 2 columns: liquid 2 x 0.5 x 100 / 2, ice 0.2 x 100 / 2 */
    SQ_CHECK_NEAR(s.info[0].lwp_g_m2, 50.0, 1e-4);
    SQ_CHECK_NEAR(s.info[0].iwp_g_m2, 10.0, 1e-4);
    SQ_CHECK_NEAR(s.info[0].top_m, 250.0, 1e-3);
    /* extent: x from 500 to 2500, z from 100 to 300 */
    SQ_CHECK_NEAR(s.info[0].min_m.x, 500.0, 1e-3);
    SQ_CHECK_NEAR(s.info[0].max_m.x, 2500.0, 1e-3);
    SQ_CHECK_NEAR(s.info[0].max_m.z, 300.0, 1e-3);
    /* domain: 4 cloudy columns of 30, mean liquid path 4 x 50 / 30 */
    SQ_CHECK_NEAR(s.cover_fraction, 4.0 / 30.0, 1e-12);
    SQ_CHECK_NEAR(s.lwp_g_m2, 4 * 50.0 / 30.0, 1e-4);
    SQ_CHECK_NEAR(s.cloud_top_m, 250.0, 1e-3);
    /* below the threshold nothing is cloud */
    sq__segment_clouds(&s, &f, 0.6f);
    SQ_CHECK(s.clouds == 0 && s.cover_fraction == 0.0);
    sq__segment_free(ctx, &s);
    sq__cloud_field_free(ctx, &f);
    free(z);
    free(zw);
    free(q);
    free(qi);
    free(zero);
    free(ter);
    sq_context_destroy(ctx);
}

/* The source's cloud fraction (WRF's CLDFRA) is the cells' sub-grid cover: the pattern covers
 * that share of a cell (mask >= 1/2 at 0.3 and 0.7 of random points, within 0.05); a cloudy cell
 * whose CLDFRA is 0 (the radiation scheme saw no cloud) and a source without CLDFRA get the
 * desc's cloud.fraction. */
SQ_TEST(cloud_fraction_from_the_source)
{
    sq_context *ctx = ctx_new(0);
    sq__cloud_grid g;
    memset(&g, 0, sizeof g);
    g.nx = 3;
    g.ny = 1;
    g.nz = 1;
    g.dx = g.dy = 6000.0f;
    sq_clouds_desc d;
    sq_clouds_desc_resolve(NULL, &d);
    d.cloud_fraction = 0.8;
    d.subgrid_scale_m = 300.0; /* many pattern cells per model cell: the share is a mean */
    sq__cloud_field f;
    SQ_CHECK_OK(sq__cloud_field_init(ctx, &f, &g, &d, 1.0f));
    float z[3] = {500.0f, 500.0f, 500.0f}, zw[6] = {0, 0, 0, 1000.0f, 1000.0f, 1000.0f};
    float q[3] = {0.3f, 0.3f, 0.3f}, zero[3] = {0}, ter[3] = {0};
    float cf[3] = {0.3f, 0.0f, 0.7f};
    sq__cloud_frame fr;
    memset(&fr, 0, sizeof fr);
    fr.z_m = z;
    fr.z_w_m = zw;
    fr.conc[SQ_HYDRO_CLOUD] = q;
    fr.u = fr.v = fr.w = zero;
    fr.terrain_m = ter;
    fr.cldfra = cf;
    sq__cloud_field_update(&f, &fr, 0.0, 0.0);
    SQ_CHECK(f.frac[0] == 0.3f && f.frac[1] == 0.8f && f.frac[2] == 0.7f);
    for (int c = 0; c < 3; c += 2) {
        int covered = 0;
        const int n = 20000;
        for (int k = 0; k < n; k++) {
            float u[4];
            sq_rng_uniform4(7, 99, (uint64_t)k, u);
            const float x = g.x0 + (float)c * g.dx + (u[0] - 0.5f) * g.dx;
            const float y = g.y0 + (u[1] - 0.5f) * g.dy, zz = 1000.0f * u[2];
            covered += sq__cloud_subgrid_mask(&f, x, y, zz, f.frac[c]) >= 0.5f;
        }
        printf("cell %d: CLDFRA %.1f, covered %.3f\n", c, (double)cf[c], (double)covered / n);
        SQ_CHECK_NEAR((double)covered / n, (double)cf[c], 0.05);
    }
    /* the next frame has no CLDFRA: the desc's fraction everywhere again */
    fr.cldfra = NULL;
    sq__cloud_field_update(&f, &fr, 60.0, 60.0);
    SQ_CHECK(f.frac[0] == 0.8f && f.frac[1] == 0.8f && f.frac[2] == 0.8f);
    sq__cloud_field_free(ctx, &f);
    sq_context_destroy(ctx);
}

static double particle_cross_section(const sq_drawable *d)
{
    const sq_clouds_view *v = &d->u.clouds;
    double x = 0.0;
    for (int i = 0; i < v->count; i++)
        x += (double)v->tau[i] * 0.3 * 3.14159265358979 * (double)v->radius_m[i] * v->radius_m[i];
    return x;
}

static double volume_cross_section(const sq_drawable *d)
{
    const sq_volume_view *v = &d->u.volume;
    const double cell = (double)v->size_m.x * v->size_m.y * v->size_m.z / ((double)v->nx * v->ny * v->nz);
    double x = 0.0;
    for (int i = 0; i < v->nx * v->ny * v->nz; i++) x += (double)v->density[i] * cell;
    return x;
}

/* Particles, structured particles and the voxelised field carry the same extinction cross-
 * section integral beta dV (m²): the particle field is the volume field, sampled. The world's
 * vertical exaggeration 3 stretches the volume and divides the extinction: the same integral. */
SQ_TEST(particles_carry_the_field)
{
    sq_context *ctx = ctx_new(0);
    double xv1 = 0.0;
    for (int e = 0; e < 2; e++) {
        sq_world *w = flat_world_e(ctx, e ? 3.0f : 1.0f);
        sq_clouds_desc d;
        memset(&d, 0, sizeof d);
        d.source = SQ_CLOUDS_SOURCE_CUMULUS;
        d.particles = 20000;
        d.plain = true;
        sq_clouds *c = NULL;
        SQ_CHECK_OK(sq_clouds_create(ctx, &d, w, &c));
        if (!c) {
            sq_world_destroy(ctx, w);
            break;
        }
        sq_drawable pd, vd;
        SQ_CHECK_OK(sq_clouds_drawable(c, &pd));
        SQ_CHECK_OK(sq_clouds_volume_drawable(c, &vd));
        const double xp = particle_cross_section(&pd), xv = volume_cross_section(&vd);
        printf("exaggeration %d: particles %.4g m2, volume %.4g m2\n", e ? 3 : 1, xp, xv);
        SQ_CHECK_REL(xp, xv, 0.06);
        /* the stretched volume holds the same integral as the unstretched one */
        if (e) SQ_CHECK_REL(xv, xv1, 0.06);
        else xv1 = xv;
        sq_clouds_destroy(c);
        d.plain = false;
        SQ_CHECK_OK(sq_clouds_create(ctx, &d, w, &c));
        if (c) {
            SQ_CHECK_OK(sq_clouds_drawable(c, &pd));
            sq_clouds_stats st;
            SQ_CHECK_OK(sq_clouds_stats_get(c, &st));
            SQ_CHECK(st.clusters < st.particles);
            SQ_CHECK_REL(particle_cross_section(&pd), xp, 0.06);
            sq_clouds_destroy(c);
        }
        sq_world_destroy(ctx, w);
    }
    sq_context_destroy(ctx);
}

/* Same seed: identical particles after steps; another seed: different. */
SQ_TEST(deterministic_for_a_seed)
{
    sq_context *ctx = ctx_new(0);
    sq_world *w = flat_world(ctx);
    sq_clouds_desc d;
    memset(&d, 0, sizeof d);
    d.source = SQ_CLOUDS_SOURCE_STRATOCUMULUS;
    d.particles = 4000;
    d.seed = 7;
    sq_clouds *a = NULL, *b = NULL, *e = NULL;
    SQ_CHECK_OK(sq_clouds_create(ctx, &d, w, &a));
    SQ_CHECK_OK(sq_clouds_create(ctx, &d, w, &b));
    d.seed = 8;
    SQ_CHECK_OK(sq_clouds_create(ctx, &d, w, &e));
    for (int k = 0; k < 5; k++) {
        SQ_CHECK_OK(sq_clouds_step(a, 120.0));
        SQ_CHECK_OK(sq_clouds_step(b, 120.0));
        SQ_CHECK_OK(sq_clouds_step(e, 120.0));
    }
    sq_drawable da, db, de;
    sq_clouds_drawable(a, &da);
    sq_clouds_drawable(b, &db);
    sq_clouds_drawable(e, &de);
    SQ_CHECK(da.u.clouds.count == db.u.clouds.count);
    SQ_CHECK(memcmp(da.u.clouds.position, db.u.clouds.position,
                    sizeof(float) * 3 * (size_t)da.u.clouds.count) == 0);
    SQ_CHECK(memcmp(da.u.clouds.tau, db.u.clouds.tau, sizeof(float) * (size_t)da.u.clouds.count) == 0);
    SQ_CHECK(da.u.clouds.count != de.u.clouds.count ||
             memcmp(da.u.clouds.position, de.u.clouds.position,
                    sizeof(float) * 3 * (size_t)da.u.clouds.count) != 0);
    sq_clouds_destroy(a);
    sq_clouds_destroy(b);
    sq_clouds_destroy(e);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* Short particle lives are resolved inside one step (particles.lifetime_s down to its documented
 * 1 s at a frame step of 120 s): a particle ends and respawns once per life — lives of 0.75-1.25 s
 * rounded up to the 1/6 s particle sub-step last 1.08 s on average, ~111 respawns in 120 s (more
 * where a particle leaves its cloud early); asked: >= 96 per particle on average, the count if
 * every life lasted 1.25 s — and none is older than its own life afterwards. One particle update
 * per step would respawn each particle at most once. */
SQ_TEST(short_lives_respawn_within_a_step)
{
    sq_context *ctx = ctx_new(0);
    sq_world *w = flat_world(ctx);
    sq_clouds_desc d;
    memset(&d, 0, sizeof d);
    d.source = SQ_CLOUDS_SOURCE_STRATOCUMULUS;
    d.particles = 2000;
    d.seed = 3;
    d.lifetime_s = 1.0;
    sq_clouds *c = NULL;
    SQ_CHECK_OK(sq_clouds_create(ctx, &d, w, &c));
    const uint64_t before = c->parts.respawns;
    SQ_CHECK_OK(sq_clouds_step(c, 120.0));
    const double per_particle = (double)(c->parts.respawns - before) / c->parts.n;
    printf("respawns per particle in 120 s: %.1f\n", per_particle);
    SQ_CHECK(per_particle >= 96.0);
    for (int i = 0; i < c->parts.n; i++) SQ_CHECK(c->parts.age[i] <= c->parts.life[i]);
    sq_clouds_destroy(c);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* The analytic field drifts at (4, 1.5) m/s: after 20 minutes the condensate-weighted centre of
 * the particles has moved ~ (4800, 1800) m (the field wraps at the domain edge, so only towers
 * away from it are compared: the mean displacement is checked within 15 %). */
SQ_TEST(clouds_drift_with_the_wind)
{
    sq_context *ctx = ctx_new(0);
    sq_world *w = flat_world(ctx);
    sq_clouds_desc d;
    memset(&d, 0, sizeof d);
    d.source = SQ_CLOUDS_SOURCE_CUMULUS;
    d.synthetic_size_m[0] = d.synthetic_size_m[1] = 60000.0;
    d.synthetic_cells[0] = d.synthetic_cells[1] = 120;
    d.synthetic_clouds = 1;
    d.particles = 3000;
    d.plain = true;
    sq_clouds *c = NULL;
    SQ_CHECK_OK(sq_clouds_create(ctx, &d, w, &c));
    if (c) {
        sq_cloud_info a, b;
        SQ_CHECK_OK(sq_clouds_cloud(c, 0, &a));
        for (int k = 0; k < 4; k++) SQ_CHECK_OK(sq_clouds_step(c, 300.0));
        SQ_CHECK_OK(sq_clouds_cloud(c, 0, &b));
        SQ_CHECK_NEAR(b.center_m.x - a.center_m.x, 4800.0, 720.0);
        SQ_CHECK_NEAR(b.center_m.y - a.center_m.y, 1800.0, 720.0);
        sq_clouds_stats st;
        SQ_CHECK_OK(sq_clouds_stats_get(c, &st));
        SQ_CHECK(st.cover_fraction > 0.0 && st.cover_fraction < 0.2);
        SQ_CHECK(st.cloud_top_m > 800.0 && st.cloud_top_m < 3800.0);
        SQ_CHECK(st.lwp_g_m2 > 0.0 && st.iwp_g_m2 == 0.0);
    }
    sq_clouds_destroy(c);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* 10^6 particles x 200 bytes against a 64 MiB limit: refused before allocating, the message
 * naming the count and the bytes; nothing left allocated. */
SQ_TEST(too_many_particles_refused)
{
    sq_context *ctx = ctx_new(64u << 20);
    sq_world *w = flat_world(ctx);
    const uint64_t before = sq_context_bytes_in_use(ctx);
    sq_clouds_desc d;
    memset(&d, 0, sizeof d);
    d.source = SQ_CLOUDS_SOURCE_CUMULUS;
    d.particles = 1000000;
    sq_clouds *c = NULL;
    SQ_CHECK(sq_clouds_create(ctx, &d, w, &c) == SQ_ERR_TOO_LARGE);
    SQ_CHECK(c == NULL);
    SQ_CHECK_MSG(strstr(sq_last_error(), "particles.count = 1000000") &&
                     strstr(sq_last_error(), "bytes"),
                 "message: %s", sq_last_error());
    SQ_CHECK(sq_context_bytes_in_use(ctx) == before);
    SQ_CHECK(sq_context_bytes_peak(ctx) < before + (1u << 20));
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}
