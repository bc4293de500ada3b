#version 450 core
// clouds_billboard.frag — eye pass of the cloud particles (SPEC 8.4–8.5; Harris & Lastra 2001):
// opacity from the splat falloff eta(t) = 2|t|³ - 3t² + 1 (|t| <= 1, 0 beyond):
//   physical      alpha = 1 - exp(-tau eta(t))
//   splat (S4)    alpha = (1 - exp(-tau_splat)) eta_1 eta(t)
// times the particle's fade (impostor cross-fade); light toward the eye
//   L = a (pi E_sun I_k p(theta) + J_amb) alpha,
// with I_k the multiple-forward-scattering light of the particle (CPU sweep), p the view-
// dependent phase (Henyey–Greenstein, or Rayleigh for the seed), theta between the sunlight's
// and the eye ray's propagation directions, J_amb the diffuse sun and sky light (CPU). Output is
// premultiplied (ONE, ONE_MINUS_SRC_ALPHA), drawn back to front; L is hazed toward the sky as
// the terrain is at the particle's distance (v_haze, from the vertex shader). Against the opaque scene the
// particle fades over half its radius of depth (soft particles) and is dropped behind it; when
// rendering impostors there is no scene (u_use_depth = 0).
in vec2 v_local;
in vec3 v_world;
flat in vec4 v_params;
flat in vec3 v_ambient;
flat in float v_depth;
flat in float v_radius;
flat in float v_center_seed;
flat in vec4 v_haze;

layout(binding = 2) uniform sampler2D u_depth;

uniform vec3 u_cam;
uniform vec2 u_proj_z;         // projection m[10], m[14]: linear depth = m14 / (ndc_z + m10)
uniform int u_use_depth;
uniform vec3 u_sun;            // toward the sun
uniform vec3 u_sun_E;          // sun radiance scale (the world's sun_radiance)
uniform float u_albedo;
uniform int u_splat_opacity;
uniform float u_splat_peak;    // (1 - exp(-tau_splat)) eta_1
uniform int u_rayleigh;

layout(location = 0) out vec4 o_color;

uniform float u_noise;         // splat texture: t / (1 + u_noise (2 n - 1)), n noise in [0, 1]

const float PI = 3.14159265358979;

// Integer hash of a lattice point to [0, 1] and smooth value noise (mean 1/2).
float hash(uvec2 q)
{
    uint h = q.x * 0x8da6b343u ^ q.y * 0xd8163841u;
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    return float(h & 0xffffffu) * (1.0 / 16777215.0);
}

float value_noise(vec2 x)
{
    vec2 i = floor(x), f = x - i;
    vec2 u = f * f * (3.0 - 2.0 * f);
    uvec2 q = uvec2(ivec2(i) + 32768);
    float a = mix(hash(q), hash(q + uvec2(1u, 0u)), u.x);
    float b = mix(hash(q + uvec2(0u, 1u)), hash(q + uvec2(1u, 1u)), u.x);
    return mix(a, b, u.y);
}

float phase(float c, float g)
{
    if (u_rayleigh != 0) return 3.0 * (1.0 + c * c) / (16.0 * PI);
    float d = 1.0 + g * g - 2.0 * g * c;
    return (1.0 - g * g) / (4.0 * PI * d * sqrt(d));
}

void main()
{
    float t = length(v_local);
    if (t >= 1.0 + 0.7 * u_noise) discard; // outside the largest textured disc: no noise
    float tau = v_params.x, fade = v_params.y, g = v_params.z, I = v_params.w;
    if (u_noise > 0.0) {
        // texture: the splat's radius scaled by a mean-one noise fixed to the particle (its
        // centre picks its place in the noise plane), so that overlapping opaque splats do not
        // read as discs; two octaves of value noise over the sprite
        vec2 q = v_local * 1.7 + fract(v_center_seed * vec2(0.7548777, 0.5698403)) * 512.0;
        float n = 0.65 * value_noise(q) + 0.35 * value_noise(2.3 * q + 7.1);
        t *= 1.0 / (1.0 + u_noise * (2.0 * n - 1.0));
    }
    if (t >= 1.0) discard;
    float eta = (2.0 * t - 3.0) * t * t + 1.0;
    float alpha = u_splat_opacity != 0 ? u_splat_peak * eta : 1.0 - exp(-tau * eta);
    alpha *= fade;
    if (u_use_depth != 0) {
        float d = texelFetch(u_depth, ivec2(gl_FragCoord.xy), 0).r;
        float z_scene = d >= 1.0 ? 3.0e38 : u_proj_z.y / ((d * 2.0 - 1.0) + u_proj_z.x);
        float soft = clamp((z_scene - v_depth) / (0.5 * v_radius), 0.0, 1.0);
        alpha *= soft;
    }
    if (alpha <= 0.0) discard;
    vec3 dir = normalize(v_world - u_cam);
    vec3 J = PI * u_sun_E * I * phase(dot(u_sun, dir), g) + v_ambient;
    o_color = vec4(mix(u_albedo * J, v_haze.rgb, v_haze.a) * alpha, alpha);
}
