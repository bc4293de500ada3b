#version 450 core
// mesh.frag — flat Lambert shading of obstacles with the sun (through the volume light buffer)
// and sky ambient, then aerial haze. Fences (kind 2) are porous: 10 cm boards with 5 cm gaps
// between a bottom and a top rail. Snow is blended over them by f_p (snow_common.glsl).
#include "frame_common.glsl"
#include "snow_common.glsl"

in vec3 v_pos;
flat in vec3 v_normal;
flat in vec3 v_albedo;
in vec3 v_aux;
in vec3 v_base;
layout(location = 0) out vec4 o_color;

void main()
{
    if (v_aux.x > 1.5 && v_aux.x < 2.5) {
        bool rail = v_aux.z < 0.12 || v_aux.z > 0.88;
        if (!rail && fract(v_aux.y / 0.15) > 0.667) discard;
    }
    vec3 n = normalize(v_normal);
    vec3 E = u_sun_radiance.xyz * sq_sun_visibility(v_pos, n);
    vec3 L = v_albedo * (E * max(dot(n, u_sun_dir.xyz), 0.0) + sq_ambient(n));
    float fp = sq_snow_cover(v_base, n, SQ_SNOW_FULL_BUILT, 0.0);
    if (fp > 0.0)
        L = mix(L, sq_snow_radiance(v_pos, sq_snow_shell_normal(v_base, n), normalize(u_cam_pos.xyz - v_pos), E), fp);
    o_color = vec4(sq_haze(L, v_pos), 1.0);
}
