/* bench_sph.c — `squall bench sph [--particles 65536|262144|1048576] [--model cross|water|both]`:
 * one full SPH sub-step (counting sort, density, strain, forces, integration) per timed call.
 * Two set-ups, one JSON line each:
 *   cross-avalanche      the thesis's Cross snow (μ∞ = 1, μ₀ = 100 Pa s, n = 2, K = 3000 s,
 *                        ρ₀ = 300 kg/m³) as a block sliding in a box tilted 35° (gravity has a
 *                        down-slope component), no-slip walls, open top;
 *   newtonian-dam-break  water (Tait, μ = 1e-3 Pa s, α = 0.02) collapsing from a column of
 *                        width a and height 2a at one end of a tank.
 * Both use dx = 0.1 m, H = 2 dx. Keys: the common ones plus model, particles,
 * particle_steps_per_s, neighbours_per_particle, bytes_per_particle (everything the solver
 * allocated, per particle) and mean per-stage milliseconds (ms_sort, ms_density, ms_strain,
 * ms_forces, ms_integrate) over the timed steps. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cases.h"
#include "squall/sph.h"

typedef struct sph_bench {
    sq_sph *s;
    double dt;
    sq_result err;
    int calls, warmup, timed;
    double ms[5];
} sph_bench;

static int step(void *user)
{
    sph_bench *b = (sph_bench *)user;
    b->err = sq_sph_step(b->s, b->dt);
    if (b->err != SQ_OK) return 1;
    if (++b->calls <= b->warmup) return 0; /* stage times of the timed calls only */
    const sq_sph_stats st = sq_sph_get_stats(b->s);
    b->ms[0] += st.ms_sort;
    b->ms[1] += st.ms_density;
    b->ms[2] += st.ms_strain;
    b->ms[3] += st.ms_forces;
    b->ms[4] += st.ms_integrate;
    b->timed++;
    return 0;
}

static int run_model(const sq_bench_args *a, int water, long particles)
{
    const double dx = 0.1, g = 9.81;
    /* block dimensions: water a column nx × ny × 2nx, snow a flat-ish block 2n × n × n/2 */
    size_t nx, ny, nz;
    if (water) {
        nx = ny = (size_t)floor(cbrt((double)particles / 2.0));
        nz = (size_t)particles / (nx * ny);
    } else {
        ny = (size_t)floor(cbrt((double)particles));
        nx = ny;
        nz = (size_t)particles / (nx * ny);
    }
    const double bx = nx * dx, by = ny * dx, bz = nz * dx;
    sq_sph_desc d;
    memset(&d, 0, sizeof d);
    d.spacing_m = dx;
    d.support_radius_m = 2.0 * dx;
    for (int f = 0; f < 6; f++) d.boundary[f] = SQ_SPH_BOUNDARY_NO_SLIP;
    d.boundary[SQ_SPH_FACE_ZMAX] = SQ_SPH_BOUNDARY_OPEN;
    if (water) {
        d.rest_density_kgm3 = 1000.0;
        d.eos = SQ_SPH_EOS_TAIT;
        d.artificial_viscosity = 0.02;
        sq_sph_rheology_preset("water", &d.rheology);
        d.gravity_mps2[2] = -g;
        d.max_speed_mps = sqrt(2.0 * g * bz);
        d.domain_max_m[0] = 4.0 * bx;
        d.domain_max_m[1] = by;
        d.domain_max_m[2] = 1.5 * bz;
    } else {
        const double th = 35.0 * 3.14159265358979 / 180.0;
        d.rest_density_kgm3 = 300.0;
        sq_sph_rheology_preset("s2-avalanche", &d.rheology);
        d.gravity_mps2[0] = g * sin(th);
        d.gravity_mps2[2] = -g * cos(th);
        d.max_speed_mps = 10.0;
        d.domain_max_m[0] = 2.0 * bx;
        d.domain_max_m[1] = by;
        d.domain_max_m[2] = 2.0 * bz;
    }
    d.max_particles = nx * ny * nz;
    sph_bench b;
    memset(&b, 0, sizeof b);
    b.warmup = a->warmup;
    sq_result r = sq_sph_create(a->ctx, &d, &b.s);
    if (r == SQ_OK) {
        const double lo[3] = {0.0, 0.0, 0.0}, hi[3] = {bx, by, bz};
        r = sq_sph_add_block(b.s, lo, hi, NULL, NULL);
    }
    /* a fixed sub-step a little below the stable one: one sub-step per timed call */
    if (r == SQ_OK) {
        b.dt = 0.8 * sq_sph_max_stable_dt(b.s);
        if (!(b.dt > 0.0)) r = SQ_ERR_UNSTABLE;
    }
    if (r != SQ_OK) {
        sq_cli_error("%s", sq_last_error());
        sq_sph_destroy(b.s);
        return sq_cli_exit_code(r);
    }
    const sq_bench_stats st = sq_bench_time(step, &b, a->warmup, a->reps);
    if (b.err != SQ_OK) {
        sq_cli_error("%s", sq_last_error());
        sq_sph_destroy(b.s);
        return sq_cli_exit_code(b.err);
    }
    const sq_sph_info in = sq_sph_get_info(b.s);
    const sq_sph_stats ss = sq_sph_get_stats(b.s);
    const double n = (double)ss.particles;
    const int all = b.timed;
    sq_json j;
    sq_json_begin(&j);
    sq_bench_json_common(&j, "sph", a, &st);
    sq_json_str(&j, "model", water ? "newtonian-dam-break" : "cross-avalanche");
    sq_json_int(&j, "particles", (long long)ss.particles);
    sq_json_num(&j, "particle_steps_per_s", st.median_ms > 0 ? n / (st.median_ms * 1e-3) : (double)NAN);
    sq_json_num(&j, "neighbours_per_particle", ss.neighbours_per_particle);
    sq_json_num(&j, "bytes_per_particle", n > 0 ? (double)in.bytes / n : (double)NAN);
    sq_json_num(&j, "dt_s", b.dt);
    static const char *const keys[5] = {"ms_sort", "ms_density", "ms_strain", "ms_forces",
                                        "ms_integrate"};
    for (int k = 0; k < 5; k++)
        sq_json_num(&j, keys[k], all > 0 ? b.ms[k] / all : (double)NAN);
    sq_json_int(&j, "substeps_last", ss.substeps);
    sq_json_end(&j, stdout);
    sq_sph_destroy(b.s);
    return SQ_EXIT_OK;
}

int sq_bench_sph(const sq_bench_args *a)
{
    int np = 262144;
    if (!sq_cli_int(a->argc, a->argv, "--particles", 262144, 64, 16777216, &np))
        return SQ_EXIT_USAGE;
    const char *model = sq_cli_value(a->argc, a->argv, "--model");
    if (!model) model = "both";
    const int cross = strcmp(model, "cross") == 0 || strcmp(model, "both") == 0;
    const int water = strcmp(model, "water") == 0 || strcmp(model, "both") == 0;
    if (!cross && !water) {
        sq_cli_error("--model %s: expected cross, water or both", model);
        return SQ_EXIT_USAGE;
    }
    int rc = SQ_EXIT_OK;
    if (cross) rc = run_model(a, 0, np);
    if (rc == SQ_EXIT_OK && water) rc = run_model(a, 1, np);
    return rc;
}
