#version 450 core
// particles_sprite.vert — camera-facing particle quads, one instance per particle (SPEC 4.3,
// 4.5). The four corners of a quad of half-side r (the particle radius) turned by the
// particle's in-plane rotation a use the corrected form of S3 eq. 5:
//   corner_k = c + sqrt(2) r [cos(a + pi/4 + k pi/2) R + sin(a + pi/4 + k pi/2) U],
// R, U the camera right and up vectors, k in strip order 0, 1, 3, 2. The sprite's own
// coordinates (+-1, +-1) turn with the quad, so its pattern rotates with it.
layout(location = 0) in vec4 a_pos_radius;  // world centre (m), radius (m)
layout(location = 1) in vec4 a_rot_tau;     // rotation (rad), tau, fade, seed
layout(location = 2) in vec4 a_albedo;      // albedo rgb

uniform mat4 u_view_proj;
uniform vec3 u_cam, u_right, u_up, u_forward;

out vec2 v_local;           // sprite coordinates in [-1, 1]^2
out vec3 v_world;
flat out vec3 v_albedo;
flat out vec4 v_params;     // tau, fade, seed, radius
flat out float v_depth;     // linear view depth of the quad (m)

const float HALF_PI = 1.5707963267949;

void main()
{
    const int order[4] = int[4](0, 1, 3, 2);
    int k = order[gl_VertexID & 3];
    float base = 0.5 * HALF_PI + float(k) * HALF_PI;
    float a = a_rot_tau.x + base;
    float r = a_pos_radius.w;
    vec3 c = a_pos_radius.xyz;
    vec3 p = c + 1.41421356 * r * (cos(a) * u_right + sin(a) * u_up);
    v_local = 1.41421356 * vec2(cos(base), sin(base));
    v_world = p;
    v_albedo = a_albedo.rgb;
    v_params = vec4(a_rot_tau.yzw, r);
    v_depth = dot(c - u_cam, u_forward);
    gl_Position = u_view_proj * vec4(p, 1.0);
}
