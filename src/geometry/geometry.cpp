// The geometry stage: face normals (cosc422_terrain.geom), normal-map normals
// (thesis_terrain.geom) and area-weighted smooth vertex normals.
#include "tessref/geometry.h"

#include <bit>
#include <cstring>
#include <map>
#include <tuple>
#include <type_traits>

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

template <typename T>
void thesis_normals_from_texture(std::span<const vec4_t<T>> texel, const mat3_t<T>& normalMatrix,
                                 std::span<vec3_t<T>> normal) {
    const mat3_t<T> matrix = normalMatrix;  // a local: the loop need not reload it after each store
    for (std::size_t k = 0; k < texel.size(); ++k)
        normal[k] = thesis_normal_from_texture(vec3_t<T>(texel[k]), matrix);
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
