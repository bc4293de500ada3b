#version 450 core
// volume_light.frag — light pass of half-angle slicing (SPEC 3.3 eqs 3.19-3.21, 3.4 step 4b),
// rendered FROM THE LIGHT: every texel of the light buffer is one sun ray (orthographic,
// directional sun); it meets slice k's plane at one point. The texel's radiance (as a ratio
// to the sun's) is carried across the slab of that ray between the neighbouring slices,
// clipped to the volume box (length Δ): L_new = T L_old + g, T = exp(-β_ext Δ). The forward
// in-scatter g (Harris multiple forward scattering with the Δx factor S0 omits) is the light
// scattered in the slab, a (1 - T) ~ β_sca Δ, times the fraction F of the phase function
// inside the forward cone the buffer keeps (Harris's γ = 0.09 sr), applied to a small disc
// blur of L_old whose radius is the cone's spread over the slab (Kniss's forward blur).
// single-scatter ablation: g = 0. Texels whose ray misses the slab copy L_old. L_old is layer
// u_src of the light array, the result goes to another layer (one layer per slice, so that
// the eye pass can read every slice's light after all light passes ran once).
// Variants are compiled with VOL_LIGHT_MODE defined (render_volume.c): 0 single-scatter
// ablation, 1 forward in-scatter of the centre value (the blur ring is narrower than half a
// texel, below the buffer's resolution), 2 with the six-tap ring. Separate programs rather
// than branches on uniforms: llvmpipe runs both sides of a branch under an execution mask.
// Without the ring every texel's recursion is its own, so one pass carries the light across
// VOL_LIGHT_STEPS consecutive slabs (8 in modes 0 and 1) and writes each result to its own
// layer (one colour attachment per layer; unused ones are GL_NONE): fewer passes, and the
// light stays in registers between slabs. With the ring a pass is one slab.
// The alpha channel carries the sun's optical depth tau along the ray (green extinction, no
// in-scatter; 0 in layer 0): the eye pass's multiple-scattering octaves attenuate the sun by
// exp(-a^i tau) from it (Wrenninge et al. 2013; render_volume.c, vol_ms_weight).
#include "volume_common.glsl"

layout(binding = 0) uniform sampler3D u_density;
layout(binding = 1) uniform sampler2DArray u_light;

in vec3 v_p;                   // volume_light.vert: the ray meets the pass's first slice plane
in float v_lambda;             // here, at this ray parameter;
in vec3 v_tmin, v_tmax;        // the ray against the box planes, per axis

uniform int u_src;             // layer holding L_old
uniform vec2 u_size;           // light buffer texels
uniform vec3 u_wl;             // light propagation direction
uniform float u_dlambda;       // light slab length spacing / (s . wl): next plane's lambda step
uniform vec3 u_tex_lo, u_tex_size; // the density's box (texture coordinates 0..1)
uniform vec3 u_sigma_ext, u_albedo;
uniform vec3 u_forward;        // F: fraction of scattered light kept in the beam, per channel
uniform vec2 u_blur;           // blur radius in texture coordinates

layout(location = 0) out vec4 o_l[VOL_LIGHT_STEPS];

void main()
{
    // the texel's own value: a fetch (bilinear filtering at a texel centre returns it)
    vec4 src = texelFetch(u_light, ivec3(ivec2(gl_FragCoord.xy), u_src), 0);
    vec3 L = src.rgb;
    float tau = src.a;
    vec2 box = vec2(max(max(v_tmin.x, v_tmin.y), v_tmin.z), min(min(v_tmax.x, v_tmax.y), v_tmax.z));
    for (int i = 0; i < VOL_LIGHT_STEPS; i++) {
        float dl = float(i) * u_dlambda;
        float len = vol_clip_len(v_lambda + dl, 0.5 * u_dlambda, box.x, box.y); // 0: misses
        float rho = vol_density(u_density, v_p + u_wl * dl, u_tex_lo, u_tex_size);
        vec3 T = exp(-rho * u_sigma_ext * len);
        tau += rho * u_sigma_ext.g * len;
#if VOL_LIGHT_MODE == 0
        L = T * L;
#elif VOL_LIGHT_MODE == 1
        L = T * L + u_albedo * (1.0 - T) * u_forward * L;
#else
        // centre 1/4, six taps on a ring 1/8 each (sum 1)
        vec3 b = 0.25 * L;
        vec2 uv = gl_FragCoord.xy / u_size;
        float layer = float(u_src);
        for (int j = 0; j < 6; j++) {
            float a = float(j) * (VOL_PI / 3.0);
            b += 0.125 * textureLod(u_light, vec3(uv + u_blur * vec2(cos(a), sin(a)), layer),
                                    0.0).rgb;
        }
        L = T * L + u_albedo * (1.0 - T) * u_forward * b;
#endif
        o_l[i] = vec4(L, tau);
    }
}
