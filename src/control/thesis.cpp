// The thesis's vertex and tessellation control shaders (Jakobsen 2012, appendix A.1/A.2),
// twin of data/shaders/thesis_terrain.vert and thesis_terrain.tesc. Local names are the
// shader's, so the two read side by side.
#include <algorithm>
#include <cmath>
#include <type_traits>

#include "shader/llvmpipe_math.h"
#include "tessref/control.h"

namespace tessref {

template <typename T>
vec4_t<T> thesis_vertex(const vec2_t<T>& position, const Sampler2D<T>& heightMap, T scaleXY,
                        T scaleZ) {
    // GLSL: thesis_terrain.vert:20 textureCoordinate
    const vec2_t<T> textureCoordinate = position / scaleXY;
    // GLSL: thesis_terrain.vert:24 height
    const T height = heightMap(textureCoordinate).r * scaleZ;
    // GLSL: thesis_terrain.vert:26 positionWithHeight
    return vec4_t<T>(position.x, position.y, height, T(1));
}

template <typename T>
T distance_factor(T factor, const ThesisDistance<T>& params) {
    // GLSL: thesis_terrain.tesc:64 distance_factor
    if (factor > params.limit) {
        factor = T(0);
    } else {
        factor = (params.limit - factor) / params.divisor;
    }
    return factor;
}

namespace {

// GLSL's dot, distance and normalize: glm's in exact math; in llvmpipe math (float) the
// driver's order of operations (llvmpipe_math.h: a dot product summed from its last
// component), which moves a unit normals' dot product by an ulp often enough, and acos near
// 1 turns an ulp into hundreds.
template <typename T>
T glsl_dot(const vec3_t<T>& a, const vec3_t<T>& b, MathMode math) {
    if constexpr (std::is_same_v<T, float>) {
        if (math == MathMode::llvmpipe) return llvmpipe_math::dot(a, b);
    }
    return glm::dot(a, b);
}

template <typename T>
T glsl_distance(const vec3_t<T>& a, const vec3_t<T>& b, MathMode math) {
    if constexpr (std::is_same_v<T, float>) {
        if (math == MathMode::llvmpipe) return llvmpipe_math::distance(a, b);
    }
    return glm::distance(a, b);
}

template <typename T>
vec3_t<T> glsl_normalize(const vec3_t<T>& v, MathMode math) {
    if constexpr (std::is_same_v<T, float>) {
        if (math == MathMode::llvmpipe) return llvmpipe_math::normalize(v);
    }
    return glm::normalize(v);
}

}  // namespace

template <typename T>
vec3_t<T> normal_from_texture(const vec3_t<T>& rgb, MathMode math) {
    // GLSL: thesis_terrain.tesc:54 normal_from_texture
    vec3_t<T> normal = rgb;
    normal.x = normal.x - T(0.5);
    normal.y = normal.y - T(0.5);
    normal.z = normal.z - T(0.5);
    normal = glsl_normalize(normal, math);
    return normal;
}

namespace {

// acos of a dot product of unit vectors, clamped into [-1, 1] in both precisions. The
// thesis's shader calls acos(dot(n1, n2)) unclamped; in float a decoded unit normal's
// self-dot often rounds above 1 (8-24 % of the texels of the shipped normal maps), acos
// gives NaN, the NaN outer level culls the patch on llvmpipe and on GPUs, and the terrain
// gets holes. That is a bug of the shader, not a property of the hardware, so this twin
// and data/shaders/thesis_terrain.tesc both clamp (a documented departure from the seed).
// In MathMode::llvmpipe the float path takes llvmpipe's acos (a polynomial in sqrt(1 - |x|),
// off the exact value by up to a few hundred ulps), so its levels are the driver's bit for
// bit: near a fractional_odd level's odd integer, the exact acos would put the level on the
// other side and change the patch's triangle count.
template <typename T>
T angle_between(const vec3_t<T>& n1, const vec3_t<T>& n2, MathMode math) {
    const T cosine = std::clamp(glsl_dot(n1, n2, math), T(-1), T(1));
    if constexpr (std::is_same_v<T, float>) {
        if (math == MathMode::llvmpipe) return llvmpipe_math::acos(cosine);
    }
    return std::acos(cosine);
}

// GLSL: thesis_terrain.tesc:79 normal_tess_factor
template <typename T>
T normal_tess_factor(const std::array<vec3_t<T>, 6>& vertexNormal, T threshold, MathMode math) {
    const T testangle = angle_between(vertexNormal[0], vertexNormal[3], math);
    const T testangle90 = angle_between(vertexNormal[2], vertexNormal[1], math);
    const T testangle2 = angle_between(vertexNormal[0], vertexNormal[5], math);
    const T testangle902 = angle_between(vertexNormal[1], vertexNormal[4], math);

    if (testangle > threshold || testangle90 > threshold || testangle2 > threshold ||
        testangle902 > threshold) {
        if constexpr (std::is_same_v<T, float>) {
            // Mesa's GLSL compiler rebalances this chain of additions of plain variables:
            // llvmpipe adds (testangle + testangle90) + (testangle2 + testangle902)
            // (llvmpipe_math.h, balanced_order), which moves the level an ulp now and then.
            if (math == MathMode::llvmpipe) {
                const T angles[] = {testangle, testangle90, testangle2, testangle902};
                return llvmpipe_math::balanced_sum(angles);
            }
        }
        return testangle + testangle90 + testangle2 + testangle902;
    }
    return T(0);
}

template <typename T>
bool uses(ThesisFactor factor, ThesisFactor wanted) {
    return factor == wanted || factor == ThesisFactor::all;
}

}  // namespace

template <typename T>
ThesisEdgeFactors<T> thesis_edge_factors(const vec3_t<T>& p, const vec3_t<T>& q,
                                         ThesisEdgeDirection direction,
                                         const ThesisControl<T>& control) {
    // GLSL: thesis_terrain.tesc:109 thesis_edge_factors
    const Edge<T> edge = canonical_edge(p, q);
    const vec3_t<T> a = edge.a;
    const vec3_t<T> b = edge.b;
    ThesisEdgeFactors<T> factors;

    if (uses<T>(control.factor, ThesisFactor::distance)) {
        // GLSL: thesis_terrain.tesc:119 midPos
        const vec3_t<T> midPos = a + ((b - a) / T(2));
        factors.distanceTessellation =
            distance_factor(glsl_distance(midPos, control.cameraPosition, control.math), control.distance);
    }

    if (uses<T>(control.factor, ThesisFactor::tessellation_map)) {
        // GLSL: thesis_terrain.tesc:126 midTexPos
        const vec2_t<T> aXY(a.x, a.y);
        const vec2_t<T> bXY(b.x, b.y);
        const vec2_t<T> midTexPos = (aXY + ((bXY - aXY) / T(2))) / control.scaleXY;
        factors.textureTessellation = control.tessellationMap(midTexPos).r;
    }

    if (uses<T>(control.factor, ThesisFactor::normal)) {
        // GLSL: thesis_terrain.tesc:133 minus
        const vec2_t<T> aXY(a.x, a.y);
        const vec2_t<T> bXY(b.x, b.y);
        const bool alongV = direction == ThesisEdgeDirection::along_v;
        const vec2_t<T> minus = alongV ? vec2_t<T>(aXY - bXY) : vec2_t<T>(bXY - aXY);  // left / down
        const vec2_t<T> plus = alongV ? vec2_t<T>(bXY - aXY) : vec2_t<T>(aXY - bXY);   // right / up
        auto probe = [&](const vec2_t<T>& xy) {
            const vec4_t<T> texel = control.normalMap(xy / control.scaleXY);
            return normal_from_texture(vec3_t<T>(texel.x, texel.y, texel.z), control.math);
        };
        // GLSL: thesis_terrain.tesc:135 vertexNormal
        const std::array<vec3_t<T>, 6> vertexNormal{probe(aXY),         probe(bXY),
                                                    probe(aXY + minus), probe(bXY + minus),
                                                    probe(aXY + plus),  probe(bXY + plus)};
        factors.normalTessellation = normal_tess_factor(vertexNormal, control.normalAngleThreshold, control.math);
    }
    return factors;
}

template <typename T>
T thesis_level(const ThesisEdgeFactors<T>& factors, const ThesisControl<T>& control) {
    // GLSL: thesis_terrain.tesc:148 thesis_level
    const T tessellationLevel = control.tessellationLevel;
    switch (control.factor) {
        case ThesisFactor::distance:
            return tessellationLevel * factors.distanceTessellation + T(1);
        case ThesisFactor::tessellation_map:
            return tessellationLevel * factors.textureTessellation + T(1);
        case ThesisFactor::normal:
            return tessellationLevel * factors.normalTessellation + T(1);
        case ThesisFactor::all:
            break;
    }
    const ThesisWeights<T>& w = control.weights;
    // Formula (2), in the shader's operation order.
    return T(1) + ((w.constant + factors.normalTessellation * w.normal +
                    factors.textureTessellation * w.texture +
                    factors.distanceTessellation * w.distance) /
                   (w.constant + w.normal + w.texture + w.distance)) *
                      tessellationLevel;
}

template <typename T>
PatchLevels<T> thesis_levels(const QuadCorners<T>& vPosition, const ThesisControl<T>& control) {
    // GLSL: thesis_terrain.tesc:165 main
    using D = ThesisEdgeDirection;
    const ThesisEdgeFactors<T> ab = thesis_edge_factors(vPosition[0], vPosition[1], D::along_v, control);
    const ThesisEdgeFactors<T> ad = thesis_edge_factors(vPosition[0], vPosition[3], D::along_u, control);
    const ThesisEdgeFactors<T> dc = thesis_edge_factors(vPosition[3], vPosition[2], D::along_v, control);
    const ThesisEdgeFactors<T> bc = thesis_edge_factors(vPosition[1], vPosition[2], D::along_u, control);

    // GLSL: thesis_terrain.tesc:183 inner
    ThesisEdgeFactors<T> inner;
    inner.distanceTessellation = (ab.distanceTessellation + ad.distanceTessellation +
                                  dc.distanceTessellation + bc.distanceTessellation) / T(4);
    inner.textureTessellation = (ab.textureTessellation + ad.textureTessellation +
                                 dc.textureTessellation + bc.textureTessellation) / T(4);
    inner.normalTessellation = (ab.normalTessellation + ad.normalTessellation +
                                dc.normalTessellation + bc.normalTessellation) / T(4);

    // GLSL: thesis_terrain.tesc:191 gl_TessLevelInner
    PatchLevels<T> levels;
    levels.inner[0] = thesis_level(inner, control);
    levels.inner[1] = thesis_level(inner, control);
    levels.outer[0] = thesis_level(ab, control);
    levels.outer[1] = thesis_level(ad, control);
    levels.outer[2] = thesis_level(dc, control);
    levels.outer[3] = thesis_level(bc, control);
    return levels;
}

#define TESSREF_INSTANTIATE(T)                                                                  \
    template vec4_t<T> thesis_vertex(const vec2_t<T>&, const Sampler2D<T>&, T, T);             \
    template T distance_factor(T, const ThesisDistance<T>&);                                    \
    template vec3_t<T> normal_from_texture(const vec3_t<T>&, MathMode);                         \
    template ThesisEdgeFactors<T> thesis_edge_factors(const vec3_t<T>&, const vec3_t<T>&,       \
                                                      ThesisEdgeDirection,                      \
                                                      const ThesisControl<T>&);                 \
    template T thesis_level(const ThesisEdgeFactors<T>&, const ThesisControl<T>&);              \
    template PatchLevels<T> thesis_levels(const QuadCorners<T>&, const ThesisControl<T>&);
TESSREF_INSTANTIATE(float)
TESSREF_INSTANTIATE(double)
#undef TESSREF_INSTANTIATE

}  // namespace tessref
