#version 450 core
// depth.frag — depth only (the depth buffer is written by the fixed function).
void main() {}
