#version 450 core
// cosc422_terrain.geom — the COSC422 terrain exercise's geometry shader of step (6): the
// three vertices of each triangle are at hand, so one normal per triangle is computed for
// lighting. GLSL 4.50 core. C++ twin: tessref::face_normal (src/geometry/geometry.cpp).

layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;

layout(location = 0) in EvaluationData {
    vec3 worldPosition;
    vec2 texCoord;
} evaluationIn[3];

layout(location = 0) out GeometryData {
    vec3 faceNormal;
    vec2 texCoord;
} geometryOut;

vec3 face_normal(vec3 p0, vec3 p1, vec3 p2)
{
    return normalize(cross(p1 - p0, p2 - p0));
}

void main()
{
    vec3 normal = face_normal(evaluationIn[0].worldPosition, evaluationIn[1].worldPosition,
                              evaluationIn[2].worldPosition);
    for (int i = 0; i < 3; i++)
    {
        geometryOut.faceNormal = normal;
        geometryOut.texCoord = evaluationIn[i].texCoord;
        gl_Position = gl_in[i].gl_Position;
        EmitVertex();
    }
    EndPrimitive();
}
