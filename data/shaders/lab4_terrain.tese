#version 450 core
// lab4_terrain.tese — lab 4's evaluation shader: bilinear position on the ground plane,
// height from the mip level that matches the tessellation level,
//   textureLod(heightMap, texCoord, maxLogTessellationLevel - logTessellationLevel),
// and the normal from the height map (appendix A). GLSL 4.50 core. C++ twins:
// tessref::lab4_evaluate, tessref::lab4_vertex_log_level (src/evaluation/evaluation.cpp)
// and tessref::lab4_vertex_normal (src/geometry/geometry.cpp).
// logTessellationLevel: a vertex on edge i uses logOuter[i], a corner its logCorner, any
// other vertex logInner (see lab4_terrain.tesc for why).
// Appendix A's cross product, (H(x+h,z) - H) x (H(x,z+h) - H), points down in a y-up
// right-handed frame; the operands are swapped to return the upward normal (exactly the
// appendix's vector negated), which lighting and the slope rule need.

layout(quads, equal_spacing, ccw) in;

layout(location = 0) in ControlData {
    vec4 tcPosition;
} controlIn[];

layout(location = 1) patch in float maxLogTessellationLevel;
layout(location = 2) patch in vec4 logOuter;
layout(location = 3) patch in float logInner;
layout(location = 4) patch in vec4 logCorner;

layout(location = 0) out EvaluationData {
    vec3 worldPosition;
    vec3 normal;
    vec2 texCoord;
} evaluationOut;

layout(binding = 0) uniform sampler2D heightMap;
uniform mat4 mvp;
uniform float horizontalScale;
uniform float verticalScale;
uniform vec2 texCoordOffset = vec2(0.0);
uniform float gridStep;  // h of appendix A, in world units

float lab4_vertex_log_level(vec2 tessCoord)
{
    bool u0 = tessCoord.x == 0.0;
    bool u1 = tessCoord.x == 1.0;
    bool v0 = tessCoord.y == 0.0;
    bool v1 = tessCoord.y == 1.0;
    if (u0 && v0) return logCorner[0];
    if (u0 && v1) return logCorner[1];
    if (u1 && v1) return logCorner[2];
    if (u1 && v0) return logCorner[3];
    if (u0) return logOuter[0];
    if (v0) return logOuter[1];
    if (u1) return logOuter[2];
    if (v1) return logOuter[3];
    return logInner;
}

float lab4_height(float x, float z, float lod)
{
    vec2 texCoord = vec2(x, z) / horizontalScale + texCoordOffset;
    return textureLod(heightMap, texCoord, lod).r * verticalScale;
}

vec3 lab4_vertex_normal(float x, float z, float lod)
{
    float h = gridStep;
    vec3 H = vec3(x, lab4_height(x, z, lod), z);
    vec3 Hx = vec3(x + h, lab4_height(x + h, z, lod), z);
    vec3 Hz = vec3(x, lab4_height(x, z + h, lod), z + h);
    return normalize(cross(Hz - H, Hx - H));
}

void main()
{
    float u = gl_TessCoord.x;
    float v = gl_TessCoord.y;

    vec4 position = mix(mix(controlIn[0].tcPosition, controlIn[3].tcPosition, u),
                        mix(controlIn[1].tcPosition, controlIn[2].tcPosition, u), v);

    vec2 texCoord = position.xz / horizontalScale + texCoordOffset;
    float logTessellationLevel = lab4_vertex_log_level(gl_TessCoord.xy);
    float lod = maxLogTessellationLevel - logTessellationLevel;
    float height = textureLod(heightMap, texCoord, lod).r * verticalScale;
    position.y = height;

    evaluationOut.worldPosition = position.xyz;
    evaluationOut.normal = lab4_vertex_normal(position.x, position.z, lod);
    evaluationOut.texCoord = texCoord;
    gl_Position = mvp * position;
}
