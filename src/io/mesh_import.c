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
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

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
                         const struct aiMaterial *am, sq_mesh_material *out, char *file_read,
                         size_t file_size)
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
        if (r == SQ_OK) snprintf(file_read, file_size, "%s", full);
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

/* What assimp's scene becomes before sq_mesh_create: z-up triangles with one material index
 * each and the file's materials. Arrays from sq_alloc (imported_free). */
typedef struct imported {
    uint64_t nv, nt;
    int nmat;
    float *pos, *nrm, *uv; /* nrm NULL unless every mesh has normals; uv NULL when none has */
    uint32_t *idx;
    int *fm;
    sq_mesh_material *mats;
    char (*tex_file)[2048]; /* per material: the PNG file its texture came from, or "" */
} imported;

static void imported_free(sq_context *ctx, imported *im)
{
    for (int i = 0; im->mats && i < im->nmat; i++) sq_free(ctx, im->mats[i].texture_rgba);
    sq_free(ctx, im->mats);
    sq_free(ctx, im->pos);
    sq_free(ctx, im->nrm);
    sq_free(ctx, im->uv);
    sq_free(ctx, im->idx);
    sq_free(ctx, im->fm);
    sq_free(ctx, im->tex_file);
    memset(im, 0, sizeof *im);
}

static sq_result read_with_assimp(sq_context *ctx, const sq_mesh_import_desc *d, fmt f,
                                  imported *im)
{
    const char *path = d->path;
    memset(im, 0, sizeof *im);
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
    float *pos = im->pos = sq_alloc(ctx, nv * 3 * sizeof(float));
    float *nrm = im->nrm = all_normals ? sq_alloc(ctx, nv * 3 * sizeof(float)) : NULL;
    float *uv = im->uv = any_uv ? sq_alloc_zero(ctx, nv * 2 * sizeof(float)) : NULL;
    uint32_t *idx = im->idx = sq_alloc(ctx, nt * 3 * sizeof(uint32_t));
    int *fm = im->fm = sq_alloc(ctx, nt * sizeof(int));
    sq_mesh_material *mats = im->mats = sq_alloc_zero(ctx, (size_t)nmat * sizeof *mats);
    im->tex_file = sq_alloc_zero(ctx, (size_t)nmat * sizeof *im->tex_file);
    im->nmat = nmat;
    if (!pos || (all_normals && !nrm) || (any_uv && !uv) || !idx || !fm || !mats ||
        !im->tex_file) {
        aiReleaseImport(sc);
        imported_free(ctx, im);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MODULE, "mesh '%s': out of memory", path);
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
        load_texture(ctx, path, sc, am, o, im->tex_file[i], sizeof im->tex_file[i]);
    }
    aiReleaseImport(sc);
    im->nv = nv;
    im->nt = t;
    return SQ_OK;
}

/* ---- the importer in a child process -------------------------------------------------------
 * assimp is not hardened against damaged files (a fuzzer crashes its PLY reader within seconds),
 * so by default it runs in a forked child that sends the imported arrays back through a pipe: a
 * crash in assimp becomes a refusal of the file, not the end of the caller's process.
 * SQ_MESH_IMPORT_IN_PROCESS=1 in the environment imports in the calling process instead. */
static bool write_all(int fd, const void *p, size_t n)
{
    const char *c = (const char *)p;
    while (n > 0) {
        const ssize_t k = write(fd, c, n);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) return false;
        c += k;
        n -= (size_t)k;
    }
    return true;
}

/* The parent's reads: polled every 0.1 s so that Ctrl-C (the context's cancellation) and the
 * time limit are answered while the child works. */
typedef struct importer_wait {
    sq_context *ctx;
    double deadline_s; /* CLOCK_MONOTONIC */
    int stop;          /* 1 cancelled, 2 past the time limit */
} importer_wait;

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static bool read_all(importer_wait *w, int fd, void *p, size_t n)
{
    char *c = (char *)p;
    while (n > 0) {
        struct pollfd pf = {.fd = fd, .events = POLLIN};
        const int ready = poll(&pf, 1, 100);
        if (ready < 0 && errno != EINTR) return false;
        if (ready <= 0) {
            if (sq_context_cancelled(w->ctx)) w->stop = 1;
            else if (now_s() > w->deadline_s) w->stop = 2;
            if (w->stop) return false;
            continue;
        }
        const ssize_t k = read(fd, c, n);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) return false;
        c += k;
        n -= (size_t)k;
    }
    return true;
}

typedef struct wire_head {
    int32_t result;
    int32_t nmat;
    uint64_t nv, nt;
    uint8_t has_nrm, has_uv;
    char message[1024];
} wire_head;

/* The child: import, then send the head and the arrays; never returns. */
static void child_import(sq_context *ctx, const sq_mesh_import_desc *d, fmt f, int fd)
{
    imported im;
    wire_head h;
    memset(&h, 0, sizeof h);
    h.result = (int32_t)read_with_assimp(ctx, d, f, &im);
    if (h.result != SQ_OK) snprintf(h.message, sizeof h.message, "%s", sq_last_error());
    h.nmat = im.nmat;
    h.nv = im.nv;
    h.nt = im.nt;
    h.has_nrm = im.nrm != NULL;
    h.has_uv = im.uv != NULL;
    bool ok = write_all(fd, &h, sizeof h);
    if (ok && h.result == SQ_OK) {
        ok = write_all(fd, im.pos, im.nv * 3 * sizeof(float)) &&
             (!im.nrm || write_all(fd, im.nrm, im.nv * 3 * sizeof(float))) &&
             (!im.uv || write_all(fd, im.uv, im.nv * 2 * sizeof(float))) &&
             write_all(fd, im.idx, im.nt * 3 * sizeof(uint32_t)) &&
             write_all(fd, im.fm, im.nt * sizeof(int));
        for (int i = 0; ok && i < im.nmat; i++) {
            const sq_mesh_material *m = &im.mats[i];
            const uint32_t flen = (uint32_t)strlen(im.tex_file[i]);
            ok = write_all(fd, m, sizeof *m) &&
                 (!m->texture_rgba ||
                  write_all(fd, m->texture_rgba, (size_t)m->texture_w * (size_t)m->texture_h * 4)) &&
                 write_all(fd, &flen, sizeof flen) && write_all(fd, im.tex_file[i], flen);
        }
    }
    close(fd);
    _exit(ok ? 0 : 3);
}

/* The parent: receive what the child imported. */
static sq_result receive(importer_wait *w, const char *path, int fd, imported *im)
{
    sq_context *ctx = w->ctx;
    wire_head h;
    memset(im, 0, sizeof *im);
    if (!read_all(w, fd, &h, sizeof h)) return SQ_ERR_IO; /* the child died: see waitpid */
    if (h.result != SQ_OK) {
        h.message[sizeof h.message - 1] = 0;
        return sq__fail(ctx, (sq_result)h.result, MODULE, "%s", h.message);
    }
    if (h.nv > SQ_MESH_MAX_ELEMENTS || h.nt > SQ_MESH_MAX_ELEMENTS || h.nmat < 1 ||
        h.nmat > SQ_MESH_MAX_MATERIALS)
        return SQ_ERR_IO;
    im->nv = h.nv;
    im->nt = h.nt;
    im->nmat = h.nmat;
    im->pos = sq_alloc(ctx, h.nv * 3 * sizeof(float));
    im->nrm = h.has_nrm ? sq_alloc(ctx, h.nv * 3 * sizeof(float)) : NULL;
    im->uv = h.has_uv ? sq_alloc(ctx, h.nv * 2 * sizeof(float)) : NULL;
    im->idx = sq_alloc(ctx, h.nt * 3 * sizeof(uint32_t));
    im->fm = sq_alloc(ctx, h.nt * sizeof(int));
    im->mats = sq_alloc_zero(ctx, (size_t)h.nmat * sizeof *im->mats);
    if (!im->pos || (h.has_nrm && !im->nrm) || (h.has_uv && !im->uv) || !im->idx || !im->fm ||
        !im->mats) {
        imported_free(ctx, im);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MODULE, "mesh '%s': out of memory", path);
    }
    bool ok = read_all(w, fd, im->pos, h.nv * 3 * sizeof(float)) &&
              (!im->nrm || read_all(w, fd, im->nrm, h.nv * 3 * sizeof(float))) &&
              (!im->uv || read_all(w, fd, im->uv, h.nv * 2 * sizeof(float))) &&
              read_all(w, fd, im->idx, h.nt * 3 * sizeof(uint32_t)) &&
              read_all(w, fd, im->fm, h.nt * sizeof(int));
    for (int i = 0; ok && i < h.nmat; i++) {
        sq_mesh_material *m = &im->mats[i];
        ok = read_all(w, fd, m, sizeof *m);
        const bool has_tex = ok && m->texture_rgba != NULL;
        m->texture_rgba = NULL;
        if (has_tex) {
            if (m->texture_w <= 0 || m->texture_h <= 0 || m->texture_w > 16384 ||
                m->texture_h > 16384) {
                ok = false;
                break;
            }
            const size_t n = (size_t)m->texture_w * (size_t)m->texture_h * 4;
            m->texture_rgba = sq_alloc(ctx, n);
            ok = m->texture_rgba && read_all(w, fd, m->texture_rgba, n);
        }
        /* the PNG file the texture came from is an input of the run: the child's record of it
         * went with the child, so it is recorded here (no output may replace it) */
        uint32_t flen = 0;
        char file[2048];
        ok = ok && read_all(w, fd, &flen, sizeof flen) && flen < sizeof file &&
             read_all(w, fd, file, flen);
        if (ok && flen > 0) {
            file[flen] = 0;
            const sq_result g = sq__input_guard(ctx, MODULE, "mesh texture", file);
            if (g != SQ_OK) {
                imported_free(ctx, im);
                return g;
            }
        }
    }
    if (!ok) {
        imported_free(ctx, im);
        return SQ_ERR_IO;
    }
    return SQ_OK;
}

/* The importer's time limit: SQ_MESH_IMPORT_TIMEOUT_S, else 120 s plus 10 s per MB of file
 * (assimp reads tens of MB per second; a file that keeps it longer has sent it into a loop). */
static double import_limit_s(const char *path)
{
    const char *env = getenv("SQ_MESH_IMPORT_TIMEOUT_S");
    if (env && atof(env) > 0.0) return atof(env);
    struct stat st;
    const double mb = stat(path, &st) == 0 ? (double)st.st_size / 1e6 : 0.0;
    return 120.0 + 10.0 * mb;
}

static sq_result read_isolated(sq_context *ctx, const sq_mesh_import_desc *d, fmt f, imported *im)
{
    const char *env = getenv("SQ_MESH_IMPORT_IN_PROCESS");
    if (env && env[0] == '1') return read_with_assimp(ctx, d, f, im);
    const double limit_s = import_limit_s(d->path);
    int p[2];
    if (pipe(p) != 0)
        return sq__fail(ctx, SQ_ERR_IO, MODULE, "mesh '%s': cannot start the importer: %s",
                        d->path, strerror(errno));
    fflush(NULL);
    const pid_t pid = fork();
    if (pid < 0) {
        const int e = errno;
        close(p[0]);
        close(p[1]);
        return sq__fail(ctx, SQ_ERR_IO, MODULE, "mesh '%s': cannot start the importer: %s",
                        d->path, strerror(e));
    }
    if (pid == 0) {
        /* a crash in assimp ends the child by its signal (no handler of the parent's runs) */
        static const int fatal[] = {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL};
        for (size_t k = 0; k < sizeof fatal / sizeof fatal[0]; k++) signal(fatal[k], SIG_DFL);
        close(p[0]);
        child_import(ctx, d, f, p[1]);
    }
    close(p[1]);
    importer_wait w = {ctx, now_s() + limit_s, 0};
    sq_result r = receive(&w, d->path, p[0], im);
    close(p[0]);
    if (w.stop) kill(pid, SIGKILL);
    int status = 0;
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    if (r != SQ_ERR_IO) return r;
    imported_free(ctx, im);
    if (w.stop == 1)
        return sq__fail(ctx, SQ_ERR_CANCELLED, MODULE, "mesh '%s': import cancelled", d->path);
    if (w.stop == 2)
        return sq__fail(ctx, SQ_ERR_PARSE, MODULE,
                        "mesh '%s' is corrupt or too large: the importer (assimp) was still "
                        "reading it after %.0f s (SQ_MESH_IMPORT_TIMEOUT_S sets the limit)",
                        d->path, limit_s);
    if (WIFSIGNALED(status))
        return sq__fail(ctx, SQ_ERR_PARSE, MODULE,
                        "mesh '%s' is corrupt: the importer (assimp) crashed on it (signal %d, %s)",
                        d->path, WTERMSIG(status), strsignal(WTERMSIG(status)));
    return sq__fail(ctx, SQ_ERR_PARSE, MODULE,
                    "mesh '%s' is corrupt: the importer (assimp) failed on it without a result "
                    "(exit status %d)",
                    d->path, WIFEXITED(status) ? WEXITSTATUS(status) : -1);
}

static sq_result import_scene(sq_context *ctx, const sq_mesh_import_desc *d, fmt f, sq_mesh **out)
{
    const char *path = d->path;
    imported im;
    sq_result r = read_isolated(ctx, d, f, &im);
    if (r != SQ_OK) return r;
    {
        const char *slash = strrchr(path, '/');
        sq_mesh_desc md;
        memset(&md, 0, sizeof md);
        md.name = slash ? slash + 1 : path;
        md.vertex_count = (int)im.nv;
        md.positions = im.pos;
        md.normals = im.nrm;
        md.uvs = im.uv;
        md.index_count = (int)(3 * im.nt);
        md.indices = im.idx;
        md.face_materials = im.fm;
        md.material_count = im.nmat;
        md.materials = im.mats;
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
    imported_free(ctx, &im);
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
