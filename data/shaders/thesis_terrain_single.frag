#version 450 core
// thesis_terrain_single.frag — the single-texture fragment shader of Jakobsen (2012),
// appendix A.6 (terrain2.frag), brought to GLSL 4.50 core. The appendix's listing ends
// without writing `fragment` (a line lost from the listing); the assignment is restored.
// Quirks kept: the light position is used unnormalized in df; h is unused; abs() lights
// back faces like front faces.

layout(location = 0) in GeometryData {
    vec3 gNormal;
    vec2 gTextureCoordinate;
} geometryIn;

layout(location = 0) out vec4 fragment;

uniform vec3 lightPosition;
uniform vec3 diffuseMaterial;
uniform vec3 ambientMaterial;
uniform vec3 specularMaterial;
uniform float shininess;

layout(binding = 4) uniform sampler2D diffuse;

void main()
{
    vec3 gNormal = geometryIn.gNormal;

    vec3 h = normalize(lightPosition + vec3(0, 0, 1));
    float df = abs(dot(gNormal, lightPosition));
    float sf = abs(dot(gNormal, normalize(lightPosition + vec3(0, 0, 1))));
    sf = pow(sf, shininess);

    vec3 light = ambientMaterial + df * diffuseMaterial + sf * specularMaterial;

    vec4 diffuseTexture = texture(diffuse, geometryIn.gTextureCoordinate);

    vec4 fragmentColour = diffuseTexture;

    fragmentColour *= vec4(light, 1);

    fragment = fragmentColour;
}
