// The evaluation shaders: thesis, COSC422, lab 4 and PN triangles. Twins of
// data/shaders/{thesis_terrain,cosc422_terrain,lab4_terrain,pn_triangles}.tese; local
// names are the shaders', so the two read side by side.
#include "tessref/evaluation.h"

#include <algorithm>
#include <type_traits>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include "common/xyz4.h"

namespace tessref {

namespace {

// GLSL mix(x, y, a) as llvmpipe computes it: x + a * (y - x) (gallivm's lerp), each
// operation rounded on its own. glm::mix is x * (1 - a) + y * a, which rounds differently:
// up to 2 ulps in a position, and through the height map's slope up to ~300 ulps in a
// height (measured on jacksboro against `tessref gl --capture`; with this form every
// compared vertex is bit-identical). Fusing the multiply-add (std::fma) matches fewer
// vertices, so llvmpipe does not fuse here. The steps are separate statements so that no
// compiler contracts them into an fma (-ffp-contract=on contracts within one expression).
// mix(x, y, 0) == x exactly; mix(x, y, 1) == x + (y - x), which is y whenever y - x is
// exact (always for the grid corners of the shipped scenes: see evaluation.h).
// Inlined: called three times per evaluated vertex.
template <typename T, int N>
[[gnu::always_inline]] inline glm::vec<N, T> mix_gpu(const glm::vec<N, T>& x, const glm::vec<N, T>& y, T a) {
    glm::vec<N, T> out;
    for (int c = 0; c < N; ++c) {
        const T difference = y[c] - x[c];
        const T scaled = a * difference;
        out[c] = x[c] + scaled;
    }
    return out;
}

}  // namespace

namespace {

// thesis_terrain.tese up to the height's texture coordinate, shared by thesis_evaluate and
// its batch: the corners' bilinear mix (position.xy) and textureCoordinate.
template <typename T>
struct ThesisGround {
    vec2_t<T> position;
    vec2_t<T> textureCoordinate;
};
template <typename T>
[[gnu::always_inline]] inline ThesisGround<T> thesis_ground(const std::array<vec4_t<T>, 4>& tcPosition,
                                                           const DomainPoint<T>& glTessCoord, T scaleXY) {
    // GLSL: thesis_terrain.tese:24 adPosition
    const vec4_t<T> adPosition = mix_gpu(tcPosition[0], tcPosition[3], glTessCoord.u);
    const vec4_t<T> bcPosition = mix_gpu(tcPosition[1], tcPosition[2], glTessCoord.u);
    // GLSL: thesis_terrain.tese:28 position
    const vec4_t<T> position = mix_gpu(adPosition, bcPosition, glTessCoord.v);
    const vec2_t<T> xy(position.x, position.y);
    // GLSL: thesis_terrain.tese:31 textureCoordinate
    return {xy, xy / scaleXY};
}

}  // namespace

template <typename T>
EvaluatedVertex<T> thesis_evaluate(const std::array<vec4_t<T>, 4>& tcPosition,
                                   const DomainPoint<T>& glTessCoord,
                                   const ThesisEvaluation<T>& evaluation) {
    // (The texture coordinate is a local, passed on in registers: read back from `out`, the
    // two separately stored halves stalled every vertex on a failed store-to-load forward.)
    const ThesisGround<T> ground = thesis_ground(tcPosition, glTessCoord, evaluation.scaleXY);
    EvaluatedVertex<T> out;
    out.textureCoordinate = ground.textureCoordinate;
    // GLSL: thesis_terrain.tese:34 height
    const T height = evaluation.heightMap(ground.textureCoordinate).r * evaluation.scaleZ;
    // GLSL: thesis_terrain.tese:36 positionWithHeight
    const vec4_t<T> positionWithHeight(ground.position.x, ground.position.y, height, T(1));
    out.position = vec3_t<T>(positionWithHeight);
    // GLSL: thesis_terrain.tese:38 gl_Position
    out.glPosition = evaluation.mvp * positionWithHeight;
    return out;
}

#if defined(__SSE2__)
namespace {

// thesis_evaluate_batch in float, four points at a time: thesis_ground's operations lane by
// lane (mix_gpu's y - x of two corners is the same for every point, so computed once).
struct ThesisGroundX4 {
    __m128 c0x, c0y, c1x, c1y;      // tcPosition[0].xy, tcPosition[1].xy
    __m128 d03x, d03y, d12x, d12y;  // tcPosition[3] - tcPosition[0], tcPosition[2] - tcPosition[1] (xy)
    __m128 scaleXY;
    ThesisGroundX4(const std::array<glm::vec4, 4>& c, float scale)
        : c0x(_mm_set1_ps(c[0].x)), c0y(_mm_set1_ps(c[0].y)), c1x(_mm_set1_ps(c[1].x)), c1y(_mm_set1_ps(c[1].y)),
          d03x(_mm_set1_ps(c[3].x - c[0].x)), d03y(_mm_set1_ps(c[3].y - c[0].y)),
          d12x(_mm_set1_ps(c[2].x - c[1].x)), d12y(_mm_set1_ps(c[2].y - c[1].y)), scaleXY(_mm_set1_ps(scale)) {}
};

// Points tc[0..3]: their ground position (x, y) to px, py and their texture coordinates.
inline void thesis_ground_x4(const ThesisGroundX4& g, const DomainPoint<float>* tc, float* px, float* py,
                             glm::vec2* textureCoordinate) {
    static_assert(sizeof(DomainPoint<float>) == 12 && sizeof(glm::vec2) == 8);
    // (u, v, w) x 4 in three loads: u0 v0 w0 u1 | v1 w1 u2 v2 | w2 u3 v3 w3.
    const float* p = &tc[0].u;
    const __m128 l0 = _mm_loadu_ps(p);
    const __m128 l1 = _mm_loadu_ps(p + 4);
    const __m128 l2 = _mm_loadu_ps(p + 8);
    const __m128 u23 = _mm_shuffle_ps(l1, l2, _MM_SHUFFLE(1, 1, 2, 2));                   // u2 u2 u3 u3
    const __m128 u = _mm_shuffle_ps(l0, u23, _MM_SHUFFLE(2, 0, 3, 0));                    // u0 u1 u2 u3
    const __m128 v01 = _mm_shuffle_ps(l0, l1, _MM_SHUFFLE(0, 0, 1, 1));                   // v0 v0 v1 v1
    const __m128 v23 = _mm_shuffle_ps(l1, l2, _MM_SHUFFLE(2, 2, 3, 3));                   // v2 v2 v3 v3
    const __m128 v = _mm_shuffle_ps(v01, v23, _MM_SHUFFLE(2, 0, 2, 0));                   // v0 v1 v2 v3
    // mix_gpu (x + a * (y - x)) of the corners' x and y:
    // GLSL: thesis_terrain.tese:24 adPosition
    // GLSL: thesis_terrain.tese:25 bcPosition
    const __m128 adx = _mm_add_ps(g.c0x, _mm_mul_ps(u, g.d03x));
    const __m128 ady = _mm_add_ps(g.c0y, _mm_mul_ps(u, g.d03y));
    const __m128 bcx = _mm_add_ps(g.c1x, _mm_mul_ps(u, g.d12x));
    const __m128 bcy = _mm_add_ps(g.c1y, _mm_mul_ps(u, g.d12y));
    // GLSL: thesis_terrain.tese:28 position
    const __m128 x = _mm_add_ps(adx, _mm_mul_ps(v, _mm_sub_ps(bcx, adx)));
    const __m128 y = _mm_add_ps(ady, _mm_mul_ps(v, _mm_sub_ps(bcy, ady)));
    _mm_storeu_ps(px, x);
    _mm_storeu_ps(py, y);
    // GLSL: thesis_terrain.tese:31 textureCoordinate
    const __m128 s = _mm_div_ps(x, g.scaleXY);
    const __m128 t = _mm_div_ps(y, g.scaleXY);
    _mm_storeu_ps(&textureCoordinate[0].x, _mm_unpacklo_ps(s, t));
    _mm_storeu_ps(&textureCoordinate[2].x, _mm_unpackhi_ps(s, t));
}

// Four positions (px, py, red * scaleZ), stored as four glm::vec3 (store_xyz4).
inline void thesis_positions_x4(const float* px, const float* py, const float* red, __m128 scaleZ,
                                glm::vec3* position) {
    static_assert(sizeof(glm::vec3) == 12);
    const __m128 x = _mm_loadu_ps(px);
    const __m128 y = _mm_loadu_ps(py);
    // GLSL: thesis_terrain.tese:34 height
    const __m128 z = _mm_mul_ps(_mm_loadu_ps(red), scaleZ);
    store_xyz4(&position[0].x, x, y, z);
}

}  // namespace
#endif

template <typename T>
void thesis_evaluate_batch(const std::array<vec4_t<T>, 4>& tcPosition,
                           std::span<const DomainPoint<T>> glTessCoord, const Sampler2DRedBatch<T>& heightMap,
                           T scaleXY, T scaleZ, std::span<vec3_t<T>> position,
                           std::span<vec2_t<T>> textureCoordinate) {
    // Blocks whose height samples fit on the stack: the points' coordinates, their samples'
    // red channels in one call, then the heights.
    std::array<T, 64> red;
    // The corners as a local: the loop need not reload them (nor recompute their differences)
    // after each store.
    const std::array<vec4_t<T>, 4> corners = tcPosition;
#if defined(__SSE2__)
    if constexpr (std::is_same_v<T, float>) {
        // Four points at a time, the ground positions kept aside (px, py) until the heights.
        const ThesisGroundX4 ground(corners, scaleXY);
        const __m128 scaleZ4 = _mm_set1_ps(scaleZ);
        alignas(16) std::array<float, 64> px, py;
        for (std::size_t k0 = 0; k0 < glTessCoord.size(); k0 += red.size()) {
            const std::size_t count = std::min(red.size(), glTessCoord.size() - k0);
            const std::size_t whole = count & ~std::size_t{3};
            for (std::size_t k = 0; k < whole; k += 4)
                thesis_ground_x4(ground, &glTessCoord[k0 + k], &px[k], &py[k], &textureCoordinate[k0 + k]);
            for (std::size_t k = whole; k < count; ++k) {
                const ThesisGround<T> g = thesis_ground(corners, glTessCoord[k0 + k], scaleXY);
                px[k] = g.position.x;
                py[k] = g.position.y;
                textureCoordinate[k0 + k] = g.textureCoordinate;
            }
            heightMap(textureCoordinate.subspan(k0, count), std::span<T>(red.data(), count));
            for (std::size_t k = 0; k < whole; k += 4)
                thesis_positions_x4(&px[k], &py[k], &red[k], scaleZ4, &position[k0 + k]);
            // GLSL: thesis_terrain.tese:34 height
            for (std::size_t k = whole; k < count; ++k) position[k0 + k] = vec3_t<T>(px[k], py[k], red[k] * scaleZ);
        }
        return;
    }
#endif
    for (std::size_t k0 = 0; k0 < glTessCoord.size(); k0 += red.size()) {
        const std::size_t count = std::min(red.size(), glTessCoord.size() - k0);
        for (std::size_t k = 0; k < count; ++k) {
            const ThesisGround<T> ground = thesis_ground(corners, glTessCoord[k0 + k], scaleXY);
            position[k0 + k] = vec3_t<T>(ground.position, T(0));
            textureCoordinate[k0 + k] = ground.textureCoordinate;
        }
        heightMap(textureCoordinate.subspan(k0, count), std::span<T>(red.data(), count));
        // GLSL: thesis_terrain.tese:34 height
        for (std::size_t k = 0; k < count; ++k) position[k0 + k].z = red[k] * scaleZ;
    }
}

template <typename T>
EvaluatedVertex<T> cosc422_evaluate(const std::array<vec4_t<T>, 4>& glInPosition,
                                    const DomainPoint<T>& glTessCoord,
                                    const Cosc422Evaluation<T>& evaluation) {
    const T u = glTessCoord.u;
    const T v = glTessCoord.v;
    // GLSL: cosc422_terrain.tese:55 posn
    vec4_t<T> posn = mix_gpu(mix_gpu(glInPosition[0], glInPosition[3], u),
                              mix_gpu(glInPosition[1], glInPosition[2], u), v);
    // GLSL: cosc422_terrain.tese:58 s
    const T s = (posn.x - evaluation.xMin) / (evaluation.xMax - evaluation.xMin);
    const T t = (posn.z - evaluation.zMin) / (evaluation.zMax - evaluation.zMin);
    // GLSL: cosc422_terrain.tese:61 height
    const T height = evaluation.heightMap(vec2_t<T>(s, t)).r * evaluation.heightScale;
    posn.y = height;

    EvaluatedVertex<T> out;
    out.position = vec3_t<T>(posn);
    out.textureCoordinate = vec2_t<T>(s, t);
    // GLSL: cosc422_terrain.tese:69 gl_Position
    out.glPosition = evaluation.mvpMatrix * posn;
    return out;
}

template <typename T>
T lab4_vertex_log_level(const DomainPoint<T>& glTessCoord, const Lab4Lod<T>& lod) {
    // GLSL: lab4_terrain.tese:38 lab4_vertex_log_level
    const bool u0 = glTessCoord.u == T(0);
    const bool u1 = glTessCoord.u == T(1);
    const bool v0 = glTessCoord.v == T(0);
    const bool v1 = glTessCoord.v == T(1);
    if (u0 && v0) return lod.logCorner[0];
    if (u0 && v1) return lod.logCorner[1];
    if (u1 && v1) return lod.logCorner[2];
    if (u1 && v0) return lod.logCorner[3];
    if (u0) return lod.logOuter[0];
    if (v0) return lod.logOuter[1];
    if (u1) return lod.logOuter[2];
    if (v1) return lod.logOuter[3];
    return lod.logInner;
}

template <typename T>
vec3_t<T> lab4_vertex_normal(T x, T z, const Lab4NormalSampling<T>& sampling) {
    // GLSL: lab4_terrain.tese:55 lab4_height
    auto lab4_height = [&](T px, T pz) {
        const vec2_t<T> texCoord = vec2_t<T>(px, pz) / sampling.horizontalScale + sampling.texCoordOffset;
        return sampling.heightMap(texCoord, sampling.lod).r * sampling.verticalScale;
    };
    // GLSL: lab4_terrain.tese:61 lab4_vertex_normal
    const T h = sampling.h;
    const vec3_t<T> H(x, lab4_height(x, z), z);
    const vec3_t<T> Hx(x + h, lab4_height(x + h, z), z);
    const vec3_t<T> Hz(x, lab4_height(x, z + h), z + h);
    // GLSL: lab4_terrain.tese:67 normalize(cross
    return glm::normalize(glm::cross(Hz - H, Hx - H));
}

template <typename T>
EvaluatedVertex<T> lab4_evaluate(const std::array<vec4_t<T>, 4>& tcPosition,
                                 const DomainPoint<T>& glTessCoord, const Lab4Lod<T>& lod,
                                 const Lab4Evaluation<T>& evaluation) {
    const T u = glTessCoord.u;
    const T v = glTessCoord.v;
    // GLSL: lab4_terrain.tese:75 position
    vec4_t<T> position = mix_gpu(mix_gpu(tcPosition[0], tcPosition[3], u),
                                  mix_gpu(tcPosition[1], tcPosition[2], u), v);

    const vec2_t<T> texCoord =
        vec2_t<T>(position.x, position.z) / evaluation.horizontalScale + evaluation.texCoordOffset;
    const T logTessellationLevel = lab4_vertex_log_level(glTessCoord, lod);
    // GLSL: lab4_terrain.tese:80 lod
    const T mipLevel = lod.maxLogTessellationLevel - logTessellationLevel;
    // GLSL: lab4_terrain.tese:81 height
    const T height = evaluation.heightMap(texCoord, mipLevel).r * evaluation.verticalScale;
    position.y = height;

    EvaluatedVertex<T> out;
    out.position = vec3_t<T>(position);
    out.textureCoordinate = texCoord;
    if (evaluation.gridStep > T(0)) {
        Lab4NormalSampling<T> sampling;
        sampling.heightMap = evaluation.heightMap;
        sampling.horizontalScale = evaluation.horizontalScale;
        sampling.verticalScale = evaluation.verticalScale;
        sampling.texCoordOffset = evaluation.texCoordOffset;
        sampling.h = evaluation.gridStep;
        sampling.lod = mipLevel;
        out.normal = lab4_vertex_normal(position.x, position.z, sampling);
    }
    // GLSL: lab4_terrain.tese:87 gl_Position
    out.glPosition = evaluation.mvp * position;
    return out;
}

namespace {

template <typename T>
bool less_lexicographic(const vec3_t<T>& p, const vec3_t<T>& q) {
    // GLSL: pn_triangles.tese:36 less_lexicographic
    return p.x < q.x || (p.x == q.x && (p.y < q.y || (p.y == q.y && p.z < q.z)));
}

}  // namespace

template <typename T>
EvaluatedVertex<T> pn_evaluate(const PnPatch<T>& patch, const DomainPoint<T>& glTessCoord,
                               const PnEvaluation<T>& evaluation) {
    const auto& pos = patch.v3VertexPos;
    const vec3_t<T>& v3P030 = pos[0];
    const vec3_t<T>& v3P021 = patch.v3PatchE1[0];
    const vec3_t<T>& v3P012 = patch.v3PatchE2[0];
    const vec3_t<T>& v3P003 = pos[1];
    const vec3_t<T>& v3P102 = patch.v3PatchE1[1];
    const vec3_t<T>& v3P201 = patch.v3PatchE2[1];
    const vec3_t<T>& v3P300 = pos[2];
    const vec3_t<T>& v3P210 = patch.v3PatchE1[2];
    const vec3_t<T>& v3P120 = patch.v3PatchE2[2];
    const vec3_t<T>& v3P111 = patch.v3P111;

    const T fU = glTessCoord.u;
    const T fV = glTessCoord.v;
    const T fW = glTessCoord.w;
    const T fUU = fU * fU;
    const T fVV = fV * fV;
    const T fWW = fW * fW;
    const T fUU3 = fUU * T(3);
    const T fVV3 = fVV * T(3);
    const T fWW3 = fWW * T(3);

    const std::array<vec3_t<T>, 3> normals{glm::normalize(patch.v3VertexNormal[0]),
                                           glm::normalize(patch.v3VertexNormal[1]),
                                           glm::normalize(patch.v3VertexNormal[2])};

    // GLSL: pn_triangles.tese:79 zeroCount
    const int zeroCount = int(fU == T(0)) + int(fV == T(0)) + int(fW == T(0));
    vec3_t<T> v3PNPoint, v3BasePosition, v3Linear, v3Quadratic;
    vec2_t<T> v2UV;
    if (evaluation.watertightEdges && zeroCount == 1) {
        // GLSL: pn_triangles.tese:85 watertightEdges
        int i = (fU == T(0)) ? 1 : 0;
        int j = (fW == T(0)) ? 1 : 2;
        const std::array<T, 3> weights{fU, fV, fW};
        if (less_lexicographic(pos[j], pos[i])) std::swap(i, j);
        // The control point (and quadratic-normal coefficient) of edge i-j next to corner i.
        auto pn_edge_point = [&](int from, int to) {
            return to == (from < 2 ? from + 1 : 0) ? patch.v3PatchE1[from] : patch.v3PatchE2[to];
        };
        auto pn_edge_normal = [&](int from, int to) {
            return to == (from < 2 ? from + 1 : 0) ? patch.v3EdgeNormal[from] : patch.v3EdgeNormal[to];
        };
        const T ci = weights[i];
        const T cj = weights[j];
        const vec3_t<T>& Pi = pos[i];
        const vec3_t<T>& Pj = pos[j];
        // GLSL: pn_triangles.tese:102 v3PNPoint
        v3PNPoint = Pi * (ci * ci) * ci + Pj * (cj * cj) * cj +
                    pn_edge_point(i, j) * ((ci * ci) * T(3)) * cj +
                    pn_edge_point(j, i) * ((cj * cj) * T(3)) * ci;
        v3BasePosition = (Pi * ci) + (Pj * cj);
        // GLSL: pn_triangles.tese:106 v3Linear
        v3Linear = (patch.v3VertexNormal[i] * ci) + (patch.v3VertexNormal[j] * cj);
        v3Quadratic = normals[i] * (ci * ci) + normals[j] * (cj * cj) + pn_edge_normal(i, j) * (ci * cj);
        v2UV = (patch.v2VertexUV[i] * ci) + (patch.v2VertexUV[j] * cj);
    } else {
        // GLSL: pn_triangles.tese:112 v3PNPoint
        v3PNPoint = v3P030 * fUU * fU +
                    v3P003 * fVV * fV +
                    v3P300 * fWW * fW +
                    v3P021 * fUU3 * fV +
                    v3P012 * fVV3 * fU +
                    v3P102 * fVV3 * fW +
                    v3P201 * fWW3 * fV +
                    v3P210 * fWW3 * fU +
                    v3P120 * fUU3 * fW +
                    v3P111 * T(6) * fW * fU * fV;
        // GLSL: pn_triangles.tese:122 v3BasePosition
        v3BasePosition = (v3P030 * fU) + (v3P003 * fV) + (v3P300 * fW);
        // GLSL: pn_triangles.tese:125 v3Linear
        v3Linear = (patch.v3VertexNormal[0] * fU) + (patch.v3VertexNormal[1] * fV) +
                   (patch.v3VertexNormal[2] * fW);
        // GLSL: pn_triangles.tese:128 v3Quadratic
        v3Quadratic = normals[0] * fUU + normals[1] * fVV + normals[2] * fWW +
                      patch.v3EdgeNormal[0] * (fU * fV) + patch.v3EdgeNormal[1] * (fV * fW) +
                      patch.v3EdgeNormal[2] * (fW * fU);
        // GLSL: pn_triangles.tese:132 v2UV
        v2UV = (patch.v2VertexUV[0] * fU) + (patch.v2VertexUV[1] * fV) + (patch.v2VertexUV[2] * fW);
    }

    EvaluatedVertex<T> out;
    // GLSL: pn_triangles.tese:137 v3PositionOut
    out.position = mix_gpu(v3BasePosition, v3PNPoint, evaluation.fInfluence);
    // GLSL: pn_triangles.tese:138 v3NormalOut
    out.normal = evaluation.normal == PnNormal::linear ? v3Linear : glm::normalize(v3Quadratic);
    out.textureCoordinate = v2UV;
    // GLSL: pn_triangles.tese:141 gl_Position
    out.glPosition = evaluation.m4ViewProjection * vec4_t<T>(out.position, T(1));
    return out;
}

#define TESSREF_INSTANTIATE(T)                                                                    \
    template vec3_t<T> lab4_vertex_normal(T, T, const Lab4NormalSampling<T>&);                   \
    template EvaluatedVertex<T> thesis_evaluate(const std::array<vec4_t<T>, 4>&,                  \
                                                const DomainPoint<T>&, const ThesisEvaluation<T>&); \
    template void thesis_evaluate_batch(const std::array<vec4_t<T>, 4>&, std::span<const DomainPoint<T>>,     \
                                        const Sampler2DRedBatch<T>&, T, T, std::span<vec3_t<T>>,             \
                                        std::span<vec2_t<T>>);                                            \
    template EvaluatedVertex<T> cosc422_evaluate(const std::array<vec4_t<T>, 4>&,                 \
                                                 const DomainPoint<T>&,                           \
                                                 const Cosc422Evaluation<T>&);                    \
    template T lab4_vertex_log_level(const DomainPoint<T>&, const Lab4Lod<T>&);                   \
    template EvaluatedVertex<T> lab4_evaluate(const std::array<vec4_t<T>, 4>&,                    \
                                              const DomainPoint<T>&, const Lab4Lod<T>&,           \
                                              const Lab4Evaluation<T>&);                          \
    template EvaluatedVertex<T> pn_evaluate(const PnPatch<T>&, const DomainPoint<T>&,             \
                                            const PnEvaluation<T>&);
TESSREF_INSTANTIATE(float)
TESSREF_INSTANTIATE(double)
#undef TESSREF_INSTANTIATE

}  // namespace tessref
