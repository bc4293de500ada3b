/* procgen_build.c — the procedural generator's triangle builder: growing vertex/triangle
 * arrays and closed, outward-oriented primitives (box, tapered cylinder, solid of revolution,
 * lumpy ellipsoid, extruded convex polygon). Vertices are shared within a primitive; the mesh
 * module splits normals at creases sharper than the crease angle, so boxes come out flat and
 * cylinders and blobs smooth. */
#include <math.h>
#include <string.h>

#include "core/core_internal.h"
#include "procgen_internal.h"
#include "squall/rng.h"

pg_xf pg_xf_identity(void)
{
    pg_xf x = {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}};
    return x;
}

pg_xf pg_xf_yaw(sq_vec3 t, float yaw)
{
    const float c = cosf(yaw), s = sinf(yaw);
    pg_xf x = {{c, s, 0, -s, c, 0, 0, 0, 1}, t};
    return x;
}

pg_xf pg_xf_rot_x(float a)
{
    const float c = cosf(a), s = sinf(a);
    pg_xf x = {{1, 0, 0, 0, c, s, 0, -s, c}, {0, 0, 0}};
    return x;
}

pg_xf pg_xf_rot_y(float a)
{
    const float c = cosf(a), s = sinf(a);
    pg_xf x = {{c, 0, -s, 0, 1, 0, s, 0, c}, {0, 0, 0}};
    return x;
}

sq_vec3 pg_apply(const pg_xf *x, sq_vec3 p)
{
    const float *m = x->m;
    return sq_v3(m[0] * p.x + m[3] * p.y + m[6] * p.z + x->t.x,
                 m[1] * p.x + m[4] * p.y + m[7] * p.z + x->t.y,
                 m[2] * p.x + m[5] * p.y + m[8] * p.z + x->t.z);
}

pg_xf pg_xf_mul(pg_xf a, pg_xf b)
{
    pg_xf r;
    for (int c = 0; c < 3; c++)
        for (int rr = 0; rr < 3; rr++) {
            float s = 0.0f;
            for (int k = 0; k < 3; k++) s += a.m[k * 3 + rr] * b.m[c * 3 + k];
            r.m[c * 3 + rr] = s;
        }
    const sq_vec3 t = b.t;
    r.t = sq_v3(a.m[0] * t.x + a.m[3] * t.y + a.m[6] * t.z + a.t.x,
                a.m[1] * t.x + a.m[4] * t.y + a.m[7] * t.z + a.t.y,
                a.m[2] * t.x + a.m[5] * t.y + a.m[8] * t.z + a.t.z);
    return r;
}

float pg_rand(uint64_t seed, uint64_t stream, uint64_t index)
{
    return sq_rng_uniform(seed, 0x9E0000ull + stream, index);
}

void pg_init(pg_mesh *b, sq_context *ctx)
{
    memset(b, 0, sizeof *b);
    b->ctx = ctx;
}

void pg_free(pg_mesh *b)
{
    sq_free(b->ctx, b->pos);
    sq_free(b->ctx, b->idx);
    sq_free(b->ctx, b->mat);
    sq_context *ctx = b->ctx;
    memset(b, 0, sizeof *b);
    b->ctx = ctx;
}

static bool grow(sq_context *ctx, void **p, int *cap, int need, size_t elem)
{
    if (need <= *cap) return true;
    int nc = *cap > 0 ? *cap : 256;
    while (nc < need) nc *= 2;
    void *q = sq_alloc(ctx, (size_t)nc * elem);
    if (!q) return false;
    if (*p) memcpy(q, *p, (size_t)*cap * elem);
    sq_free(ctx, *p);
    *p = q;
    *cap = nc;
    return true;
}

int pg_vertex(pg_mesh *b, sq_vec3 p)
{
    if (b->oom) return 0;
    int cap = b->cap_v;
    if (!grow(b->ctx, (void **)&b->pos, &cap, b->nv + 1, 3 * sizeof(float))) {
        b->oom = true;
        return 0;
    }
    b->cap_v = cap;
    b->pos[3 * b->nv] = p.x;
    b->pos[3 * b->nv + 1] = p.y;
    b->pos[3 * b->nv + 2] = p.z;
    return b->nv++;
}

void pg_tri(pg_mesh *b, int a, int c, int d, int mat)
{
    if (b->oom) return;
    int cap = b->cap_t, cap2 = b->cap_t;
    if (!grow(b->ctx, (void **)&b->idx, &cap, b->nt + 1, 3 * sizeof(uint32_t)) ||
        !grow(b->ctx, (void **)&b->mat, &cap2, b->nt + 1, sizeof(int))) {
        b->oom = true;
        return;
    }
    b->cap_t = cap;
    b->idx[3 * b->nt] = (uint32_t)a;
    b->idx[3 * b->nt + 1] = (uint32_t)c;
    b->idx[3 * b->nt + 2] = (uint32_t)d;
    b->mat[b->nt++] = mat;
}

void pg_quad(pg_mesh *b, int a, int c, int d, int e, int mat)
{
    pg_tri(b, a, c, d, mat);
    pg_tri(b, a, d, e, mat);
}

void pg_box(pg_mesh *b, const pg_xf *x, sq_vec3 lo, sq_vec3 hi, int mat)
{
    int v[8];
    for (int k = 0; k < 8; k++)
        v[k] = pg_vertex(b, pg_apply(x, sq_v3((k & 1) ? hi.x : lo.x, (k & 2) ? hi.y : lo.y,
                                              (k & 4) ? hi.z : lo.z)));
    /* corners: bit 0 x, bit 1 y, bit 2 z; faces counter-clockwise from outside */
    pg_quad(b, v[0], v[2], v[3], v[1], mat); /* -z */
    pg_quad(b, v[4], v[5], v[7], v[6], mat); /* +z */
    pg_quad(b, v[0], v[1], v[5], v[4], mat); /* -y */
    pg_quad(b, v[2], v[6], v[7], v[3], mat); /* +y */
    pg_quad(b, v[0], v[4], v[6], v[2], mat); /* -x */
    pg_quad(b, v[1], v[3], v[7], v[5], mat); /* +x */
}

void pg_cylinder(pg_mesh *b, sq_vec3 a, sq_vec3 c, float ra, float rc, int sides, int mat)
{
    const sq_vec3 ax = sq_v3_sub(c, a);
    const float len = sq_v3_len(ax);
    if (!(len > 0.0f)) return;
    const sq_vec3 w = sq_v3_scale(ax, 1.0f / len);
    const sq_vec3 helper = fabsf(w.z) < 0.9f ? sq_v3(0, 0, 1) : sq_v3(1, 0, 0);
    const sq_vec3 u = sq_v3_norm(sq_v3_cross(helper, w));
    const sq_vec3 v = sq_v3_cross(w, u);
    const int base = b->nv;
    const bool apex_a = ra <= 0.0f, apex_c = rc <= 0.0f;
    for (int ring = 0; ring < 2; ring++) {
        const sq_vec3 o = ring ? c : a;
        const float r = ring ? rc : ra;
        if (r <= 0.0f) {
            pg_vertex(b, o);
            continue;
        }
        for (int s = 0; s < sides; s++) {
            const float t = 2.0f * SQ_PI_F * (float)s / (float)sides;
            pg_vertex(b, sq_v3_add(o, sq_v3_add(sq_v3_scale(u, r * cosf(t)),
                                                sq_v3_scale(v, r * sinf(t)))));
        }
    }
    const int ra0 = base, rc0 = base + (apex_a ? 1 : sides);
    for (int s = 0; s < sides; s++) {
        const int s1 = (s + 1) % sides;
        if (apex_a && apex_c) return;
        if (apex_a) pg_tri(b, ra0, rc0 + s1, rc0 + s, mat);
        else if (apex_c) pg_tri(b, ra0 + s, ra0 + s1, rc0, mat);
        else pg_quad(b, ra0 + s, ra0 + s1, rc0 + s1, rc0 + s, mat);
    }
    /* caps (fans) */
    if (!apex_a) {
        const int ca = pg_vertex(b, a);
        for (int s = 0; s < sides; s++) pg_tri(b, ca, ra0 + (s + 1) % sides, ra0 + s, mat);
    }
    if (!apex_c) {
        const int cc = pg_vertex(b, c);
        for (int s = 0; s < sides; s++) pg_tri(b, cc, rc0 + s, rc0 + (s + 1) % sides, mat);
    }
}

void pg_lathe(pg_mesh *b, const pg_xf *x, const float *radius, const float *z, int rings,
              int sides, int mat)
{
    int start[64];
    if (rings < 2 || rings > 64) return;
    for (int r = 0; r < rings; r++) {
        start[r] = b->nv;
        if (radius[r] <= 0.0f) {
            pg_vertex(b, pg_apply(x, sq_v3(0, 0, z[r])));
            continue;
        }
        for (int s = 0; s < sides; s++) {
            const float t = 2.0f * SQ_PI_F * ((float)s + 0.5f) / (float)sides;
            pg_vertex(b, pg_apply(x, sq_v3(radius[r] * cosf(t), radius[r] * sinf(t), z[r])));
        }
    }
    for (int r = 0; r + 1 < rings; r++) {
        const bool pa = radius[r] <= 0.0f, pc = radius[r + 1] <= 0.0f;
        for (int s = 0; s < sides; s++) {
            const int s1 = (s + 1) % sides;
            if (pa && pc) break;
            if (pa) pg_tri(b, start[r], start[r + 1] + s1, start[r + 1] + s, mat);
            else if (pc) pg_tri(b, start[r] + s, start[r] + s1, start[r + 1], mat);
            else pg_quad(b, start[r] + s, start[r] + s1, start[r + 1] + s1, start[r + 1] + s, mat);
        }
    }
    if (radius[0] > 0.0f) {
        const int c = pg_vertex(b, pg_apply(x, sq_v3(0, 0, z[0])));
        for (int s = 0; s < sides; s++) pg_tri(b, c, start[0] + (s + 1) % sides, start[0] + s, mat);
    }
    if (radius[rings - 1] > 0.0f) {
        const int c = pg_vertex(b, pg_apply(x, sq_v3(0, 0, z[rings - 1])));
        const int t0 = start[rings - 1];
        for (int s = 0; s < sides; s++) pg_tri(b, c, t0 + s, t0 + (s + 1) % sides, mat);
    }
}

void pg_blob(pg_mesh *b, sq_vec3 c, sq_vec3 r, int rings, int sides, float lump, uint64_t seed,
             int mat)
{
    const int top = pg_vertex(b, sq_v3(c.x, c.y, c.z + r.z * (1.0f + lump * 0.5f)));
    const int first = b->nv;
    for (int i = 1; i < rings; i++) {
        const float th = SQ_PI_F * (float)i / (float)rings;
        for (int s = 0; s < sides; s++) {
            const float ph = 2.0f * SQ_PI_F * ((float)s + 0.5f * (float)(i & 1)) / (float)sides;
            const float k = 1.0f + lump * (pg_rand(seed, 1, (uint64_t)(i * 64 + s)) - 0.35f);
            pg_vertex(b, sq_v3(c.x + r.x * k * sinf(th) * cosf(ph), c.y + r.y * k * sinf(th) * sinf(ph),
                               c.z + r.z * k * cosf(th)));
        }
    }
    const int bottom = pg_vertex(b, sq_v3(c.x, c.y, c.z - r.z * 0.85f));
    for (int s = 0; s < sides; s++) pg_tri(b, top, first + s, first + (s + 1) % sides, mat);
    for (int i = 0; i + 2 < rings; i++) {
        const int r0 = first + i * sides, r1 = r0 + sides;
        for (int s = 0; s < sides; s++) {
            const int s1 = (s + 1) % sides;
            pg_quad(b, r0 + s, r1 + s, r1 + s1, r0 + s1, mat);
        }
    }
    const int last = first + (rings - 2) * sides;
    for (int s = 0; s < sides; s++) pg_tri(b, bottom, last + (s + 1) % sides, last + s, mat);
}

void pg_prism(pg_mesh *b, const pg_xf *x, const float *xy, int n, float h, int mat)
{
    if (n < 3 || n > 64) return;
    const int lo = b->nv;
    for (int i = 0; i < n; i++) pg_vertex(b, pg_apply(x, sq_v3(xy[2 * i], xy[2 * i + 1], 0.0f)));
    const int hi = b->nv;
    for (int i = 0; i < n; i++) pg_vertex(b, pg_apply(x, sq_v3(xy[2 * i], xy[2 * i + 1], h)));
    for (int i = 1; i + 1 < n; i++) {
        pg_tri(b, lo, lo + i + 1, lo + i, mat); /* bottom, seen from below */
        pg_tri(b, hi, hi + i, hi + i + 1, mat);
    }
    for (int i = 0; i < n; i++) {
        const int j = (i + 1) % n;
        pg_quad(b, lo + i, lo + j, hi + j, hi + i, mat);
    }
}

sq_result pg_to_mesh(pg_mesh *b, const char *name, const sq_mesh_material *mats, int nmat,
                     bool open, sq_mesh **out)
{
    if (b->oom)
        return sq__fail(b->ctx, SQ_ERR_OUT_OF_MEMORY, "place", "%s: out of memory", name);
    sq_mesh_desc d = {0};
    d.name = name;
    d.vertex_count = b->nv;
    d.positions = b->pos;
    d.index_count = 3 * b->nt;
    d.indices = b->idx;
    d.face_materials = b->mat;
    d.material_count = nmat;
    d.materials = mats;
    d.crease_angle_deg = 50.0f;
    d.open = open;
    return sq_mesh_create(b->ctx, &d, out);
}

sq_result pg_add_lod(pg_mesh *b, sq_mesh *m, float error_m)
{
    if (b->oom)
        return sq__fail(b->ctx, SQ_ERR_OUT_OF_MEMORY, "place", "%s: out of memory", m->name);
    sq_mesh_desc d = {0};
    d.name = m->name;
    d.vertex_count = b->nv;
    d.positions = b->pos;
    d.index_count = 3 * b->nt;
    d.indices = b->idx;
    d.face_materials = b->mat;
    d.crease_angle_deg = 50.0f;
    return sq_mesh_add_lod(b->ctx, m, &d, error_m);
}
