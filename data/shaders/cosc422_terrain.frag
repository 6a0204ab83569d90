#version 450 core
// cosc422_terrain.frag — diffuse lighting of the COSC422 terrain with the per-face normal
// from the geometry shader, modulated by the height map as a grey texture. GLSL 4.50 core.

layout(location = 0) in GeometryData {
    vec3 faceNormal;
    vec2 texCoord;
} geometryIn;

layout(location = 0) out vec4 outputColor;

layout(binding = 0) uniform sampler2D heightMap;
uniform vec3 lightDirection = vec3(0.0, 1.0, 0.0);
uniform float ambient = 0.2;

void main()
{
    float diffuseTerm = max(dot(normalize(geometryIn.faceNormal), normalize(lightDirection)), 0.0);
    vec3 albedo = vec3(texture(heightMap, geometryIn.texCoord).r * 0.5 + 0.5);
    outputColor = vec4(albedo * (ambient + (1.0 - ambient) * diffuseTerm), 1.0);
}
