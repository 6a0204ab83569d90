#version 450 core
// Capture of the fixed-function primitive generator, stage 3 of 3: hands every vertex's
// gl_TessCoord and its patch (gl_PrimitiveID within the draw) to transform feedback
// (varyings "tess_coord", "patch_id", interleaved), with GL_RASTERIZER_DISCARD on.
//
// Layout qualifiers are compile-time, so the backend compiles this file once per
// combination, inserting after the #version line:
//   #define TESSREF_DOMAIN   quads | triangles | isolines
//   #define TESSREF_SPACING  equal_spacing | fractional_odd_spacing | fractional_even_spacing
//   #define TESSREF_WINDING  ccw | cw
//   #define TESSREF_POINT_MODE            (only for point mode)
// Without them the file compiles as quads, equal_spacing, ccw.

#ifndef TESSREF_DOMAIN
#define TESSREF_DOMAIN quads
#endif
#ifndef TESSREF_SPACING
#define TESSREF_SPACING equal_spacing
#endif
#ifndef TESSREF_WINDING
#define TESSREF_WINDING ccw
#endif

layout(TESSREF_DOMAIN, TESSREF_SPACING, TESSREF_WINDING) in;
#ifdef TESSREF_POINT_MODE
layout(point_mode) in;
#endif

out vec3 tess_coord;  // exactly gl_TessCoord: transform feedback returns its bits
out int patch_id;     // which patch of the draw emitted this vertex

void main() {
    tess_coord = gl_TessCoord;
    patch_id = gl_PrimitiveID;
    gl_Position = vec4(gl_TessCoord, 1.0);
}
