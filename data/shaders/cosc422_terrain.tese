#version 450 core
// cosc422_terrain.tese — the COSC422 terrain exercise's evaluation shader after step (3):
// a bilinear mapping of the patch, texture coordinates from the terrain's x and z bounds,
// height = height-map value * 10 in y. GLSL 4.50 core. C++ twin: tessref::cosc422_evaluate
// (src/evaluation/evaluation.cpp). The bilinear mapping is written as the thesis's mix() so
// that all quad scenes share one corner order (corner 0 at (0,0), 1 at (0,1), 2 at (1,1),
// 3 at (1,0)).

layout(quads, equal_spacing, ccw) in;

layout(location = 0) out EvaluationData {
    vec3 worldPosition;
    vec2 texCoord;
} evaluationOut;

layout(binding = 0) uniform sampler2D heightMap;
uniform mat4 mvpMatrix;
uniform float xMin = -45.0;
uniform float xMax = 45.0;
uniform float zMin = 0.0;
uniform float zMax = -100.0;
uniform float heightScale = 10.0;

void main()
{
    float u = gl_TessCoord.x;
    float v = gl_TessCoord.y;

    vec4 posn = mix(mix(gl_in[0].gl_Position, gl_in[3].gl_Position, u),
                    mix(gl_in[1].gl_Position, gl_in[2].gl_Position, u), v);

    float s = (posn.x - xMin) / (xMax - xMin);
    float t = (posn.z - zMin) / (zMax - zMin);

    float height = texture(heightMap, vec2(s, t)).r * heightScale;
    posn.y = height;

    evaluationOut.worldPosition = posn.xyz;
    evaluationOut.texCoord = vec2(s, t);
    gl_Position = mvpMatrix * posn;
}
