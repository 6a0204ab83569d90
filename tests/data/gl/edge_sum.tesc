#version 450 core
// A user's control shader: data/shaders/cosc422_terrain.tesc with a bug in outer level 0,
// whose edge average lost its "/ 2" (marked below). Its levels differ from the CPU
// reference's on every patch whose edge (c0, c1) is not at z = 0, so llvmpipe's triangle
// counts differ from the prediction and `tessref gl` must name those patches, with both
// values of the levels and of the triangle counts (test_gl_backend.cpp).

layout(vertices = 4) out;

uniform mat4 mvMatrix;
// 0: world-space z, 1: eye-space z.
uniform int levelSpace = 0;

float cosc422_level(float zAvg)
{
    return (zAvg + 100) * 18 / 100 + 2;
}

float level_z(vec4 position)
{
    return (levelSpace == 1) ? (mvMatrix * position).z : position.z;
}

void main()
{
    gl_out[gl_InvocationID].gl_Position = gl_in[gl_InvocationID].gl_Position;

    if (gl_InvocationID == 0)
    {
        float z0 = level_z(gl_in[0].gl_Position);
        float z1 = level_z(gl_in[1].gl_Position);
        float z2 = level_z(gl_in[2].gl_Position);
        float z3 = level_z(gl_in[3].gl_Position);

        gl_TessLevelOuter[0] = cosc422_level(z0 + z1);  // the bug: (z0 + z1) / 2
        gl_TessLevelOuter[1] = cosc422_level((z0 + z3) / 2);
        gl_TessLevelOuter[2] = cosc422_level((z3 + z2) / 2);
        gl_TessLevelOuter[3] = cosc422_level((z1 + z2) / 2);

        float zAvg = (z0 + z1 + z2 + z3) / 4;
        gl_TessLevelInner[0] = cosc422_level(zAvg);
        gl_TessLevelInner[1] = cosc422_level(zAvg);
    }
}
