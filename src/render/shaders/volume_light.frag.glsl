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
#include "volume_common.glsl"

layout(binding = 0) uniform sampler3D u_density;
layout(binding = 1) uniform sampler2DArray u_light;

in vec3 v_p;                   // volume_light.vert: the ray meets the slice plane here,
in float v_lambda;             // at this ray parameter;
in vec3 v_tmin, v_tmax;        // the ray against the box planes, per axis

uniform int u_src;             // layer holding L_old
uniform vec2 u_size;           // light buffer texels
uniform float u_dlambda;       // light slab length spacing / (s . wl)
uniform vec3 u_box_lo, u_box_size;
uniform vec3 u_sigma_ext, u_albedo;
uniform vec3 u_forward;        // F: fraction of scattered light kept in the beam, per channel
uniform vec2 u_blur;           // blur radius in texture coordinates

layout(location = 0) out vec4 o_l;

void main()
{
    // the texel's own value: a fetch (bilinear filtering at a texel centre returns it)
    vec3 L_old = texelFetch(u_light, ivec3(ivec2(gl_FragCoord.xy), u_src), 0).rgb;
    vec2 box = vec2(max(max(v_tmin.x, v_tmin.y), v_tmin.z), min(min(v_tmax.x, v_tmax.y), v_tmax.z));
    float len = vol_clip_len(v_lambda, 0.5 * u_dlambda, box.x, box.y); // 0: the ray misses the slab
    float rho = vol_density(u_density, v_p, u_box_lo, u_box_size);
    vec3 T = exp(-rho * u_sigma_ext * len);
    vec3 L = T * L_old;
#if VOL_LIGHT_MODE == 1
    L += u_albedo * (1.0 - T) * u_forward * L_old;
#elif VOL_LIGHT_MODE == 2
    // centre 1/4, six taps on a ring 1/8 each (sum 1)
    vec3 b = 0.25 * L_old;
    vec2 uv = gl_FragCoord.xy / u_size;
    float layer = float(u_src);
    for (int i = 0; i < 6; i++) {
        float a = float(i) * (VOL_PI / 3.0);
        b += 0.125 * textureLod(u_light, vec3(uv + u_blur * vec2(cos(a), sin(a)), layer), 0.0).rgb;
    }
    L += u_albedo * (1.0 - T) * u_forward * b;
#endif
    o_l = vec4(L, 1.0);
}
