// mesh_common.glsl — the vertex interface of world meshes drawn by render_meshes.c, for any pass
// that draws them with its own shader (sq__mesh_pass_draw_with): per-vertex attributes of the
// mesh buffers, the per-instance index (an instanced attribute) and the instance table (a
// texture buffer at unit 9, four RGBA32F texels per instance: position + yaw, scale, tint 0,
// tint 1). World axes: x east, y north, z up, metres.

layout(location = 0) in vec3 a_pos;     // mesh frame, metres
layout(location = 1) in vec3 a_normal;  // mesh frame, unit
layout(location = 2) in vec2 a_uv;      // texture coordinates (0 when the mesh has none)
layout(location = 3) in uint a_instance; // index into the instance table
layout(location = 4) in vec4 a_snormal; // welded normal (sq__snow_welded_normals), w: wall top

layout(binding = 9) uniform samplerBuffer u_instances;

// World position and unit normal of this vertex of this instance (scale per axis, rotation
// about z by yaw, translation; normals by the inverse transpose).
void sq_mesh_world(out vec3 p, out vec3 n)
{
    int base = int(a_instance) * 4;
    vec4 py = texelFetch(u_instances, base);
    vec3 k = texelFetch(u_instances, base + 1).xyz;
    float c = cos(py.w), s = sin(py.w);
    vec3 q = a_pos * k;
    p = vec3(c * q.x - s * q.y, s * q.x + c * q.y, q.z) + py.xyz;
    vec3 m = a_normal / k;
    n = normalize(vec3(c * m.x - s * m.y, s * m.x + c * m.y, m.z));
}

// World welded normal (unit) of this vertex of this instance and its flag w (top of a wall),
// for the snow shell.
vec4 sq_mesh_world_welded_normal()
{
    int base = int(a_instance) * 4;
    float yaw = texelFetch(u_instances, base).w;
    vec3 k = texelFetch(u_instances, base + 1).xyz;
    float c = cos(yaw), s = sin(yaw);
    vec3 m = a_snormal.xyz / k;
    return vec4(normalize(vec3(c * m.x - s * m.y, s * m.x + c * m.y, m.z)), a_snormal.w);
}

// The instance's largest scale factor (what a level's error is multiplied by, as render_meshes.c
// does to choose it).
float sq_mesh_scale_max()
{
    vec3 k = texelFetch(u_instances, int(a_instance) * 4 + 1).xyz;
    return max(k.x, max(k.y, k.z));
}

// The instance's two tint colours (0 = keep the material's colour).
void sq_mesh_tints(out vec3 t0, out vec3 t1)
{
    int base = int(a_instance) * 4;
    t0 = texelFetch(u_instances, base + 2).rgb;
    t1 = texelFetch(u_instances, base + 3).rgb;
}
