/* scene_geo.c — the georeferenced parts of a scene's world: a DEM terrain (world.terrain.kind:
 * dem) and named polygon areas (world.areas), read through the io layer's loaders
 * (sq_scene_desc.load_dem / load_area), so that this layer never touches files. The DEM's metric
 * CRS becomes the world's; world (x, y) = CRS (easting, northing) − crs_offset_m, with the
 * offset from world.terrain.crs_origin_m or the terrain's centre rounded to 100 m. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/core_internal.h"
#include "scene_internal.h"

/* A path from the scene file, relative to the file's directory (presets: the source tree). */
static void resolve_path(const sq_cfg *cfg, const char *p, char *out, size_t size)
{
    if (p[0] == '/' || !cfg->base_dir[0]) snprintf(out, size, "%s", p);
    else snprintf(out, size, "%s/%s", cfg->base_dir, p);
}

/* Prefixes the loader's message with the scene's source, logs it, returns r. */
static sq_result refail(sq_context *ctx, const sq_cfg *cfg, sq_result r)
{
    char why[1024];
    snprintf(why, sizeof why, "%s", sq_last_error());
    return sq__fail(ctx, r, "scene", "%s: %s", cfg->source, why);
}

sq_result sq__scene_geo_world(sq_context *ctx, const sq_scene_desc *sd,
                              const sq__world_section *ws, const sq__area_item *items,
                              int item_count, sq_world_desc *wd, sq__scene_geo *keep)
{
    const sq_cfg *cfg = sd->cfg;
    memset(keep, 0, sizeof *keep);
    if (ws->terrain_kind == SQ__TERRAIN_CHOICE_DEM) {
        if (!ws->dem[0])
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "scene",
                            "%s: world.terrain.kind = dem needs world.terrain.dem (a raster file "
                            "GDAL reads: GeoTIFF, ESRI ASCII grid, ...)", cfg->source);
        if (!sd->load_dem)
            return sq__fail(ctx, SQ_ERR_UNSUPPORTED, "scene", "%s: DEM terrains need a loader",
                            cfg->source);
        if (ws->roi_count != 0 && ws->roi_count != 4)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "scene",
                            "%s: world.terrain.roi has %d values; expected [xmin, ymin, xmax, "
                            "ymax] in the DEM's CRS", cfg->source, ws->roi_count);
        char path[1024];
        resolve_path(cfg, ws->dem, path, sizeof path);
        sq_dem_desc dd;
        memset(&dd, 0, sizeof dd);
        dd.path = path;
        dd.key = "world.terrain";
        for (int k = 0; k < 4 && ws->roi_count == 4; k++) dd.roi[k] = (double)ws->roi[k];
        dd.crs = ws->crs;
        dd.assign_crs = ws->dem_crs;
        dd.cell_m = (double)ws->cell_m;
        dd.nodata = ws->nodata;
        dd.resampling = ws->resampling;
        sq_result r = sd->load_dem(ctx, &dd, &keep->dem);
        if (r != SQ_OK) return refail(ctx, cfg, r);
        const sq_dem *d = &keep->dem;
        double off[2];
        if (ws->crs_origin_count == 2) {
            off[0] = (double)ws->crs_origin[0];
            off[1] = (double)ws->crs_origin[1];
        } else {
            off[0] = 100.0 * floor((d->x0 + 0.5 * (d->nx - 1) * d->dx) / 100.0 + 0.5);
            off[1] = 100.0 * floor((d->y0 + 0.5 * (d->ny - 1) * d->dy) / 100.0 + 0.5);
        }
        wd->terrain.grid_heights_m = d->heights_m;
        wd->terrain.grid_void = d->void_mask;
        wd->terrain.grid_w = d->nx;
        wd->terrain.grid_h = d->ny;
        wd->terrain.grid_dx_m = (float)d->dx;
        wd->terrain.grid_dy_m = (float)d->dy;
        wd->terrain.origin_m[0] = (float)(d->x0 - off[0]);
        wd->terrain.origin_m[1] = (float)(d->y0 - off[1]);
        wd->terrain.origin_set = true;
        wd->crs_wkt = d->crs_wkt;
        wd->crs_offset_m[0] = off[0];
        wd->crs_offset_m[1] = off[1];
        sq_log(ctx, SQ_LOG_INFO, "scene",
               "terrain from %s: %dx%d samples of %g m, world (0, 0) = (%.1f, %.1f) in %s", path,
               d->nx, d->ny, d->dx, off[0], off[1], d->crs_name);
    }
    if (item_count > 0) {
        if (!sd->load_area)
            return sq__fail(ctx, SQ_ERR_UNSUPPORTED, "scene", "%s: world.areas need a loader",
                            cfg->source);
        if (!wd->crs_wkt || !wd->crs_wkt[0])
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "scene",
                            "%s: world.areas need a georeferenced terrain (world.terrain.kind: "
                            "dem) to place their polygons", cfg->source);
        for (int i = 0; i < item_count; i++) {
            const sq__area_item *it = &items[i];
            char key[64];
            snprintf(key, sizeof key, "world.areas[%d]", i);
            if (!it->name[0])
                return sq__fail(ctx, SQ_ERR_INVALID_ARG, "scene", "%s: %s.name: empty",
                                cfg->source, key);
            if (!it->file[0])
                return sq__fail(ctx, SQ_ERR_INVALID_ARG, "scene", "%s: %s.file: empty",
                                cfg->source, key);
            for (int k = 0; k < i; k++)
                if (strcmp(items[k].name, it->name) == 0)
                    return sq__fail(ctx, SQ_ERR_INVALID_ARG, "scene",
                                    "%s: %s.name = '%s': used by world.areas[%d] too",
                                    cfg->source, key, it->name, k);
            resolve_path(cfg, it->file, keep->paths[i], sizeof keep->paths[i]);
            sq_area_desc ad;
            memset(&ad, 0, sizeof ad);
            ad.path = keep->paths[i];
            ad.key = key;
            ad.layer = it->layer;
            ad.attribute = it->attribute;
            ad.assign_crs = it->crs;
            ad.target_crs_wkt = wd->crs_wkt;
            ad.offset_m[0] = wd->crs_offset_m[0];
            ad.offset_m[1] = wd->crs_offset_m[1];
            sq_result r = sd->load_area(ctx, &ad, &keep->areas[i]);
            keep->area_count = i + 1;
            if (r != SQ_OK) return refail(ctx, cfg, r);
            const sq_area *a = &keep->areas[i];
            sq_world_area *v = &keep->views[i];
            v->name = it->name;
            v->source = keep->paths[i];
            v->feature_count = a->feature_count;
            v->feature_value = a->feature_value;
            v->feature_area_m2 = a->feature_area_m2;
            v->ring_count = a->ring_count;
            v->ring_start = a->ring_start;
            v->ring_feature = a->ring_feature;
            v->xy_m = a->xy_m;
            memcpy(v->bounds, a->bounds, sizeof v->bounds);
            v->area_m2 = a->area_m2;
        }
        wd->areas = keep->views;
        wd->area_count = item_count;
    }
    return SQ_OK;
}

void sq__scene_geo_release(sq_context *ctx, sq__scene_geo *keep)
{
    /* the loaders allocate through ctx (squall/geo.h), so the scene frees with sq_free */
    sq_free(ctx, keep->dem.heights_m);
    sq_free(ctx, keep->dem.void_mask);
    sq_free(ctx, keep->dem.crs_wkt);
    for (int i = 0; i < keep->area_count; i++) {
        sq_area *a = &keep->areas[i];
        sq_free(ctx, a->feature_value);
        sq_free(ctx, a->feature_area_m2);
        sq_free(ctx, a->ring_start);
        sq_free(ctx, a->ring_feature);
        sq_free(ctx, a->xy_m);
    }
    memset(keep, 0, sizeof *keep);
}
