/* bench_snowcover.c — `squall bench snow-cover [--preset snowy-suburb] [--time 12] [--width 640]
 * [--height 360]`: frames of a snow-cover preset (S2 chapter 2, SPEC §6) as `squall render`
 * makes them: the scene (every layer, the procedural place) built from the preset, advanced to
 * --time seconds, then each frame one scene step of 1/fps, the camera, the drawables, the GL draw
 * and the 8-bit read-back (which waits for the GL work). Timed (median of --reps after --warmup):
 *   ms_per_frame      the whole frame: step + draw + read-back;
 *   ms_occlusion_map  the adaptive occlusion map (the renderer's own timing, GL finished), mean
 *                     per frame: the map is drawn again only when the view leaves the last one
 *                     (occlusion_maps_drawn of frames_timed; ms_occlusion_map_drawn is the cost
 *                     of one drawing, occlusion_share_drawn its share of a frame; the GL work
 *                     queued before it is finished first, so it is timed alone;
 *                     cpu_ms_occlusion_map_drawn and cpu_occlusion_share_drawn: the same in
 *                     CPU time of all threads, against cpu_ms_per_frame — steadier on a machine
 *                     shared with other work);
 *   ms_scene          a frame of the same view without snow and flakes (world geometry, shadows);
 *                     cpu_ms_scene and cpu_ms_no_flakes: CPU time of all threads per such frame
 *                     (and per frame with snow but no flakes), as cpu_ms_per_frame;
 *   ms_flakes         the flakes: their step and sizing (CPU) plus the particle pass (the frame
 *                     with flakes minus the frame without them);
 * and reported: shadow_cascades_drawn (cascade maps drawn over the frames_timed frames; a cascade
 * keeps its map while the view stays in its cell, render_shadow.c), faces (LOD-0 triangles of the world's meshes), faces_drawn and camera_faces (what
 * the renderer drew over all views / for the camera, after culling and LODs; the terrain's
 * triangles in terrain_faces_drawn / camera_terrain_faces, culled by tiles), flakes,
 * flakes_visible, the snow depth, cpu_ms_per_frame (CPU time of all threads per timed full frame, warm-up excluded: on a
 * machine shared with other work the wall time says little) and the GL renderer string (llvmpipe
 * and GPU figures are not comparable). One JSON line. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "cases.h"
#include "squall/io.h"
#include "squall/render.h"
#include "squall/scene.h"

typedef struct cover_bench {
    sq_scene *scene;
    sq_renderer *r;
    uint8_t *rgba;
    double dt;
    sq_drawable all[16], no_snow[16], no_flakes[16];
    int n_all, n_no_snow, n_no_flakes;
    sq_camera cam;
    int mode; /* 0 full frame with a step, 1 without snow or flakes, 2 without flakes */
    double ms_occ_sum, cpu_occ_sum, ms_step_sum;
    int frames, occ_drawn, cascades_drawn;
    sq_result err;
} cover_bench;

static void gather(cover_bench *b)
{
    b->cam = sq_scene_camera(b->scene);
    b->n_all = sq_scene_drawables(b->scene, b->all, 16);
    b->n_no_snow = b->n_no_flakes = 0;
    for (int i = 0; i < b->n_all; i++) {
        const sq_drawable *d = &b->all[i];
        const bool flakes = d->kind == SQ_DRAWABLE_PARTICLES;
        if (!flakes && d->kind != SQ_DRAWABLE_SNOW_COVER) b->no_snow[b->n_no_snow++] = *d;
        if (!flakes) b->no_flakes[b->n_no_flakes++] = *d;
    }
}

static int frame(void *user)
{
    cover_bench *b = user;
    const sq_world *w = sq_scene_world(b->scene);
    const sq_drawable *d = b->all;
    int n = b->n_all;
    if (b->mode == 0) {
        const double t0 = sq_time_now();
        b->err = sq_scene_step(b->scene, b->dt);
        if (b->err != SQ_OK) return 1;
        gather(b);
        b->ms_step_sum += 1e3 * (sq_time_now() - t0);
        n = b->n_all;
    } else if (b->mode == 1) {
        d = b->no_snow;
        n = b->n_no_snow;
    } else {
        d = b->no_flakes;
        n = b->n_no_flakes;
    }
    b->err = sq_renderer_draw(b->r, w, &b->cam, d, n, sq_scene_time(b->scene));
    if (b->err == SQ_OK) b->err = sq_renderer_read_rgba8(b->r, b->rgba);
    if (b->err != SQ_OK) return 1;
    if (b->mode == 0) {
        sq_render_stats st;
        sq_renderer_stats(b->r, &st);
        b->ms_occ_sum += st.ms_occlusion_map;
        b->cpu_occ_sum += st.cpu_ms_occlusion_map;
        b->occ_drawn += st.ms_occlusion_map > 0.0;
        b->cascades_drawn += st.shadow_cascades_drawn;
        b->frames++;
    }
    return 0;
}

/* CPU time of the process (all threads: llvmpipe's rasteriser threads included), ms. */
static double cpu_ms(void)
{
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    return 1e3 * ((double)u.ru_utime.tv_sec + (double)u.ru_stime.tv_sec) +
           1e-3 * ((double)u.ru_utime.tv_usec + (double)u.ru_stime.tv_usec);
}

static double metric(sq_scene *s, const char *suffix)
{
    sq_metric m[64];
    const int n = sq_scene_metrics(s, m, 64);
    for (int i = 0; i < n; i++) {
        const size_t a = strlen(m[i].name), b = strlen(suffix);
        if (a >= b && strcmp(m[i].name + a - b, suffix) == 0) return m[i].value;
    }
    return (double)NAN;
}

int sq_bench_snowcover(const sq_bench_args *a)
{
    const char *preset = sq_cli_value(a->argc, a->argv, "--preset");
    if (!preset) preset = "snowy-suburb";
    int width, height;
    double at_s = 12.0;
    if (!sq_cli_int(a->argc, a->argv, "--width", 640, 16, 16384, &width) ||
        !sq_cli_int(a->argc, a->argv, "--height", 360, 16, 16384, &height))
        return SQ_EXIT_USAGE;
    const char *tv = sq_cli_value(a->argc, a->argv, "--time");
    if (tv) {
        char *end = NULL;
        at_s = strtod(tv, &end);
        if (!end || *end || !(at_s >= 0.0 && at_s < 1e6)) {
            sq_cli_error("bench snow-cover: --time %s; must be a time in [0, 1e6) s", tv);
            return SQ_EXIT_USAGE;
        }
    }
    sq_cfg *cfg = NULL;
    sq_result r = sq_cfg_load(a->ctx, preset, &cfg);
    if (r != SQ_OK) {
        sq_cli_error("bench snow-cover: %s", sq_last_error());
        return sq_cli_exit_code(r);
    }
    cover_bench b;
    memset(&b, 0, sizeof b);
    sq_scene_desc sd = {.cfg = cfg, .load_heightmap = sq_scene_heightmap_loader,
                        .load_dem = sq_dem_load, .load_area = sq_area_load,
                        .load_mesh = sq_scene_mesh_loader};
    const double t_build = sq_time_now();
    r = sq_scene_create(a->ctx, &sd, &b.scene);
    const double ms_build = 1e3 * (sq_time_now() - t_build);
    sq_cfg_destroy(cfg);
    sq_render_desc rd;
    memset(&rd, 0, sizeof rd);
    rd.width = width;
    rd.height = height;
    if (r == SQ_OK) {
        const sq_scene_output *o = sq_scene_output_settings(b.scene);
        rd.shadows_off = o->shadow_cascades == 0;
        rd.shadow_cascades = o->shadow_cascades;
        rd.shadow_map_size = o->shadow_map_size;
        rd.shadow_distance_m = o->shadow_distance_m;
        rd.lod_pixels = o->lod_pixels;
        rd.cull_pixels = o->cull_pixels;
        rd.mesh_distance_m = o->mesh_distance_m;
    }
    b.rgba = malloc((size_t)width * (size_t)height * 4);
    if (r == SQ_OK && !b.rgba) r = sq_set_error(SQ_ERR_OUT_OF_MEMORY, "bench snow-cover: frame");
    if (r == SQ_OK) r = sq_renderer_create(a->ctx, &rd, &b.r);
    sq_render_info info;
    memset(&info, 0, sizeof info);
    if (r == SQ_OK) r = sq_renderer_info(b.r, &info);
    if (r == SQ_OK && at_s > 0.0) r = sq_scene_step(b.scene, at_s);
    int code = SQ_EXIT_OK;
    if (r != SQ_OK) {
        sq_cli_error("bench snow-cover: %s", sq_last_error());
        code = sq_cli_exit_code(r);
        goto done;
    }
    b.dt = sq_scene_frame_dt(b.scene);
    gather(&b);
    b.mode = 0;
    /* the warm-up frames first (they compile the snow programs and draw the first shadow
     * cascades and occlusion map), so that the CPU time is that of the timed frames */
    for (int i = 0; i < a->warmup; i++)
        if (frame(&b) != 0) goto failed;
    const double cpu0 = cpu_ms();
    const sq_bench_stats full = sq_bench_time(frame, &b, 0, a->reps);
    const double cpu_per_frame = (cpu_ms() - cpu0) / (double)a->reps;
    if (b.err != SQ_OK) goto failed;
    const double ms_occ = b.frames > 0 ? b.ms_occ_sum / b.frames : (double)NAN;
    const double ms_occ_drawn = b.occ_drawn > 0 ? b.ms_occ_sum / b.occ_drawn : 0.0;
    const double cpu_occ_drawn = b.occ_drawn > 0 ? b.cpu_occ_sum / b.occ_drawn : 0.0;
    const double ms_step = b.frames > 0 ? b.ms_step_sum / b.frames : (double)NAN;
    sq_render_stats st;
    sq_renderer_stats(b.r, &st);
    b.mode = 1;
    double cpu1 = cpu_ms();
    const sq_bench_stats scene_only = sq_bench_time(frame, &b, 1, a->reps);
    const double cpu_scene = (cpu_ms() - cpu1) / (double)(1 + a->reps);
    if (b.err != SQ_OK) goto failed;
    b.mode = 2;
    cpu1 = cpu_ms();
    const sq_bench_stats no_flakes = sq_bench_time(frame, &b, 1, a->reps);
    const double cpu_no_flakes = (cpu_ms() - cpu1) / (double)(1 + a->reps);
    if (b.err != SQ_OK) goto failed;
    /* the flakes' CPU share: the step of a frame is almost all flakes (the depth grid is a fill) */
    int flakes = 0;
    for (int i = 0; i < b.n_all; i++)
        if (b.all[i].kind == SQ_DRAWABLE_PARTICLES) flakes += b.all[i].u.particles.count;
    const double ms_flakes = fmax(0.0, full.median_ms - ms_step - no_flakes.median_ms) + ms_step;
    sq_json j;
    sq_json_begin(&j);
    sq_bench_json_common(&j, "snow-cover", a, &full);
    sq_json_str(&j, "preset", preset);
    sq_json_str(&j, "gl_renderer", info.gl_renderer);
    sq_json_int(&j, "width", width);
    sq_json_int(&j, "height", height);
    sq_json_num(&j, "time_s", sq_scene_time(b.scene));
    const sq_world *world = sq_scene_world(b.scene);
    sq_json_int(&j, "faces", (long long)sq_world_mesh_face_count(world));
    sq_json_int(&j, "instances", sq_world_mesh_instances(world, NULL, NULL, NULL));
    sq_json_int(&j, "faces_drawn", (long long)st.faces);
    sq_json_int(&j, "camera_faces", (long long)st.camera_faces);
    sq_json_int(&j, "terrain_faces_drawn", (long long)st.terrain_faces);
    sq_json_int(&j, "camera_terrain_faces", (long long)st.camera_terrain_faces);
    sq_json_int(&j, "flakes", flakes);
    sq_json_num(&j, "flakes_visible", metric(b.scene, "flakes_visible"));
    sq_json_num(&j, "snow_depth_m", metric(b.scene, "snow_depth_m"));
    sq_json_num(&j, "ms_per_frame", full.median_ms);
    sq_json_num(&j, "cpu_ms_per_frame", cpu_per_frame);
    sq_json_num(&j, "ms_occlusion_map", ms_occ);
    sq_json_num(&j, "occlusion_share", ms_occ / full.median_ms);
    sq_json_int(&j, "occlusion_maps_drawn", b.occ_drawn);
    sq_json_int(&j, "frames_timed", b.frames);
    sq_json_num(&j, "ms_occlusion_map_drawn", ms_occ_drawn);
    sq_json_num(&j, "occlusion_share_drawn", ms_occ_drawn / full.median_ms);
    sq_json_num(&j, "cpu_ms_occlusion_map_drawn", cpu_occ_drawn);
    sq_json_num(&j, "cpu_occlusion_share_drawn", cpu_occ_drawn / cpu_per_frame);
    sq_json_num(&j, "ms_scene", scene_only.median_ms);
    sq_json_num(&j, "cpu_ms_scene", cpu_scene);
    sq_json_num(&j, "cpu_ms_no_flakes", cpu_no_flakes);
    sq_json_num(&j, "ms_flakes", ms_flakes);
    sq_json_num(&j, "ms_shadow_cpu", st.ms_shadow);
    sq_json_int(&j, "shadow_cascades_drawn", b.cascades_drawn);
    sq_json_num(&j, "ms_build_scene", ms_build);
    sq_json_end(&j, stdout);
    goto done;
failed:
    sq_cli_error("bench snow-cover: %s", sq_last_error());
    code = sq_cli_exit_code(b.err);
done:
    sq_renderer_destroy(b.r);
    sq_scene_destroy(b.scene);
    free(b.rgba);
    return code;
}
