/* render/snow_map.h — the CPU side of the snow-cover model (S2 §2.2, SPEC §6.2–6.3), free of
 * OpenGL so that it is built and tested without it (-DSQ_WITH_GL=OFF):
 *   - the adaptive occlusion map's region: the camera frustum clipped at the snow-detail
 *     distance D_snow, its ground footprint's bounding box, a power-of-two texel size and an
 *     origin snapped to whole texels (a world-aligned grid: a point's texel, and so its exposure,
 *     never changes while the camera moves and the texel size stays);
 *   - the snow prediction function f_p = f_e · f_inc (eqs 2.1–2.3): exposure from M taps of the
 *     map with a depth bias, inclination max(0, N·up) perturbed by a multi-octave 3D noise;
 *   - the snow shell: a displacement by depth × f_e × a weight of the vertex's welded normal,
 *     along the blend of that normal and up, straight up at the top of a wall (a wall stays
 *     vertical); a function of the position alone, so coincident vertices of a mesh with split
 *     normals move together (no cracks at creases);
 *   - a CPU occlusion map (the top surface per texel from sq_world_surface_at), the reference
 *     the GL pass (render_snowcover.c, shaders/snow_common.glsl) mirrors.
 * The GLSL in shaders/snow_common.glsl implements the same formulas; keep them in step. */
#ifndef SQ_RENDER_SNOW_MAP_H
#define SQ_RENDER_SNOW_MAP_H

#include <stdbool.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/sqmath.h"
#include "squall/world.h"

/* The map's placement: texel (i, j) covers x in origin.x + [i, i+1) texel, y likewise; its
 * value is the height of the highest surface at the texel centre (the GL map stores the depth
 * (top - z) / (top - bottom) of an orthographic camera at top_z looking down). */
typedef struct sq__snow_map_geom {
    double origin[2];
    double texel_m;
    int size;            /* texels per side */
    float top_z, bottom_z;
    double need_lo[2], need_hi[2]; /* what the view needs covered: footprint box plus margin */
} sq__snow_map_geom;

/* Step 1 of S2 §2.2.2. The camera's frustum (resolved camera, aspect = width / height) with its
 * far plane at detail_m, its 8 corners projected on the ground plane, their bounding box grown
 * by margin_texels on each side (need_lo / need_hi); the texel is the smallest power of two (in
 * metres, 2^k for any integer k) with which size texels cover it with a texel to spare on each
 * side, and the origin puts the box in the middle of the map, rounded down to whole texels (a
 * world-aligned grid). top_z / bottom_z: the vertical range of the ortho camera. */
sq__snow_map_geom sq__snow_map_region(const sq_camera *camera, float aspect, float detail_m,
                                      int size, int margin_texels, float top_z, float bottom_z);

/* Whether the map drawn for `have` serves the view that needs `need` (both from
 * sq__snow_map_region): the same texel, size and vertical range, and need's box inside have's
 * map. Every point's exposure is then what a map drawn for `need` gives (the same world-aligned
 * texels), so a static world's map is drawn again only when the view leaves it. */
bool sq__snow_map_serves(const sq__snow_map_geom *have, const sq__snow_map_geom *need);

/* A rectangle of a map's texels: i in [lo[0], hi[0]), j in [lo[1], hi[1]); empty when a hi <= lo. */
typedef struct sq__texel_rect {
    int lo[2], hi[2];
} sq__texel_rect;

/* The texels of map g that the view of `need` reads (need's box, need_lo..need_hi, rounded out
 * to whole texels) grown by grow texels on each side, within the map. */
sq__texel_rect sq__snow_map_rect(const sq__snow_map_geom *g, const sq__snow_map_geom *need, int grow);
bool sq__texel_rect_inside(sq__texel_rect a, sq__texel_rect b); /* a within b (empty a: true) */
/* want minus have as at most 4 disjoint rectangles (bands below, above, left, right of their
 * overlap; want itself when they do not overlap). Returns the count. */
int sq__texel_rect_minus(sq__texel_rect want, sq__texel_rect have, sq__texel_rect out[4]);

/* Height of the highest surface at every texel centre of g (size² floats, row j = y index):
 * the CPU occlusion map. */
void sq__snow_map_fill(const sq_world *w, const sq__snow_map_geom *g, float *height);

/* Tap offsets (in texels, x then y) of the M-tap exposure: M = 1 (centre), 4 (S2's four
 * neighbours at the tap radius), 5 (centre and four), 9 (3 × 3 grid of spacing radius).
 * Returns M, or 0 for an unsupported M. */
int sq__snow_taps(int m, float radius_texels, float offsets[][2]);

/* Depth bias of a surface whose normal has z component nz: bias_m plus the rise of the surface
 * over the taps' reach, (radius + 1/2) texels x tan(slope) (tan at most 3), so that a tap up a
 * sloped roof does not count the roof itself as its occluder (slope-scaled, as for shadow maps). */
float sq__snow_slope_bias(const sq__snow_map_geom *g, float nz, float radius_texels, float bias_m);

/* Exposure f_e (eq 2.2) of point p (surface normal z component nz) from the map of heights: the
 * fraction of the M taps whose occluder height is at most p.z + the slope bias (D_occ - D_act
 * >= -b), each tap's answer blended bilinearly from the four texels around it (percentage-
 * closer filtering: smooth edges, still a function of the point alone); 1 outside the map. */
float sq__snow_exposure(const float *height, const sq__snow_map_geom *g, sq_vec3 p, float nz,
                        int taps, float radius_texels, float bias_m);

/* 3D value noise in [0, 1] (integer hash, smooth-step interpolation) and its octave sum
 * (frequency x2, amplitude x1/2 per octave; mean about 1/2), as in snow_common.glsl. */
float sq__snow_noise3(sq_vec3 x);
float sq__snow_fbm3(sq_vec3 x, int octaves);

/* Inclination f_inc (eq 2.3) of unit normal n at p: max(0, n.z) times a mean-one noise factor
 * 1 + amplitude (2 fbm(p / scale_m) - 1), clamped to [0, 1]; amplitude 0 gives max(0, n.z). */
float sq__snow_inclination(sq_vec3 n, sq_vec3 p, float amplitude, float scale_m);

/* Exposure of a vertex of the snow shell at the top of a wall (sq__snow_welded_normals,
 * ns.w = 1; nz = ns.z): 1 when none of the four texels around p holds an occluder above p.z +
 * the slope bias, else 0. Such a corner lies on the edge of its top face: the M taps reach a
 * radius beyond it onto the ground or an eave beside the wall, and their bilinear blend half-
 * exposed a wall's top corner 0.2 m under a roof's overhang, which then rose inside the roof. */
float sq__snow_corner_exposure(const float *height, const sq__snow_map_geom *g, sq_vec3 p, float nz,
                               float radius_texels, float bias_m);

/* Displacement of a vertex with welded normal ns (sq__snow_welded_normals; its exposure f_e
 * from sq__snow_exposure with nz = ns.z, or sq__snow_corner_exposure where ns.w = 1): by depth_m × f_e × min(1, 2 max(0, ns.z)), along
 * normalize(ns + blend (up - ns)) (ns.w = 0), straight up at the top of a wall (ns.w = 1). */
sq_vec3 sq__snow_shell_offset(sq_vec4 ns, float depth_m, float f_e, float blend);

/* Shading normal of the snow shell over a surface of unit normal n where the depth varies with
 * gradient (gx, gy) (m per m, a drift): the shell lies w × depth above the surface, w =
 * min(1, 2 max(0, n.z)) as in the offset, so its normal is normalize(n - n.z w (gx, gy, 0)) --
 * exactly the normal of z = h(x, y) + depth(x, y) where w = 1 (slopes up to 60 degrees); n
 * itself on walls and overhangs. */
sq_vec3 sq__snow_shell_normal(sq_vec3 n, float gx, float gy);

/* A wall: a triangle within 10 degrees of vertical (|n.z| < sin 10 degrees). */
#define SQ__SNOW_WALL_NZ 0.1736482f

/* The snow shell's normal of each vertex of a triangle mesh (n vertices, positions and normals
 * 3 floats each; index_count indices, 3 per triangle; out 4 floats per vertex, may not alias),
 * the same for all vertices at exactly the same position (welded):
 *   - at the top of a wall (a welded vertex is a corner of a wall triangle that lies below it,
 *     and the upmost welded normal is not a wall's: a box's top corner, a gable's apex): xyz
 *     that upmost normal (largest z; ties to the largest x, then y), w = 1: the shell moves the
 *     vertex straight up, so the wall stays vertical (its window quads stay in front of it), and
 *     its weight and exposure take that face's slope (none for a flat top: a wall's top corner
 *     just under a roof's overhang is occluded);
 *   - elsewhere (a smooth surface; a roof's eave over its fascia or its flat underside, a
 *     conifer tier's rim, a gable's foot): xyz the normalised sum of the welded normals (S2's
 *     smoothed normal), w = 0; opposite normals at one place (a sheet seen from both sides)
 *     cancel: up.
 * Returns false when out of memory (out then holds the input normals, w = 0). */
bool sq__snow_welded_normals(sq_context *ctx, const float *positions, const float *normals, int n,
                             const uint32_t *indices, int index_count, float *out);

#endif
