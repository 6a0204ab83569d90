#version 450 core
// drop_steep.geom — a user's geometry shader for a COSC422 scene with face normals that
// emits fewer triangles than it is given: a triangle whose face normal leans more than
// about 18 degrees from the up axis (y, the scene's plane xz) is dropped, the others pass
// through with that normal. The count it emits depends on every normal's last bits near the
// threshold, so the CPU's count must be llvmpipe's.
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

const float steepness = 0.95;

void main()
{
    vec3 p0 = evaluationIn[0].worldPosition;
    vec3 normal = normalize(cross(evaluationIn[1].worldPosition - p0, evaluationIn[2].worldPosition - p0));
    if (abs(normal.y) < steepness)
        return;
    for (int i = 0; i < 3; i++)
    {
        geometryOut.faceNormal = normal;
        geometryOut.texCoord = evaluationIn[i].texCoord;
        gl_Position = gl_in[i].gl_Position;
        EmitVertex();
    }
    EndPrimitive();
}
