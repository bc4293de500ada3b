/* test_snapshot.c — the frame loop's copies of a frame's drawables (run_snapshot.c): in snapshot
 * mode the drawing thread draws the copy while the simulation thread changes the phenomenon's
 * arrays, so every array a drawable points to must be copied. A clouds drawable (particles and
 * groups) is copied: the copy has the source's values, lives elsewhere, and keeps them when the
 * source changes (the clouds were drawn from the live arrays before: a group could cover more
 * particles than the drawable had, "group 1 covers particles [8832, 9607) of 9512"). */
#include <string.h>

#include "run/run_internal.h"
#include "sq_test.h"

SQ_LABEL(unit)

SQ_TEST(clouds_drawable_copied)
{
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(NULL, &ctx));
    enum { N = 5 };
    float pos[3 * N], rad[N], tau[N], g[N];
    for (int i = 0; i < N; i++) {
        pos[3 * i] = (float)i;
        pos[3 * i + 1] = 10.0f + (float)i;
        pos[3 * i + 2] = 1000.0f + (float)i;
        rad[i] = 50.0f + (float)i;
        tau[i] = 2.0f + (float)i;
        g[i] = 0.8f;
    }
    sq_cloud_group groups[2] = {{sq_v3(1, 2, 3), 100.0f, 0, 2}, {sq_v3(4, 5, 6), 200.0f, 2, 3}};
    sq_drawable d;
    memset(&d, 0, sizeof d);
    d.kind = SQ_DRAWABLE_CLOUDS;
    d.name = "clouds";
    d.u.clouds.count = N;
    d.u.clouds.position = pos;
    d.u.clouds.radius_m = rad;
    d.u.clouds.tau = tau;
    d.u.clouds.g = g;
    d.u.clouds.groups = groups;
    d.u.clouds.group_count = 2;
    d.u.clouds.version = 7;
    static sq__run_frame_slot slot;
    SQ_CHECK_OK(sq__run_snapshot(ctx, &slot, &d, 1));
    SQ_CHECK(slot.count == 1);
    const sq_clouds_view *c = &slot.drawables[0].u.clouds;
    SQ_CHECK(c->position != pos && c->radius_m != rad && c->tau != tau && c->g != g &&
             c->groups != groups);
    /* the simulation side moves on: new values, a group now reaching further */
    float pos0[3 * N], rad0[N];
    memcpy(pos0, pos, sizeof pos);
    memcpy(rad0, rad, sizeof rad);
    for (int i = 0; i < N; i++) {
        pos[3 * i + 2] += 500.0f;
        rad[i] = 1.0f;
        tau[i] = 0.0f;
    }
    groups[1].count = 30;
    SQ_CHECK(c->count == N && c->group_count == 2 && c->version == 7);
    SQ_CHECK(memcmp(c->position, pos0, sizeof pos0) == 0);
    SQ_CHECK(memcmp(c->radius_m, rad0, sizeof rad0) == 0);
    SQ_CHECK_NEAR(c->tau[4], 6.0, 0.0);
    SQ_CHECK_NEAR(c->g[2], 0.8, 1e-7);
    SQ_CHECK(c->groups[0].first == 0 && c->groups[0].count == 2);
    SQ_CHECK(c->groups[1].first == 2 && c->groups[1].count == 3); /* within the copy's 5 */
    SQ_CHECK_NEAR(c->groups[1].radius_m, 200.0, 0.0);
    SQ_CHECK_NEAR(c->groups[1].center_m.z, 6.0, 0.0);
    sq__run_slot_free(ctx, &slot);
    sq_context_destroy(ctx);
}
