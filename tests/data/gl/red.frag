#version 450 core
// A user's fragment shader: constant red wherever the terrain covers a pixel
// (test_gl_backend.cpp, GlUserShaders).
layout(location = 0) out vec4 fragment;

void main()
{
    fragment = vec4(1.0, 0.0, 0.0, 1.0);
}
