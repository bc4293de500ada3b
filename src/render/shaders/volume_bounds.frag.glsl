#version 450 core
// volume_bounds.frag — once per frame and pixel, before the slices: the part of the pixel's
// view ray that the volume may fill, [max(t_box_in, 0), min(t_box_out, t_scene)] in metres
// from the camera, t_scene being the distance to the opaque surface seen through the pixel
// (from the depth buffer; the sky is infinitely far). The eye pass clips every slab to it, so
// terrain hides the dust behind it (SPEC 3.4 step 5) and slabs cut by the box or the camera
// count only their inside part. Empty intervals are written as (1, 0). Beside the interval it
// stores what the eye pass needs per pixel and would otherwise recompute for every slice: the
// slab length along this ray dt = spacing / |s . dir| (with |s . dir| >= 0.05), the distance
// t_clip at which the near plane cuts the ray, and the phase function of the sun light
// scattered toward the eye along it (HG per channel, second lobe, SPEC 2.6).
// It also writes, as the depth of the eye pass's depth buffer, the window depth of the farthest
// point a slice fragment can stand for, t_out + half a slab along this ray (plus 2 % for
// depth rounding), so that llvmpipe's early depth test drops the slice fragments behind it
// (behind the terrain or past the box) before the eye shader runs; they would be discarded.
// Opaque dust ends the ray too (u_tau_stop > 0): the pass walks the eye pass's own slices along
// the ray front to back, summing the optical depth the eye pass will give their slabs (the same
// density function at the same points, each slab's length clipped to the interval, so never
// more than the eye pass's; the smallest channel's extinction), and stops at the first slice
// past which it exceeds u_tau_stop: the slices behind it are not drawn. What they would have
// added, and the scene behind, reach the pixel through a transmittance below exp(-u_tau_stop),
// so the picture changes by less than that fraction of the radiance behind. The walk runs only
// inside the box around the dust (u_dust_lo/hi: clear air costs nothing) and gives up after
// VOL_MARCH_DUSTY dusty slices (translucent dust: all slices drawn, as without the walk).
#include "volume_common.glsl"



layout(binding = 0) uniform sampler3D u_density; // as the eye pass samples it
layout(binding = 2) uniform sampler2D u_depth; // opaque scene depth (window depth in [0, 1])

uniform mat4 u_inv_view_proj;
uniform vec2 u_viewport;
uniform vec3 u_cam;
uniform vec3 u_box_lo, u_box_size;
uniform mat4 u_view_proj;
uniform vec3 u_s;              // slice axis (unit)
uniform float u_spacing;       // slice spacing along s (m)
uniform vec3 u_cam_forward;    // camera view direction
uniform float u_near;          // near plane distance (m)
uniform vec3 u_sun_dir;        // unit vector toward the sun
uniform vec3 u_g;              // HG asymmetry per channel
uniform vec2 u_g2w2;           // second lobe: asymmetry, weight
uniform vec3 u_tex_lo, u_tex_size; // the density's box (texture coordinates 0..1)
uniform float u_d_first;       // the eye pass's slice k lies on the plane s . x = d_first + k spacing
uniform int u_planes;          // number of slices
uniform float u_sigma_min;     // smallest extinction per density unit over the channels
uniform float u_tau_stop;      // optical depth past which the slices are not drawn; 0: all drawn
uniform vec3 u_dust_lo, u_dust_hi; // a box outside which the density is 0 (render_volume.c)
const int VOL_MARCH_DUSTY = 8; // dusty slices after which the walk gives up (translucent dust)

// The distance of the slice at which the optical depth from the camera first exceeds
// u_tau_stop along the ray p + t dir inside [b.x, b.y] (3e38 if it does not). The slices meet
// the ray at t_k = (d_first + k spacing - s . p) / (s . dir), dt apart; slice k stands for
// [t_k - dt/2, t_k + dt/2] (the eye pass's slab), clipped here to [b.x, b.y].
float opaque_distance(vec3 p, vec3 dir, vec2 b)
{
    float u = dot(u_s, dir);
    // only where there is dust: clear air adds nothing, and the slabs clipped to it are shorter
    vec2 db = vol_box_interval(p, dir, u_dust_lo, u_dust_hi);
    b = vec2(max(b.x, db.x), min(b.y, db.y));
    if (u_tau_stop <= 0.0 || b.x >= b.y || abs(u) < 0.05) return 3.0e38;
    float dt = u_spacing / abs(u);
    // the plane coordinate at t = b.x, and the first slice whose slab reaches past b.x
    float kf = (dot(u_s, p) + b.x * u - u_d_first) / u_spacing;
    float k0 = u > 0.0 ? floor(kf - 0.5) + 1.0 : ceil(kf + 0.5) - 1.0;
    float t0 = (u_d_first + k0 * u_spacing - dot(u_s, p)) / u;
    float tau = 0.0;
    int dusty = 0;
    for (int j = 0; j < u_planes; j++) {
        float t = t0 + float(j) * dt;
        if (t - 0.5 * dt >= b.y) break;
        float len = max(min(t + 0.5 * dt, b.y) - max(t - 0.5 * dt, b.x), 0.0);
        float rho = vol_density_smooth(u_density, p + t * dir, u_tex_lo, u_tex_size);
        tau += rho * u_sigma_min * len;
        if (tau > u_tau_stop) return t;
        if (rho > 0.0 && ++dusty >= VOL_MARCH_DUSTY) break;
    }
    return 3.0e38;
}

layout(location = 0) out vec4 o_bounds; // t_in, t_out, dt, t_clip (m)
layout(location = 1) out vec4 o_phase;  // phase function toward the eye, per channel (1/sr);
                                        // alpha: cos theta (for the octaves)

void main()
{
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec2 ndc = (vec2(px) + 0.5) / u_viewport * 2.0 - 1.0;
    vec4 f = u_inv_view_proj * vec4(ndc, 1.0, 1.0);
    vec3 dir = normalize(f.xyz / f.w - u_cam);
    float d = texelFetch(u_depth, px, 0).r;
    float t_scene = 3.0e38;
    if (d < 1.0) {
        vec4 w = u_inv_view_proj * vec4(ndc, d * 2.0 - 1.0, 1.0);
        t_scene = length(w.xyz / w.w - u_cam);
    }
    vec2 box = vol_box_interval(u_cam, dir, u_box_lo, u_box_lo + u_box_size);
    vec2 b = vec2(max(box.x, 0.0), min(box.y, t_scene));
    float dt = u_spacing / max(abs(dot(u_s, dir)), 0.05);
    float t_clip = u_near / max(dot(dir, u_cam_forward), 1e-4);
    o_bounds = vec4(b.x < b.y ? b : vec2(1.0, 0.0), dt, t_clip);
    float cos_theta = dot(u_sun_dir, dir); // = (light propagation) . (propagation toward eye)
    vec3 p1 = vec3(vol_hg(cos_theta, u_g.r), vol_hg(cos_theta, u_g.g), vol_hg(cos_theta, u_g.b));
    o_phase = vec4(mix(p1, vec3(vol_hg(cos_theta, u_g2w2.x)), u_g2w2.y), cos_theta);
    // the farthest point a slice fragment of this ray can stand for: t_out + half a slab, or
    // the slice where the dust has become opaque
    float t_far = (min(b.y, opaque_distance(u_cam, dir, b)) + 0.5 * dt) * 1.02;
    vec4 c = u_view_proj * vec4(u_cam + dir * min(t_far, 1.0e30), 1.0);
    float depth = c.w > 0.0 ? clamp(c.z / c.w * 0.5 + 0.5, 0.0, 1.0) : 1.0;
    gl_FragDepth = b.x < b.y ? depth : 0.0;
}
