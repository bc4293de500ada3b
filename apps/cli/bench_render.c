/* bench_render.c — `squall bench render-volume`: milliseconds per frame of the GL renderer
 * (draw + 8-bit read-back, which waits for the frame) for
 *   1. a dust volume of --size^3 cells (default 128) with --slices half-angle slices (128),
 *   2. --particles soft particles (default 10^5),
 *   3. the same scene with neither (the base renderer's share),
 * at --width x --height (1280 x 720), with --light light-buffer texels per side (256). One
 * JSON line per configuration; --only volume|particles|base measures one of them. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "cases.h"
#include "squall/noise.h"
#include "squall/render.h"
#include "squall/world.h"

typedef struct frame_job {
    sq_renderer *r;
    const sq_world *w;
    sq_camera cam;
    const sq_drawable *d;
    int n;
    double t;
    uint8_t *rgba;
} frame_job;

static int draw_frame(void *user)
{
    frame_job *f = user;
    f->t += 1.0 / 30.0;
    if (sq_renderer_draw(f->r, f->w, &f->cam, f->d, f->n, f->t) != SQ_OK) return 1;
    return sq_renderer_read_rgba8(f->r, f->rgba) != SQ_OK;
}

/* A dust cloud: fBm noise thresholded, thinning with height, in [0, 1]. */
static void fill_dust(float *dens, int n)
{
    sq_noise nz;
    sq_noise_init(&nz, 2012);
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                const float x = (float)i / (float)n, y = (float)j / (float)n, z = (float)k / (float)n;
                const float f = sq_noise_fbm3(&nz, 4.0f * x, 4.0f * y, 4.0f * z, 3, 2.0f, 0.5f);
                const float v = (0.5f + 0.8f * f) * expf(-2.5f * z);
                dens[((size_t)k * (size_t)n + (size_t)j) * (size_t)n + (size_t)i] = v > 0.0f ? v : 0.0f;
            }
}

static void fill_particles(float *pos, float *rad, float *rot, int count, sq_vec3 c)
{
    uint32_t h = 20120229u;
    for (int i = 0; i < count; i++) {
        float u[5];
        for (int k = 0; k < 5; k++) {
            h = h * 1664525u + 1013904223u;
            u[k] = (float)(h >> 8) / 16777216.0f;
        }
        pos[3 * i + 0] = c.x + 300.0f * (u[0] - 0.5f);
        pos[3 * i + 1] = c.y + 300.0f * (u[1] - 0.5f);
        pos[3 * i + 2] = 2.0f + 60.0f * u[2] * u[2];
        rad[i] = 0.5f + 1.5f * u[3];
        rot[i] = 6.2831853f * u[4];
    }
}

int sq_bench_render_volume(const sq_bench_args *a)
{
    int width, height, size, slices, particles, light;
    if (!sq_cli_int(a->argc, a->argv, "--width", 1280, 16, 16384, &width) ||
        !sq_cli_int(a->argc, a->argv, "--height", 720, 16, 16384, &height) ||
        !sq_cli_int(a->argc, a->argv, "--size", 128, 4, 1024, &size) ||
        !sq_cli_int(a->argc, a->argv, "--slices", 128, 1, 4096, &slices) ||
        !sq_cli_int(a->argc, a->argv, "--particles", 100000, 1, 10000000, &particles) ||
        !sq_cli_int(a->argc, a->argv, "--light", 256, 8, 4096, &light))
        return SQ_EXIT_USAGE;
    const char *only = sq_cli_value(a->argc, a->argv, "--only");
    if (only && strcmp(only, "volume") != 0 && strcmp(only, "particles") != 0 &&
        strcmp(only, "base") != 0) {
        sq_cli_error("bench render-volume: --only %s; must be volume, particles or base", only);
        return SQ_EXIT_USAGE;
    }
    sq_context *ctx = a->ctx;
    int rc = SQ_EXIT_OK;
    sq_world *w = NULL;
    sq_renderer *r = NULL;
    const size_t ncell = (size_t)size * (size_t)size * (size_t)size;
    float *dens = malloc(sizeof(float) * ncell);
    float *pos = malloc(sizeof(float) * 3 * (size_t)particles);
    float *rad = malloc(sizeof(float) * (size_t)particles);
    float *rot = malloc(sizeof(float) * (size_t)particles);
    uint8_t *rgba = malloc((size_t)width * (size_t)height * 4);
    if (!dens || !pos || !rad || !rot || !rgba) {
        sq_cli_error("bench render-volume: out of memory (%d^3 cells, %d particles)", size,
                     particles);
        rc = SQ_EXIT_RUNTIME;
        goto done;
    }
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_DUNES;
    sq_result res = sq_world_create(ctx, &wd, &w);
    sq_render_desc rd = {0};
    rd.width = width;
    rd.height = height;
    rd.volume_slices = slices;
    rd.light_buffer_size = light;
    rd.volume_noise = true;
    rd.seed = 1;
    if (res == SQ_OK) res = sq_renderer_create(ctx, &rd, &r);
    sq_render_info info;
    if (res == SQ_OK) res = sq_renderer_info(r, &info);
    if (res != SQ_OK) {
        sq_cli_error("bench render-volume: %s", sq_last_error());
        rc = sq_cli_exit_code(res);
        goto done;
    }
    fill_dust(dens, size);
    const sq_vec3 centre = sq_v3(0.0f, 0.0f, 0.0f);
    fill_particles(pos, rad, rot, particles, centre);

    sq_drawable vol;
    memset(&vol, 0, sizeof vol);
    vol.kind = SQ_DRAWABLE_VOLUME;
    vol.name = "dust";
    sq_volume_view *v = &vol.u.volume;
    v->density = dens;
    v->nx = v->ny = v->nz = size;
    sq_world_terrain terrain;
    sq_world_get_terrain(w, &terrain);
    v->origin_m = sq_v3(-400.0f, -400.0f, terrain.height_min - 5.0f);
    v->size_m = sq_v3(800.0f, 800.0f, 250.0f);
    const float sigma = 0.02f, albedo[3] = {0.85f, 0.72f, 0.55f};
    for (int c = 0; c < 3; c++) {
        v->sigma_ext[c] = sigma;
        v->albedo[c] = albedo[c];
        v->g[c] = 0.7f;
    }
    v->g2 = -0.3f;
    v->w2 = 0.1f;
    v->density_max = 1.0f;
    v->version = 1;

    sq_drawable part;
    memset(&part, 0, sizeof part);
    part.kind = SQ_DRAWABLE_PARTICLES;
    part.name = "dust-particles";
    sq_particles_view *p = &part.u.particles;
    p->count = particles;
    p->position = pos;
    p->radius_m = rad;
    p->rotation_rad = rot;
    p->tau_default = 0.4f;
    for (int c = 0; c < 3; c++) p->albedo[c] = albedo[c];
    p->g = 0.7f;
    p->sprite = SQ_SPRITE_PUFF;
    p->softness_m = 1.0f;
    p->version = 1;

    frame_job job;
    memset(&job, 0, sizeof job);
    job.r = r;
    job.w = w;
    job.rgba = rgba;
    job.cam.position_m = sq_v3(-380.0f, -300.0f, sq_world_height_at(w, -380.0f, -300.0f) + 40.0f);
    job.cam.target_m = sq_v3(0.0f, 0.0f, sq_world_height_at(w, 0.0f, 0.0f) + 20.0f);
    job.cam.fov_y_deg = 55.0f;

    const struct {
        const sq_drawable *d;
        int vol, parts;
        const char *name;
    } configs[3] = {{&vol, size, 0, "volume"}, {&part, 0, particles, "particles"},
                    {NULL, 0, 0, "base"}};
    for (int k = 0; k < 3; k++) {
        if (only && strcmp(only, configs[k].name) != 0) continue;
        job.d = configs[k].d;
        job.n = configs[k].d ? 1 : 0;
        const sq_bench_stats s = sq_bench_time(draw_frame, &job, a->warmup, a->reps);
        if (s.reps < a->reps) {
            sq_cli_error("bench render-volume: frame failed: %s", sq_last_error());
            rc = SQ_EXIT_RUNTIME;
            goto done;
        }
        sq_json j;
        sq_json_begin(&j);
        sq_bench_json_common(&j, "render-volume", a, &s);
        sq_json_num(&j, "ms_per_frame", s.median_ms);
        sq_json_int(&j, "width", width);
        sq_json_int(&j, "height", height);
        sq_json_int(&j, "slices", configs[k].vol ? slices : 0);
        sq_json_int(&j, "light_buffer", configs[k].vol ? light : 0);
        sq_json_int(&j, "volume", configs[k].vol);
        sq_json_int(&j, "particles", configs[k].parts);
        sq_json_str(&j, "gl_renderer", info.gl_renderer);
        sq_json_end(&j, stdout);
    }
done:
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    free(dens);
    free(pos);
    free(rad);
    free(rot);
    free(rgba);
    return rc;
}
