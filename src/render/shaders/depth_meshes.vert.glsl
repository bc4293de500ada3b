#version 450 core
// depth_meshes.vert — world mesh instances into a depth target (shadow maps, the snow
// occlusion map): only the position, with the caller's view-projection.
#include "mesh_common.glsl"

layout(location = 0) uniform mat4 u_depth_view_proj;

void main()
{
    vec3 p, n;
    sq_mesh_world(p, n);
    gl_Position = u_depth_view_proj * vec4(p, 1.0);
}
