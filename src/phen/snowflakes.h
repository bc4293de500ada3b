/* phen/snowflakes.h — falling snowflakes as a particles drawable, shared by the phenomena that
 * draw snowfall (the snowdrift's flakes in its lattice wind, the snow cover's around the camera):
 * one rule for how a flake looks. */
#ifndef SQ_PHEN_SNOWFLAKES_H
#define SQ_PHEN_SNOWFLAKES_H

#include "squall/drawable.h"

/* Fills dr with count flakes at position (3 floats each), their in-plane rotation, radius
 * (NULL: radius_default_m for all) and fade (NULL: 1): the six-fold flake sprite, opaque (optical
 * depth 2 through the centre), white ice (single-scattering albedo 0.95, grey extinction),
 * forward scattering of the sun (Henyey–Greenstein g = 0.5); softness_m fades flakes against
 * opaque geometry (0: hard). */
void sq__snowflakes_drawable(sq_drawable *dr, int count, const float *position,
                             const float *rotation_rad, const float *radius_m, const float *fade,
                             float radius_default_m, float softness_m, uint64_t version);

#endif
