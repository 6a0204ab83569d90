#version 450 core
// lab4_terrain.frag — lab 4's shading, reduced to its two rules: height-based and
// slope-based (the normal's y) material weights, lit by one directional Phong light.
// GLSL 4.50 core.

layout(location = 0) in EvaluationData {
    vec3 worldPosition;
    vec3 normal;
    vec2 texCoord;
} evaluationIn;

layout(location = 0) out vec4 fragment;

uniform vec3 cameraPosition;
uniform vec3 lightDirection = vec3(0.3, 1.0, 0.2);
uniform vec3 sandColour = vec3(0.76, 0.70, 0.50);
uniform vec3 rockColour = vec3(0.45, 0.40, 0.36);
uniform float sandHeight = 50.0;
uniform float blendWidth = 10.0;

void main()
{
    vec3 n = normalize(evaluationIn.normal);
    float heightWeight = smoothstep(sandHeight - blendWidth, sandHeight + blendWidth,
                                    evaluationIn.worldPosition.y);
    float slopeWeight = 1.0 - smoothstep(0.6, 0.8, n.y);  // steep = rock
    float rock = max(heightWeight, slopeWeight);
    vec3 albedo = mix(sandColour, rockColour, rock);

    vec3 l = normalize(lightDirection);
    vec3 viewDirection = normalize(cameraPosition - evaluationIn.worldPosition);
    vec3 halfVector = normalize(l + viewDirection);
    float diffuseTerm = max(dot(n, l), 0.0);
    float specularTerm = pow(max(dot(n, halfVector), 0.0), mix(8.0, 32.0, rock)) * mix(0.05, 0.3, rock);
    fragment = vec4(albedo * (0.15 + 0.85 * diffuseTerm) + vec3(specularTerm), 1.0);
}
