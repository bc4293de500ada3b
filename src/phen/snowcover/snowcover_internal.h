/* snowcover_internal.h — the snow-cover phenomenon's state (squall/snowcover.h): the
 * accumulation grid, the falling-snow pool and the camera the emitter follows. */
#ifndef SQ_SNOWCOVER_INTERNAL_H
#define SQ_SNOWCOVER_INTERNAL_H

#include "core/core_internal.h"
#include "squall/snowcover.h"
#include "squall/field.h"

#define SQ_SNOWCOVER_G 9.80665 /* m/s², standard gravity */
#define SQ_SNOWCOVER_RHO_WATER 1000.0 /* kg/m³ */
/* The deepest snow cover ever measured on the ground: 11.82 m on Mount Ibuki, Japan, 14 February
 * 1927. The accumulation model refuses to go deeper (the displaced shell would bury houses and
 * balloon every mesh; the depth is then a time-lapse or rate mistake, not a snow scene). */
#define SQ_SNOWCOVER_MAX_DEPTH_M 11.82
/* floats per flake of the pool: position 3, velocity 3, birth offset 2, rotation, spin, radius,
 * fade */
#define SQ__SNOWCOVER_FLAKE_FLOATS 12

struct sq_snowcover {
    sq_context *ctx;
    sq_snowcover_desc d; /* resolved */
    const sq_world *world;
    double time_s;
    double water_m;      /* water equivalent fallen on exposed ground (prior + accumulated) */
    /* accumulation grid: depth (m) on the highest surface of each column, cell centres at
     * origin + (i + 1/2) cell */
    int nx, ny;
    double origin[2], cell_m;
    float *depth;
    uint64_t version;
    /* falling snow: pool of flakes */
    int nflakes;
    float *pool;         /* one block holding the arrays below: SQ__SNOWCOVER_FLAKE_FLOATS each */
    float *pos, *vel;    /* 3 per flake, world metres, m/s */
    float *birth;        /* 2 per flake: horizontal offset from the emitter centre at birth */
    float *rot, *spin;   /* rad, rad/s */
    float *radius, *fade; /* per frame, from the camera (layers, eq 2.4) */
    uint64_t flake_step; /* counter of the noise draws */
    bool have_camera, seeded;
    sq_camera camera;    /* resolved */
    double centre[3];    /* emitter box centre (x, y) and its top z */
    double box_m;        /* emitter side */
    int visible;         /* flakes drawn in the last frame's view */
    double ms_flakes;    /* time of the last flake step + sizing */
    sq_metric metrics[6];
    /* inputs from another layer (sq_snowcover_set_inputs): depth, wind u, v, w */
    bool has_depth_in, has_wind_in;
    sq_named_field depth_in, wind_in[3];
};

/* The wind of the input fields at p (nearest cell; 0 in solid cells); false outside them. */
bool sq__snowcover_input_wind(const sq_snowcover *s, const float p[3], double w[3]);

/* The accumulation grid over the world's terrain (snowcover_desc.c). */
void sq__snowcover_grid(const sq_snowcover_desc *d, const sq_world *w, int *nx, int *ny,
                        double origin[2], double *cell);

/* falling snow (snowcover_flakes.c) */
void sq__snowcover_flakes_seed(sq_snowcover *s);
void sq__snowcover_flakes_step(sq_snowcover *s, double dt_s);
void sq__snowcover_flakes_size(sq_snowcover *s);

/* checkpoints (snowcover_state.c) */
sq_result sq__snowcover_save_state(const void *self, sq_state_writer *w);
sq_result sq__snowcover_load_state(void *self, sq_state_reader *r);

int sq__snowcover_drawables(sq_snowcover *s, sq_drawable *out, int max);
int sq__snowcover_metrics(sq_snowcover *s, sq_metric *out, int max);
int sq__snowcover_fields(sq_snowcover *s, sq_named_field *out, int max);

#endif
