#version 450 core
// volume_composite.frag — composites the volume eye buffer over the opaque scene (SPEC 3.4
// step 5): dual-source blending ONE, SRC1_COLOR gives hdr = C + T_acc * hdr per channel, i.e.
// premultiplied "over" with per-channel extinction.
layout(binding = 3) uniform sampler2D u_eye_c;
layout(binding = 4) uniform sampler2D u_eye_t;
layout(location = 0, index = 0) out vec4 o_color;
layout(location = 0, index = 1) out vec4 o_trans;

void main()
{
    ivec2 px = ivec2(gl_FragCoord.xy);
    o_color = vec4(texelFetch(u_eye_c, px, 0).rgb, 0.0);
    o_trans = vec4(texelFetch(u_eye_t, px, 0).rgb, 1.0);
}
