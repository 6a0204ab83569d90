#version 450 core
// cosc422_terrain.tesc — the COSC422 terrain exercise's control shader with steps (4) and
// (5): level = (z_avg + 100) * 18 / 100 + 2, z in world space or in eye space. GLSL 4.50
// core. C++ twin: tessref::cosc422_levels (src/control/cosc422.cpp).
// Change from the exercise: each outer level uses the z average of its own edge's two end
// points (so the two patches of an edge agree); the inner levels use the 4-corner average
// the exercise describes. Not clamped: an eye-space z below -111.1 gives a level <= 0 and
// culls the patch, as the exercise's formula would.

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

        gl_TessLevelOuter[0] = cosc422_level((z0 + z1) / 2);
        gl_TessLevelOuter[1] = cosc422_level((z0 + z3) / 2);
        gl_TessLevelOuter[2] = cosc422_level((z3 + z2) / 2);
        gl_TessLevelOuter[3] = cosc422_level((z1 + z2) / 2);

        float zAvg = (z0 + z1 + z2 + z3) / 4;
        gl_TessLevelInner[0] = cosc422_level(zAvg);
        gl_TessLevelInner[1] = cosc422_level(zAvg);
    }
}
