#version 450 core
// pn_triangles.vert — the PN triangles tutorial's vertex shader, reduced to what the
// tessellation stages read: world-space position, normal and UV, and the view-projection
// position in gl_Position (the control shader measures edges there). GLSL 4.50 core.

layout(location = 0) in vec3 v3VertexPos;
layout(location = 1) in vec3 v3VertexNormal;
layout(location = 2) in vec2 v2VertexUV;

layout(location = 0) out VertexData {
    vec3 v3Position;
    vec3 v3Normal;
    vec2 v2UV;
} vertexOut;

uniform mat4 m4Transform;
uniform mat4 m4ViewProjection;

void main()
{
    vec4 v4Position = m4Transform * vec4(v3VertexPos, 1.0);
    vertexOut.v3Position = v4Position.xyz;
    vertexOut.v3Normal = (m4Transform * vec4(v3VertexNormal, 0.0)).xyz;
    vertexOut.v2UV = v2VertexUV;
    gl_Position = m4ViewProjection * v4Position;
}
