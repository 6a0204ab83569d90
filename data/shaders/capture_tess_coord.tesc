#version 450 core
// Capture of the fixed-function primitive generator, stage 2 of 3: writes the patch's six
// levels exactly as given. uintBitsToFloat reinterprets the bits without arithmetic, so
// NaN, +-inf, denormals and negatives reach gl_TessLevelOuter/Inner as they are and the
// primitive generator alone decides what to cull and how to clamp.

layout(vertices = 1) out;

in uvec4 vs_outer_level_bits[];
in uvec2 vs_inner_level_bits[];

void main() {
    gl_TessLevelOuter[0] = uintBitsToFloat(vs_outer_level_bits[0].x);
    gl_TessLevelOuter[1] = uintBitsToFloat(vs_outer_level_bits[0].y);
    gl_TessLevelOuter[2] = uintBitsToFloat(vs_outer_level_bits[0].z);
    gl_TessLevelOuter[3] = uintBitsToFloat(vs_outer_level_bits[0].w);
    gl_TessLevelInner[0] = uintBitsToFloat(vs_inner_level_bits[0].x);
    gl_TessLevelInner[1] = uintBitsToFloat(vs_inner_level_bits[0].y);
}
