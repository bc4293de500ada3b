#version 450 core
// depth_surface.vert — a heightfield surface drawable (surface_grid.glsl) into a depth target:
// the avalanche's snow casts its shadow into the sun's cascades like the terrain it lies on.
#include "surface_grid.glsl"

layout(location = 8) uniform mat4 u_depth_view_proj;

void main()
{
    ivec2 ij;
    vec3 p;
    gl_Position = sq_surface_vertex(ij, p) ? u_depth_view_proj * vec4(p, 1.0)
                                           : vec4(2.0, 2.0, 2.0, 1.0);
}
