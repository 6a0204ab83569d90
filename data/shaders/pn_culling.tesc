#version 450 core
// pn_culling.tesc — the PN triangles tutorial's control shader (pn_triangles.tesc) with the
// patch culling of the tutorial's step 35: a patch wholly outside the view frustum, or whose
// front face (counter-clockwise) points away from the camera, gets outer level 0, and the
// primitive generator discards it. No C++ model: the CPU runs this file through the SPIR-V
// interpreter (scene pn-culling), and must discard exactly the patches llvmpipe discards.
// Both tests read the corners as the vertex shader hands them on: gl_in[i].gl_Position is
// already the view-projection of the world position (clip space), so the frustum is
// -w <= x, y, z <= w, and the winding seen on the screen is the sign of the corners'
// determinant (below). A PN patch bulges past its corners; the tutorial culls on the
// corners all the same, and so does this shader.

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

// Every corner beyond the same one of the six clip planes: no point of the flat triangle
// can be inside the frustum.
bool outside_frustum()
{
    vec4 a = gl_in[0].gl_Position;
    vec4 b = gl_in[1].gl_Position;
    vec4 c = gl_in[2].gl_Position;
    return (a.x < -a.w && b.x < -b.w && c.x < -c.w) || (a.x > a.w && b.x > b.w && c.x > c.w) ||
           (a.y < -a.w && b.y < -b.w && c.y < -c.w) || (a.y > a.w && b.y > b.w && c.y > c.w) ||
           (a.z < -a.w && b.z < -b.w && c.z < -c.w) || (a.z > a.w && b.z > b.w && c.z > c.w);
}

// The corners wound clockwise (or in a line) on the screen: the patch shows its back.
// With every corner in front of the eye (w > 0) the sign of the determinant of the rows
// (x, y, w) is the sign of the screen-space triangle's area times w0 w1 w2 > 0, so no
// divide by w is needed; a corner behind the eye leaves the patch to the frustum test.
// Written out term by term, each product and difference rounded on its own, so that the
// CPU and the GPU compute the same float.
bool faces_away()
{
    vec4 a = gl_in[0].gl_Position;
    vec4 b = gl_in[1].gl_Position;
    vec4 c = gl_in[2].gl_Position;
    if (!(a.w > 0.0f && b.w > 0.0f && c.w > 0.0f))
        return false;
    float fMinor0 = b.y * c.w - b.w * c.y;
    float fMinor1 = b.x * c.w - b.w * c.x;
    float fMinor2 = b.x * c.y - b.y * c.x;
    float fDeterminant = a.x * fMinor0 - a.y * fMinor1 + a.w * fMinor2;
    return fDeterminant <= 0.0f;
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

        // Step 35: a culled patch's outer levels 0 make the generator discard it.
        if (outside_frustum() || faces_away()) {
            gl_TessLevelOuter[0] = 0.0f;
            gl_TessLevelOuter[1] = 0.0f;
            gl_TessLevelOuter[2] = 0.0f;
            gl_TessLevelInner[0] = 0.0f;
        }
    }
}
