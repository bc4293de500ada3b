/* fuzz_mesh.c — the mesh importer (src/io/mesh_import.c, on assimp): byte 0 picks the file type
 * (OBJ, PLY, glTF 2.0 JSON), the rest is the file, written under that ending (the importer
 * chooses its reader by the ending) and imported with LOD generation.
 * Contract: success gives a mesh whose every level has finite positions and unit normals, indices
 * below its vertex count, parts that cover the index array with valid materials, finite bounds
 * and textures of the size they say; failure names the file; nothing leaks through the context.
 * assimp is the packaged, uninstrumented library and not hardened: the importer runs it in a
 * child process, so its crashes and loops must come back as refusals naming the file (the first
 * minutes of fuzzing crashed its PLY reader: regress/mesh/); a crash in squall's use of what it
 * returns is ours. Seeds: tests/fuzz/corpus/mesh/ (byte 0 = 0 OBJ, 1 PLY, 2 glTF). */
#include <math.h>
#include <stdbool.h>
#include <sys/stat.h>

#include "fuzz_util.h"
#include "sq_config.h"
#include "squall/mesh.h"

static char dir[64];
static char path[3][96];

static void remove_files(void)
{
    for (int k = 0; k < 3; k++) unlink(path[k]);
    rmdir(dir);
}

static const char *mesh_path(int kind)
{
    if (!dir[0]) {
        snprintf(dir, sizeof dir, "/tmp/squall-fuzz-mesh-XXXXXX");
        if (!mkdtemp(dir)) abort();
        static const char *const ext[3] = {"obj", "ply", "gltf"};
        for (int k = 0; k < 3; k++) snprintf(path[k], sizeof path[k], "%s/m.%s", dir, ext[k]);
        atexit(remove_files);
        /* an input that keeps assimp in a loop is refused by the importer's own limit, before
         * libFuzzer's 10 s per input */
        setenv("SQ_MESH_IMPORT_TIMEOUT_S", "4", 0);
    }
    return path[kind];
}

static void check_lod(const sq_mesh *m, const sq_mesh_lod *l, int level)
{
    FUZZ_CHECK(l->vertex_count >= 0 && l->index_count >= 0 && l->index_count % 3 == 0,
               "LOD %d: %d vertices, %d indices", level, l->vertex_count, l->index_count);
    for (int v = 0; v < l->vertex_count; v++) {
        const float *p = &l->positions[3 * v], *n = &l->normals[3 * v];
        FUZZ_CHECK(isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]), "LOD %d vertex %d: %g %g %g",
                   level, v, p[0], p[1], p[2]);
        const double len = sqrt((double)n[0] * n[0] + (double)n[1] * n[1] + (double)n[2] * n[2]);
        FUZZ_CHECK(fabs(len - 1.0) < 1e-3, "LOD %d vertex %d: normal of length %g", level, v, len);
    }
    for (int i = 0; i < l->index_count; i++)
        FUZZ_CHECK(l->indices[i] < (uint32_t)l->vertex_count, "LOD %d index %d = %u of %d vertices",
                   level, i, l->indices[i], l->vertex_count);
    uint32_t covered = 0;
    for (int p = 0; p < l->part_count; p++) {
        const sq_mesh_part *pt = &l->parts[p];
        FUZZ_CHECK(pt->first_index == covered && pt->index_count % 3 == 0 && pt->material >= 0 &&
                       pt->material < m->material_count,
                   "LOD %d part %d: first %u (expected %u), %u indices, material %d of %d", level,
                   p, pt->first_index, covered, pt->index_count, pt->material, m->material_count);
        covered += pt->index_count;
    }
    FUZZ_CHECK(covered == (uint32_t)l->index_count, "LOD %d: parts cover %u of %d indices", level,
               covered, l->index_count);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
#if !SQ_HAVE_ASSIMP
    (void)data, (void)size; /* built without assimp: there is no importer to fuzz */
    return 0;
#else
    if (size < 1) return 0;
    sq_context *ctx = sq_fuzz_context(256u << 20);
    const char *file = mesh_path(data[0] % 3);
    FILE *fp = fopen(file, "wb");
    if (!fp) abort();
    if (size > 1 && fwrite(data + 1, 1, size - 1, fp) != size - 1) abort();
    fclose(fp);
    sq_mesh_import_desc d = {.path = file, .lods = 3};
    sq_mesh *m = NULL;
    const sq_result r = sq_mesh_import(ctx, &d, &m);
    if (getenv("SQ_FUZZ_VERBOSE")) /* what each seed does */
        fprintf(stderr, "%s: %s\n", file,
                r == SQ_OK ? "imported" : sq_last_error());
    if (r == SQ_OK) {
        FUZZ_CHECK(m && m->lod_count >= 1 && m->lod_count <= SQ_MESH_MAX_LODS, "%d LODs",
                   m ? m->lod_count : -1);
        FUZZ_CHECK(m->material_count >= 1, "%d materials", m->material_count);
        for (int k = 0; k < m->material_count; k++) {
            const sq_mesh_material *mt = &m->materials[k];
            FUZZ_CHECK(!mt->texture_rgba || (mt->texture_w > 0 && mt->texture_h > 0),
                       "material %d: texture %dx%d", k, mt->texture_w, mt->texture_h);
            if (mt->texture_rgba) { /* every texel is there (a short buffer shows under ASan) */
                volatile uint8_t last =
                    mt->texture_rgba[4 * ((size_t)mt->texture_w * (size_t)mt->texture_h) - 1];
                (void)last;
            }
        }
        for (int l = 0; l < m->lod_count; l++) check_lod(m, &m->lods[l], l);
        FUZZ_CHECK(isfinite(m->bounds_min.x) && isfinite(m->bounds_max.z), "bounds not finite");
        sq_mesh_destroy(ctx, m);
    } else {
        FUZZ_CHECK(m == NULL, "a refused import returned a mesh");
        FUZZ_CHECK(strstr(sq_last_error(), file) != NULL, "the refusal does not name the file: %s",
                   sq_last_error());
    }
    sq_fuzz_context_clean(ctx, "an import");
    return 0;
#endif
}
