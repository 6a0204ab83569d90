// tessref/geometry.h — the geometry stage: normals of the tessellated surface.
//
// Pure functions mirroring the geometry shaders in data/shaders/ (lab 4's appendix-A normal,
// which the lab computes in its evaluation shader, is evaluation.h's lab4_vertex_normal):
//   face_normal                 cosc422_terrain.geom   one normal per triangle
//   thesis_normal_from_texture  thesis_terrain.geom    per-vertex normal from the normal map
//   thesis_geometry             thesis_terrain.geom    the whole shader for one triangle
//   smooth_vertex_normals       (no shader)            area-weighted vertex normals
// Templates over the scalar (float: GPU-faithful; double: accuracy), instantiated in
// src/geometry/.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/control.h"

namespace tessref {

// normalize(cross(p1 - p0, p2 - p0)): the normal of a counter-clockwise triangle. A
// degenerate triangle gives NaN components, as normalize(vec3(0)) does in GLSL.
template <typename T>
vec3_t<T> face_normal(const vec3_t<T>& p0, const vec3_t<T>& p1, const vec3_t<T>& p2);

// NormalFromTexture of the thesis's geometry shader: normalMatrix * normalize(rgb - 0.5).
// Quirk kept: the result is not normalized again, so a normalMatrix with scale returns a
// non-unit normal, as the shader hands it to the fragment shader.
template <typename T>
vec3_t<T> thesis_normal_from_texture(const vec3_t<T>& rgb, const mat3_t<T>& normalMatrix);
// thesis_normal_from_texture at many texels: normal[k] = thesis_normal_from_texture(
// vec3(texel[k]), normalMatrix), bit for bit (texel: a normal-map sample, alpha ignored).
// One tight loop, so that the square roots and divisions of neighbouring vertices overlap.
// The spans have the same size.
template <typename T>
void thesis_normals_from_texture(std::span<const vec4_t<T>> texel, const mat3_t<T>& normalMatrix,
                                 std::span<vec3_t<T>> normal);

// The thesis's geometry shader for one triangle: gNormal[i] = NormalFromTexture(
// texture(normalMap, textureCoordinate[i]).rgb), positions and texture coordinates pass
// through (so only the normals are returned).
template <typename T>
std::array<vec3_t<T>, 3> thesis_geometry(const std::array<vec2_t<T>, 3>& textureCoordinate,
                                         const Sampler2D<T>& normalMap,
                                         const mat3_t<T>& normalMatrix);

// Smooth vertex normals over a triangle list: each vertex gets the normalized sum of
// cross(p1 - p0, p2 - p0) of its triangles (twice their area times their unit normal, hence
// area weighted), summed in triangle order. With Weld::by_position, vertices whose positions
// are bitwise equal share one sum (the pipeline emits one copy of a shared vertex per
// patch), so every copy gets the same normal; Weld::by_index uses the indices as given.
// A vertex in no triangle, or whose sum is zero, gets (0, 0, 0).
enum class Weld : std::uint8_t { by_index, by_position };
template <typename T>
std::vector<vec3_t<T>> smooth_vertex_normals(std::span<const vec3_t<T>> positions,
                                             std::span<const std::array<std::uint32_t, 3>> triangles,
                                             Weld weld = Weld::by_position);

}  // namespace tessref
