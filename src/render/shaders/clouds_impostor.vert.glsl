#version 450 core
// clouds_impostor.vert — an impostor: one camera-facing quad per distant cloud, centred on the
// cloud, of half-size h (the bounding sphere seen through the impostor's frustum), textured
// with the cloud rendered from the eye when the impostor was made (SPEC 8.5; Harris 2001).
uniform mat4 u_view_proj;
uniform vec3 u_center, u_right, u_up, u_cam, u_forward;
uniform float u_half;

out vec2 v_uv;
flat out float v_depth;

void main()
{
    const vec2 corner[4] = vec2[4](vec2(-1.0, -1.0), vec2(1.0, -1.0), vec2(-1.0, 1.0),
                                   vec2(1.0, 1.0));
    vec2 q = corner[gl_VertexID & 3];
    vec3 p = u_center + u_half * (q.x * u_right + q.y * u_up);
    v_uv = 0.5 * q + 0.5;
    v_depth = dot(u_center - u_cam, u_forward);
    gl_Position = u_view_proj * vec4(p, 1.0);
}
