#version 450 core
// discard where the face normal leans towards -x: the pixel is left to what lies behind the
// fragment (tests/test_user_fragment.cpp).
layout(location = 0) in GeometryData {
    vec3 faceNormal;
    vec2 texCoord;
} geometryIn;

layout(location = 0) out vec4 outputColor;

void main()
{
    if (geometryIn.faceNormal.x < -0.2)
        discard;
    outputColor = vec4(geometryIn.texCoord, 0.5, 1.0);
}
