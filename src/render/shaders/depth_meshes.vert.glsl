#version 450 core
// depth_meshes.vert — world mesh instances into a depth target (shadow maps, the snow
// occlusion map): only the position, with the caller's view-projection.
// SQ_SINK (the occlusion map, render_snowcover.c): the level drawn is sunk by its geometric
// error (u_sink_m, mesh metres, times the instance's largest scale) divided by its face's
// inclination n.z (at least 0.3162, as the slope bias's tan 3): a surface within that error of
// the finest one lies at most error / n.z above it vertically, so the sunk level's top is never
// above the finest surface, which the camera's level must not find occluded by its own object.
#include "mesh_common.glsl"

layout(location = 0) uniform mat4 u_depth_view_proj;
#ifdef SQ_SINK
layout(location = 1) uniform float u_sink_m;
#endif

void main()
{
    vec3 p, n;
    sq_mesh_world(p, n);
#ifdef SQ_SINK
    vec3 k = texelFetch(u_instances, int(a_instance) * 4 + 1).xyz;
    p.z -= u_sink_m * max(k.x, max(k.y, k.z)) / max(n.z, 0.3162);
#endif
    gl_Position = u_depth_view_proj * vec4(p, 1.0);
}
