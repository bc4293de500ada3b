#version 450 core
// mesh.vert — obstacles (boxes, gable-roof houses, fences) as flat-shaded triangles in world
// space. a_aux = (obstacle kind, coordinate along the obstacle in m, height fraction).
#include "frame_common.glsl"

layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec3 a_albedo;
layout(location = 3) in vec3 a_aux;
out vec3 v_pos;
flat out vec3 v_normal;
flat out vec3 v_albedo;
out vec3 v_aux;

void main()
{
    v_pos = a_pos;
    v_normal = a_normal;
    v_albedo = a_albedo;
    v_aux = a_aux;
    gl_Position = u_view_proj * vec4(a_pos, 1.0);
}
