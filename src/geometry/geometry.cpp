// The geometry stage: face normals (cosc422_terrain.geom), normal-map normals
// (thesis_terrain.geom) and area-weighted smooth vertex normals.
#include "tessref/geometry.h"

#include <bit>
#include <cstring>
#include <map>
#include <tuple>
#include <type_traits>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include "common/xyz4.h"

namespace tessref {

template <typename T>
vec3_t<T> face_normal(const vec3_t<T>& p0, const vec3_t<T>& p1, const vec3_t<T>& p2) {
    // GLSL: cosc422_terrain.geom:21 normalize(cross
    return glm::normalize(glm::cross(p1 - p0, p2 - p0));
}

template <typename T>
vec3_t<T> thesis_normal_from_texture(const vec3_t<T>& rgb, const mat3_t<T>& normalMatrix) {
    // GLSL: thesis_terrain.geom:25 thesis_normal_from_texture
    vec3_t<T> normal = rgb;
    normal.x = normal.x - T(0.5);
    normal.y = normal.y - T(0.5);
    normal.z = normal.z - T(0.5);
    normal = normalMatrix * glm::normalize(normal);
    return normal;
}

#if defined(__SSE2__)
namespace {

// thesis_normal_from_texture at four float texels, lane by lane the same operations in the
// same order: rgb - 0.5; normalize as glm does it, v * (1 / sqrt((x*x + y*y) + z*z)); then
// glm's mat3 * vec3, row r = (m[0][r] * x + m[1][r] * y) + m[2][r] * z. (IEEE's correctly
// rounded sqrt and division give the scalar bits; a NaN that the arithmetic makes is the
// same default NaN either way.)
struct NormalMatrixX4 {
    __m128 m[3][3];  // m[c][r]: normalMatrix[c][r] in every lane
    explicit NormalMatrixX4(const glm::mat3& matrix) {
        for (int c = 0; c < 3; ++c)
            for (int r = 0; r < 3; ++r) m[c][r] = _mm_set1_ps(matrix[c][r]);
    }
};

inline void thesis_normals_from_texture_x4(const glm::vec4* texel, const NormalMatrixX4& matrix, glm::vec3* out) {
    __m128 r = _mm_loadu_ps(&texel[0].x);
    __m128 g = _mm_loadu_ps(&texel[1].x);
    __m128 b = _mm_loadu_ps(&texel[2].x);
    __m128 a = _mm_loadu_ps(&texel[3].x);
    _MM_TRANSPOSE4_PS(r, g, b, a);
    const __m128 half = _mm_set1_ps(0.5f);
    const __m128 x = _mm_sub_ps(r, half);
    const __m128 y = _mm_sub_ps(g, half);
    const __m128 z = _mm_sub_ps(b, half);
    const __m128 dot = _mm_add_ps(_mm_add_ps(_mm_mul_ps(x, x), _mm_mul_ps(y, y)), _mm_mul_ps(z, z));
    const __m128 scale = _mm_div_ps(_mm_set1_ps(1.0f), _mm_sqrt_ps(dot));
    const __m128 nx = _mm_mul_ps(x, scale);
    const __m128 ny = _mm_mul_ps(y, scale);
    const __m128 nz = _mm_mul_ps(z, scale);
    __m128 o[3];
    for (int row = 0; row < 3; ++row)
        o[row] = _mm_add_ps(_mm_add_ps(_mm_mul_ps(matrix.m[0][row], nx), _mm_mul_ps(matrix.m[1][row], ny)),
                            _mm_mul_ps(matrix.m[2][row], nz));
    store_xyz4(&out[0].x, o[0], o[1], o[2]);
}

}  // namespace
#endif

template <typename T>
void thesis_normals_from_texture(std::span<const vec4_t<T>> texel, const mat3_t<T>& normalMatrix,
                                 std::span<vec3_t<T>> normal) {
    const mat3_t<T> matrix = normalMatrix;  // a local: the loop need not reload it after each store
    std::size_t k = 0;
#if defined(__SSE2__)
    if constexpr (std::is_same_v<T, float>) {
        static_assert(sizeof(glm::vec3) == 3 * sizeof(float) && sizeof(glm::vec4) == 4 * sizeof(float));
        const NormalMatrixX4 matrix4(matrix);
        for (; k + 4 <= texel.size(); k += 4) thesis_normals_from_texture_x4(&texel[k], matrix4, &normal[k]);
    }
#endif
    for (; k < texel.size(); ++k) normal[k] = thesis_normal_from_texture(vec3_t<T>(texel[k]), matrix);
}

template <typename T>
std::array<vec3_t<T>, 3> thesis_geometry(const std::array<vec2_t<T>, 3>& textureCoordinate,
                                         const Sampler2D<T>& normalMap,
                                         const mat3_t<T>& normalMatrix) {
    std::array<vec3_t<T>, 3> gNormal;
    for (int i = 0; i < 3; ++i) {
        // GLSL: thesis_terrain.geom:36 gNormal
        const vec4_t<T> texel = normalMap(textureCoordinate[i]);
        gNormal[i] = thesis_normal_from_texture(vec3_t<T>(texel), normalMatrix);
    }
    return gNormal;
}

namespace {

// The exact bits of a position, as a key (so -0 and +0, or two NaNs with different
// payloads, stay apart: welding is by bitwise equality).
template <typename T>
auto position_key(const vec3_t<T>& p) {
    using Bits = std::conditional_t<std::is_same_v<T, float>, std::uint32_t, std::uint64_t>;
    return std::make_tuple(std::bit_cast<Bits>(p.x), std::bit_cast<Bits>(p.y), std::bit_cast<Bits>(p.z));
}

}  // namespace

template <typename T>
std::vector<vec3_t<T>> smooth_vertex_normals(std::span<const vec3_t<T>> positions,
                                             std::span<const std::array<std::uint32_t, 3>> triangles,
                                             Weld weld) {
    // Group of each vertex: itself, or the first vertex with the same position bits.
    std::vector<std::uint32_t> group(positions.size());
    if (weld == Weld::by_position) {
        std::map<decltype(position_key(positions[0])), std::uint32_t> first;
        for (std::uint32_t i = 0; i < positions.size(); ++i) {
            group[i] = first.try_emplace(position_key(positions[i]), i).first->second;
        }
    } else {
        for (std::uint32_t i = 0; i < positions.size(); ++i) group[i] = i;
    }

    // cross(p1 - p0, p2 - p0) is twice the area times the unit normal: summing it weights
    // each triangle by its area. Sums run in triangle order, once per group.
    std::vector<vec3_t<T>> sum(positions.size(), vec3_t<T>(T(0)));
    for (const auto& triangle : triangles) {
        const vec3_t<T>& p0 = positions[triangle[0]];
        const vec3_t<T>& p1 = positions[triangle[1]];
        const vec3_t<T>& p2 = positions[triangle[2]];
        const vec3_t<T> weighted = glm::cross(p1 - p0, p2 - p0);
        for (std::uint32_t corner : triangle) sum[group[corner]] += weighted;
    }

    std::vector<vec3_t<T>> normals(positions.size(), vec3_t<T>(T(0)));
    for (std::size_t i = 0; i < positions.size(); ++i) {
        const vec3_t<T>& s = sum[group[i]];
        if (glm::dot(s, s) > T(0)) normals[i] = glm::normalize(s);
    }
    return normals;
}

#define TESSREF_INSTANTIATE(T)                                                                   \
    template vec3_t<T> face_normal(const vec3_t<T>&, const vec3_t<T>&, const vec3_t<T>&);        \
    template vec3_t<T> thesis_normal_from_texture(const vec3_t<T>&, const mat3_t<T>&);           \
    template void thesis_normals_from_texture(std::span<const vec4_t<T>>, const mat3_t<T>&,       \
                                              std::span<vec3_t<T>>);                              \
    template std::array<vec3_t<T>, 3> thesis_geometry(const std::array<vec2_t<T>, 3>&,           \
                                                      const Sampler2D<T>&, const mat3_t<T>&);    \
    template std::vector<vec3_t<T>> smooth_vertex_normals(                                       \
        std::span<const vec3_t<T>>, std::span<const std::array<std::uint32_t, 3>>, Weld);
TESSREF_INSTANTIATE(float)
TESSREF_INSTANTIATE(double)
#undef TESSREF_INSTANTIATE

}  // namespace tessref
