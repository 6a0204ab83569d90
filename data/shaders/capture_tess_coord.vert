#version 450 core
// Capture of the fixed-function primitive generator, stage 1 of 3: one vertex per patch
// (GL_PATCH_VERTICES = 1) carrying that patch's six tessellation levels as raw float bits.
// Integer attributes travel bit for bit, so any float the caller chose (NaN with its
// payload, +-inf, denormals, -0, negatives) reaches the control shader untouched.
// Used by src/gl/tess_capture.cpp; the CPU twin is tessref::tessellate (tessellator.h).

layout(location = 0) in uvec4 outer_level_bits;  // gl_TessLevelOuter[0..3]
layout(location = 1) in uvec2 inner_level_bits;  // gl_TessLevelInner[0..1]

out uvec4 vs_outer_level_bits;
out uvec2 vs_inner_level_bits;

void main() {
    vs_outer_level_bits = outer_level_bits;
    vs_inner_level_bits = inner_level_bits;
}
