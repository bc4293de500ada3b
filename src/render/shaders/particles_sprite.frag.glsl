#version 450 core
// particles_sprite.frag — soft particles (SPEC 4.2 with its fixes): the opaque scene depth and
// the fragment's depth are both LINEAR view depths (metres), fade = saturate((z_scene -
// z_particle) / softness_m), fragments behind the scene are dropped, no depth writes. Opacity
// per channel alpha_c = 1 - exp(-tau sigma_rel_c shape(x)) with the sprite shape by kind; the
// particle emits its single-scattering source a J (alpha premultiplied), J = E_sun p_HG(g)
// shadow + J_amb, the shadow read through the volume's light buffer when there is one. Output
// for dual-source blending ONE, SRC1_COLOR: hdr = C + (1 - alpha) hdr per channel.
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
uniform int u_sprite;           // sq_sprite_kind (DEFAULT mapped to PUFF on the CPU)
uniform float u_softness;       // m; 0 = hard
uniform vec3 u_sun_radiance, u_sun_dir; // radiance of a white plane facing the sun
uniform vec3 u_sky, u_ground;   // hemisphere radiances of the base renderer's ambient
uniform int u_has_shadow;
uniform mat4 u_shadow_matrix;

layout(location = 0, index = 0) out vec4 o_color;
layout(location = 0, index = 1) out vec4 o_trans;

const float PI = 3.14159265358979;

float hash(vec3 p)
{
    uvec3 q = uvec3(ivec3(floor(p)) + 32768);
    uint h = q.x * 0x8da6b343u ^ q.y * 0xd8163841u ^ q.z * 0xcb1ab31fu;
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    return float(h & 0xffffffu) / 16777215.0;
}

float value_noise(vec3 x)
{
    vec3 i = floor(x), f = x - i;
    vec3 u = f * f * (3.0 - 2.0 * f);
    float a = mix(hash(i), hash(i + vec3(1, 0, 0)), u.x);
    float b = mix(hash(i + vec3(0, 1, 0)), hash(i + vec3(1, 1, 0)), u.x);
    float c = mix(hash(i + vec3(0, 0, 1)), hash(i + vec3(1, 0, 1)), u.x);
    float d = mix(hash(i + vec3(0, 1, 1)), hash(i + vec3(1, 1, 1)), u.x);
    return mix(mix(a, b, u.y), mix(c, d, u.y), u.z);
}

float hg(float c, float g)
{
    float d = 1.0 + g * g - 2.0 * g * c;
    return (1.0 - g * g) / (4.0 * PI * d * sqrt(d));
}

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

// Shape factor in [0, 1] that scales the centre optical depth across the sprite.
float shape(vec2 x, float seed)
{
    float r2 = dot(x, x);
    if (r2 >= 1.0) return 0.0;
    float window = (1.0 - r2) * (1.0 - r2);
    if (u_sprite == 2) return exp(-r2 / (2.0 * 0.4 * 0.4)) * window;        // DISC
    if (u_sprite == 3) return flake6(x);                                     // FLAKE6
    if (u_sprite == 4) {                                                     // SPLAT
        float t = sqrt(r2);
        return 2.0 * t * t * t - 3.0 * t * t + 1.0;
    }
    // PUFF: gaussian modulated by two octaves of noise fixed to the sprite (turns with it)
    vec3 q = vec3(x * 3.0, seed * 7.31);
    float n = 0.6 * value_noise(q) + 0.4 * value_noise(2.1 * q + 5.3);
    return exp(-r2 / (2.0 * 0.42 * 0.42)) * window * (0.3 + 1.4 * smoothstep(0.25, 0.75, n));
}

vec3 sun_shadow(vec3 p)
{
    if (u_has_shadow == 0) return vec3(1.0);
    vec4 t = u_shadow_matrix * vec4(p, 1.0);
    return texture(u_shadow, t.xy).rgb; // clamps to border 1 outside the volume's footprint
}

void main()
{
    float tau = v_params.x, fade = v_params.y, seed = v_params.z, radius = v_params.w;
    float r2 = dot(v_local, v_local);
    if (r2 >= 1.0) discard;

    vec3 dir = normalize(v_world - u_cam);
    float z_part = v_depth;
    vec3 n = vec3(0.0);
    bool sphere = u_sprite == 5;
    if (sphere) {
        float h = sqrt(1.0 - r2);
        n = normalize(v_local.x * u_right + v_local.y * u_up - h * u_forward);
        z_part -= radius * h; // the sphere's surface is nearer than the quad's plane
    }

    float d = texelFetch(u_depth, ivec2(gl_FragCoord.xy), 0).r;
    float z_scene = d >= 1.0 ? 3.0e38 : u_proj_z.y / ((d * 2.0 - 1.0) + u_proj_z.x);
    if (z_scene <= z_part) discard; // behind opaque geometry
    float soft = u_softness > 0.0 ? clamp((z_scene - z_part) / u_softness, 0.0, 1.0) : 1.0;

    vec3 E = u_sun_radiance * sun_shadow(v_world);
    vec3 C, alpha;
    if (sphere) {
        float up = 0.5 + 0.5 * n.z;
        vec3 L = E * max(dot(n, u_sun_dir), 0.0) + u_sky * up + u_ground * (1.0 - up);
        float edge = clamp((1.0 - sqrt(r2)) * radius / max(fwidth(sqrt(r2)) * radius, 1e-6), 0.0, 1.0);
        alpha = vec3(fade * soft * edge);
        C = v_albedo * L * alpha;
    } else {
        alpha = (1.0 - exp(-tau * u_sigma_rel * shape(v_local, seed))) * (fade * soft);
        vec3 J = PI * E * hg(dot(u_sun_dir, dir), u_g) + 0.5 * (u_sky + u_ground);
        C = v_albedo * J * alpha;
    }
    o_color = vec4(C, 0.0);
    o_trans = vec4(1.0 - alpha, 1.0);
}
