#version 450 core
// pn_triangles.tese — the PN triangles tutorial's evaluation shader (steps 25-28), brought
// to GLSL 4.50 core. C++ twin: tessref::pn_evaluate (src/evaluation/evaluation.cpp).
// Changes from the tutorial (the C++ twin makes the same):
//  - watertight edges: on an edge (exactly one weight 0) the four remaining terms are summed
//    in the canonical order of the edge's end points, so both patches of the edge add them
//    in the same order; the tutorial's order depends on which way round the patch holds
//    the edge and can differ in the last bit;
//  - the normal is the tutorial's linear interpolation (normalMode 0) or Vlachos'
//    quadratic normal, normalized (normalMode 1).

layout(triangles, fractional_odd_spacing, ccw) in;

layout(location = 0) in PatchVertex {
    vec3 v3VertexPos;
    vec3 v3VertexNormal;
    vec2 v2VertexUV;
    vec3 v3PatchE1;
    vec3 v3PatchE2;
    vec3 v3EdgeNormal;
} controlIn[];

layout(location = 6) patch in vec3 v3P111;

layout(location = 0) out EvaluationData {
    vec3 v3PositionOut;
    vec3 v3NormalOut;
    vec2 v2UVOut;
} evaluationOut;

uniform mat4 m4ViewProjection;
uniform float fInfluence = 0.75f;
uniform int normalMode = 1;
uniform bool watertightEdges = true;

bool less_lexicographic(vec3 p, vec3 q)
{
    return p.x < q.x || (p.x == q.x && (p.y < q.y || (p.y == q.y && p.z < q.z)));
}

// The control point next to corner i on the edge from i to j.
vec3 pn_edge_point(int i, int j)
{
    return (j == (i < 2 ? i + 1 : 0)) ? controlIn[i].v3PatchE1 : controlIn[j].v3PatchE2;
}

// The quadratic-normal coefficient of the edge i-j.
vec3 pn_edge_normal(int i, int j)
{
    return (j == (i < 2 ? i + 1 : 0)) ? controlIn[i].v3EdgeNormal : controlIn[j].v3EdgeNormal;
}

void main()
{
    vec3 v3P030 = controlIn[0].v3VertexPos;
    vec3 v3P021 = controlIn[0].v3PatchE1;
    vec3 v3P012 = controlIn[0].v3PatchE2;
    vec3 v3P003 = controlIn[1].v3VertexPos;
    vec3 v3P102 = controlIn[1].v3PatchE1;
    vec3 v3P201 = controlIn[1].v3PatchE2;
    vec3 v3P300 = controlIn[2].v3VertexPos;
    vec3 v3P210 = controlIn[2].v3PatchE1;
    vec3 v3P120 = controlIn[2].v3PatchE2;

    float fU = gl_TessCoord.x;
    float fV = gl_TessCoord.y;
    float fW = gl_TessCoord.z;
    float fUU = fU * fU;
    float fVV = fV * fV;
    float fWW = fW * fW;
    float fUU3 = fUU * 3.0f;
    float fVV3 = fVV * 3.0f;
    float fWW3 = fWW * 3.0f;

    vec3 N0 = normalize(controlIn[0].v3VertexNormal);
    vec3 N1 = normalize(controlIn[1].v3VertexNormal);
    vec3 N2 = normalize(controlIn[2].v3VertexNormal);

    int zeroCount = int(fU == 0.0) + int(fV == 0.0) + int(fW == 0.0);
    vec3 v3PNPoint;
    vec3 v3BasePosition;
    vec3 v3Linear;
    vec3 v3Quadratic;
    vec2 v2UV;
    if (watertightEdges && zeroCount == 1)
    {
        // The two corners of the edge, in canonical order, and their weights.
        int i = (fU == 0.0) ? 1 : 0;
        int j = (fW == 0.0) ? 1 : 2;
        float weights[3] = float[3](fU, fV, fW);
        vec3 normals[3] = vec3[3](N0, N1, N2);
        if (less_lexicographic(controlIn[j].v3VertexPos, controlIn[i].v3VertexPos))
        {
            int k = i;
            i = j;
            j = k;
        }
        float ci = weights[i];
        float cj = weights[j];
        vec3 Pi = controlIn[i].v3VertexPos;
        vec3 Pj = controlIn[j].v3VertexPos;
        v3PNPoint = Pi * (ci * ci) * ci + Pj * (cj * cj) * cj
                  + pn_edge_point(i, j) * ((ci * ci) * 3.0f) * cj
                  + pn_edge_point(j, i) * ((cj * cj) * 3.0f) * ci;
        v3BasePosition = (Pi * ci) + (Pj * cj);
        v3Linear = (controlIn[i].v3VertexNormal * ci) + (controlIn[j].v3VertexNormal * cj);
        v3Quadratic = normals[i] * (ci * ci) + normals[j] * (cj * cj) + pn_edge_normal(i, j) * (ci * cj);
        v2UV = (controlIn[i].v2VertexUV * ci) + (controlIn[j].v2VertexUV * cj);
    }
    else
    {
        v3PNPoint = v3P030 * fUU * fU +
            v3P003 * fVV * fV +
            v3P300 * fWW * fW +
            v3P021 * fUU3 * fV +
            v3P012 * fVV3 * fU +
            v3P102 * fVV3 * fW +
            v3P201 * fWW3 * fV +
            v3P210 * fWW3 * fU +
            v3P120 * fUU3 * fW +
            v3P111 * 6.0f * fW * fU * fV;
        v3BasePosition = (v3P030 * gl_TessCoord.x) +
            (v3P003 * gl_TessCoord.y) +
            (v3P300 * gl_TessCoord.z);
        v3Linear = (controlIn[0].v3VertexNormal * gl_TessCoord.x) +
            (controlIn[1].v3VertexNormal * gl_TessCoord.y) +
            (controlIn[2].v3VertexNormal * gl_TessCoord.z);
        v3Quadratic = N0 * fUU + N1 * fVV + N2 * fWW
                    + controlIn[0].v3EdgeNormal * (fU * fV)
                    + controlIn[1].v3EdgeNormal * (fV * fW)
                    + controlIn[2].v3EdgeNormal * (fW * fU);
        v2UV = (controlIn[0].v2VertexUV * gl_TessCoord.x) +
            (controlIn[1].v2VertexUV * gl_TessCoord.y) +
            (controlIn[2].v2VertexUV * gl_TessCoord.z);
    }

    evaluationOut.v3PositionOut = mix(v3BasePosition, v3PNPoint, fInfluence);
    evaluationOut.v3NormalOut = (normalMode == 0) ? v3Linear : normalize(v3Quadratic);
    evaluationOut.v2UVOut = v2UV;

    gl_Position = m4ViewProjection * vec4(evaluationOut.v3PositionOut, 1.0f);
}
