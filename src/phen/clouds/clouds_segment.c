/* clouds_segment.c — clouds as connected sets of cloudy cells (issue 10; S4 §2.2 step 1 reads
 * "cloud position, radius and boundary distribution" from WRF without saying how): a cell is
 * cloudy when its condensate (cloud water + ice + snow) is at least the threshold; clouds are
 * the 6-connected components (faces shared; the vertical levels of a column stack). Per cloud:
 * the condensate-weighted centre, the extent of its cells, its cells and boundary cells (a
 * 6-neighbour outside the cloud or outside the grid), liquid and ice water paths averaged over
 * its footprint (g/m²: sum of C dz over its cells / its columns), its top. For the domain: the
 * cover fraction (columns with a cloudy cell), the highest cloudy cell and the mean water
 * paths. Iterative flood fill, labels in order of the first cell met (deterministic). */
#include <math.h>
#include <string.h>

#include "clouds_internal.h"

sq_result sq__segment_init(sq_context *ctx, sq__segmentation *s, const sq__cloud_grid *g)
{
    memset(s, 0, sizeof *s);
    const size_t cells = (size_t)g->nx * g->ny * g->nz;
    s->info = sq_alloc_zero(ctx, SQ__MAX_CLOUDS * sizeof(sq_cloud_info));
    s->stack = sq_alloc(ctx, cells * sizeof(int32_t));
    s->column = sq_alloc(ctx, (size_t)g->nx * g->ny);
    s->colmark = sq_alloc(ctx, (size_t)g->nx * g->ny * sizeof(int32_t));
    s->foot = sq_alloc(ctx, SQ__MAX_CLOUDS * sizeof(int32_t));
    if (!s->info || !s->stack || !s->column || !s->colmark || !s->foot) {
        sq__segment_free(ctx, s);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "clouds", "no memory for cloud segmentation");
    }
    return SQ_OK;
}

void sq__segment_free(sq_context *ctx, sq__segmentation *s)
{
    sq_free(ctx, s->info);
    sq_free(ctx, s->stack);
    sq_free(ctx, s->column);
    sq_free(ctx, s->colmark);
    sq_free(ctx, s->foot);
    memset(s, 0, sizeof *s);
}

/* Statistics of one labelled cloud (its cells are those with label == id). */
typedef struct acc {
    double w, cx, cy, cz, lwp, iwp;
    float lo[3], hi[3], top;
    int cells, boundary, foot;
} acc;

void sq__segment_clouds(sq__segmentation *s, sq__cloud_field *f, float threshold_g_m3)
{
    const sq__cloud_grid *g = &f->grid;
    const int nx = g->nx, ny = g->ny, nz = g->nz;
    const size_t cols = (size_t)nx * ny, cells = cols * (size_t)nz;
    const float e = f->exaggeration;
    int32_t *label = f->label;
    for (size_t c = 0; c < cells; c++) label[c] = f->cond[c] >= threshold_g_m3 ? -2 : -1;
    memset(s->column, 0, cols);
    for (size_t q = 0; q < cols; q++) s->colmark[q] = -1;
    int32_t *foot = s->foot;
    memset(foot, 0, SQ__MAX_CLOUDS * sizeof(int32_t));
    s->clouds = 0;
    s->largest_dropped = 0;
    s->cloud_top_m = 0.0;
    double lwp_all = 0.0, iwp_all = 0.0;
    for (size_t c0 = 0; c0 < cells; c0++) {
        if (label[c0] != -2) continue;
        int id = s->clouds;
        if (id >= SQ__MAX_CLOUDS) { /* merge the rest into the last cloud (counted) */
            id = SQ__MAX_CLOUDS - 1;
            s->largest_dropped++;
        } else {
            s->clouds++;
            memset(&s->info[id], 0, sizeof s->info[id]);
        }
        acc a;
        memset(&a, 0, sizeof a);
        for (int q = 0; q < 3; q++) {
            a.lo[q] = INFINITY;
            a.hi[q] = -INFINITY;
        }
        a.top = -INFINITY;
        size_t top = 0;
        s->stack[top++] = (int32_t)c0;
        label[c0] = id;
        while (top > 0) {
            const size_t c = (size_t)s->stack[--top];
            const int i = (int)(c % (size_t)nx), j = (int)((c / (size_t)nx) % (size_t)ny);
            const int k = (int)(c / cols);
            const int ni[6] = {i - 1, i + 1, i, i, i, i}, nj[6] = {j, j, j - 1, j + 1, j, j};
            const int nk[6] = {k, k, k, k, k - 1, k + 1};
            bool boundary = false;
            for (int q = 0; q < 6; q++) {
                if (ni[q] < 0 || nj[q] < 0 || nk[q] < 0 || ni[q] >= nx || nj[q] >= ny ||
                    nk[q] >= nz) {
                    boundary = true;
                    continue;
                }
                const size_t n = sq__cell(g, ni[q], nj[q], nk[q]);
                if (label[n] == -2) {
                    label[n] = id;
                    s->stack[top++] = (int32_t)n;
                } else if (label[n] == -1) {
                    boundary = true;
                }
            }
            float zlo, zhi;
            sq__cloud_cell_bounds(f, i, j, k, &zlo, &zhi);
            const float dz = zhi - zlo;
            const float x = g->x0 + (float)i * g->dx, y = g->y0 + (float)j * g->dy;
            const float z = f->z[c];
            const double w = (double)f->cond[c] * (double)dz;
            a.w += w;
            a.cx += w * (double)x;
            a.cy += w * (double)y;
            a.cz += w * (double)z;
            a.lwp += (double)(f->conc[SQ_HYDRO_CLOUD][c] + f->conc[SQ_HYDRO_RAIN][c]) * (double)dz;
            a.iwp += (double)(f->conc[SQ_HYDRO_ICE][c] + f->conc[SQ_HYDRO_SNOW][c] +
                              f->conc[SQ_HYDRO_GRAUPEL][c]) *
                     (double)dz;
            const float lo[3] = {x - 0.5f * g->dx, y - 0.5f * g->dy, zlo};
            const float hi[3] = {x + 0.5f * g->dx, y + 0.5f * g->dy, zhi};
            for (int q = 0; q < 3; q++) {
                a.lo[q] = fminf(a.lo[q], lo[q]);
                a.hi[q] = fmaxf(a.hi[q], hi[q]);
            }
            a.top = fmaxf(a.top, z);
            a.cells++;
            a.boundary += boundary;
            const size_t col = (size_t)j * nx + i;
            s->column[col] = 1;
            if (s->colmark[col] != (int32_t)c0) { /* first cell of this fill in the column */
                s->colmark[col] = (int32_t)c0;
                a.foot++;
            }
        }
        sq_cloud_info *ci = &s->info[id];
        const double area = (double)g->dx * (double)g->dy;
        if (a.w > 0.0) {
            ci->center_m = sq_v3((float)(a.cx / a.w), (float)(a.cy / a.w), e * (float)(a.cz / a.w));
        }
        ci->min_m = sq_v3(a.lo[0], a.lo[1], e * a.lo[2]);
        ci->max_m = sq_v3(a.hi[0], a.hi[1], e * a.hi[2]);
        ci->cells += a.cells;
        ci->boundary_cells += a.boundary;
        ci->top_m = fmax(ci->top_m, (double)a.top);
        ci->lwp_g_m2 += a.lwp * area; /* total (g) for now: divided by the footprint below */
        ci->iwp_g_m2 += a.iwp * area;
        foot[id] += a.foot;
        lwp_all += a.lwp * area;
        iwp_all += a.iwp * area;
        if ((double)a.top > s->cloud_top_m) s->cloud_top_m = (double)a.top;
    }
    /* water paths averaged over each cloud's footprint */
    for (int id = 0; id < s->clouds; id++) {
        const double area = (double)foot[id] * (double)g->dx * (double)g->dy;
        if (area > 0.0) {
            s->info[id].lwp_g_m2 /= area;
            s->info[id].iwp_g_m2 /= area;
        }
    }
    int covered = 0;
    for (size_t q = 0; q < cols; q++) covered += s->column[q] != 0;
    s->cover_fraction = (double)covered / (double)cols;
    const double domain = (double)cols * (double)g->dx * (double)g->dy;
    s->lwp_g_m2 = lwp_all / domain;
    s->iwp_g_m2 = iwp_all / domain;
}
