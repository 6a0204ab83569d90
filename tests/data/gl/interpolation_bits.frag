#version 450 core
// The interpolated inputs' low bits made visible: fract(texCoord * 65536) moves by about one
// 8-bit step per ulp of a texture coordinate near 0.5, so a picture of it is the same as
// llvmpipe's only where every input is interpolated to the bit (tests/test_user_fragment.cpp).
layout(location = 0) in GeometryData {
    vec3 faceNormal;
    vec2 texCoord;
} geometryIn;

layout(location = 0) out vec4 outputColor;

void main()
{
    outputColor = vec4(fract(geometryIn.texCoord * 65536.0), fract(geometryIn.faceNormal.x * 4096.0), 1.0);
}
