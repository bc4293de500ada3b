// snow_common.glsl — snow lying on the opaque surfaces (S2 chapter 2, SPEC §6.2–6.5), included
// after frame_common.glsl by the terrain, obstacle and mesh shaders. The formulas mirror
// src/render/snow_map.c (tested there on the CPU); render_snowcover.c fills the Snow block
// (binding 4, mirrored by snow_block there) and binds the occlusion map (unit 11: depth of an
// orthographic camera at the top looking down, 0 at top_z .. 1 at bottom_z) and the snow depth
// (unit 12: metres on the highest surface of each column). Without a snow-cover drawable the
// block's u_snow_depth_grid.z is 0 and every function returns "no snow".

layout(std140, binding = 4) uniform Snow {
    vec4 u_snow_map;        // origin x, origin y (m), texel (m), size (texels)
    vec4 u_snow_range;      // top z, bottom z (m), detail distance D_snow (m), far-field blend start (m)
    vec4 u_snow_depth_grid; // 1/dx, 1/dy (1/m), enabled (0/1), shell blend (0 normal .. 1 up)
    vec4 u_snow_depth_org;  // origin x, y of the depth grid (m), nx, ny
    vec4 u_snow_taps;       // M, tap radius (texels), depth bias (m), noise amplitude
    vec4 u_snow_albedo;     // snow albedo (linear rgb), brdf (0 physical, 1 Blinn-Phong)
    vec4 u_snow_look;       // sparkle, Blinn-Phong exponent, noise scale (m), camera m/px at 1 m
};
layout(binding = 11) uniform sampler2D u_snow_occ;
layout(binding = 12) uniform sampler2D u_snow_depth;

// Programs compiled with SQ_NO_SNOW (the renderer's variants for frames without a snow-cover
// drawable) have the snow compiled out: a software rasteriser (llvmpipe) runs the code of a
// branch not taken under an execution mask, so a uniform "no snow" still cost every pixel it.
#ifdef SQ_NO_SNOW
bool sq_snow_on() { return false; }
#else
bool sq_snow_on() { return u_snow_depth_grid.z > 0.5; }
#endif

// Snow depth (m) at world (x, y): bilinear between cell centres, edge cells beyond the grid.
float sq_snow_depth_at(vec2 xy)
{
    vec2 uv = (xy - u_snow_depth_org.xy) * u_snow_depth_grid.xy / u_snow_depth_org.zw;
    return texture(u_snow_depth, uv).r;
}

// Integer-hash 3D value noise in [0, 1] and its octave sum (frequency x2, amplitude x1/2),
// as sq__snow_noise3 / sq__snow_fbm3.
float sq_snow_hash3(ivec3 q)
{
    uint h = uint(q.x) * 0x8da6b343u ^ uint(q.y) * 0xd8163841u ^ uint(q.z) * 0xcb1ab31fu;
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    return float(h & 0xffffffu) / 16777215.0;
}

float sq_snow_noise3(vec3 x)
{
    vec3 i = floor(x), t = x - i;
    vec3 u = t * t * (3.0 - 2.0 * t);
    ivec3 q = ivec3(i);
    float c0 = mix(mix(sq_snow_hash3(q), sq_snow_hash3(q + ivec3(1, 0, 0)), u.x),
                   mix(sq_snow_hash3(q + ivec3(0, 1, 0)), sq_snow_hash3(q + ivec3(1, 1, 0)), u.x), u.y);
    float c1 = mix(mix(sq_snow_hash3(q + ivec3(0, 0, 1)), sq_snow_hash3(q + ivec3(1, 0, 1)), u.x),
                   mix(sq_snow_hash3(q + ivec3(0, 1, 1)), sq_snow_hash3(q + ivec3(1, 1, 1)), u.x), u.y);
    return mix(c0, c1, u.z);
}

float sq_snow_fbm3(vec3 x, int octaves)
{
    float sum = 0.0, amp = 0.5, norm = 0.0;
    for (int o = 0; o < octaves; o++) {
        sum += amp * sq_snow_noise3(x);
        norm += amp;
        amp *= 0.5;
        x *= 2.0;
    }
    return sum / norm;
}

// Weight of the occlusion map at p: 1 inside the map and nearer than the far-field blend start,
// falling to 0 at D_snow and over the last 4 texels of the map (S2 §2.4.2: beyond, texture
// blending only). Depends on p and the camera only, so coincident vertices agree.
float sq_snow_near_weight(vec3 p)
{
    if (u_snow_map.w < 1.0) return 0.0;
    float d = length(p - u_cam_pos.xyz);
    float w = 1.0 - smoothstep(u_snow_range.w, u_snow_range.z, d);
    vec2 uv = (p.xy - u_snow_map.xy) / u_snow_map.z;
    vec2 edge = min(uv, vec2(u_snow_map.w) - uv);
    return w * smoothstep(0.0, 4.0, min(edge.x, edge.y));
}

// Exposure f_e (eq 2.2): the fraction of the M taps around p whose occluder is not
// above p by more than the bias, slope-scaled by the surface's normal z nz
// (sq__snow_slope_bias: + (radius + 1/2) texels x tan(slope), tan at most 3), plus the
// camera's allowance: lod_m, the error of the level of detail the camera draws p's surface with
// (render_meshes.c; 0 for the terrain), which may lie up to that below the finer level the map
// holds, but at least a pixel at p's distance (the camera's own resolution). corner: the top of
// a wall (sq__snow_corner_exposure): 1 when none of the four texels around p is above the bias,
// else 0.
float sq_snow_exposure_map(vec3 p, float nz, float lod_m, bool corner)
{
    vec2 uv = (p.xy - u_snow_map.xy) / u_snow_map.z;
    int size = int(u_snow_map.w);
    float span = u_snow_range.x - u_snow_range.y;
    float d_act = (u_snow_range.x - p.z) / span;
    float c = clamp(nz, 0.3162, 1.0);
    float lod = max(lod_m, length(p - u_cam_pos.xyz) * u_snow_look.w);
    float bias = (u_snow_taps.z + lod + (u_snow_taps.y + 0.5) * u_snow_map.z * sqrt(1.0 - c * c) / c) / span;
    if (corner) {
        ivec2 t0 = ivec2(floor(uv - 0.5));
        for (int q = 0; q < 4; q++) {
            ivec2 t = clamp(t0 + ivec2(q & 1, q >> 1), ivec2(0), ivec2(size - 1));
            if (texelFetch(u_snow_occ, t, 0).r - d_act < -bias) return 0.0;
        }
        return 1.0;
    }
    int m = int(u_snow_taps.x);
    float r = u_snow_taps.y;
    vec2 off[9];
    int n = 0;
    if (m == 1 || m == 5) off[n++] = vec2(0.0);
    if (m == 4 || m == 5) {
        off[n++] = vec2(r, 0.0);
        off[n++] = vec2(-r, 0.0);
        off[n++] = vec2(0.0, r);
        off[n++] = vec2(0.0, -r);
    }
    if (m == 9)
        for (int j = -1; j <= 1; j++)
            for (int i = -1; i <= 1; i++) off[n++] = r * vec2(i, j);
    if (n == 0) return 1.0;
    float exposed = 0.0;
    for (int k = 0; k < n; k++) {
        // the four texels around the tap, their answers blended bilinearly (as sq__snow_exposure)
        vec2 a = uv + off[k] - 0.5;
        vec2 fa = floor(a), w = a - fa;
        ivec2 t0 = ivec2(fa);
        vec4 e;
        for (int q = 0; q < 4; q++) {
            ivec2 t = clamp(t0 + ivec2(q & 1, q >> 1), ivec2(0), ivec2(size - 1));
            e[q] = texelFetch(u_snow_occ, t, 0).r - d_act >= -bias ? 1.0 : 0.0;
        }
        exposed += mix(mix(e.x, e.y, w.x), mix(e.z, e.w, w.x), w.y);
    }
    return exposed / float(n);
}

// f_e with the far field: the map's answer near the camera, 1 (no occlusion test) beyond.
float sq_snow_exposure(vec3 p, float nz, float lod_m, bool corner)
{
    float w = sq_snow_near_weight(p);
    return w > 0.0 ? mix(1.0, sq_snow_exposure_map(p, nz, lod_m, corner), w) : 1.0;
}

// Inclination f_inc (eq 2.3): max(0, N.z) times a mean-one noise factor (sq__snow_inclination).
float sq_snow_inclination(vec3 n, vec3 p)
{
    float up = max(n.z, 0.0);
    float a = u_snow_taps.w;
    if (up <= 0.0 || a == 0.0) return min(up, 1.0);
    float f = sq_snow_fbm3(p / u_snow_look.z, 3);
    return clamp(up * (1.0 + a * (2.0 * f - 1.0)), 0.0, 1.0);
}

// S2's far-field density (eqs 2.9-2.10) on world tiles of 8 m: the centre-out ramp F1
// (normalised) and the edge-in ramp F2 weight two noise layers, so that the centres and the
// edges of a tile get snow alike and no tile pattern shows.
float sq_snow_far_density(vec3 p)
{
    vec2 b = vec2(8.0);
    vec2 x = mod(p.xy, b);
    float f1 = min(min(x.x, b.x - x.x), min(x.y, b.y - x.y)) / (0.5 * max(b.x, b.y));
    float f2 = max(abs(x.x - 0.5 * b.x), abs(x.y - 0.5 * b.y)) / (0.5 * max(b.x, b.y));
    float n1 = sq_snow_noise3(vec3(p.xy / 3.0, 0.5)), n2 = sq_snow_noise3(vec3(p.xy / 3.0 + 17.3, 1.5));
    return clamp(0.8 + 0.4 * (f1 * n1 + f2 * n2) - 0.2, 0.0, 1.0);
}

// f_p (eq 2.1) at p with unit normal n (lod_m: as for the exposure), blended into the far field
// beyond the map. full_m: the
// depth from which thin snow covers the surface whole (SQ_SNOW_FULL_GROUND on the terrain, whose
// grass and rough ground poke through; SQ_SNOW_FULL_BUILT on roofs, walls and other meshes).
const float SQ_SNOW_FULL_GROUND = 0.16, SQ_SNOW_FULL_BUILT = 0.06;
float sq_snow_cover(vec3 p, vec3 n, float full_m, float lod_m)
{
    if (!sq_snow_on()) return 0.0;
    float inc = sq_snow_inclination(n, p);
    if (inc <= 0.0) return 0.0;
    float w = sq_snow_near_weight(p);
    float near_fp = w > 0.0 ? sq_snow_exposure_map(p, n.z, lod_m, false) * inc : 0.0;
    float far_fp = inc * sq_snow_far_density(p);
    float depth = sq_snow_depth_at(p.xy);
    // thin snow covers partly, in patches: the covered fraction grows with depth / (full_m / 2)
    // times a noise in [0.5, 1.5]; whole from about full_m (16 cm on the ground, 6 cm on a
    // smooth roof, where 16 cm left a wind-scoured roof's few centimetres as blotches)
    float patchy = sq_snow_noise3(vec3(p.xy / 1.5, 0.37)) * 0.7 + sq_snow_noise3(vec3(p.xy / 0.4, 5.1)) * 0.3;
    float cover = clamp(depth / (0.5 * full_m) * (0.5 + patchy), 0.0, 1.0);
    return cover * mix(far_fp, near_fp, w);
}

// The snow shell (sq__snow_shell_offset): displacement of a vertex at p with the welded normal
// ns (sq__snow_welded_normals: unit xyz, w = 1 at the top of a wall) by depth x f_e x min(1,
// 2 max(0, ns.z)), along the blend of ns and up, straight up at the top of a wall, whose
// exposure is sq__snow_corner_exposure's (lod_m: as for the exposure). A function of p, ns and the drawn level: coincident vertices move together.
vec3 sq_snow_shell(vec3 p, vec4 ns, float lod_m)
{
    if (!sq_snow_on()) return vec3(0.0);
    float w = min(1.0, 2.0 * max(0.0, ns.z));
    if (w <= 0.0) return vec3(0.0);
    vec3 up = vec3(0.0, 0.0, 1.0);
    vec3 dir = ns.w > 0.5 ? up : normalize(mix(ns.xyz, up, u_snow_depth_grid.w));
    return dir * (sq_snow_depth_at(p.xy) * sq_snow_exposure(p, ns.z, lod_m, ns.w > 0.5) * w);
}

// Shading normal of the shell over a surface of unit normal n at p where the depth varies (a
// drift): normalize(n - n.z w grad(depth)), w as in the shell (sq__snow_shell_normal); the
// gradient by central differences one depth cell apart.
vec3 sq_snow_shell_normal(vec3 p, vec3 n)
{
    float w = min(1.0, 2.0 * max(0.0, n.z));
    if (!sq_snow_on() || w <= 0.0) return n;
    vec2 h = 1.0 / u_snow_depth_grid.xy;
    vec2 g = vec2(sq_snow_depth_at(p.xy + vec2(h.x, 0.0)) - sq_snow_depth_at(p.xy - vec2(h.x, 0.0)),
                  sq_snow_depth_at(p.xy + vec2(0.0, h.y)) - sq_snow_depth_at(p.xy - vec2(0.0, h.y))) /
             (2.0 * h);
    return normalize(n - n.z * w * vec3(g, 0.0));
}

// Radiance of snow at p (unit normal n, view direction v toward the eye) under the sun E_sun
// (already shadowed) and the sky: the physically based default or S2's Blinn-Phong (eq 2.7)
// with the noise-perturbed normal.
vec3 sq_snow_radiance(vec3 p, vec3 n, vec3 v, vec3 E_sun)
{
    vec3 s = u_sun_dir.xyz;
    vec3 a = u_snow_albedo.rgb;
    // per-pixel normal perturbation: 3 octaves of the 3D noise (S2 §2.2.2 step 3)
    vec3 q = p / max(u_snow_look.z * 0.05, 1e-3);
    vec3 g = vec3(sq_snow_noise3(q), sq_snow_noise3(q + 31.7), sq_snow_noise3(q + 63.1)) - 0.5;
    vec3 np = normalize(n + 0.35 * g);
    vec3 h = normalize(s + v);
    if (u_snow_albedo.w > 0.5) {
        // Blinn-Phong: I_a K_a + I_l K_d max(0, L.N) + I_l K_s max(0, N.H)^n
        float spec = pow(max(dot(np, h), 0.0), max(u_snow_look.y, 1.0));
        return a * (E_sun * max(dot(np, s), 0.0) + sq_ambient(np)) + 0.3 * E_sun * spec;
    }
    // physical: a near-white diffuse lobe with wrap lighting for the light that travels inside
    // the snowpack (tinted blue: ice absorbs red), a forward-scattering lobe toward grazing views
    // against the sun, and sparse glints of facets aligned with the half vector.
    float ndl = dot(np, s);
    float wrap = max((ndl + 0.3) / 1.3, 0.0);
    vec3 sss = vec3(0.70, 0.84, 1.0);
    vec3 diffuse = a * (E_sun * mix(sss * wrap, vec3(max(ndl, 0.0)), 0.75) + sq_ambient(np));
    float fwd = sq_hg(dot(-v, s), 0.6) * pow(1.0 - max(dot(np, v), 0.0), 3.0);
    vec3 forward = 0.25 * a * E_sun * fwd * step(0.0, ndl);
    // glints: 2 cm cells, a few per cent of them with a facet normal close to h
    ivec3 cell = ivec3(floor(p / 0.02));
    float pick = sq_snow_hash3(cell);
    vec3 facet = normalize(n + 0.6 * (vec3(sq_snow_hash3(cell + 7), sq_snow_hash3(cell + 13),
                                            sq_snow_hash3(cell + 29)) - 0.5));
    float glint = step(1.0 - 0.04 * u_snow_look.x, pick) * pow(max(dot(facet, h), 0.0), 400.0);
    return diffuse + forward + 40.0 * u_snow_look.x * glint * E_sun;
}
