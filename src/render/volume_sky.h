/* render/volume_sky.h — the sky and ground visibility of a volume's voxels through the medium
 * itself (volume_sky.c explains the model): the attenuation of the volume pass's ambient light.
 * Free of OpenGL. */
#ifndef SQ_RENDER_VOLUME_SKY_H
#define SQ_RENDER_VOLUME_SKY_H

#include <stddef.h>

/* The directions: straight up (down) with this weight, the rest over four grazing directions
 * along the grid axes at this cosine of the zenith angle. */
#define SQ_VOL_SKY_W_VERTICAL 0.5
#define SQ_VOL_SKY_MU_GRAZING 0.21132486540518713

/* Floats of scratch sq__volume_sky_visibility needs for an nx * ny * nz grid. */
static inline size_t sq__volume_sky_work_floats(int nx, int ny) { return 11 * (size_t)nx * ny; }

/* For a density grid (x fastest, cell sizes cell_m in m, densities < 0 read as 0) and the
 * diffuse light's attenuation per density unit and per metre climbed, per channel (sigma, 1/m;
 * render_volume.c: sigma_ext sqrt(3 (1 - albedo)(1 - albedo g))): out[3 v + c] = the sky's
 * visibility from voxel centre v on channel c (1 = clear sky), out[3 n + 3 v + c] = the
 * ground's (n voxels), each ground point's light scaled by its own sky visibility. */
void sq__volume_sky_visibility(const float *density, int nx, int ny, int nz,
                               const double cell_m[3], const double sigma[3], float *work,
                               float *out);

#endif
