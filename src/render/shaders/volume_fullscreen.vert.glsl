#version 450 core
// volume_fullscreen.vert — one triangle covering the viewport (3 vertices, no attributes); the
// light-buffer passes and the final eye-buffer composite of the volume pass draw it.
void main()
{
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    gl_Position = vec4(p, 0.0, 1.0);
}
