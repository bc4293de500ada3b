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
// single-scatter ablation: g = 0. Texels whose ray misses the slab copy L_old (ping-pong).
#include "volume_common.glsl"

layout(binding = 0) uniform sampler3D u_density;
layout(binding = 1) uniform sampler2D u_light_old;
layout(binding = 5) uniform sampler3D u_noise;

uniform vec2 u_size;           // light buffer texels
uniform vec4 u_uv_rect;        // light-frame coordinates covered: u0, v0, u1, v1 (m)
uniform vec3 u_e1, u_e2;       // light-frame axes (perpendicular to wl)
uniform vec3 u_wl;             // light propagation direction
uniform vec3 u_s;              // slice axis
uniform float u_plane;         // this slice: s . x = u_plane
uniform float u_dlambda;       // light slab length spacing / (s . wl)
uniform vec3 u_box_lo, u_box_size, u_dims;
uniform vec3 u_sigma_ext, u_albedo;
uniform vec3 u_forward;        // F: fraction of scattered light kept in the beam, per channel
uniform vec2 u_blur;           // blur radius in texture coordinates
uniform int u_blur_wide;       // 1 if that radius reaches half a texel
uniform int u_multiple;        // 0: single-scatter ablation (pure attenuation)
uniform int u_use_noise;
uniform float u_noise_amp, u_noise_freq;
uniform vec3 u_noise_offset;

layout(location = 0) out vec4 o_l;

void main()
{
    vec2 uv = gl_FragCoord.xy / u_size;
    vec3 L_old = texture(u_light_old, uv).rgb;
    vec2 uvm = mix(u_uv_rect.xy, u_uv_rect.zw, uv);
    vec3 q = u_e1 * uvm.x + u_e2 * uvm.y;              // ray origin on the light frame plane
    float lambda = (u_plane - dot(u_s, q)) / dot(u_s, u_wl);
    vec3 p = q + u_wl * lambda;
    vec2 box = vol_box_interval(q, u_wl, u_box_lo, u_box_lo + u_box_size);
    float len = vol_clip_len(lambda, 0.5 * u_dlambda, box.x, box.y);
    if (len <= 0.0) {
        o_l = vec4(L_old, 1.0);
        return;
    }
    float rho = vol_density(u_density, u_noise, p, u_box_lo, u_box_size, u_dims,
                            u_use_noise != 0, u_noise_amp, u_noise_freq, u_noise_offset);
    vec3 T = exp(-rho * u_sigma_ext * len);
    vec3 L = T * L_old;
    if (u_multiple != 0) {
        // centre 1/4, six taps on a ring 1/8 each (sum 1); a ring narrower than half a texel
        // is below the buffer's resolution and the blur is the centre value
        vec3 b = L_old;
        if (u_blur_wide != 0) {
            b *= 0.25;
            for (int i = 0; i < 6; i++) {
                float a = float(i) * (VOL_PI / 3.0);
                b += 0.125 * texture(u_light_old, uv + u_blur * vec2(cos(a), sin(a))).rgb;
            }
        }
        L += u_albedo * (1.0 - T) * u_forward * b;
    }
    o_l = vec4(L, 1.0);
}
