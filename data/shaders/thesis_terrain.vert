#version 450 core
// thesis_terrain.vert — the vertex shader of Jakobsen (2012), appendix A.1, brought to
// GLSL 4.50 core (explicit location, an output block). C++ twin: tessref::thesis_vertex
// (src/control/thesis.cpp). The patch corners arrive flat (z = 0); the height is looked up
// here so that the control shader sees it, and looked up again in the evaluation shader.

layout(location = 0) in vec4 position;

layout(location = 0) out VertexData {
    vec4 vPosition;
} vertexOut;

layout(binding = 0) uniform sampler2D heightMap;
uniform float scaleXY;
uniform float scaleZ;

void main(void)
{
    // Texture coordinate from the position and the scale in the xy plane.
    vec2 textureCoordinate = position.xy / scaleXY;

    // Height map value times the z scale is the height (texture() outside a fragment
    // shader samples the base level).
    float height = texture(heightMap, textureCoordinate).r * scaleZ;

    vec4 positionWithHeight = vec4(position.x, position.y, height, 1.0);

    vertexOut.vPosition = positionWithHeight;
}
