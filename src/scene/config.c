/* config.c — the configuration tree: building, lookup, `--set path=value` overrides, YAML
 * output, and the built-in presets. */
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/core_internal.h"
#include "squall/scene.h"

typedef struct {
    const char *name;
    const char *text;
} sq__embedded_file;
extern const sq__embedded_file sq__preset_files[];
extern const int sq__preset_count;

static char *dupstr(const char *s)
{
    if (!s) return NULL;
    size_t n = strlen(s) + 1;
    char *d = (char *)malloc(n);
    if (d) memcpy(d, s, n);
    return d;
}

sq_result sq_cfg_create(sq_cfg **out)
{
    sq_cfg *c = (sq_cfg *)calloc(1, sizeof *c);
    if (!c) return sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory");
    c->root = sq_cfg_node_new(SQ_CFG_MAP, NULL, NULL, 0, 0);
    if (!c->root) {
        free(c);
        return sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory");
    }
    *out = c;
    return SQ_OK;
}

void sq_cfg_destroy(sq_cfg *cfg)
{
    if (!cfg) return;
    sq_cfg_node_free(cfg->root);
    free(cfg);
}

sq_cfg_node *sq_cfg_node_new(sq_cfg_kind kind, const char *key, const char *value, int line,
                             int col)
{
    sq_cfg_node *n = (sq_cfg_node *)calloc(1, sizeof *n);
    if (!n) return NULL;
    n->kind = kind;
    n->key = dupstr(key);
    n->value = dupstr(value);
    n->line = line;
    n->col = col;
    return n;
}

void sq_cfg_node_free(sq_cfg_node *n)
{
    while (n) {
        sq_cfg_node *next = n->next;
        sq_cfg_node_free(n->child);
        free(n->key);
        free(n->value);
        free(n);
        n = next;
    }
}

void sq_cfg_node_append(sq_cfg_node *parent, sq_cfg_node *child)
{
    if (!parent || !child) return;
    sq_cfg_node **p = &parent->child;
    while (*p) p = &(*p)->next;
    *p = child;
}

sq_cfg_node *sq_cfg_get(const sq_cfg_node *map, const char *key)
{
    if (!map || map->kind != SQ_CFG_MAP) return NULL;
    for (sq_cfg_node *c = map->child; c; c = c->next)
        if (c->key && strcmp(c->key, key) == 0) return c;
    return NULL;
}

/* Finds element of a sequence by index, or (for maps inside) by name/type field. */
static sq_cfg_node *seq_find(sq_cfg_node *seq, const char *part)
{
    char *end = NULL;
    long idx = strtol(part, &end, 10);
    int i = 0;
    if (*part && !*end) {
        for (sq_cfg_node *c = seq->child; c; c = c->next, i++)
            if (i == idx) return c;
        return NULL;
    }
    for (sq_cfg_node *c = seq->child; c; c = c->next) {
        sq_cfg_node *nm = sq_cfg_get(c, "name");
        if (nm && nm->value && strcmp(nm->value, part) == 0) return c;
    }
    for (sq_cfg_node *c = seq->child; c; c = c->next) {
        sq_cfg_node *ty = sq_cfg_get(c, "type");
        if (ty && ty->value && strcmp(ty->value, part) == 0) return c;
    }
    return NULL;
}

sq_result sq_cfg_set(sq_cfg *cfg, const char *assignment)
{
    const char *eq = assignment ? strchr(assignment, '=') : NULL;
    if (!eq || eq == assignment)
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "--set '%s': expected path.to.key=value (e.g. output.fps=30)",
                             assignment ? assignment : "");
    char path[512];
    size_t plen = (size_t)(eq - assignment);
    if (plen >= sizeof path) return sq__set_error(SQ_ERR_INVALID_ARG, "--set: path too long");
    memcpy(path, assignment, plen);
    path[plen] = 0;
    const char *value = eq + 1;
    sq_cfg_node *node = cfg->root;
    char *save = NULL;
    char walked[512] = "";
    for (char *part = strtok_r(path, ".", &save); part; part = strtok_r(NULL, ".", &save)) {
        char *next_part = save && *save ? save : NULL;
        if (walked[0]) strncat(walked, ".", sizeof walked - strlen(walked) - 1);
        strncat(walked, part, sizeof walked - strlen(walked) - 1);
        sq_cfg_node *child = NULL;
        if (node->kind == SQ_CFG_SEQ) {
            child = seq_find(node, part);
            if (!child)
                return sq__set_error(SQ_ERR_NOT_FOUND,
                                     "--set %s: no element '%s' in '%s' (use an index, or a "
                                     "layer's name or type)",
                                     assignment, part, walked);
        } else if (node->kind == SQ_CFG_MAP) {
            child = sq_cfg_get(node, part);
            if (!child) {
                child = sq_cfg_node_new(next_part ? SQ_CFG_MAP : SQ_CFG_SCALAR, part, NULL, 0, 0);
                if (!child) return sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory");
                sq_cfg_node_append(node, child);
            }
        } else {
            return sq__set_error(SQ_ERR_INVALID_ARG, "--set %s: '%s' is a value, not a section",
                                 assignment, walked);
        }
        node = child;
    }
    /* replace the node's content with the scalar (or a flow list "[a, b]" kept as text) */
    sq_cfg_node_free(node->child);
    node->child = NULL;
    node->kind = SQ_CFG_SCALAR;
    free(node->value);
    node->value = dupstr(value);
    node->line = node->col = 0;
    return SQ_OK;
}

/* ---- YAML output ------------------------------------------------------------------------- */
typedef struct {
    char *buf;
    size_t len, cap;
} strbuf;

static void sb_put(strbuf *b, const char *s)
{
    size_t n = strlen(s);
    if (b->len + n + 1 > b->cap) {
        size_t cap = (b->cap ? b->cap * 2 : 1024) + n;
        char *nb = (char *)realloc(b->buf, cap);
        if (!nb) return;
        b->buf = nb;
        b->cap = cap;
    }
    memcpy(b->buf + b->len, s, n + 1);
    b->len += n;
}

static void sb_indent(strbuf *b, int depth)
{
    for (int i = 0; i < depth; i++) sb_put(b, "  ");
}

static bool needs_quotes(const char *v)
{
    if (!*v) return true;
    if (v[0] == '[') return false;
    for (const char *p = v; *p; p++)
        if (*p == ':' || *p == '#' || *p == '\n' || *p == '"' || *p == '\'') return true;
    return isspace((unsigned char)v[0]) || v[0] == '-' ? !isdigit((unsigned char)v[1]) : false;
}

static void put_scalar(strbuf *b, const char *v)
{
    if (!v) v = "";
    if (needs_quotes(v)) {
        sb_put(b, "\"");
        for (const char *p = v; *p; p++) {
            char c[3] = {*p, 0, 0};
            if (*p == '"' || *p == '\\') {
                c[0] = '\\';
                c[1] = *p;
            }
            sb_put(b, c);
        }
        sb_put(b, "\"");
    } else {
        sb_put(b, v);
    }
}

static void emit(strbuf *b, const sq_cfg_node *n, int depth, bool in_seq_first);

static void emit_children(strbuf *b, const sq_cfg_node *n, int depth)
{
    for (const sq_cfg_node *c = n->child; c; c = c->next) emit(b, c, depth, false);
}

static void emit(strbuf *b, const sq_cfg_node *n, int depth, bool inline_first)
{
    (void)inline_first;
    sb_indent(b, depth);
    if (n->key) {
        put_scalar(b, n->key);
        sb_put(b, ":");
    } else {
        sb_put(b, "-");
    }
    if (n->kind == SQ_CFG_SCALAR) {
        sb_put(b, " ");
        put_scalar(b, n->value);
        sb_put(b, "\n");
    } else if (!n->child) {
        sb_put(b, n->kind == SQ_CFG_MAP ? " {}\n" : " []\n");
    } else {
        sb_put(b, "\n");
        emit_children(b, n, depth + 1);
    }
}

char *sq_cfg_to_yaml(const sq_cfg *cfg)
{
    strbuf b = {0};
    sb_put(&b, "");
    if (cfg && cfg->root) emit_children(&b, cfg->root, 0);
    return b.buf;
}

/* ---- presets ------------------------------------------------------------------------------ */
int sq_preset_count(void) { return sq__preset_count; }

const char *sq_preset_name(int i)
{
    return i >= 0 && i < sq__preset_count ? sq__preset_files[i].name : NULL;
}

const char *sq_preset_text(const char *name)
{
    for (int i = 0; name && i < sq__preset_count; i++)
        if (strcmp(sq__preset_files[i].name, name) == 0) return sq__preset_files[i].text;
    return NULL;
}

const char *sq_preset_default(void)
{
    if (sq_preset_text("desert-sandstorm") && sq_plugin_find("sandstorm"))
        return "desert-sandstorm";
    return "terrain-flight";
}
