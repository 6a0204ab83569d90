#version 450 core
// thesis_terrain.tesc — the tessellation control shader of Jakobsen (2012), appendix A.2,
// brought to GLSL 4.50 core. C++ twin: src/control/thesis.cpp (tessref::thesis_levels and
// the functions it calls carry the same names as the functions here).
//
// Changes from the appendix (the C++ twin makes the same ones):
//  - #version 450 core, input/output blocks, explicit locations and bindings;
//  - the factor (distance, map, normal or all) is a uniform instead of commented-out
//    blocks; the weights, DistanceFactor's 50 and 10 and the 0.90 threshold are uniforms
//    whose defaults are the appendix's constants;
//  - one function computes the three factors of one edge from that edge alone, with its end
//    points in canonical order (canonical_edge) and the normal probes offset by the edge's
//    own vector. For a grid laid out with u along +x and v along +y this is the appendix's
//    computation exactly; in general it keeps the two patches of an edge in agreement;
//  - the probe struct's distance member, which never reached a level, is dropped.
//
// Quirks kept: distance_factor is 0..5 (not 0..1); normal_tess_factor is a sum of four
// angles in radians; formula (2) can therefore exceed 64; the decoded normal-map zero is
// never exactly 0; the normal probes lie on the edge's own line.

layout(vertices = 4) out;

layout(location = 0) in VertexData {
    vec4 vPosition;
} vertexIn[];

layout(location = 0) out ControlData {
    vec4 tcPosition;
} controlOut[];

uniform float tessellationLevel;
uniform float scaleXY;
uniform vec3 cameraPosition;

// 0: distance, 1: tessellation map, 2: normal, 3: all factors by formula (2).
uniform int thesisFactor = 3;
uniform float distanceLimit = 50.0;
uniform float distanceDivisor = 10.0;
uniform float normalAngleThreshold = 0.90;
uniform float normalTessellationWeight = 5.0;
uniform float textureTessellationWeight = 5.0;
uniform float distanceTessellationWeight = 5.0;
uniform float constantTessellationWeight = 1.0;

layout(binding = 1) uniform sampler2D tessellationMap;
layout(binding = 2) uniform sampler2D normalMap;

#define ID gl_InvocationID

const int ALONG_V = 0;  // edges ab and dc (u constant): probes offset by left/right
const int ALONG_U = 1;  // edges ad and bc (v constant): probes offset by down/up

// NormalFromTexture: the colour minus 0.5, normalized.
vec3 normal_from_texture(vec3 normal)
{
    normal.x = normal.x - 0.5;
    normal.y = normal.y - 0.5;
    normal.z = normal.z - 0.5;
    normal = normalize(normal);
    return normal;
}

// DistanceFactor: 0 beyond the limit, else (limit - d) / 10 (5 at d = 0).
float distance_factor(float factor)
{
    if (factor > distanceLimit)
    {
        factor = 0.0;
    }
    else
    {
        factor = (distanceLimit - factor) / distanceDivisor;
    }
    return factor;
}

// normalTessFactor: the angles between opposite probes; their sum when any exceeds the
// threshold. Clamped before acos (the thesis's shader is not: a rounded-up 1 gives NaN).
float normal_tess_factor(vec3 vertexNormal[6])
{
    float testangle = acos(clamp(dot(vertexNormal[0], vertexNormal[3]), -1.0, 1.0));
    float testangle90 = acos(clamp(dot(vertexNormal[2], vertexNormal[1]), -1.0, 1.0));
    float testangle2 = acos(clamp(dot(vertexNormal[0], vertexNormal[5]), -1.0, 1.0));
    float testangle902 = acos(clamp(dot(vertexNormal[1], vertexNormal[4]), -1.0, 1.0));

    if (testangle > normalAngleThreshold || testangle90 > normalAngleThreshold ||
        testangle2 > normalAngleThreshold || testangle902 > normalAngleThreshold)
    {
        return (testangle + testangle90 + testangle2 + testangle902);
    }
    return 0.0;
}

// The edge's end points in lexicographic (x, y, z) order.
void canonical_edge(vec3 p, vec3 q, out vec3 a, out vec3 b)
{
    bool swapEnds = q.x < p.x || (q.x == p.x && (q.y < p.y || (q.y == p.y && q.z < p.z)));
    a = swapEnds ? q : p;
    b = swapEnds ? p : q;
}

struct ThesisEdgeFactors
{
    float distanceTessellation;
    float textureTessellation;
    float normalTessellation;
};

ThesisEdgeFactors thesis_edge_factors(vec3 p, vec3 q, int direction)
{
    vec3 a;
    vec3 b;
    canonical_edge(p, q, a, b);
    ThesisEdgeFactors factors = ThesisEdgeFactors(0.0, 0.0, 0.0);

    // Distance: the edge midpoint, equation (1).
    if (thesisFactor == 0 || thesisFactor == 3)
    {
        vec3 midPos = vec3(a + ((b - a) / 2));
        factors.distanceTessellation = distance_factor(distance(midPos, cameraPosition.xyz));
    }

    // Tessellation map at the edge midpoint.
    if (thesisFactor == 1 || thesisFactor == 3)
    {
        vec2 midTexPos = vec2((a.xy + ((b.xy - a.xy) / 2)) / scaleXY);
        factors.textureTessellation = texture(tessellationMap, midTexPos).r;
    }

    // Normals at the six probes of the edge.
    if (thesisFactor == 2 || thesisFactor == 3)
    {
        vec2 minus = (direction == ALONG_V) ? vec2(a.xy - b.xy) : vec2(b.xy - a.xy);  // left / down
        vec2 plus = (direction == ALONG_V) ? vec2(b.xy - a.xy) : vec2(a.xy - b.xy);   // right / up
        vec3 vertexNormal[6];
        vertexNormal[0] = normal_from_texture(texture(normalMap, (a.xy) / scaleXY).xyz);
        vertexNormal[1] = normal_from_texture(texture(normalMap, (b.xy) / scaleXY).xyz);
        vertexNormal[2] = normal_from_texture(texture(normalMap, (a.xy + minus) / scaleXY).xyz);
        vertexNormal[3] = normal_from_texture(texture(normalMap, (b.xy + minus) / scaleXY).xyz);
        vertexNormal[4] = normal_from_texture(texture(normalMap, (a.xy + plus) / scaleXY).xyz);
        vertexNormal[5] = normal_from_texture(texture(normalMap, (b.xy + plus) / scaleXY).xyz);
        factors.normalTessellation = normal_tess_factor(vertexNormal);
    }
    return factors;
}

// Formula (2) for all factors, else tessellationLevel * factor + 1.
float thesis_level(ThesisEdgeFactors factors)
{
    if (thesisFactor == 0)
        return tessellationLevel * factors.distanceTessellation + 1;
    if (thesisFactor == 1)
        return tessellationLevel * factors.textureTessellation + 1;
    if (thesisFactor == 2)
        return tessellationLevel * factors.normalTessellation + 1;
    return 1 + ((constantTessellationWeight
                 + factors.normalTessellation * normalTessellationWeight
                 + factors.textureTessellation * textureTessellationWeight
                 + factors.distanceTessellation * distanceTessellationWeight)
                / (constantTessellationWeight + normalTessellationWeight
                   + textureTessellationWeight + distanceTessellationWeight))
           * tessellationLevel;
}

void main()
{
    // Passes through the vertex position.
    controlOut[ID].tcPosition = vertexIn[ID].vPosition;

    if (ID == 0)
    {
        vec3 P0 = vertexIn[0].vPosition.xyz;
        vec3 P1 = vertexIn[1].vPosition.xyz;
        vec3 P2 = vertexIn[2].vPosition.xyz;
        vec3 P3 = vertexIn[3].vPosition.xyz;

        ThesisEdgeFactors ab = thesis_edge_factors(P0, P1, ALONG_V);
        ThesisEdgeFactors ad = thesis_edge_factors(P0, P3, ALONG_U);
        ThesisEdgeFactors dc = thesis_edge_factors(P3, P2, ALONG_V);
        ThesisEdgeFactors bc = thesis_edge_factors(P1, P2, ALONG_U);

        // The inner factors are the averages of the four edges' factors.
        ThesisEdgeFactors inner;
        inner.distanceTessellation = (ab.distanceTessellation + ad.distanceTessellation
                                      + dc.distanceTessellation + bc.distanceTessellation) / 4;
        inner.textureTessellation = (ab.textureTessellation + ad.textureTessellation
                                     + dc.textureTessellation + bc.textureTessellation) / 4;
        inner.normalTessellation = (ab.normalTessellation + ad.normalTessellation
                                    + dc.normalTessellation + bc.normalTessellation) / 4;

        gl_TessLevelInner[0] = thesis_level(inner);
        gl_TessLevelInner[1] = thesis_level(inner);
        gl_TessLevelOuter[0] = thesis_level(ab);
        gl_TessLevelOuter[1] = thesis_level(ad);
        gl_TessLevelOuter[2] = thesis_level(dc);
        gl_TessLevelOuter[3] = thesis_level(bc);
    }
}
