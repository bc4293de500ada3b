/* field_files.c — the checks shared by the field-file writers (NetCDF, VTK image data): one
 * grid for all fields, names usable as NetCDF variable and VTK array names. */
#include <math.h>
#include <string.h>

#include "io/io_internal.h"

static bool name_ok(const char *s)
{
    if (!s || !*s || strlen(s) > 128) return false;
    if (!((*s >= 'A' && *s <= 'Z') || (*s >= 'a' && *s <= 'z') || *s == '_')) return false;
    for (const char *p = s + 1; *p; p++) {
        const char c = *p;
        if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
              c == '_' || c == '.' || c == '-'))
            return false;
    }
    return true;
}

static bool vec_equal(sq_vec3 a, sq_vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

sq_result sq__field_file_check(sq_context *ctx, const sq_field_file_desc *desc,
                               const sq_named_field *fields, int count, const char *what)
{
    if (!desc) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "%s desc is NULL", what);
    if (!desc->path || !*desc->path)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "%s path is empty", what);
    if (desc->crs_wkt && *desc->crs_wkt &&
        (!isfinite(desc->crs_offset_m[0]) || !isfinite(desc->crs_offset_m[1])))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "%s '%s': crs_offset_m is not finite", what,
                        desc->path);
    if (!isfinite(desc->time_s))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "%s '%s': time_s = %g; must be finite", what,
                        desc->path, desc->time_s);
    if (count < 1 || !fields)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                        "%s '%s': field count = %d; needs at least 1", what, desc->path,
                        fields ? count : 0);
    const sq_named_field *f0 = &fields[0];
    for (int i = 0; i < count; i++) {
        const sq_named_field *f = &fields[i];
        if (!name_ok(f->name))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                            "%s '%s': field %d name '%s' must match [A-Za-z_][A-Za-z0-9_.-]* "
                            "(at most 128 characters)",
                            what, desc->path, i, f->name ? f->name : "(null)");
        if (!strcmp(f->name, "x") || !strcmp(f->name, "y") || !strcmp(f->name, "z") ||
            !strcmp(f->name, "time"))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                            "%s '%s': field name '%s' is taken by a coordinate", what, desc->path,
                            f->name);
        for (int j = 0; j < i; j++)
            if (!strcmp(f->name, fields[j].name))
                return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                                "%s '%s': field name '%s' appears twice (fields %d and %d)", what,
                                desc->path, f->name, j, i);
        if (!f->data)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "%s '%s': field '%s' has no data", what,
                            desc->path, f->name);
        if (f->nx < 1 || f->ny < 1 || f->nz < 1)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                            "%s '%s': field '%s' is %dx%dx%d; every axis needs at least 1", what,
                            desc->path, f->name, f->nx, f->ny, f->nz);
        if (f->nx != f0->nx || f->ny != f0->ny || f->nz != f0->nz)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                            "%s '%s': field '%s' is %dx%dx%d but '%s' is %dx%dx%d; all fields of "
                            "a file share one grid",
                            what, desc->path, f->name, f->nx, f->ny, f->nz, f0->name, f0->nx,
                            f0->ny, f0->nz);
        /* 2D maps share x and y; each may lie at its own level */
        const bool same_grid = f0->nz == 1 ? f->origin_m.x == f0->origin_m.x &&
                                                 f->origin_m.y == f0->origin_m.y &&
                                                 f->spacing_m.x == f0->spacing_m.x &&
                                                 f->spacing_m.y == f0->spacing_m.y
                                           : vec_equal(f->origin_m, f0->origin_m) &&
                                                 vec_equal(f->spacing_m, f0->spacing_m);
        if (f0->nz == 1 && (f->level < SQ_FIELD_LEVEL_ALTITUDE || f->level > SQ_FIELD_LEVEL_SURFACE))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "%s '%s': field '%s' level = %d; not an "
                            "sq_field_level", what, desc->path, f->name, (int)f->level);
        if (!same_grid)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                            "%s '%s': field '%s' has another origin or spacing than '%s'; all "
                            "fields of a file share one grid",
                            what, desc->path, f->name, f0->name);
        if (!(f->spacing_m.x > 0.0f) || !(f->spacing_m.y > 0.0f) || !(f->spacing_m.z > 0.0f) ||
            !isfinite(f->spacing_m.x) || !isfinite(f->spacing_m.y) || !isfinite(f->spacing_m.z))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                            "%s '%s': field '%s' spacing_m = (%g, %g, %g); each must be > 0 and "
                            "finite",
                            what, desc->path, f->name, (double)f->spacing_m.x,
                            (double)f->spacing_m.y, (double)f->spacing_m.z);
        if (!isfinite(f->origin_m.x) || !isfinite(f->origin_m.y) || !isfinite(f->origin_m.z))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                            "%s '%s': field '%s' origin is not finite", what, desc->path, f->name);
    }
    return SQ_OK;
}
