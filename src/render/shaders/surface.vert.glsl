#version 450 core
// surface.vert — a heightfield surface drawable (deposited snow, avalanche deposit) generated
// from gl_VertexID: 6 vertices per cell of an nx x ny grid whose heights and coverage come from
// textures. Cells whose four corners all have zero coverage are moved outside the clip volume
// (not drawn). Normals from central differences of the heights.
#include "frame_common.glsl"

layout(binding = 1) uniform sampler2D u_height;   // R32F, nx x ny, metres
layout(binding = 2) uniform sampler2D u_coverage; // R32F, nx x ny, [0, 1]
layout(location = 0) uniform ivec2 u_n;
layout(location = 1) uniform vec3 u_origin;
layout(location = 2) uniform vec2 u_d;
layout(location = 3) uniform int u_has_coverage;

out vec3 v_pos;
out vec3 v_normal;
out float v_coverage;

float height(ivec2 ij) { return texelFetch(u_height, clamp(ij, ivec2(0), u_n - 1), 0).r; }
float coverage(ivec2 ij) { return u_has_coverage != 0 ? texelFetch(u_coverage, ij, 0).r : 1.0; }

void main()
{
    const ivec2 corner[6] = ivec2[](ivec2(0, 0), ivec2(1, 0), ivec2(1, 1), ivec2(0, 0),
                                    ivec2(1, 1), ivec2(0, 1));
    int cell = gl_VertexID / 6;
    ivec2 c = ivec2(cell % (u_n.x - 1), cell / (u_n.x - 1));
    ivec2 ij = c + corner[gl_VertexID % 6];
    float cmax = max(max(coverage(c), coverage(c + ivec2(1, 0))),
                     max(coverage(c + ivec2(0, 1)), coverage(c + ivec2(1, 1))));
    if (cmax <= 0.0) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
        v_pos = vec3(0.0);
        v_normal = vec3(0.0, 0.0, 1.0);
        v_coverage = 0.0;
        return;
    }
    float h = height(ij);
    float gx = (height(ij + ivec2(1, 0)) - height(ij - ivec2(1, 0))) /
               (float(min(ij.x + 1, u_n.x - 1) - max(ij.x - 1, 0)) * u_d.x);
    float gy = (height(ij + ivec2(0, 1)) - height(ij - ivec2(0, 1))) /
               (float(min(ij.y + 1, u_n.y - 1) - max(ij.y - 1, 0)) * u_d.y);
    v_pos = vec3(u_origin.xy + vec2(ij) * u_d, h);
    v_normal = normalize(vec3(-gx, -gy, 1.0));
    v_coverage = coverage(ij);
    gl_Position = u_view_proj * vec4(v_pos, 1.0);
}
