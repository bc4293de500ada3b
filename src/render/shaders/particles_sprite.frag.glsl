#version 450 core
// particles_sprite.frag — soft particles (SPEC 4.2 with its fixes): the opaque scene depth and
// the fragment's depth are both LINEAR view depths (metres), fade = saturate((z_scene -
// z_particle) / softness_m), fragments behind the scene are dropped, no depth writes. Opacity
// per channel alpha_c = 1 - exp(-tau sigma_rel_c shape(x)) with the sprite shape by kind; the
// particle emits its single-scattering source a J (alpha premultiplied), J = E_sun p_HG(g)
// shadow + J_amb, the shadow read through the volume's light buffer when there is one. Output
// for dual-source blending ONE, SRC1_COLOR: hdr = C + (1 - alpha) hdr per channel.
// Compiled per sprite kind (PART_SPRITE = sq_sprite_kind, DEFAULT mapped to PUFF) and with
// PART_SHADOW 0/1 (render_particles.c): llvmpipe evaluates every side of a branch under an
// execution mask, so one shader with branches on uniforms would pay for all sprite kinds.
in vec2 v_local;
in vec3 v_world;
flat in vec3 v_albedo;
flat in vec4 v_params;
flat in float v_depth;

layout(binding = 2) uniform sampler2D u_depth;
layout(binding = 6) uniform sampler2D u_shadow;

uniform vec3 u_cam, u_right, u_up, u_forward;
uniform vec2 u_proj_z;          // projection m[10], m[14]: linear depth = m14 / (ndc_z + m10)
uniform vec3 u_sigma_rel;
uniform float u_g;
uniform float u_softness;       // m; 0 = hard
uniform vec3 u_sun_radiance, u_sun_dir; // radiance of a white plane facing the sun
uniform vec3 u_sky, u_ground;   // hemisphere radiances of the base renderer's ambient
uniform mat4 u_shadow_matrix;

layout(location = 0, index = 0) out vec4 o_color;
layout(location = 0, index = 1) out vec4 o_trans;

const float PI = 3.14159265358979;

#if PART_SPRITE == 1
// Integer hash of a lattice point to [0, 1].
float hash(uvec2 q)
{
    uint h = q.x * 0x8da6b343u ^ q.y * 0xd8163841u;
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    return float(h & 0xffffffu) * (1.0 / 16777215.0);
}

// Smooth value noise in [0, 1] over the plane (four lattice hashes per sample).
float value_noise(vec2 x)
{
    vec2 i = floor(x), f = x - i;
    vec2 u = f * f * (3.0 - 2.0 * f);
    uvec2 q = uvec2(ivec2(i) + 32768);
    float a = mix(hash(q), hash(q + uvec2(1u, 0u)), u.x);
    float b = mix(hash(q + uvec2(0u, 1u)), hash(q + uvec2(1u, 1u)), u.x);
    return mix(a, b, u.y);
}
#endif

float hg(float c, float g)
{
    float d = 1.0 + g * g - 2.0 * g * c;
    return (1.0 - g * g) / (4.0 * PI * d * sqrt(d));
}

#if PART_SPRITE == 3
// Distance of x (in the frame of one arm along +x) to the segment from o along dir, length len.
float seg_dist(vec2 x, vec2 o, vec2 dir, float len)
{
    vec2 v = x - o;
    return length(v - dir * clamp(dot(v, dir), 0.0, len));
}

// Six-fold flake: six arms with two pairs of side branches at 60 degrees and a small core;
// symmetric under rotations by 60 degrees and reflections.
float flake6(vec2 x)
{
    float r = length(x);
    float phi = atan(x.y, x.x);
    float sector = PI / 3.0;
    float ph = phi - sector * floor(phi / sector + 0.5); // angle to the nearest arm
    vec2 q = r * vec2(cos(ph), abs(sin(ph)));           // arm frame, upper half
    const vec2 br = vec2(0.5, 0.8660254);
    float d = seg_dist(q, vec2(0.0), vec2(1.0, 0.0), 0.92);
    d = min(d, seg_dist(q, vec2(0.38, 0.0), br, 0.26));
    d = min(d, seg_dist(q, vec2(0.62, 0.0), br, 0.16));
    float w = 0.055;
    return max(exp(-(d * d) / (w * w)), exp(-(r * r) / (0.14 * 0.14)));
}
#endif

#if PART_SPRITE != 5
// Shape factor in [0, 1] (PUFF up to 1.7) that scales the centre optical depth across the
// sprite, for r2 = |x|^2 < 1 (main discards the rest).
float shape(vec2 x, float r2, float seed)
{
    float window = (1.0 - r2) * (1.0 - r2);
#if PART_SPRITE == 2 // DISC
    return exp(-r2 / (2.0 * 0.4 * 0.4)) * window;
#elif PART_SPRITE == 3 // FLAKE6
    return flake6(x);
#elif PART_SPRITE == 4 // SPLAT
    float t = sqrt(r2);
    return 2.0 * t * t * t - 3.0 * t * t + 1.0;
#else // PUFF: gaussian modulated by two octaves of noise fixed to the sprite (turns with it),
     // each particle at its own place in the noise plane (an R2 low-discrepancy offset)
    vec2 q = x * 3.0 + fract(seed * vec2(0.7548777, 0.5698403)) * 4096.0;
    float n = 0.6 * value_noise(q) + 0.4 * value_noise(2.1 * q + 5.3);
    return exp(-r2 / (2.0 * 0.42 * 0.42)) * window * (0.3 + 1.4 * smoothstep(0.25, 0.75, n));
#endif
}
#endif

vec3 sun_shadow(vec3 p)
{
#if PART_SHADOW
    vec4 t = u_shadow_matrix * vec4(p, 1.0);
    return textureLod(u_shadow, t.xy, 0.0).rgb; // border 1 outside the volume's footprint
#else
    return vec3(1.0);
#endif
}

void main()
{
    float tau = v_params.x, fade = v_params.y, seed = v_params.z, radius = v_params.w;
    float r2 = dot(v_local, v_local);
    if (r2 >= 1.0) discard;

    float z_part = v_depth;
#if PART_SPRITE == 5
    float h = sqrt(1.0 - r2);
    vec3 n = normalize(v_local.x * u_right + v_local.y * u_up - h * u_forward);
    z_part -= radius * h; // the sphere's surface is nearer than the quad's plane
#endif

    float d = texelFetch(u_depth, ivec2(gl_FragCoord.xy), 0).r;
    float z_scene = d >= 1.0 ? 3.0e38 : u_proj_z.y / ((d * 2.0 - 1.0) + u_proj_z.x);
    if (z_scene <= z_part) discard; // behind opaque geometry
    float soft = u_softness > 0.0 ? clamp((z_scene - z_part) / u_softness, 0.0, 1.0) : 1.0;

    vec3 E = u_sun_radiance * sun_shadow(v_world);
#if PART_SPRITE == 5
    float up = 0.5 + 0.5 * n.z;
    vec3 L = E * max(dot(n, u_sun_dir), 0.0) + u_sky * up + u_ground * (1.0 - up);
    float edge = clamp((1.0 - sqrt(r2)) * radius / max(fwidth(sqrt(r2)) * radius, 1e-6), 0.0, 1.0);
    vec3 alpha = vec3(fade * soft * edge);
    vec3 C = v_albedo * L * alpha;
#else
    vec3 dir = normalize(v_world - u_cam);
    vec3 alpha = (1.0 - exp(-tau * u_sigma_rel * shape(v_local, r2, seed))) * (fade * soft);
    vec3 J = PI * E * hg(dot(u_sun_dir, dir), u_g) + 0.5 * (u_sky + u_ground);
    vec3 C = v_albedo * J * alpha;
#endif
    o_color = vec4(C, 0.0);
    o_trans = vec4(1.0 - alpha, 1.0);
}
