#version 450 core
// sky.frag — the analytic sky behind everything (frame_common.glsl sq_sky_radiance). Drawn
// first without depth writes: the cleared depth (far) stays behind it.
#include "frame_common.glsl"

in vec2 v_ndc;
layout(location = 0) out vec4 o_color;

void main()
{
    vec4 p = u_inv_view_proj * vec4(v_ndc, 1.0, 1.0);
    vec3 d = normalize(p.xyz / p.w - u_cam_pos.xyz);
    o_color = vec4(sq_sky_radiance(d, true), 1.0);
}
