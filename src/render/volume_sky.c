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
 * directions: half the weight straight up (down), half over four grazing directions at
 * mu = cos(zenith angle) = 0.211 (the lower two-point Gauss–Legendre node on [0, 1], 78° from
 * the zenith) along the grid axes, five per hemisphere; per channel (the albedo, so kappa, is per
 * channel: the light deep inside dust is redder).
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

/* Bilinear sample of a layer (nx * ny values) at fractional cell coordinates (x, y); false when
 * the point lies beyond the box's side (more than half a cell outside the outer centres). */
static inline bool layer_sample(const float *layer, int nx, int ny, float x, float y, float *out)
{
    if (x < -0.5f || y < -0.5f || x > (float)nx - 0.5f || y > (float)ny - 0.5f) return false;
    x = x < 0.0f ? 0.0f : (x > (float)(nx - 1) ? (float)(nx - 1) : x);
    y = y < 0.0f ? 0.0f : (y > (float)(ny - 1) ? (float)(ny - 1) : y);
    int i0 = (int)x, j0 = (int)y;
    if (i0 > nx - 2) i0 = nx > 1 ? nx - 2 : 0;
    if (j0 > ny - 2) j0 = ny > 1 ? ny - 2 : 0;
    const int i1 = nx > 1 ? i0 + 1 : 0, j1 = ny > 1 ? j0 + 1 : 0;
    const float fx = nx > 1 ? x - (float)i0 : 0.0f, fy = ny > 1 ? y - (float)j0 : 0.0f;
    const float a = layer[(size_t)j0 * nx + i0], b = layer[(size_t)j0 * nx + i1];
    const float c = layer[(size_t)j1 * nx + i0], d = layer[(size_t)j1 * nx + i1];
    const float ab = a + (b - a) * fx;
    *out = ab + ((c + (d - c) * fx) - ab) * fy;
    return true;
}

static inline float pos(float v) { return v > 0.0f ? v : 0.0f; }

/* One direction's sweep. up: toward the sky (layers from the top), else toward the ground.
 * (ox, oy): horizontal cells travelled per layer along the direction (0, 0: straight up or
 * down); dz: the layers' spacing (m). ground: with !up, the ground's light under each column
 * per channel (3 nx*ny), else NULL. work: 8 nx*ny scratch (the vertical density path and the
 * carried ground light of the previous and the current layer). Adds w * exp(-sigma_c D)
 * (times the ground's light) to out[3 v + c] (out: the sky's or the ground's array). */
static void sweep(const float *density, int nx, int ny, int nz, const float sigma[3], float ox,
                  float oy, float dz, bool up, const float *ground, float w, float *work,
                  float *out)
{
    const size_t nxy = (size_t)nx * (size_t)ny;
    float *d_prev = work, *d_cur = work + nxy, *lit_prev = work + 2 * nxy,
          *lit_cur = work + 5 * nxy;
    const bool straight = ox == 0.0f && oy == 0.0f;
    for (int s = 0; s < nz; s++) {
        const int k = up ? nz - 1 - s : s;
        const float *rho = density + (size_t)k * nxy;
        const float *rho_prev = s > 0 ? density + (size_t)(up ? k + 1 : k - 1) * nxy : NULL;
        float *o_layer = out + 3 * (size_t)k * nxy;
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                const size_t c = (size_t)j * nx + i;
                const float r0 = pos(rho[c]);
                /* half a layer to the box's top (bottom), or to where the direction left the
                 * box through a side (clear air beyond) */
                float D = 0.5f * r0 * dz, L[3] = {1.0f, 1.0f, 1.0f}, dp, rp;
                const float x = (float)i + ox, y = (float)j + oy;
                if (s == 0) {
                    for (int ch = 0; ground && ch < 3; ch++)
                        if (!layer_sample(ground + ch * nxy, nx, ny, (float)i + 0.5f * ox,
                                          (float)j + 0.5f * oy, &L[ch]))
                            L[ch] = 1.0f;
                } else if (straight) {
                    D = d_prev[c] + 0.5f * (r0 + pos(rho_prev[c])) * dz;
                    for (int ch = 0; ground && ch < 3; ch++) L[ch] = lit_prev[ch * nxy + c];
                } else if (layer_sample(d_prev, nx, ny, x, y, &dp)) {
                    layer_sample(rho_prev, nx, ny, x, y, &rp);
                    D = dp + 0.5f * (r0 + pos(rp)) * dz;
                    for (int ch = 0; ground && ch < 3; ch++)
                        layer_sample(lit_prev + ch * nxy, nx, ny, x, y, &L[ch]);
                }
                d_cur[c] = D;
                float *o = o_layer + 3 * c;
                for (int ch = 0; ch < 3; ch++) {
                    lit_cur[ch * nxy + c] = L[ch];
                    o[ch] += w * L[ch] * (D > 0.0f ? expf(-sigma[ch] * D) : 1.0f);
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
    const float sg[3] = {(float)sigma[0], (float)sigma[1], (float)sigma[2]};
    static const float az[SKY_AZIMUTHS][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
    const double tan_g = sqrt(1.0 - SQ_VOL_SKY_MU_GRAZING * SQ_VOL_SKY_MU_GRAZING) /
                         SQ_VOL_SKY_MU_GRAZING;
    const float gx = (float)(tan_g * cell_m[2] / cell_m[0]),
                gy = (float)(tan_g * cell_m[2] / cell_m[1]);
    const float dz = (float)cell_m[2];
    for (int up = 1; up >= 0; up--) {
        float *ground = NULL;
        if (!up) {
            /* the ground under each column is lit as the sky reaches the lowest layer */
            ground = work + 8 * nxy;
            for (int ch = 0; ch < 3; ch++)
                for (size_t c = 0; c < nxy; c++) ground[ch * nxy + c] = sky[3 * c + ch];
        }
        float *o = up ? sky : gnd;
        sweep(density, nx, ny, nz, sg, 0.0f, 0.0f, dz, up != 0, ground,
              (float)SQ_VOL_SKY_W_VERTICAL, work, o);
        for (int a = 0; a < SKY_AZIMUTHS; a++)
            sweep(density, nx, ny, nz, sg, az[a][0] * gx, az[a][1] * gy, dz, up != 0, ground,
                  (float)(1.0 - SQ_VOL_SKY_W_VERTICAL) / SKY_AZIMUTHS, work, o);
    }
}
