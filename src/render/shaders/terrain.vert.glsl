#version 450 core
// terrain.vert — the world heightfield mesh (built once per world generation in renderer.c):
// world-space position and the world's per-vertex unit normal.
#include "frame_common.glsl"

layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
out vec3 v_pos;
out vec3 v_normal;

void main()
{
    v_pos = a_pos;
    v_normal = a_normal;
    gl_Position = u_view_proj * vec4(a_pos, 1.0);
}
