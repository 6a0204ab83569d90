#version 450 core
// A user's evaluation shader with a syntax error on line 14 (a missing comma):
// test_gl_backend.cpp expects this file's name and line 14 in the error.
layout(quads, fractional_odd_spacing, ccw) in;

layout(location = 0) in ControlData {
    vec4 tcPosition;
} controlIn[];

uniform mat4 mvp;

void main()
{
    vec4 ad = mix(controlIn[0].tcPosition controlIn[3].tcPosition, gl_TessCoord.x);
    gl_Position = mvp * ad;
}
