#version 450 core
// surface.vert — a heightfield surface drawable (deposited snow, avalanche deposit), its cells
// from surface_grid.glsl; cells not drawn are moved outside the clip volume. Normals from
// central differences of the heights.
#include "frame_common.glsl"
#include "surface_grid.glsl"

out vec3 v_pos;
out vec3 v_normal;
out float v_coverage;

void main()
{
    ivec2 ij;
    vec3 p;
    if (!sq_surface_vertex(ij, p)) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
        v_pos = vec3(0.0);
        v_normal = vec3(0.0, 0.0, 1.0);
        v_coverage = 0.0;
        return;
    }
    float gx = (sq_surface_height(ij + ivec2(1, 0)) - sq_surface_height(ij - ivec2(1, 0))) /
               (float(min(ij.x + 1, u_n.x - 1) - max(ij.x - 1, 0)) * u_d.x);
    float gy = (sq_surface_height(ij + ivec2(0, 1)) - sq_surface_height(ij - ivec2(0, 1))) /
               (float(min(ij.y + 1, u_n.y - 1) - max(ij.y - 1, 0)) * u_d.y);
    v_pos = p;
    v_normal = normalize(vec3(-gx, -gy, 1.0));
    v_coverage = sq_surface_coverage(ij);
    gl_Position = u_view_proj * vec4(v_pos, 1.0);
}
