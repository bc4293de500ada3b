#version 450 core
// volume_light.vert — one triangle covering the light buffer for a light pass
// (volume_light.frag). Everything the pass needs per texel that is affine in the texel's
// position is computed here at the three corners and interpolated (exact for affine
// functions): the sun ray's origin on the light frame plane q, the ray parameter lambda where it
// meets the slice plane, that point p, and per axis the ray's entry and exit parameters
// through the box planes (the sign of 1/wl picks the same plane at every corner, so min and
// max stay affine).
uniform vec4 u_uv_rect;        // light-frame coordinates covered: u0, v0, u1, v1 (m)
uniform vec3 u_e1, u_e2;       // light-frame axes (perpendicular to wl)
uniform vec3 u_wl;             // light propagation direction
uniform vec3 u_inv_wl;         // 1 / wl per axis (+-1e10 where wl has no component)
uniform vec3 u_s;              // slice axis
uniform float u_plane;         // this slice: s . x = u_plane
uniform vec3 u_box_lo, u_box_size;

out vec3 v_p;                  // where the texel's ray meets the slice plane
out float v_lambda;            // ray parameter there
out vec3 v_tmin, v_tmax;       // ray parameters at the box planes, per axis

void main()
{
    vec2 uv = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    vec2 uvm = mix(u_uv_rect.xy, u_uv_rect.zw, uv);
    vec3 q = u_e1 * uvm.x + u_e2 * uvm.y;
    v_lambda = (u_plane - dot(u_s, q)) / dot(u_s, u_wl);
    v_p = q + u_wl * v_lambda;
    vec3 t0 = (u_box_lo - q) * u_inv_wl;
    vec3 t1 = (u_box_lo + u_box_size - q) * u_inv_wl;
    v_tmin = min(t0, t1);
    v_tmax = max(t0, t1);
    gl_Position = vec4(uv * 2.0 - 1.0, 0.0, 1.0);
}
