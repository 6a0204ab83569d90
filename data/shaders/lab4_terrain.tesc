#version 450 core
// lab4_terrain.tesc — lab 4's control shader: power-of-two tessellation levels from
// distance zones (equal spacing), edge levels made consistent with the neighbours, and the
// binary logarithms the evaluation shader needs to pick the matching mip level. GLSL 4.50
// core. C++ twin: tessref::lab4_control (src/control/lab4.cpp).
//
// Zones: [0, firstZoneEnd) gets maxLevel, each next zone (ending zoneGrowth times farther)
// half the level, down to minLevel. An edge's level is the lower (or higher) of the levels
// of the two patches beside it, whose centres are computed from the edge itself, so both
// patches write the same level. The lab passes one log2 per patch; here every edge and
// every corner gets its own (see lab4_terrain.tese), because one log per patch samples the
// two sides of an edge from different mips and opens a crack.

layout(vertices = 4) out;

layout(location = 0) in VertexData {
    vec4 vPosition;
} vertexIn[];

layout(location = 0) out ControlData {
    vec4 tcPosition;
} controlOut[];

layout(location = 1) patch out float maxLogTessellationLevel;
layout(location = 2) patch out vec4 logOuter;
layout(location = 3) patch out float logInner;
layout(location = 4) patch out vec4 logCorner;

uniform vec3 cameraPosition;
uniform float firstZoneEnd = 50.0;
uniform float zoneGrowth = 2.0;
uniform float maxLevel = 64.0;
uniform float minLevel = 1.0;
// 0: the lower of the two patches' levels, 1: the higher.
uniform int edgeRule = 0;

#define ID gl_InvocationID

float lab4_zone_level(float distanceToCamera)
{
    float level = maxLevel;
    float zoneEnd = firstZoneEnd;
    while (distanceToCamera >= zoneEnd && level > minLevel)
    {
        level = level * 0.5;
        zoneEnd = zoneEnd * zoneGrowth;
    }
    return level;
}

void canonical_edge(vec3 p, vec3 q, out vec3 a, out vec3 b)
{
    bool swapEnds = q.x < p.x || (q.x == p.x && (q.y < p.y || (q.y == p.y && q.z < p.z)));
    a = swapEnds ? q : p;
    b = swapEnds ? p : q;
}

// The level of the edge p-q: the two patches beside it have their centres at m +- r.
float lab4_edge_level(vec3 p, vec3 q)
{
    vec3 a;
    vec3 b;
    canonical_edge(p, q, a, b);
    vec3 m = (a + b) * 0.5;
    vec3 r = vec3(-(b.z - a.z), 0.0, b.x - a.x) * 0.5;
    float level1 = lab4_zone_level(distance(m + r, cameraPosition));
    float level2 = lab4_zone_level(distance(m - r, cameraPosition));
    return (edgeRule == 0) ? min(level1, level2) : max(level1, level2);
}

void main()
{
    controlOut[ID].tcPosition = vertexIn[ID].vPosition;

    if (ID == 0)
    {
        vec3 c0 = vertexIn[0].vPosition.xyz;
        vec3 c1 = vertexIn[1].vPosition.xyz;
        vec3 c2 = vertexIn[2].vPosition.xyz;
        vec3 c3 = vertexIn[3].vPosition.xyz;

        vec3 centre = (c0 + c1 + c2 + c3) * 0.25;
        float patchLevel = lab4_zone_level(distance(centre, cameraPosition));

        gl_TessLevelOuter[0] = lab4_edge_level(c0, c1);
        gl_TessLevelOuter[1] = lab4_edge_level(c0, c3);
        gl_TessLevelOuter[2] = lab4_edge_level(c3, c2);
        gl_TessLevelOuter[3] = lab4_edge_level(c1, c2);
        gl_TessLevelInner[0] = patchLevel;
        gl_TessLevelInner[1] = patchLevel;

        maxLogTessellationLevel = log2(maxLevel);
        logOuter = log2(vec4(gl_TessLevelOuter[0], gl_TessLevelOuter[1],
                             gl_TessLevelOuter[2], gl_TessLevelOuter[3]));
        logInner = log2(patchLevel);
        logCorner = log2(vec4(lab4_zone_level(distance(c0, cameraPosition)),
                              lab4_zone_level(distance(c1, cameraPosition)),
                              lab4_zone_level(distance(c2, cameraPosition)),
                              lab4_zone_level(distance(c3, cameraPosition))));
    }
}
