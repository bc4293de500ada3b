/* avalanche_release.c — the release slab: its region (the release rectangle, or the polygons of
 * a world area), the slope-normal thickness at each point (the desc's depth, a polygon's
 * thickness attribute, optionally the Swiss slope and altitude dependence), and the particles
 * on the lattice of the spacing dx: vertical columns where the terrain normal has vertical
 * component n_z hold depth / (n_z dx) particles on average (4x4 ordered dithering of the
 * fraction), the lowest dx/2 from the terrain along the normal.
 *
 * Three passes of growing cost, so that a release too large for memory is refused at once:
 *   estimate  O(coarse cells): the volume and count over at most 512 x 512 cells of the region
 *   count     O(columns):      the exact dithered count, column by column (no per-particle loop)
 *   place     O(columns + N):  the positions
 * Count and place poll the context's interrupt callback. */
#include <float.h>
#include <math.h>
#include <string.h>

#include "avalanche_internal.h"

#define MOD "avalanche"
#define P "sq_avalanche_desc." /* the scene shows it as layers.<name>. */
#define ESTIMATE_CELLS 512     /* per axis, at most */
#define POLL_COLUMNS (1 << 18) /* columns between interrupt polls */

/* Swiss slope factor f(psi) = 0.291 / (sin psi - 0.202 cos psi): 1 at psi = 28 deg, smaller on
 * steeper slopes; 1 below 28 deg (release slopes are steeper; the formula grows without bound
 * toward 11 deg). nz = cos psi. */
double sq__aval_slope_factor(double nz)
{
    const double psi = acos(fmin(1.0, fmax(0.0, nz)));
    if (psi <= 28.0 * SQ_PI / 180.0) return 1.0;
    return 0.291 / (sin(psi) - 0.202 * cos(psi));
}

void sq__aval_region_bounds(const sq__aval_plan *pl, double b[4])
{
    if (pl->area) {
        memcpy(b, pl->area->bounds, 4 * sizeof(double));
    } else {
        b[0] = pl->release_lo[0];
        b[1] = pl->release_lo[1];
        b[2] = pl->release_hi[0];
        b[3] = pl->release_hi[1];
    }
}

double sq__aval_thickness_at(const sq__aval_plan *pl, const sq_world *w, double x, double y,
                             double *nz_out)
{
    int feature = 0;
    if (pl->area) {
        feature = sq_world_area_feature_at(pl->area, x, y);
        if (feature < 0) return -1.0;
    } else if (x < pl->release_lo[0] || x > pl->release_hi[0] || y < pl->release_lo[1] ||
               y > pl->release_hi[1]) {
        return -1.0;
    }
    const sq_vec3 n = sq_world_normal_at(w, (float)x, (float)y);
    double nz = (double)n.z;
    if (!(nz > 0.05)) nz = 0.05; /* a cliff: cap the column at 20 x the depth */
    if (nz_out) *nz_out = nz;
    double d = pl->d.release_depth_m;
    if (pl->area && isfinite(pl->area->feature_value[feature])) d = pl->area->feature_value[feature];
    if (pl->d.release_slope_dependent) d *= sq__aval_slope_factor(nz);
    if (pl->d.release_gradient_m != 0.0) {
        const double z = (double)sq_world_height_at(w, (float)x, (float)y);
        d += pl->d.release_gradient_m * (z - pl->d.release_reference_altitude_m) / 100.0;
    }
    return d > 0.0 ? d : 0.0;
}

/* The fine lattice of release columns: the rectangle's is centred in it (as many whole spacings
 * as fit), an area's starts at its bounds. */
static void lattice(const sq__aval_plan *pl, double *x0, double *y0, int64_t *ni, int64_t *nj)
{
    const double dx = pl->spacing;
    if (pl->area) {
        *x0 = pl->area->bounds[0];
        *y0 = pl->area->bounds[1];
        *ni = (int64_t)ceil((pl->area->bounds[2] - pl->area->bounds[0]) / dx);
        *nj = (int64_t)ceil((pl->area->bounds[3] - pl->area->bounds[1]) / dx);
    } else {
        *ni = (int64_t)floor(pl->d.release_length_m / dx + 1e-9);
        *nj = (int64_t)floor(pl->d.release_width_m / dx + 1e-9);
        *x0 = pl->d.release_x_m - 0.5 * (double)*ni * dx;
        *y0 = pl->d.release_y_m - 0.5 * (double)*nj * dx;
    }
}

sq_result sq__aval_release_estimate(sq_context *ctx, sq__aval_plan *pl, const sq_world *w)
{
    double b[4];
    sq__aval_region_bounds(pl, b);
    const double dx = pl->spacing;
    double c = dx;
    const double ext = fmax(b[2] - b[0], b[3] - b[1]);
    if (ext / c > ESTIMATE_CELLS) c = ext / ESTIMATE_CELLS;
    const int ni = (int)ceil((b[2] - b[0]) / c), nj = (int)ceil((b[3] - b[1]) / c);
    double vol = 0.0, top = -DBL_MAX, area = 0.0, zmax = -DBL_MAX;
    size_t voids = 0, inside = 0;
    double gx = 0.0, gy = 0.0;
    for (int j = 0; j < nj; j++)
        for (int i = 0; i < ni; i++) {
            const double x = b[0] + (i + 0.5) * c, y = b[1] + (j + 0.5) * c;
            double nz = 1.0;
            const double d = sq__aval_thickness_at(pl, w, x, y, &nz);
            if (d < 0.0) continue;
            inside++;
            if (sq_world_void_at(w, (float)x, (float)y)) voids++;
            const double h = (double)sq_world_height_at(w, (float)x, (float)y);
            const double cw = fmin(c, b[2] - b[0] - i * c), ch = fmin(c, b[3] - b[1] - j * c);
            area += cw * ch;
            vol += cw * ch * d / nz;
            if (d / nz > pl->max_column_m) pl->max_column_m = d / nz;
            if (h + d / nz + 0.5 * dx > top) top = h + d / nz + 0.5 * dx;
            const sq_vec3 n = sq_world_normal_at(w, (float)x, (float)y);
            gx += (double)n.x;
            gy += (double)n.y;
            if (h > zmax) {
                zmax = h;
                if (pl->area) {
                    pl->crown[0] = x;
                    pl->crown[1] = y;
                    pl->crown[2] = h;
                }
            }
        }
    if (inside == 0 || !(vol > 0.0))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "%srelease: the release %s holds no snow (area %.4g m2, thickness 0 "
                        "everywhere or no point inside); check release.depth_m and the polygons",
                        P, pl->area ? "area" : "rectangle", area);
    if (voids > 0)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "%srelease%s%s%s: %.1f %% of the release lies where the DEM has no data "
                        "(its heights were filled by interpolation); a release needs measured "
                        "terrain: move it or use a DEM without voids there",
                        P, pl->area ? ".area = '" : "", pl->area ? pl->d.release_area : "",
                        pl->area ? "'" : "", 100.0 * (double)voids / (double)inside);
    const double gl = sqrt(gx * gx + gy * gy);
    pl->fall_dir[0] = gl > 1e-6 ? gx / gl : 1.0;
    pl->fall_dir[1] = gl > 1e-6 ? gy / gl : 0.0;
    pl->volume_m3 = vol;
    pl->release_area_m2 = area;
    pl->release_top_z = top;
    pl->count_estimate = vol / (dx * dx * dx);
    /* the lattice's columns: a release thinner than a spacing on average has more columns
     * than particles; refuse those before counting them one by one */
    double x0, y0;
    int64_t li, lj;
    lattice(pl, &x0, &y0, &li, &lj);
    pl->columns = (double)li * (double)lj;
    return SQ_OK;
}

sq_result sq__aval_release_place(sq_context *ctx, const sq__aval_plan *pl, const sq_world *w,
                                 float *pos, size_t cap, size_t *count, double *volume,
                                 double *top_z)
{
    const double dx = pl->spacing;
    double x0, y0;
    int64_t ni, nj;
    lattice(pl, &x0, &y0, &ni, &nj);
    size_t n = 0;
    double vol = 0.0, top = -DBL_MAX;
    int64_t since_poll = 0;
    for (int64_t j = 0; j < nj; j++)
        for (int64_t i = 0; i < ni; i++) {
            if (++since_poll >= POLL_COLUMNS) {
                since_poll = 0;
                sq_result r = sq_context_poll_interrupt(ctx, MOD, pos ? "the particle release"
                                                                      : "counting the release");
                if (r != SQ_OK) return r;
            }
            const double x = x0 + ((double)i + 0.5) * dx, y = y0 + ((double)j + 0.5) * dx;
            double nz = 1.0;
            const double d = sq__aval_thickness_at(pl, w, x, y, &nz);
            if (d <= 0.0) continue;
            const double D = d / nz; /* vertical extent of the slab */
            vol += dx * dx * D;
            const int64_t m = (int64_t)floor(D / dx + sq__aval_dither((int)(i & 3), (int)(j & 3)));
            if (m <= 0) continue;
            const double h = (double)sq_world_height_at(w, (float)x, (float)y);
            const double zb = h + 0.5 * dx / nz;
            const double zt = zb + (double)(m - 1) * dx;
            if (zt > top) top = zt;
            if (pos) {
                if (n + (size_t)m > cap)
                    return sq__fail(ctx, SQ_ERR_INTERNAL, MOD,
                                    "release placement exceeds its count (%zu)", cap);
                for (int64_t k = 0; k < m; k++) {
                    pos[3 * (n + (size_t)k)] = (float)x;
                    pos[3 * (n + (size_t)k) + 1] = (float)y;
                    pos[3 * (n + (size_t)k) + 2] = (float)(zb + (double)k * dx);
                }
            }
            n += (size_t)m;
        }
    *count = n;
    if (volume) *volume = vol;
    if (top_z) *top_z = top;
    return SQ_OK;
}
