/* field.c — 3D float fields with ghost layers; views; ghost filling (serial exchange). */
#include <stdio.h>
#include <string.h>

#include "core_internal.h"
#include "squall/field.h"

uint64_t sq_field3_bytes(sq_dims n, int ghost)
{
    if (n.nx <= 0 || n.ny <= 0 || n.nz <= 0 || ghost < 0) return 0;
    uint64_t ex = (uint64_t)(n.nx + 2 * ghost), ey = (uint64_t)(n.ny + 2 * ghost),
             ez = (uint64_t)(n.nz + 2 * ghost);
    return ex * ey * ez * sizeof(float);
}

sq_result sq_field3_create(sq_context *ctx, sq_dims n, int ghost, sq_field3 *out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "field", "field: out is NULL");
    memset(out, 0, sizeof *out);
    if (n.nx <= 0 || n.ny <= 0 || n.nz <= 0 || ghost < 0)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "field",
                        "field size = %dx%dx%d with %d ghost layers; every axis needs at least 1 "
                        "cell and ghosts must be >= 0",
                        n.nx, n.ny, n.nz, ghost);
    uint64_t bytes = sq_field3_bytes(n, ghost);
    char what[96];
    snprintf(what, sizeof what, "field %dx%dx%d", n.nx, n.ny, n.nz);
    sq_result r = sq_context_check_memory(ctx, bytes, what);
    if (r != SQ_OK) return r;
    float *base = (float *)sq_alloc_zero(ctx, (size_t)bytes);
    if (!base) return SQ_ERR_OUT_OF_MEMORY;
    out->base = base;
    out->n = n;
    out->ghost = ghost;
    out->sy = n.nx + 2 * ghost;
    out->sz = out->sy * (ptrdiff_t)(n.ny + 2 * ghost);
    out->count = (size_t)(bytes / sizeof(float));
    out->origin = base + ghost + ghost * out->sy + ghost * out->sz;
    return SQ_OK;
}

void sq_field3_destroy(sq_context *ctx, sq_field3 *f)
{
    if (!f) return;
    sq_free(ctx, f->base);
    memset(f, 0, sizeof *f);
}

void sq_field3_fill(sq_field3 *f, float v)
{
    for (size_t i = 0; i < f->count; i++) f->base[i] = v;
}

void sq_field3_copy(sq_field3 *dst, const sq_field3 *src)
{
    if (dst->count == src->count) memcpy(dst->base, src->base, src->count * sizeof(float));
}

sq_field_view sq_field3_view(const sq_field3 *f)
{
    sq_field_view v = {f->origin, f->n, 1, f->sy, f->sz};
    return v;
}

sq_field_view sq_field3_subview(const sq_field3 *f, int i0, int j0, int k0, sq_dims n)
{
    sq_field_view v = {sq_field3_at(f, i0, j0, k0), n, 1, f->sy, f->sz};
    return v;
}

static int wrap_or_clamp(int i, int n, int periodic)
{
    if (periodic) return ((i % n) + n) % n;
    return i < 0 ? 0 : (i >= n ? n - 1 : i);
}

void sq_field3_fill_ghosts(sq_field3 *f, const int periodic[3])
{
    const int g = f->ghost;
    if (g == 0) return;
    const int nx = f->n.nx, ny = f->n.ny, nz = f->n.nz;
    int p[3] = {0, 0, 0};
    if (periodic) memcpy(p, periodic, sizeof p);
    for (int k = -g; k < nz + g; k++)
        for (int j = -g; j < ny + g; j++)
            for (int i = -g; i < nx + g; i++) {
                if (i >= 0 && i < nx && j >= 0 && j < ny && k >= 0 && k < nz) {
                    i = nx - 1; /* skip the interior row segment */
                    continue;
                }
                int si = wrap_or_clamp(i, nx, p[0]), sj = wrap_or_clamp(j, ny, p[1]),
                    sk = wrap_or_clamp(k, nz, p[2]);
                *sq_field3_at(f, i, j, k) = *sq_field3_at(f, si, sj, sk);
            }
}
