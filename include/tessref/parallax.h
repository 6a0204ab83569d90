// tessref/parallax.h — normal mapping, parallax mapping and the self-shadow trace (the
// PN-triangles tutorial's parts 1 and 2 and its "super extra"), as pieces of a fragment
// shader, in float (GPU-faithful). The shading model that puts them together is
// ShadingKind::pom (shading.h, pom_shading).
//
// TANGENT FRAME. A tangent-space map needs the surface's tangent t (the direction in which u
// grows), bitangent b and normal n. tessref derives t from the uv derivatives of the
// triangle a fragment lies on: with edges e1 = p1 - p0, e2 = p2 - p0 and uv differences
// d1 = uv1 - uv0, d2 = uv2 - uv0,
//   dP/du = (e1 * d2.v - e2 * d1.v) / r,   dP/dv = (e2 * d1.u - e1 * d2.u) / r,
//   r = d1.u * d2.v - d2.u * d1.v
// (the chain rule inverted: e_k = dP/du * d_k.u + dP/dv * d_k.v). Position and uv are both
// affine over a triangle, so this is what a fragment shader gets from dFdx/dFdy of its
// position and uv, whatever the perspective. On a mesh it is the tangent of the tessellated
// PN surface; on a height-field terrain, whose uv is linear in x and z, it is the height
// field's own slope along u: (dx/du, dh/du, dz/du). The frame is then built per fragment
// against the interpolated normal n (Gram-Schmidt):
//   t' = normalize(t - n * dot(n, t)),  b' = cross(n, t') * sign,
// the tutorial's bitangent cross(n, t) with a handedness sign = -1 when the uv is mirrored
// (dot(cross(n, t'), dP/dv) < 0), so that a shift along b' is a shift of +v.
//
// NORMAL MAP. The tutorial decodes only red and green: xy = (rg - 0.5) * 2, z = sqrt(1 -
// dot(xy, xy)) (clamped at 0, where GLSL's sqrt of a negative is undefined), and returns
// normalize(mat3(t', b', n) * (x, y, z)). A flat texel (0.5, 0.5) leaves n unchanged.
//
// HEIGHT MAP. The tutorial's bump map: its red channel is the height with 1 at the surface
// and smaller values below it (nothing rises above the geometry). fBumpScale is the uv
// distance the view ray moves per unit of depth when it enters at 45 degrees, i.e. the
// depth of the range [0, 1] in uv units.
//
// PARALLAX (v the unit view direction toward the eye in tangent space, (v.x, v.y, v.z) =
// (dot(V, t'), dot(V, b'), dot(V, n))):
//   parallax    one step: uv - fBumpScale * v.xy / v.z * (1 - h(uv));
//   steep       layers: n_s = round(mix(fMaxLayers, fMinLayers, |v.z|)) (more layers toward
//               grazing angles), each lowering the ray by 1 / n_s and moving uv by
//               -fBumpScale * v.xy / (v.z * n_s); the search stops at the first layer whose
//               height map value is at or above the ray, and returns that layer's uv;
//   occlusion   the same search, then the tutorial's interpolation between layers i - 1 and
//               i by the heights' distances to the ray:
//               w = (h_i - ray_i) / ((h_i - ray_i) - (h_{i-1} - ray_{i-1})),
//               uv = mix(uv_i, uv_{i-1}, w).
// A constant height h gives exactly uv - fBumpScale * v.xy / v.z * (1 - h) under parallax
// and occlusion (hand-derived in tests/test_parallax.cpp).
//
// SELF-SHADOW. From the parallax uv and its height h0, march toward the light
// (l = tangent-space light direction) in fShadowLayers equal steps from h0 up to 1: each
// step raises the ray by (1 - h0) / n and moves uv by fBumpScale * l.xy / l.z times that;
// if the height map is above the ray at any step, the point is in its own shadow (0),
// otherwise lit (1). A light at or below the tangent plane (l.z <= 0) shadows (0).
//
// Texture lookups are textureGrad(sampler, uv, dFdx(texCoord), dFdy(texCoord)) with the
// derivatives of the unshifted texCoord, as the tutorial passes them (its loop branches).
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include <glm/glm.hpp>

#include "tessref/texture.h"

namespace tessref {

// The uv derivatives of a triangle: dP/du and dP/dv (see TANGENT FRAME). Both zero when the
// triangle's uv are degenerate (r = 0 or not finite).
struct UvDerivatives {
    glm::vec3 dPdu{0.0f};
    glm::vec3 dPdv{0.0f};
};
UvDerivatives triangle_uv_derivatives(glm::vec3 p0, glm::vec3 p1, glm::vec3 p2, glm::vec2 uv0, glm::vec2 uv1,
                                      glm::vec2 uv2);

// The orthonormal tangent frame at a fragment: t', b', n (see TANGENT FRAME). n is the
// normalized normal; with no usable dP/du (zero, or parallel to n) t' is any unit vector
// perpendicular to n (the one closest to x, else z).
struct TangentFrame {
    glm::vec3 tangent{1.0f, 0.0f, 0.0f};
    glm::vec3 bitangent{0.0f, 1.0f, 0.0f};
    glm::vec3 normal{0.0f, 0.0f, 1.0f};
};
TangentFrame tangent_frame(glm::vec3 normal, const UvDerivatives& uv_derivatives);

// World direction -> tangent space: (dot(d, t'), dot(d, b'), dot(d, n)).
glm::vec3 to_tangent_space(const TangentFrame& frame, glm::vec3 direction);

// The normal map at uv (sampler s2NormalTexture) in world space (see NORMAL MAP).
glm::vec3 normal_map(const TangentFrame& frame, const Texture* s2NormalTexture, glm::vec2 uv, glm::vec2 dx,
                     glm::vec2 dy);

enum class ParallaxMode : std::uint8_t { none, parallax, steep, occlusion };
// "none", "parallax", "steep", "occlusion".
const char* to_string(ParallaxMode mode);
std::optional<ParallaxMode> parallax_mode_from_string(std::string_view name);

struct ParallaxParams {
    ParallaxMode mode = ParallaxMode::occlusion;
    float fBumpScale = 0.05f;
    float fMinLayers = 5.0f;    // the tutorial's constants
    float fMaxLayers = 15.0f;
    float fShadowLayers = 30.0f;  // "shadows will need more steps"
};

// The number of layers for a tangent-space view direction: round(mix(fMaxLayers,
// fMinLayers, |v.z|)), round half to even.
float parallax_layers(glm::vec3 tangent_view, const ParallaxParams& params);

// The shifted uv for the unit tangent-space view direction v (toward the eye). mode none
// returns uv.
glm::vec2 parallax_uv(glm::vec3 tangent_view, glm::vec2 uv, const Texture* s2BumpTexture, glm::vec2 dx,
                      glm::vec2 dy, const ParallaxParams& params);

// 1 lit, 0 in the height map's own shadow, for the unit tangent-space light direction l
// (toward the light) at uv (see SELF-SHADOW).
float parallax_shadow(glm::vec3 tangent_light, glm::vec2 uv, const Texture* s2BumpTexture, glm::vec2 dx,
                      glm::vec2 dy, const ParallaxParams& params);

}  // namespace tessref
