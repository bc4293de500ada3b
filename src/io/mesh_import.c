/* mesh_import.c — mesh files through assimp (glTF 2.0, OBJ, FBX, PLY) into sq_mesh: the file is
 * checked first (exists, readable, a regular file, a supported ending, its memory need against
 * the context's limit — from the file size, and for PLY from the element counts its header
 * declares), then imported with node transforms baked in and polygons triangulated; points and
 * lines are skipped. The result becomes one mesh with one material per file material (base
 * colour, optional PNG base-colour texture); sq_mesh_create computes missing normals and drops
 * degenerate triangles; coarser LODs come from vertex clustering. Files with y up (glTF by its
 * specification, OBJ and FBX by custom) are turned to the world's z up. */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "io/io_internal.h"
#include "squall/io.h"

#if SQ_HAVE_ASSIMP
#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#endif

#define MODULE "mesh"
/* Bytes of memory the importer and the mesh need per byte of file, at most (assimp's copy of
 * the data with its post-processing, our LOD 0 and the coarser levels); checked before loading. */
#define BYTES_PER_FILE_BYTE 12

typedef enum fmt { FMT_NONE, FMT_GLTF, FMT_OBJ, FMT_FBX, FMT_PLY } fmt;

static fmt format_of(const char *path, char *ext, size_t size)
{
    const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
    ext[0] = 0;
    if (!dot || (slash && dot < slash)) return FMT_NONE;
    size_t n = 0;
    for (const char *c = dot; *c && n + 1 < size; c++) ext[n++] = (char)tolower((unsigned char)*c);
    ext[n] = 0;
    if (!strcmp(ext, ".gltf") || !strcmp(ext, ".glb")) return FMT_GLTF;
    if (!strcmp(ext, ".obj")) return FMT_OBJ;
    if (!strcmp(ext, ".fbx")) return FMT_FBX;
    if (!strcmp(ext, ".ply")) return FMT_PLY;
    return FMT_NONE;
}

/* For a PLY file, the bytes its header's vertex and face counts imply (0 if not found). */
static uint64_t ply_declared_bytes(FILE *fp, uint64_t *verts, uint64_t *faces)
{
    char line[256];
    *verts = *faces = 0;
    for (int i = 0; i < 200 && fgets(line, sizeof line, fp); i++) {
        unsigned long long n = 0;
        if (sscanf(line, "element vertex %llu", &n) == 1) *verts = n;
        else if (sscanf(line, "element face %llu", &n) == 1) *faces = n;
        if (!strncmp(line, "end_header", 10)) break;
    }
    /* per vertex: assimp's copy (position, normal, uv: 32) + ours (32, split normals up to 3
     * per triangle corner); per face: up to 4 triangles of 12 bytes each in both copies */
    return *verts * 64u + *faces * (2u * 48u + 3u * 32u);
}

static sq_result precheck(sq_context *ctx, const char *path, fmt *f)
{
    char ext[16];
    struct stat st;
    if (!path || !path[0]) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "mesh file path is empty");
    /* only a regular file (a FIFO would block the open), recorded so no output replaces it */
    FILE *fp = NULL;
    sq_result r = sq__input_open(ctx, MODULE, "mesh", path, &fp);
    if (r != SQ_OK) return r;
    if (fstat(fileno(fp), &st) != 0) {
        const int e = errno;
        fclose(fp);
        return sq__fail(ctx, SQ_ERR_IO, MODULE, "cannot open mesh '%s': %s", path, strerror(e));
    }
    *f = format_of(path, ext, sizeof ext);
    if (*f == FMT_NONE) {
        fclose(fp);
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "mesh '%s': unsupported format '%s'; supported: glTF 2.0 (.gltf, .glb), "
                        "OBJ (.obj), FBX (.fbx), PLY (.ply)",
                        path, ext[0] ? ext : "(no file ending)");
    }
    if (st.st_size == 0) {
        fclose(fp);
        return sq__fail(ctx, SQ_ERR_PARSE, MODULE, "mesh '%s' is empty (0 bytes)", path);
    }
    uint64_t need = (uint64_t)st.st_size * BYTES_PER_FILE_BYTE;
    char what[600];
    snprintf(what, sizeof what, "mesh '%s' (%lld bytes of file)", path, (long long)st.st_size);
    if (*f == FMT_PLY) {
        uint64_t v, fc;
        const uint64_t declared = ply_declared_bytes(fp, &v, &fc);
        if (declared > need) {
            need = declared;
            snprintf(what, sizeof what, "mesh '%s' (its header declares %llu vertices and %llu faces)",
                     path, (unsigned long long)v, (unsigned long long)fc);
        }
    }
    fclose(fp);
    return sq_context_check_memory(ctx, need, what);
}

#if SQ_HAVE_ASSIMP
/* Reads a material's base-colour texture: an embedded PNG ("*N") or a PNG file beside the mesh.
 * Other image kinds are skipped with a warning (the material keeps its colour). */
static void load_texture(sq_context *ctx, const char *mesh_path, const struct aiScene *sc,
                         const struct aiMaterial *am, sq_mesh_material *out)
{
    struct aiString tp;
    if (aiGetMaterialTexture(am, aiTextureType_BASE_COLOR, 0, &tp, NULL, NULL, NULL, NULL, NULL,
                             NULL) != aiReturn_SUCCESS &&
        aiGetMaterialTexture(am, aiTextureType_DIFFUSE, 0, &tp, NULL, NULL, NULL, NULL, NULL,
                             NULL) != aiReturn_SUCCESS)
        return;
    const char *t = tp.data;
    uint8_t *rgba = NULL;
    int w = 0, h = 0;
    sq_result r;
    if (t[0] == '*') {
        const unsigned idx = (unsigned)strtoul(t + 1, NULL, 10);
        if (idx >= sc->mNumTextures) return;
        const struct aiTexture *tx = sc->mTextures[idx];
        if (tx->mHeight != 0) { /* raw ARGB8888 texels */
            if (tx->mWidth == 0 || tx->mWidth > 16384 || tx->mHeight > 16384) return;
            w = (int)tx->mWidth;
            h = (int)tx->mHeight;
            rgba = sq_alloc(ctx, (size_t)w * (size_t)h * 4);
            if (!rgba) return;
            for (size_t i = 0; i < (size_t)w * (size_t)h; i++) {
                rgba[4 * i] = tx->pcData[i].r;
                rgba[4 * i + 1] = tx->pcData[i].g;
                rgba[4 * i + 2] = tx->pcData[i].b;
                rgba[4 * i + 3] = tx->pcData[i].a;
            }
            r = SQ_OK;
        } else {
            char name[600];
            snprintf(name, sizeof name, "%s (embedded texture %u)", mesh_path, idx);
            r = sq__png_decode_rgba8(ctx, tx->pcData, tx->mWidth, name, &rgba, &w, &h);
        }
    } else {
        char full[2048];
        const char *slash = strrchr(mesh_path, '/');
        if (t[0] == '/' || !slash) snprintf(full, sizeof full, "%s", t);
        else snprintf(full, sizeof full, "%.*s/%s", (int)(slash - mesh_path), mesh_path, t);
        char ext[16];
        const char *dot = strrchr(full, '.');
        snprintf(ext, sizeof ext, "%s", dot ? dot : "");
        for (char *c = ext; *c; c++) *c = (char)tolower((unsigned char)*c);
        if (strcmp(ext, ".png") != 0) {
            sq_log(ctx, SQ_LOG_WARN, MODULE,
                   "mesh '%s': texture '%s' is not a PNG; only PNG textures are read, the "
                   "material keeps its colour",
                   mesh_path, t);
            return;
        }
        r = sq_png_read_rgba8(ctx, full, &rgba, &w, &h);
    }
    if (r != SQ_OK) {
        sq_log(ctx, SQ_LOG_WARN, MODULE, "mesh '%s': texture skipped: %s", mesh_path, sq_last_error());
        sq_clear_error();
        sq_free(ctx, rgba);
        return;
    }
    out->texture_rgba = rgba;
    out->texture_w = w;
    out->texture_h = h;
}

static sq_result import_scene(sq_context *ctx, const sq_mesh_import_desc *d, fmt f, sq_mesh **out)
{
    const char *path = d->path;
    const unsigned flags = aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                           aiProcess_SortByPType | aiProcess_PreTransformVertices |
                           aiProcess_ValidateDataStructure;
    const struct aiScene *sc = aiImportFile(path, flags);
    if (!sc || (sc->mFlags & AI_SCENE_FLAGS_INCOMPLETE) || !sc->mRootNode) {
        const sq_result r = sq__fail(ctx, SQ_ERR_PARSE, MODULE, "mesh '%s' is corrupt or unreadable: %s",
                                     path, sc ? "the file holds no complete scene" : aiGetErrorString());
        if (sc) aiReleaseImport(sc);
        return r;
    }
    /* counts over the triangle meshes */
    uint64_t nv = 0, nt = 0;
    bool all_normals = true, any_uv = false;
    for (unsigned m = 0; m < sc->mNumMeshes; m++) {
        const struct aiMesh *am = sc->mMeshes[m];
        if (!(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
        nv += am->mNumVertices;
        nt += am->mNumFaces;
        all_normals = all_normals && am->mNormals;
        any_uv = any_uv || am->mTextureCoords[0];
    }
    if (nt == 0 || nv == 0) {
        aiReleaseImport(sc);
        return sq__fail(ctx, SQ_ERR_PARSE, MODULE, "mesh '%s' holds no triangles (%u meshes)", path,
                        sc->mNumMeshes);
    }
    if (nv > SQ_MESH_MAX_ELEMENTS || nt > SQ_MESH_MAX_ELEMENTS) {
        aiReleaseImport(sc);
        return sq__fail(ctx, SQ_ERR_TOO_LARGE, MODULE,
                        "mesh '%s': %llu vertices, %llu triangles; at most %d of each", path,
                        (unsigned long long)nv, (unsigned long long)nt, SQ_MESH_MAX_ELEMENTS);
    }
    const int nmat = sc->mNumMaterials > 0 ? (int)sc->mNumMaterials : 1;
    if (nmat > SQ_MESH_MAX_MATERIALS) {
        aiReleaseImport(sc);
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "mesh '%s': %d materials; at most %d",
                        path, nmat, SQ_MESH_MAX_MATERIALS);
    }
    float *pos = sq_alloc(ctx, nv * 3 * sizeof(float));
    float *nrm = all_normals ? sq_alloc(ctx, nv * 3 * sizeof(float)) : NULL;
    float *uv = any_uv ? sq_alloc_zero(ctx, nv * 2 * sizeof(float)) : NULL;
    uint32_t *idx = sq_alloc(ctx, nt * 3 * sizeof(uint32_t));
    int *fm = sq_alloc(ctx, nt * sizeof(int));
    sq_mesh_material *mats = sq_alloc_zero(ctx, (size_t)nmat * sizeof *mats);
    sq_result r = SQ_OK;
    if (!pos || (all_normals && !nrm) || (any_uv && !uv) || !idx || !fm || !mats) {
        r = sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MODULE, "mesh '%s': out of memory", path);
        goto done;
    }
    const bool yup = d->up == SQ_MESH_UP_Y || (d->up == SQ_MESH_UP_DEFAULT && f != FMT_PLY);
    uint64_t v0 = 0, t = 0;
    for (unsigned m = 0; m < sc->mNumMeshes; m++) {
        const struct aiMesh *am = sc->mMeshes[m];
        if (!(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
        for (unsigned v = 0; v < am->mNumVertices; v++) {
            const struct aiVector3D p = am->mVertices[v];
            float *o = &pos[3 * (v0 + v)];
            o[0] = p.x;
            o[1] = yup ? -p.z : p.y;
            o[2] = yup ? p.y : p.z;
            if (nrm) {
                const struct aiVector3D n = am->mNormals[v];
                float *q = &nrm[3 * (v0 + v)];
                q[0] = n.x;
                q[1] = yup ? -n.z : n.y;
                q[2] = yup ? n.y : n.z;
            }
            if (uv && am->mTextureCoords[0]) {
                uv[2 * (v0 + v)] = am->mTextureCoords[0][v].x;
                uv[2 * (v0 + v) + 1] = am->mTextureCoords[0][v].y;
            }
        }
        for (unsigned k = 0; k < am->mNumFaces; k++) {
            const struct aiFace *fc = &am->mFaces[k];
            if (fc->mNumIndices != 3) continue; /* points and lines of a mixed mesh */
            for (int c = 0; c < 3; c++) idx[3 * t + (uint64_t)c] = (uint32_t)(v0 + fc->mIndices[c]);
            fm[t++] = am->mMaterialIndex < (unsigned)nmat ? (int)am->mMaterialIndex : 0;
        }
        v0 += am->mNumVertices;
    }
    for (int i = 0; i < nmat; i++) {
        sq_mesh_material *o = &mats[i];
        o->base_color = sq_v3(0.6f, 0.6f, 0.6f);
        if ((unsigned)i >= sc->mNumMaterials) continue;
        const struct aiMaterial *am = sc->mMaterials[i];
        struct aiString name;
        if (aiGetMaterialString(am, AI_MATKEY_NAME, &name) == aiReturn_SUCCESS)
            snprintf(o->name, sizeof o->name, "%.47s", name.data);
        struct aiColor4D c;
        if (aiGetMaterialColor(am, AI_MATKEY_BASE_COLOR, &c) == aiReturn_SUCCESS ||
            aiGetMaterialColor(am, AI_MATKEY_COLOR_DIFFUSE, &c) == aiReturn_SUCCESS)
            o->base_color = sq_v3(fmaxf(c.r, 0.0f), fmaxf(c.g, 0.0f), fmaxf(c.b, 0.0f));
        load_texture(ctx, path, sc, am, o);
    }
    aiReleaseImport(sc);
    sc = NULL;
    {
        const char *slash = strrchr(path, '/');
        sq_mesh_desc md;
        memset(&md, 0, sizeof md);
        md.name = slash ? slash + 1 : path;
        md.vertex_count = (int)nv;
        md.positions = pos;
        md.normals = nrm;
        md.uvs = uv;
        md.index_count = (int)(3 * t);
        md.indices = idx;
        md.face_materials = fm;
        md.material_count = nmat;
        md.materials = mats;
        r = sq_mesh_create(ctx, &md, out);
        if (r == SQ_ERR_INVALID_ARG || r == SQ_ERR_TOO_LARGE) {
            char why[1024];
            snprintf(why, sizeof why, "%s", sq_last_error());
            r = sq__fail(ctx, r, MODULE, "mesh '%s': %s", path, why);
        }
    }
    if (r == SQ_OK && d->lods != 1) r = sq_mesh_generate_lods(ctx, *out, d->lods > 0 ? d->lods : 4);
    if (r != SQ_OK) {
        sq_mesh_destroy(ctx, *out);
        *out = NULL;
    }
done:
    if (sc) aiReleaseImport(sc);
    for (int i = 0; mats && i < nmat; i++) sq_free(ctx, mats[i].texture_rgba);
    sq_free(ctx, mats);
    sq_free(ctx, pos);
    sq_free(ctx, nrm);
    sq_free(ctx, uv);
    sq_free(ctx, idx);
    sq_free(ctx, fm);
    return r;
}
#endif

sq_result sq_mesh_import(sq_context *ctx, const sq_mesh_import_desc *d, sq_mesh **out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "sq_mesh_import: out is NULL");
    *out = NULL;
    if (!d) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "sq_mesh_import: desc is NULL");
    if (d->lods < 0 || d->lods > SQ_MESH_MAX_LODS)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "mesh '%s': lods = %d; must be 0..%d",
                        d->path ? d->path : "", d->lods, SQ_MESH_MAX_LODS);
    fmt f = FMT_NONE;
    sq_result r = precheck(ctx, d->path, &f);
    if (r != SQ_OK) return r;
#if SQ_HAVE_ASSIMP
    r = import_scene(ctx, d, f, out);
    if (r == SQ_OK && (*out)->degenerate_dropped > 0)
        sq_log(ctx, SQ_LOG_WARN, MODULE, "mesh '%s': %lld degenerate (zero-area) triangles dropped",
               d->path, (long long)(*out)->degenerate_dropped);
    return r;
#else
    (void)f;
    return sq__fail(ctx, SQ_ERR_UNSUPPORTED, MODULE,
                    "mesh '%s': this build has no mesh import (configure with SQ_WITH_ASSIMP=ON)",
                    d->path);
#endif
}

sq_result sq_scene_mesh_loader(sq_context *ctx, const sq_mesh_import_desc *d, sq_mesh **out)
{
    return sq_mesh_import(ctx, d, out);
}
