/* params.c — parameter tables: defaults, typed setting from text with range and unit checks,
 * formatting back to text, validation and "did you mean" suggestions. The tables are the single
 * source of truth for scene-file keys, --set overrides, `squall params` and the docs. */
#include <ctype.h>
#include <errno.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/core_internal.h"
#include "scene/scene_internal.h"
#include "squall/plugin.h"

#define FIELD(desc, p, T) ((T *)((char *)(desc) + (p)->offset))
#define CFIELD(desc, p, T) ((const T *)((const char *)(desc) + (p)->offset))

/* Parses up to max numbers from "a b c", "a, b, c" or "[a, b, c]". Returns the count or -1. */
static int parse_numbers(const char *s, double *out, int max)
{
    int n = 0;
    while (*s) {
        while (*s && (isspace((unsigned char)*s) || *s == ',' || *s == '[' || *s == ']')) s++;
        if (!*s) break;
        if (n >= max) return -1;
        char *end = NULL;
        errno = 0;
        double v = strtod(s, &end);
        if (end == s || errno == ERANGE) return -1;
        out[n++] = v;
        s = end;
        if (*s && !isspace((unsigned char)*s) && *s != ',' && *s != ']') return -1;
    }
    return n;
}

bool sq__parse_u64(const char *s, uint64_t *out)
{
    *out = 0;
    while (isspace((unsigned char)*s)) s++;
    if (!isdigit((unsigned char)*s)) return false; /* no sign, no "0x", no ".5", no "1e3" */
    const char *p = s;
    while (isdigit((unsigned char)*p)) p++;
    const char *end = p;
    while (isspace((unsigned char)*p)) p++;
    if (*p) return false;
    uint64_t v = 0;
    for (const char *d = s; d < end; d++) {
        const uint64_t digit = (uint64_t)(*d - '0');
        if (v > (UINT64_MAX - digit) / 10) return false; /* above 2^64 - 1 */
        v = v * 10 + digit;
    }
    *out = v;
    return true;
}

static int parse_bool(const char *s, bool *out)
{
    const char *t[] = {"true", "yes", "on", "1"}, *f[] = {"false", "no", "off", "0"};
    for (int i = 0; i < 4; i++) {
        if (strcasecmp(s, t[i]) == 0) return *out = true, 1;
        if (strcasecmp(s, f[i]) == 0) return *out = false, 1;
    }
    return 0;
}

/* Index of name in "a|b|c" or -1. */
static int enum_index(const char *choices, const char *name)
{
    int idx = 0;
    size_t n = strlen(name);
    const char *c = choices;
    while (c && *c) {
        const char *e = strchr(c, '|');
        size_t len = e ? (size_t)(e - c) : strlen(c);
        if (len == n && strncmp(c, name, n) == 0) return idx;
        idx++;
        c = e ? e + 1 : NULL;
    }
    return -1;
}

static void enum_name(const char *choices, int index, char *buf, size_t size)
{
    const char *c = choices;
    for (int i = 0; c && i < index; i++) {
        c = strchr(c, '|');
        if (c) c++;
    }
    if (!c) {
        snprintf(buf, size, "%d", index);
        return;
    }
    const char *e = strchr(c, '|');
    size_t len = e ? (size_t)(e - c) : strlen(c);
    if (len >= size) len = size - 1;
    memcpy(buf, c, len);
    buf[len] = 0;
}

static const char *unit_text(const sq_param *p)
{
    if (!p->unit || !*p->unit || strcmp(p->unit, "1") == 0) return "";
    return p->unit;
}

static sq_result set_numbers(const sq_param *p, void *desc, const double *v, int n)
{
    switch (p->type) {
    case SQ_PARAM_FLOAT: *FIELD(desc, p, float) = (float)v[0]; break;
    case SQ_PARAM_DOUBLE: *FIELD(desc, p, double) = v[0]; break;
    case SQ_PARAM_INT: *FIELD(desc, p, int) = (int)v[0]; break;
    case SQ_PARAM_U64: *FIELD(desc, p, uint64_t) = (uint64_t)v[0]; break;
    case SQ_PARAM_VEC3:
        for (int i = 0; i < 3; i++) FIELD(desc, p, float)[i] = (float)v[i];
        break;
    case SQ_PARAM_FLOATS:
        for (int i = 0; i < n; i++) FIELD(desc, p, float)[i] = (float)v[i];
        *(int *)((char *)desc + p->count_offset) = n;
        break;
    default: return SQ_ERR_INTERNAL;
    }
    return SQ_OK;
}

void sq_params_defaults(const sq_param *table, size_t n, void *desc)
{
    for (size_t i = 0; i < n; i++) {
        const sq_param *p = &table[i];
        double v[64];
        int cnt;
        switch (p->type) {
        case SQ_PARAM_FLOAT:
        case SQ_PARAM_DOUBLE:
        case SQ_PARAM_INT:
        case SQ_PARAM_U64: set_numbers(p, desc, &p->def, 1); break;
        case SQ_PARAM_BOOL: *FIELD(desc, p, bool) = p->def != 0.0; break;
        case SQ_PARAM_ENUM: *FIELD(desc, p, int) = (int)p->def; break;
        case SQ_PARAM_VEC3:
            cnt = parse_numbers(p->def_text ? p->def_text : "0 0 0", v, 3);
            if (cnt == 3) set_numbers(p, desc, v, 3);
            break;
        case SQ_PARAM_FLOATS:
            cnt = parse_numbers(p->def_text ? p->def_text : "", v,
                                p->max_count < 64 ? p->max_count : 64);
            if (cnt >= 0) set_numbers(p, desc, v, cnt);
            break;
        case SQ_PARAM_STRING:
            snprintf(FIELD(desc, p, char), SQ_PARAM_STRING_MAX, "%s",
                     p->def_text ? p->def_text : "");
            break;
        default: break;
        }
    }
}

const sq_param *sq_params_find(const sq_param *table, size_t n, const char *key)
{
    for (size_t i = 0; i < n; i++)
        if (strcmp(table[i].key, key) == 0) return &table[i];
    return NULL;
}

size_t sq__edit_distance(const char *a, const char *b)
{
    size_t la = strlen(a), lb = strlen(b);
    if (la > 63 || lb > 63) return 99;
    size_t d[64][64];
    for (size_t i = 0; i <= la; i++) d[i][0] = i;
    for (size_t j = 0; j <= lb; j++) d[0][j] = j;
    for (size_t i = 1; i <= la; i++)
        for (size_t j = 1; j <= lb; j++) {
            size_t c = d[i - 1][j - 1] + (a[i - 1] != b[j - 1]);
            if (d[i - 1][j] + 1 < c) c = d[i - 1][j] + 1;
            if (d[i][j - 1] + 1 < c) c = d[i][j - 1] + 1;
            d[i][j] = c;
        }
    return d[la][lb];
}

const char *sq_params_suggest(const sq_param *table, size_t n, const char *key)
{
    const char *best = NULL;
    size_t bestd = 99;
    for (size_t i = 0; i < n; i++) {
        size_t d = sq__edit_distance(key, table[i].key);
        /* also compare the last component: "speed" vs "wind.speed_mps" */
        const char *dot = strrchr(table[i].key, '.');
        if (dot) {
            size_t d2 = sq__edit_distance(key, dot + 1) + 1;
            if (d2 < d) d = d2;
        }
        if (strstr(table[i].key, key) && strlen(key) >= 3) d = d < 2 ? d : 2;
        if (d < bestd) {
            bestd = d;
            best = table[i].key;
        }
    }
    size_t len = strlen(key);
    size_t limit = len <= 4 ? 2 : len / 2 + 1;
    return bestd <= limit ? best : NULL;
}

static sq_result range_error(const sq_param *p, const char *section, const char *where,
                             const char *value)
{
    const char *u = unit_text(p);
    if (p->min == 0.0 && p->max == 0.0) /* unbounded key: only finiteness and the C type limit */
        return sq__set_error(SQ_ERR_INVALID_ARG, "%s%s%s%s%s = %s%s%s: must be finite and within "
                             "+-%g",
                             where ? where : "", where ? ": " : "", section ? section : "",
                             section ? "." : "", p->key, value, *u ? " " : "", u,
                             p->type == SQ_PARAM_INT ? (double)INT_MAX : (double)FLT_MAX);
    return sq__set_error(SQ_ERR_INVALID_ARG, "%s%s%s%s%s = %s%s%s: outside the range [%g, %g]%s%s",
                         where ? where : "", where ? ": " : "", section ? section : "",
                         section ? "." : "", p->key, value, *u ? " " : "", u, p->min, p->max,
                         *u ? " " : "", u);
}

static bool in_range(const sq_param *p, double v)
{
    if (!isfinite(v)) return false;
    /* Whatever the table says, the value must fit the C type it is stored in (converting an
     * out-of-range double to float or int is undefined behaviour). */
    if ((p->type == SQ_PARAM_FLOAT || p->type == SQ_PARAM_VEC3 || p->type == SQ_PARAM_FLOATS) &&
        fabs(v) > (double)FLT_MAX)
        return false;
    if (p->type == SQ_PARAM_INT && (v < (double)INT_MIN || v > (double)INT_MAX)) return false;
    if (p->min == 0.0 && p->max == 0.0) return true; /* unbounded */
    return v >= p->min && v <= p->max;
}

sq_result sq_params_set(const sq_param *table, size_t n, void *desc, const char *section,
                        const char *key, const char *value, const char *where)
{
    const char *W = where ? where : "";
    const char *sep = where ? ": " : "";
    const char *S = section ? section : "";
    const char *dot = section ? "." : "";
    const sq_param *p = sq_params_find(table, n, key);
    if (!p) {
        const char *s = sq_params_suggest(table, n, key);
        if (s)
            return sq__set_error(SQ_ERR_NOT_FOUND, "%s%sunknown key '%s%s%s'; did you mean '%s%s%s'?",
                                 W, sep, S, dot, key, S, dot, s);
        return sq__set_error(SQ_ERR_NOT_FOUND,
                             "%s%sunknown key '%s%s%s' (see `squall params %s` for the keys)", W,
                             sep, S, dot, key, section ? section : "LAYER");
    }
    if (!value) value = "";
    const char *u = unit_text(p);
    double v[64];
    int cnt;
    switch (p->type) {
    case SQ_PARAM_U64: {
        uint64_t n64 = 0;
        if (!sq__parse_u64(value, &n64))
            return sq__set_error(SQ_ERR_INVALID_ARG,
                                 "%s%s%s%s%s = '%s': expected a whole number in 0..%llu (digits "
                                 "only)",
                                 W, sep, S, dot, p->key, value, (unsigned long long)UINT64_MAX);
        *FIELD(desc, p, uint64_t) = n64;
        return SQ_OK;
    }
    case SQ_PARAM_FLOAT:
    case SQ_PARAM_DOUBLE:
    case SQ_PARAM_INT:
        cnt = parse_numbers(value, v, 1);
        if (cnt != 1 || strchr(value, '[')) {
            return sq__set_error(SQ_ERR_INVALID_ARG, "%s%s%s%s%s = '%s': expected a %s%s%s", W,
                                 sep, S, dot, p->key, value,
                                 p->type == SQ_PARAM_FLOAT || p->type == SQ_PARAM_DOUBLE
                                     ? "number"
                                     : "whole number",
                                 *u ? " in " : "", u);
        }
        if (p->type == SQ_PARAM_INT && v[0] != floor(v[0]))
            return sq__set_error(SQ_ERR_INVALID_ARG, "%s%s%s%s%s = '%s': expected a whole number",
                                 W, sep, S, dot, p->key, value);
        if (!in_range(p, v[0])) return range_error(p, section, where, value);
        return set_numbers(p, desc, v, 1);
    case SQ_PARAM_BOOL: {
        bool b;
        if (!parse_bool(value, &b))
            return sq__set_error(SQ_ERR_INVALID_ARG,
                                 "%s%s%s%s%s = '%s': expected true or false", W, sep, S, dot,
                                 p->key, value);
        *FIELD(desc, p, bool) = b;
        return SQ_OK;
    }
    case SQ_PARAM_ENUM: {
        int idx = enum_index(p->choices, value);
        if (idx < 0)
            return sq__set_error(SQ_ERR_INVALID_ARG, "%s%s%s%s%s = '%s': expected one of %s", W,
                                 sep, S, dot, p->key, value, p->choices);
        *FIELD(desc, p, int) = idx;
        return SQ_OK;
    }
    case SQ_PARAM_VEC3:
        cnt = parse_numbers(value, v, 3);
        if (cnt != 3)
            return sq__set_error(SQ_ERR_INVALID_ARG,
                                 "%s%s%s%s%s = '%s': expected 3 numbers [x, y, z]%s%s", W, sep, S,
                                 dot, p->key, value, *u ? " in " : "", u);
        for (int i = 0; i < 3; i++)
            if (!in_range(p, v[i])) return range_error(p, section, where, value);
        return set_numbers(p, desc, v, 3);
    case SQ_PARAM_FLOATS: {
        int maxc = p->max_count < 64 ? p->max_count : 64;
        cnt = parse_numbers(value, v, maxc);
        if (cnt < 0)
            return sq__set_error(SQ_ERR_INVALID_ARG,
                                 "%s%s%s%s%s = '%s': expected a list of at most %d numbers%s%s", W,
                                 sep, S, dot, p->key, value, maxc, *u ? " in " : "", u);
        for (int i = 0; i < cnt; i++)
            if (!in_range(p, v[i])) return range_error(p, section, where, value);
        return set_numbers(p, desc, v, cnt);
    }
    case SQ_PARAM_STRING:
        if (strlen(value) >= SQ_PARAM_STRING_MAX)
            return sq__set_error(SQ_ERR_INVALID_ARG, "%s%s%s%s%s: text longer than %d characters",
                                 W, sep, S, dot, p->key, SQ_PARAM_STRING_MAX - 1);
        snprintf(FIELD(desc, p, char), SQ_PARAM_STRING_MAX, "%s", value);
        return SQ_OK;
    default: return sq__set_error(SQ_ERR_INTERNAL, "parameter %s has no type", p->key);
    }
}

void sq_params_format(const sq_param *p, const void *desc, char *buf, size_t size)
{
    size_t len = 0;
    buf[0] = 0;
    switch (p->type) {
    case SQ_PARAM_FLOAT: snprintf(buf, size, "%g", (double)*CFIELD(desc, p, float)); break;
    case SQ_PARAM_DOUBLE: snprintf(buf, size, "%g", *CFIELD(desc, p, double)); break;
    case SQ_PARAM_INT: snprintf(buf, size, "%d", *CFIELD(desc, p, int)); break;
    case SQ_PARAM_U64:
        snprintf(buf, size, "%llu", (unsigned long long)*CFIELD(desc, p, uint64_t));
        break;
    case SQ_PARAM_BOOL: snprintf(buf, size, "%s", *CFIELD(desc, p, bool) ? "true" : "false"); break;
    case SQ_PARAM_ENUM: enum_name(p->choices, *CFIELD(desc, p, int), buf, size); break;
    case SQ_PARAM_VEC3: {
        const float *f = CFIELD(desc, p, float);
        snprintf(buf, size, "[%g, %g, %g]", (double)f[0], (double)f[1], (double)f[2]);
        break;
    }
    case SQ_PARAM_FLOATS: {
        const float *f = CFIELD(desc, p, float);
        int cnt = *(const int *)((const char *)desc + p->count_offset);
        len += (size_t)snprintf(buf + len, size - len, "[");
        for (int i = 0; i < cnt && len < size; i++)
            len += (size_t)snprintf(buf + len, size - len, i ? ", %g" : "%g", (double)f[i]);
        if (len < size) snprintf(buf + len, size - len, "]");
        break;
    }
    case SQ_PARAM_STRING: {
        const char *s = CFIELD(desc, p, char);
        snprintf(buf, size, "\"%s\"", s);
        break;
    }
    default: break;
    }
}

sq_result sq_params_validate(const sq_param *table, size_t n, const void *desc,
                             const char *section)
{
    for (size_t i = 0; i < n; i++) {
        const sq_param *p = &table[i];
        char buf[256];
        bool ok = true;
        switch (p->type) {
        case SQ_PARAM_FLOAT: ok = in_range(p, (double)*CFIELD(desc, p, float)); break;
        case SQ_PARAM_DOUBLE: ok = in_range(p, *CFIELD(desc, p, double)); break;
        case SQ_PARAM_INT: ok = in_range(p, (double)*CFIELD(desc, p, int)); break;
        case SQ_PARAM_VEC3:
            for (int k = 0; k < 3; k++) ok = ok && in_range(p, (double)CFIELD(desc, p, float)[k]);
            break;
        case SQ_PARAM_FLOATS: {
            int cnt = *(const int *)((const char *)desc + p->count_offset);
            for (int k = 0; k < cnt; k++) ok = ok && in_range(p, (double)CFIELD(desc, p, float)[k]);
            break;
        }
        default: break;
        }
        if (!ok) {
            sq_params_format(p, desc, buf, sizeof buf);
            return range_error(p, section, NULL, buf);
        }
    }
    return SQ_OK;
}

/* ---- live changes ---------------------------------------------------------------------------- */
/* Whether an entry holds the same value in a and b (a FLOATS list: its count and the elements
 * in use; a STRING: up to its NUL). */
static bool entry_equal(const sq_param *p, const void *a, const void *b)
{
    switch (p->type) {
    case SQ_PARAM_FLOAT: return memcmp(CFIELD(a, p, float), CFIELD(b, p, float), sizeof(float)) == 0;
    case SQ_PARAM_DOUBLE:
        return memcmp(CFIELD(a, p, double), CFIELD(b, p, double), sizeof(double)) == 0;
    case SQ_PARAM_INT:
    case SQ_PARAM_ENUM: return *CFIELD(a, p, int) == *CFIELD(b, p, int);
    case SQ_PARAM_BOOL: return *CFIELD(a, p, bool) == *CFIELD(b, p, bool);
    case SQ_PARAM_U64: return *CFIELD(a, p, uint64_t) == *CFIELD(b, p, uint64_t);
    case SQ_PARAM_VEC3: return memcmp(CFIELD(a, p, float), CFIELD(b, p, float), 3 * sizeof(float)) == 0;
    case SQ_PARAM_STRING:
        return strncmp(CFIELD(a, p, char), CFIELD(b, p, char), SQ_PARAM_STRING_MAX) == 0;
    case SQ_PARAM_FLOATS: {
        const int na = *(const int *)((const char *)a + p->count_offset);
        const int nb = *(const int *)((const char *)b + p->count_offset);
        if (na != nb) return false;
        const int n = na < 0 ? 0 : na > p->max_count ? p->max_count : na;
        return memcmp(CFIELD(a, p, float), CFIELD(b, p, float), (size_t)n * sizeof(float)) == 0;
    }
    default: return true;
    }
}

static void entry_copy(const sq_param *p, void *dst, const void *src)
{
    size_t bytes = 0;
    switch (p->type) {
    case SQ_PARAM_FLOAT: bytes = sizeof(float); break;
    case SQ_PARAM_DOUBLE: bytes = sizeof(double); break;
    case SQ_PARAM_INT:
    case SQ_PARAM_ENUM: bytes = sizeof(int); break;
    case SQ_PARAM_BOOL: bytes = sizeof(bool); break;
    case SQ_PARAM_U64: bytes = sizeof(uint64_t); break;
    case SQ_PARAM_VEC3: bytes = 3 * sizeof(float); break;
    case SQ_PARAM_STRING: bytes = SQ_PARAM_STRING_MAX; break;
    case SQ_PARAM_FLOATS:
        bytes = (size_t)p->max_count * sizeof(float);
        memcpy((char *)dst + p->count_offset, (const char *)src + p->count_offset, sizeof(int));
        break;
    default: return;
    }
    memcpy((char *)dst + p->offset, (const char *)src + p->offset, bytes);
}

bool sq_param_live(const sq_param *p, const sq_phen_plugin *plugin)
{
    return p && (p->flags & SQ_PARAM_LIVE) && (!plugin || plugin->apply_live);
}

const sq_param *sq_params_first_change(const sq_param *table, size_t n, const void *a,
                                       const void *b, bool live)
{
    for (size_t i = 0; i < n; i++) {
        const sq_param *p = &table[i];
        if (((p->flags & SQ_PARAM_LIVE) != 0) == live && !entry_equal(p, a, b)) return p;
    }
    return NULL;
}

void sq_params_copy_live(const sq_param *table, size_t n, void *dst, const void *src)
{
    for (size_t i = 0; i < n; i++)
        if (table[i].flags & SQ_PARAM_LIVE) entry_copy(&table[i], dst, src);
}
