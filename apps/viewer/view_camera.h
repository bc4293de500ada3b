/* view_camera.h — the viewer's camera: the scene's own path until the user takes over, then an
 * orbit camera (around a target: drag turns, wheel zooms, WASD/QE move the target) or a fly camera
 * (drag looks, WASD/QE move, wheel sets the speed). Angles: yaw about +z from +x, pitch above
 * the horizontal. Pure math, no GTK. */
#ifndef SQ_VIEW_CAMERA_H
#define SQ_VIEW_CAMERA_H

#include <stdbool.h>

#include "squall/world.h"

typedef enum view_cam_mode { VIEW_CAM_PATH = 0, VIEW_CAM_ORBIT = 1, VIEW_CAM_FLY = 2 } view_cam_mode;

typedef struct view_camera {
    view_cam_mode mode;
    sq_vec3 position;   /* eye (fly, and orbit's derived eye) */
    sq_vec3 target;     /* orbit centre */
    float distance_m;   /* orbit: eye to target */
    float yaw, pitch;   /* radians: direction the camera looks */
    float fov_deg, near_m, far_m;
    float speed_mps;    /* fly speed (WASD/QE) */
} view_camera;

/* Takes over from cam (the scene's current camera) in mode ORBIT or FLY. */
void view_camera_take(view_camera *c, const sq_camera *cam, view_cam_mode mode);
/* Mouse drag by (dx, dy) pixels: orbit turns the eye around the target, fly turns the view. */
void view_camera_drag(view_camera *c, double dx_px, double dy_px);
/* Wheel steps (positive = away / slower): orbit zoom, fly speed. */
void view_camera_wheel(view_camera *c, double steps);
/* Moves for dt seconds with forward/right/up in {-1, 0, 1} (W/S, D/A, E/Q): the fly eye, or the
 * orbit target (speed scaled with the distance). */
void view_camera_move(view_camera *c, float forward, float right, float up, double dt_s);
/* Orbit around the box [lo, hi] so that it fills the view. */
void view_camera_frame_box(view_camera *c, sq_vec3 lo, sq_vec3 hi);
/* The sq_camera for the renderer. */
sq_camera view_camera_get(const view_camera *c);

#endif
