#version 450 core
// meshes_cutout.frag — world meshes with a base-colour texture: texels with alpha < 0.5 are cut
// out (meshes_shade.glsl).
#define SQ_CUTOUT 1
#include "meshes_shade.glsl"
