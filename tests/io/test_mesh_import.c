/* test_mesh_import.c — mesh files through assimp: an OBJ (quads, no normals, a degenerate face)
 * and a glTF 2.0 (binary buffer in a data URI, normals, a PNG base-colour texture beside it)
 * written here, imported with the right triangle counts, normals (given ones turned from y up
 * to z up, missing ones computed flat), base colour and texture; and the refusals (missing file,
 * unsupported ending, corrupt contents, a PLY whose header declares more than memory allows). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "sq_test.h"
#include "squall/io.h"
#include "squall/mesh.h"

SQ_LABEL(unit)

static sq_context *make_ctx(void)
{
    sq_context *ctx = NULL;
    sq_context_desc cd;
    memset(&cd, 0, sizeof cd);
    cd.threads = 1;
    if (sq_context_create(&cd, &ctx) != SQ_OK) exit(1);
    return ctx;
}

static char dir[256];

static const char *tmp_path(const char *name)
{
    static char buf[512];
    if (!dir[0]) {
        snprintf(dir, sizeof dir, "/tmp/sq_mesh_import_XXXXXX");
        if (!mkdtemp(dir)) exit(1);
    }
    snprintf(buf, sizeof buf, "%s/%s", dir, name);
    return buf;
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    if (!f) exit(1);
    fputs(text, f);
    fclose(f);
}

static void cleanup(void)
{
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (dir[0] && system(cmd) != 0) fprintf(stderr, "could not remove %s\n", dir);
}

static sq_result import(sq_context *ctx, const char *path, int lods, sq_mesh **m)
{
    sq_mesh_import_desc d;
    memset(&d, 0, sizeof d);
    d.path = path;
    d.lods = lods;
    return sq_mesh_import(ctx, &d, m);
}

/* Unit normal of LOD 0 triangle t from its corners' stored normals (all three must agree). */
static bool flat_normal(const sq_mesh_lod *l, int t, sq_vec3 *n)
{
    const float *a = &l->normals[3 * l->indices[3 * t]];
    for (int k = 1; k < 3; k++) {
        const float *b = &l->normals[3 * l->indices[3 * t + k]];
        if (fabsf(a[0] - b[0]) + fabsf(a[1] - b[1]) + fabsf(a[2] - b[2]) > 1e-4f) return false;
    }
    *n = sq_v3(a[0], a[1], a[2]);
    return true;
}

/* A unit cube as 6 quads (OBJ faces of 4 vertices) without normals, plus a zero-area triangle. */
SQ_TEST(obj_cube_faces_and_computed_normals)
{
    sq_context *ctx = make_ctx();
    const char *p = tmp_path("cube.obj");
    write_text(p, "# cube written by the test\n"
                  "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                  "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 3 4 8 7\nf 1 5 8 4\nf 2 3 7 6\n"
                  "f 1 2 2\n");
    sq_mesh *m = NULL;
    SQ_CHECK_MSG(import(ctx, p, 1, &m) == SQ_OK, "%s", sq_last_error());
    if (m) {
        /* 6 quads -> 12 triangles; the degenerate one dropped and counted */
        SQ_CHECK_MSG(sq_mesh_face_count(m, 0) == 12, "faces %lld", (long long)sq_mesh_face_count(m, 0));
        SQ_CHECK_MSG(m->degenerate_dropped == 1, "dropped %lld", (long long)m->degenerate_dropped);
        /* OBJ is y up: the file's y (0..1) becomes z, its z becomes -y */
        SQ_CHECK(fabsf(m->bounds_min.z) < 1e-6f && fabsf(m->bounds_max.z - 1.0f) < 1e-6f);
        SQ_CHECK(fabsf(m->bounds_min.y + 1.0f) < 1e-6f && fabsf(m->bounds_max.y) < 1e-6f);
        SQ_CHECK_MSG(fabs(sq_mesh_volume(m) - 1.0) < 1e-5, "volume %g", sq_mesh_volume(m));
        SQ_CHECK(m->solid);
        /* computed normals: flat per face, axis-aligned, pointing out of the cube */
        const sq_mesh_lod *l = &m->lods[0];
        const sq_vec3 c = sq_v3(0.5f, -0.5f, 0.5f);
        for (int t = 0; t < 12; t++) {
            sq_vec3 n;
            SQ_CHECK_MSG(flat_normal(l, t, &n), "triangle %d: corner normals differ", t);
            const float *a = &l->positions[3 * l->indices[3 * t]];
            const sq_vec3 out = sq_v3_sub(sq_v3(a[0], a[1], a[2]), c);
            const float ax = fmaxf(fabsf(n.x), fmaxf(fabsf(n.y), fabsf(n.z)));
            SQ_CHECK_MSG(fabsf(ax - 1.0f) < 1e-5f && sq_v3_dot(n, out) > 0.0f,
                         "triangle %d normal (%g %g %g)", t, (double)n.x, (double)n.y, (double)n.z);
        }
    }
    sq_mesh_destroy(ctx, m);
    cleanup();
    sq_context_destroy(ctx);
}

static void b64(const unsigned char *in, size_t n, char *out)
{
    static const char t[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t o = 0;
    for (size_t i = 0; i < n; i += 3) {
        const unsigned v = (unsigned)in[i] << 16 | (i + 1 < n ? (unsigned)in[i + 1] << 8 : 0u) |
                           (i + 2 < n ? in[i + 2] : 0u);
        out[o++] = t[(v >> 18) & 63];
        out[o++] = t[(v >> 12) & 63];
        out[o++] = i + 1 < n ? t[(v >> 6) & 63] : '=';
        out[o++] = i + 2 < n ? t[v & 63] : '=';
    }
    out[o] = 0;
}

/* A glTF box (24 vertices with normals and uvs, 36 indices) of 2 x 1 x 3 m (x, y up, z), a
 * base colour factor and a 4 x 2 PNG texture. */
SQ_TEST(gltf_box_normals_colour_texture)
{
    sq_context *ctx = make_ctx();
    enum { NV = 24, NI = 36 };
    float pos[NV * 3], nrm[NV * 3], uv[NV * 2];
    uint16_t idx[NI];
    const float half[3] = {1.0f, 0.5f, 1.5f};
    int v = 0, k = 0;
    for (int axis = 0; axis < 3; axis++)
        for (int sgn = -1; sgn <= 1; sgn += 2) {
            /* the face with normal sgn * e_axis; u, w the other axes, counter-clockwise outside */
            const int u = (axis + 1) % 3, w = (axis + 2) % 3;
            const float cu[4] = {-1, 1, 1, -1}, cw[4] = {-1, -1, 1, 1};
            const int base = v;
            for (int c = 0; c < 4; c++) {
                float q[3];
                q[axis] = (float)sgn * half[axis];
                q[u] = cu[c] * half[u] * (float)sgn;
                q[w] = cw[c] * half[w];
                memcpy(&pos[3 * v], q, sizeof q);
                nrm[3 * v] = nrm[3 * v + 1] = nrm[3 * v + 2] = 0.0f;
                nrm[3 * v + axis] = (float)sgn;
                uv[2 * v] = 0.5f * (cu[c] + 1.0f);
                uv[2 * v + 1] = 0.5f * (cw[c] + 1.0f);
                v++;
            }
            const uint16_t t6[6] = {0, 1, 2, 0, 2, 3};
            for (int i = 0; i < 6; i++) idx[k++] = (uint16_t)(base + t6[i]);
        }
    unsigned char buf[sizeof pos + sizeof nrm + sizeof uv + sizeof idx];
    memcpy(buf, pos, sizeof pos);
    memcpy(buf + sizeof pos, nrm, sizeof nrm);
    memcpy(buf + sizeof pos + sizeof nrm, uv, sizeof uv);
    memcpy(buf + sizeof pos + sizeof nrm + sizeof uv, idx, sizeof idx);
    char *enc = malloc(2 * sizeof buf + 8);
    b64(buf, sizeof buf, enc);
    /* the texture: 4 x 2, left half red, right half blue */
    uint8_t tex[4 * 2 * 4];
    for (int i = 0; i < 8; i++) {
        const bool left = (i % 4) < 2;
        tex[4 * i] = left ? 255 : 0;
        tex[4 * i + 1] = 0;
        tex[4 * i + 2] = left ? 0 : 255;
        tex[4 * i + 3] = 255;
    }
    SQ_CHECK(sq_png_write_rgba8(tmp_path("box_colour.png"), 4, 2, tex, true) == SQ_OK);
    char *json = malloc(strlen(enc) + 4096);
    sprintf(json,
            "{\"asset\": {\"version\": \"2.0\"},\n"
            " \"scene\": 0, \"scenes\": [{\"nodes\": [0]}], \"nodes\": [{\"mesh\": 0}],\n"
            " \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0, \"NORMAL\": 1, "
            "\"TEXCOORD_0\": 2}, \"indices\": 3, \"material\": 0}]}],\n"
            " \"materials\": [{\"name\": \"painted\", \"pbrMetallicRoughness\": {\"baseColorFactor\": "
            "[0.8, 0.5, 0.25, 1.0], \"baseColorTexture\": {\"index\": 0}}}],\n"
            " \"textures\": [{\"source\": 0}], \"images\": [{\"uri\": \"box_colour.png\"}],\n"
            " \"buffers\": [{\"byteLength\": %zu, \"uri\": \"data:application/octet-stream;base64,%s\"}],\n"
            " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": %zu},"
            " {\"buffer\": 0, \"byteOffset\": %zu, \"byteLength\": %zu},"
            " {\"buffer\": 0, \"byteOffset\": %zu, \"byteLength\": %zu},"
            " {\"buffer\": 0, \"byteOffset\": %zu, \"byteLength\": %zu}],\n"
            " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": %d, \"type\": \"VEC3\","
            " \"min\": [-1, -0.5, -1.5], \"max\": [1, 0.5, 1.5]},"
            " {\"bufferView\": 1, \"componentType\": 5126, \"count\": %d, \"type\": \"VEC3\"},"
            " {\"bufferView\": 2, \"componentType\": 5126, \"count\": %d, \"type\": \"VEC2\"},"
            " {\"bufferView\": 3, \"componentType\": 5123, \"count\": %d, \"type\": \"SCALAR\"}]}\n",
            sizeof buf, enc, sizeof pos, sizeof pos, sizeof nrm, sizeof pos + sizeof nrm, sizeof uv,
            sizeof pos + sizeof nrm + sizeof uv, sizeof idx, NV, NV, NV, NI);
    const char *p = tmp_path("box.gltf");
    write_text(p, json);
    sq_mesh *m = NULL;
    SQ_CHECK_MSG(import(ctx, p, 1, &m) == SQ_OK, "%s", sq_last_error());
    if (m) {
        SQ_CHECK(sq_mesh_face_count(m, 0) == 12);
        SQ_CHECK(m->degenerate_dropped == 0);
        /* y up turned to z up: extents x 2, y 3 (the file's z), z 1 (the file's y) */
        const sq_vec3 e = sq_v3_sub(m->bounds_max, m->bounds_min);
        SQ_CHECK_MSG(fabsf(e.x - 2.0f) < 1e-5f && fabsf(e.y - 3.0f) < 1e-5f && fabsf(e.z - 1.0f) < 1e-5f,
                     "extent %g %g %g", (double)e.x, (double)e.y, (double)e.z);
        SQ_CHECK_MSG(fabs(sq_mesh_volume(m) - 6.0) < 1e-4, "volume %g", sq_mesh_volume(m));
        /* the file's normals, turned: every triangle's normal is its face's outward axis */
        const sq_mesh_lod *l = &m->lods[0];
        int up = 0;
        for (int t = 0; t < 12; t++) {
            sq_vec3 n;
            SQ_CHECK(flat_normal(l, t, &n));
            const float *a = &l->positions[3 * l->indices[3 * t]];
            SQ_CHECK(sq_v3_dot(n, sq_v3(a[0], a[1], a[2])) > 0.0f);
            up += n.z > 0.99f;
        }
        SQ_CHECK_MSG(up == 2, "%d triangles face up", up);
        SQ_CHECK(l->uvs != NULL);
        SQ_CHECK(m->material_count >= 1);
        const sq_mesh_material *mt = &m->materials[l->parts[0].material];
        SQ_CHECK_MSG(fabsf(mt->base_color.x - 0.8f) < 1e-4f && fabsf(mt->base_color.y - 0.5f) < 1e-4f &&
                         fabsf(mt->base_color.z - 0.25f) < 1e-4f,
                     "base colour %g %g %g", (double)mt->base_color.x, (double)mt->base_color.y,
                     (double)mt->base_color.z);
        SQ_CHECK_MSG(mt->texture_rgba && mt->texture_w == 4 && mt->texture_h == 2, "texture %dx%d",
                     mt->texture_w, mt->texture_h);
        if (mt->texture_rgba) SQ_CHECK(mt->texture_rgba[0] == 255 && mt->texture_rgba[4 * 3 + 2] == 255);
    }
    sq_mesh_destroy(ctx, m);
    free(enc);
    free(json);
    cleanup();
    sq_context_destroy(ctx);
}

SQ_TEST(bad_files_refused)
{
    sq_context *ctx = make_ctx();
    sq_mesh *m = NULL;
    SQ_CHECK(import(ctx, tmp_path("missing.glb"), 0, &m) == SQ_ERR_IO && !m);
    SQ_CHECK_MSG(strstr(sq_last_error(), "missing.glb") && strstr(sq_last_error(), "No such file"), "%s",
                 sq_last_error());
    write_text(tmp_path("model.stl"), "solid x\nendsolid x\n");
    SQ_CHECK(import(ctx, tmp_path("model.stl"), 0, &m) == SQ_ERR_INVALID_ARG);
    SQ_CHECK_MSG(strstr(sq_last_error(), "unsupported format '.stl'"), "%s", sq_last_error());
    write_text(tmp_path("junk.glb"), "this is not a glTF binary file at all");
    SQ_CHECK(import(ctx, tmp_path("junk.glb"), 0, &m) == SQ_ERR_PARSE);
    SQ_CHECK_MSG(strstr(sq_last_error(), "junk.glb"), "%s", sq_last_error());
    write_text(tmp_path("huge.ply"), "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n"
                                     "property float x\nproperty float y\nproperty float z\n"
                                     "element face 8000000000\nproperty list uchar int vertex_indices\n"
                                     "end_header\n");
    SQ_CHECK(import(ctx, tmp_path("huge.ply"), 0, &m) == SQ_ERR_TOO_LARGE);
    SQ_CHECK_MSG(strstr(sq_last_error(), "huge.ply") && strstr(sq_last_error(), "bytes"), "%s", sq_last_error());
    cleanup();
    sq_context_destroy(ctx);
}
