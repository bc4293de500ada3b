#version 450 core
// clouds_billboard.vert — camera-facing cloud particles (SPEC 8.5; S4 §3.2 billboards), one
// instance per particle, for the eye pass and for rendering impostors (the camera comes in as
// uniforms, not from the Frame block, so both use this program). Corners c +- r R +- r U with R,
// U the camera's right and up vectors; the sprite coordinate v_local spans [-1, 1]^2. The aerial
// haze between the eye (the Frame block's camera: impostors are rendered from it too) and the
// particle's centre is the terrain's (frame_common.glsl sq_haze), per particle.
#include "frame_common.glsl"

layout(location = 0) in vec4 a_pos_radius; // world centre (m), radius (m)
layout(location = 1) in vec4 a_params;     // tau, fade, g, I_sun (MFS light, ratio to the sun)
layout(location = 2) in vec4 a_ambient;    // diffuse sun + sky radiance (rgb), 0

uniform mat4 u_bb_view_proj; // the eye's, or an impostor camera's
uniform vec3 u_cam, u_right, u_up, u_forward;
uniform float u_noise;      // the splat's texture reaches past r: the quad grows by 0.7 u_noise
                            // (the two-octave noise seldom exceeds 0.85, see the fragment shader)

out vec2 v_local;
out vec3 v_world;
flat out vec4 v_params;
flat out vec3 v_ambient;
flat out float v_depth;  // linear view depth of the particle's centre (m)
flat out float v_radius;
flat out float v_center_seed; // a number fixed to the particle (from its centre)
flat out vec4 v_haze;    // rgb the sky the haze blends to, a the blend weight (sq_haze)

void main()
{
    const vec2 corner[4] = vec2[4](vec2(-1.0, -1.0), vec2(1.0, -1.0), vec2(-1.0, 1.0),
                                   vec2(1.0, 1.0));
    vec2 q = corner[gl_VertexID & 3] * (1.0 + 0.7 * u_noise);
    float r = a_pos_radius.w;
    vec3 c = a_pos_radius.xyz;
    vec3 p = c + r * (q.x * u_right + q.y * u_up);
    v_local = q;
    v_world = p;
    v_params = a_params;
    v_ambient = a_ambient.rgb;
    v_depth = dot(c - u_cam, u_forward);
    v_radius = r;
    v_center_seed = dot(c, vec3(0.00731, 0.01113, 0.00517));
    v_haze = vec4(sq_haze_inscatter(c), sq_haze_fraction(c));
    gl_Position = u_bb_view_proj * vec4(p, 1.0);
}
