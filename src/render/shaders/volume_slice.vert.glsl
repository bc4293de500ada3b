#version 450 core
// volume_slice.vert — one half-angle slice polygon (plane perpendicular to the slice axis s,
// clipped to the volume box on the CPU) in world metres -> clip space (SPEC 3.4 step 2).
layout(location = 0) in vec3 a_pos;
uniform mat4 u_view_proj;
out vec3 v_world;

void main()
{
    v_world = a_pos;
    gl_Position = u_view_proj * vec4(a_pos, 1.0);
}
