#version 450 core
// surface.frag — shading of heightfield surfaces, blended over the ground by coverage
// (C = f * C_surface + (1 - f) * C_below, SPEC 6.4 eq. 2.8, through alpha blending).
// Snow (material 2): albedo ~0.9, normals perturbed by value noise (SPEC 6.4: several octaves,
// frequency x2, amplitude x1/2), wrapped diffuse for its soft, translucent look, a weak
// Blinn–Phong highlight (eq. 2.7) and sky light tinted slightly blue in shadow.
// Avalanche snow (material 4, docs/phen/avalanche.md): churned snow is granular — lumps of
// ~0.3–1.5 m with shadowed gaps between them — so it reads darker and rougher than the smooth
// cover around it: strongly perturbed normals, sun and sky occluded in the gaps (the lumps'
// own shadows), no wrap. Where a lump is smaller than a pixel the shading fades to the lumps'
// mean (no shimmer), which keeps the flow's overall darkening at any distance. Other
// materials: Lambert.
#include "frame_common.glsl"

in vec3 v_pos;
in vec3 v_normal;
in float v_coverage;
layout(location = 0) out vec4 o_color;
layout(location = 4) uniform vec3 u_albedo;
layout(location = 5) uniform int u_material;

void main()
{
    if (v_coverage < 1.0 / 255.0) discard;
    vec3 n = normalize(v_normal);
    vec3 s = u_sun_dir.xyz;
    vec3 E = u_sun_radiance.xyz * sq_sun_visibility(v_pos, n);
    vec3 L;
    if (u_material == 2) {
        vec2 q = v_pos.xy / 0.6;
        float e = 0.05;
        vec2 grad = vec2(sq_fbm(q + vec2(e, 0.0)) - sq_fbm(q - vec2(e, 0.0)),
                         sq_fbm(q + vec2(0.0, e)) - sq_fbm(q - vec2(0.0, e))) / (2.0 * e);
        n = normalize(n + 0.08 * vec3(-grad, 0.0));
        const float wrap = 0.2;
        float diffuse = max((dot(n, s) + wrap) / (1.0 + wrap), 0.0);
        vec3 v = normalize(u_cam_pos.xyz - v_pos);
        vec3 h = normalize(s + v);
        float spec = dot(n, s) > 0.0 ? 0.06 * pow(max(dot(n, h), 0.0), 48.0) : 0.0;
        vec3 ambient = sq_ambient(n) * vec3(0.92, 0.97, 1.08);
        L = u_albedo * (E * diffuse + ambient) + E * spec;
    } else if (u_material == 4) {
        vec2 q = v_pos.xy / 0.8;                 // lumps ~0.8 m
        float px = length(fwidth(q));            // lump periods per pixel
        float detail = 1.0 - smoothstep(0.35, 1.2, px);
        float e = 0.07;
        float h0 = sq_fbm(q);
        vec2 grad = vec2(sq_fbm(q + vec2(e, 0.0)) - sq_fbm(q - vec2(e, 0.0)),
                         sq_fbm(q + vec2(0.0, e)) - sq_fbm(q - vec2(0.0, e))) / (2.0 * e);
        vec3 nl = normalize(n + 1.1 * detail * vec3(-grad, 0.0));
        // tops (h0 high) see sun and sky; gaps are shadowed by the lumps around them
        float top = mix(0.62, smoothstep(0.28, 0.68, h0), detail);
        float sun_occ = mix(0.25, 1.0, top);
        float sky_occ = mix(0.45, 1.0, top);
        float diffuse = max(dot(nl, s), 0.0) * sun_occ;
        vec3 ambient = sq_ambient(nl) * vec3(0.92, 0.97, 1.08) * sky_occ;
        float grain = 0.93 + 0.07 * sq_value_noise(v_pos.xy / 0.15) * detail;
        L = u_albedo * grain * (E * diffuse + ambient);
    } else {
        float detail = 0.9 + 0.2 * sq_fbm(v_pos.xy / 3.0);
        L = u_albedo * detail * (E * max(dot(n, s), 0.0) + sq_ambient(n));
    }
    o_color = vec4(sq_haze(L, v_pos), clamp(v_coverage, 0.0, 1.0));
}
