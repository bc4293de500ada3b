/* test_phenomenon.c — the generic phenomenon handle (squall/phenomenon.h): created from a typed
 * desc and from "key=value" settings, stepped, read through named fields with units and grid
 * geometry, metrics and drawables; the dust field read through the handle holds the dust mass
 * the typed budget reports (bookkeeping checked, not a printed value); error messages name the
 * C desc and key; a scene's layers are the same handles and the scene phrases a layer's refusal
 * with the file position of the key the rule names. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sq_config.h"
#include "sq_test.h"
#include "squall/io.h"
#include "squall/phenomenon.h"
#include "squall/sandstorm.h"
#include "squall/scene.h"

static sq_context *mkctx(void)
{
    sq_context_desc cd = {0};
    cd.threads = 2;
    cd.log_level = SQ_LOG_NONE;
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    return ctx;
}

static sq_world *flat_world(sq_context *ctx, float size_m)
{
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_FLAT;
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = size_m;
    wd.terrain.resolution[0] = wd.terrain.resolution[1] = 33;
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &wd, &w));
    return w;
}

#if SQ_HAVE_SANDSTORM
/* A small desert sandstorm with dust flowing in: typed desc through the generic handle. */
static sq_sandstorm_desc small_storm(void)
{
    sq_sandstorm_desc d;
    memset(&d, 0, sizeof d);
    d.cells[0] = 16;
    d.cells[1] = 16;
    d.cells[2] = 8;
    d.cell_size_m = 50.0;
    d.inflow_dust_kg_m3 = 2e-3;
    d.bins = 2;
    return d;
}

SQ_TEST(sandstorm_fields_metrics_drawables)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx, 2000.0f);
    const sq_sandstorm_desc sd = small_storm();
    sq_phenomenon_desc pd = {0};
    pd.type = "sandstorm";
    pd.name = "storm";
    pd.typed_desc = &sd;
    pd.typed_desc_size = sizeof sd;
    sq_phenomenon *p = NULL;
    SQ_CHECK_OK(sq_phenomenon_create(ctx, &pd, w, &p));
    if (!p) goto done;
    SQ_CHECK(strcmp(sq_phenomenon_type(p), "sandstorm") == 0);
    SQ_CHECK(strcmp(sq_phenomenon_name(p), "storm") == 0);
    SQ_CHECK(sq_phenomenon_memory_bytes(p) > 0);
    sq_sandstorm *typed = (sq_sandstorm *)sq_phenomenon_typed(p, "sandstorm");
    SQ_CHECK(typed != NULL);
    SQ_CHECK(sq_phenomenon_typed(p, "snowdrift") == NULL);
    const sq_sandstorm_desc *resolved = (const sq_sandstorm_desc *)sq_phenomenon_desc_get(p);
    SQ_CHECK(resolved->cells[0] == 16 && resolved->sigma_g > 1.0); /* zero fields resolved */

    for (int k = 0; k < 5; k++) SQ_CHECK_OK(sq_phenomenon_step(p, 2.0));
    SQ_CHECK_NEAR(sq_phenomenon_time(p), 10.0, 1e-12);

    sq_named_field f;
    SQ_CHECK_OK(sq_phenomenon_field_find(p, "dust_mass_concentration", &f));
    SQ_CHECK(strcmp(f.units, "kg m-3") == 0);
    SQ_CHECK(f.nx == 16 && f.ny == 16 && f.nz == 8);
    SQ_CHECK_NEAR(f.spacing_m.x, 50.0, 1e-6);
    /* cell centres: the domain is centred on the origin, the first cell centre half a cell in */
    SQ_CHECK_NEAR(f.origin_m.x, -400.0 + 25.0, 1e-3);
    double mass = 0.0;
    bool finite = true;
    for (size_t c = 0; c < (size_t)f.nx * f.ny * f.nz; c++) {
        finite = finite && isfinite(f.data[c]) && f.data[c] >= 0.0f;
        mass += f.data[c];
    }
    mass *= (double)f.spacing_m.x * f.spacing_m.y * f.spacing_m.z;
    sq_sandstorm_budget b;
    sq_sandstorm_get_budget(typed, &b);
    printf("dust through the handle: %.6g kg; typed budget: suspended %.6g kg\n", mass,
           b.suspended_kg);
    SQ_CHECK(finite);
    SQ_CHECK(b.suspended_kg > 1.0); /* dust came in */
    SQ_CHECK_REL(mass, b.suspended_kg, 1e-4);

    /* every field has a name, units and data; index and name agree */
    const int nf = sq_phenomenon_field_count(p);
    SQ_CHECK(nf >= 5);
    for (int i = 0; i < nf; i++) {
        sq_named_field a, bb;
        SQ_CHECK_OK(sq_phenomenon_field(p, i, &a));
        SQ_CHECK(a.name && a.units && a.data && a.nx > 0);
        SQ_CHECK_OK(sq_phenomenon_field_find(p, a.name, &bb));
        SQ_CHECK(bb.data == a.data);
    }
    SQ_CHECK(sq_phenomenon_field(p, nf, &f) == SQ_ERR_NOT_FOUND);
    SQ_CHECK(sq_phenomenon_field_find(p, "dust", &f) == SQ_ERR_NOT_FOUND);
    SQ_CHECK(strstr(sq_last_error(), "dust_mass_concentration") != NULL); /* lists the names */

    const int nm = sq_phenomenon_metric_count(p);
    SQ_CHECK(nm > 0);
    bool vis = false;
    for (int i = 0; i < nm; i++) {
        sq_metric m;
        SQ_CHECK_OK(sq_phenomenon_metric(p, i, &m));
        SQ_CHECK(m.name && m.unit);
        if (strstr(m.name, "visibility") && strcmp(m.unit, "m") == 0 && m.value > 0.0) vis = true;
    }
    SQ_CHECK(vis);
    sq_drawable dr[8];
    const int nd = sq_phenomenon_drawables(p, dr, 8);
    SQ_CHECK(nd >= 1 && dr[0].kind == SQ_DRAWABLE_VOLUME);
done:
    sq_phenomenon_destroy(p);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* Settings through the table, and every refusal naming sq_<type>_desc.<key>. */
SQ_TEST(settings_and_messages)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx, 2000.0f);
    sq_phenomenon *p = NULL;
    sq_phenomenon_desc pd = {0};
    pd.type = "sandstorm";
    const char *ok[] = {"domain.nx=8", "domain.ny=8", "domain.nz=4", "domain.cell_size_m=100",
                        "dust.bins=1"};
    pd.settings = ok;
    pd.setting_count = 5;
    SQ_CHECK_OK(sq_phenomenon_create(ctx, &pd, w, &p));
    if (p) {
        const sq_sandstorm_desc *d = (const sq_sandstorm_desc *)sq_phenomenon_desc_get(p);
        SQ_CHECK(d->cells[0] == 8 && d->cells[2] == 4 && d->bins == 1);
        SQ_CHECK_NEAR(d->cell_size_m, 100.0, 0.0);
        SQ_CHECK_OK(sq_phenomenon_step(p, 1.0));
        sq_phenomenon_destroy(p);
        p = NULL;
    }
    const char *typo[] = {"dust.sigma=2"};
    pd.settings = typo;
    pd.setting_count = 1;
    SQ_CHECK(sq_phenomenon_create(ctx, &pd, w, &p) == SQ_ERR_NOT_FOUND && !p);
    SQ_CHECK(strstr(sq_last_error(), "sq_phenomenon_desc.settings[0]: unknown key "
                                     "'sq_sandstorm_desc.dust.sigma'; did you mean "
                                     "'sq_sandstorm_desc.dust.sigma_g'?") != NULL);
    const char *range[] = {"dust.bins=0"};
    pd.settings = range;
    SQ_CHECK(sq_phenomenon_create(ctx, &pd, w, &p) == SQ_ERR_INVALID_ARG && !p);
    SQ_CHECK(strstr(sq_last_error(), "sq_sandstorm_desc.dust.bins = 0") != NULL);
    const char *noeq[] = {"dust.bins"};
    pd.settings = noeq;
    SQ_CHECK(sq_phenomenon_create(ctx, &pd, w, &p) == SQ_ERR_INVALID_ARG && !p);
    /* a rule of the phenomenon, from a typed desc */
    sq_sandstorm_desc sd = small_storm();
    sd.n_imag = -0.1;
    pd.settings = NULL;
    pd.setting_count = 0;
    pd.typed_desc = &sd;
    pd.typed_desc_size = sizeof sd;
    SQ_CHECK(sq_phenomenon_create(ctx, &pd, w, &p) == SQ_ERR_INVALID_ARG && !p);
    SQ_CHECK(strstr(sq_last_error(), "sq_sandstorm_desc.dust.n_imag = -0.1") != NULL);
    pd.typed_desc_size = sizeof sd - 8;
    SQ_CHECK(sq_phenomenon_create(ctx, &pd, w, &p) == SQ_ERR_INVALID_ARG && !p);
    SQ_CHECK(strstr(sq_last_error(), "typed_desc_size") != NULL);
    pd.type = "tornado";
    SQ_CHECK(sq_phenomenon_create(ctx, &pd, w, &p) == SQ_ERR_NOT_FOUND && !p);
    SQ_CHECK(strstr(sq_last_error(), "available: sandstorm") != NULL);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* A scene's layer is a handle; a layer's refusal comes back as file:line: layers.<name>.<key>. */
SQ_TEST(scene_layers_are_handles)
{
    sq_context *ctx = mkctx();
    const char *yaml = "name: t\n"
                       "world:\n"
                       "  terrain: {kind: flat, size_m: [2000, 2000], resolution: [33, 33]}\n"
                       "layers:\n"
                       "  - type: sandstorm\n"
                       "    name: haboob\n"
                       "    domain: {nx: 8, ny: 8, nz: 4, cell_size_m: 100}\n"
                       "    dust: {bins: 1}\n"
                       "    wave:\n"
                       "      kx_per_m: BADX\n"
                       "output: {width: 32, height: 16, fps: 4, frames: 2}\n";
    char text[1024];
    snprintf(text, sizeof text, "%s", yaml);
    char *bad = strstr(text, "BADX");
    /* |k| h = 5 > pi/2: the wave aliases on the grid, the phenomenon's rule (in table range) */
    memcpy(bad, "0.05", 4);
    sq_cfg *cfg = NULL;
    SQ_CHECK_OK(sq_cfg_parse(ctx, text, strlen(text), "t.yaml", &cfg));
    sq_scene_desc sdsc = {.cfg = cfg};
    sq_scene *s = NULL;
    sq_result r = sq_scene_create(ctx, &sdsc, &s);
    printf("scene refusal: %s\n", sq_last_error());
    SQ_CHECK(r == SQ_ERR_INVALID_ARG && !s);
    SQ_CHECK(strstr(sq_last_error(), "t.yaml:10:") != NULL); /* the line of kx_per_m */
    SQ_CHECK(strstr(sq_last_error(), "layers.haboob.wave.kx_per_m, layers.haboob.wave.ky_per_m = (0.05, 0)") != NULL);
    SQ_CHECK(strstr(sq_last_error(), "sq_sandstorm_desc") == NULL);
    sq_cfg_destroy(cfg);
    cfg = NULL;

    memcpy(bad, "0.00", 4);
    SQ_CHECK_OK(sq_cfg_parse(ctx, text, strlen(text), "t.yaml", &cfg));
    sdsc.cfg = cfg;
    SQ_CHECK_OK(sq_scene_create(ctx, &sdsc, &s));
    if (s) {
        SQ_CHECK(sq_scene_layer_count(s) == 1);
        sq_phenomenon *p = sq_scene_layer(s, 0);
        SQ_CHECK(p && strcmp(sq_phenomenon_name(p), "haboob") == 0);
        SQ_CHECK(sq_scene_layer(s, 1) == NULL);
        SQ_CHECK_OK(sq_scene_step(s, 0.5));
        SQ_CHECK_NEAR(sq_phenomenon_time(p), sq_scene_time(s), 1e-12);
        sq_named_field f;
        SQ_CHECK_OK(sq_phenomenon_field_find(p, "dust_mass_concentration", &f));
        SQ_CHECK(f.nx == 8 && f.nz == 4);
        /* the scene's metrics are the handle's, prefixed with the layer name */
        sq_metric m[64];
        const int n = sq_scene_metrics(s, m, 64);
        SQ_CHECK(n == sq_phenomenon_metric_count(p));
        if (n > 0) SQ_CHECK(strncmp(m[0].name, "haboob.", 7) == 0);
    }
    sq_scene_destroy(s);
    sq_cfg_destroy(cfg);
    sq_context_destroy(ctx);
}
#endif

/* Arguments refused without a crash. */
SQ_TEST(null_arguments)
{
    sq_context *ctx = mkctx();
    sq_phenomenon *p = (sq_phenomenon *)1;
    SQ_CHECK(sq_phenomenon_create(ctx, NULL, NULL, &p) == SQ_ERR_INVALID_ARG && p == NULL);
    SQ_CHECK(sq_phenomenon_field_count(NULL) == 0);
    SQ_CHECK(sq_phenomenon_metric_count(NULL) == 0);
    SQ_CHECK(sq_phenomenon_step(NULL, 1.0) == SQ_ERR_INVALID_ARG);
    sq_phenomenon_destroy(NULL);
    sq_context_destroy(ctx);
}
