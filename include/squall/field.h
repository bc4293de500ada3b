/* squall/field.h — 3D scalar fields of float with ghost layers, and borrowed views.
 * Layout: x fastest, then y, then z. A field of interior size nx*ny*nz with g ghost layers
 * stores (nx+2g)(ny+2g)(nz+2g) floats; sq_field3_at(f, i, j, k) is valid for
 * -g <= i < nx+g (likewise j, k). The data pointer is 64-byte aligned at the allocation. */
#ifndef SQ_FIELD_H
#define SQ_FIELD_H

#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sq_dims {
    int nx, ny, nz;
} sq_dims;

typedef struct sq_field3 {
    float *base;     /* allocation (owned) */
    float *origin;   /* element (0,0,0) of the interior */
    sq_dims n;       /* interior size */
    int ghost;       /* ghost layers on every side */
    ptrdiff_t sy, sz; /* strides in elements for j and k (sx = 1) */
    size_t count;    /* total elements including ghosts */
} sq_field3;

/* A read-only borrowed window: element (i,j,k) is data[i*sx + j*sy + k*sz]. Valid until the
 * owner's next step, resize or destroy. */
typedef struct sq_field_view {
    const float *data;
    sq_dims n;
    ptrdiff_t sx, sy, sz;
} sq_field_view;

/* Bytes a field of these dimensions needs (for memory checks before allocating). */
SQ_API uint64_t sq_field3_bytes(sq_dims n, int ghost);
/* Creates a zero-filled field. Fails with SQ_ERR_INVALID_ARG for a non-positive size and
 * SQ_ERR_TOO_LARGE if it would exceed the context's memory limit. */
SQ_API sq_result sq_field3_create(sq_context *ctx, sq_dims n, int ghost, sq_field3 *out);
SQ_API void sq_field3_destroy(sq_context *ctx, sq_field3 *f);
SQ_API void sq_field3_fill(sq_field3 *f, float v); /* includes ghosts */
SQ_API void sq_field3_copy(sq_field3 *dst, const sq_field3 *src); /* same dims and ghosts */
SQ_API sq_field_view sq_field3_view(const sq_field3 *f);
/* View of the box [i0,i0+n.nx) x [j0, ...) x [k0, ...) of f (may include ghosts). */
SQ_API sq_field_view sq_field3_subview(const sq_field3 *f, int i0, int j0, int k0, sq_dims n);
/* Fills ghost layers: periodic[axis] wraps, otherwise copies the nearest interior value
 * (zero gradient). This is the serial domain-decomposition exchange. */
SQ_API void sq_field3_fill_ghosts(sq_field3 *f, const int periodic[3]);

static inline float *sq_field3_at(const sq_field3 *f, int i, int j, int k)
{
    return f->origin + i + (ptrdiff_t)j * f->sy + (ptrdiff_t)k * f->sz;
}
static inline float sq_view_get(const sq_field_view *v, int i, int j, int k)
{
    return v->data[(ptrdiff_t)i * v->sx + (ptrdiff_t)j * v->sy + (ptrdiff_t)k * v->sz];
}

#ifdef __cplusplus
}
#endif
#endif
