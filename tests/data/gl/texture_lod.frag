#version 450 core
// texture() with its implicit level of detail: the height map (unit 0) repeated four
// times across the terrain, minified so that the lod falls between mip levels; the lod is
// the quad's, from its top-left fragment's derivatives (tests/test_user_fragment.cpp).
layout(location = 0) in GeometryData {
    vec3 faceNormal;
    vec2 texCoord;
} geometryIn;

layout(location = 0) out vec4 outputColor;

layout(binding = 0) uniform sampler2D heightMap;

void main()
{
    vec2 st = geometryIn.texCoord * 4.0;
    vec2 grid = floor(st);
    // Mirrored tiles: the coordinate stays continuous, so the derivatives do too.
    vec2 mirrored = mix(st - grid, 1.0 - (st - grid), mod(grid, 2.0));
    float h = texture(heightMap, mirrored).r;
    outputColor = vec4(h, fract(h * 16.0), fract(h * 256.0), 1.0);
}
