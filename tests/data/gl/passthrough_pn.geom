#version 450 core
// A user's geometry shader for PN triangles, whose models have none: it hands on the
// evaluation shader's outputs unchanged (the EvaluationData block the fragment shader
// reads), so the picture must be the twins' own (test_gl_backend.cpp).
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;

layout(location = 0) in EvaluationData {
    vec3 v3PositionOut;
    vec3 v3NormalOut;
    vec2 v2UVOut;
} evaluationIn[];

layout(location = 0) out EvaluationData {
    vec3 v3PositionOut;
    vec3 v3NormalOut;
    vec2 v2UVOut;
} geometryOut;

void main()
{
    for (int i = 0; i < 3; ++i)
    {
        geometryOut.v3PositionOut = evaluationIn[i].v3PositionOut;
        geometryOut.v3NormalOut = evaluationIn[i].v3NormalOut;
        geometryOut.v2UVOut = evaluationIn[i].v2UVOut;
        gl_Position = gl_in[i].gl_Position;
        EmitVertex();
    }
    EndPrimitive();
}
