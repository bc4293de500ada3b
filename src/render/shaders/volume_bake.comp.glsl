#version 450 core
// volume_bake.comp — once per frame when render.volume_noise is on: the density with its
// texture coordinates displaced by a random vector field of amplitude noise_amp density voxels
// (three octaves of tileable value noise from a 32^3 texture, amplitudes 0.55/0.3/0.15 at
// 1, 2.03 and 4.07 times the base frequency, animated by a slowly drifting offset; S0 Fig 3.12),
// evaluated at the centres of a grid of u_dims points (the density's size or finer) into an
// R32F 3D texture. The volume passes then read this texture with trilinear filtering instead of
// evaluating the noise per fragment. The finest octave varies over about one density voxel, so
// the bake grid is finer than the density where memory allows (render_volume.c): the dust's
// edges get billows below the simulation's cell size, its interior (no gradient) is unchanged.
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(binding = 0) uniform sampler3D u_density;
layout(binding = 5) uniform sampler3D u_noise;
layout(binding = 0, r32f) uniform writeonly image3D u_out;

uniform ivec3 u_dims;        // bake grid points per axis
uniform ivec3 u_src_dims;    // density voxels per axis
uniform float u_noise_amp;   // displacement amplitude (density voxels)
uniform float u_noise_freq;  // noise texture coordinates per density voxel
uniform vec3 u_noise_offset; // animation offset (noise texture coordinates)

void main()
{
    ivec3 c = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(c, u_dims))) return;
    vec3 src = vec3(u_src_dims);
    vec3 tc = (vec3(c) + 0.5) / vec3(u_dims);
    vec3 q = tc * src * u_noise_freq + u_noise_offset;
    vec3 n = textureLod(u_noise, q, 0.0).xyz * 0.55 +
             textureLod(u_noise, 2.03 * q + 0.37, 0.0).xyz * 0.3 +
             textureLod(u_noise, 4.07 * q + 0.71, 0.0).xyz * 0.15;
    tc += (n * 2.0 - 1.0) * u_noise_amp / src;
    imageStore(u_out, c, vec4(max(textureLod(u_density, tc, 0.0).r, 0.0)));
}
