#version 450 core
// volume_eye.frag — eye pass of half-angle slicing (SPEC 3.4 step 4a, eq. 3.22 with its Δx):
// one fragment of slice k stands for the slab of the view ray between the neighbouring
// slices, clipped to the volume box, to the camera and to the opaque scene depth (so terrain
// hides dust behind it; the per-pixel bounds come from volume_bounds.frag). Over that length
// Δ the slab has transmittance T = exp(-β_ext Δ) per channel and emits the exact integral of
// a constant source: a J (1 - T), with a the albedo and J = E_sun L_k p(θ) + J_amb the
// phase-weighted radiance falling on it (L_k from layer k of the light array, carried to the
// fragment through half of its own light slab). For thin slabs this is L β_sca p Δs_eye of
// (3.22). The slices are drawn back to front (the light array holds every slice's light, so
// the eye order need not follow the light order) and composited by dual-source blending
// ONE, SRC1_COLOR: C = C_i + T C per channel (eq. 3.1, "over" with per-channel extinction),
// into a float copy of the HDR scene. Compiled with VOL_PHASE_GREY (one g for all channels),
// VOL_PHASE_LOBE2 (second HG lobe weight w2 > 0) and VOL_GREY_EXT (one extinction coefficient
// for all channels) set by render_volume.c, so that the medium costs only what it needs
// (llvmpipe evaluates both sides of branches).
#include "volume_common.glsl"

in vec3 v_world;
in vec2 v_light_uv;             // light-buffer coordinates of v_world
in vec3 v_back_tmin, v_back_tmax; // ray v_world - t wl against the box planes, per axis
flat in float v_layer;

layout(binding = 0) uniform sampler3D u_density;
layout(binding = 1) uniform sampler2DArray u_light; // per slice: light arriving (ratio to E_sun)
layout(binding = 2) uniform sampler2D u_bounds;     // per pixel: ray interval the volume may fill

uniform vec3 u_cam;
uniform vec3 u_cam_forward;    // camera view direction
uniform float u_near;          // near plane distance (m)
uniform vec3 u_box_lo, u_box_size;
uniform vec3 u_s;              // slice axis (unit)
uniform float u_spacing;       // slice spacing along s (m)
uniform vec3 u_wl;             // light propagation direction (unit)
uniform float u_dlambda;       // light slab length spacing / (s . wl) (m)
uniform vec3 u_sigma_ext, u_albedo, u_g;
uniform vec2 u_g2w2;
uniform vec3 u_sun_radiance, u_sun_dir; // sun irradiance E; unit vector TOWARD the sun
uniform vec3 u_ambient;        // phase-averaged sky + ground radiance J_amb

layout(location = 0, index = 0) out vec4 o_color;
layout(location = 0, index = 1) out vec4 o_trans;

void main()
{
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec3 v = v_world - u_cam;
    float t = length(v);
    vec3 dir = v / max(t, 1e-6);
    float dt = u_spacing / max(abs(dot(u_s, dir)), 0.05);
    vec2 bounds = texelFetch(u_bounds, px, 0).xy;
    // The nearer neighbour slice along this ray lies at t - dt. If the near plane clips it away
    // (camera inside the volume), this slice also stands for its part of the ray, down to the
    // camera, so that no dust goes missing in front of the first visible slice.
    float t_clip = u_near / max(dot(dir, u_cam_forward), 1e-4);
    float lo = t - dt < t_clip ? bounds.x : max(t - 0.5 * dt, bounds.x);
    float len = min(t + 0.5 * dt, bounds.y) - lo;
    if (len <= 0.0) discard;

    float rho = vol_density(u_density, v_world, u_box_lo, u_box_size);
    if (rho <= 0.0) discard; // clear air: T = 1, no light (leaves the target as it is)
    vec3 beta = rho * u_sigma_ext;
#if VOL_GREY_EXT
    vec3 T = vec3(exp(-beta.g * len));
#else
    vec3 T = exp(-beta * len);
#endif

    // sun light reaching this point: the light arriving at the slice, then half a light slab
    vec3 L = textureLod(u_light, vec3(v_light_uv, v_layer), 0.0).rgb;
    vec2 lb = vec2(max(max(v_back_tmin.x, v_back_tmin.y), v_back_tmin.z),
                   min(min(v_back_tmax.x, v_back_tmax.y), v_back_tmax.z));
    float back = lb.x <= lb.y ? clamp(lb.y, 0.0, 0.5 * u_dlambda) : 0.0;
#if VOL_GREY_EXT
    L *= exp(-beta.g * back);
#else
    L *= exp(-beta * back);
#endif
    float cos_theta = dot(u_sun_dir, dir); // = (light propagation) . (propagation toward eye)
#if VOL_PHASE_GREY
    float ph = vol_hg(cos_theta, u_g.r);
#if VOL_PHASE_LOBE2
    ph = mix(ph, vol_hg(cos_theta, u_g2w2.x), u_g2w2.y);
#endif
    vec3 phase = vec3(ph);
#else
    vec3 phase = vec3(vol_hg(cos_theta, u_g.r), vol_hg(cos_theta, u_g.g), vol_hg(cos_theta, u_g.b));
#if VOL_PHASE_LOBE2
    phase = mix(phase, vec3(vol_hg(cos_theta, u_g2w2.x)), u_g2w2.y);
#endif
#endif
    vec3 J = u_sun_radiance * L * phase + u_ambient;
    o_color = vec4(u_albedo * J * (1.0 - T), 0.0);
    o_trans = vec4(T, 1.0);
}
