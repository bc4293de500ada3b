/* avalanche_meshes.c — the world's closed meshes (houses, cars, imported models) as colliders of
 * the avalanche: the meshes inside the SPH domain are voxelised (sq_world_voxelise, meshes only:
 * the terrain has its own heightfield collider) on cells of half the particle spacing, coarser
 * if the box would exceed SQ_AVAL_MESH_CELLS cells, into one signed-distance collider. */
#include <float.h>
#include <math.h>
#include <string.h>

#include "phen/avalanche/avalanche_internal.h"
#include "squall/mesh.h"
#include "squall/world.h"
#include "world/world_struct.h"

#define MOD "avalanche"
#define SQ_AVAL_MESH_CELLS (1 << 24)

sq_result sq__avalanche_add_meshes(sq_avalanche *a)
{
    const sq_world *w = a->world;
    const sq_sph_desc *sd = &a->plan.sph;
    double lo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, hi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
    int inside = 0;
    for (int i = 0; i < w->mesh_instance_count; i++) {
        const sq_mesh_instance *in = &w->mesh_instances[i];
        const sq_mesh *m = w->meshes[in->mesh];
        if (!m->solid) continue;
        /* a box around the instance whatever its heading: the footprint's circumradius */
        const double sx = fabs((double)in->scale.x), sy = fabs((double)in->scale.y);
        const double ex = fmax(fabs((double)m->bounds_min.x), fabs((double)m->bounds_max.x)) * sx;
        const double ey = fmax(fabs((double)m->bounds_min.y), fabs((double)m->bounds_max.y)) * sy;
        const double rad = sqrt(ex * ex + ey * ey);
        const double px = in->position_m.x, py = in->position_m.y, pz = in->position_m.z;
        const double sz = in->scale.z;
        const double b0[3] = {px - rad, py - rad, pz + (double)m->bounds_min.z * sz};
        const double b1[3] = {px + rad, py + rad, pz + (double)m->bounds_max.z * sz};
        bool meets = true;
        for (int k = 0; k < 3; k++) meets = meets && b1[k] > sd->domain_min_m[k] && b0[k] < sd->domain_max_m[k];
        if (!meets) continue;
        inside++;
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], fmax(b0[k], sd->domain_min_m[k]));
            hi[k] = fmax(hi[k], fmin(b1[k], sd->domain_max_m[k]));
        }
    }
    if (inside == 0) return SQ_OK;
    double h = 0.5 * a->plan.spacing;
    int n[3];
    for (;;) {
        double cells = 1.0;
        for (int k = 0; k < 3; k++) {
            n[k] = (int)ceil((hi[k] - lo[k]) / h) + 4; /* two empty cells around */
            cells *= n[k];
        }
        if (cells <= SQ_AVAL_MESH_CELLS) break;
        h *= 1.25;
    }
    if (h > 0.5 * a->plan.spacing)
        sq_log(a->ctx, SQ_LOG_WARN, MOD,
               "%d meshes in the avalanche domain voxelised on %.3g m cells (coarser than half the "
               "particle spacing, to stay within %d cells)", inside, h, SQ_AVAL_MESH_CELLS);
    const double origin[3] = {lo[0] - 2.0 * h, lo[1] - 2.0 * h, lo[2] - 2.0 * h};
    uint8_t *mask = (uint8_t *)sq_alloc(a->ctx, (size_t)n[0] * n[1] * n[2]);
    if (!mask) return sq__fail(a->ctx, SQ_ERR_OUT_OF_MEMORY, MOD, "out of memory for the mesh colliders");
    sq_result r = sq_world_voxelise(w, origin, h, n, SQ_SOLID_MESHES, mask);
    if (r == SQ_OK) {
        sq_sph_solid_grid_desc g;
        memset(&g, 0, sizeof g);
        for (int k = 0; k < 3; k++) {
            g.origin_m[k] = origin[k];
            g.n[k] = n[k];
        }
        g.cell_m = h;
        g.solid = mask;
        g.contact.friction = a->plan.d.friction; /* as the box obstacles */
        g.contact.restitution = a->plan.d.restitution;
        r = sq_sph_add_solid_grid(a->sph, &g);
    }
    sq_free(a->ctx, mask);
    return r;
}
