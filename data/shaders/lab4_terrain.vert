#version 450 core
// lab4_terrain.vert — lab 4's vertex shader: a pass-through of the camera-centred grid
// (already snapped to the quad size and placed in world space, y = 0). GLSL 4.50 core.

layout(location = 0) in vec4 position;

layout(location = 0) out VertexData {
    vec4 vPosition;
} vertexOut;

void main()
{
    vertexOut.vPosition = position;
}
