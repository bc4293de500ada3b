#version 450 core
// terrain.vert — the world heightfield mesh (built once per world generation in renderer.c):
// world-space position and the world's per-vertex unit normal, raised by the snow shell
// (snow_common.glsl: the terrain's normals are smooth already).
#include "frame_common.glsl"
#include "snow_common.glsl"

layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
out vec3 v_pos;
out vec3 v_normal;
out vec3 v_base; // before the snow shell: where the occlusion map is read

void main()
{
    vec3 p = a_pos + sq_snow_shell(a_pos, vec4(a_normal, 0.0), 0.0);
    v_base = a_pos;
    v_pos = p;
    v_normal = a_normal;
    gl_Position = u_view_proj * vec4(p, 1.0);
}
