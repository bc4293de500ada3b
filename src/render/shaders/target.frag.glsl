#version 450 core
// target.frag — colour between the caller's framebuffer and the renderer's linear HDR frame
// (sq_renderer_draw_to). Mode 0 copies linear radiance (either way). Mode 1 reads a display
// colour made with Squall's tone curve (tonemap.frag: exposure, ACES fit, sRGB) and returns the
// linear radiance that maps to it: sRGB decode, the positive root of the ACES fit solved for x,
// divided by the exposure. tonemap.frag applied to the result gives the input back, so pixels
// without any drawable keep their value.
in vec2 v_ndc;
layout(location = 0) out vec4 o_color;
layout(binding = 0) uniform sampler2D u_src;
layout(location = 0) uniform int u_mode;
layout(location = 1) uniform float u_exposure;

float srgb_decode(float v)
{
    if (v <= 0.04045) return v / 12.92;
    return pow((v + 0.055) / 1.055, 2.4);
}

// y = x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14)  <=>  a x^2 + b x + c = 0 with
// a = 2.43 y - 2.51 < 0, b = 0.59 y - 0.03, c = 0.14 y >= 0: the roots have opposite signs
// (c / a <= 0) and the non-negative one is (-b - sqrt(b^2 - 4 a c)) / (2 a). y = 1 (saturated)
// returns the smallest x that saturates (7.24).
float aces_inverse(float y)
{
    y = clamp(y, 0.0, 1.0);
    float a = 2.43 * y - 2.51, b = 0.59 * y - 0.03, c = 0.14 * y;
    return max((-b - sqrt(max(b * b - 4.0 * a * c, 0.0))) / (2.0 * a), 0.0);
}

void main()
{
    vec4 s = texelFetch(u_src, ivec2(gl_FragCoord.xy), 0);
    if (u_mode == 0) {
        o_color = vec4(s.rgb, 1.0);
        return;
    }
    vec3 x = vec3(aces_inverse(srgb_decode(s.r)), aces_inverse(srgb_decode(s.g)),
                  aces_inverse(srgb_decode(s.b)));
    o_color = vec4(x / u_exposure, 1.0);
}
