#version 450 core
// tonemap.frag — HDR linear RGB -> exposure -> ACES filmic fit (Narkowicz 2015) -> sRGB, the
// same curve as src/render/tonemap.c (sq_tonemap_rgba8). Writes the 8-bit target.
in vec2 v_ndc;
layout(location = 0) out vec4 o_color;
layout(binding = 0) uniform sampler2D u_hdr;
layout(location = 0) uniform float u_exposure;

float aces(float x)
{
    if (!(x > 0.0)) return 0.0;
    float y = (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14);
    return min(y, 1.0);
}

float srgb(float c)
{
    if (c <= 0.0031308) return 12.92 * max(c, 0.0);
    return 1.055 * pow(min(c, 1.0), 1.0 / 2.4) - 0.055;
}

void main()
{
    vec3 c = texelFetch(u_hdr, ivec2(gl_FragCoord.xy), 0).rgb * u_exposure;
    o_color = vec4(srgb(aces(c.r)), srgb(aces(c.g)), srgb(aces(c.b)), 1.0);
}
