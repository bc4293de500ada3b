/* procgen_internal.h — the procedural place generator's private parts: a growing triangle
 * builder with closed primitives (boxes, tapered cylinders, cone frustums, ellipsoid blobs,
 * convex polyhedra by rings), the prototype meshes (houses, trees, cars, fences, a pavilion,
 * town buildings) and the layouts (suburb, town). Every primitive is a closed, outward-oriented
 * surface, so a prototype made of them is a union of closed parts: a solid for the world's
 * winding-number queries (world_mesh.c). */
#ifndef SQ_PROCGEN_INTERNAL_H
#define SQ_PROCGEN_INTERNAL_H

#include <stdbool.h>
#include <stdint.h>

#include "squall/mesh.h"

/* ---- builder (procgen_build.c) ------------------------------------------------------------- */
typedef struct pg_mesh {
    sq_context *ctx;
    float *pos;      /* 3 per vertex */
    int nv, cap_v;
    uint32_t *idx;   /* 3 per triangle */
    int *mat;        /* per triangle */
    int nt, cap_t;
    bool oom;
} pg_mesh;

/* An affine frame: p' = m * p + t (m column-major 3x3). */
typedef struct pg_xf {
    float m[9];
    sq_vec3 t;
} pg_xf;

pg_xf pg_xf_identity(void);
/* Translation, then rotation about z by yaw (radians) around the origin: p' = Rz p + t. */
pg_xf pg_xf_yaw(sq_vec3 t, float yaw);
/* a then b: p' = a(b(p)). */
pg_xf pg_xf_mul(pg_xf a, pg_xf b);
pg_xf pg_xf_rot_x(float angle);
pg_xf pg_xf_rot_y(float angle);
sq_vec3 pg_apply(const pg_xf *x, sq_vec3 p);

void pg_init(pg_mesh *b, sq_context *ctx);
void pg_free(pg_mesh *b);
int pg_vertex(pg_mesh *b, sq_vec3 p);
void pg_tri(pg_mesh *b, int a, int c, int d, int mat);
/* Quad a, b, c, d counter-clockwise seen from outside. */
void pg_quad(pg_mesh *b, int a, int c, int d, int e, int mat);
/* Closed box lo..hi in frame x. */
void pg_box(pg_mesh *b, const pg_xf *x, sq_vec3 lo, sq_vec3 hi, int mat);
/* Closed tapered cylinder from a (radius ra) to c (radius rc), `sides` sides; radius 0 at an end
 * makes a cone. */
void pg_cylinder(pg_mesh *b, sq_vec3 a, sq_vec3 c, float ra, float rc, int sides, int mat);
/* Closed solid of revolution about the z axis through `centre`: rings (radius, z) from bottom to
 * top, each with `sides` vertices rotated by phase; a ring of radius 0 is a single apex point.
 * Bottom and top are closed with fans. */
void pg_lathe(pg_mesh *b, const pg_xf *x, const float *radius, const float *z, int rings,
              int sides, int mat);
/* Closed, lumpy ellipsoid (foliage clump): a UV sphere of `rings` x `sides`, radii r, each vertex
 * pushed out by up to `lump` of its radius by hashed noise from seed. */
void pg_blob(pg_mesh *b, sq_vec3 centre, sq_vec3 r, int rings, int sides, float lump,
             uint64_t seed, int mat);
/* Closed prism: a convex polygon (n points, counter-clockwise seen from above, z = 0 in frame x)
 * extruded to height h. */
void pg_prism(pg_mesh *b, const pg_xf *x, const float *xy, int n, float h, int mat);
/* Turns the builder into a mesh (LOD 0) or adds it to m as a level with error error_m. */
sq_result pg_to_mesh(pg_mesh *b, const char *name, const sq_mesh_material *mats, int nmat,
                     bool open, sq_mesh **out);
sq_result pg_add_lod(pg_mesh *b, sq_mesh *m, float error_m);

/* Deterministic uniform in [0, 1) from (seed, stream, index). */
float pg_rand(uint64_t seed, uint64_t stream, uint64_t index);

/* ---- prototypes (procgen_parts.c) ----------------------------------------------------------- */
typedef enum pg_roof {
    PG_ROOF_GABLE = 0,
    PG_ROOF_HIP = 1,
    PG_ROOF_FLAT = 2
} pg_roof;

typedef struct pg_house_spec {
    float width, depth;   /* footprint along x (frontage) and y (the front faces -y) */
    int storeys;
    float storey_h;       /* m */
    pg_roof roof;
    float pitch_deg;
    float overhang;       /* eaves overhang, m */
    bool chimney, porch, garage;
    uint64_t seed;
} pg_house_spec;

sq_result pg_make_house(sq_context *ctx, const pg_house_spec *s, sq_mesh **out);

typedef enum pg_tree_kind {
    PG_TREE_CONIFER = 0,
    PG_TREE_BROADLEAF = 1,
    PG_TREE_BARE = 2      /* broadleaf without leaves: trunk and branches only */
} pg_tree_kind;

sq_result pg_make_tree(sq_context *ctx, pg_tree_kind kind, float height, uint64_t seed,
                       sq_mesh **out);
sq_result pg_make_car(sq_context *ctx, int style, uint64_t seed, sq_mesh **out);
/* A fence section `length` long along x: posts, rails and pickets (picket = true) or boards. */
sq_result pg_make_fence(sq_context *ctx, float length, bool picket, sq_mesh **out);
sq_result pg_make_hedge(sq_context *ctx, float length, uint64_t seed, sq_mesh **out);
/* An octagonal pavilion with upturned, overhanging eaves on a stone platform. */
sq_result pg_make_pavilion(sq_context *ctx, float radius, sq_mesh **out);
/* A town building: frontage along x, depth along y (front faces -y), storeys, a shop front at
 * the ground floor; roof gable or flat. */
sq_result pg_make_town_building(sq_context *ctx, float width, float depth, int storeys,
                                pg_roof roof, bool shop, uint64_t seed, sq_mesh **out);
sq_result pg_make_lamp(sq_context *ctx, sq_mesh **out);

/* ---- layouts (procgen_place.c) --------------------------------------------------------------- */
#endif
