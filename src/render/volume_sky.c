/* volume_sky.c — how much of the sky and of the ground every voxel of a volume sees through the
 * medium itself: the attenuation of the volume pass's ambient light (the default; the renderer's
 * volume_ambient_uniform turns it off; docs/validation.md "Ambient light inside the medium").
 *
 * Model. The ambient source of the eye pass is the phase-averaged radiance of the sky (upper
 * hemisphere) and of the ground (lower hemisphere), each over half the sphere (render_volume.c,
 * ambient_radiance). Deep in a scattering medium lit by diffuse light the mean intensity decays
 * as exp(-kappa tau) with depth tau (extinction optical depth), the diffusion approximation's
 * decay constant kappa = sqrt(3 (1 - albedo)(1 - albedo g)) (Ishimaru 1978, ch. 9; Bohren &
 * Clothiaux 2006, ch. 6): absorption removes the light, scattering only slows its way in (a
 * conservative medium, albedo 1, is not darkened by it: kappa = 0). Each hemisphere's share is
 * scaled by
 *     V = sum over directions n of w_n exp(-kappa sigma_ext D_n),
 * D_n the density integrated over the VERTICAL distance the direction n climbs (descends) from
 * the point until it leaves the box: in a horizontally uniform layer every direction gives the
 * same D and V = exp(-kappa tau_v) of the vertical optical depth tau_v above (below) the point,
 * the diffusion decay; where a finite body has open sides (a wall's face, a blob's flank), the
 * directions that leave it sideways reach the clear sky sooner and let that light in. The
 * directions: two-point Gauss–Legendre nodes in mu = cos(zenith angle) on [0, 1]
 * (mu = 1/2 ± 1/(2 sqrt 3), weight 1/2 each) times four azimuths along the grid axes (1/4 each),
 * eight per hemisphere; per channel (the albedo, so kappa, is per channel: the light deep inside
 * dust is redder).
 *
 * Evaluation. Per direction one sweep over the layers (from the top for the sky, from the bottom
 * for the ground): D at a voxel centre is D at the point one layer further along the direction
 * (bilinear in that layer) plus the trapezoid of the density over the layer's spacing; O(voxels)
 * per direction. Beyond the box's sides the air is clear (a direction that leaves through a side
 * sees the unattenuated sky or ground from there), above its top the sky is clear, and the
 * ground under the box is lit in proportion to the sky visibility of the box's lowest layer (its
 * own light, sun and sky, scaled like the sky's: an approximation for the sun part, whose shadow
 * is not computed here). */
#include <math.h>
#include <stdbool.h>
#include <string.h>

#include "render/volume_sky.h"

#define SKY_AZIMUTHS 4

const double sq__volume_sky_mu[SQ_VOL_SKY_MU_NODES] = {0.78867513459481287,
                                                       0.21132486540518713};
const double sq__volume_sky_weight[SQ_VOL_SKY_MU_NODES] = {0.5, 0.5};

/* Bilinear sample of a layer (nx * ny values) at fractional cell coordinates (x, y); false when
 * the point lies beyond the box's side (more than half a cell outside the outer centres). */
static bool layer_sample(const float *layer, int nx, int ny, double x, double y, double *out)
{
    if (x < -0.5 || y < -0.5 || x > nx - 0.5 || y > ny - 0.5) return false;
    x = x < 0.0 ? 0.0 : (x > nx - 1 ? nx - 1 : x);
    y = y < 0.0 ? 0.0 : (y > ny - 1 ? ny - 1 : y);
    int i0 = (int)x, j0 = (int)y;
    if (i0 > nx - 2) i0 = nx > 1 ? nx - 2 : 0;
    if (j0 > ny - 2) j0 = ny > 1 ? ny - 2 : 0;
    const int i1 = nx > 1 ? i0 + 1 : 0, j1 = ny > 1 ? j0 + 1 : 0;
    const double fx = nx > 1 ? x - i0 : 0.0, fy = ny > 1 ? y - j0 : 0.0;
    const double a = layer[(size_t)j0 * nx + i0], b = layer[(size_t)j0 * nx + i1];
    const double c = layer[(size_t)j1 * nx + i0], d = layer[(size_t)j1 * nx + i1];
    *out = (a + (b - a) * fx) + ((c + (d - c) * fx) - (a + (b - a) * fx)) * fy;
    return true;
}

/* One direction's sweep. up: toward the sky (layers from the top), else toward the ground.
 * (ox, oy): horizontal cells travelled per layer along the direction; dz: the layers' spacing
 * (m). ground: with !up, the ground's light under each column per channel (3 nx*ny), else NULL.
 * work: 8 nx*ny scratch (the vertical density path and the carried ground light of the previous
 * and the current layer). Adds w * exp(-sigma_c D) (times the ground's light) to out[3 v + c]
 * (out: the sky's or the ground's array). */
static void sweep(const float *density, int nx, int ny, int nz, const double sigma[3],
                  double ox, double oy, double dz, bool up, const float *ground, double w,
                  float *work, float *out)
{
    const size_t nxy = (size_t)nx * (size_t)ny;
    float *d_prev = work, *d_cur = work + nxy, *lit_prev = work + 2 * nxy,
          *lit_cur = work + 5 * nxy;
    for (int s = 0; s < nz; s++) {
        const int k = up ? nz - 1 - s : s;
        const float *rho = density + (size_t)k * nxy;
        const float *rho_prev = s > 0 ? density + (size_t)(up ? k + 1 : k - 1) * nxy : NULL;
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                const size_t c = (size_t)j * nx + i;
                const double r0 = rho[c] > 0.0f ? (double)rho[c] : 0.0;
                /* half a layer to the box's top (bottom), or to where the direction left the
                 * box through a side (clear air beyond) */
                double D = r0 * 0.5 * dz, L[3] = {1.0, 1.0, 1.0}, dp, rp;
                const double x = i + ox, y = j + oy;
                if (s == 0) {
                    for (int ch = 0; ground && ch < 3; ch++)
                        if (!layer_sample(ground + ch * nxy, nx, ny, i + 0.5 * ox, j + 0.5 * oy,
                                          &L[ch]))
                            L[ch] = 1.0;
                } else if (layer_sample(d_prev, nx, ny, x, y, &dp)) {
                    layer_sample(rho_prev, nx, ny, x, y, &rp);
                    D = dp + 0.5 * (r0 + (rp > 0.0 ? rp : 0.0)) * dz;
                    for (int ch = 0; ground && ch < 3; ch++)
                        layer_sample(lit_prev + ch * nxy, nx, ny, x, y, &L[ch]);
                }
                d_cur[c] = (float)D;
                float *o = out + 3 * ((size_t)k * nxy + c);
                for (int ch = 0; ch < 3; ch++) {
                    lit_cur[ch * nxy + c] = (float)L[ch];
                    o[ch] += (float)(w * L[ch] * exp(-sigma[ch] * D));
                }
            }
        float *tmp = d_prev;
        d_prev = d_cur;
        d_cur = tmp;
        tmp = lit_prev;
        lit_prev = lit_cur;
        lit_cur = tmp;
    }
}

void sq__volume_sky_visibility(const float *density, int nx, int ny, int nz, const double cell_m[3],
                               const double sigma[3], float *work, float *out)
{
    const size_t nxy = (size_t)nx * (size_t)ny, n = nxy * (size_t)nz;
    memset(out, 0, sizeof(float) * 6 * n);
    float *sky = out, *gnd = out + 3 * n;
    static const double az[SKY_AZIMUTHS][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
    for (int up = 1; up >= 0; up--) {
        float *ground = NULL;
        if (!up) {
            /* the ground under each column is lit as the sky reaches the lowest layer */
            ground = work + 8 * nxy;
            for (int ch = 0; ch < 3; ch++)
                for (size_t c = 0; c < nxy; c++) ground[ch * nxy + c] = sky[3 * c + ch];
        }
        for (int m = 0; m < SQ_VOL_SKY_MU_NODES; m++) {
            const double mu = sq__volume_sky_mu[m];
            const double tan_t = sqrt(1.0 - mu * mu) / mu;
            for (int a = 0; a < SKY_AZIMUTHS; a++) {
                const double ox = az[a][0] * tan_t * cell_m[2] / cell_m[0];
                const double oy = az[a][1] * tan_t * cell_m[2] / cell_m[1];
                sweep(density, nx, ny, nz, sigma, ox, oy, cell_m[2], up != 0, ground,
                      sq__volume_sky_weight[m] / SKY_AZIMUTHS, work, up ? sky : gnd);
            }
        }
    }
}
