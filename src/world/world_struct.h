/* world_struct.h — the layout of sq_world (opaque in include/squall/world.h): private to the
 * library and its tests. Applications read a world through the sq_world_* accessors. */
#ifndef SQ_WORLD_STRUCT_H
#define SQ_WORLD_STRUCT_H

#include "squall/world.h"

struct sq_world {
    /* terrain heightfield: heights[j*nx + i] at (origin.x + i*dx, origin.y + j*dy) */
    int nx, ny;
    float dx, dy;
    sq_vec3 origin;        /* x, y of sample (0,0); z unused */
    float *heights;        /* nx*ny, metres above datum */
    float *normals;        /* 3*nx*ny, unit normals */
    float height_min, height_max;
    sq_terrain_kind terrain_kind;
    sq_terrain_material terrain_material;
    float snow_line_m; /* sq_terrain_desc.snow_line_m; 0 = none */
    /* obstacles */
    sq_obstacle obstacles[SQ_MAX_OBSTACLES];
    int obstacle_count;
    /* sun and sky */
    sq_vec3 sun_dir;       /* unit vector toward the sun */
    sq_vec3 sun_radiance;  /* linear RGB irradiance scale of the sun at the ground */
    sq_vec3 sky_zenith;    /* linear RGB sky radiance at zenith */
    sq_vec3 sky_horizon;   /* linear RGB sky radiance at the horizon */
    sq_vec3 ground_albedo;
    float turbidity;
    /* georeference: NULL when the world has no CRS (owned by the world) */
    char *crs_wkt;
    double crs_offset_m[2];
    /* 1 where the terrain source had no data (the height is filled); NULL = all measured */
    uint8_t *terrain_void;
    /* named polygon areas (owned copies) */
    sq_world_area areas[SQ_MAX_WORLD_AREAS];
    int area_count;
    /* meshes (sq_world_set_meshes): the mesh pointers are borrowed — the meshes must outlive
     * the world or the next sq_world_set_meshes; the instances are the world's copy, with z
     * resolved on the terrain and scale (0,0,0) replaced by (1,1,1) */
    const sq_mesh *const *meshes;
    int mesh_count;
    sq_mesh_instance *mesh_instances;
    int mesh_instance_count;
    int64_t mesh_faces;    /* LOD-0 triangles over all instances */
    struct sq__mesh_accel *mesh_accel; /* BVHs behind the solid queries (private) */
    /* the sun's clock (sq_sun_desc.utc_set): sun_dir, sun_radiance and the sky follow
     * sq_world_set_time; sun_position is the sun's place at time_s */
    bool sun_follows_clock;
    bool sun_from_time;    /* the sun's direction comes from day, hour and latitude (no
                              sun.direction given) */
    double sun_utc_start_unix_s, sun_clock_scale;
    float sun_latitude_deg, sun_longitude_deg, sun_north_rotation_deg, sun_irradiance_w_m2;
    double time_s;
    sq_sun_position sun_position;
    float vertical_exaggeration;
    uint64_t generation;   /* changes when terrain, obstacles or meshes change */
};

#endif
