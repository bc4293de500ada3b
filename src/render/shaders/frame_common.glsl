// frame_common.glsl — included (#include "frame_common.glsl") by the base renderer's shaders:
// the per-frame uniform block (binding 0, mirrored by sq__frame_block in renderer.c), the
// analytic sky, sun shadowing by volumes, terrain haze and a value noise for surface detail.
// World axes: x east, y north, z up, metres. Radiance in the world's linear relative units
// (world.c sky_model): a white Lambertian plane facing the sun reads sun_radiance, so the sun's
// irradiance is pi * sun_radiance and a surface of albedo a under sky radiance L_sky reads a L_sky.

layout(std140, binding = 0) uniform Frame {
    mat4 u_view_proj;
    mat4 u_inv_view_proj;
    mat4 u_view;
    mat4 u_sun_shadow_matrix;  // world -> light-buffer texture coordinates (volume pass)
    vec4 u_cam_pos;            // xyz camera position, w time_s
    vec4 u_sun_dir;            // xyz unit vector toward the sun, w 1 if u_sun_shadow is valid
    vec4 u_sun_radiance;       // xyz sun irradiance scale at the ground, w turbidity
    vec4 u_sky_zenith;         // xyz, w near plane (m)
    vec4 u_sky_horizon;        // xyz, w far plane (m)
    vec4 u_ground_albedo;      // xyz, w terrain kind (sq_terrain_kind)
    vec4 u_viewport;           // width, height, 1/width, 1/height
    vec4 u_params;             // x exposure, y 1 / vertical exaggeration of the world
};

layout(binding = 7) uniform sampler2D u_sun_shadow; // transmittance of sun light (rgb)

// Sun shadows of opaque geometry (render_shadow.c): cascaded shadow maps fitted to the view
// (binding 3, mirrored by shadow_block in render_shadow.c).
layout(std140, binding = 3) uniform Shadow {
    mat4 u_shadow_matrix[4]; // world -> (u, v, depth) in [0, 1] of cascade c
    vec4 u_shadow_split;     // far end of cascade c along the view axis (m)
    vec4 u_shadow_texel;     // world size of one texel of cascade c (m)
    vec4 u_shadow_params;    // x cascades (0 = no shadows), y map size (px), z fade start (m)
};
layout(binding = 8) uniform sampler2DArrayShadow u_shadow_map;

const float SQ_PI = 3.14159265358979;
const float SQ_SUN_ANGULAR_RADIUS = 0.00465; // rad (0.27 degrees)

// Distance along the view axis (m, positive) of a depth-buffer value d in [0, 1] (standard
// OpenGL perspective of sq_camera_proj, clip z in [-1, 1]); d = 1 is the far plane.
float sq_linear_depth(float d)
{
    float n = u_sky_zenith.w, f = u_sky_horizon.w;
    float z = 2.0 * d - 1.0;
    return 2.0 * n * f / (f + n - z * (f - n));
}

// Fraction of the sun's light that reaches world point p through the volumes (1 = clear).
vec3 sq_sun_transmittance(vec3 p)
{
    if (u_sun_dir.w < 0.5) return vec3(1.0);
    vec4 t = u_sun_shadow_matrix * vec4(p, 1.0);
    vec2 uv = t.xy / t.w;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) return vec3(1.0);
    return texture(u_sun_shadow, uv).rgb;
}

// Fraction of the sun's disc visible from p (0 in the shadow of opaque geometry, 1 lit), with
// unit surface normal n: the cascade covering p's view depth, a receiver offset along n of 1.5
// texels against acne, and 3 x 3 bilinear comparisons (percentage-closer filtering over about
// 4 x 4 texels). Beyond the last cascade it fades to 1.
float sq_opaque_shadow(vec3 p, vec3 n)
{
    int count = int(u_shadow_params.x);
    if (count == 0) return 1.0;
    float depth = -(u_view * vec4(p, 1.0)).z;
    int c = 0;
    while (c < count - 1 && depth > u_shadow_split[c]) c++;
    if (depth > u_shadow_split[count - 1]) return 1.0;
    float texel = u_shadow_texel[c];
    float cosl = dot(n, u_sun_dir.xyz);
    vec3 q = p + n * texel * (1.0 + 1.5 * (1.0 - abs(cosl)));
    vec4 t = u_shadow_matrix[c] * vec4(q, 1.0);
    if (any(lessThan(t.xy, vec2(0.0))) || any(greaterThan(t.xy, vec2(1.0)))) return 1.0;
    float inv = 1.0 / u_shadow_params.y;
    float ref = t.z - 0.0002;
    float lit = 0.0;
    for (int j = -1; j <= 1; j++)
        for (int i = -1; i <= 1; i++)
            lit += texture(u_shadow_map, vec4(t.xy + vec2(i, j) * inv, float(c), ref));
    lit /= 9.0;
    float fade = smoothstep(u_shadow_params.z, u_shadow_split[count - 1], depth);
    return mix(lit, 1.0, fade);
}

// Sun light reaching p with normal n: through the volumes and past opaque geometry.
vec3 sq_sun_visibility(vec3 p, vec3 n) { return sq_sun_transmittance(p) * sq_opaque_shadow(p, n); }

float sq_hg(float cos_theta, float g)
{
    float d = 1.0 + g * g - 2.0 * g * cos_theta;
    return (1.0 - g * g) / (4.0 * SQ_PI * d * sqrt(d));
}

// Optical depth of the haze aerosol along the zenith from sea level, from the turbidity (T = 1:
// clean air), and the part of it above the camera: the aerosol thins out with a scale height of
// 1.5 km above sea level (as the aerial haze below; world heights are the physical ones times
// the vertical exaggeration, u_params.y = 1 / exaggeration).
float sq_haze_depth() { return 0.05 * max(u_sun_radiance.w - 1.0, 0.0); }
float sq_haze_depth_above_camera()
{
    float inv_e = u_params.y > 0.0 ? u_params.y : 1.0;
    return sq_haze_depth() * exp(-max(u_cam_pos.z * inv_e, 0.0) / 1500.0);
}

// Sky radiance seen from the camera along unit direction d: gradient between zenith and horizon
// (weight (1 - d.z)^3), a forward-scattering haze glow around the sun (Henyey–Greenstein g = 0.75,
// single scattering of the aerosol optical depth above the camera along the view path: it fades
// as the camera climbs out of the haze), optionally the sun disc.
// Below the horizon the sky fades to light reflected by the ground.
vec3 sq_sky_radiance(vec3 d, bool with_sun)
{
    vec3 s = u_sun_dir.xyz;
    vec3 E = u_sun_radiance.xyz;
    float mu = d.z;
    float h = max(mu, 0.0);
    float t = (1.0 - h) * (1.0 - h) * (1.0 - h);
    vec3 L = mix(u_sky_zenith.xyz, u_sky_horizon.xyz, t);
    if (mu < 0.0) {
        vec3 ground = u_ground_albedo.xyz *
                      (E * max(s.z, 0.0) + 0.5 * (u_sky_zenith.xyz + u_sky_horizon.xyz));
        L = mix(u_sky_horizon.xyz, ground, smoothstep(0.0, 0.15, -mu));
    }
    float c = dot(d, s);
    float tau = sq_haze_depth_above_camera() / max(h, 0.05);
    // single scattering: irradiance (pi E) x scattered fraction x phase; 0.5 for the aerosol
    // light lost before it reaches the eye
    L += SQ_PI * E * sq_hg(c, 0.75) * (1.0 - exp(-tau)) * 0.5 * step(-0.02, s.z);
    if (with_sun && mu > 0.0 && s.z > -SQ_SUN_ANGULAR_RADIUS) {
        float ca = cos(SQ_SUN_ANGULAR_RADIUS);
        if (c > ca) {
            // disc radiance = irradiance (pi E) / solid angle, with a little limb darkening;
            // capped below the half-float maximum of the HDR target
            float omega = SQ_PI * SQ_SUN_ANGULAR_RADIUS * SQ_SUN_ANGULAR_RADIUS;
            float r = clamp(acos(min(c, 1.0)) / SQ_SUN_ANGULAR_RADIUS, 0.0, 1.0);
            float limb = 1.0 - 0.4 * (1.0 - sqrt(max(1.0 - r * r, 0.0)));
            L += min(SQ_PI * E / omega * limb, vec3(30000.0));
        }
    }
    return L;
}

// Radiance a white surface with unit normal n reflects from the sky and the ground (irradiance
// / pi; hemisphere blend: the sky's mean radiance above, the ground's reflection below).
vec3 sq_ambient(vec3 n)
{
    vec3 sky = mix(u_sky_horizon.xyz, u_sky_zenith.xyz, 0.35);
    vec3 ground = u_ground_albedo.xyz *
                  (u_sun_radiance.xyz * max(u_sun_dir.z, 0.0) + sky);
    float up = 0.5 + 0.5 * n.z;
    return sky * up + ground * (1.0 - up);
}

// Aerial haze: extinction (1/m) at sea level and scale heights of its two parts. Air molecules
// (clean air, turbidity 1; 1e-5/m is about Rayleigh's 1.16e-5/m at 550 nm) thin out with the
// atmosphere's scale height of 8 km; the aerosol that turbidity adds lives in the lowest
// kilometres and falls off with a scale height of about 1.5 km (Elterman 1968; the continental
// aerosol profiles of Hess, Koepke & Schult 1998 use 1-2 km). At sea level the two add up to the
// 1e-5 (1 + 2 (T - 1)) / m of a uniform haze; above a few kilometres (mountains, a plateau,
// clouds seen from above) the air is clear.
const float SQ_HAZE_AIR_BETA = 1.0e-5;
const float SQ_HAZE_AIR_SCALE_M = 8000.0;
const float SQ_HAZE_AEROSOL_BETA = 2.0e-5; // per unit of turbidity above 1
const float SQ_HAZE_AEROSOL_SCALE_M = 1500.0;

// Mean of exp(-z / H) along a straight path between heights z0 and z1 (m above sea level):
// exp(-z_low / H) (1 - exp(-d)) / d with d = |z1 - z0| / H (stable both ways).
float sq_haze_profile_mean(float z0, float z1, float H)
{
    float d = abs(z1 - z0) / H;
    float low = exp(-min(z0, z1) / H);
    return d < 1e-3 ? low * (1.0 - 0.5 * d) : low * (1.0 - exp(-d)) / d;
}

// Optical depth of the haze between the camera and world point p. World heights are the
// physical ones times the vertical exaggeration (u_params.y holds 1 / exaggeration), so the
// profile and the path length are taken in physical metres.
float sq_haze_optical_depth(vec3 p)
{
    float inv_e = u_params.y > 0.0 ? u_params.y : 1.0;
    vec3 v = p - u_cam_pos.xyz;
    float len = length(vec3(v.xy, v.z * inv_e));
    float z0 = u_cam_pos.z * inv_e, z1 = p.z * inv_e;
    float aerosol = SQ_HAZE_AEROSOL_BETA * max(u_sun_radiance.w - 1.0, 0.0);
    return len * (SQ_HAZE_AIR_BETA * sq_haze_profile_mean(z0, z1, SQ_HAZE_AIR_SCALE_M) +
                  aerosol * sq_haze_profile_mean(z0, z1, SQ_HAZE_AEROSOL_SCALE_M));
}

// Aerial perspective: blends radiance toward the horizon sky with the haze's optical depth
// along the view ray (1 - exp(-tau)). Over the last half of the way to the far plane the blend
// also goes to 1: a terrain that reaches beyond the far plane then meets the sky drawn behind it
// (the horizon colour just below the horizon) without a step where it is clipped, instead of
// ending in a bright edge.
// The blend weight toward the sky, and the sky radiance blended to, for world point p.
float sq_haze_fraction(vec3 p)
{
    float dist = length(p - u_cam_pos.xyz);
    float far = u_sky_horizon.w;
    return max(1.0 - exp(-sq_haze_optical_depth(p)), smoothstep(0.5 * far, far, dist));
}

vec3 sq_haze_inscatter(vec3 p)
{
    vec3 v = p - u_cam_pos.xyz;
    vec3 d = v / max(length(v), 1e-3);
    return sq_sky_radiance(normalize(vec3(d.xy, max(d.z, 0.02))), false);
}

vec3 sq_haze(vec3 L, vec3 p) { return mix(L, sq_haze_inscatter(p), sq_haze_fraction(p)); }

// Integer-hash value noise in [0, 1] (smooth, period-free).
float sq_hash(ivec2 q)
{
    uint h = uint(q.x) * 0x8da6b343u ^ uint(q.y) * 0xd8163841u;
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    return float(h & 0xffffffu) / 16777215.0;
}

float sq_value_noise(vec2 x)
{
    vec2 i = floor(x);
    vec2 f = x - i;
    vec2 u = f * f * (3.0 - 2.0 * f);
    ivec2 q = ivec2(i);
    float a = sq_hash(q), b = sq_hash(q + ivec2(1, 0));
    float c = sq_hash(q + ivec2(0, 1)), e = sq_hash(q + ivec2(1, 1));
    return mix(mix(a, b, u.x), mix(c, e, u.x), u.y);
}

// Three octaves, mean ~0.5.
float sq_fbm(vec2 x)
{
    return 0.5 * sq_value_noise(x) + 0.3 * sq_value_noise(2.03 * x + 17.1) +
           0.2 * sq_value_noise(4.01 * x + 41.7);
}
