#version 450 core
// shrink.geom — a user's geometry shader for a COSC422 scene that moves every vertex: each
// triangle shrunk toward its centroid to 60 %, an affine combination of gl_in[].gl_Position
// (GL combines them in clip space, the CPU in world space: the same points but for
// rounding), with the face normal of cosc422_terrain.geom.
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;
layout(location = 0) in EvaluationData { vec3 worldPosition; vec2 texCoord; } evaluationIn[3];
layout(location = 0) out GeometryData { vec3 faceNormal; vec2 texCoord; } geometryOut;
void main()
{
    vec3 p0 = evaluationIn[0].worldPosition;
    vec3 normal = normalize(cross(evaluationIn[1].worldPosition - p0, evaluationIn[2].worldPosition - p0));
    vec4 c = (gl_in[0].gl_Position + gl_in[1].gl_Position + gl_in[2].gl_Position) / 3.0;
    for (int i = 0; i < 3; i++) {
        geometryOut.faceNormal = normal;
        geometryOut.texCoord = evaluationIn[i].texCoord;
        gl_Position = mix(c, gl_in[i].gl_Position, 0.6);
        EmitVertex();
    }
    EndPrimitive();
}
