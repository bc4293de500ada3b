/* world_mesh.c — meshes placed in the world (sq_world_set_meshes) and the acceleration
 * structure behind the world's solid queries: a bounding-volume hierarchy (median split on the
 * longest axis, 4 triangles per leaf) per mesh over its LOD 0, and one over the instances'
 * world boxes. Meshes are solids by their winding number along a vertical line: every triangle
 * the line crosses above p counts sign(n_z) of its outward normal (+1 leaving, -1 entering a
 * closed part), so a point inside k overlapping closed parts (walls and the roof on them) has
 * winding k and a point outside 0, whatever the parts' overlaps. A line through a shared edge or
 * vertex is counted once (the rasteriser's top-left rule on exact edge functions in double). */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/core_internal.h"
#include "world_internal.h"

#define MODULE "world"
#define LEAF_SIZE 4

typedef struct bvh_node {
    float lo[3], hi[3];
    int32_t first; /* leaf: first item; inner: left child (right = first + 1) */
    int32_t count; /* leaf: items (> 0); inner: 0 */
} bvh_node;

typedef struct bvh {
    bvh_node *nodes;
    int32_t node_count;
    int32_t *order; /* item index of each leaf slot */
} bvh;

typedef struct mesh_accel {
    bvh tree;
    float *tri;       /* 9 floats per triangle in leaf order: a, b, c (mesh frame) */
    int32_t tri_count;
    bool solid;       /* closed and consistently oriented */
} mesh_accel;

struct sq__mesh_accel {
    mesh_accel *mesh;    /* one per world mesh */
    bvh top;             /* over instances */
    float *inst_box;     /* 6 per instance: world lo, hi */
    float *inst_inv;     /* 8 per instance: cos, sin, 1/sx, 1/sy, 1/sz, tx, ty, tz */
    float zmax;          /* top of every instance */
    uint64_t bytes;
};

/* ---- building ----------------------------------------------------------------------------- */
typedef struct build_item {
    float lo[3], hi[3], c[3];
} build_item;

static float axis_key(const build_item *it, const int32_t *idx, int32_t k, int axis)
{
    return it[idx[k]].c[axis];
}

/* Partially orders idx[lo..hi) so that the element at k is in place (quickselect). */
static void select_kth(const build_item *it, int32_t *idx, int32_t lo, int32_t hi, int32_t k,
                       int axis)
{
    while (hi - lo > 1) {
        const float pivot = axis_key(it, idx, lo + (hi - lo) / 2, axis);
        int32_t i = lo, j = hi - 1;
        while (i <= j) {
            while (axis_key(it, idx, i, axis) < pivot) i++;
            while (axis_key(it, idx, j, axis) > pivot) j--;
            if (i <= j) {
                const int32_t t = idx[i];
                idx[i] = idx[j];
                idx[j] = t;
                i++;
                j--;
            }
        }
        if (k <= j) hi = j + 1;
        else if (k >= i) lo = i;
        else return;
    }
}

static sq_result bvh_build(sq_context *ctx, const build_item *it, int32_t n, bvh *out)
{
    memset(out, 0, sizeof *out);
    if (n <= 0) return SQ_OK;
    const int32_t max_nodes = 2 * n;
    out->nodes = sq_alloc(ctx, (size_t)max_nodes * sizeof(bvh_node));
    out->order = sq_alloc(ctx, (size_t)n * sizeof(int32_t));
    typedef struct task {
        int32_t node, lo, hi;
    } task;
    task *stack = sq_alloc(ctx, 128 * sizeof(task));
    if (!out->nodes || !out->order || !stack) {
        sq_free(ctx, stack);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MODULE, "out of memory building a BVH of %d items", n);
    }
    for (int32_t i = 0; i < n; i++) out->order[i] = i;
    int sp = 0;
    out->node_count = 1;
    stack[sp++] = (task){0, 0, n};
    while (sp > 0) {
        const task t = stack[--sp];
        bvh_node *nd = &out->nodes[t.node];
        float clo[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, chi[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
        for (int a = 0; a < 3; a++) {
            nd->lo[a] = FLT_MAX;
            nd->hi[a] = -FLT_MAX;
        }
        for (int32_t i = t.lo; i < t.hi; i++) {
            const build_item *b = &it[out->order[i]];
            for (int a = 0; a < 3; a++) {
                nd->lo[a] = fminf(nd->lo[a], b->lo[a]);
                nd->hi[a] = fmaxf(nd->hi[a], b->hi[a]);
                clo[a] = fminf(clo[a], b->c[a]);
                chi[a] = fmaxf(chi[a], b->c[a]);
            }
        }
        const int32_t cnt = t.hi - t.lo;
        if (cnt <= LEAF_SIZE || sp >= 126) {
            nd->first = t.lo;
            nd->count = cnt;
            continue;
        }
        int axis = 0;
        for (int a = 1; a < 3; a++)
            if (chi[a] - clo[a] > chi[axis] - clo[axis]) axis = a;
        const int32_t mid = t.lo + cnt / 2;
        select_kth(it, out->order, t.lo, t.hi, mid, axis);
        const int32_t left = out->node_count;
        out->node_count += 2;
        nd->first = left;
        nd->count = 0;
        stack[sp++] = (task){left, t.lo, mid};
        stack[sp++] = (task){left + 1, mid, t.hi};
    }
    sq_free(ctx, stack);
    return SQ_OK;
}

static void bvh_free(sq_context *ctx, bvh *b)
{
    sq_free(ctx, b->nodes);
    sq_free(ctx, b->order);
    memset(b, 0, sizeof *b);
}

static sq_result build_mesh_accel(sq_context *ctx, const sq_mesh *m, mesh_accel *out)
{
    memset(out, 0, sizeof *out);
    const sq_mesh_lod *l = &m->lods[0];
    const int32_t nt = l->index_count / 3;
    build_item *it = sq_alloc(ctx, (size_t)(nt > 0 ? nt : 1) * sizeof *it);
    if (!it) return SQ_ERR_OUT_OF_MEMORY;
    for (int32_t f = 0; f < nt; f++) {
        for (int a = 0; a < 3; a++) {
            it[f].lo[a] = FLT_MAX;
            it[f].hi[a] = -FLT_MAX;
            it[f].c[a] = 0.0f;
        }
        for (int k = 0; k < 3; k++) {
            const float *p = &l->positions[3 * l->indices[3 * f + k]];
            for (int a = 0; a < 3; a++) {
                it[f].lo[a] = fminf(it[f].lo[a], p[a]);
                it[f].hi[a] = fmaxf(it[f].hi[a], p[a]);
                it[f].c[a] += p[a] / 3.0f;
            }
        }
    }
    sq_result r = bvh_build(ctx, it, nt, &out->tree);
    sq_free(ctx, it);
    if (r != SQ_OK) return r;
    out->tri = sq_alloc(ctx, (size_t)(nt > 0 ? nt : 1) * 9 * sizeof(float));
    if (!out->tri) return SQ_ERR_OUT_OF_MEMORY;
    for (int32_t s = 0; s < nt; s++) {
        const int32_t f = out->tree.order[s];
        for (int k = 0; k < 3; k++)
            memcpy(&out->tri[9 * s + 3 * k], &l->positions[3 * l->indices[3 * f + k]],
                   3 * sizeof(float));
    }
    out->tri_count = nt;
    out->solid = m->solid;
    return SQ_OK;
}

static void accel_free(sq_context *ctx, sq__mesh_accel *a, int meshes)
{
    if (!a) return;
    if (a->mesh)
        for (int i = 0; i < meshes; i++) {
            bvh_free(ctx, &a->mesh[i].tree);
            sq_free(ctx, a->mesh[i].tri);
        }
    sq_free(ctx, a->mesh);
    bvh_free(ctx, &a->top);
    sq_free(ctx, a->inst_box);
    sq_free(ctx, a->inst_inv);
    sq_free(ctx, a);
}

void sq__world_meshes_free(sq_context *ctx, sq_world *w)
{
    accel_free(ctx, w->mesh_accel, w->mesh_count);
    sq_free(ctx, (void *)w->meshes);
    sq_free(ctx, w->mesh_instances);
    w->mesh_accel = NULL;
    w->meshes = NULL;
    w->mesh_instances = NULL;
    w->mesh_count = w->mesh_instance_count = 0;
    w->mesh_faces = 0;
}

/* World box of an instance: the 8 transformed corners of the mesh bounds. */
static void instance_box(const sq_mesh *m, const sq_mesh_instance *in, float lo[3], float hi[3])
{
    const sq_mat4 M = sq_mesh_instance_matrix(in);
    for (int a = 0; a < 3; a++) {
        lo[a] = FLT_MAX;
        hi[a] = -FLT_MAX;
    }
    for (int c = 0; c < 8; c++) {
        const sq_vec4 p = sq_m4_mul_v4(M, (sq_vec4){(c & 1) ? m->bounds_max.x : m->bounds_min.x,
                                                     (c & 2) ? m->bounds_max.y : m->bounds_min.y,
                                                     (c & 4) ? m->bounds_max.z : m->bounds_min.z,
                                                     1.0f});
        const float q[3] = {p.x, p.y, p.z};
        for (int a = 0; a < 3; a++) {
            lo[a] = fminf(lo[a], q[a]);
            hi[a] = fmaxf(hi[a], q[a]);
        }
    }
}

static bool finite3(sq_vec3 v) { return isfinite(v.x) && isfinite(v.y) && isfinite(v.z); }

sq_result sq_world_check_mesh_instance(sq_context *ctx, const sq_world *w, const sq_mesh *m,
                                       const sq_mesh_instance *in)
{
    if (!w || !m || !in || m->lod_count < 1)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "mesh instance: world, mesh or instance missing");
    if (!isfinite(in->position_m.x) || !isfinite(in->position_m.y) || isinf(in->position_m.z) ||
        !isfinite(in->yaw_deg))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "mesh %s: position (%g, %g, %g), yaw %g deg; must be finite (z may be "
                        "NaN: on the terrain)",
                        m->name, (double)in->position_m.x, (double)in->position_m.y,
                        (double)in->position_m.z, (double)in->yaw_deg);
    const sq_vec3 k = in->scale;
    const bool unit = k.x == 0.0f && k.y == 0.0f && k.z == 0.0f;
    if (!unit && !(finite3(k) && k.x > 0.0f && k.y > 0.0f && k.z > 0.0f))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "mesh %s: scale (%g, %g, %g); every factor must be > 0", m->name,
                        (double)k.x, (double)k.y, (double)k.z);
    sq_vec3 tmin, tmax;
    sq_world_bounds(w, &tmin, &tmax);
    sq_mesh_instance probe = *in;
    if (isnan(probe.position_m.z)) probe.position_m.z = 0.0f;
    float lo[3], hi[3];
    instance_box(m, &probe, lo, hi);
    if (lo[0] < tmin.x || hi[0] > tmax.x || lo[1] < tmin.y || hi[1] > tmax.y)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "mesh %s at (%g, %g): its footprint x %.6g..%.6g m, y %.6g..%.6g m "
                        "reaches outside the terrain (x %.6g..%.6g m, y %.6g..%.6g m)",
                        m->name, (double)in->position_m.x, (double)in->position_m.y,
                        (double)lo[0], (double)hi[0], (double)lo[1], (double)hi[1],
                        (double)tmin.x, (double)tmax.x, (double)tmin.y, (double)tmax.y);
    return SQ_OK;
}

sq_result sq_world_set_meshes(sq_context *ctx, sq_world *w, const sq_mesh *const *meshes,
                              int mesh_count, const sq_mesh_instance *instances,
                              int instance_count)
{
    if (!w) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "sq_world_set_meshes: world is NULL");
    if (mesh_count < 0 || instance_count < 0 || (mesh_count > 0 && !meshes) ||
        (instance_count > 0 && !instances))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "sq_world_set_meshes: %d meshes (%s), %d instances (%s)", mesh_count,
                        meshes ? "set" : "NULL", instance_count, instances ? "set" : "NULL");
    for (int i = 0; i < mesh_count; i++)
        if (!meshes[i] || meshes[i]->lod_count < 1)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "mesh %d is %s", i,
                            meshes[i] ? "empty" : "NULL");
    /* validate every instance before changing anything */
    for (int i = 0; i < instance_count; i++) {
        if (instances[i].mesh < 0 || instances[i].mesh >= mesh_count)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                            "mesh instance %d: mesh %d; there are %d meshes", i, instances[i].mesh,
                            mesh_count);
        sq_result r = sq_world_check_mesh_instance(ctx, w, meshes[instances[i].mesh], &instances[i]);
        if (r != SQ_OK) return r;
    }
    /* memory: instances, per-instance boxes and transforms, top BVH, mesh BVHs + triangles */
    uint64_t bytes = (uint64_t)instance_count * (sizeof(sq_mesh_instance) + 14 * 4 + 2 * 32 + 4);
    for (int i = 0; i < mesh_count; i++) {
        const uint64_t nt = (uint64_t)meshes[i]->lods[0].index_count / 3;
        bytes += nt * (36 + 2 * 32 + 4 + 36) + (uint64_t)meshes[i]->lods[0].index_count * 8;
    }
    sq_result r = sq_context_check_memory(ctx, bytes, "mesh instances and their BVHs");
    if (r != SQ_OK) return r;

    sq__world_meshes_free(ctx, w);
    w->generation = sq__world_next_generation();
    if (instance_count == 0 && mesh_count == 0) return SQ_OK;
    sq__mesh_accel *a = sq_alloc_zero(ctx, sizeof *a);
    w->meshes = sq_alloc(ctx, (size_t)(mesh_count > 0 ? mesh_count : 1) * sizeof(sq_mesh *));
    w->mesh_instances =
        sq_alloc(ctx, (size_t)(instance_count > 0 ? instance_count : 1) * sizeof(sq_mesh_instance));
    if (!a || !w->meshes || !w->mesh_instances) {
        sq_free(ctx, a);
        sq__world_meshes_free(ctx, w);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MODULE, "out of memory for mesh instances");
    }
    w->mesh_accel = a;
    memcpy((void *)w->meshes, meshes, (size_t)mesh_count * sizeof(sq_mesh *));
    w->mesh_count = mesh_count;
    w->mesh_instance_count = instance_count;
    a->mesh = sq_alloc_zero(ctx, (size_t)(mesh_count > 0 ? mesh_count : 1) * sizeof(mesh_accel));
    a->inst_box = sq_alloc(ctx, (size_t)(instance_count > 0 ? instance_count : 1) * 6 * sizeof(float));
    a->inst_inv = sq_alloc(ctx, (size_t)(instance_count > 0 ? instance_count : 1) * 8 * sizeof(float));
    build_item *it = sq_alloc(ctx, (size_t)(instance_count > 0 ? instance_count : 1) * sizeof *it);
    if (!a->mesh || !a->inst_box || !a->inst_inv || !it) {
        sq_free(ctx, it);
        sq__world_meshes_free(ctx, w);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MODULE, "out of memory for mesh instances");
    }
    for (int i = 0; i < mesh_count && r == SQ_OK; i++) r = build_mesh_accel(ctx, meshes[i], &a->mesh[i]);
    a->zmax = -FLT_MAX;
    for (int i = 0; i < instance_count && r == SQ_OK; i++) {
        sq_mesh_instance in = instances[i];
        const sq_mesh *m = meshes[in.mesh];
        if (in.scale.x == 0.0f && in.scale.y == 0.0f && in.scale.z == 0.0f)
            in.scale = sq_v3(1, 1, 1);
        if (isnan(in.position_m.z)) {
            /* on the terrain: the lowest terrain under the footprint (corners and centre) */
            sq_mesh_instance probe = in;
            probe.position_m.z = 0.0f;
            float lo[3], hi[3];
            instance_box(m, &probe, lo, hi);
            float z = sq_world_height_at(w, in.position_m.x, in.position_m.y);
            for (int c = 0; c < 4; c++)
                z = fminf(z, sq_world_height_at(w, (c & 1) ? hi[0] : lo[0], (c & 2) ? hi[1] : lo[1]));
            in.position_m.z = z;
        }
        w->mesh_instances[i] = in;
        w->mesh_faces += sq_mesh_face_count(m, 0);
        float *b = &a->inst_box[6 * i];
        instance_box(m, &in, b, b + 3);
        for (int q = 0; q < 3; q++) {
            it[i].lo[q] = b[q];
            it[i].hi[q] = b[3 + q];
            it[i].c[q] = 0.5f * (b[q] + b[3 + q]);
        }
        a->zmax = fmaxf(a->zmax, b[5]);
        const float ang = in.yaw_deg * SQ_PI_F / 180.0f;
        float *v = &a->inst_inv[8 * i];
        v[0] = cosf(ang);
        v[1] = sinf(ang);
        v[2] = 1.0f / in.scale.x;
        v[3] = 1.0f / in.scale.y;
        v[4] = 1.0f / in.scale.z;
        v[5] = in.position_m.x;
        v[6] = in.position_m.y;
        v[7] = in.position_m.z;
    }
    if (r == SQ_OK) r = bvh_build(ctx, it, instance_count, &a->top);
    sq_free(ctx, it);
    if (r != SQ_OK) {
        sq__world_meshes_free(ctx, w);
        return r;
    }
    a->bytes = bytes;
    return SQ_OK;
}

/* ---- queries ------------------------------------------------------------------------------ */
/* Edge function of p against the edge u -> v in double, evaluated in a canonical vertex order so
 * two triangles sharing the edge get exactly opposite values. */
static double edge_fn(const float *u, const float *v, double px, double py)
{
    const bool swap = u[0] > v[0] || (u[0] == v[0] && u[1] > v[1]);
    const float *a = swap ? v : u, *b = swap ? u : v;
    const double ax = a[0], ay = a[1], bx = b[0], by = b[1];
    const double e = (bx - ax) * (py - ay) - (by - ay) * (px - ax);
    return swap ? -e : e;
}

/* Does the vertical line through (px, py) cross triangle t (projected on xy)? Points on an edge
 * count for the triangle whose edge is a top or left edge (each point of a shared edge counts
 * once). Returns the crossing height and the sign of the outward normal's z. */
static bool vertical_cross(const float *t, double px, double py, double *z, int *sign)
{
    const float *a = t, *b = t + 3, *c = t + 6;
    double e0 = edge_fn(b, c, px, py), e1 = edge_fn(c, a, px, py), e2 = edge_fn(a, b, px, py);
    const double area = e0 + e1 + e2; /* twice the projected signed area (ccw > 0) */
    if (area == 0.0) return false;    /* a vertical triangle: the line does not cross it */
    const double s = area > 0.0 ? 1.0 : -1.0;
    e0 *= s;
    e1 *= s;
    e2 *= s;
    const float *ev[3][2] = {{b, c}, {c, a}, {a, b}};
    const double e[3] = {e0, e1, e2};
    for (int k = 0; k < 3; k++) {
        if (e[k] < 0.0) return false;
        if (e[k] == 0.0) {
            /* the edge in the triangle's counter-clockwise (projected) order */
            const float *u = s > 0 ? ev[k][0] : ev[k][1], *v = s > 0 ? ev[k][1] : ev[k][0];
            const double dx = (double)v[0] - (double)u[0], dy = (double)v[1] - (double)u[1];
            const bool top_left = dy < 0.0 || (dy == 0.0 && dx > 0.0);
            if (!top_left) return false;
        }
    }
    const double inv = 1.0 / (e0 + e1 + e2);
    *z = (e0 * (double)a[2] + e1 * (double)b[2] + e2 * (double)c[2]) * inv;
    *sign = area > 0.0 ? 1 : -1; /* ccw seen from above: outward normal points up */
    return true;
}

/* Visits every crossing of the vertical line through local (px, py) with mesh ma, skipping BVH
 * nodes whose top is at or below z_cull (-INFINITY: none); visit returns false to stop. */
typedef bool (*crossing_fn)(void *user, double z, int sign);
static void column_walk(const mesh_accel *ma, double px, double py, double z_cull,
                        crossing_fn visit, void *user)
{
    if (ma->tri_count == 0) return;
    int32_t stack[64];
    int sp = 0;
    stack[sp++] = 0;
    const float fx = (float)px, fy = (float)py;
    while (sp > 0) {
        const bvh_node *n = &ma->tree.nodes[stack[--sp]];
        if (fx < n->lo[0] || fx > n->hi[0] || fy < n->lo[1] || fy > n->hi[1]) continue;
        if ((double)n->hi[2] <= z_cull) continue;
        if (n->count == 0) {
            if (sp < 62) {
                stack[sp++] = n->first;
                stack[sp++] = n->first + 1;
            }
            continue;
        }
        for (int32_t s = n->first; s < n->first + n->count; s++) {
            double z;
            int sign;
            if (vertical_cross(&ma->tri[9 * s], px, py, &z, &sign) && !visit(user, z, sign))
                return;
        }
    }
}

typedef struct column_acc {
    double pz;
    int winding;
    double ztop;
} column_acc;

static bool column_add(void *user, double z, int sign)
{
    column_acc *c = (column_acc *)user;
    if (z > c->pz) c->winding += sign;
    if (isnan(c->ztop) || z > c->ztop) c->ztop = z;
    return true;
}

/* Winding number of the mesh around local point p (counting crossings above it), and the highest
 * crossing (NaN when none). */
static void mesh_column(const mesh_accel *ma, double px, double py, double pz, bool want_top,
                        int *winding, double *ztop)
{
    column_acc c = {pz, 0, NAN};
    /* without the top, nodes wholly below p cannot change the winding above it */
    column_walk(ma, px, py, want_top ? -(double)INFINITY : pz, column_add, &c);
    *winding = c.winding;
    *ztop = c.ztop;
}

/* Local coordinates of world point (x, y, z) in instance i. */
static void to_local(const sq__mesh_accel *a, int32_t i, double x, double y, double z, double *lx,
                     double *ly, double *lz)
{
    const float *v = &a->inst_inv[8 * i];
    const double c = v[0], s = v[1];
    const double dx = x - (double)v[5], dy = y - (double)v[6];
    *lx = (c * dx + s * dy) * (double)v[2];
    *ly = (-s * dx + c * dy) * (double)v[3];
    *lz = (z - (double)v[7]) * (double)v[4];
}

bool sq__world_mesh_solid_at(const sq_world *w, sq_vec3 p)
{
    const sq__mesh_accel *a = w->mesh_accel;
    if (!a || a->top.node_count == 0 || p.z > a->zmax) return false;
    int32_t stack[64];
    int sp = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        const bvh_node *n = &a->top.nodes[stack[--sp]];
        if (p.x < n->lo[0] || p.x > n->hi[0] || p.y < n->lo[1] || p.y > n->hi[1] ||
            p.z < n->lo[2] || p.z > n->hi[2])
            continue;
        if (n->count == 0) {
            if (sp < 62) {
                stack[sp++] = n->first;
                stack[sp++] = n->first + 1;
            }
            continue;
        }
        for (int32_t s = n->first; s < n->first + n->count; s++) {
            const int32_t i = a->top.order[s];
            const float *b = &a->inst_box[6 * i];
            if (p.x < b[0] || p.x > b[3] || p.y < b[1] || p.y > b[4] || p.z < b[2] || p.z > b[5])
                continue;
            const mesh_accel *ma = &a->mesh[w->mesh_instances[i].mesh];
            if (!ma->solid) continue;
            double lx, ly, lz, top;
            int wn;
            to_local(a, i, p.x, p.y, p.z, &lx, &ly, &lz);
            mesh_column(ma, lx, ly, lz, false, &wn, &top);
            if (wn > 0) return true;
        }
    }
    return false;
}

/* Every crossing of the vertical line through local (px, py) with mesh ma: its height and sign
 * (as mesh_column counts them). Returns the number of crossings, or -1 when more than cap. */
typedef struct crossing_list {
    double *z;
    int8_t *sign;
    int n, cap;
} crossing_list;

static bool crossing_keep(void *user, double z, int sign)
{
    crossing_list *l = (crossing_list *)user;
    if (l->n == l->cap) {
        l->n = -1;
        return false;
    }
    l->z[l->n] = z;
    l->sign[l->n++] = (int8_t)sign;
    return true;
}

static int mesh_crossings(const mesh_accel *ma, double px, double py, double *z, int8_t *sign,
                          int cap)
{
    crossing_list l = {z, sign, 0, cap};
    column_walk(ma, px, py, -INFINITY, crossing_keep, &l);
    return l.n;
}

#define COLUMN_CROSSINGS 512

void sq__world_mesh_solid_column(const sq_world *w, float x, float y, const float *zc, int nz,
                                 uint8_t *out)
{
    const sq__mesh_accel *a = w->mesh_accel;
    if (!a || a->top.node_count == 0 || nz <= 0) return;
    double cz[COLUMN_CROSSINGS];
    int8_t cs[COLUMN_CROSSINGS];
    int32_t stack[64];
    int sp = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        const bvh_node *n = &a->top.nodes[stack[--sp]];
        if (x < n->lo[0] || x > n->hi[0] || y < n->lo[1] || y > n->hi[1]) continue;
        if (n->count == 0) {
            if (sp < 62) {
                stack[sp++] = n->first;
                stack[sp++] = n->first + 1;
            }
            continue;
        }
        for (int32_t s = n->first; s < n->first + n->count; s++) {
            const int32_t i = a->top.order[s];
            const float *b = &a->inst_box[6 * i];
            if (x < b[0] || x > b[3] || y < b[1] || y > b[4]) continue;
            const mesh_accel *ma = &a->mesh[w->mesh_instances[i].mesh];
            if (!ma->solid) continue;
            double lx, ly, lz0;
            to_local(a, i, x, y, 0.0, &lx, &ly, &lz0);
            const int nc = mesh_crossings(ma, lx, ly, cz, cs, COLUMN_CROSSINGS);
            for (int k = 0; k < nz; k++) {
                const float zk = zc[k];
                if (out[k] || zk < b[2] || zk > b[5]) continue;
                if (nc < 0) { /* too many crossings for the buffer: one query per cell */
                    out[k] = sq__world_mesh_solid_at(w, sq_v3(x, y, zk));
                    continue;
                }
                double lz;
                to_local(a, i, x, y, zk, &lx, &ly, &lz);
                int wn = 0;
                for (int c = 0; c < nc; c++) wn += cz[c] > lz ? cs[c] : 0;
                out[k] = wn > 0;
            }
        }
    }
}

bool sq__world_mesh_top_at(const sq_world *w, float x, float y, float *z_out)
{
    const sq__mesh_accel *a = w->mesh_accel;
    if (!a || a->top.node_count == 0) return false;
    bool any = false;
    float best = -FLT_MAX;
    int32_t stack[64];
    int sp = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        const bvh_node *n = &a->top.nodes[stack[--sp]];
        if (x < n->lo[0] || x > n->hi[0] || y < n->lo[1] || y > n->hi[1] || n->hi[2] <= best)
            continue;
        if (n->count == 0) {
            if (sp < 62) {
                stack[sp++] = n->first;
                stack[sp++] = n->first + 1;
            }
            continue;
        }
        for (int32_t s = n->first; s < n->first + n->count; s++) {
            const int32_t i = a->top.order[s];
            const float *b = &a->inst_box[6 * i];
            if (x < b[0] || x > b[3] || y < b[1] || y > b[4] || b[5] <= best) continue;
            const mesh_accel *ma = &a->mesh[w->mesh_instances[i].mesh];
            double lx, ly, lz, top;
            int wn;
            to_local(a, i, x, y, 0.0, &lx, &ly, &lz);
            mesh_column(ma, lx, ly, INFINITY, true, &wn, &top);
            if (isnan(top)) continue;
            const float zt = (float)(top * (double)w->mesh_instances[i].scale.z) +
                             w->mesh_instances[i].position_m.z;
            if (zt > best) {
                best = zt;
                any = true;
            }
        }
    }
    if (any) *z_out = best;
    return any;
}

uint64_t sq__world_mesh_bytes(const sq_world *w)
{
    return w->mesh_accel ? w->mesh_accel->bytes : 0;
}
