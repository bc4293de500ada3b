#version 450 core
// depth_world.vert — terrain and obstacles (world-space positions) into a depth target.
layout(location = 0) in vec3 a_pos;
layout(location = 0) uniform mat4 u_depth_view_proj;

void main() { gl_Position = u_depth_view_proj * vec4(a_pos, 1.0); }
