#version 450 core
// cosc422_terrain.tese — the COSC422 terrain exercise's evaluation shader after step (3):
// a bilinear mapping of the patch, texture coordinates from the terrain's x and z bounds,
// height = height-map value * 10 in y. GLSL 4.50 core. C++ twin: tessref::cosc422_evaluate
// (src/evaluation/evaluation.cpp). The bilinear mapping is written as the thesis's mix() so
// that all quad scenes share one corner order (corner 0 at (0,0), 1 at (0,1), 2 at (1,1),
// 3 at (1,0)).
// With TERRAIN_NORMALS (defined by tessref gl for [geometry] normals = "height_field") it
// also hands on lab 4's appendix-A normal, one texel apart at mip 0, in lab4_terrain.tese's
// EvaluationData block (worldPosition, normal, texCoord), which pom.frag reads for a
// terrain. C++ twin: tessref::pipeline::height_field_normal (src/pipeline/terrain.cpp).

layout(quads, equal_spacing, ccw) in;

layout(location = 0) out EvaluationData {
    vec3 worldPosition;
#ifdef TERRAIN_NORMALS
    vec3 normal;
#endif
    vec2 texCoord;
} evaluationOut;

layout(binding = 0) uniform sampler2D heightMap;
uniform mat4 mvpMatrix;
uniform float xMin = -45.0;
uniform float xMax = 45.0;
uniform float zMin = 0.0;
uniform float zMax = -100.0;
uniform float heightScale = 10.0;

#ifdef TERRAIN_NORMALS
uniform float gridStep;  // h of appendix A: one texel, |xMax - xMin| / width

float cosc422_height(float x, float z)
{
    return textureLod(heightMap, vec2((x - xMin) / (xMax - xMin), (z - zMin) / (zMax - zMin)), 0.0).r * heightScale;
}

// lab4_terrain.tese's lab4_vertex_normal through this shader's world -> texture mapping.
vec3 height_field_normal(float x, float z)
{
    float h = gridStep;
    vec3 H = vec3(x, cosc422_height(x, z), z);
    vec3 Hx = vec3(x + h, cosc422_height(x + h, z), z);
    vec3 Hz = vec3(x, cosc422_height(x, z + h), z + h);
    return normalize(cross(Hz - H, Hx - H));
}
#endif

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
#ifdef TERRAIN_NORMALS
    evaluationOut.normal = height_field_normal(posn.x, posn.z);
#endif
    gl_Position = mvpMatrix * posn;
}
