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

#endif
