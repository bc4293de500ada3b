// volume_common.glsl — shared by the volume pass shaders (#include "volume_common.glsl"):
// ray/box intersection, the Henyey–Greenstein phase function (SPEC 2.6; cos theta between
// PROPAGATION directions, g > 0 forward), the density lookup, and the slab
// clipping used to make every slice stand for exactly the part of its slab that lies inside
// the box. The noise perturbation of texture coordinates (S0 Fig 3.12) is baked into the
// density texture once per frame (volume_bake.comp), so the passes read one texture.

const float VOL_PI = 3.14159265358979;

// Ray p + t d against the box [lo, hi]: returns (t_enter, t_exit); empty if t_enter > t_exit.
vec2 vol_box_interval(vec3 p, vec3 d, vec3 lo, vec3 hi)
{
    vec3 inv = 1.0 / d; // IEEE: +-inf for axis-parallel rays, handled by min/max below
    vec3 t0 = (lo - p) * inv;
    vec3 t1 = (hi - p) * inv;
    vec3 tmin = min(t0, t1);
    vec3 tmax = max(t0, t1);
    return vec2(max(max(tmin.x, tmin.y), tmin.z), min(min(tmax.x, tmax.y), tmax.z));
}

float vol_hg(float cos_theta, float g)
{
    float d = 1.0 + g * g - 2.0 * g * cos_theta;
    return (1.0 - g * g) / (4.0 * VOL_PI * d * sqrt(d));
}

// Texture coordinates of world point p in the density's box [lo, lo + size]: x and z clamped,
// y left to the texture's wrap (clamp to edge, or mirrored: sq_volume_view.mirror_y_m).
vec3 vol_tc(vec3 p, vec3 lo, vec3 size)
{
    vec3 tc = (p - lo) / size;
    return vec3(clamp(tc.x, 0.0, 1.0), tc.y, clamp(tc.z, 0.0, 1.0));
}

// Density at world point p; lo, size: the density's box (u_tex_lo, u_tex_size). Clamped into the
// box in x and z; in y the texture's wrap decides: clamped to the edge texels, or mirrored at the
// y faces when the view draws the box beyond them (sq_volume_view.mirror_y_m).
// Explicit LOD 0: the textures have one level, and llvmpipe skips the LOD computation.
// Sharp edges (sq_volume_view.edge_sharpness; render_volume.c upload_density): the texture's
// green holds the local maximum M of the density over the cell's 27 neighbours and blue the
// edge weight e (0 where the density varies smoothly); the trilinear rho is moved toward
// M smoothstep(0.4, 0.6, rho / M), which puts the edge at the half-maximum contour and makes
// it five times steeper (alpha unused). One-channel textures read green = blue = 0: unchanged.
float vol_density(sampler3D dens, vec3 p, vec3 lo, vec3 size)
{
    vec3 tc = vol_tc(p, lo, size);
    vec3 s = textureLod(dens, tc, 0.0).rgb;
    float rho = max(s.r, 0.0);
    float f = clamp(rho / max(s.g, 1e-30), 0.0, 1.0);
    return mix(rho, s.g * smoothstep(0.4, 0.6, f), clamp(s.b, 0.0, 1.0));
}

// The same with the edge drawn on a smooth field (the eye pass): the half-maximum contour of the
// trilinear field is made of the cells' near-planar pieces with kinks between them, which the
// steepened edge shows as facets up close. Where the edge weight is non-zero, rho and M for
// the edge come from the cubic B-spline of the texels instead (C2: the contour bends smoothly
// through the cells; eight trilinear fetches, Sigg & Hadwiger 2005, GPU Gems 2 ch. 20), the
// weight e itself and the smooth field (e = 0) stay trilinear. The B-spline's slope at a step's
// half-maximum is 3/4 of the trilinear one, so the edge is steepened over 0.45-0.55 (the same
// width as vol_density's, docs/validation.md "Sharp dust edges").
float vol_density_smooth(sampler3D dens, vec3 p, vec3 lo, vec3 size)
{
    vec3 tc = vol_tc(p, lo, size);
    vec3 s = textureLod(dens, tc, 0.0).rgb;
    float rho = max(s.r, 0.0), e = clamp(s.b, 0.0, 1.0);
    if (e <= 0.0) return rho;
    vec3 n = vec3(textureSize(dens, 0));
    vec3 x = tc * n - 0.5, i = floor(x), f = x - i;
    vec3 f2 = f * f, f3 = f2 * f, g = 1.0 - f;
    vec3 w0 = g * g * g / 6.0, w1 = (4.0 - 6.0 * f2 + 3.0 * f3) / 6.0;
    vec3 w3 = f3 / 6.0, w2 = 1.0 - w0 - w1 - w3;
    vec3 a0 = w0 + w1, a1 = w2 + w3;
    vec3 c0 = (i - 0.5 + w1 / a0) / n, c1 = (i + 1.5 + w3 / a1) / n;
    vec3 b = vec3(0.0);
    for (int k = 0; k < 8; k++) {
        vec3 sel = vec3(k & 1, (k >> 1) & 1, (k >> 2) & 1);
        vec3 wk = mix(a0, a1, sel);
        b += wk.x * wk.y * wk.z * textureLod(dens, mix(c0, c1, sel), 0.0).rgb;
    }
    float m = max(b.g, 1e-30);
    return mix(rho, m * smoothstep(0.45, 0.55, clamp(max(b.r, 0.0) / m, 0.0, 1.0)), e);
}

// Length of the slab [c - h, c + h] that lies inside [a, b] (0 if none).
float vol_clip_len(float c, float h, float a, float b)
{
    return max(min(c + h, b) - max(c - h, a), 0.0);
}
