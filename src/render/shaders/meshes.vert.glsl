#version 450 core
// meshes.vert — world mesh instances for the camera: world position, normal, texture
// coordinates and the albedo after the instance's tint (material uniforms of render_meshes.c);
// the position raised by the snow shell (snow_common.glsl) from the welded normal.
#include "frame_common.glsl"
#include "mesh_common.glsl"
#include "snow_common.glsl"

layout(location = 0) uniform vec3 u_base_color; // material albedo (linear)
layout(location = 1) uniform int u_tint;        // 0 none, 1 primary, 2 secondary
layout(location = 3) uniform float u_lod_error_m; // the drawn level's error (mesh frame, m)

out vec3 v_pos;
out vec3 v_normal;
out vec3 v_base; // before the snow shell
out vec2 v_uv;
flat out vec3 v_albedo;
flat out float v_lod_m; // the level's error in the world (x the largest scale)
// the snow layer's edge (meshes_shade.glsl): 1 where the shell raised this vertex straight up (the
// top of a wall), else 0; and that times the vertex's height before the shell
out float v_edge_q;
out float v_edge_qz;

void main()
{
    vec3 p, n;
    sq_mesh_world(p, n);
    vec3 t0, t1;
    sq_mesh_tints(t0, t1);
    vec3 a = u_base_color;
    if (u_tint == 1 && max(t0.r, max(t0.g, t0.b)) > 0.0) a = t0;
    if (u_tint == 2 && max(t1.r, max(t1.g, t1.b)) > 0.0) a = t1;
    v_albedo = a;
    v_base = p;
    v_lod_m = u_lod_error_m * sq_mesh_scale_max();
    v_edge_q = v_edge_qz = 0.0;
#ifndef SQ_NO_SHELL /* instances too far for the shell to move them by half a pixel (render_meshes.c) */
    if (sq_snow_on()) {
        vec4 ns = sq_mesh_world_welded_normal();
        vec3 o = sq_snow_shell(p, ns, v_lod_m);
        v_edge_q = ns.w > 0.5 && o.z > 0.0 ? 1.0 : 0.0;
        v_edge_qz = v_edge_q * p.z;
        p += o;
    }
#endif
    v_pos = p;
    v_normal = n;
    v_uv = a_uv;
    gl_Position = u_view_proj * vec4(p, 1.0);
}
