#version 450 core
// volume_bake.comp — once per frame when render.volume_noise is on: the density with its
// texture coordinates displaced by a smooth random vector field of amplitude noise_amp voxels
// (two octaves of tileable value noise from a 32^3 texture, animated by a drifting offset;
// S0 Fig 3.12), evaluated at every voxel centre into an R32F 3D texture of the density's size.
// The volume passes then read this texture with trilinear filtering instead of evaluating the
// noise per fragment (three 3D fetches -> one); the displacement field varies over 2-4 voxels,
// so sampling it at voxel centres keeps its detail.
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(binding = 0) uniform sampler3D u_density;
layout(binding = 5) uniform sampler3D u_noise;
layout(binding = 0, r32f) uniform writeonly image3D u_out;

uniform ivec3 u_dims;        // nx, ny, nz
uniform float u_noise_amp;   // displacement amplitude (voxels)
uniform float u_noise_freq;  // noise texture coordinates per voxel
uniform vec3 u_noise_offset; // animation offset (noise texture coordinates)

void main()
{
    ivec3 c = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(c, u_dims))) return;
    vec3 dims = vec3(u_dims);
    vec3 tc = (vec3(c) + 0.5) / dims;
    vec3 q = tc * dims * u_noise_freq + u_noise_offset;
    vec3 n = textureLod(u_noise, q, 0.0).xyz * 0.65 +
             textureLod(u_noise, 2.03 * q + 0.37, 0.0).xyz * 0.35;
    tc += (n * 2.0 - 1.0) * u_noise_amp / dims;
    imageStore(u_out, c, vec4(max(textureLod(u_density, tc, 0.0).r, 0.0)));
}
