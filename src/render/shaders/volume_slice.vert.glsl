#version 450 core
// volume_slice.vert — the half-angle slice polygons (planes perpendicular to the slice axis s,
// clipped to the volume box on the CPU and split into triangles, all slices in one draw in
// back-to-front order) in world metres -> clip space (SPEC 3.4 step 2). w of the attribute is
// the layer of the light array holding the sun light that arrives at the vertex's slice.
layout(location = 0) in vec4 a_pos_layer;
uniform mat4 u_view_proj;
out vec3 v_world;
flat out float v_layer;

void main()
{
    v_world = a_pos_layer.xyz;
    v_layer = a_pos_layer.w;
    gl_Position = u_view_proj * vec4(a_pos_layer.xyz, 1.0);
}
