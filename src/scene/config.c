/* config.c — the configuration tree: building, lookup, `--set path=value` overrides, YAML
 * output, and the built-in presets. */
#include <ctype.h>
#include <stdbool.h>
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

/* Strict UTF-8 (no overlong forms, no surrogates, at most U+10FFFF). Returns the byte offset
 * of the first invalid sequence, or -1 when s is valid. */
static long utf8_invalid_at(const char *s)
{
    const unsigned char *p = (const unsigned char *)s, *b = p;
    while (*p) {
        const unsigned c = *p;
        int n;
        unsigned cp;
        if (c < 0x80) {
            p++;
            continue;
        } else if (c >= 0xC2 && c <= 0xDF) {
            n = 1;
            cp = c & 0x1Fu;
        } else if (c >= 0xE0 && c <= 0xEF) {
            n = 2;
            cp = c & 0x0Fu;
        } else if (c >= 0xF0 && c <= 0xF4) {
            n = 3;
            cp = c & 0x07u;
        } else {
            return (long)(p - b);
        }
        for (int k = 1; k <= n; k++) {
            if ((p[k] & 0xC0u) != 0x80u) return (long)(p - b);
            cp = (cp << 6) | (p[k] & 0x3Fu);
        }
        if ((n == 2 && cp < 0x800) || (n == 3 && cp < 0x10000) || cp > 0x10FFFF ||
            (cp >= 0xD800 && cp <= 0xDFFF))
            return (long)(p - b);
        p += n + 1;
    }
    return -1;
}

bool sq_cfg_text_ok(const char *text)
{
    if (!text || utf8_invalid_at(text) >= 0) return false;
    for (const unsigned char *p = (const unsigned char *)text; *p; p++)
        if (*p < 0x20 || *p == 0x7F) return false;
    return true;
}

/* The --set text must be what a scene file could hold: UTF-8 without control characters. */
sq_result sq_cfg_check_text(const char *what, const char *text)
{
    const long bad = utf8_invalid_at(text);
    if (bad >= 0)
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "%s: byte %ld (0x%02X) is not valid UTF-8; keys and values are "
                             "UTF-8 text",
                             what, bad + 1, (unsigned)(unsigned char)text[bad]);
    for (const unsigned char *p = (const unsigned char *)text; *p; p++)
        if (*p < 0x20 || *p == 0x7F)
            return sq__set_error(SQ_ERR_INVALID_ARG,
                                 "%s: byte %ld is a control character (0x%02X); keys and values "
                                 "are printable text",
                                 what, (long)(p - (const unsigned char *)text) + 1, (unsigned)*p);
    return SQ_OK;
}

static char *trimmed_copy(const char *b, const char *e)
{
    while (b < e && isspace((unsigned char)*b)) b++;
    while (e > b && isspace((unsigned char)e[-1])) e--;
    char *d = (char *)malloc((size_t)(e - b) + 1);
    if (d) {
        memcpy(d, b, (size_t)(e - b));
        d[e - b] = 0;
    }
    return d;
}

/* "[a, b, c]" as a sequence of scalars (what the YAML flow list gives); nesting is refused. */
static sq_result parse_set_list(const char *assignment, const char *value, sq_cfg_node *seq)
{
    const size_t n = strlen(value);
    if (n < 2 || value[n - 1] != ']')
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "--set %s: the list opened by '[' is not closed by a final ']'",
                             assignment);
    const char *b = value + 1, *end = value + n - 1;
    for (const char *q = b; q < end; q++)
        if (*q == '[' || *q == ']' || *q == '{' || *q == '}')
            return sq__set_error(SQ_ERR_INVALID_ARG,
                                 "--set %s: '%c' inside a list; lists hold plain values, e.g. "
                                 "[1, 2, 3]",
                                 assignment, *q);
    const char *q = b;
    while (q < end && isspace((unsigned char)*q)) q++;
    if (q == end) return SQ_OK; /* [] */
    while (b <= end) {
        const char *c = memchr(b, ',', (size_t)(end - b));
        if (!c) c = end;
        char *item = trimmed_copy(b, c);
        if (!item) return sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory");
        if (!*item) {
            free(item);
            return sq__set_error(SQ_ERR_INVALID_ARG, "--set %s: empty element in the list",
                                 assignment);
        }
        sq_cfg_node *it = sq_cfg_node_new(SQ_CFG_SCALAR, NULL, item, 0, 0);
        free(item);
        if (!it) return sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory");
        sq_cfg_node_append(seq, it);
        b = c + 1;
    }
    return SQ_OK;
}

sq_result sq_cfg_set(sq_cfg *cfg, const char *assignment)
{
    const char *eq = assignment ? strchr(assignment, '=') : NULL;
    if (!eq || eq == assignment)
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "--set '%s': expected path.to.key=value (e.g. output.fps=30)",
                             assignment && sq_cfg_text_ok(assignment) ? assignment : "");
    sq_result r = sq_cfg_check_text("--set", assignment);
    if (r != SQ_OK) return r;
    char path[512];
    size_t plen = (size_t)(eq - assignment);
    if (plen >= sizeof path)
        return sq__set_error(SQ_ERR_INVALID_ARG, "--set: the key path is %zu characters; at most %zu",
                             plen, sizeof path - 1);
    memcpy(path, assignment, plen);
    path[plen] = 0;
    if (path[0] == '.' || path[plen - 1] == '.' || strstr(path, ".."))
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "--set %s: empty part in the key path '%s' (parts are separated by "
                             "single dots)",
                             assignment, path);
    const char *value = eq + 1;
    /* the new content first, so a refused value leaves the tree as it was */
    sq_cfg_node *content = NULL;
    if (value[0] == '[') {
        content = sq_cfg_node_new(SQ_CFG_SEQ, NULL, NULL, 0, 0);
        if (!content) return sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory");
        r = parse_set_list(assignment, value, content);
        if (r != SQ_OK) {
            sq_cfg_node_free(content);
            return r;
        }
    }
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
                r = sq__set_error(SQ_ERR_NOT_FOUND,
                                  "--set %s: no element '%s' in '%s' (use an index, or a "
                                  "layer's name or type)",
                                  assignment, part, walked);
        } else if (node->kind == SQ_CFG_MAP) {
            child = sq_cfg_get(node, part);
            if (!child) {
                child = sq_cfg_node_new(next_part ? SQ_CFG_MAP : SQ_CFG_SCALAR, part, NULL, 0, 0);
                if (!child)
                    r = sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory");
                else
                    sq_cfg_node_append(node, child);
            }
        } else {
            r = sq__set_error(SQ_ERR_INVALID_ARG, "--set %s: '%s' is a value, not a section",
                              assignment, walked);
        }
        if (r != SQ_OK) {
            sq_cfg_node_free(content);
            return r;
        }
        node = child;
    }
    /* replace the node's content with the scalar or the list */
    sq_cfg_node_free(node->child);
    node->child = NULL;
    free(node->value);
    node->value = NULL;
    if (content) {
        node->kind = SQ_CFG_SEQ;
        node->child = content->child;
        content->child = NULL;
        sq_cfg_node_free(content);
    } else {
        node->kind = SQ_CFG_SCALAR;
        node->value = dupstr(value);
        if (!node->value) return sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory");
    }
    node->line = node->col = 0;
    return SQ_OK;
}

/* ---- YAML output ------------------------------------------------------------------------- */
/* The writer's contract: sq_cfg_parse(sq_cfg_to_yaml(t)) gives back t (kinds, keys, values and
 * order) for every tree whose text is valid UTF-8 (tests/fuzz checks it on random trees). A
 * scalar is written plain only when it is made of characters that read back unchanged in
 * every position the writer uses; everything else is double-quoted with escapes for the
 * characters YAML does not allow raw or would fold (controls, DEL, C1, U+2028/9, BOM, U+FFFE/F). */
typedef struct {
    char *buf;
    size_t len, cap;
    bool failed;
} strbuf;

static void sb_putn(strbuf *b, const char *s, size_t n)
{
    if (b->failed) return;
    if (b->len + n + 1 > b->cap) {
        size_t cap = (b->cap ? b->cap * 2 : 1024) + n;
        char *nb = (char *)realloc(b->buf, cap);
        if (!nb) {
            b->failed = true;
            return;
        }
        b->buf = nb;
        b->cap = cap;
    }
    memcpy(b->buf + b->len, s, n);
    b->len += n;
    b->buf[b->len] = 0;
}

static void sb_put(strbuf *b, const char *s) { sb_putn(b, s, strlen(s)); }

static void sb_indent(strbuf *b, int depth)
{
    for (int i = 0; i < depth; i++) sb_put(b, "  ");
}

static bool plain_ok(const char *v)
{
    const unsigned char c0 = (unsigned char)v[0];
    if (!(isalnum(c0) || c0 == '_' || c0 == '/' || c0 == '.' || c0 == '(' ||
          (c0 == '-' && (isdigit((unsigned char)v[1]) || v[1] == '.'))))
        return false;
    size_t n = 0;
    for (const unsigned char *p = (const unsigned char *)v; *p; p++, n++)
        if (!(isalnum(*p) || *p == ' ' || *p == '_' || *p == '.' || *p == '/' || *p == '+' ||
              *p == '-' || *p == '(' || *p == ')' || *p == ','))
            return false;
    return n < 256 && v[n - 1] != ' ';
}

static void put_quoted(strbuf *b, const char *v)
{
    sb_put(b, "\"");
    const unsigned char *p = (const unsigned char *)v;
    while (*p) {
        char esc[16];
        unsigned cp = 0;
        int len = 1;
        if (*p >= 0xC0) { /* valid UTF-8 here (checked by the caller) */
            len = *p >= 0xF0 ? 4 : *p >= 0xE0 ? 3 : 2;
            cp = *p & (len == 2 ? 0x1Fu : len == 3 ? 0x0Fu : 0x07u);
            for (int k = 1; k < len; k++) cp = (cp << 6) | (p[k] & 0x3Fu);
        } else {
            cp = *p;
        }
        if (cp == '"' || cp == '\\') {
            esc[0] = '\\';
            esc[1] = (char)cp;
            sb_putn(b, esc, 2);
        } else if (cp < 0x20 || (cp >= 0x7F && cp <= 0x9F)) {
            snprintf(esc, sizeof esc, "\\x%02X", cp);
            sb_put(b, esc);
        } else if (cp == 0x2028 || cp == 0x2029 || cp == 0xFEFF || cp == 0xFFFE || cp == 0xFFFF) {
            snprintf(esc, sizeof esc, "\\u%04X", cp);
            sb_put(b, esc);
        } else {
            sb_putn(b, (const char *)p, (size_t)len);
        }
        p += len;
    }
    sb_put(b, "\"");
}

static void put_scalar(strbuf *b, const char *v)
{
    if (!v) v = "";
    if (plain_ok(v))
        sb_put(b, v);
    else
        put_quoted(b, v);
}

static bool tree_text_ok(const sq_cfg_node *n)
{
    for (; n; n = n->next) {
        if ((n->key && utf8_invalid_at(n->key) >= 0) ||
            (n->value && utf8_invalid_at(n->value) >= 0) || !tree_text_ok(n->child))
            return false;
    }
    return true;
}

static void emit(strbuf *b, const sq_cfg_node *n, int depth, bool in_seq);

static void emit_children(strbuf *b, const sq_cfg_node *n, int depth)
{
    for (const sq_cfg_node *c = n->child; c; c = c->next)
        emit(b, c, depth, n->kind == SQ_CFG_SEQ);
}

static void emit(strbuf *b, const sq_cfg_node *n, int depth, bool in_seq)
{
    sb_indent(b, depth);
    if (in_seq) {
        sb_put(b, "-");
    } else {
        /* libyaml reads implicit keys of at most 1024 characters: longer ones are explicit */
        strbuf k = {0};
        put_scalar(&k, n->key);
        if (k.failed || !k.buf) {
            b->failed = true;
            free(k.buf);
            return;
        }
        if (k.len > 512) {
            sb_put(b, "? ");
            sb_put(b, k.buf);
            sb_put(b, "\n");
            sb_indent(b, depth);
        } else {
            sb_put(b, k.buf);
        }
        free(k.buf);
        sb_put(b, ":");
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
    if (cfg && cfg->root && !tree_text_ok(cfg->root)) {
        free(b.buf);
        sq__set_error(SQ_ERR_INVALID_ARG, "the configuration holds text that is not valid UTF-8; "
                                          "YAML cannot represent it");
        return NULL;
    }
    if (cfg && cfg->root && cfg->root->child)
        emit_children(&b, cfg->root, 0);
    else
        sb_put(&b, "{}\n");
    if (b.failed) {
        free(b.buf);
        sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory writing YAML");
        return NULL;
    }
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
    if (sq_preset_text("haboob") && sq_plugin_find("sandstorm")) return "haboob";
    return "terrain-flight";
}
