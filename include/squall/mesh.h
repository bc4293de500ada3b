/* squall/mesh.h — triangle meshes for the world: geometry with materials (base colour and an
 * optional base-colour texture), levels of detail (LODs), their placement in the world as
 * instances, and a procedural generator of whole places (a suburb, a town) built from meshes.
 *
 * Axes as in the world: x east, y north, z up, metres. A mesh lives in its own frame; an
 * instance places it (scale, then rotation about z, then translation). Meshes are opaque
 * geometry for the renderer and, when closed, solids for the solvers (sq_world_solid_at).
 *
 * Files (glTF 2.0, OBJ, FBX, PLY) are read by the io layer: sq_mesh_import in squall/io.h. */
#ifndef SQ_MESH_H
#define SQ_MESH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/sqmath.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SQ_MESH_MAX_LODS 4
#define SQ_MESH_MAX_MATERIALS 64
/* Indices are 32-bit; one LOD holds at most this many vertices and triangles. */
#define SQ_MESH_MAX_ELEMENTS (1 << 28)

typedef enum sq_mesh_tint {
    SQ_TINT_NONE = 0,      /* the material's own colour */
    SQ_TINT_PRIMARY = 1,   /* replaced by the instance's tint[0] when that is set */
    SQ_TINT_SECONDARY = 2  /* replaced by the instance's tint[1] when that is set */
} sq_mesh_tint;

typedef struct sq_mesh_material {
    char name[48];
    sq_vec3 base_color;   /* linear RGB albedo in [0, 1]; multiplies the texture */
    sq_mesh_tint tint;    /* instances may recolour this material (walls, roofs, car bodies) */
    /* Optional base-colour texture: 8-bit sRGB RGBA, rows top first, texture_w * texture_h * 4
     * bytes; texels with alpha < 0.5 are cut out. Owned by the mesh; NULL = none. */
    uint8_t *texture_rgba;
    int texture_w, texture_h;
} sq_mesh_material;

/* A range of one LOD's index array drawn with one material. */
typedef struct sq_mesh_part {
    uint32_t first_index; /* into indices (a multiple of 3) */
    uint32_t index_count; /* 3 per triangle */
    int material;         /* into sq_mesh.materials */
} sq_mesh_part;

/* One level of detail: indexed triangles (counter-clockwise seen from outside). */
typedef struct sq_mesh_lod {
    int vertex_count;
    float *positions;     /* 3 per vertex, metres in the mesh frame */
    float *normals;       /* 3 per vertex, unit length */
    float *uvs;           /* 2 per vertex (OpenGL convention: v = 0 at the bottom row of the
                             texture); NULL when the mesh has no texture coordinates */
    int index_count;      /* 3 per triangle */
    uint32_t *indices;
    int part_count;
    sq_mesh_part *parts;  /* cover the index array; one per material used */
    float error_m;        /* geometric error against LOD 0 (0 for LOD 0); the renderer draws the
                             coarsest LOD whose error projects below ~1 pixel */
} sq_mesh_lod;

/* A mesh: read-only after creation; owned by whoever created it (sq_mesh_destroy). */
typedef struct sq_mesh {
    char name[128];
    int lod_count;                    /* 1..SQ_MESH_MAX_LODS; LOD 0 is the full detail */
    sq_mesh_lod lods[SQ_MESH_MAX_LODS];
    int material_count;
    sq_mesh_material *materials;
    sq_vec3 bounds_min, bounds_max;   /* of LOD 0, mesh frame */
    bool solid;                       /* closed and consistently oriented (every edge used as
                                         often in each direction) and not declared open: a solid
                                         for the solvers; else drawn two-sided, surfaces only */
    int64_t degenerate_dropped;       /* zero-area triangles removed at creation */
    uint64_t bytes;                   /* heap bytes held (all LODs, textures) */
} sq_mesh;

/* Input of sq_mesh_create: arrays borrowed for the call. */
typedef struct sq_mesh_desc {
    const char *name;         /* for messages; NULL -> "mesh" */
    int vertex_count;
    const float *positions;   /* 3 per vertex (required, finite) */
    const float *normals;     /* 3 per vertex; NULL -> computed (area-weighted, split at creases
                                 sharper than crease_angle_deg) */
    const float *uvs;         /* 2 per vertex; NULL = none */
    int index_count;          /* 3 per triangle (> 0) */
    const uint32_t *indices;  /* each < vertex_count */
    const int *face_materials; /* one per triangle; NULL -> material 0 for all */
    int material_count;       /* 0 -> one grey material */
    const sq_mesh_material *materials; /* copied (textures too) */
    float crease_angle_deg;   /* for computed normals; 0 -> 45 */
    bool open;                /* not a solid even if closed (roads, ground tiles) */
} sq_mesh_desc;

/* Bytes sq_mesh_create needs for desc with lods levels in all (LOD 0 included): the check done
 * before anything is allocated (sq_context_check_memory). */
SQ_API uint64_t sq_mesh_memory_bytes(const sq_mesh_desc *desc, int lods);
/* Builds LOD 0 from desc: checks indices and finiteness (SQ_ERR_INVALID_ARG naming the mesh,
 * the element and the rule), drops zero-area triangles (counted in degenerate_dropped),
 * computes missing normals, groups triangles into parts by material. */
SQ_API sq_result sq_mesh_create(sq_context *ctx, const sq_mesh_desc *desc, sq_mesh **out);
/* Adds a coarser level given explicitly (e.g. a generator's simplified house), error_m its
 * geometric error. Materials index the mesh's materials. */
SQ_API sq_result sq_mesh_add_lod(sq_context *ctx, sq_mesh *mesh, const sq_mesh_desc *lod,
                                 float error_m);
/* Generates coarser levels by vertex clustering (Rossignac & Borrel 1993) of LOD 0 until the mesh
 * has `levels` LODs (at most SQ_MESH_MAX_LODS) or a level no longer removes a quarter of the
 * triangles. Cell sizes grow from 1/24 to 1/4 of the bounding-box diagonal. */
SQ_API sq_result sq_mesh_generate_lods(sq_context *ctx, sq_mesh *mesh, int levels);
SQ_API void sq_mesh_destroy(sq_context *ctx, sq_mesh *mesh);
/* Triangles of LOD lod (0 if out of range). */
SQ_API int64_t sq_mesh_face_count(const sq_mesh *mesh, int lod);
/* Enclosed volume of LOD 0 (divergence theorem; meaningful for closed meshes), m^3. */
SQ_API double sq_mesh_volume(const sq_mesh *mesh);

/* ---- import (the io layer reads files: sq_mesh_import in squall/io.h) ---------------------- */
typedef enum sq_mesh_up {
    SQ_MESH_UP_DEFAULT = 0, /* by format: glTF, OBJ, FBX y up; PLY z up */
    SQ_MESH_UP_Y = 1,       /* the file's +y is up: turned so that it becomes +z */
    SQ_MESH_UP_Z = 2
} sq_mesh_up;

typedef struct sq_mesh_import_desc {
    const char *path;     /* glTF 2.0 (.gltf, .glb), OBJ (.obj), FBX (.fbx) or PLY (.ply) */
    int lods;             /* levels in all: a file's single level is simplified by vertex
                             clustering up to this many; 0 -> 4; 1 = no simplification */
    sq_mesh_up up;
} sq_mesh_import_desc;

/* ---- instances: a mesh placed in the world -------------------------------------------------- */
typedef struct sq_mesh_instance {
    int mesh;             /* index into the world's mesh list */
    sq_vec3 position_m;   /* where the mesh origin goes; z NaN -> on the terrain (the lowest
                             terrain under the footprint, so nothing floats) */
    float yaw_deg;        /* heading: rotation about z, counter-clockwise seen from above */
    sq_vec3 scale;        /* per axis of the mesh frame, > 0; (0, 0, 0) -> 1 */
    sq_vec3 tint[2];      /* colours for SQ_TINT_PRIMARY / SECONDARY materials; 0 -> material */
} sq_mesh_instance;

/* World-from-mesh matrix of an instance (scale, rotation about z, translation). */
SQ_API sq_mat4 sq_mesh_instance_matrix(const sq_mesh_instance *inst);

/* ---- procedural places ---------------------------------------------------------------------- */
typedef enum sq_place_kind {
    SQ_PLACE_NONE = 0,
    SQ_PLACE_SUBURB = 1, /* detached houses (gable and hip roofs) on garden plots along a street
                            grid, trees (trunk, branches, foliage), cars, fences, a park with a
                            pavilion with overhanging eaves */
    SQ_PLACE_TOWN = 2    /* town blocks: terraced houses and apartment buildings around
                            courtyards, shops, street trees, parked cars */
} sq_place_kind;

typedef struct sq_place_desc {
    sq_place_kind kind;
    float size_m[2];      /* extent along x and y; 0 -> 1000 x 1000 */
    float center_m[2];    /* centre (x, y); 0 is physical */
    uint64_t seed;        /* 0 is a valid seed: the same seed gives the same place */
    float tree_density;   /* multiplier of trees per garden/street; 0 -> 1 */
    /* Ground height under (x, y) so roads and driveways follow the terrain; NULL -> z = 0. */
    float (*height_at)(const void *user, float x, float y);
    const void *height_user;
} sq_place_desc;

/* A generated place: meshes (owned by the place) and instances that index them. */
typedef struct sq_place {
    int mesh_count;
    sq_mesh **meshes;
    int instance_count;
    sq_mesh_instance *instances;
    int64_t faces;        /* triangles over all instances at LOD 0 */
    int houses, trees, cars;
    uint64_t bytes;       /* heap bytes of meshes + instances */
} sq_place;

/* Bytes a place of this desc will need at most (checked before generating). */
SQ_API uint64_t sq_place_memory_bytes(const sq_place_desc *desc);
SQ_API sq_result sq_place_generate(sq_context *ctx, const sq_place_desc *desc, sq_place **out);
SQ_API void sq_place_destroy(sq_context *ctx, sq_place *place);

#ifdef __cplusplus
}
#endif
#endif
