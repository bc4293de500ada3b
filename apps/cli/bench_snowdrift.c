/* bench_snowdrift.c — `squall bench snowdrift [--preset village-snowdrift] [--spinup 48]`: the
 * wind-driven snow phenomenon of a preset (SPEC §5; by default the village-snowdrift preset's
 * world and snowdrift layer exactly as `squall simulate` builds them) stepped frame by frame,
 * a frame being 1/fps of simulated time (1/24 s for the preset) followed by what the CLI asks of
 * the layer every frame: the camera (flake sizes; the preset's first camera), the drawables
 * (snow cover heightfield, flakes) and the metrics (snow budget). After --spinup frames (default 48 = 2 s of snowfall and drifting) and --warmup
 * frames, --reps frames are timed (median, min, max). One JSON line: the common keys
 * (ms_per_step = ms per frame, steps_per_s = frames per simulated second of wall time) plus
 * frames_per_s, lbm_steps_per_frame, snow_steps_per_frame, the MLUPS of the wind part, and the
 * mean ms per frame of each stage over the timed frames (ms_lbm: collide + stream, boundaries,
 * drive; ms_ustar: velocity views + friction velocity; ms_transport: snowfall + transport;
 * ms_deposit: deposition, roll-off, solidification; ms_erode; ms_couple: snow cells passed to
 * the wind lattice; ms_flakes: visual flakes moved and sized; ms_derived: snow cover; ms_budget:
 * metrics), read
 * from sq_snowdrift_get_stats outside the timed calls; cpu_ms_per_frame is this process's CPU
 * time (user + system), which unlike the wall time leaves out waits for descheduled partners.
 * Under mpirun (the wind lattice and the snow split in z slabs, docs/mpi.md) every rank steps
 * its slab and rank 0 prints the line with ranks, the slowest rank's ms per frame, the bytes
 * all ranks sent and the meetings per frame, and per_rank. */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/resource.h>

#include "cases.h"
#include "squall/io.h"
#include "squall/par.h"
#include "squall/plugin.h"
#include "squall/scene.h"
#include "squall/snowdrift.h"

enum {
    SD_LBM,
    SD_USTAR,
    SD_TRANSPORT,
    SD_DEPOSIT,
    SD_ERODE,
    SD_COUPLE,
    SD_FLAKES,
    SD_DERIVED,
    SD_BUDGET,
    SD_COUNT
};

typedef struct snow_bench {
    const sq_phen_plugin *pl;
    sq_snowdrift *s;
    sq_camera camera;
    double frame_dt;
    sq_result err;
} snow_bench;

static double cpu_ms(void)
{
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    return 1e3 * ((double)u.ru_utime.tv_sec + (double)u.ru_stime.tv_sec) +
           1e-3 * ((double)u.ru_utime.tv_usec + (double)u.ru_stime.tv_usec);
}

static void stage_ms(const sq_snowdrift_stats *st, double out[SD_COUNT])
{
    out[SD_LBM] = st->ms_lbm;
    out[SD_USTAR] = st->ms_ustar;
    out[SD_TRANSPORT] = st->ms_transport;
    out[SD_DEPOSIT] = st->ms_deposit;
    out[SD_ERODE] = st->ms_erode;
    out[SD_COUPLE] = st->ms_couple;
    out[SD_FLAKES] = st->ms_flakes;
    out[SD_DERIVED] = st->ms_derived;
    out[SD_BUDGET] = st->ms_budget;
}

/* one frame as the CLI runs it: step, drawables, metrics (through the plug-in's vtable, as
 * the scene calls them) */
static sq_result frame(snow_bench *b)
{
    sq_result r = b->pl->step(b->s, b->frame_dt);
    if (r != SQ_OK) return r;
    if (b->pl->observe) b->pl->observe(b->s, &b->camera);
    sq_drawable dr[4];
    (void)b->pl->drawables(b->s, dr, 4);
    sq_metric m[32];
    (void)b->pl->metrics(b->s, m, 32);
    return SQ_OK;
}

static int step(void *user)
{
    snow_bench *b = (snow_bench *)user;
    b->err = frame(b);
    return b->err != SQ_OK;
}

/* Applies a layer's map (nested maps become dotted keys) through the plug-in's table. */
static sq_result apply_layer(const sq_phen_plugin *pl, const sq_cfg_node *map, const char *prefix,
                             void *desc)
{
    for (const sq_cfg_node *c = map->child; c; c = c->next) {
        if (!prefix[0] && (strcmp(c->key, "type") == 0 || strcmp(c->key, "name") == 0 ||
                           strcmp(c->key, "enabled") == 0))
            continue;
        char key[256];
        snprintf(key, sizeof key, "%s%s%s", prefix, prefix[0] ? "." : "", c->key);
        sq_result r = SQ_OK;
        if (c->kind == SQ_CFG_MAP)
            r = apply_layer(pl, c, key, desc);
        else if (c->kind == SQ_CFG_SCALAR)
            r = sq_params_set(pl->params, pl->param_count, desc, "layers", key, c->value,
                              "bench");
        else
            r = sq_set_error(SQ_ERR_INVALID_ARG, "bench snowdrift: %s: lists not supported", key);
        if (r != SQ_OK) return r;
    }
    return SQ_OK;
}

int sq_bench_snowdrift(const sq_bench_args *a)
{
    const char *preset = sq_cli_value(a->argc, a->argv, "--preset");
    if (!preset) preset = "village-snowdrift";
    int spinup;
    if (!sq_cli_int(a->argc, a->argv, "--spinup", 48, 0, 100000, &spinup)) return SQ_EXIT_USAGE;
    const sq_phen_plugin *pl = sq_plugin_find("snowdrift");
    if (!pl) {
        sq_cli_error("bench snowdrift: the snowdrift phenomenon is not in this build");
        return SQ_EXIT_RUNTIME;
    }
    sq_cfg *cfg = NULL;
    sq_result r = sq_cfg_load(a->ctx, preset, &cfg);
    if (r != SQ_OK) {
        sq_cli_error("bench snowdrift: %s", sq_last_error());
        return sq_cli_exit_code(r);
    }
    /* the scene's world and output settings (no layers created) */
    sq_scene_desc sd = {.cfg = cfg, .load_heightmap = sq_scene_heightmap_loader,
                        .validate_only = true, .load_dem = sq_dem_load, .load_area = sq_area_load,
                        .load_mesh = sq_scene_mesh_loader};
    sq_scene *scene = NULL;
    r = sq_scene_create(a->ctx, &sd, &scene);
    if (r != SQ_OK) {
        sq_cli_error("bench snowdrift: %s", sq_last_error());
        sq_cfg_destroy(cfg);
        return sq_cli_exit_code(r);
    }
    /* the first snowdrift layer's desc, built like the scene builds it */
    sq_snowdrift_desc d;
    memset(&d, 0, sizeof d);
    sq_params_defaults(pl->params, pl->param_count, &d);
    const sq_cfg_node *layers = sq_cfg_get(cfg->root, "layers");
    bool found = false;
    for (const sq_cfg_node *l = layers ? layers->child : NULL; l && !found && r == SQ_OK;
         l = l->next) {
        const sq_cfg_node *type = l->kind == SQ_CFG_MAP ? sq_cfg_get(l, "type") : NULL;
        if (!type || !type->value || strcmp(type->value, "snowdrift") != 0) continue;
        found = true;
        r = apply_layer(pl, l, "", &d);
    }
    sq_cfg_destroy(cfg);
    if (r == SQ_OK && !found)
        r = sq_set_error(SQ_ERR_INVALID_ARG, "bench snowdrift: scene '%s' has no snowdrift layer",
                         preset);
    if (r == SQ_OK) r = sq_snowdrift_desc_resolve(&d, &d);
    snow_bench b;
    memset(&b, 0, sizeof b);
    b.pl = pl;
    b.frame_dt = sq_scene_frame_dt(scene);
    b.camera = sq_scene_camera(scene); /* the preset's first camera (flake sizes) */
    if (r == SQ_OK) r = sq_snowdrift_create(a->ctx, &d, sq_scene_world(scene), &b.s);
    if (r != SQ_OK) {
        sq_cli_error("bench snowdrift: %s", sq_last_error());
        sq_scene_destroy(scene);
        return sq_cli_exit_code(r);
    }
    for (int q = 0; q < spinup + a->warmup && r == SQ_OK; q++) r = frame(&b);
    int code = SQ_EXIT_OK;
    if (r != SQ_OK) {
        sq_cli_error("bench snowdrift: spin-up: %s", sq_last_error());
        code = sq_cli_exit_code(r);
    } else {
        sq_snowdrift_stats s0, s1;
        sq_snowdrift_get_stats(b.s, &s0);
        const uint64_t meet0 = sq_par_meetings(), sent0 = sq_par_bytes_sent();
        const double cpu0 = cpu_ms();
        const double t0 = sq_time_now();
        const sq_bench_stats st = sq_bench_time(step, &b, 0, a->reps);
        const double wall_ms = 1e3 * (sq_time_now() - t0);
        const double cpu1 = cpu_ms();
        const uint64_t meet1 = sq_par_meetings(), sent1 = sq_par_bytes_sent();
        sq_snowdrift_get_stats(b.s, &s1);
        const double nfr = (double)(s1.steps - s0.steps);
        /* under mpirun: every rank's figures to rank 0 (collective, before any rank prints) */
        const int nr = sq_par_size(), me = sq_par_rank();
        char ranks_json[4096] = "";
        double slowest = st.median_ms, comm = 0.0;
        if (nr > 1 && b.err == SQ_OK) {
            const double plane = (double)d.cells[0] * d.cells[1];
            const double mine[3] = {plane * (double)((int64_t)(me + 1) * d.cells[2] / nr -
                                                     (int64_t)me * d.cells[2] / nr),
                                    st.median_ms, nfr > 0 ? (double)(sent1 - sent0) / nfr : 0.0};
            const sq_bench_rank_keys keys = {"ms_per_frame", "mcells_per_s",
                                             "bytes_sent_per_frame"};
            (void)sq_bench_per_rank(mine, &keys, ranks_json, sizeof ranks_json, &slowest, &comm);
        }
        if (b.err != SQ_OK) {
            sq_cli_error("bench snowdrift: %s", sq_last_error());
            code = sq_cli_exit_code(b.err);
        } else if (me == 0) {
            const double frames = (double)(s1.steps - s0.steps);
            const double lbm_steps = (double)(s1.lbm_steps - s0.lbm_steps);
            double m0[SD_COUNT], m1[SD_COUNT];
            stage_ms(&s0, m0);
            stage_ms(&s1, m1);
            static const char *const keys[SD_COUNT] = {
                "ms_lbm",   "ms_ustar",  "ms_transport", "ms_deposit", "ms_erode",
                "ms_couple", "ms_flakes", "ms_derived",   "ms_budget"};
            char grid[64];
            snprintf(grid, sizeof grid, "%dx%dx%d", d.cells[0], d.cells[1], d.cells[2]);
            sq_snowdrift_budget bu;
            sq_snowdrift_get_budget(b.s, &bu);
            sq_json j;
            sq_json_begin(&j);
            sq_bench_json_common(&j, "snowdrift", a, &st);
            sq_json_str(&j, "preset", preset);
            sq_json_str(&j, "grid", grid);
            sq_json_num(&j, "frame_dt_s", b.frame_dt);
            sq_json_num(&j, "ms_per_frame", st.median_ms);
            sq_json_num(&j, "frames_per_s", st.median_ms > 0 ? 1e3 / st.median_ms : (double)NAN);
            sq_json_int(&j, "spinup_frames", spinup);
            sq_json_num(&j, "lbm_steps_per_frame", frames > 0 ? lbm_steps / frames : (double)NAN);
            sq_json_num(&j, "snow_steps_per_frame",
                        frames > 0 ? (double)(s1.snow_steps - s0.snow_steps) / frames
                                   : (double)NAN);
            const double ms_lbm = m1[SD_LBM] - m0[SD_LBM];
            sq_json_num(&j, "wind_mlups",
                        ms_lbm > 0 ? lbm_steps * (double)s1.cells / (ms_lbm * 1e3) : (double)NAN);
            double sum = 0;
            for (int q = 0; q < SD_COUNT; q++) {
                const double v = frames > 0 ? (m1[q] - m0[q]) / frames : (double)NAN;
                sum += v;
                sq_json_num(&j, keys[q], v);
            }
            const double mean = frames > 0 ? wall_ms / frames : (double)NAN;
            sq_json_num(&j, "ms_per_frame_mean", mean);
            sq_json_num(&j, "ms_other", mean - sum);
            sq_json_num(&j, "snow_cells", (double)bu.snow_cells);
            sq_json_num(&j, "airborne_flakes", (double)bu.airborne_flakes);
            sq_json_bool(&j, "budget_exact", bu.fallen_flakes == bu.airborne_flakes +
                                                                    bu.deposited_flakes +
                                                                    bu.left_flakes);
            sq_json_num(&j, "cpu_ms_per_frame", frames > 0 ? (cpu1 - cpu0) / frames : (double)NAN);
            sq_json_int(&j, "ranks", nr);
            if (nr > 1) {
                sq_json_str(&j, "decomposition", "slabs along z (wind and snow)");
                sq_json_num(&j, "ms_per_frame_slowest", slowest);
                sq_json_num(&j, "comm_bytes_per_frame", comm);
                sq_json_num(&j, "meetings_per_frame",
                            frames > 0 ? (double)(meet1 - meet0) / frames : 0.0);
                sq_json_raw(&j, "per_rank", ranks_json);
            }
            sq_json_end(&j, stdout);
        }
    }
    sq_snowdrift_destroy(b.s);
    sq_scene_destroy(scene);
    return code;
}
