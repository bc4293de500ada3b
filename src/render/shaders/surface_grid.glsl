// surface_grid.glsl — the vertices of a heightfield surface drawable, generated from
// gl_VertexID: 6 per cell of an nx x ny grid whose heights and coverage come from textures
// (renderer.c uploads them). Cells whose four corners all have zero coverage are not drawn.
// Shared by the lit pass (surface.vert) and the sun's shadow cascades (depth_surface.vert).

layout(binding = 1) uniform sampler2D u_height;   // R32F, nx x ny, metres
layout(binding = 2) uniform sampler2D u_coverage; // R32F, nx x ny, [0, 1]
layout(location = 0) uniform ivec2 u_n;
layout(location = 1) uniform vec3 u_origin;
layout(location = 2) uniform vec2 u_d;
layout(location = 3) uniform int u_has_coverage;

float sq_surface_height(ivec2 ij) { return texelFetch(u_height, clamp(ij, ivec2(0), u_n - 1), 0).r; }
float sq_surface_coverage(ivec2 ij)
{
    return u_has_coverage != 0 ? texelFetch(u_coverage, ij, 0).r : 1.0;
}

// Vertex gl_VertexID of the grid: its grid index ij and world position; false for a vertex of a
// cell that is not drawn.
bool sq_surface_vertex(out ivec2 ij, out vec3 pos)
{
    const ivec2 corner[6] = ivec2[](ivec2(0, 0), ivec2(1, 0), ivec2(1, 1), ivec2(0, 0),
                                    ivec2(1, 1), ivec2(0, 1));
    int cell = gl_VertexID / 6;
    ivec2 c = ivec2(cell % (u_n.x - 1), cell / (u_n.x - 1));
    ij = c + corner[gl_VertexID % 6];
    float cmax = max(max(sq_surface_coverage(c), sq_surface_coverage(c + ivec2(1, 0))),
                     max(sq_surface_coverage(c + ivec2(0, 1)), sq_surface_coverage(c + ivec2(1, 1))));
    pos = vec3(u_origin.xy + vec2(ij) * u_d, sq_surface_height(ij));
    return cmax > 0.0;
}
