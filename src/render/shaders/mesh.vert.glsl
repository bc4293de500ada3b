#version 450 core
// mesh.vert — obstacles (boxes, gable-roof houses, fences) as flat-shaded triangles in world
// space. a_aux = (obstacle kind, coordinate along the obstacle in m, height fraction). The snow
// shell raises them vertically by depth x f_e (a function of the position alone, so the flat-
// shaded faces stay joined; the slope bias of a 60 degree roof); porous fences are not raised.
#include "frame_common.glsl"
#include "snow_common.glsl"

layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec3 a_albedo;
layout(location = 3) in vec3 a_aux;
out vec3 v_pos;
flat out vec3 v_normal;
flat out vec3 v_albedo;
out vec3 v_aux;
out vec3 v_base;

void main()
{
    vec3 p = a_pos;
    if (sq_snow_on() && !(a_aux.x > 1.5 && a_aux.x < 2.5))
        p.z += sq_snow_depth_at(p.xy) * sq_snow_exposure(p, 0.5, 0.0, false);
    v_base = a_pos;
    v_pos = p;
    v_normal = a_normal;
    v_albedo = a_albedo;
    v_aux = a_aux;
    gl_Position = u_view_proj * vec4(p, 1.0);
}
