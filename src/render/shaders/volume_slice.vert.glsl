#version 450 core
// volume_slice.vert — the half-angle slice polygons (planes perpendicular to the slice axis s,
// clipped to the volume box on the CPU and split into triangles, all slices in one draw in
// back-to-front order) in world metres -> clip space (SPEC 3.4 step 2). w of the attribute is
// the layer of the light array holding the sun light that arrives at the vertex's slice.
// Quantities affine in the world position are computed here and interpolated (exact on the
// planar slices): the light-buffer coordinates, and per axis the entry and exit distances of
// the ray from the point back toward the sun through the box planes.
layout(location = 0) in vec4 a_pos_layer;
uniform mat4 u_view_proj;
uniform mat4 u_light_matrix;   // world -> light-buffer texture coordinates
uniform vec3 u_box_lo, u_box_size;
uniform vec3 u_inv_back;       // 1 / (-wl) per axis (+-1e10 where wl has no component)
out vec3 v_world;
out vec2 v_light_uv;
out vec3 v_back_tmin, v_back_tmax;
flat out float v_layer;

void main()
{
    vec3 p = a_pos_layer.xyz;
    v_world = p;
    v_layer = a_pos_layer.w;
    v_light_uv = (u_light_matrix * vec4(p, 1.0)).xy;
    vec3 t0 = (u_box_lo - p) * u_inv_back;
    vec3 t1 = (u_box_lo + u_box_size - p) * u_inv_back;
    v_back_tmin = min(t0, t1); // the sign of u_inv_back picks the same face at every vertex,
    v_back_tmax = max(t0, t1); // so these stay affine in p
    gl_Position = u_view_proj * vec4(p, 1.0);
}
