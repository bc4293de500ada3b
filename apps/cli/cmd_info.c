/* cmd_info.c — `squall info`, `squall scenes`, `squall scene show`, `squall params`. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "commands.h"
#include "squall/io.h"
#include "squall/render.h"
#include "squall/scene.h"

int sq_cmd_info(int argc, char **argv)
{
    if (sq_cli_flag(argc, argv, "--help")) {
        printf("usage: squall info [--json] [--no-gl]\n\n"
               "Prints the version, the OpenGL vendor/renderer/version of the headless context, the\n"
               "worker thread count, compiled-in features, phenomena and presets.\n");
        return SQ_EXIT_OK;
    }
    sq_context *ctx = NULL;
    if (sq_cli_context(argc, argv, &ctx) != SQ_OK) return SQ_EXIT_USAGE;
    sq_render_info gi;
    memset(&gi, 0, sizeof gi);
    sq_result gr = SQ_ERR_UNSUPPORTED;
    char gl_err[512] = "disabled (--no-gl)";
    if (!sq_cli_flag(argc, argv, "--no-gl")) {
        gr = sq_gl_probe(ctx, &gi);
        if (gr != SQ_OK) snprintf(gl_err, sizeof gl_err, "%s", sq_last_error());
    }
    char phen[256] = "", presets[512] = "";
    for (int i = 0; i < sq_plugin_count(); i++) {
        strncat(phen, i ? " " : "", sizeof phen - strlen(phen) - 1);
        strncat(phen, sq_plugin_at(i)->name, sizeof phen - strlen(phen) - 1);
    }
    for (int i = 0; i < sq_preset_count(); i++) {
        strncat(presets, i ? " " : "", sizeof presets - strlen(presets) - 1);
        strncat(presets, sq_preset_name(i), sizeof presets - strlen(presets) - 1);
    }
    if (sq_cli_flag(argc, argv, "--json")) {
        sq_json j;
        sq_json_begin(&j);
        sq_json_str(&j, "version", sq_version());
        sq_json_int(&j, "threads", sq_context_threads(ctx));
        sq_json_str(&j, "features", sq_features());
        sq_json_str(&j, "phenomena", phen);
        sq_json_str(&j, "presets", presets);
        if (gr == SQ_OK) {
            sq_json_str(&j, "gl_vendor", gi.gl_vendor);
            sq_json_str(&j, "gl_renderer", gi.gl_renderer);
            sq_json_str(&j, "gl_version", gi.gl_version);
            sq_json_int(&j, "gl_max_3d_texture_size", gi.max_3d_texture_size);
        } else {
            sq_json_str(&j, "gl_error", gl_err);
        }
        sq_json_end(&j, stdout);
    } else {
        printf("squall %s\n", sq_version());
        if (gr == SQ_OK) {
            printf("gl vendor:    %s\n", gi.gl_vendor);
            printf("gl renderer:  %s\n", gi.gl_renderer);
            printf("gl version:   %s (GLSL %s)\n", gi.gl_version, gi.glsl_version);
            printf("gl limits:    texture %d, 3D texture %d, viewport %dx%d\n", gi.max_texture_size,
                   gi.max_3d_texture_size, gi.max_viewport[0], gi.max_viewport[1]);
        } else {
            printf("gl:           not available: %s\n", gl_err);
        }
        printf("threads:      %d\n", sq_context_threads(ctx));
        printf("features:     %s\n", sq_features());
        printf("phenomena:    %s\n", phen[0] ? phen : "(none)");
        printf("presets:      %s\n", presets);
        printf("default demo: %s\n", sq_preset_default());
    }
    sq_context_destroy(ctx);
    return SQ_EXIT_OK;
}

int sq_cmd_scenes(int argc, char **argv)
{
    if (sq_cli_flag(argc, argv, "--help")) {
        printf("usage: squall scenes\n\nLists the built-in presets. `squall scene show NAME` prints "
               "one as YAML;\n`squall render NAME` renders it.\n");
        return SQ_EXIT_OK;
    }
    for (int i = 0; i < sq_preset_count(); i++) {
        const char *name = sq_preset_name(i);
        const char *text = sq_preset_text(name);
        /* the description line of the preset */
        const char *d = strstr(text, "\ndescription:");
        char desc[160] = "";
        if (!d && strncmp(text, "description:", 12) == 0) d = text - 1;
        if (d) {
            d += 13;
            while (*d == ' ' || *d == '"') d++;
            size_t n = strcspn(d, "\"\n");
            if (n >= sizeof desc) n = sizeof desc - 1;
            memcpy(desc, d, n);
            desc[n] = 0;
        }
        printf("%-20s %s%s\n", name, desc, strcmp(name, sq_preset_default()) == 0 ? " (default)" : "");
    }
    return SQ_EXIT_OK;
}

int sq_cmd_scene(int argc, char **argv)
{
    if (argc < 2 || sq_cli_flag(argc, argv, "--help")) {
        printf("usage: squall scene show NAME\n\nPrints a built-in preset as YAML, to copy and "
               "edit:\n  squall scene show desert-sandstorm > storm.yaml && squall render "
               "storm.yaml\n");
        return argc < 2 ? SQ_EXIT_USAGE : SQ_EXIT_OK;
    }
    if (strcmp(argv[1], "show") != 0 || argc < 3) {
        sq_cli_error("usage: squall scene show NAME (see squall scenes)");
        return SQ_EXIT_USAGE;
    }
    const char *text = sq_preset_text(argv[2]);
    if (!text) {
        sq_cli_error("no preset named '%s' (see squall scenes)", argv[2]);
        return SQ_EXIT_USAGE;
    }
    fputs(text, stdout);
    return SQ_EXIT_OK;
}

/* "live" (applies to a running scene: squall view applies it at once) or "rebuild" (the scene
 * restarts): the library's rule, the one the viewer's panel follows. */
static const char *change_of(const sq_param *p, const sq_phen_plugin *plugin)
{
    return sq_param_live(p, plugin) ? "live" : "rebuild";
}

static void print_markdown(const sq_param *t, size_t n, const void *desc,
                           const sq_phen_plugin *plugin)
{
    printf("| key | unit | default | range | change | meaning |\n|---|---|---|---|---|---|\n");
    for (size_t i = 0; i < n; i++) {
        const sq_param *p = &t[i];
        char v[512], range[128] = "";
        sq_params_format(p, desc, v, sizeof v);
        if (p->type == SQ_PARAM_ENUM) {
            snprintf(range, sizeof range, "%s", p->choices);
            for (char *c = range; *c; c++)
                if (*c == '|') *c = '/';
        } else if (p->type == SQ_PARAM_BOOL)
            snprintf(range, sizeof range, "true/false");
        else if (!(p->min == 0 && p->max == 0) && p->type != SQ_PARAM_STRING)
            snprintf(range, sizeof range, "%g … %g", p->min, p->max);
        printf("| `%s` | %s | `%s` | %s | %s | %s |\n", p->key,
               p->unit && *p->unit && strcmp(p->unit, "1") ? p->unit : "–", v,
               range[0] ? range : "–", change_of(p, plugin), p->doc ? p->doc : "");
    }
}

static bool g_markdown;

static void print_table(const char *title, const sq_param *t, size_t n, size_t desc_size, bool yaml,
                        const sq_phen_plugin *plugin)
{
    char *desc = (char *)calloc(1, desc_size > (1u << 16) ? desc_size : (1u << 16));
    if (!desc) return;
    sq_params_defaults(t, n, desc);
    if (g_markdown) {
        print_markdown(t, n, desc, plugin);
        free(desc);
        return;
    }
    if (yaml) {
        printf("# %s: every key with its default\n", title);
        for (size_t i = 0; i < n; i++) {
            char v[512];
            sq_params_format(&t[i], desc, v, sizeof v);
            printf("%s: %s    # %s%s%s%s\n", t[i].key, v, t[i].unit && *t[i].unit && strcmp(t[i].unit, "1") ? "[" : "",
                   t[i].unit && *t[i].unit && strcmp(t[i].unit, "1") ? t[i].unit : "",
                   t[i].unit && *t[i].unit && strcmp(t[i].unit, "1") ? "] " : "",
                   change_of(&t[i], plugin));
            printf("    # %s\n", t[i].doc ? t[i].doc : "");
        }
        free(desc);
        return;
    }
    printf("%s\n", title);
    for (size_t i = 0; i < n; i++) {
        const sq_param *p = &t[i];
        char v[512], range[96] = "";
        sq_params_format(p, desc, v, sizeof v);
        if (p->type == SQ_PARAM_ENUM)
            snprintf(range, sizeof range, "%s", p->choices);
        else if (p->type == SQ_PARAM_BOOL)
            snprintf(range, sizeof range, "true|false");
        else if (!(p->min == 0 && p->max == 0) && p->type != SQ_PARAM_STRING)
            snprintf(range, sizeof range, "[%g, %g]", p->min, p->max);
        const char *unit = p->unit && *p->unit ? p->unit : "-";
        printf("  %-32s %-8s default %-14s range %-20s %s\n", p->key, unit, v,
               range[0] ? range : "-", change_of(p, plugin));
        printf("      %s\n", p->doc ? p->doc : "");
    }
    free(desc);
}

int sq_cmd_params(int argc, char **argv)
{
    if (sq_cli_flag(argc, argv, "--help")) {
        printf("usage: squall params [LAYER|world|obstacle|mesh|area|camera|camera-key|output] [--yaml|--markdown]\n\n"
               "Prints every parameter with its unit, default, range and meaning. Scene files use\n"
               "these keys (nested maps or dotted keys); --set layers.NAME.KEY=VALUE overrides.\n"
               "The last column says how a change applies in `squall view`: live (to the running\n"
               "scene, at once; the clock goes on) or rebuild (the scene is made again and\n"
               "restarts from time 0). The viewer's panel follows the same rule.\n");
        return SQ_EXIT_OK;
    }
    bool yaml = sq_cli_flag(argc, argv, "--yaml");
    g_markdown = sq_cli_flag(argc, argv, "--markdown");
    const char *what = argc > 1 && argv[1][0] != '-' ? argv[1] : NULL;
    if (!what) {
        printf("sections: world obstacle mesh area camera camera-key output\nlayers:  ");
        for (int i = 0; i < sq_plugin_count(); i++) printf("%s ", sq_plugin_at(i)->name);
        printf("\n\nusage: squall params NAME\n");
        return SQ_EXIT_OK;
    }
    size_t n = 0;
    const sq_param *t = sq_scene_section_params(what, &n);
    if (t) {
        print_table(what, t, n, 0, yaml, NULL);
        return SQ_EXIT_OK;
    }
    const sq_phen_plugin *p = sq_plugin_find(what);
    if (!p) {
        sq_cli_error("no layer or section named '%s' (see squall params)", what);
        return SQ_EXIT_USAGE;
    }
    char title[256];
    snprintf(title, sizeof title, "%s — %s", p->name, p->summary);
    print_table(title, p->params, p->param_count, p->desc_size, yaml, p);
    return SQ_EXIT_OK;
}
