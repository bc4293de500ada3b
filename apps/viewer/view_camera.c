/* view_camera.c — orbit and fly camera math of the viewer (see view_camera.h). */
#include "view_camera.h"

#include <math.h>

#define PI_F 3.14159265358979f
#define PITCH_MAX (0.49f * PI_F)

static sq_vec3 dir_of(float yaw, float pitch)
{
    return sq_v3(cosf(pitch) * cosf(yaw), cosf(pitch) * sinf(yaw), sinf(pitch));
}

static float clampf(float v, float lo, float hi) { return v < lo ? lo : v > hi ? hi : v; }

static sq_vec3 add(sq_vec3 a, sq_vec3 b, float s)
{
    return sq_v3(a.x + s * b.x, a.y + s * b.y, a.z + s * b.z);
}

static void orbit_eye(view_camera *c)
{
    c->position = add(c->target, dir_of(c->yaw, c->pitch), -c->distance_m);
}

void view_camera_take(view_camera *c, const sq_camera *cam, view_cam_mode mode)
{
    const sq_camera r = sq_camera_resolve(*cam);
    const float dx = r.target_m.x - r.position_m.x, dy = r.target_m.y - r.position_m.y,
                dz = r.target_m.z - r.position_m.z;
    float d = sqrtf(dx * dx + dy * dy + dz * dz);
    if (!(d > 1e-3f)) d = 1.0f;
    c->mode = mode;
    c->position = r.position_m;
    c->target = r.target_m;
    c->distance_m = d;
    c->yaw = atan2f(dy, dx);
    c->pitch = clampf(asinf(clampf(dz / d, -1.0f, 1.0f)), -PITCH_MAX, PITCH_MAX);
    c->fov_deg = r.fov_y_deg;
    c->near_m = r.near_m;
    c->far_m = r.far_m;
    if (!(c->speed_mps > 0.0f)) c->speed_mps = 20.0f;
    if (mode == VIEW_CAM_ORBIT) orbit_eye(c);
}

void view_camera_drag(view_camera *c, double dx_px, double dy_px)
{
    const float k = 0.005f; /* radians per pixel */
    c->yaw -= (float)dx_px * k;
    c->pitch = clampf(c->pitch - (float)dy_px * k * (c->mode == VIEW_CAM_ORBIT ? -1.0f : 1.0f),
                      -PITCH_MAX, PITCH_MAX);
    if (c->mode == VIEW_CAM_ORBIT) orbit_eye(c);
}

void view_camera_wheel(view_camera *c, double steps)
{
    if (c->mode == VIEW_CAM_ORBIT) {
        c->distance_m = clampf(c->distance_m * powf(1.15f, (float)steps), 1.0f, 1e6f);
        orbit_eye(c);
    } else {
        c->speed_mps = clampf(c->speed_mps * powf(1.25f, (float)-steps), 0.1f, 1e5f);
    }
}

void view_camera_move(view_camera *c, float forward, float right, float up, double dt_s)
{
    const float v = (c->mode == VIEW_CAM_ORBIT ? 0.5f * c->distance_m : c->speed_mps) * (float)dt_s;
    const sq_vec3 f = c->mode == VIEW_CAM_ORBIT ? dir_of(c->yaw, 0.0f) : dir_of(c->yaw, c->pitch);
    const sq_vec3 r = sq_v3(sinf(c->yaw), -cosf(c->yaw), 0.0f);
    sq_vec3 *p = c->mode == VIEW_CAM_ORBIT ? &c->target : &c->position;
    *p = add(*p, f, forward * v);
    *p = add(*p, r, right * v);
    *p = add(*p, sq_v3(0, 0, 1), up * v);
    if (c->mode == VIEW_CAM_ORBIT) orbit_eye(c);
}

void view_camera_frame_box(view_camera *c, sq_vec3 lo, sq_vec3 hi)
{
    const sq_vec3 mid = sq_v3(0.5f * (lo.x + hi.x), 0.5f * (lo.y + hi.y), 0.5f * (lo.z + hi.z));
    const float ex = hi.x - lo.x, ey = hi.y - lo.y, ez = hi.z - lo.z;
    const float radius = 0.5f * sqrtf(ex * ex + ey * ey + ez * ez);
    const float half = 0.5f * (c->fov_deg > 0.0f ? c->fov_deg : 50.0f) * PI_F / 180.0f;
    c->mode = VIEW_CAM_ORBIT;
    c->target = mid;
    c->distance_m = clampf(radius / sinf(half), 1.0f, 1e6f);
    if (c->pitch > -0.1f) c->pitch = -0.35f; /* look down onto it */
    if (c->far_m > 0.0f && c->far_m < 2.5f * c->distance_m) c->far_m = 2.5f * c->distance_m;
    orbit_eye(c);
}

sq_camera view_camera_get(const view_camera *c)
{
    sq_camera cam = {0};
    cam.position_m = c->position;
    cam.target_m = add(c->position, dir_of(c->yaw, c->pitch),
                       c->mode == VIEW_CAM_ORBIT ? c->distance_m : 100.0f);
    cam.up = sq_v3(0, 0, 1);
    cam.fov_y_deg = c->fov_deg;
    cam.near_m = c->near_m;
    cam.far_m = c->far_m;
    return cam;
}
