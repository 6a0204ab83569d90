#version 450 core
// A user's fragment shader that declares the thesis twins' float uniform `shininess` as an
// int: the uniform contract is broken, test_gl_backend.cpp expects an error naming it.
layout(location = 0) out vec4 fragment;

uniform int shininess;

void main()
{
    fragment = vec4(1.0, 0.0, float(shininess), 1.0);
}
