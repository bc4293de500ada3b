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
// into a float copy of the HDR scene. What depends only on the pixel's ray (slab length, near
// plane cut, phase function) comes from the bounds pass. Compiled with VOL_GREY_EXT 1 when the
// extinction is the same on every channel (one exponential per transmittance; llvmpipe would
// evaluate both sides of a branch).
// J_amb: the sky's and the ground's halves of the ambient light, each scaled by its visibility
// through the medium from this point (u_ambient, a 3D texture; one texel of the unscaled sum
// when the renderer's ambient is uniform).
// Multiple scattering beyond the forward lobe, u_ms_mode 2 (diffusion, the default): the
// delta-Eddington P1 source of the light scattered out of the sun's beam, for the slab that
// the sun ray through the point crosses: tau the sun's optical depth to the point (alpha of
// the light layer plus the half slab), tau0 the whole ray's (alpha of the last light layer,
// u_tau_total), plus the delta-Eddington beam's forward-peak light scattered once more;
// render_internal.h (sq__volume_ms_diffusion, sq__volume_ms_beam) gives the equations, per
// channel here. u_ms_mode 1 (octaves): octaves i = 1..n add E albedo^i b^i (exp(-a^i tau) - exp(-tau))
// p_HG(theta, c^i g) to J, after Wrenninge et al. 2013 (render_internal.h,
// sq__volume_ms_weight). 0: none.
#include "volume_common.glsl"

in vec3 v_world;
in vec2 v_light_uv;             // light-buffer coordinates of v_world
in vec3 v_back_tmin, v_back_tmax; // ray v_world - t wl against the box planes, per axis
flat in float v_layer;

layout(binding = 0) uniform sampler3D u_density;
layout(binding = 1) uniform sampler2DArray u_light; // per slice: light arriving (ratio to E_sun)
layout(binding = 2) uniform sampler2D u_bounds;     // per pixel: t_in, t_out, dt, t_clip
layout(binding = 3) uniform sampler2D u_phase;      // per pixel: phase toward the eye

uniform vec3 u_cam;
uniform vec3 u_tex_lo, u_tex_size; // the density's box (texture coordinates 0..1)
uniform float u_dlambda;       // light slab length spacing / (s . wl) (m)
uniform vec3 u_sigma_ext, u_albedo;
uniform vec3 u_sun_radiance;   // sun irradiance E
// per voxel: the phase-averaged ambient radiance J_amb, the sky's half and the ground's half
// each scaled by its visibility through the medium (render_volume.c, volume_sky.c)
layout(binding = 4) uniform sampler3D u_ambient;
// the light after the last slab: its alpha is the sun ray's whole optical depth (mode 2)
layout(binding = 5) uniform sampler2D u_tau_total;
uniform int u_ms_mode;         // multiple scattering: 0 none, 1 octaves, 2 diffusion
uniform int u_ms_octaves;      // multiple-scattering octaves beyond the first (mode 1)
uniform vec3 u_ms_abc;         // per octave: extinction scale a, weight b, asymmetry scale c
uniform float u_ms_g;          // asymmetry of the first octave (green)

const float VOL_K2_GUARD = 0.01; // render_internal.h SQ_VOL_MS_K2_GUARD
const float VOL_MS_WIDTH = 0.5;  // render_internal.h SQ_VOL_MS_WIDTH

// sq__volume_ms_diffusion per channel: w albedo, g asymmetry, tau and tau0 the optical depths
// to the point and through the whole sun ray (per channel), ct = cos(theta).
vec3 vol_ms_diffusion(vec3 w, float g, vec3 tau, vec3 tau0, float ct)
{
    float f = g * g, gs = g / (1.0 + g);
    vec3 sc = 1.0 - w * f;
    vec3 ws = min(w * (1.0 - f) / sc, vec3(0.999));
    vec3 h = 1.0 / (3.0 * (1.0 - ws * gs));
    vec3 t0 = sc * max(tau0, tau);
    // light leaving sideways: the body taken as wide as VOL_MS_WIDTH times the sun ray's
    // depth, extrapolated by 2h on each side (geometric buckling of two transverse directions)
    vec3 wdt = VOL_MS_WIDTH * t0 + 4.0 * h;
    vec3 k2 = 3.0 * (1.0 - ws) * (1.0 - ws * gs) + 2.0 * VOL_PI * VOL_PI / (wdt * wdt);
    vec3 near1 = step(abs(k2 - 1.0), vec3(VOL_K2_GUARD));
    k2 = mix(k2, 1.0 + VOL_K2_GUARD * sign(k2 - 1.0 + 1e-12), near1);
    vec3 k = sqrt(k2);
    vec3 C = 3.0 * ws * (1.0 + gs - ws * gs) / (k2 - 1.0), S = 3.0 * h * ws * gs;
    vec3 t = sc * tau;
    vec3 ek = exp(-k * t0), ec = exp(-t0);
    vec3 a11 = 1.0 + 2.0 * h * k, a12 = ek * (1.0 - 2.0 * h * k);
    vec3 r1 = -C * (1.0 + 2.0 * h) - 2.0 * S, r2 = -C * ec * (1.0 - 2.0 * h) + 2.0 * S * ec;
    vec3 det = a11 * a11 - a12 * a12;
    vec3 A = (r1 * a11 - a12 * r2) / det, B = (a11 * r2 - a12 * r1) / det;
    vec3 e1 = exp(-k * t), e2 = exp(-k * (t0 - t)), e3 = exp(-t);
    vec3 phi = A * e1 + B * e2 + C * e3;
    vec3 F = S * e3 - h * (-k * A * e1 + k * B * e2 - C * e3);
    return max(phi + 3.0 * g * F * ct, 0.0) / (4.0 * VOL_PI);
}

layout(location = 0, index = 0) out vec4 o_color;
layout(location = 0, index = 1) out vec4 o_trans;

void main()
{
    ivec2 px = ivec2(gl_FragCoord.xy);
    float t = length(v_world - u_cam);
    vec4 bounds = texelFetch(u_bounds, px, 0); // t_in, t_out, dt, t_clip
    float dt = bounds.z;
    // The nearer neighbour slice along this ray lies at t - dt. If the near plane clips it away
    // (camera inside the volume), this slice also stands for its part of the ray, down to the
    // camera (t_clip: where the near plane cuts the ray), so that no dust goes missing in front
    // of the first visible slice.
    float lo = t - dt < bounds.w ? bounds.x : max(t - 0.5 * dt, bounds.x);
    float len = min(t + 0.5 * dt, bounds.y) - lo;
    if (len <= 0.0) discard;

    // the edge on the smooth (cubic B-spline) field: no facets up close (volume_common.glsl)
    float rho = vol_density_smooth(u_density, v_world, u_tex_lo, u_tex_size);
    if (rho <= 0.0) discard; // clear air: T = 1, no light (leaves the target as it is)
    vec3 beta = rho * u_sigma_ext;
#if VOL_GREY_EXT
    vec3 T = vec3(exp(-beta.g * len));
#else
    vec3 T = exp(-beta * len);
#endif

    // sun light reaching this point: the light arriving at the slice, then half a light slab
    vec4 light = textureLod(u_light, vec3(v_light_uv, v_layer), 0.0);
    vec3 L = light.rgb;
    vec2 lb = vec2(max(max(v_back_tmin.x, v_back_tmin.y), v_back_tmin.z),
                   min(min(v_back_tmax.x, v_back_tmax.y), v_back_tmax.z));
    float back = lb.x <= lb.y ? clamp(lb.y, 0.0, 0.5 * u_dlambda) : 0.0;
#if VOL_GREY_EXT
    L *= exp(-beta.g * back);
#else
    L *= exp(-beta * back);
#endif
    vec4 phase = texelFetch(u_phase, px, 0);
    vec3 Ls = L * phase.rgb;
    if (u_ms_mode == 2) { // uniform: the same side for every fragment
        float tau = light.a + beta.g * back;
        float tau0 = textureLod(u_tau_total, v_light_uv, 0.0).a;
        vec3 per = u_sigma_ext / u_sigma_ext.g; // optical depth per channel from green's
        Ls += vol_ms_diffusion(u_albedo, u_ms_g, tau * per, tau0 * per, phase.a);
        // J_beam: the forward peak's light beyond the beam exp(-tau) (delta-Eddington: the
        // beam is exp(-(1 - w f) tau))
        float f = u_ms_g * u_ms_g;
        vec3 beam = max(exp(-(1.0 - u_albedo * f) * tau * per) - exp(-tau * per), 0.0);
        // scattered once in the peak and once more toward the eye: HG(g) twice ~ HG(g^2)
        Ls += vol_hg(phase.a, f) * beam;
    } else if (u_ms_mode == 1 && u_ms_octaves > 0) {
        float tau = light.a + beta.g * back;
        float direct = exp(-tau), a = 1.0, b = 1.0, g = u_ms_g;
        vec3 w = vec3(1.0);
        for (int i = 0; i < u_ms_octaves; i++) {
            a *= u_ms_abc.x;
            b *= u_ms_abc.y;
            g *= u_ms_abc.z;
            w *= u_albedo;
            Ls += w * (b * max(exp(-a * tau) - direct, 0.0) * vol_hg(phase.a, g));
        }
    }
    vec3 tc = vol_tc(v_world, u_tex_lo, u_tex_size);
    vec3 J = u_sun_radiance * Ls + textureLod(u_ambient, tc, 0.0).rgb;
    o_color = vec4(u_albedo * J * (1.0 - T), 0.0);
    o_trans = vec4(T, 1.0);
}
