#version 450 core
// terrain.frag — Lambertian ground: albedo/pi * sun * cos(incidence) * volume transmittance +
// albedo * sky ambient, then aerial haze. The albedo blends the terrain kind's colour (sand on
// dunes, grass/soil elsewhere) with rock on steep slopes, modulated by a mean-one value-noise
// detail so that flat ground is not a uniform colour. Snow (snow_common.glsl) is blended over
// it by f_p (S2 eq 2.8).
#include "frame_common.glsl"
#include "snow_common.glsl"

in vec3 v_pos;
in vec3 v_normal;
in vec3 v_base;
layout(location = 0) out vec4 o_color;
layout(location = 0) uniform vec3 u_albedo_flat;  // kind colour on gentle slopes
layout(location = 1) uniform vec3 u_albedo_steep; // rock on slopes steeper than ~40 degrees
layout(location = 2) uniform vec3 u_albedo_low;   // below the snow line (meadow, scree)
layout(location = 3) uniform float u_snow_line;   // m above sea level; <= 0: no snow line
layout(location = 4) uniform vec2 u_steep_nz;     // n.z from which the rock fades in (x..y)

void main()
{
    vec3 n = normalize(v_normal);
    float steep = 1.0 - smoothstep(u_steep_nz.x, u_steep_nz.y, n.z);
    vec3 flat_albedo = u_albedo_flat;
    if (u_snow_line > 0.0) {
        // the snow line: a 100 m band, its edge moved +-60 m by noise at 150 m
        float z = v_pos.z + 120.0 * (sq_fbm(v_pos.xy / 150.0) - 0.5);
        flat_albedo = mix(u_albedo_low, u_albedo_flat, smoothstep(u_snow_line - 50.0, u_snow_line + 50.0, z));
    }
    vec3 albedo = mix(flat_albedo, u_albedo_steep, steep);
    // detail: mean ~1 (sq_fbm has mean ~0.5), +-15 % at 40 m and +-10 % at 2 m
    float detail = (0.85 + 0.3 * sq_fbm(v_pos.xy / 40.0)) *
                   (0.9 + 0.2 * sq_value_noise(v_pos.xy / 2.0));
    albedo *= detail;
    vec3 s = u_sun_dir.xyz;
    vec3 E = u_sun_radiance.xyz * sq_sun_visibility(v_pos, n);
    vec3 L = albedo * (E * max(dot(n, s), 0.0) + sq_ambient(n));
    float fp = sq_snow_cover(v_base, n, SQ_SNOW_FULL_GROUND, 0.0);
    if (fp > 0.0)
        L = mix(L, sq_snow_radiance(v_pos, sq_snow_shell_normal(v_base, n), normalize(u_cam_pos.xyz - v_pos), E), fp);
    o_color = vec4(sq_haze(L, v_pos), 1.0);
}
