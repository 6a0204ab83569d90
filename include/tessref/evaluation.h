// tessref/evaluation.h — the tessellation evaluation stage: one gl_TessCoord -> one vertex.
//
// Pure functions mirroring the evaluation shaders in data/shaders/:
//   thesis_evaluate    thesis_terrain.tese    bilinear mix of the 4 corners, height from
//                                             texture(heightMap, xy / scaleXY).r * scaleZ
//   cosc422_evaluate   cosc422_terrain.tese   bilinear mix, height = texture(...).r * 10 in y
//   lab4_evaluate      lab4_terrain.tese      bilinear mix, height from the mip level that
//                                             matches the tessellation level (textureLod)
//   lab4_vertex_normal lab4_terrain.tese      appendix A's normal from the height field
//   pn_evaluate        pn_triangles.tese      PN triangle, influence 0.75
// Each is a template over the scalar: float (GPU-faithful, the shader's operations in its
// order) or double (accuracy), chosen per call; both are instantiated in src/evaluation/.
// The tess coord comes from the primitive generator: TessCoord (float) for the float path,
// TessCoordExact (double) for the double path.
//
// mix() is computed as llvmpipe computes it, x + a * (y - x) with each operation rounded
// (not glm's x * (1 - a) + y * a): float positions then equal `tessref gl --capture`'s bit for
// bit. mix(x, y, 0) == x exactly, and mix(x, y, 1) == y whenever y - x is exact in float
// (Sterbenz: y/2 <= x <= 2y, or both on a common grid as patch corners are), so a corner
// tess coord gives the corner bit for bit and a vertex on a shared edge depends only on
// that edge's two corners: neighbouring patches compute the same bits given the same tess
// coordinate along the edge. Corners for which y - x rounds could crack on llvmpipe too;
// `tessref check` would find such a crack in the exported mesh.
//
// Quad corner layout: see control.h (c0 = (0,0), c1 = (0,1), c2 = (1,1), c3 = (1,0)).
#pragma once

#include <array>
#include <span>

#include <glm/glm.hpp>

#include "tessref/control.h"
#include "tessref/tessellator.h"

namespace tessref {

// One evaluated vertex.
template <typename T>
struct EvaluatedVertex {
    vec3_t<T> position{T(0)};           // world space, after displacement (the mesh vertex)
    vec4_t<T> glPosition{T(0)};         // gl_Position = mvp * vec4(position, 1)
    vec2_t<T> textureCoordinate{T(0)};  // the TES's texture coordinate output
    vec3_t<T> normal{T(0)};             // pn_evaluate, and lab4_evaluate with gridStep > 0;
                                        // zero otherwise
};

// ---------------------------------------------------------------------------------------
// Thesis, thesis_terrain.tese (z up).
//   adPosition = mix(tcPosition[0], tcPosition[3], u); bcPosition = mix(tcPosition[1],
//   tcPosition[2], u); position = mix(adPosition, bcPosition, v);
//   textureCoordinate = position.xy / scaleXY;
//   height = texture(heightMap, textureCoordinate).r * scaleZ;
//   positionWithHeight = vec4(position.x, position.y, height, 1); gl_Position = mvp * it.
// The corners' own z (the vertex shader's height) is interpolated and then discarded, as in
// the shader: the height comes only from the texture.
// ---------------------------------------------------------------------------------------
template <typename T>
struct ThesisEvaluation {
    Sampler2D<T> heightMap;
    mat4_t<T> mvp{T(1)};
    T scaleXY = T(1);
    T scaleZ = T(1);
};
template <typename T>
EvaluatedVertex<T> thesis_evaluate(const std::array<vec4_t<T>, 4>& tcPosition,
                                   const DomainPoint<T>& glTessCoord,
                                   const ThesisEvaluation<T>& evaluation);
// thesis_evaluate at many domain points of one patch, for the mesh: position[k] and
// textureCoordinate[k] are thesis_evaluate(tcPosition, glTessCoord[k], evaluation)'s bit for
// bit, where evaluation samples through `heightMap`'s red channel (one call per block of
// points instead of one per point); gl_Position, which the pipeline does not keep, is not computed. The three
// spans have the same size.
template <typename T>
void thesis_evaluate_batch(const std::array<vec4_t<T>, 4>& tcPosition,
                           std::span<const DomainPoint<T>> glTessCoord, const Sampler2DRedBatch<T>& heightMap,
                           T scaleXY, T scaleZ, std::span<vec3_t<T>> position,
                           std::span<vec2_t<T>> textureCoordinate);

// ---------------------------------------------------------------------------------------
// COSC422, cosc422_terrain.tese (y up). posn = the same bilinear mix of gl_in[0..3];
// s = (x - xMin) / (xMax - xMin), t = (z - zMin) / (zMax - zMin) with the assignment's
// x in [-45, 45] and z from 0 (zMin) to -100 (zMax); posn.y = texture(heightMap, (s,t)).r
// * heightScale (10).
// ---------------------------------------------------------------------------------------
template <typename T>
struct Cosc422Evaluation {
    Sampler2D<T> heightMap;
    mat4_t<T> mvpMatrix{T(1)};
    T xMin = T(-45), xMax = T(45);
    T zMin = T(0), zMax = T(-100);
    T heightScale = T(10);
};
template <typename T>
EvaluatedVertex<T> cosc422_evaluate(const std::array<vec4_t<T>, 4>& glInPosition,
                                    const DomainPoint<T>& glTessCoord,
                                    const Cosc422Evaluation<T>& evaluation);

// ---------------------------------------------------------------------------------------
// Lab 4, lab4_terrain.tese (y up). position = the bilinear mix of the corners (y = 0);
// texCoord = position.xz / horizontalScale + texCoordOffset;
// height = textureLod(heightMap, texCoord, maxLogTessellationLevel - logTessellationLevel).r
// * verticalScale, where logTessellationLevel is chosen per vertex by lab4_vertex_log_level
// (edge vertices use their edge's level, corners their corner level, see control.h).
// ---------------------------------------------------------------------------------------
template <typename T>
struct Lab4Evaluation {
    Sampler2DLod<T> heightMap;
    mat4_t<T> mvp{T(1)};
    T horizontalScale = T(1);  // world units per texture-coordinate unit
    T verticalScale = T(1);
    vec2_t<T> texCoordOffset{T(0)};
    // > 0: also the appendix-A normal (lab4_vertex_normal below) with this grid step
    // h, sampled at the vertex's own lod, as the lab computes normals in this shader.
    T gridStep = T(0);
};
// Lab 4 appendix A, y up: with H(x, z) = (x, height(x, z), z),
//   N = normalize((H(x+h, z) - H(x, z)) x (H(x, z+h) - H(x, z)))
// where height(x, z) = textureLod(heightMap, (x, z) / horizontalScale + texCoordOffset,
// lod).r * verticalScale and h is the height-map grid step in world units.
// Not kept: in a right-handed y-up frame the appendix's operand order gives the normal
// pointing down (cross(x, z) = -y); this returns the upward one, which is exactly the
// negation of the appendix's expression (the operands swapped), because lab 4 uses the
// normal for Phong lighting and for its slope rule (y near 1 = flat).
template <typename T>
struct Lab4NormalSampling {
    Sampler2DLod<T> heightMap;
    T horizontalScale = T(1);
    T verticalScale = T(1);
    vec2_t<T> texCoordOffset{T(0)};
    T h = T(1);  // grid step in world units
    T lod = T(0);
};
template <typename T>
vec3_t<T> lab4_vertex_normal(T x, T z, const Lab4NormalSampling<T>& sampling);

// logTessellationLevel for a tess coord: u == 0 -> edge 0, v == 0 -> edge 1, u == 1 ->
// edge 2, v == 1 -> edge 3; two of them at once -> that corner; otherwise logInner.
template <typename T>
T lab4_vertex_log_level(const DomainPoint<T>& glTessCoord, const Lab4Lod<T>& lod);
template <typename T>
EvaluatedVertex<T> lab4_evaluate(const std::array<vec4_t<T>, 4>& tcPosition,
                                 const DomainPoint<T>& glTessCoord, const Lab4Lod<T>& lod,
                                 const Lab4Evaluation<T>& evaluation);

// ---------------------------------------------------------------------------------------
// PN triangles, pn_triangles.tese. (u, v, w) = gl_TessCoord weights P030, P003, P300:
//   v3PNPoint = P030 uuu + P003 vvv + P300 www + P021 3uu v + P012 3vv u + P102 3vv w
//             + P201 3ww v + P210 3ww u + P120 3uu w + P111 6 w u v        (that order)
//   v3BasePosition = P030 u + P003 v + P300 w
//   position = mix(v3BasePosition, v3PNPoint, fInfluence)                   (0.75)
// Normal: PnNormal::linear is the tutorial's v3NormalOut = N0 u + N1 v + N2 w (not
// normalized, as the tutorial leaves it); PnNormal::quadratic is Vlachos et al.'s quadratic
// normal N0 uu + N1 vv + N2 ww + n01 uv + n12 vw + n20 wu, normalized (the default).
// Watertight edges (default on): when exactly one of u, v, w is 0 the vertex lies on an
// edge; the tutorial's sum order then depends on which way round the patch holds that edge,
// so its two patches can differ in the last bit. With watertightEdges the four non-zero
// terms (and the normal's) are summed in the canonical order of the edge's end points
// instead; off reproduces the tutorial's sum order exactly.
// ---------------------------------------------------------------------------------------
enum class PnNormal : std::uint8_t { linear, quadratic };
template <typename T>
struct PnEvaluationParams {  // [evaluation] model = "pn" (control.h: STAGE PARAMETERS)
    T fInfluence = T(0.75);
    PnNormal normal = PnNormal::quadratic;
    bool watertightEdges = true;

    template <typename U>
    PnEvaluationParams<U> as() const {
        return {static_cast<U>(fInfluence), normal, watertightEdges};
    }
};
template <typename T>
struct PnEvaluation : PnEvaluationParams<T> {
    mat4_t<T> m4ViewProjection{T(1)};
};
template <typename T>
EvaluatedVertex<T> pn_evaluate(const PnPatch<T>& patch, const DomainPoint<T>& glTessCoord,
                               const PnEvaluation<T>& evaluation = {});

}  // namespace tessref
