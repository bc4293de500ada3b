/* world_internal.h — the world's private parts shared between its files: the mesh
 * acceleration structure (world_mesh.c) behind sq_world_solid_at and sq_world_surface_at. */
#ifndef SQ_WORLD_INTERNAL_H
#define SQ_WORLD_INTERNAL_H

#include "squall/world.h"
#include "world/world_struct.h"

typedef struct sq__mesh_accel sq__mesh_accel;

/* True if p is inside a closed mesh instance (winding number > 0). */
bool sq__world_mesh_solid_at(const sq_world *w, sq_vec3 p);
/* Sets out[k] = 1 where (x, y, zc[k]) is inside a closed mesh instance (the answer of
 * sq__world_mesh_solid_at, from one pass along the vertical line); other entries are kept. */
void sq__world_mesh_solid_column(const sq_world *w, float x, float y, const float *zc, int nz,
                                 uint8_t *out);
/* Highest mesh surface over (x, y) into *z_out; false when no instance covers the point. */
bool sq__world_mesh_top_at(const sq_world *w, float x, float y, float *z_out);
/* Frees the instances and the acceleration structure (the meshes are not the world's). */
void sq__world_meshes_free(sq_context *ctx, sq_world *w);
/* Bytes held for the instances and BVHs. */
uint64_t sq__world_mesh_bytes(const sq_world *w);
/* A generation number no world of the process had before (renderer caches key on the world's
 * address and generation; a new world may reuse a destroyed one's address). */
uint64_t sq__world_next_generation(void);
/* dst becomes the world as it is now for drawing one frame: its sun, sky and clock copied, the
 * terrain, obstacles, areas and meshes shared with src (borrowed: never destroy dst with
 * sq_world_destroy, free only its memory). The frame loop hands such a copy from the simulation
 * thread to the drawing thread with each frame, so that a step moving the sun
 * (sq_world_set_time) or a live sky change (sq_world_set_sky) on the one never changes a picture
 * the other is drawing, and the frame after the change shows it. */
void sq__world_frame_copy(sq_world *dst, const sq_world *src);

#endif
