#version 450 core
// pn_triangles.tesc — the PN triangles tutorial's control shader (steps 20-24 and extra 36),
// brought to GLSL 4.50 core (blocks, explicit locations). C++ twins: tessref::pn_patch,
// tessref::project_to_plane, tessref::pn_tess_level and tessref::pn_levels
// (src/control/pn.cpp).
// Changes from the tutorial (the C++ twin makes the same):
//  - extra 36 (a flat patch gets level 1) is applied per edge: an edge whose two vertex
//    normals are equal gets level 1, so the neighbour across it agrees; a patch with all
//    three normals equal therefore gets 1 everywhere, as the tutorial asks;
//  - the Vlachos quadratic-normal coefficient of each edge is computed as well
//    (v3EdgeNormal), for the evaluation shader's quadratic normal.
// Quirks kept: tess_level() measures clip-space gl_Position.xyz without the divide by w,
// and only the y resolution matters, as in the tutorial.

layout(vertices = 3) out;

layout(location = 0) in VertexData {
    vec3 v3Position;
    vec3 v3Normal;
    vec2 v2UV;
} vertexIn[];

layout(location = 0) out PatchVertex {
    vec3 v3VertexPos;
    vec3 v3VertexNormal;
    vec2 v2VertexUV;
    vec3 v3PatchE1;
    vec3 v3PatchE2;
    vec3 v3EdgeNormal;
} controlOut[];

layout(location = 6) patch out vec3 v3P111;

uniform vec2 v2Resolution;
uniform bool flatEdgesAtLevel1 = true;

vec3 project_to_plane(vec3 v3Point, vec3 v3PlanePoint, vec3 v3PlaneNormal)
{
    float fD = dot(v3Point - v3PlanePoint, v3PlaneNormal);
    vec3 v3D = fD * v3PlaneNormal;
    return v3Point - v3D;
}

float pn_tess_level(vec3 v3Point1, vec3 v3Point2)
{
    const float fPixelsPerEdge = 4.0f;
    vec2 v2P1 = (v3Point1.xy + v3Point2.xy) * 0.5f;
    vec2 v2P2 = v2P1;
    v2P2.y += distance(v3Point1, v3Point2);
    float fLength = length((v2P1 - v2P2) * v2Resolution * 0.5f);
    return clamp(fLength / fPixelsPerEdge, 1.0f, 32.0f);
}

float pn_edge_level(int i, int j)
{
    if (flatEdgesAtLevel1 && vertexIn[i].v3Normal == vertexIn[j].v3Normal)
        return 1.0f;
    return pn_tess_level(gl_in[i].gl_Position.xyz, gl_in[j].gl_Position.xyz);
}

void main()
{
    controlOut[gl_InvocationID].v3VertexPos = vertexIn[gl_InvocationID].v3Position;
    controlOut[gl_InvocationID].v3VertexNormal = vertexIn[gl_InvocationID].v3Normal;
    controlOut[gl_InvocationID].v2VertexUV = vertexIn[gl_InvocationID].v2UV;

    // The Bezier control points of this invocation's edge (to the next vertex).
    int iNextInvocID = gl_InvocationID < 2 ? gl_InvocationID + 1 : 0;
    vec3 v3CurrPos = vertexIn[gl_InvocationID].v3Position;
    vec3 v3NextPos = vertexIn[iNextInvocID].v3Position;
    vec3 v3CurrNormal = normalize(vertexIn[gl_InvocationID].v3Normal);
    vec3 v3NextNormal = normalize(vertexIn[iNextInvocID].v3Normal);

    vec3 v3ProjPoint1 = project_to_plane(v3NextPos, v3CurrPos, v3CurrNormal);
    vec3 v3ProjPoint2 = project_to_plane(v3CurrPos, v3NextPos, v3NextNormal);

    controlOut[gl_InvocationID].v3PatchE1 = ((2.0f * v3CurrPos) + v3ProjPoint1) / 3.0f;
    controlOut[gl_InvocationID].v3PatchE2 = ((2.0f * v3NextPos) + v3ProjPoint2) / 3.0f;

    // Vlachos' quadratic normal coefficient of the edge; symmetric in its end points.
    vec3 v3Edge = v3NextPos - v3CurrPos;
    vec3 v3NormalSum = v3CurrNormal + v3NextNormal;
    float fV = 2.0f * dot(v3Edge, v3NormalSum) / dot(v3Edge, v3Edge);
    controlOut[gl_InvocationID].v3EdgeNormal = normalize(v3NormalSum - fV * v3Edge);

    barrier();
    if (gl_InvocationID == 0) {
        vec3 v3P030 = controlOut[0].v3VertexPos;
        vec3 v3P021 = controlOut[0].v3PatchE1;
        vec3 v3P012 = controlOut[0].v3PatchE2;
        vec3 v3P003 = controlOut[1].v3VertexPos;
        vec3 v3P102 = controlOut[1].v3PatchE1;
        vec3 v3P201 = controlOut[1].v3PatchE2;
        vec3 v3P300 = controlOut[2].v3VertexPos;
        vec3 v3P210 = controlOut[2].v3PatchE1;
        vec3 v3P120 = controlOut[2].v3PatchE2;

        vec3 v3E = (v3P021 + v3P012 + v3P102 + v3P201 + v3P210 + v3P120) / 6.0f;
        vec3 v3V = (v3P300 + v3P003 + v3P030) / 3.0f;
        v3P111 = v3E + ((v3E - v3V) / 2.0f);

        gl_TessLevelOuter[0] = pn_edge_level(1, 2);
        gl_TessLevelOuter[1] = pn_edge_level(2, 0);
        gl_TessLevelOuter[2] = pn_edge_level(0, 1);
        gl_TessLevelInner[0] = max(gl_TessLevelOuter[0], max(gl_TessLevelOuter[1],
                                   gl_TessLevelOuter[2]));
    }
}
