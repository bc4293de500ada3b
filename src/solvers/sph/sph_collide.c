/* sph_collide.c — particle colliders (SPEC §7.7): the heightfield terrain (bilinear height and
 * normal), axis-aligned box obstacles, voxelised solids (signed distance, sph_sdf.c) and the
 * safety clamp inside the domain walls.
 * A penetrating particle is projected to the surface plus the collision radius; if it moves
 * into the surface, the normal velocity is reversed and scaled by the restitution e and the
 * tangential velocity is reduced by Coulomb friction v_t ← v_t max(0, 1 − μ_k |Δv_n| / |v_t|).
 * Voellmy's turbulent friction is a drag over the flow's depth (sph.c, basal_drag). */
#include "solvers/sph/sph_internal.h"

void sq__sph_terrain_eval(const sq__sph_terrain *t, float x, float y, float *h, float n[3])
{
    float fx = (x - t->ox) * t->inv_dx, fy = (y - t->oy) * t->inv_dy;
    int outx = 0, outy = 0;
    if (!(fx > 0.0f)) {
        fx = 0.0f;
        outx = 1;
    } else if (fx > (float)(t->nx - 1)) {
        fx = (float)(t->nx - 1);
        outx = 1;
    }
    if (!(fy > 0.0f)) {
        fy = 0.0f;
        outy = 1;
    } else if (fy > (float)(t->ny - 1)) {
        fy = (float)(t->ny - 1);
        outy = 1;
    }
    int i = (int)fx, j = (int)fy;
    if (i > t->nx - 2) i = t->nx - 2;
    if (j > t->ny - 2) j = t->ny - 2;
    const float tx = fx - (float)i, ty = fy - (float)j;
    const float *r0 = t->h + (size_t)j * (size_t)t->nx + (size_t)i;
    const float *r1 = r0 + t->nx;
    const float h00 = r0[0], h10 = r0[1], h01 = r1[0], h11 = r1[1];
    *h = (1.0f - ty) * ((1.0f - tx) * h00 + tx * h10) + ty * ((1.0f - tx) * h01 + tx * h11);
    const float gx = outx ? 0.0f : ((1.0f - ty) * (h10 - h00) + ty * (h11 - h01)) * t->inv_dx;
    const float gy = outy ? 0.0f : ((1.0f - tx) * (h01 - h00) + tx * (h11 - h10)) * t->inv_dy;
    const float inv = 1.0f / sqrtf(gx * gx + gy * gy + 1.0f);
    n[0] = -gx * inv;
    n[1] = -gy * inv;
    n[2] = inv;
}

/* Velocity response at a contact with unit normal n (pointing out of the solid). */
static inline void respond(float v[3], const float n[3], const sq__sph_contact *c)
{
    const float vn = v[0] * n[0] + v[1] * n[1] + v[2] * n[2];
    if (vn >= 0.0f) return; /* separating: position projection only */
    const float dvn = -(1.0f + c->e) * vn; /* |Δv_n| */
    v[0] += dvn * n[0];
    v[1] += dvn * n[1];
    v[2] += dvn * n[2];
    const float vn2 = -c->e * vn;
    float t[3] = {v[0] - vn2 * n[0], v[1] - vn2 * n[1], v[2] - vn2 * n[2]};
    const float vt = sqrtf(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    float f = 0.0f;
    if (vt > 0.0f) {
        f = 1.0f - c->mu_k * dvn / vt;
        if (f < 0.0f) f = 0.0f;
    }
    v[0] = vn2 * n[0] + f * t[0];
    v[1] = vn2 * n[1] + f * t[1];
    v[2] = vn2 * n[2] + f * t[2];
}

/* Contacts of position p (projected if project) and velocity v. Returns 1 if anything
 * changed. Without projection only particles already on a surface (within a hair of the
 * collision radius, where the drift's projection left them) get the velocity response.
 */
static int contact(const sq_sph *s, float p[3], float v[3], int project)
{
    int touched = 0;
    const float r = s->coll_r;
    const float tol = project ? 0.0f : 1e-4f * r + 1e-6f;
    if (s->has_terrain) {
        float h, n[3];
        sq__sph_terrain_eval(&s->terrain, p[0], p[1], &h, n);
        const float sd = (p[2] - h) * n[2]; /* signed distance to the local tangent plane */
        if (sd < r + tol) {
            if (project && sd < r) {
                const float push = r - sd;
                p[0] += push * n[0];
                p[1] += push * n[1];
                p[2] += push * n[2];
            }
            respond(v, n, &s->terrain.c);
            touched = 1;
        }
    }
    for (int b = 0; b < s->box_count; b++) {
        const sq__sph_box *bx = &s->boxes[b];
        float best = INFINITY;
        int face = -1;
        for (int a = 0; a < 3; a++) {
            const float plo = p[a] - (bx->lo[a] - r - tol), phi = (bx->hi[a] + r + tol) - p[a];
            if (!(plo > 0.0f && phi > 0.0f)) {
                face = -1;
                break;
            }
            if (plo < best) {
                best = plo;
                face = 2 * a;
            }
            if (phi < best) {
                best = phi;
                face = 2 * a + 1;
            }
        }
        if (face < 0) continue;
        const int a = face / 2;
        float n[3] = {0.0f, 0.0f, 0.0f};
        if (face & 1) {
            if (project) p[a] = bx->hi[a] + r;
            n[a] = 1.0f;
        } else {
            if (project) p[a] = bx->lo[a] - r;
            n[a] = -1.0f;
        }
        respond(v, n, &bx->c);
        touched = 1;
    }
    /* voxelised solids: the signed distance's 0-level, normal along its gradient */
    for (int g = 0; g < s->sdf_count; g++) {
        float d, n[3];
        if (!sq__sph_sdf_eval(&s->sdfs[g], p, &d, n) || !(d < r + tol)) continue;
        if (project && d < r) {
            const float push = r - d;
            p[0] += push * n[0];
            p[1] += push * n[1];
            p[2] += push * n[2];
        }
        respond(v, n, &s->sdfs[g].c);
        touched = 1;
    }
    /* domain walls: the mirror images repel; this clamp only catches violent impacts */
    if (s->any_wall) {
        const float mg = s->wall_margin;
        for (int a = 0; a < 3; a++) {
            if (s->face[2 * a] <= SQ_SPH_BOUNDARY_FREE_SLIP && p[a] < s->lo[a] + mg + tol) {
                if (project && p[a] < s->lo[a] + mg) p[a] = s->lo[a] + mg;
                if (v[a] < 0.0f) v[a] = 0.0f;
                touched = 1;
            }
            if (s->face[2 * a + 1] <= SQ_SPH_BOUNDARY_FREE_SLIP && p[a] > s->hi[a] - mg - tol) {
                if (project && p[a] > s->hi[a] - mg) p[a] = s->hi[a] - mg;
                if (v[a] > 0.0f) v[a] = 0.0f;
                touched = 1;
            }
        }
    }
    return touched;
}

void sq__sph_collide(const sq_sph *s, size_t i)
{
    float p[3] = {s->x[i], s->y[i], s->z[i]};
    float v[3] = {s->hx[i], s->hy[i], s->hz[i]};
    if (contact(s, p, v, 1)) {
        float *X = s->x, *Y = s->y, *Z = s->z, *HX = s->hx, *HY = s->hy, *HZ = s->hz;
        X[i] = p[0];
        Y[i] = p[1];
        Z[i] = p[2];
        HX[i] = v[0];
        HY[i] = v[1];
        HZ[i] = v[2];
    }
}

void sq__sph_contact_velocity(const sq_sph *s, size_t i)
{
    float p[3] = {s->x[i], s->y[i], s->z[i]};
    float v[3] = {s->vx[i], s->vy[i], s->vz[i]};
    if (contact(s, p, v, 0)) {
        float *VX = s->vx, *VY = s->vy, *VZ = s->vz;
        VX[i] = v[0];
        VY[i] = v[1];
        VZ[i] = v[2];
    }
}
