#version 450 core
// thesis_terrain.geom — the geometry shader of Jakobsen (2012), appendix A.4, brought to
// GLSL 4.50 core (blocks, explicit locations and binding). C++ twin: tessref::thesis_geometry
// and tessref::thesis_normal_from_texture (src/geometry/geometry.cpp).
// Quirk kept: normalMatrix is applied after normalize, so the normal handed to the
// fragment shader is not unit length when normalMatrix scales.

layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;

layout(location = 0) in EvaluationData {
    vec2 textureCoordinate;
} evaluationIn[3];

layout(location = 0) out GeometryData {
    vec3 gNormal;
    vec2 gTextureCoordinate;
} geometryOut;

uniform mat3 normalMatrix;
layout(binding = 2) uniform sampler2D normalMap;

// NormalFromTexture: the colour minus 0.5 (the map's zero is 0.5), normalized, then
// transformed by normalMatrix.
vec3 thesis_normal_from_texture(vec3 normal)
{
    normal.x = normal.x - 0.5;
    normal.y = normal.y - 0.5;
    normal.z = normal.z - 0.5;
    normal = normalMatrix * normalize(normal);
    return normal;
}

void main()
{
    geometryOut.gNormal = thesis_normal_from_texture(texture(normalMap, evaluationIn[0].textureCoordinate).rgb);
    gl_Position = gl_in[0].gl_Position;
    geometryOut.gTextureCoordinate = evaluationIn[0].textureCoordinate;
    EmitVertex();

    geometryOut.gNormal = thesis_normal_from_texture(texture(normalMap, evaluationIn[1].textureCoordinate).rgb);
    gl_Position = gl_in[1].gl_Position;
    geometryOut.gTextureCoordinate = evaluationIn[1].textureCoordinate;
    EmitVertex();

    geometryOut.gNormal = thesis_normal_from_texture(texture(normalMap, evaluationIn[2].textureCoordinate).rgb);
    gl_Position = gl_in[2].gl_Position;
    geometryOut.gTextureCoordinate = evaluationIn[2].textureCoordinate;
    EmitVertex();

    EndPrimitive();
}
