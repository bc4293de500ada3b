// meshes_shade.glsl — Lambertian shading of world meshes, the body of meshes.frag (opaque
// materials) and meshes_cutout.frag (textured ones: texels with alpha < 0.5 are cut out; a
// shader that may discard keeps llvmpipe from testing depth before shading, so opaque
// materials use the variant without): albedo (material colour or the instance's tint, times
// the base-colour texture when there is one)
// under the sun (opaque shadow map and volume transmittance) and the sky ambient, then aerial
// haze. Faces seen from behind (open meshes) are lit with the flipped normal. Snow
// (snow_common.glsl) is blended over them by f_p (S2 eq 2.8).
#include "frame_common.glsl"
#include "snow_common.glsl"

in vec3 v_pos;
in vec3 v_normal;
in vec3 v_base;
in vec2 v_uv;
flat in vec3 v_albedo;
flat in float v_lod_m; // the drawn level's error (m), for the snow exposure
in float v_edge_q;  // meshes.vert: the snow layer's edge
in float v_edge_qz;
layout(location = 0) out vec4 o_color;
layout(location = 2) uniform int u_has_texture;
layout(binding = 10) uniform sampler2D u_base_texture; // sRGB: sampled as linear

void main()
{
    vec3 albedo = v_albedo;
    if (u_has_texture != 0) {
        vec4 t = texture(u_base_texture, v_uv);
#ifdef SQ_CUTOUT
        if (t.a < 0.5) discard;
#endif
        albedo *= t.rgb;
    }
    vec3 n = normalize(v_normal);
    if (!gl_FrontFacing) n = -n;
    vec3 s = u_sun_dir.xyz;
    vec3 E = u_sun_radiance.xyz * sq_sun_visibility(v_pos, n);
    vec3 L = albedo * (E * max(dot(n, s), 0.0) + sq_ambient(n));
    float fp = sq_snow_cover(v_base, n, SQ_SNOW_FULL_BUILT, v_lod_m);
    // the snow layer's edge: where the shell raised the top of a wall straight up, the part of a
    // wall (or of a face turned down, a fascia) above its former top edge is the side of the
    // snow on top, not the wall stretched. Over a face with raised and kept corners, qz / q
    // interpolates the former heights of the raised ones (that top edge above this point) and
    // (z - qz) / (1 - q) those of the kept ones: stretched upward when the first is higher.
    float q = v_edge_q;
    if (n.z < 0.1736 && q > 1e-4 && q < 1.0 - 1e-4) {
        float z_raised = v_edge_qz / q, z_kept = (v_base.z - v_edge_qz) / (1.0 - q);
        if (z_raised > z_kept && v_pos.z > z_raised) fp = 1.0;
    }
    if (fp > 0.0)
        L = mix(L, sq_snow_radiance(v_pos, sq_snow_shell_normal(v_base, n), normalize(u_cam_pos.xyz - v_pos), E), fp);
    o_color = vec4(sq_haze(L, v_pos), 1.0);
}
