#version 450 core
// pn_triangles.frag — Blinn-Phong shading of the PN surface with one directional light
// (the tutorial's full fragment shader, with its texture and shadow maps, belongs to the
// earlier tutorials). GLSL 4.50 core.

layout(location = 0) in EvaluationData {
    vec3 v3PositionOut;
    vec3 v3NormalOut;
    vec2 v2UVOut;
} evaluationIn;

layout(location = 0) out vec4 v4ColourOut;

uniform vec3 v3CameraPosition;
uniform vec3 v3LightDirection = vec3(0.4, 0.8, 0.45);
uniform vec3 v3DiffuseColour = vec3(0.8, 0.8, 0.85);
uniform float fShininess = 32.0;

void main()
{
    vec3 v3Normal = normalize(evaluationIn.v3NormalOut);
    vec3 v3Light = normalize(v3LightDirection);
    vec3 v3View = normalize(v3CameraPosition - evaluationIn.v3PositionOut);
    vec3 v3Half = normalize(v3Light + v3View);
    float fDiffuse = max(dot(v3Normal, v3Light), 0.0);
    float fSpecular = pow(max(dot(v3Normal, v3Half), 0.0), fShininess);
    v4ColourOut = vec4(v3DiffuseColour * (0.1 + 0.9 * fDiffuse) + vec3(0.3 * fSpecular), 1.0);
}
