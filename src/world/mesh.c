/* mesh.c — triangle meshes (squall/mesh.h): validation, degenerate-face removal, normals
 * computed with crease splitting where a file has none, grouping by material, levels of detail
 * by vertex clustering (Rossignac & Borrel 1993: quantise positions to a grid, merge the
 * vertices of a cell at their mean, drop the triangles that collapse), enclosed volume. */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/core_internal.h"
#include "squall/mesh.h"

#define MODULE "mesh"
/* Twice the area below which a triangle is degenerate (m^2): a 30 um square. */
#define DEGENERATE_AREA2 1.0e-9

static const char *mesh_name(const sq_mesh_desc *d) { return d->name ? d->name : "mesh"; }

/* ---- small helpers ------------------------------------------------------------------------ */
static sq_vec3 vload(const float *a, int64_t i) { return sq_v3(a[3 * i], a[3 * i + 1], a[3 * i + 2]); }

static void lod_free(sq_context *ctx, sq_mesh_lod *l)
{
    sq_free(ctx, l->positions);
    sq_free(ctx, l->normals);
    sq_free(ctx, l->uvs);
    sq_free(ctx, l->indices);
    sq_free(ctx, l->parts);
    memset(l, 0, sizeof *l);
}

static uint64_t lod_bytes(const sq_mesh_lod *l)
{
    return (uint64_t)l->vertex_count * (l->uvs ? 32u : 24u) + (uint64_t)l->index_count * 4u +
           (uint64_t)l->part_count * sizeof(sq_mesh_part);
}

uint64_t sq_mesh_memory_bytes(const sq_mesh_desc *d, int lods)
{
    if (!d) return 0;
    const uint64_t tris = (uint64_t)(d->index_count > 0 ? d->index_count : 0) / 3u;
    /* computed normals may split every corner: at most 3 vertices per triangle */
    uint64_t verts = (uint64_t)(d->vertex_count > 0 ? d->vertex_count : 0);
    if (!d->normals && 3u * tris > verts) verts = 3u * tris;
    const uint64_t lod0 = verts * 32u + tris * 12u;
    /* work arrays of creation: face normals, adjacency, corner normals, sort keys */
    const uint64_t work = tris * (24u + 12u + 36u + 8u) + verts * 16u;
    uint64_t tex = 0;
    for (int m = 0; m < d->material_count && d->materials; m++)
        tex += (uint64_t)d->materials[m].texture_w * (uint64_t)d->materials[m].texture_h * 4u;
    /* coarser levels: each at most half the previous one */
    const uint64_t levels = lods > 1 ? lod0 : 0;
    return sizeof(sq_mesh) + lod0 + work + levels + tex;
}

/* ---- building one level ------------------------------------------------------------------- */
/* A triangle soup after validation: kept triangles (indices into the input vertices) and their
 * materials. */
typedef struct tri_list {
    int64_t n;
    uint32_t *idx; /* 3n */
    int *mat;      /* n */
} tri_list;

/* Computes vertex normals split at creases: every triangle corner gets the area-weighted sum
 * of the normals of the triangles around its vertex that lie within the crease angle of its own
 * triangle; identical (vertex, normal) pairs share an output vertex. Writes the level. */
static sq_result build_level(sq_context *ctx, const char *name, int vcount, const float *pos,
                             const float *nrm, const float *uv, const tri_list *t, int materials,
                             float crease_deg, sq_mesh_lod *out)
{
    memset(out, 0, sizeof *out);
    const int64_t nt = t->n;
    if (nt == 0)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "%s: no triangle left (all degenerate)",
                        name);
    sq_result res = SQ_OK;
    /* per-corner output vertex */
    uint32_t *corner_v = sq_alloc(ctx, (size_t)nt * 3 * sizeof(uint32_t));
    float *cn = NULL, *fn = NULL;
    int64_t *adj_start = NULL, *adj = NULL;
    int64_t *first_out = NULL, *next_out = NULL;
    float *opos = NULL, *onrm = NULL, *ouv = NULL;
    int64_t ovc = 0;
    if (!corner_v) goto oom;
    if (!nrm) {
        fn = sq_alloc(ctx, (size_t)nt * 3 * sizeof(float));
        cn = sq_alloc(ctx, (size_t)nt * 9 * sizeof(float));
        adj_start = sq_alloc_zero(ctx, ((size_t)vcount + 1) * sizeof(int64_t));
        adj = sq_alloc(ctx, (size_t)nt * 3 * sizeof(int64_t));
        if (!fn || !cn || !adj_start || !adj) goto oom;
        for (int64_t f = 0; f < nt; f++) {
            const sq_vec3 a = vload(pos, t->idx[3 * f]), b = vload(pos, t->idx[3 * f + 1]),
                          c = vload(pos, t->idx[3 * f + 2]);
            const sq_vec3 n = sq_v3_cross(sq_v3_sub(b, a), sq_v3_sub(c, a)); /* 2 x area */
            fn[3 * f] = n.x;
            fn[3 * f + 1] = n.y;
            fn[3 * f + 2] = n.z;
            for (int k = 0; k < 3; k++) adj_start[t->idx[3 * f + k] + 1]++;
        }
        for (int v = 0; v < vcount; v++) adj_start[v + 1] += adj_start[v];
        int64_t *fill = sq_alloc(ctx, (size_t)vcount * sizeof(int64_t));
        if (!fill) goto oom;
        memcpy(fill, adj_start, (size_t)vcount * sizeof(int64_t));
        for (int64_t f = 0; f < nt; f++)
            for (int k = 0; k < 3; k++) adj[fill[t->idx[3 * f + k]]++] = f;
        sq_free(ctx, fill);
        const float cos_crease = cosf((crease_deg > 0.0f ? crease_deg : 45.0f) * SQ_PI_F / 180.0f);
        for (int64_t f = 0; f < nt; f++) {
            const sq_vec3 nf = sq_v3_norm(vload(fn, f));
            for (int k = 0; k < 3; k++) {
                const uint32_t v = t->idx[3 * f + k];
                sq_vec3 s = sq_v3(0, 0, 0);
                for (int64_t q = adj_start[v]; q < adj_start[v + 1]; q++) {
                    const sq_vec3 ng = vload(fn, adj[q]);
                    if (sq_v3_dot(sq_v3_norm(ng), nf) >= cos_crease) s = sq_v3_add(s, ng);
                }
                const sq_vec3 u = sq_v3_len(s) > 0.0f ? sq_v3_norm(s) : nf;
                cn[9 * f + 3 * k] = u.x;
                cn[9 * f + 3 * k + 1] = u.y;
                cn[9 * f + 3 * k + 2] = u.z;
            }
        }
    }
    /* unique (vertex, normal) pairs: a chain of output vertices per input vertex */
    first_out = sq_alloc(ctx, (size_t)vcount * sizeof(int64_t));
    next_out = sq_alloc(ctx, (size_t)nt * 3 * sizeof(int64_t));
    if (!first_out || !next_out) goto oom;
    for (int v = 0; v < vcount; v++) first_out[v] = -1;
    /* output arrays sized for the worst case, shrunk below */
    opos = sq_alloc(ctx, (size_t)nt * 9 * sizeof(float));
    onrm = sq_alloc(ctx, (size_t)nt * 9 * sizeof(float));
    if (uv) ouv = sq_alloc(ctx, (size_t)nt * 6 * sizeof(float));
    if (!opos || !onrm || (uv && !ouv)) goto oom;
    for (int64_t f = 0; f < nt; f++)
        for (int k = 0; k < 3; k++) {
            const uint32_t v = t->idx[3 * f + k];
            sq_vec3 n;
            if (cn) n = vload(cn, 3 * f + k);
            else {
                n = vload(nrm, v);
                const float len = sq_v3_len(n);
                n = len > 0.0f && isfinite(len) ? sq_v3_scale(n, 1.0f / len) : sq_v3(0, 0, 1);
            }
            int64_t found = -1;
            for (int64_t o = first_out[v]; o >= 0; o = next_out[o])
                if (fabsf(onrm[3 * o] - n.x) < 1e-4f && fabsf(onrm[3 * o + 1] - n.y) < 1e-4f &&
                    fabsf(onrm[3 * o + 2] - n.z) < 1e-4f) {
                    found = o;
                    break;
                }
            if (found < 0) {
                found = ovc++;
                memcpy(&opos[3 * found], &pos[3 * (size_t)v], 3 * sizeof(float));
                onrm[3 * found] = n.x;
                onrm[3 * found + 1] = n.y;
                onrm[3 * found + 2] = n.z;
                if (uv) memcpy(&ouv[2 * found], &uv[2 * (size_t)v], 2 * sizeof(float));
                next_out[found] = first_out[v];
                first_out[v] = found;
            }
            corner_v[3 * f + k] = (uint32_t)found;
        }
    if (ovc > SQ_MESH_MAX_ELEMENTS) {
        res = sq__fail(ctx, SQ_ERR_TOO_LARGE, MODULE, "%s: %lld vertices; at most %d per mesh",
                       name, (long long)ovc, SQ_MESH_MAX_ELEMENTS);
        goto done;
    }
    /* the level: vertices compacted, triangles ordered by material (counting sort) */
    out->vertex_count = (int)ovc;
    out->positions = sq_alloc(ctx, (size_t)ovc * 3 * sizeof(float));
    out->normals = sq_alloc(ctx, (size_t)ovc * 3 * sizeof(float));
    if (uv) out->uvs = sq_alloc(ctx, (size_t)ovc * 2 * sizeof(float));
    out->index_count = (int)(nt * 3);
    out->indices = sq_alloc(ctx, (size_t)nt * 3 * sizeof(uint32_t));
    int64_t *count = sq_alloc_zero(ctx, ((size_t)materials + 1) * sizeof(int64_t));
    if (!out->positions || !out->normals || (uv && !out->uvs) || !out->indices || !count) {
        sq_free(ctx, count);
        goto oom;
    }
    memcpy(out->positions, opos, (size_t)ovc * 3 * sizeof(float));
    memcpy(out->normals, onrm, (size_t)ovc * 3 * sizeof(float));
    if (uv) memcpy(out->uvs, ouv, (size_t)ovc * 2 * sizeof(float));
    for (int64_t f = 0; f < nt; f++) count[t->mat[f] + 1]++;
    int used = 0;
    for (int m = 0; m < materials; m++) used += count[m + 1] > 0;
    for (int m = 0; m < materials; m++) count[m + 1] += count[m];
    out->parts = sq_alloc(ctx, (size_t)(used > 0 ? used : 1) * sizeof(sq_mesh_part));
    if (!out->parts) {
        sq_free(ctx, count);
        goto oom;
    }
    for (int m = 0; m < materials; m++)
        if (count[m + 1] > count[m]) {
            sq_mesh_part *p = &out->parts[out->part_count++];
            p->first_index = (uint32_t)(3 * count[m]);
            p->index_count = (uint32_t)(3 * (count[m + 1] - count[m]));
            p->material = m;
        }
    for (int64_t f = 0; f < nt; f++) {
        const int64_t slot = count[t->mat[f]]++;
        for (int k = 0; k < 3; k++) out->indices[3 * slot + k] = corner_v[3 * f + k];
    }
    sq_free(ctx, count);
    goto done;
oom:
    res = sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MODULE, "%s: out of memory building %lld triangles",
                   name, (long long)nt);
done:
    if (res != SQ_OK) lod_free(ctx, out);
    sq_free(ctx, corner_v);
    sq_free(ctx, cn);
    sq_free(ctx, fn);
    sq_free(ctx, adj_start);
    sq_free(ctx, adj);
    sq_free(ctx, first_out);
    sq_free(ctx, next_out);
    sq_free(ctx, opos);
    sq_free(ctx, onrm);
    sq_free(ctx, ouv);
    return res;
}

/* Checks a desc and collects its non-degenerate triangles. */
static sq_result collect_triangles(sq_context *ctx, const sq_mesh_desc *d, int materials,
                                   tri_list *t, int64_t *dropped)
{
    const char *name = mesh_name(d);
    memset(t, 0, sizeof *t);
    *dropped = 0;
    if (d->vertex_count < 3 || !d->positions)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "%s: %d vertices, positions %s; a mesh needs at least 3 vertices", name,
                        d->vertex_count, d->positions ? "set" : "NULL");
    if (d->index_count < 3 || d->index_count % 3 != 0 || !d->indices)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "%s: %d indices; need a positive multiple of 3 (triangles)", name,
                        d->index_count);
    if (d->vertex_count > SQ_MESH_MAX_ELEMENTS || d->index_count / 3 > SQ_MESH_MAX_ELEMENTS)
        return sq__fail(ctx, SQ_ERR_TOO_LARGE, MODULE,
                        "%s: %d vertices, %d triangles; at most %d of each per mesh", name,
                        d->vertex_count, d->index_count / 3, SQ_MESH_MAX_ELEMENTS);
    for (int v = 0; v < 3 * d->vertex_count; v++)
        if (!isfinite(d->positions[v]) || fabsf(d->positions[v]) > 1.0e7f)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                            "%s: vertex %d has coordinate %g; positions must be finite and within "
                            "10 000 km",
                            name, v / 3, (double)d->positions[v]);
    if (d->normals)
        for (int v = 0; v < 3 * d->vertex_count; v++)
            if (!isfinite(d->normals[v]))
                return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                                "%s: normal of vertex %d is not finite", name, v / 3);
    if (d->uvs)
        for (int v = 0; v < 2 * d->vertex_count; v++)
            if (!isfinite(d->uvs[v]))
                return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                                "%s: texture coordinate of vertex %d is not finite", name, v / 2);
    const int64_t nt = d->index_count / 3;
    t->idx = sq_alloc(ctx, (size_t)nt * 3 * sizeof(uint32_t));
    t->mat = sq_alloc(ctx, (size_t)nt * sizeof(int));
    if (!t->idx || !t->mat) {
        sq_free(ctx, t->idx);
        sq_free(ctx, t->mat);
        memset(t, 0, sizeof *t);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MODULE, "%s: out of memory", name);
    }
    for (int64_t f = 0; f < nt; f++) {
        const uint32_t *q = &d->indices[3 * f];
        for (int k = 0; k < 3; k++)
            if (q[k] >= (uint32_t)d->vertex_count) {
                sq_free(ctx, t->idx);
                sq_free(ctx, t->mat);
                memset(t, 0, sizeof *t);
                return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                                "%s: triangle %lld uses vertex %u; there are %d vertices", name,
                                (long long)f, q[k], d->vertex_count);
            }
        const int m = d->face_materials ? d->face_materials[f] : 0;
        if (m < 0 || m >= materials) {
            sq_free(ctx, t->idx);
            sq_free(ctx, t->mat);
            memset(t, 0, sizeof *t);
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                            "%s: triangle %lld has material %d; there are %d materials", name,
                            (long long)f, m, materials);
        }
        const sq_vec3 a = vload(d->positions, q[0]), b = vload(d->positions, q[1]),
                      c = vload(d->positions, q[2]);
        const sq_vec3 n = sq_v3_cross(sq_v3_sub(b, a), sq_v3_sub(c, a));
        const double a2 = (double)sq_v3_dot(n, n);
        if (q[0] == q[1] || q[1] == q[2] || q[0] == q[2] || !(a2 > DEGENERATE_AREA2 * DEGENERATE_AREA2)) {
            (*dropped)++;
            continue;
        }
        memcpy(&t->idx[3 * t->n], q, 3 * sizeof(uint32_t));
        t->mat[t->n++] = m;
    }
    return SQ_OK;
}

static void bounds_of(const sq_mesh_lod *l, sq_vec3 *mn, sq_vec3 *mx)
{
    sq_vec3 a = sq_v3(FLT_MAX, FLT_MAX, FLT_MAX), b = sq_v3(-FLT_MAX, -FLT_MAX, -FLT_MAX);
    for (int v = 0; v < l->vertex_count; v++) {
        const float *p = &l->positions[3 * v];
        a = sq_v3(fminf(a.x, p[0]), fminf(a.y, p[1]), fminf(a.z, p[2]));
        b = sq_v3(fmaxf(b.x, p[0]), fmaxf(b.y, p[1]), fmaxf(b.z, p[2]));
    }
    *mn = a;
    *mx = b;
}

static sq_result copy_materials(sq_context *ctx, sq_mesh *m, const sq_mesh_desc *d)
{
    const int n = d->material_count > 0 && d->materials ? d->material_count : 1;
    if (n > SQ_MESH_MAX_MATERIALS)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "%s: %d materials; at most %d",
                        mesh_name(d), n, SQ_MESH_MAX_MATERIALS);
    m->materials = sq_alloc_zero(ctx, (size_t)n * sizeof(sq_mesh_material));
    if (!m->materials) return SQ_ERR_OUT_OF_MEMORY;
    m->material_count = n;
    if (!(d->material_count > 0 && d->materials)) {
        snprintf(m->materials[0].name, sizeof m->materials[0].name, "default");
        m->materials[0].base_color = sq_v3(0.5f, 0.5f, 0.5f);
        return SQ_OK;
    }
    for (int i = 0; i < n; i++) {
        const sq_mesh_material *s = &d->materials[i];
        sq_mesh_material *o = &m->materials[i];
        *o = *s;
        o->texture_rgba = NULL;
        o->texture_w = o->texture_h = 0;
        const sq_vec3 c = s->base_color;
        if (!(isfinite(c.x) && isfinite(c.y) && isfinite(c.z)) || c.x < 0 || c.y < 0 || c.z < 0)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                            "%s: material %d base colour (%g, %g, %g); must be finite and >= 0",
                            mesh_name(d), i, (double)c.x, (double)c.y, (double)c.z);
        if (s->texture_rgba) {
            if (s->texture_w < 1 || s->texture_h < 1 || s->texture_w > 16384 ||
                s->texture_h > 16384)
                return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                                "%s: material %d texture %dx%d; sides must be 1..16384",
                                mesh_name(d), i, s->texture_w, s->texture_h);
            const size_t b = (size_t)s->texture_w * (size_t)s->texture_h * 4;
            o->texture_rgba = sq_alloc(ctx, b);
            if (!o->texture_rgba) return SQ_ERR_OUT_OF_MEMORY;
            memcpy(o->texture_rgba, s->texture_rgba, b);
            o->texture_w = s->texture_w;
            o->texture_h = s->texture_h;
            m->bytes += b;
        }
    }
    return SQ_OK;
}

typedef struct pos_key {
    float p[3];
    int32_t i;
} pos_key;

static int cmp_pos(const void *a, const void *b)
{
    const pos_key *x = a, *y = b;
    for (int k = 0; k < 3; k++)
        if (x->p[k] != y->p[k]) return x->p[k] < y->p[k] ? -1 : 1;
    return 0;
}

static int cmp_u64(const void *a, const void *b)
{
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : (x > y);
}

/* True when every edge (on positions, welded exactly) is used as often in each direction:
 * the surface is closed and consistently oriented, so its winding number is defined. */
static bool balanced_edges(sq_context *ctx, const sq_mesh_lod *l)
{
    const int nv = l->vertex_count;
    /* weld by exact position: sort vertex ids by position */
    int32_t *weld = sq_alloc(ctx, (size_t)nv * sizeof(int32_t));
    pos_key *keys = sq_alloc(ctx, (size_t)nv * sizeof(pos_key));
    const int64_t ne = l->index_count;
    uint64_t *edges = sq_alloc(ctx, (size_t)ne * sizeof(uint64_t));
    bool ok = weld && keys && edges;
    if (ok) {
        for (int v = 0; v < nv; v++) {
            memcpy(keys[v].p, &l->positions[3 * v], sizeof keys[v].p);
            keys[v].i = v;
        }
        qsort(keys, (size_t)nv, sizeof(pos_key), cmp_pos);
        int32_t id = -1;
        for (int s = 0; s < nv; s++) {
            if (s == 0 || cmp_pos(&keys[s], &keys[s - 1]) != 0) id++;
            weld[keys[s].i] = id;
        }
        /* each directed edge as (min, max) with the direction in the low bit */
        for (int64_t f = 0; f < ne / 3; f++)
            for (int k = 0; k < 3; k++) {
                const uint32_t a = (uint32_t)weld[l->indices[3 * f + k]];
                const uint32_t b = (uint32_t)weld[l->indices[3 * f + (k + 1) % 3]];
                const uint64_t lo = a < b ? a : b, hi = a < b ? b : a;
                edges[3 * f + k] = (lo << 33) | (hi << 1) | (a < b ? 1u : 0u);
            }
        qsort(edges, (size_t)ne, sizeof(uint64_t), cmp_u64);
        for (int64_t s = 0; s < ne && ok;) {
            int64_t e = s, fwd = 0;
            while (e < ne && (edges[e] >> 1) == (edges[s] >> 1)) fwd += (int64_t)(edges[e++] & 1u);
            if (2 * fwd != e - s) ok = false;
            s = e;
        }
    }
    sq_free(ctx, weld);
    sq_free(ctx, keys);
    sq_free(ctx, edges);
    return ok;
}

sq_result sq_mesh_create(sq_context *ctx, const sq_mesh_desc *d, sq_mesh **out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "sq_mesh_create: out is NULL");
    *out = NULL;
    if (!d) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "sq_mesh_create: desc is NULL");
    char what[160];
    snprintf(what, sizeof what, "mesh %s (%d triangles)", mesh_name(d), d->index_count / 3);
    sq_result r = sq_context_check_memory(ctx, sq_mesh_memory_bytes(d, 1), what);
    if (r != SQ_OK) return r;
    sq_mesh *m = sq_alloc_zero(ctx, sizeof *m);
    if (!m) return SQ_ERR_OUT_OF_MEMORY;
    snprintf(m->name, sizeof m->name, "%s", mesh_name(d));
    m->solid = !d->open;
    r = copy_materials(ctx, m, d);
    tri_list t = {0};
    if (r == SQ_OK) r = collect_triangles(ctx, d, m->material_count, &t, &m->degenerate_dropped);
    if (r == SQ_OK)
        r = build_level(ctx, m->name, d->vertex_count, d->positions, d->normals, d->uvs, &t,
                        m->material_count, d->crease_angle_deg, &m->lods[0]);
    sq_free(ctx, t.idx);
    sq_free(ctx, t.mat);
    if (r != SQ_OK) {
        sq_mesh_destroy(ctx, m);
        return r;
    }
    m->lod_count = 1;
    bounds_of(&m->lods[0], &m->bounds_min, &m->bounds_max);
    if (m->solid && !balanced_edges(ctx, &m->lods[0])) {
        m->solid = false;
        sq_log(ctx, SQ_LOG_INFO, MODULE,
               "%s is not closed (or not consistently oriented): drawn, but not a solid for the "
               "solvers",
               m->name);
    }
    m->bytes += sizeof *m + (uint64_t)m->material_count * sizeof(sq_mesh_material) +
                lod_bytes(&m->lods[0]);
    if (m->degenerate_dropped > 0)
        sq_log(ctx, SQ_LOG_INFO, MODULE, "%s: %lld degenerate triangles dropped", m->name,
               (long long)m->degenerate_dropped);
    *out = m;
    return SQ_OK;
}

sq_result sq_mesh_add_lod(sq_context *ctx, sq_mesh *m, const sq_mesh_desc *d, float error_m)
{
    if (!m || !d) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "sq_mesh_add_lod: NULL mesh or desc");
    if (m->lod_count >= SQ_MESH_MAX_LODS)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "%s: already %d LODs; at most %d",
                        m->name, m->lod_count, SQ_MESH_MAX_LODS);
    if (!(error_m > 0.0f) || !isfinite(error_m))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "%s: LOD error %g m; must be > 0",
                        m->name, (double)error_m);
    tri_list t;
    int64_t dropped;
    sq_mesh_desc dd = *d;
    if (!dd.name) dd.name = m->name;
    sq_result r = collect_triangles(ctx, &dd, m->material_count, &t, &dropped);
    sq_mesh_lod *l = &m->lods[m->lod_count];
    if (r == SQ_OK)
        r = build_level(ctx, m->name, d->vertex_count, d->positions, d->normals,
                        m->lods[0].uvs ? d->uvs : NULL, &t, m->material_count,
                        d->crease_angle_deg, l);
    sq_free(ctx, t.idx);
    sq_free(ctx, t.mat);
    if (r != SQ_OK) return r;
    if (m->lods[0].uvs && !l->uvs) { /* keep the layout of LOD 0: zero coordinates */
        l->uvs = sq_alloc_zero(ctx, (size_t)l->vertex_count * 2 * sizeof(float));
        if (!l->uvs) {
            lod_free(ctx, l);
            return SQ_ERR_OUT_OF_MEMORY;
        }
    }
    l->error_m = error_m;
    m->bytes += lod_bytes(l);
    m->lod_count++;
    return SQ_OK;
}

/* ---- vertex clustering -------------------------------------------------------------------- */
typedef struct key_index {
    uint64_t key;
    int64_t i;
} key_index;

static int cmp_key(const void *a, const void *b)
{
    const key_index *x = a, *y = b;
    if (x->key != y->key) return x->key < y->key ? -1 : 1;
    return x->i < y->i ? -1 : (x->i > y->i);
}

/* A triangle's clusters in ascending order, for finding duplicates. */
typedef struct tri_key {
    uint32_t s[3];
    int64_t i;
} tri_key;

static int cmp_tri(const void *a, const void *b)
{
    const tri_key *x = a, *y = b;
    for (int k = 0; k < 3; k++)
        if (x->s[k] != y->s[k]) return x->s[k] < y->s[k] ? -1 : 1;
    return x->i < y->i ? -1 : (x->i > y->i);
}

static bool same_tri(const tri_key *x, const tri_key *y)
{
    return x->s[0] == y->s[0] && x->s[1] == y->s[1] && x->s[2] == y->s[2];
}

/* One coarser level of LOD 0 with cells of `cell` metres. */
static sq_result cluster_level(sq_context *ctx, sq_mesh *m, float cell, sq_mesh_lod *out)
{
    const sq_mesh_lod *l0 = &m->lods[0];
    const int nv = l0->vertex_count;
    const int64_t nt = l0->index_count / 3;
    sq_result r = SQ_OK;
    key_index *ki = sq_alloc(ctx, (size_t)nv * sizeof *ki);
    int64_t *cluster = sq_alloc(ctx, (size_t)nv * sizeof(int64_t));
    float *cpos = sq_alloc_zero(ctx, (size_t)nv * 3 * sizeof(float));
    float *cuv = l0->uvs ? sq_alloc_zero(ctx, (size_t)nv * 2 * sizeof(float)) : NULL;
    int *ccount = sq_alloc_zero(ctx, (size_t)nv * sizeof(int));
    int *face_mat = sq_alloc(ctx, (size_t)nt * sizeof(int));
    uint32_t *tri = sq_alloc(ctx, (size_t)nt * 3 * sizeof(uint32_t));
    tri_key *tk = sq_alloc(ctx, (size_t)nt * sizeof *tk);
    if (!ki || !cluster || !cpos || (l0->uvs && !cuv) || !ccount || !face_mat || !tri || !tk) {
        r = sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MODULE, "%s: out of memory building LODs", m->name);
        goto done;
    }
    /* cells keyed by 21 bits per axis */
    for (int v = 0; v < nv; v++) {
        const float *p = &l0->positions[3 * v];
        uint64_t q[3];
        const float o[3] = {m->bounds_min.x, m->bounds_min.y, m->bounds_min.z};
        for (int a = 0; a < 3; a++) {
            double c = floor((double)(p[a] - o[a]) / (double)cell);
            q[a] = (uint64_t)(c < 0 ? 0 : (c > 2097151.0 ? 2097151.0 : c));
        }
        ki[v].key = q[0] | (q[1] << 21) | (q[2] << 42);
        ki[v].i = v;
    }
    qsort(ki, (size_t)nv, sizeof *ki, cmp_key);
    int64_t nc = 0;
    for (int s = 0; s < nv; s++) {
        if (s > 0 && ki[s].key != ki[s - 1].key) nc++;
        const int64_t v = ki[s].i, c = nc;
        cluster[v] = c;
        for (int a = 0; a < 3; a++) cpos[3 * c + a] += l0->positions[3 * v + a];
        if (cuv)
            for (int a = 0; a < 2; a++) cuv[2 * c + a] += l0->uvs[2 * v + a];
        ccount[c]++;
    }
    nc++;
    for (int64_t c = 0; c < nc; c++) {
        for (int a = 0; a < 3; a++) cpos[3 * c + a] /= (float)ccount[c];
        if (cuv)
            for (int a = 0; a < 2; a++) cuv[2 * c + a] /= (float)ccount[c];
    }
    /* triangles that keep three clusters, each once (the first of duplicates) */
    int64_t kept = 0;
    for (const sq_mesh_part *p = l0->parts; p < l0->parts + l0->part_count; p++)
        for (uint32_t i = p->first_index; i < p->first_index + p->index_count; i += 3) {
            const int64_t a = cluster[l0->indices[i]], b = cluster[l0->indices[i + 1]],
                          c = cluster[l0->indices[i + 2]];
            if (a == b || b == c || a == c) continue;
            tri[3 * kept] = (uint32_t)a;
            tri[3 * kept + 1] = (uint32_t)b;
            tri[3 * kept + 2] = (uint32_t)c;
            face_mat[kept] = p->material;
            int64_t s0 = a < b ? a : b, s2 = a > b ? a : b, s1;
            if (c < s0) {
                s1 = s0;
                s0 = c;
            } else if (c > s2) {
                s1 = s2;
                s2 = c;
            } else
                s1 = c;
            tk[kept].s[0] = (uint32_t)s0;
            tk[kept].s[1] = (uint32_t)s1;
            tk[kept].s[2] = (uint32_t)s2;
            tk[kept].i = kept;
            kept++;
        }
    qsort(tk, (size_t)kept, sizeof *tk, cmp_tri);
    tri_list t = {0, sq_alloc(ctx, (size_t)(kept > 0 ? kept : 1) * 3 * sizeof(uint32_t)),
                  sq_alloc(ctx, (size_t)(kept > 0 ? kept : 1) * sizeof(int))};
    if (!t.idx || !t.mat) {
        sq_free(ctx, t.idx);
        sq_free(ctx, t.mat);
        r = sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MODULE, "%s: out of memory building LODs", m->name);
        goto done;
    }
    for (int64_t s = 0; s < kept; s++) {
        if (s > 0 && same_tri(&tk[s], &tk[s - 1])) continue;
        const int64_t f = tk[s].i;
        const sq_vec3 a = vload(cpos, tri[3 * f]), b = vload(cpos, tri[3 * f + 1]),
                      c = vload(cpos, tri[3 * f + 2]);
        const sq_vec3 n = sq_v3_cross(sq_v3_sub(b, a), sq_v3_sub(c, a));
        if (!((double)sq_v3_dot(n, n) > DEGENERATE_AREA2 * DEGENERATE_AREA2)) continue;
        memcpy(&t.idx[3 * t.n], &tri[3 * f], 3 * sizeof(uint32_t));
        t.mat[t.n++] = face_mat[f];
    }
    r = t.n > 0 ? build_level(ctx, m->name, (int)nc, cpos, NULL, cuv, &t, m->material_count, 40.0f,
                              out)
                : SQ_ERR_INVALID_ARG;
    sq_free(ctx, t.idx);
    sq_free(ctx, t.mat);
done:
    sq_free(ctx, ki);
    sq_free(ctx, cluster);
    sq_free(ctx, cpos);
    sq_free(ctx, cuv);
    sq_free(ctx, ccount);
    sq_free(ctx, face_mat);
    sq_free(ctx, tri);
    sq_free(ctx, tk);
    return r;
}

sq_result sq_mesh_generate_lods(sq_context *ctx, sq_mesh *m, int levels)
{
    if (!m) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "sq_mesh_generate_lods: mesh is NULL");
    if (levels > SQ_MESH_MAX_LODS) levels = SQ_MESH_MAX_LODS;
    const float diag = sq_v3_len(sq_v3_sub(m->bounds_max, m->bounds_min));
    if (!(diag > 0.0f)) return SQ_OK;
    /* cell sizes: diag/24, /10, /4 — each level must remove a quarter of the triangles */
    const float frac[3] = {1.0f / 24.0f, 1.0f / 10.0f, 1.0f / 4.0f};
    int step = 0;
    while (m->lod_count < levels && step < 3) {
        const float cell = diag * frac[step++];
        const float prev_err = m->lods[m->lod_count - 1].error_m;
        if (cell <= prev_err) continue;
        sq_mesh_lod l;
        sq_result r = cluster_level(ctx, m, cell, &l);
        if (r == SQ_ERR_INVALID_ARG) {
            sq_clear_error();
            break; /* nothing left at this cell size */
        }
        if (r != SQ_OK) return r;
        const int64_t prev = m->lods[m->lod_count - 1].index_count / 3;
        if ((int64_t)l.index_count / 3 > prev * 3 / 4) {
            lod_free(ctx, &l);
            continue;
        }
        l.error_m = cell;
        m->bytes += lod_bytes(&l);
        m->lods[m->lod_count++] = l;
    }
    return SQ_OK;
}

void sq_mesh_destroy(sq_context *ctx, sq_mesh *m)
{
    if (!m) return;
    for (int l = 0; l < SQ_MESH_MAX_LODS; l++) lod_free(ctx, &m->lods[l]);
    if (m->materials)
        for (int i = 0; i < m->material_count; i++) sq_free(ctx, m->materials[i].texture_rgba);
    sq_free(ctx, m->materials);
    sq_free(ctx, m);
}

int64_t sq_mesh_face_count(const sq_mesh *m, int lod)
{
    if (!m || lod < 0 || lod >= m->lod_count) return 0;
    return m->lods[lod].index_count / 3;
}

double sq_mesh_volume(const sq_mesh *m)
{
    if (!m || m->lod_count < 1) return 0.0;
    const sq_mesh_lod *l = &m->lods[0];
    double v = 0.0;
    for (int i = 0; i < l->index_count; i += 3) {
        const float *a = &l->positions[3 * l->indices[i]], *b = &l->positions[3 * l->indices[i + 1]],
                    *c = &l->positions[3 * l->indices[i + 2]];
        /* signed volume of the tetrahedron (origin, a, b, c) */
        const double ax = a[0], ay = a[1], az = a[2], bx = b[0], by = b[1], bz = b[2],
                     cx = c[0], cy = c[1], cz = c[2];
        v += (ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)) / 6.0;
    }
    return v;
}

sq_mat4 sq_mesh_instance_matrix(const sq_mesh_instance *in)
{
    const float a = in->yaw_deg * SQ_PI_F / 180.0f, c = cosf(a), s = sinf(a);
    sq_vec3 k = in->scale;
    if (k.x == 0.0f && k.y == 0.0f && k.z == 0.0f) k = sq_v3(1, 1, 1);
    sq_mat4 m = sq_m4_identity();
    m.m[0] = c * k.x;
    m.m[1] = s * k.x;
    m.m[4] = -s * k.y;
    m.m[5] = c * k.y;
    m.m[10] = k.z;
    m.m[12] = in->position_m.x;
    m.m[13] = in->position_m.y;
    m.m[14] = in->position_m.z;
    return m;
}
