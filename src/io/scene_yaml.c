/* scene_yaml.c — scene files: YAML (libyaml event parser) into the configuration tree, with
 * every node's line and column kept for error messages; presets; heightmap loading for scenes.
 * Anchors/aliases and tags are refused (scene files are plain data). */
#include "sq_config.h"
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <yaml.h>

#include "core/core_internal.h"
#include "io/io_internal.h"
#include "squall/io.h"
#include "squall/scene.h"

#define MAX_DEPTH 64
#define MAX_SCENE_BYTES (4u << 20)

typedef struct frame {
    sq_cfg_node *node;
    char *pending_key; /* map: key waiting for its value */
    int key_line, key_col;
} frame;

/* Whether line (0-based) of text is indented with a tab: YAML allows spaces only, and libyaml's
 * message for it ("found character that cannot start any token") does not say so. */
static bool tab_indented(const char *text, size_t len, size_t line)
{
    size_t i = 0;
    for (size_t l = 0; l < line && i < len; i++)
        if (text[i] == '\n') l++;
    for (; i < len && (text[i] == ' ' || text[i] == '\t'); i++)
        if (text[i] == '\t') return true;
    return false;
}

static sq_result parse_error(sq_context *ctx, const char *source, const yaml_parser_t *p,
                             const char *text, size_t len)
{
    const yaml_mark_t *m = p->problem_mark.line || p->problem_mark.column ? &p->problem_mark
                                                                          : &p->context_mark;
    return sq__fail(ctx, SQ_ERR_PARSE, "scene", "%s:%zu:%zu: malformed YAML: %s%s%s%s", source,
                    m->line + 1, m->column + 1, p->problem ? p->problem : "syntax error",
                    p->context ? " " : "", p->context ? p->context : "",
                    tab_indented(text, len, m->line)
                        ? " (the line is indented with a tab; YAML indents with spaces only)"
                        : "");
}

static sq_result attach(sq_context *ctx, const char *source, frame *top, sq_cfg_node *n,
                        const char *scalar_text, int line, int col, bool *consumed_as_key)
{
    *consumed_as_key = false;
    if (top->node->kind == SQ_CFG_SEQ) {
        sq_cfg_node_append(top->node, n);
        return SQ_OK;
    }
    /* map */
    if (!top->pending_key) {
        if (n->kind != SQ_CFG_SCALAR)
            return sq__fail(ctx, SQ_ERR_PARSE, "scene",
                            "%s:%d:%d: a map key must be a plain value", source, line, col);
        top->pending_key = strdup(scalar_text ? scalar_text : "");
        top->key_line = line;
        top->key_col = col;
        *consumed_as_key = true;
        return SQ_OK;
    }
    for (sq_cfg_node *c = top->node->child; c; c = c->next)
        if (c->key && strcmp(c->key, top->pending_key) == 0)
            return sq__fail(ctx, SQ_ERR_PARSE, "scene", "%s:%d:%d: duplicate key '%s'", source,
                            top->key_line, top->key_col, top->pending_key);
    n->key = top->pending_key;
    n->line = top->key_line;
    n->col = top->key_col;
    top->pending_key = NULL;
    sq_cfg_node_append(top->node, n);
    return SQ_OK;
}

sq_result sq_cfg_parse(sq_context *ctx, const char *text, size_t len, const char *source,
                       sq_cfg **out)
{
    *out = NULL;
    if (!source) source = "<scene>";
    sq_cfg *cfg = NULL;
    sq_result r = sq_cfg_create(&cfg);
    if (r != SQ_OK) return r;
    snprintf(cfg->source, sizeof cfg->source, "%s", source);
    yaml_parser_t p;
    if (!yaml_parser_initialize(&p)) {
        sq_cfg_destroy(cfg);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "scene", "cannot initialise the YAML parser");
    }
    yaml_parser_set_input_string(&p, (const unsigned char *)text, len);
    frame stack[MAX_DEPTH];
    int depth = 0;
    bool done = false, have_root = false;
    while (!done && r == SQ_OK) {
        yaml_event_t ev;
        if (!yaml_parser_parse(&p, &ev)) {
            r = parse_error(ctx, source, &p, text, len);
            break;
        }
        int line = (int)ev.start_mark.line + 1, col = (int)ev.start_mark.column + 1;
        switch (ev.type) {
        case YAML_STREAM_END_EVENT: done = true; break;
        case YAML_DOCUMENT_START_EVENT:
            if (have_root)
                r = sq__fail(ctx, SQ_ERR_PARSE, "scene",
                             "%s:%d:%d: more than one YAML document; a scene is one document",
                             source, line, col);
            break;
        case YAML_ALIAS_EVENT:
            r = sq__fail(ctx, SQ_ERR_PARSE, "scene",
                         "%s:%d:%d: YAML aliases are not supported in scene files", source, line,
                         col);
            break;
        case YAML_SCALAR_EVENT:
        case YAML_MAPPING_START_EVENT:
        case YAML_SEQUENCE_START_EVENT: {
            const yaml_char_t *anchor = ev.type == YAML_SCALAR_EVENT ? ev.data.scalar.anchor
                                        : ev.type == YAML_MAPPING_START_EVENT
                                            ? ev.data.mapping_start.anchor
                                            : ev.data.sequence_start.anchor;
            const yaml_char_t *tag = ev.type == YAML_SCALAR_EVENT ? ev.data.scalar.tag
                                     : ev.type == YAML_MAPPING_START_EVENT
                                         ? ev.data.mapping_start.tag
                                         : ev.data.sequence_start.tag;
            if (anchor) {
                r = sq__fail(ctx, SQ_ERR_PARSE, "scene", "%s:%d:%d: YAML anchors are not supported",
                             source, line, col);
                break;
            }
            if (tag) {
                r = sq__fail(ctx, SQ_ERR_PARSE, "scene",
                             "%s:%d:%d: YAML tags ('%.40s') are not supported in scene files",
                             source, line, col, (const char *)tag);
                break;
            }
            if (ev.type == YAML_SCALAR_EVENT &&
                strlen((const char *)ev.data.scalar.value) != ev.data.scalar.length) {
                r = sq__fail(ctx, SQ_ERR_PARSE, "scene",
                             "%s:%d:%d: a value holds a NUL character (\\0); scene text cannot",
                             source, line, col);
                break;
            }
            if (depth == 0) {
                if (ev.type != YAML_MAPPING_START_EVENT) {
                    r = sq__fail(ctx, SQ_ERR_PARSE, "scene",
                                 "%s:%d:%d: a scene file must be a map of sections (world, camera, "
                                 "layers, output)",
                                 source, line, col);
                    break;
                }
                cfg->root->line = line;
                cfg->root->col = col;
                stack[depth++] = (frame){cfg->root, NULL, 0, 0};
                have_root = true;
                break;
            }
            sq_cfg_kind k = ev.type == YAML_SCALAR_EVENT        ? SQ_CFG_SCALAR
                            : ev.type == YAML_MAPPING_START_EVENT ? SQ_CFG_MAP
                                                                  : SQ_CFG_SEQ;
            const char *val = ev.type == YAML_SCALAR_EVENT ? (const char *)ev.data.scalar.value : NULL;
            sq_cfg_node *n = sq_cfg_node_new(k, NULL, val, line, col);
            if (!n) {
                r = sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "scene", "out of memory");
                break;
            }
            bool as_key = false;
            r = attach(ctx, source, &stack[depth - 1], n, val, line, col, &as_key);
            if (r != SQ_OK || as_key) {
                sq_cfg_node_free(n);
                break;
            }
            if (k != SQ_CFG_SCALAR) {
                if (depth >= MAX_DEPTH) {
                    r = sq__fail(ctx, SQ_ERR_PARSE, "scene", "%s:%d:%d: nesting deeper than %d",
                                 source, line, col, MAX_DEPTH);
                    break;
                }
                stack[depth++] = (frame){n, NULL, 0, 0};
            }
            break;
        }
        case YAML_MAPPING_END_EVENT:
        case YAML_SEQUENCE_END_EVENT:
            if (depth > 0) {
                frame *f = &stack[depth - 1];
                if (f->pending_key) {
                    r = sq__fail(ctx, SQ_ERR_PARSE, "scene", "%s:%d:%d: key '%s' has no value",
                                 source, f->key_line, f->key_col, f->pending_key);
                }
                free(f->pending_key);
                f->pending_key = NULL;
                depth--;
            }
            break;
        default: break;
        }
        yaml_event_delete(&ev);
    }
    for (int i = 0; i < depth; i++) free(stack[i].pending_key);
    yaml_parser_delete(&p);
    if (r == SQ_OK && !have_root)
        r = sq__fail(ctx, SQ_ERR_PARSE, "scene", "%s: empty scene file", source);
    if (r != SQ_OK) {
        sq_cfg_destroy(cfg);
        return r;
    }
    *out = cfg;
    return SQ_OK;
}

sq_result sq_cfg_load_file(sq_context *ctx, const char *path, sq_cfg **out)
{
    *out = NULL;
    FILE *f = NULL;
    sq_result r0 = sq__input_open(ctx, "scene", "scene file", path, &f);
    if (r0 != SQ_OK) return r0;
    struct stat st;
    if (fstat(fileno(f), &st) != 0) {
        fclose(f);
        return sq__fail(ctx, SQ_ERR_IO, "scene", "cannot read scene file '%s'", path);
    }
    if ((uint64_t)st.st_size > MAX_SCENE_BYTES) {
        fclose(f);
        return sq__fail(ctx, SQ_ERR_TOO_LARGE, "scene", "scene file '%s' is %lld bytes; at most %u",
                        path, (long long)st.st_size, MAX_SCENE_BYTES);
    }
    size_t n = (size_t)st.st_size;
    char *buf = (char *)malloc(n + 1);
    if (!buf) {
        fclose(f);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "scene", "out of memory reading '%s'", path);
    }
    size_t got = fread(buf, 1, n, f);
    int err = ferror(f);
    fclose(f);
    if (got != n || err) {
        free(buf);
        return sq__fail(ctx, SQ_ERR_IO, "scene", "cannot read scene file '%s'", path);
    }
    buf[n] = 0;
    sq_result r = sq_cfg_parse(ctx, buf, n, path, out);
    free(buf);
    if (r == SQ_OK) {
        const char *slash = strrchr(path, '/');
        if (slash)
            snprintf((*out)->base_dir, sizeof (*out)->base_dir, "%.*s", (int)(slash - path), path);
        else
            snprintf((*out)->base_dir, sizeof (*out)->base_dir, ".");
    }
    return r;
}

sq_result sq_cfg_load_preset(sq_context *ctx, const char *name, sq_cfg **out)
{
    *out = NULL;
    const char *text = sq_preset_text(name);
    if (!text) {
        char list[512] = "";
        for (int i = 0; i < sq_preset_count(); i++) {
            strncat(list, i ? ", " : "", sizeof list - strlen(list) - 1);
            strncat(list, sq_preset_name(i), sizeof list - strlen(list) - 1);
        }
        return sq__fail(ctx, SQ_ERR_NOT_FOUND, "scene",
                        "'%s' is neither a scene file nor a preset (presets: %s)", name, list);
    }
    char src[128];
    snprintf(src, sizeof src, "preset %s", name);
    sq_result r = sq_cfg_parse(ctx, text, strlen(text), src, out);
    /* data files a preset names (a DEM, release polygons) are relative to the source tree */
    if (r == SQ_OK) snprintf((*out)->base_dir, sizeof (*out)->base_dir, "%s", SQ_SOURCE_DIR);
    return r;
}

sq_result sq_cfg_load(sq_context *ctx, const char *file_or_preset, sq_cfg **out)
{
    struct stat st;
    size_t n = strlen(file_or_preset);
    bool yaml_ext = (n > 5 && strcmp(file_or_preset + n - 5, ".yaml") == 0) ||
                    (n > 4 && strcmp(file_or_preset + n - 4, ".yml") == 0);
    if (stat(file_or_preset, &st) == 0 || yaml_ext || strchr(file_or_preset, '/'))
        return sq_cfg_load_file(ctx, file_or_preset, out);
    return sq_cfg_load_preset(ctx, file_or_preset, out);
}

sq_result sq_scene_heightmap_loader(sq_context *ctx, const char *path, uint16_t **out, int *width,
                                    int *height)
{
    return sq_png_read_heightmap16(ctx, path, 8192 * 8192, out, width, height);
}
