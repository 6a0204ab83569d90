#version 450 core
// A user's control shader for the cosc422 scene, written as a shader that shares work
// between its invocations: each invocation puts its own corner's z into a per-patch array,
// barrier(), then invocation 0 sets each edge's outer level from the larger z of the edge's
// two corners (loops over a constant index array) and the inner levels from the largest
// of the four. The COSC422 formula, (z + 100) * 18 / 100 + 2, on
// the maximum where the twin (cosc422_terrain.tesc) takes the average: other levels than
// the model's on every patch that is not level, so the CPU must run this shader to
// predict llvmpipe's counts (test_user_shaders.cpp).

layout(vertices = 4) out;

uniform mat4 mvMatrix;
// 0: world-space z, 1: eye-space z.
uniform int levelSpace = 0;

layout(location = 0) patch out float cornerZ[4];

// gl_TessLevelOuter[e]'s corners (control.h PATCH LAYOUT: edges (0,1) (0,3) (3,2) (1,2)).
const int edgeCorners[8] = int[8](0, 1, 0, 3, 3, 2, 1, 2);

float cosc422_level(float z)
{
    return (z + 100) * 18 / 100 + 2;
}

void main()
{
    gl_out[gl_InvocationID].gl_Position = gl_in[gl_InvocationID].gl_Position;
    vec4 corner = gl_in[gl_InvocationID].gl_Position;
    cornerZ[gl_InvocationID] = (levelSpace == 1) ? (mvMatrix * corner).z : corner.z;

    barrier();

    if (gl_InvocationID == 0)
    {
        for (int e = 0; e < 4; ++e)
        {
            float edgeZ = -1.0e30;
            for (int k = 0; k < 2; ++k)
                edgeZ = max(edgeZ, cornerZ[edgeCorners[2 * e + k]]);
            gl_TessLevelOuter[e] = cosc422_level(edgeZ);
        }
        float patchZ = -1.0e30;
        for (int k = 0; k < 4; ++k)
            patchZ = max(patchZ, cornerZ[k]);
        gl_TessLevelInner[0] = cosc422_level(patchZ);
        gl_TessLevelInner[1] = cosc422_level(patchZ);
    }
}
