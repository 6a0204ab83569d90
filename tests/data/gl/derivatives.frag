#version 450 core
// dFdx, dFdy and fwidth of the interpolated texture coordinate, scaled so that their low
// bits show: the quad's differences of llvmpipe's interpolation (tests/test_user_fragment.cpp).
layout(location = 0) in GeometryData {
    vec3 faceNormal;
    vec2 texCoord;
} geometryIn;

layout(location = 0) out vec4 outputColor;

void main()
{
    vec2 dx = dFdx(geometryIn.texCoord);
    vec2 dy = dFdy(geometryIn.texCoord);
    float w = fwidth(geometryIn.texCoord.x + geometryIn.texCoord.y);
    outputColor = vec4(fract(abs(dx.x) * 16384.0), fract(abs(dy.y) * 16384.0), fract(w * 4096.0), 1.0);
}
