#version 450 core
// meshes.frag — world meshes with opaque materials (no texel is cut out): meshes_shade.glsl.
#include "meshes_shade.glsl"
