#version 450 core
// clouds_impostor.frag — draws an impostor texture (premultiplied radiance + alpha) scaled by
// its cross-fade weight w, dropped behind the opaque scene and faded against it over u_soft m.
in vec2 v_uv;
flat in float v_depth;

layout(binding = 0) uniform sampler2D u_image;
layout(binding = 2) uniform sampler2D u_depth;
uniform vec2 u_proj_z;
uniform float u_weight;
uniform float u_soft;

layout(location = 0) out vec4 o_color;

void main()
{
    vec4 c = texture(u_image, v_uv);
    float d = texelFetch(u_depth, ivec2(gl_FragCoord.xy), 0).r;
    float z_scene = d >= 1.0 ? 3.0e38 : u_proj_z.y / ((d * 2.0 - 1.0) + u_proj_z.x);
    float soft = clamp((z_scene - v_depth) / u_soft, 0.0, 1.0);
    float w = u_weight * soft;
    if (c.a * w <= 0.0) discard;
    o_color = c * w;
}
