#version 450 core
// cosc422_terrain.vert — the COSC422 terrain exercise's vertex shader after step (2): a
// pass-through, since a patch is not a renderable primitive. GLSL 4.50 core.

layout(location = 0) in vec4 position;

void main()
{
    gl_Position = position;
}
