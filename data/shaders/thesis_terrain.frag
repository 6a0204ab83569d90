#version 450 core
// thesis_terrain.frag — the multi-texture fragment shader of Jakobsen (2012), appendix A.5,
// brought to GLSL 4.50 core (input block, explicit output location and bindings).
// Quirks kept: the light position is used unnormalized as the light direction in df; h is
// computed and never used; abs() lights back faces like front faces.

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

// Rotates texture coordinates by 90 degrees.
uniform mat4 rotationMatrix;

layout(binding = 4) uniform sampler2D diffuse;
layout(binding = 5) uniform sampler2D canyon_rock01;
layout(binding = 6) uniform sampler2D canyon_rock02;
layout(binding = 7) uniform sampler2D dry_grass09;
layout(binding = 8) uniform sampler2D dry_grass12;
layout(binding = 9) uniform sampler2D romanian_sand05;
layout(binding = 10) uniform sampler2D VertRock_0_90_mask;
layout(binding = 11) uniform sampler2D VertDetail_0_90_mask;
layout(binding = 12) uniform sampler2D Grass_mask;
layout(binding = 13) uniform sampler2D Flow_mask;
layout(binding = 14) uniform sampler2D AmbientOcc;

void main()
{
    vec3 gNormal = geometryIn.gNormal;
    vec2 gTextureCoordinate = geometryIn.gTextureCoordinate;

    vec3 h = normalize(lightPosition + vec3(0, 0, 1));
    float df = abs(dot(gNormal, lightPosition));
    float sf = abs(dot(gNormal, normalize(lightPosition + vec3(0, 0, 1))));
    sf = pow(sf, shininess);

    vec3 light = texture(AmbientOcc, gTextureCoordinate).rgb + df * diffuseMaterial + sf * specularMaterial;

    vec4 diffuseTexture = texture(diffuse, gTextureCoordinate);

    // Texture coordinate rotated by the rotation matrix (row vector times matrix).
    vec2 textureCoordinate90 = (vec4(gTextureCoordinate, 1, 1) * rotationMatrix).xy;

    vec4 textureRock = mix(texture(canyon_rock01, textureCoordinate90 * 20),
                           texture(canyon_rock01, gTextureCoordinate * 20),
                           texture(VertRock_0_90_mask, gTextureCoordinate).r);
    vec4 textureRock2 = mix(texture(canyon_rock02, textureCoordinate90 * 10),
                            texture(canyon_rock02, gTextureCoordinate * 10),
                            texture(VertRock_0_90_mask, gTextureCoordinate).r);

    vec4 texturegrass1 = mix(texture(dry_grass12, textureCoordinate90 * 50),
                             texture(dry_grass12, gTextureCoordinate * 50),
                             texture(VertDetail_0_90_mask, gTextureCoordinate).r);
    vec4 texturegrass2 = mix(texture(dry_grass09, textureCoordinate90 * 100),
                             texture(dry_grass09, gTextureCoordinate * 100),
                             texture(VertDetail_0_90_mask, gTextureCoordinate).r);
    vec4 texturesand = mix(texture(romanian_sand05, textureCoordinate90 * 50),
                           texture(romanian_sand05, gTextureCoordinate * 50),
                           texture(VertDetail_0_90_mask, gTextureCoordinate).r);

    vec4 fragmentColour = diffuseTexture;

    fragmentColour = mix(fragmentColour, textureRock, 0.8);
    fragmentColour = mix(fragmentColour, textureRock2, 0.5);

    fragmentColour = mix(fragmentColour, texturegrass1, texture(Grass_mask, gTextureCoordinate).r);
    fragmentColour = mix(fragmentColour, texturegrass2, texture(Grass_mask, gTextureCoordinate).r / 2);

    fragmentColour = mix(fragmentColour, texturesand, texture(Flow_mask, gTextureCoordinate).r);

    fragmentColour *= vec4(light, 1);

    fragment = fragmentColour;
}
