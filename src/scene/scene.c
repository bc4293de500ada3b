/* scene.c — builds a scene from a configuration tree through the parameter tables (world,
 * camera, output and each layer's plug-in), creates the world and the phenomena, and steps
 * everything on one clock, sub-cycling each layer to its stable time step. */
#include <ctype.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "core/core_internal.h"
#include "phen/phenomenon_internal.h"
#include "scene_internal.h"
#include "squall/rng.h"
#include "world/world_struct.h"

#define MAX_LAYERS 16
#define MAX_METRICS 256

typedef struct layer {
    const sq_phen_plugin *plugin;
    char name[64];
    sq_phenomenon *ph; /* the generic handle; its phenomenon is created after every check */
} layer;

struct sq_scene {
    sq_context *ctx;
    char name[SQ_PARAM_STRING_MAX + 16];
    uint64_t seed;
    sq_world *world;
    sq_camera camera;
    sq_camera_key keys[SQ_MAX_CAMERA_KEYS];
    int key_count;
    sq_scene_output out;
    layer layers[MAX_LAYERS];
    int layer_count;
    double time_s;
    uint64_t step_count;
    uint64_t memory_bytes;
    char metric_names[MAX_METRICS][96];
    char camera_where[320];                      /* file:line of camera.position */
    char key_where[SQ_MAX_CAMERA_KEYS][320];     /* file:line of each camera.path key */
    /* meshes placed in the world (the world borrows them; destroyed after it) */
    sq_place *place;
    sq_mesh **file_meshes;
    int file_mesh_count;
    /* the world section it was built from, for live changes (sq_scene_apply_live) */
    sq_cfg_node *world_cfg;
};

/* Logs the error already set (by the parameter tables) and returns r. */
static sq_result relog(sq_context *ctx, sq_result r)
{
    sq_log(ctx, SQ_LOG_ERROR, "scene", "%s", sq_last_error());
    return r;
}

/* ---- messages for scene users ------------------------------------------------------------- */
/* A phenomenon's solver names its own C fields ("raise speed_of_sound_mps", "lower dt_s"); a
 * scene user sets keys. Each identifier with an underscore that is not already a key of the
 * layer but is the trailing part of exactly one of its keys ("dt_max_s" ->
 * "numerics.dt_max_s") becomes the full key "layers.NAME.KEY", and the message is prefixed with
 * "layers.NAME: " unless it names the layer already; the desc's own name ("sq_avalanche_desc.")
 * becomes "layers.NAME.". Returns r, with the new text set. */
static const char *unique_key_ending(const sq_param *t, size_t n, const char *word, size_t len)
{
    const char *found = NULL;
    for (size_t i = 0; i < n; i++) {
        const size_t kl = strlen(t[i].key);
        if (kl == len && strncmp(t[i].key, word, len) == 0) return NULL; /* a key already */
        if (kl > len && t[i].key[kl - len - 1] == '.' && strncmp(t[i].key + kl - len, word, len) == 0) {
            if (found) return NULL; /* ambiguous */
            found = t[i].key;
        }
    }
    return found;
}

sq_result sq__scene_translate_error(const sq_param *table, size_t n, const char *layer_name,
                                    sq_result r)
{
    char in[1024], out[1536];
    snprintf(in, sizeof in, "%s", sq_last_error());
    char prefix[96];
    snprintf(prefix, sizeof prefix, "layers.%s", layer_name);
    size_t o = 0;
    if (!strstr(in, "layers.") && !strstr(in, "_desc."))
        o = (size_t)snprintf(out, sizeof out, "%s: ", prefix);
    for (const char *p = in; *p && o + 1 < sizeof out;) {
        const bool start = p == in || !(isalnum((unsigned char)p[-1]) || p[-1] == '_' ||
                                        p[-1] == '.');
        if (start && (isalpha((unsigned char)*p) || *p == '_')) {
            const char *e = p;
            while (isalnum((unsigned char)*e) || *e == '_') e++;
            const size_t len = (size_t)(e - p);
            if (*e == '.' && len > 8 && strncmp(p, "sq_", 3) == 0 &&
                strncmp(e - 5, "_desc", 5) == 0) { /* the C desc's name: the layer's keys */
                o += (size_t)snprintf(out + o, sizeof out - o, "%s.", prefix);
                p = e + 1;
                continue;
            }
            const char *key = *e != '.' && memchr(p, '_', len) ? unique_key_ending(table, n, p, len)
                                                                : NULL;
            if (key)
                o += (size_t)snprintf(out + o, sizeof out - o, "%s.%s", prefix, key);
            else
                o += (size_t)snprintf(out + o, sizeof out - o, "%.*s", (int)len, p);
            p = e;
            continue;
        }
        out[o++] = *p++;
        out[o] = 0;
    }
    if (o >= sizeof out) o = sizeof out - 1;
    out[o] = 0;
    return sq__set_error(r, "%s", out);
}

/* ---- applying a cfg subtree through a table ------------------------------------------------ */
typedef struct apply_ctx {
    const sq_cfg *cfg;
    const char *section; /* e.g. "world", "layers[0] (sandstorm)" */
} apply_ctx;

static void where_of(const apply_ctx *a, const sq_cfg_node *n, char *buf, size_t size)
{
    if (n && n->line > 0)
        snprintf(buf, size, "%s:%d:%d", a->cfg->source, n->line, n->col);
    else
        snprintf(buf, size, "%s (--set)", a->cfg->source);
}

/* Joins the scalar children of a sequence into "[a, b, c]"; fails for nested content. */
static sq_result seq_text(const apply_ctx *a, const sq_cfg_node *seq, const char *key, char *buf,
                          size_t size)
{
    size_t len = 0;
    len += (size_t)snprintf(buf, size, "[");
    for (const sq_cfg_node *c = seq->child; c; c = c->next) {
        if (c->kind != SQ_CFG_SCALAR) {
            char w[320];
            where_of(a, c, w, sizeof w);
            return sq__set_error(SQ_ERR_INVALID_ARG, "%s: %s.%s: expected a list of numbers",
                                 w, a->section, key);
        }
        if (len < size)
            len += (size_t)snprintf(buf + len, size - len, "%s%s", c == seq->child ? "" : ", ",
                                    c->value ? c->value : "");
    }
    if (len < size) snprintf(buf + len, size - len, "]");
    return SQ_OK;
}

/* Applies every entry of map under prefix; skip: keys handled by the caller (NULL-terminated). */
static sq_result apply_map(const apply_ctx *a, const sq_cfg_node *map, const char *prefix,
                           const sq_param *table, size_t n, void *desc, const char *const *skip)
{
    for (const sq_cfg_node *c = map->child; c; c = c->next) {
        if (!prefix[0] && skip) {
            bool s = false;
            for (const char *const *k = skip; *k; k++) s = s || strcmp(*k, c->key) == 0;
            if (s) continue;
        }
        char key[256];
        snprintf(key, sizeof key, "%s%s%s", prefix, prefix[0] ? "." : "", c->key);
        char w[320];
        where_of(a, c, w, sizeof w);
        sq_result r;
        if (c->kind == SQ_CFG_MAP) {
            /* a nested section, unless the table has this exact key (then it is a type error) */
            if (sq_params_find(table, n, key))
                return sq__set_error(SQ_ERR_INVALID_ARG, "%s: %s.%s: expected a value, found a map",
                                     w, a->section, key);
            r = apply_map(a, c, key, table, n, desc, NULL);
        } else if (c->kind == SQ_CFG_SEQ) {
            char text[1024];
            r = seq_text(a, c, key, text, sizeof text);
            if (r == SQ_OK) r = sq_params_set(table, n, desc, a->section, key, text, w);
        } else {
            /* a key that is a prefix of table keys used with a scalar: wrong type */
            if (!sq_params_find(table, n, key)) {
                size_t kl = strlen(key);
                for (size_t i = 0; i < n; i++)
                    if (strncmp(table[i].key, key, kl) == 0 && table[i].key[kl] == '.')
                        return sq__set_error(SQ_ERR_INVALID_ARG,
                                             "%s: %s.%s: expected a section with keys such as "
                                             "'%s', found a value",
                                             w, a->section, key, table[i].key + kl + 1);
            }
            r = sq_params_set(table, n, desc, a->section, key, c->value, w);
        }
        if (r != SQ_OK) return r;
    }
    return SQ_OK;
}

static sq_result expect_kind(const apply_ctx *a, const sq_cfg_node *n, sq_cfg_kind k,
                             const char *what)
{
    if (n->kind == k) return SQ_OK;
    char w[320];
    where_of(a, n, w, sizeof w);
    const char *names[] = {"a value", "a map", "a list"};
    return sq__set_error(SQ_ERR_INVALID_ARG, "%s: %s: expected %s, found %s", w, what, names[k],
                         names[n->kind]);
}

/* ---- sections ------------------------------------------------------------------------------ */
/* terrain.kind = wrf through the io layer's loader (terrain grid, georeference, the file's sun
 * clock), and sun.date: a sun that follows the scene clock. On failure *owned is NULL. */
static sq_result world_from_wrf_and_date(sq_context *ctx, const sq_scene_desc *sd,
                                         const sq__world_section *ws, bool wrf_terrain,
                                         sq_world_desc *wd, void **owned)
{
    const sq_cfg *cfg = sd->cfg;
    *owned = NULL;
    if (wrf_terrain) {
        if (!ws->wrf[0] || !sd->load_wrf_world)
            return sq__fail(ctx, !ws->wrf[0] ? SQ_ERR_INVALID_ARG : SQ_ERR_UNSUPPORTED, "scene",
                            "%s: world.terrain.kind = wrf %s", cfg->source,
                            !ws->wrf[0] ? "needs world.terrain.wrf (a WRF output file)"
                                        : "needs a WRF loader (this program does not supply one)");
        char path[1024];
        if (ws->wrf[0] == '/' || !cfg->base_dir[0])
            snprintf(path, sizeof path, "%s", ws->wrf);
        else
            snprintf(path, sizeof path, "%s/%s", cfg->base_dir, ws->wrf);
        const sq_vec3 dir = wd->sun.direction;
        sq_result r = sd->load_wrf_world(ctx, path, wd, owned);
        if (r != SQ_OK) return r;
        /* an explicit direction or date overrides the file's sun */
        wd->sun.direction = dir;
        if (sq_v3_len(dir) > 0.0f || ws->sun_date[0]) wd->sun.utc_set = false;
        wd->sun.clock_scale = ws->clock_scale;
    }
    if (ws->sun_date[0]) {
        int y = 0, mo = 0, d = 0, h = 0, mi = 0, sec = 0;
        char sep = ' ';
        const int got = sscanf(ws->sun_date, "%4d-%2d-%2d%c%2d:%2d:%2d", &y, &mo, &d, &sep, &h,
                               &mi, &sec);
        if (!(got == 3 || got == 7) || (got == 7 && sep != ' ' && sep != 'T' && sep != '_') ||
            mo < 1 || mo > 12 || d < 1 || d > 31 || h > 23 || mi > 59 || sec > 60 || h < 0 ||
            mi < 0 || sec < 0) {
            sq_free(ctx, *owned);
            *owned = NULL;
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "scene",
                            "%s: world.sun.date = '%s'; expected 'YYYY-MM-DD hh:mm:ss' (UTC)",
                            cfg->source, ws->sun_date);
        }
        wd->sun.utc_set = true;
        wd->sun.utc_start_unix_s = sq_unix_time(y, mo, d, h, mi, (double)sec);
        wd->sun.latitude_deg = ws->latitude_deg;
        wd->sun.longitude_deg = ws->longitude_deg;
        wd->sun.clock_scale = ws->clock_scale;
    }
    return SQ_OK;
}

static sq_result build_world(sq_context *ctx, const sq_scene_desc *sd, const sq_cfg_node *node,
                             sq__world_section *ws_out, sq_world **out)
{
    const sq_cfg *cfg = sd->cfg;
    sq__world_section ws;
    sq_params_defaults(sq__world_params, sq__world_param_count, &ws);
    apply_ctx a = {cfg, "world"};
    static const char *const skip[] = {"obstacles", "areas", "meshes", NULL};
    sq_obstacle *obs = (sq_obstacle *)calloc(SQ_MAX_OBSTACLES, sizeof *obs);
    sq__area_item *areas = (sq__area_item *)calloc(SQ_MAX_WORLD_AREAS, sizeof *areas);
    sq__scene_geo *geo = (sq__scene_geo *)calloc(1, sizeof *geo);
    if (!obs || !areas || !geo) {
        free(obs);
        free(areas);
        free(geo);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "scene", "out of memory");
    }
    int nobs = 0, nareas = 0;
    sq_result r = SQ_OK;
    if (node) {
        r = expect_kind(&a, node, SQ_CFG_MAP, "world");
        if (r == SQ_OK) r = apply_map(&a, node, "", sq__world_params, sq__world_param_count, &ws, skip);
        const sq_cfg_node *ol = sq_cfg_get(node, "obstacles");
        if (r == SQ_OK && ol) {
            r = expect_kind(&a, ol, SQ_CFG_SEQ, "world.obstacles");
            int i = 0;
            for (const sq_cfg_node *o = ol->child; r == SQ_OK && o; o = o->next, i++) {
                char sec[64];
                snprintf(sec, sizeof sec, "world.obstacles[%d]", i);
                apply_ctx oa = {cfg, sec};
                r = expect_kind(&oa, o, SQ_CFG_MAP, sec);
                if (r != SQ_OK) break;
                if (nobs >= SQ_MAX_OBSTACLES) {
                    r = sq__set_error(SQ_ERR_INVALID_ARG, "%s: world.obstacles: more than %d",
                                      cfg->source, SQ_MAX_OBSTACLES);
                    break;
                }
                sq__obstacle_item it;
                sq_params_defaults(sq__obstacle_params, sq__obstacle_param_count, &it);
                r = apply_map(&oa, o, "", sq__obstacle_params, sq__obstacle_param_count, &it, NULL);
                if (r != SQ_OK) break;
                if (it.center_count < 2) {
                    r = sq__set_error(SQ_ERR_INVALID_ARG, "%s: %s.center: expected [x, y] or [x, y, z]",
                                      cfg->source, sec);
                    break;
                }
                sq_obstacle *ob = &obs[nobs++];
                ob->kind = (sq_obstacle_kind)it.kind;
                ob->center_m = sq_v3(it.center[0], it.center[1],
                                     it.center_count == 3 ? it.center[2] : NAN);
                ob->size_m = sq_v3(it.size[0], it.size[1], it.size[2]);
                ob->roof_m = it.roof_m;
                ob->yaw_deg = it.yaw_deg;
                ob->albedo = sq_v3(it.albedo[0], it.albedo[1], it.albedo[2]);
            }
        }
        const sq_cfg_node *al = sq_cfg_get(node, "areas");
        if (r == SQ_OK && al) {
            r = expect_kind(&a, al, SQ_CFG_SEQ, "world.areas");
            for (const sq_cfg_node *o = r == SQ_OK ? al->child : NULL; r == SQ_OK && o; o = o->next) {
                char sec[64];
                snprintf(sec, sizeof sec, "world.areas[%d]", nareas);
                apply_ctx oa = {cfg, sec};
                if (nareas >= SQ_MAX_WORLD_AREAS) {
                    r = sq__set_error(SQ_ERR_INVALID_ARG, "%s: world.areas: more than %d",
                                      cfg->source, SQ_MAX_WORLD_AREAS);
                    break;
                }
                r = expect_kind(&oa, o, SQ_CFG_MAP, sec);
                if (r != SQ_OK) break;
                sq_params_defaults(sq__area_params, sq__area_param_count, &areas[nareas]);
                r = apply_map(&oa, o, "", sq__area_params, sq__area_param_count, &areas[nareas],
                              NULL);
                nareas++;
            }
        }
    }
    /* procedural city: rows x cols blocks separated by streets */
    for (int rr = 0; r == SQ_OK && rr < ws.city_rows; rr++)
        for (int cc = 0; cc < ws.city_cols; cc++) {
            if (nobs >= SQ_MAX_OBSTACLES) break;
            float pitch = ws.city_block_m + ws.city_street_m;
            float x = ws.city_center[0] + ((float)cc - 0.5f * (float)(ws.city_cols - 1)) * pitch;
            float y = ws.city_center[1] + ((float)rr - 0.5f * (float)(ws.city_rows - 1)) * pitch;
            float u = sq_rng_uniform(ws.city_seed, 0xC17Eu, (uint64_t)(rr * 64 + cc));
            float h = ws.city_height_min_m + (ws.city_height_max_m - ws.city_height_min_m) * u * u;
            float shade = 0.35f + 0.3f * sq_rng_uniform(ws.city_seed, 0xC17Fu, (uint64_t)(rr * 64 + cc));
            sq_obstacle *ob = &obs[nobs++];
            memset(ob, 0, sizeof *ob);
            ob->kind = SQ_OBSTACLE_BOX;
            ob->center_m = sq_v3(x, y, NAN);
            ob->size_m = sq_v3(ws.city_block_m, ws.city_block_m, h);
            ob->albedo = sq_v3(shade, shade * 0.95f, shade * 0.9f);
        }
    if (r != SQ_OK) {
        free(obs);
        free(areas);
        free(geo);
        return relog(ctx, r);
    }
    sq_world_desc wd = {0};
    /* "wrf" is the last choice of terrain.kind: a float grid from the file */
    const bool wrf_terrain = ws.terrain_kind == SQ__TERRAIN_CHOICE_WRF;
    wd.terrain.kind = wrf_terrain ? SQ_TERRAIN_GRID : (sq_terrain_kind)ws.terrain_kind;
    wd.terrain.vertical_exaggeration = ws.vertical_exaggeration;
    wd.terrain.material = (sq_terrain_material)ws.terrain_material;
    wd.terrain.snow_line_m = ws.snow_line_m;
    if (ws.size_count == 2) {
        wd.terrain.size_m[0] = ws.size_m[0];
        wd.terrain.size_m[1] = ws.size_m[1];
    }
    if (ws.resolution_count == 2) {
        wd.terrain.resolution[0] = (int)ws.resolution[0];
        wd.terrain.resolution[1] = (int)ws.resolution[1];
    }
    if (ws.origin_count == 2) {
        wd.terrain.origin_m[0] = ws.origin_m[0];
        wd.terrain.origin_m[1] = ws.origin_m[1];
        wd.terrain.origin_set = true;
    }
    wd.terrain.base_m = ws.base_m;
    wd.terrain.relief_m = ws.relief_m;
    wd.terrain.feature_m = ws.feature_m;
    wd.terrain.octaves = ws.octaves;
    wd.terrain.slope_deg = ws.slope_deg;
    wd.terrain.dune_dir_deg = ws.dune_dir_deg;
    wd.terrain.seed = ws.terrain_seed;
    wd.sun.direction = sq_v3(ws.sun_direction[0], ws.sun_direction[1], ws.sun_direction[2]);
    wd.sun.day_of_year = ws.day_of_year;
    wd.sun.hour_solar = ws.hour;
    wd.sun.hour_set = true;
    wd.sun.latitude_deg = ws.latitude_deg;
    wd.sun.irradiance_w_m2 = ws.irradiance;
    wd.sky.turbidity = ws.turbidity;
    wd.obstacles = obs;
    wd.obstacle_count = nobs;
    uint16_t *hm = NULL;
    void *wrf_owned = NULL;
    r = world_from_wrf_and_date(ctx, sd, &ws, wrf_terrain, &wd, &wrf_owned);
    if (r != SQ_OK) {
        free(obs);
        free(areas);
        free(geo);
        return r;
    }
    if (wd.terrain.kind == SQ_TERRAIN_HEIGHTMAP) {
        if (!ws.heightmap[0]) {
            free(obs);
            free(areas);
            free(geo);
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "scene",
                            "%s: world.terrain.kind = heightmap needs world.terrain.heightmap "
                            "(a 16-bit PNG path)",
                            cfg->source);
        }
        if (!sd->load_heightmap) {
            free(obs);
            free(areas);
            free(geo);
            return sq__fail(ctx, SQ_ERR_UNSUPPORTED, "scene", "heightmap terrains need a loader");
        }
        char path[1024];
        if (ws.heightmap[0] == '/' || !cfg->base_dir[0] || strcmp(cfg->base_dir, ".") == 0)
            snprintf(path, sizeof path, "%s", ws.heightmap);
        else
            snprintf(path, sizeof path, "%s/%s", cfg->base_dir, ws.heightmap);
        r = sd->load_heightmap(ctx, path, &hm, &wd.terrain.heightmap_w, &wd.terrain.heightmap_h);
        if (r != SQ_OK) {
            free(obs);
            free(areas);
            free(geo);
            return r;
        }
        wd.terrain.heightmap = hm;
        wd.terrain.metres_per_px = ws.metres_per_px;
        wd.terrain.height_min_m = ws.height_min_m;
        wd.terrain.height_max_m = ws.height_max_m;
    }
    r = sq__scene_geo_world(ctx, sd, &ws, areas, nareas, &wd, geo);
    if (r == SQ_OK) r = sq_world_create(ctx, &wd, out);
    sq__scene_geo_release(ctx, geo);
    sq_free(ctx, hm);
    sq_free(ctx, wrf_owned);
    free(obs);
    free(areas);
    free(geo);
    *ws_out = ws;
    return r;
}

/* ---- meshes: a procedural place and mesh files ---------------------------------------------- */
static float world_height(const void *user, float x, float y)
{
    return sq_world_height_at((const sq_world *)user, x, y);
}

static sq_result build_place(sq_scene *s, const sq_cfg *cfg, const sq__world_section *ws)
{
    if (ws->place_kind == SQ_PLACE_NONE) return SQ_OK;
    sq_place_desc pd;
    memset(&pd, 0, sizeof pd);
    pd.kind = (sq_place_kind)ws->place_kind;
    pd.size_m[0] = ws->place_size_count == 2 ? ws->place_size_m[0] : 1000.0f;
    pd.size_m[1] = ws->place_size_count == 2 ? ws->place_size_m[1] : 1000.0f;
    pd.center_m[0] = ws->place_center_count == 2 ? ws->place_center[0] : 0.0f;
    pd.center_m[1] = ws->place_center_count == 2 ? ws->place_center[1] : 0.0f;
    pd.seed = ws->place_seed;
    pd.tree_density = ws->place_tree_density;
    pd.height_at = world_height;
    pd.height_user = s->world;
    sq_vec3 lo, hi;
    sq_world_bounds(s->world, &lo, &hi);
    const float x0 = pd.center_m[0] - 0.5f * pd.size_m[0], x1 = pd.center_m[0] + 0.5f * pd.size_m[0];
    const float y0 = pd.center_m[1] - 0.5f * pd.size_m[1], y1 = pd.center_m[1] + 0.5f * pd.size_m[1];
    if (x0 < lo.x || x1 > hi.x || y0 < lo.y || y1 > hi.y)
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "scene",
                        "%s: world.place.size_m = [%g, %g] around world.place.center = [%g, %g] covers x %g..%g m, "
                        "y %g..%g m, which reaches outside the terrain (x %g..%g m, y %g..%g m); "
                        "enlarge world.terrain.size_m or shrink the place",
                        cfg->source, (double)pd.size_m[0], (double)pd.size_m[1],
                        (double)pd.center_m[0], (double)pd.center_m[1], (double)x0, (double)x1,
                        (double)y0, (double)y1, (double)lo.x, (double)hi.x, (double)lo.y,
                        (double)hi.y);
    return sq_place_generate(s->ctx, &pd, &s->place);
}

typedef struct file_key {
    char path[1024];
    int lods, up;
} file_key;

static sq_result build_meshes(sq_scene *s, const sq_scene_desc *sd, const sq_cfg_node *wnode,
                              const sq__world_section *ws)
{
    const sq_cfg *cfg = sd->cfg;
    sq_result r = build_place(s, cfg, ws);
    if (r != SQ_OK) return r;
    const sq_cfg_node *ml = wnode ? sq_cfg_get(wnode, "meshes") : NULL;
    apply_ctx a = {cfg, "world.meshes"};
    int items = 0;
    if (ml) {
        r = expect_kind(&a, ml, SQ_CFG_SEQ, "world.meshes");
        if (r != SQ_OK) return relog(s->ctx, r);
        for (const sq_cfg_node *o = ml->child; o; o = o->next) items++;
    }
    const int np = s->place ? s->place->mesh_count : 0, nip = s->place ? s->place->instance_count : 0;
    if (items == 0 && np == 0) return SQ_OK;
    if (items > 0 && !sd->load_mesh)
        return sq__fail(s->ctx, SQ_ERR_UNSUPPORTED, "scene", "%s: world.meshes need a mesh loader",
                        cfg->source);
    s->file_meshes = calloc((size_t)(items > 0 ? items : 1), sizeof *s->file_meshes);
    file_key *keys = calloc((size_t)(items > 0 ? items : 1), sizeof *keys);
    const sq_mesh **all = calloc((size_t)(np + items + 1), sizeof *all);
    sq_mesh_instance *inst = calloc((size_t)(nip + items + 1), sizeof *inst);
    if (!s->file_meshes || !keys || !all || !inst) {
        free(keys);
        free(all);
        free(inst);
        return sq__fail(s->ctx, SQ_ERR_OUT_OF_MEMORY, "scene", "out of memory");
    }
    for (int i = 0; i < np; i++) all[i] = s->place->meshes[i];
    if (nip > 0) memcpy(inst, s->place->instances, (size_t)nip * sizeof *inst);
    int ni = nip, i = 0;
    for (const sq_cfg_node *o = ml ? ml->child : NULL; r == SQ_OK && o; o = o->next, i++) {
        char sec[64], w[320];
        snprintf(sec, sizeof sec, "world.meshes[%d]", i);
        apply_ctx oa = {cfg, sec};
        where_of(&oa, o, w, sizeof w);
        r = expect_kind(&oa, o, SQ_CFG_MAP, sec);
        if (r != SQ_OK) {
            r = relog(s->ctx, r);
            break;
        }
        sq__mesh_item it;
        sq_params_defaults(sq__mesh_params, sq__mesh_param_count, &it);
        r = apply_map(&oa, o, "", sq__mesh_params, sq__mesh_param_count, &it, NULL);
        if (r != SQ_OK) {
            r = relog(s->ctx, r);
            break;
        }
        if (!it.file[0]) {
            r = sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "scene", "%s: %s.file: a mesh file is required",
                         w, sec);
            break;
        }
        if (it.position_count < 2) {
            r = sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "scene",
                         "%s: %s.position: expected [x, y] or [x, y, z]", w, sec);
            break;
        }
        file_key k;
        if (it.file[0] == '/' || !cfg->base_dir[0]) snprintf(k.path, sizeof k.path, "%s", it.file);
        else snprintf(k.path, sizeof k.path, "%s/%s", cfg->base_dir, it.file);
        k.lods = it.lods;
        k.up = it.up;
        int mesh = -1;
        for (int f = 0; f < s->file_mesh_count; f++)
            if (!strcmp(keys[f].path, k.path) && keys[f].lods == k.lods && keys[f].up == k.up) mesh = f;
        if (mesh < 0) {
            sq_mesh_import_desc md = {k.path, it.lods, (sq_mesh_up)it.up};
            sq_mesh *m = NULL;
            r = sd->load_mesh(s->ctx, &md, &m);
            if (r != SQ_OK) {
                char why[1024];
                snprintf(why, sizeof why, "%s", sq_last_error());
                r = sq__fail(s->ctx, r, "scene", "%s: %s.file: %s", w, sec, why);
                break;
            }
            mesh = s->file_mesh_count;
            keys[mesh] = k;
            s->file_meshes[s->file_mesh_count++] = m;
            all[np + mesh] = m;
        }
        sq_mesh_instance *in = &inst[ni];
        memset(in, 0, sizeof *in);
        in->mesh = np + mesh;
        in->position_m = sq_v3(it.position[0], it.position[1],
                               it.position_count == 3 ? it.position[2] : NAN);
        in->yaw_deg = it.yaw_deg;
        in->scale = it.scale_count >= 3 ? sq_v3(it.scale[0], it.scale[1], it.scale[2])
                                        : sq_v3(it.scale[0], it.scale[0], it.scale[0]);
        in->tint[0] = sq_v3(it.color[0], it.color[1], it.color[2]);
        r = sq_world_check_mesh_instance(s->ctx, s->world, s->file_meshes[mesh], in);
        if (r != SQ_OK) {
            char why[1024];
            snprintf(why, sizeof why, "%s", sq_last_error());
            r = sq__fail(s->ctx, r, "scene", "%s: %s: %s", w, sec, why);
            break;
        }
        ni++;
    }
    if (r == SQ_OK)
        r = sq_world_set_meshes(s->ctx, s->world, all, np + s->file_mesh_count, inst, ni);
    free(keys);
    free(all);
    free(inst);
    if (r == SQ_OK && s->world->mesh_instance_count > 0)
        sq_log(s->ctx, SQ_LOG_INFO, "scene", "meshes: %d instances of %d meshes, %lld faces",
               s->world->mesh_instance_count, s->world->mesh_count,
               (long long)s->world->mesh_faces);
    return r;
}

static sq_result build_camera(sq_scene *s, const sq_cfg *cfg, const sq_cfg_node *node)
{
    sq__camera_section cs;
    sq_params_defaults(sq__camera_params, sq__camera_param_count, &cs);
    apply_ctx a = {cfg, "camera"};
    static const char *const skip[] = {"path", NULL};
    sq_result r = SQ_OK;
    if (node) {
        r = expect_kind(&a, node, SQ_CFG_MAP, "camera");
        if (r == SQ_OK) r = apply_map(&a, node, "", sq__camera_params, sq__camera_param_count, &cs, skip);
        const sq_cfg_node *path = sq_cfg_get(node, "path");
        if (r == SQ_OK && path) {
            r = expect_kind(&a, path, SQ_CFG_SEQ, "camera.path");
            int i = 0;
            for (const sq_cfg_node *k = path->child; r == SQ_OK && k; k = k->next, i++) {
                char sec[64];
                snprintf(sec, sizeof sec, "camera.path[%d]", i);
                apply_ctx ka = {cfg, sec};
                if (i >= SQ_MAX_CAMERA_KEYS) {
                    r = sq__set_error(SQ_ERR_INVALID_ARG, "%s: camera.path: more than %d keys",
                                      cfg->source, SQ_MAX_CAMERA_KEYS);
                    break;
                }
                r = expect_kind(&ka, k, SQ_CFG_MAP, sec);
                if (r != SQ_OK) break;
                sq__camera_key_item it;
                sq_params_defaults(sq__camera_key_params, sq__camera_key_param_count, &it);
                r = apply_map(&ka, k, "", sq__camera_key_params, sq__camera_key_param_count, &it,
                              NULL);
                if (r != SQ_OK) break;
                if (i > 0 && it.t <= s->keys[i - 1].time_s) {
                    char w[320];
                    where_of(&ka, k, w, sizeof w);
                    r = sq__set_error(SQ_ERR_INVALID_ARG,
                                      "%s: %s.t = %g: key times must increase (previous %g)", w,
                                      sec, it.t, s->keys[i - 1].time_s);
                    break;
                }
                s->keys[i].time_s = it.t;
                s->keys[i].position_m = sq_v3(it.position[0], it.position[1], it.position[2]);
                s->keys[i].target_m = sq_v3(it.target[0], it.target[1], it.target[2]);
                s->keys[i].fov_y_deg = it.fov_deg;
                s->key_count = i + 1;
            }
        }
    }
    if (r != SQ_OK) return relog(s->ctx, r);
    s->camera.position_m = sq_v3(cs.position[0], cs.position[1], cs.position[2]);
    s->camera.target_m = sq_v3(cs.target[0], cs.target[1], cs.target[2]);
    s->camera.up = sq_v3(cs.up[0], cs.up[1], cs.up[2]);
    s->camera.fov_y_deg = cs.fov_deg;
    s->camera.near_m = cs.near_m;
    s->camera.far_m = cs.far_m;
    return SQ_OK;
}

static sq_result build_output(sq_scene *s, const sq_cfg *cfg, const sq_cfg_node *node)
{
    sq_params_defaults(sq__output_params, sq__output_param_count, &s->out);
    apply_ctx a = {cfg, "output"};
    sq_result r = SQ_OK;
    if (node) {
        r = expect_kind(&a, node, SQ_CFG_MAP, "output");
        if (r == SQ_OK) r = apply_map(&a, node, "", sq__output_params, sq__output_param_count, &s->out, NULL);
    }
    const sq_cfg_node *vn = node ? sq_cfg_get(node, "video") : NULL;
    const size_t vl = strlen(s->out.video);
    if (r == SQ_OK && vl && (vl < 4 || strcasecmp(s->out.video + vl - 4, ".mp4") != 0)) {
        char w[320];
        where_of(&a, vn ? vn : node, w, sizeof w);
        r = sq__set_error(SQ_ERR_INVALID_ARG,
                          "%s: output.video = '%s': squall writes H.264 video as .mp4 only; end "
                          "the name with .mp4, or use output.frames_dir for PNG frames",
                          w, s->out.video);
    }
    if (r != SQ_OK) return relog(s->ctx, r);
    if (s->out.frames == 0) {
        double f = floor(s->out.duration_s * s->out.fps + 0.5);
        s->out.frames = f < 1.0 ? 1 : (int)f;
    }
    return SQ_OK;
}

/* Relative file paths of a layer (SQ_PARAM_PATH entries) are taken against the scene file's
 * folder (a preset's: the source tree). */
static sq_result resolve_paths(const sq_cfg *cfg, const sq_phen_plugin *pl, void *desc)
{
    if (!cfg->base_dir[0]) return SQ_OK;
    for (size_t i = 0; i < pl->param_count; i++) {
        const sq_param *p = &pl->params[i];
        if (p->type != SQ_PARAM_STRING || !(p->flags & SQ_PARAM_PATH)) continue;
        char *v = (char *)desc + p->offset;
        if (!v[0] || v[0] == '/') continue;
        char path[SQ_PARAM_STRING_MAX];
        const int n = snprintf(path, sizeof path, "%s/%s", cfg->base_dir, v);
        if (n < 0 || (size_t)n >= sizeof path)
            return sq__set_error(SQ_ERR_INVALID_ARG, "%s: %s = '%s': the path with the scene's "
                                 "folder is longer than %d characters",
                                 cfg->source, p->key, v, SQ_PARAM_STRING_MAX - 1);
        memcpy(v, path, (size_t)n + 1);
    }
    return SQ_OK;
}

/* The node of a dotted table key under a layer's map: nested maps ("wind: {speed_mps: 3}") or
 * dotted keys ("wind.speed_mps: 3"); NULL when the key is not in the file (a default). */
static const sq_cfg_node *find_key(const sq_cfg_node *map, const char *key)
{
    if (!map || map->kind != SQ_CFG_MAP) return NULL;
    const sq_cfg_node *n = sq_cfg_get(map, key);
    if (n) return n;
    const char *dot = strchr(key, '.');
    if (!dot) return NULL;
    char head[128];
    const size_t len = (size_t)(dot - key);
    if (len >= sizeof head) return NULL;
    memcpy(head, key, len);
    head[len] = '\0';
    return find_key(sq_cfg_get(map, head), dot + 1);
}

/* A layer's refusal, phrased by the phenomenon about its C desc ("sq_<type>_desc.<key> = ...:
 * rule"), for the scene: the place of <key> in the file (else of the layer) in front and
 * "layers.<name>." for the desc's name. The rule itself is not re-derived here. */
static sq_result translate_layer_error(sq_scene *s, const apply_ctx *la, const sq_cfg_node *l,
                                       const layer *L, sq_result r)
{
    char msg[1536], out[2048], prefix[80], repl[96];
    snprintf(msg, sizeof msg, "%s", sq_last_error());
    snprintf(prefix, sizeof prefix, "sq_%s_desc.", L->plugin->name);
    snprintf(repl, sizeof repl, "layers.%s.", L->name);
    const sq_cfg_node *node = l;
    const char *at = strstr(msg, prefix);
    if (at) { /* the longest table key the message names */
        const char *k = at + strlen(prefix);
        size_t best = 0;
        const sq_param *t = L->plugin->params;
        for (size_t i = 0; i < L->plugin->param_count; i++) {
            const size_t n = strlen(t[i].key);
            if (n > best && strncmp(k, t[i].key, n) == 0 &&
                !(k[n] == '_' || (k[n] >= 'a' && k[n] <= 'z') || (k[n] >= '0' && k[n] <= '9'))) {
                const sq_cfg_node *kn = find_key(l, t[i].key);
                best = n;
                node = kn ? kn : l;
            }
        }
    }
    size_t len = 0;
    for (const char *p = msg; *p && len + 1 < sizeof out;) {
        if (strncmp(p, prefix, strlen(prefix)) == 0) {
            len += (size_t)snprintf(out + len, sizeof out - len, "%s", repl);
            p += strlen(prefix);
        } else {
            out[len++] = *p++;
        }
    }
    out[len < sizeof out ? len : sizeof out - 1] = '\0';
    char w[320];
    where_of(la, node, w, sizeof w);
    return sq__fail(s->ctx, r, "scene", "%s: %s", w, out);
}

static sq_result build_layers(sq_scene *s, const sq_scene_desc *sd, const sq_cfg_node *node)
{
    const sq_cfg *cfg = sd->cfg;
    apply_ctx a = {cfg, "layers"};
    if (!node) return SQ_OK;
    sq_result r = expect_kind(&a, node, SQ_CFG_SEQ, "layers");
    if (r != SQ_OK) return relog(s->ctx, r);
    int i = 0;
    for (const sq_cfg_node *l = node->child; l; l = l->next, i++) {
        char sec[96];
        snprintf(sec, sizeof sec, "layers[%d]", i);
        apply_ctx la = {cfg, sec};
        char w[320];
        where_of(&la, l, w, sizeof w);
        r = expect_kind(&la, l, SQ_CFG_MAP, sec);
        if (r != SQ_OK) return relog(s->ctx, r);
        const sq_cfg_node *type = sq_cfg_get(l, "type");
        if (!type || type->kind != SQ_CFG_SCALAR || !type->value)
            return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "scene",
                            "%s: %s needs 'type: <phenomenon>' (see `squall params`)", w, sec);
        const sq_phen_plugin *pl = sq_plugin_find(type->value);
        if (!pl) {
            char known[256] = "";
            for (int k = 0; k < sq_plugin_count(); k++) {
                strncat(known, k ? ", " : "", sizeof known - strlen(known) - 1);
                strncat(known, sq_plugin_at(k)->name, sizeof known - strlen(known) - 1);
            }
            where_of(&la, type, w, sizeof w);
            return sq__fail(s->ctx, SQ_ERR_NOT_FOUND, "scene",
                            "%s: %s.type = '%s': no such phenomenon in this build (available: %s)",
                            w, sec, type->value, known[0] ? known : "none");
        }
        const sq_cfg_node *en = sq_cfg_get(l, "enabled");
        if (en && en->value && (strcmp(en->value, "false") == 0 || strcmp(en->value, "no") == 0))
            continue;
        if (s->layer_count >= MAX_LAYERS)
            return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "scene", "%s: more than %d layers", w,
                            MAX_LAYERS);
        layer *L = &s->layers[s->layer_count];
        const sq_cfg_node *nm = sq_cfg_get(l, "name");
        if (nm) {
            /* a name addresses the layer in --set layers.NAME.key and prefixes its metrics */
            where_of(&la, nm, w, sizeof w);
            const char *v = nm->kind == SQ_CFG_SCALAR && nm->value ? nm->value : "";
            bool digits = *v != 0;
            for (const char *c = v; *c; c++) digits = digits && isdigit((unsigned char)*c);
            if (!*v || strchr(v, '.') || digits || strlen(v) >= sizeof L->name)
                return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "scene",
                                "%s: %s.name = '%s': a layer name is 1..%zu characters, not a "
                                "number and without '.' (it addresses the layer in --set "
                                "layers.NAME.key)",
                                w, sec, v, sizeof L->name - 1);
        }
        snprintf(L->name, sizeof L->name, "%s", nm && nm->value ? nm->value : pl->name);
        for (int k = 0; k < s->layer_count; k++)
            if (strcmp(s->layers[k].name, L->name) == 0) {
                where_of(&la, nm ? nm : l, w, sizeof w);
                return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "scene",
                                "%s: %s is named '%s' like an earlier layer; give each layer a "
                                "unique name (layers share names through their type when "
                                "'name:' is missing)",
                                w, sec, L->name);
            }
        snprintf(sec, sizeof sec, "layers.%s", L->name); /* as --set addresses it */
        la.section = sec;
        L->plugin = pl;
        void *desc = calloc(1, pl->desc_size);
        if (!desc) return sq__fail(s->ctx, SQ_ERR_OUT_OF_MEMORY, "scene", "out of memory");
        s->layer_count++;
        sq_params_defaults(pl->params, pl->param_count, desc);
        static const char *const skip[] = {"type", "name", "enabled", NULL};
        r = apply_map(&la, l, "", pl->params, pl->param_count, desc, skip);
        if (r == SQ_OK) r = resolve_paths(cfg, pl, desc);
        if (r != SQ_OK) {
            free(desc);
            return relog(s->ctx, r);
        }
        /* resolve, ranges, the phenomenon's own rules and the memory check live in the handle;
         * the phenomenon itself is created once every layer has passed (sq_scene_create) */
        const sq__phen_make m = {pl, L->name, desc, s->world, true, s->memory_bytes};
        sq__phen_stage stage;
        r = sq__phenomenon_make(s->ctx, &m, &L->ph, &stage);
        free(desc);
        if (r != SQ_OK)
            return stage == SQ__PHEN_RULES ? translate_layer_error(s, &la, l, L, r) : r;
        s->memory_bytes += sq_phenomenon_memory_bytes(L->ph);
    }
    return SQ_OK;
}

/* The renderer refuses a camera within 0.1 m of the terrain; the scene says it first, naming
 * the key and its file:line, which it keeps from building the camera: the camera's position,
 * every path key, and the path between keys (sampled 64 times per segment). Only rendering
 * needs a camera, so render commands call this; simulate does not. */
#define CAMERA_CLEARANCE_M 0.1f
static void note_camera_places(sq_scene *s, const sq_cfg *cfg)
{
    const sq_cfg_node *cam = sq_cfg_get(cfg->root, "camera");
    const sq_cfg_node *path = cam ? sq_cfg_get(cam, "path") : NULL;
    const sq_cfg_node *pos = cam ? sq_cfg_get(cam, "position") : NULL;
    apply_ctx a = {cfg, "camera"};
    where_of(&a, pos ? pos : cam, s->camera_where, sizeof s->camera_where);
    const sq_cfg_node *kn = path ? path->child : NULL;
    for (int i = 0; i < s->key_count; i++, kn = kn ? kn->next : NULL)
        where_of(&a, kn, s->key_where[i], sizeof s->key_where[i]);
}

sq_result sq_scene_check_camera(const sq_scene *s)
{
    if (!s) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_scene_check_camera: scene is NULL");
    if (s->key_count == 0) {
        const sq_vec3 p = s->camera.position_m;
        const float h = sq_world_height_at(s->world, p.x, p.y);
        if (!(p.z >= h + CAMERA_CLEARANCE_M))
            return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "scene",
                            "%s: camera.position = [%g, %g, %g] m: the terrain surface there is at "
                            "%.2f m; raise z above %.2f m",
                            s->camera_where, (double)p.x, (double)p.y, (double)p.z, (double)h,
                            (double)(h + CAMERA_CLEARANCE_M));
        return SQ_OK;
    }
    for (int i = 0; i < s->key_count; i++) {
        const sq_vec3 p = s->keys[i].position_m;
        const float h = sq_world_height_at(s->world, p.x, p.y);
        if (!(p.z >= h + CAMERA_CLEARANCE_M))
            return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "scene",
                            "%s: camera.path[%d].position = [%g, %g, %g] m: the terrain surface "
                            "there is at %.2f m; raise z above %.2f m",
                            s->key_where[i], i, (double)p.x, (double)p.y, (double)p.z, (double)h,
                            (double)(h + CAMERA_CLEARANCE_M));
    }
    for (int i = 0; i + 1 < s->key_count; i++) {
        const double t0 = s->keys[i].time_s, t1 = s->keys[i + 1].time_s;
        for (int k = 1; k < 64; k++) {
            const double t = t0 + (t1 - t0) * k / 64.0;
            const sq_camera c = sq_camera_at(&s->camera, s->keys, s->key_count, t);
            const float hc = sq_world_height_at(s->world, c.position_m.x, c.position_m.y);
            if (!(c.position_m.z >= hc + CAMERA_CLEARANCE_M))
                return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "scene",
                                "%s: camera.path[%d]..[%d]: the path between these keys passes "
                                "%.2f m above the terrain at t = %.3g s (x %.1f, y %.1f m); it "
                                "needs %.2f m: raise the keys or add one between them",
                                s->key_where[i], i, i + 1, (double)(c.position_m.z - hc), t,
                                (double)c.position_m.x, (double)c.position_m.y,
                                (double)CAMERA_CLEARANCE_M);
        }
    }
    return SQ_OK;
}

/* ---- configuration subtrees: copies and comparison (live changes) ----------------------------- */
static sq_cfg_node *clone_node(const sq_cfg_node *n)
{
    sq_cfg_node *c = sq_cfg_node_new(n->kind, n->key, n->value, n->line, n->col);
    if (!c) return NULL;
    for (const sq_cfg_node *k = n->child; k; k = k->next) {
        sq_cfg_node *kc = clone_node(k);
        if (!kc) {
            sq_cfg_node_free(c);
            return NULL;
        }
        sq_cfg_node_append(c, kc);
    }
    return c;
}

static bool same_text(const char *a, const char *b)
{
    return (!a && !b) || (a && b && strcmp(a, b) == 0);
}

/* The same content (kinds, keys, values, order), wherever it was written. */
static bool same_node(const sq_cfg_node *a, const sq_cfg_node *b)
{
    if (!a || !b) return a == b;
    if (a->kind != b->kind || !same_text(a->key, b->key) || !same_text(a->value, b->value))
        return false;
    const sq_cfg_node *x = a->child, *y = b->child;
    for (; x && y; x = x->next, y = y->next)
        if (!same_node(x, y)) return false;
    return !x && !y;
}

static const char *const top_keys[] = {"name", "description", "seed", "world",
                                       "camera", "layers", "output", NULL};

sq_result sq_scene_create(sq_context *ctx, const sq_scene_desc *desc, sq_scene **out)
{
    if (!out || !desc || !desc->cfg || !desc->cfg->root)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "scene", "sq_scene_create: missing desc or cfg");
    *out = NULL;
    const sq_cfg *cfg = desc->cfg;
    apply_ctx a = {cfg, "scene"};
    /* unknown top-level keys */
    for (const sq_cfg_node *c = cfg->root->child; c; c = c->next) {
        bool known = false;
        for (const char *const *k = top_keys; *k; k++) known = known || strcmp(*k, c->key) == 0;
        if (!known) {
            char w[320];
            where_of(&a, c, w, sizeof w);
            const char *best = NULL;
            size_t bl = 99;
            for (const char *const *k = top_keys; *k; k++) {
                size_t d = sq__edit_distance(c->key, *k);
                if (d < bl) {
                    bl = d;
                    best = *k;
                }
            }
            if (bl <= 2)
                return sq__fail(ctx, SQ_ERR_NOT_FOUND, "scene",
                                "%s: unknown key '%s'; did you mean '%s'?", w, c->key, best);
            return sq__fail(ctx, SQ_ERR_NOT_FOUND, "scene",
                            "%s: unknown key '%s' (top-level keys: name, description, seed, world, "
                            "camera, layers, output)",
                            w, c->key);
        }
    }
    sq_scene *s = (sq_scene *)calloc(1, sizeof *s);
    if (!s) return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "scene", "out of memory");
    s->ctx = ctx;
    const sq_cfg_node *nm = sq_cfg_get(cfg->root, "name");
    snprintf(s->name, sizeof s->name, "%s", nm && nm->value ? nm->value : cfg->source);
    const sq_cfg_node *seed = sq_cfg_get(cfg->root, "seed");
    if (seed && seed->value) {
        uint64_t v = 0;
        if (!sq__parse_u64(seed->value, &v)) {
            char w[320];
            where_of(&a, seed, w, sizeof w);
            sq_scene_destroy(s);
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "scene",
                            "%s: seed = '%s': expected a whole number in 0..18446744073709551615 "
                            "(digits only)",
                            w, seed->value);
        }
        s->seed = v;
    }
    sq_result r = build_output(s, cfg, sq_cfg_get(cfg->root, "output"));
    if (r == SQ_OK) r = build_camera(s, cfg, sq_cfg_get(cfg->root, "camera"));
    sq__world_section ws;
    memset(&ws, 0, sizeof ws);
    if (r == SQ_OK) r = build_world(ctx, desc, sq_cfg_get(cfg->root, "world"), &ws, &s->world);
    if (r == SQ_OK) r = build_meshes(s, desc, sq_cfg_get(cfg->root, "world"), &ws);
    if (r == SQ_OK) note_camera_places(s, cfg);
    if (r == SQ_OK) r = build_layers(s, desc, sq_cfg_get(cfg->root, "layers"));
    const sq_cfg_node *wn = sq_cfg_get(cfg->root, "world");
    if (r == SQ_OK && wn && !(s->world_cfg = clone_node(wn)))
        r = sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "scene", "out of memory");
    if (r == SQ_OK && !desc->validate_only)
        for (int i = 0; i < s->layer_count && r == SQ_OK; i++) {
            if (sq__cancelled(ctx)) {
                r = sq__fail_cancelled(ctx, "scene", "while creating the layers");
                break;
            }
            r = sq__phenomenon_instantiate(s->layers[i].ph);
            if (r != SQ_OK)
                r = sq__scene_translate_error(s->layers[i].plugin->params,
                                              s->layers[i].plugin->param_count,
                                              s->layers[i].name, r);
        }
    if (r != SQ_OK) {
        sq_scene_destroy(s);
        return r;
    }
    *out = s;
    return SQ_OK;
}

void sq_scene_destroy(sq_scene *s)
{
    if (!s) return;
    for (int i = s->layer_count - 1; i >= 0; i--) sq_phenomenon_destroy(s->layers[i].ph);
    sq_world_destroy(s->ctx, s->world);
    sq_place_destroy(s->ctx, s->place);
    for (int i = 0; i < s->file_mesh_count; i++) sq_mesh_destroy(s->ctx, s->file_meshes[i]);
    free(s->file_meshes);
    sq_cfg_node_free(s->world_cfg);
    free(s);
}

/* For checkpoints (scene_state.c). */
sq_phenomenon *sq__scene_layer_handle(const sq_scene *s, int i)
{
    return i >= 0 && i < s->layer_count ? s->layers[i].ph : NULL;
}
uint64_t sq__scene_steps(const sq_scene *s) { return s->step_count; }
void sq__scene_set_clock(sq_scene *s, double time_s, uint64_t steps)
{
    s->time_s = time_s;
    s->step_count = steps;
}
sq_context *sq__scene_context(const sq_scene *s) { return s->ctx; }

const sq_scene_output *sq_scene_output_settings(const sq_scene *s) { return &s->out; }
const sq_world *sq_scene_world(const sq_scene *s) { return s->world; }
const char *sq_scene_name(const sq_scene *s) { return s->name; }
uint64_t sq_scene_seed(const sq_scene *s) { return s->seed; }
double sq_scene_time(const sq_scene *s) { return s->time_s; }
int sq_scene_frame_count(const sq_scene *s) { return s->out.frames; }
double sq_scene_frame_dt(const sq_scene *s) { return s->out.time_scale / (double)s->out.fps; }
int sq_scene_layer_count(const sq_scene *s) { return s->layer_count; }
uint64_t sq_scene_memory_bytes(const sq_scene *s) { return s->memory_bytes; }
const char *sq_scene_layer_name(const sq_scene *s, int i)
{
    return i >= 0 && i < s->layer_count ? s->layers[i].name : NULL;
}
const char *sq_scene_layer_type(const sq_scene *s, int i)
{
    return i >= 0 && i < s->layer_count ? s->layers[i].plugin->name : NULL;
}
sq_phenomenon *sq_scene_layer(sq_scene *s, int i)
{
    return s && i >= 0 && i < s->layer_count ? s->layers[i].ph : NULL;
}

sq_result sq_scene_step(sq_scene *s, double dt_s)
{
    if (!(dt_s > 0.0) || !isfinite(dt_s))
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "scene", "step dt = %g s; must be > 0", dt_s);
    for (int i = 0; i < s->layer_count; i++) {
        sq__scene_couple(s, i);
        const sq_result r = sq_phenomenon_step(s->layers[i].ph, dt_s);
        if (r != SQ_OK)
            return r == SQ_ERR_CANCELLED ? r
                                         : sq__scene_translate_error(s->layers[i].plugin->params,
                                                                     s->layers[i].plugin->param_count,
                                                                     s->layers[i].name, r);
    }
    s->time_s += dt_s;
    s->step_count++;
    sq_world_set_time(s->world, s->time_s); /* a sun with a date moves with the clock */
    return SQ_OK;
}

sq_result sq_scene_frame_sync(sq_scene *s, bool gather)
{
    sq_result r = SQ_OK;
    for (int i = 0; i < s->layer_count && r == SQ_OK; i++)
        r = sq_phenomenon_frame_sync(s->layers[i].ph, gather);
    return r;
}

sq_camera sq_scene_camera(sq_scene *s)
{
    double video_t = s->out.time_scale > 0.0 ? (s->time_s - s->out.warmup_s) / s->out.time_scale
                                             : s->time_s;
    sq_camera c = sq_camera_at(&s->camera, s->keys, s->key_count, video_t);
    for (int i = 0; i < s->layer_count; i++) sq_phenomenon_observe(s->layers[i].ph, &c);
    return c;
}

int sq_scene_drawables(sq_scene *s, sq_drawable *out, int max)
{
    int n = 0, first[MAX_LAYERS + 1];
    for (int i = 0; i < s->layer_count; i++) {
        first[i] = n;
        if (n < max) n += sq_phenomenon_drawables(s->layers[i].ph, out + n, max - n);
    }
    first[s->layer_count] = n;
    return sq__scene_couple_drawables(s, out, first);
}

int sq_scene_metrics(sq_scene *s, sq_metric *out, int max)
{
    int n = 0;
    if (max > MAX_METRICS) max = MAX_METRICS;
    for (int i = 0; i < s->layer_count && n < max; i++) {
        layer *L = &s->layers[i];
        int k = sq_phenomenon_metric_count(L->ph);
        if (k > max - n) k = max - n;
        for (int j = 0; j < k; j++) sq_phenomenon_metric(L->ph, j, &out[n + j]);
        for (int j = 0; j < k; j++) {
            char full[sizeof s->metric_names[0]];
            snprintf(full, sizeof full, "%s.%s", L->name, out[n + j].name);
            memcpy(s->metric_names[n + j], full, sizeof full);
            out[n + j].name = s->metric_names[n + j];
        }
        n += k;
    }
    return n;
}

int sq_scene_fields(sq_scene *s, sq_named_field *out, int max)
{
    int n = 0;
    for (int i = 0; i < s->layer_count && n < max; i++) {
        sq_phenomenon *p = s->layers[i].ph;
        const int k = sq_phenomenon_field_count(p);
        for (int j = 0; j < k && n < max; j++) sq_phenomenon_field(p, j, &out[n++]);
    }
    return n;
}

/* ---- live changes ------------------------------------------------------------------------------ */
/* A scratch scene for the sections of the new configuration, on the running scene's world. */
static void scratch_free(sq_scene *t)
{
    if (!t) return;
    t->world = NULL; /* borrowed */
    sq_scene_destroy(t);
}

static void set_rebuild(sq_live_result *res, const char *fmt, ...)
{
    res->rebuild = true;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(res->reason, sizeof res->reason, fmt, ap);
    va_end(ap);
}

/* The world section: the world is built once, so a change needs a rebuild, except for the live
 * keys of the sun and the sky (turbidity, irradiance, the sun's day, hour, latitude and clock
 * scale) of a procedural or file terrain: *sky_change is set and *ws holds the new section. The
 * first key that needs a rebuild is named. */
static sq_result check_world(const sq_scene *s, const sq_cfg *cfg, sq__world_section *ws,
                             bool *sky_change, sq_live_result *res)
{
    *sky_change = false;
    const sq_cfg_node *wn = sq_cfg_get(cfg->root, "world");
    if (same_node(s->world_cfg, wn)) return SQ_OK;
    sq__world_section a;
    sq_params_defaults(sq__world_params, sq__world_param_count, &a);
    sq_params_defaults(sq__world_params, sq__world_param_count, ws);
    static const char *const skip[] = {"obstacles", "areas", "meshes", NULL};
    apply_ctx ac = {cfg, "world"};
    sq_result r = SQ_OK;
    if (wn) r = expect_kind(&ac, wn, SQ_CFG_MAP, "world");
    if (r == SQ_OK && wn)
        r = apply_map(&ac, wn, "", sq__world_params, sq__world_param_count, ws, skip);
    if (r != SQ_OK) return relog(s->ctx, r);
    if (s->world_cfg)
        (void)apply_map(&ac, s->world_cfg, "", sq__world_params, sq__world_param_count, &a, skip);
    const sq_param *p = sq_params_first_change(sq__world_params, sq__world_param_count, &a, ws, false);
    bool lists = true;
    for (const char *const *k = skip; *k; k++)
        lists = lists && same_node(s->world_cfg ? sq_cfg_get(s->world_cfg, *k) : NULL,
                                   wn ? sq_cfg_get(wn, *k) : NULL);
    if (!p && lists && ws->terrain_kind != SQ__TERRAIN_CHOICE_WRF &&
        a.terrain_kind != SQ__TERRAIN_CHOICE_WRF) {
        *sky_change = sq_params_first_change(sq__world_params, sq__world_param_count, &a, ws,
                                             true) != NULL;
        return SQ_OK;
    }
    if (!p) p = sq_params_first_change(sq__world_params, sq__world_param_count, &a, ws, true);
    set_rebuild(res, "world.%s changed: the world is built once, the scene must be rebuilt",
                !lists ? "obstacles, areas or meshes" : p ? p->key : "terrain");
    return SQ_OK;
}

sq_result sq_scene_apply_live(sq_scene *s, const sq_scene_desc *desc, sq_live_result *res)
{
    if (!s || !desc || !desc->cfg || !desc->cfg->root || !res)
        return sq__fail(s ? s->ctx : NULL, SQ_ERR_INVALID_ARG, "scene",
                        "sq_scene_apply_live: missing scene, desc, cfg or result");
    memset(res, 0, sizeof *res);
    const sq_cfg *cfg = desc->cfg;
    /* the seed and the world: fixed for the scene's life */
    const sq_cfg_node *seed = sq_cfg_get(cfg->root, "seed");
    uint64_t sv = 0;
    if (seed && seed->value && sq__parse_u64(seed->value, &sv) && sv != s->seed)
        set_rebuild(res, "seed changed: the scene must be rebuilt");
    if (res->rebuild) return SQ_OK;
    sq__world_section ws;
    bool sky_change = false;
    {
        const sq_result r = check_world(s, cfg, &ws, &sky_change, res);
        if (r != SQ_OK || res->rebuild) return r;
    }
    /* every other section, built exactly as sq_scene_create builds it (the same rules and
     * messages), into a scratch scene on this scene's world */
    sq_scene *t = (sq_scene *)calloc(1, sizeof *t);
    if (!t) return sq__fail(s->ctx, SQ_ERR_OUT_OF_MEMORY, "scene", "out of memory");
    t->ctx = s->ctx;
    t->world = s->world;
    t->seed = s->seed;
    sq_result r = build_output(t, cfg, sq_cfg_get(cfg->root, "output"));
    if (r == SQ_OK) r = build_camera(t, cfg, sq_cfg_get(cfg->root, "camera"));
    if (r == SQ_OK) r = build_layers(t, desc, sq_cfg_get(cfg->root, "layers"));
    if (r != SQ_OK) {
        scratch_free(t);
        return r;
    }
    /* what needs a rebuild: a non-live output key, other layers, a non-live layer key, a live
     * key of a phenomenon without the apply_live hook */
    const sq_param *p = sq_params_first_change(sq__output_params, sq__output_param_count, &s->out,
                                               &t->out, false);
    if (p) set_rebuild(res, "output.%s changed: it is not a live key, the scene must be rebuilt",
                       p->key);
    if (!res->rebuild && t->layer_count != s->layer_count)
        set_rebuild(res, "the layers changed (%s): the scene must be rebuilt",
                    t->layer_count > s->layer_count ? "one added or enabled" : "one removed or disabled");
    for (int i = 0; i < s->layer_count && !res->rebuild; i++) {
        const layer *a = &s->layers[i], *b = &t->layers[i];
        if (a->plugin != b->plugin || strcmp(a->name, b->name) != 0) {
            set_rebuild(res, "layer '%s' is now '%s': the scene must be rebuilt", a->name, b->name);
            break;
        }
        const sq_phen_plugin *pl = a->plugin;
        const void *da = sq_phenomenon_desc_get(a->ph), *db = sq_phenomenon_desc_get(b->ph);
        const sq_param *q = sq_params_first_change(pl->params, pl->param_count, da, db, false);
        const sq_param *l = sq_params_first_change(pl->params, pl->param_count, da, db, true);
        char key[200];
        if (q || (l && !sq_param_live(l, pl))) {
            snprintf(key, sizeof key, "layers.%s.%s", a->name, q ? q->key : l->key);
            set_rebuild(res, q ? "%s changed: it is not a live key, the scene must be rebuilt"
                               : "%s changed: this phenomenon takes no live change, the scene "
                                 "must be rebuilt",
                        key);
        }
    }
    if (res->rebuild) {
        scratch_free(t);
        return SQ_OK;
    }
    /* apply: the sun and sky, output rendering keys, the camera, then each layer's hook */
    const sq_cfg_node *wn = sq_cfg_get(cfg->root, "world");
    if (!same_node(s->world_cfg, wn)) {
        sq_cfg_node *copy = wn ? clone_node(wn) : NULL;
        if (wn && !copy) {
            scratch_free(t);
            return sq__fail(s->ctx, SQ_ERR_OUT_OF_MEMORY, "scene", "out of memory");
        }
        if (sky_change) {
            sq__world_section old;
            sq_params_defaults(sq__world_params, sq__world_param_count, &old);
            static const char *const skip[] = {"obstacles", "areas", "meshes", NULL};
            apply_ctx ac = {cfg, "world"};
            if (s->world_cfg)
                (void)apply_map(&ac, s->world_cfg, "", sq__world_params, sq__world_param_count,
                                &old, skip);
            for (size_t i = 0; i < sq__world_param_count; i++)
                if ((sq__world_params[i].flags & SQ_PARAM_LIVE) &&
                    sq_params_first_change(&sq__world_params[i], 1, &old, &ws, true))
                    res->changed++;
            sq_world_set_sky(s->world, ws.day_of_year, ws.hour, ws.latitude_deg, ws.clock_scale,
                             ws.turbidity, ws.irradiance);
        }
        sq_cfg_node_free(s->world_cfg);
        s->world_cfg = copy; /* the same content as far as the world is concerned */
    }
    for (size_t i = 0; i < sq__output_param_count; i++)
        if ((sq__output_params[i].flags & SQ_PARAM_LIVE) &&
            sq_params_first_change(&sq__output_params[i], 1, &s->out, &t->out, true))
            res->changed++;
    sq_params_copy_live(sq__output_params, sq__output_param_count, &s->out, &t->out);
    if (memcmp(&s->camera, &t->camera, sizeof s->camera) != 0 || s->key_count != t->key_count ||
        memcmp(s->keys, t->keys, sizeof s->keys) != 0) {
        s->camera = t->camera;
        memcpy(s->keys, t->keys, sizeof s->keys);
        s->key_count = t->key_count;
        note_camera_places(s, cfg);
        res->changed++;
    }
    for (int i = 0; i < s->layer_count && r == SQ_OK; i++) {
        const sq_phen_plugin *pl = s->layers[i].plugin;
        sq_live_result lr;
        memset(&lr, 0, sizeof lr);
        r = sq_phenomenon_apply_live(s->layers[i].ph, sq_phenomenon_desc_get(t->layers[i].ph),
                                     pl->desc_size, &lr);
        if (r != SQ_OK)
            r = sq__scene_translate_error(pl->params, pl->param_count, s->layers[i].name, r);
        res->changed += lr.changed;
    }
    scratch_free(t);
    return r;
}
