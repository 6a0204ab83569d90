// tessref/control.h — the tessellation control stage: per-patch tessellation levels.
//
// Every model here is a pure function of plain data (patch corners, camera, viewport,
// samplers) and mirrors a control shader in data/shaders/ line by line:
//   constant           any scene                 (all six levels = one number)
//   thesis_*           thesis_terrain.tesc       distance, tessellation-map and normal
//                                                factors, alone or by formula (2)
//   cosc422_*          cosc422_terrain.tesc      level = (z_avg+100)*18/100 + 2, world or eye z
//   lab4_*             lab4_terrain.tesc         power-of-two distance zones, equal spacing
//   pn_*               pn_triangles.tesc         projected-sphere level, PN control points
//
// CRACK-FREEDOM CONTRACT. Every outer level is computed from the data of its own edge
// only (its two end points, plus scene-wide uniforms), by a computation that gives the
// same bits whichever way round the two end points are passed. Two patches that share an
// edge therefore always write bitwise-equal gl_TessLevelOuter for it. Where a source
// computes something direction-dependent (the thesis's a + (b - a)/2), the end points are
// first put in canonical order (canonical_edge: lexicographic x, then y, then z); for the
// grid layout below this is exactly the direction the thesis uses, so its values are kept
// bit for bit. Inner levels follow each source (average of the edge factors, max, ...).
//
// PATCH LAYOUT (all quad models; the evaluation stage uses the same):
//   corners[0..3] are the thesis's vPosition[0..3]; the evaluation maps gl_TessCoord (u, v)
//   to mix(mix(c0, c3, u), mix(c1, c2, u), v), so
//     c0 = (u,v) (0,0),  c1 = (0,1),  c2 = (1,1),  c3 = (1,0).
//   gl_TessLevelOuter[i] belongs to the edge (kQuadEdges[i]):
//     outer[0] u = 0: c0-c1 (thesis "ab")     outer[1] v = 0: c0-c3 (thesis "ad")
//     outer[2] u = 1: c3-c2 (thesis "dc")     outer[3] v = 1: c1-c2 (thesis "bc")
//   With ccw winding the triangles face cross(c3 - c0, c1 - c0). The thesis's values are
//   reproduced bit for bit when u runs along +x and v along +y (c0 = (x0,y0), c1 = (x0,y1),
//   c2 = (x1,y1), c3 = (x1,y0), x0 < x1, y0 < y1): then every thesis edge direction
//   (a -> b, d -> c, a -> d, b -> c) is the canonical one.
// Triangle patches (PN): corners[0..2] have gl_TessCoord (1,0,0), (0,1,0), (0,0,1);
//   outer[0] u = 0: c1-c2, outer[1] v = 0: c2-c0, outer[2] w = 0: c0-c1 (kTriangleEdges).
//
// PRECISION. Each model is a template over the scalar: float is the GPU-faithful path
// (the shader's operations in the shader's order, float rounding at each step), double the
// accuracy path (same formula). Both are instantiated in src/control/. Transcendentals
// (acos, log2) and the vector built-ins come in two math modes (MathMode, below): exact, the
// C library's correctly rounded functions and glm (the default, and the only mode of the
// double path), or, in float, llvmpipe's own approximations and orders of operations
// (src/shader/llvmpipe_math.h), which put the thesis's normal factor off the exact one by up
// to thousands of ulps. Either way both patches of an edge compute alike, so no mode can open
// a crack.
// The compiler must not contract a*b+c into fma (the project builds with ISO C++, where
// GCC's default is -ffp-contract=off; x86-64 without -mfma has no fma anyway; the build
// also says -ffp-contract=off explicitly).
//
// STAGE PARAMETERS. A model's uniforms come in two parts. Its *Params struct (or, for
// constant, ConstantControl) holds what a scene file sets, one field per [control] key,
// spelled as the shader spells the uniform; the Scene keeps it in double. The model's full
// struct derives from it and adds what the pipeline binds from elsewhere (camera, viewport,
// samplers). as<float>() converts the scene's values once for the gpu path.
//
// QUIRKS KEPT (each because the shader that ran does it; see docs in each section):
//   thesis: DistanceFactor returns (50 - d)/10, i.e. 0..5, not 0..1 as the text says;
//           the normal factor is a sum of four angles in radians (0 or > 0.9, up to 4*pi);
//           so formula (2) can exceed 64 (the primitive generator clamps); the normal-map
//           decode subtracts 0.5 from n/255, so no byte decodes to exactly 0; the normal factor's probe points lie on the
//           edge's own line (offsets +-(b - a)), not across it as the thesis's figure 4 shows.
//   cosc422: the ramp is not clamped: an eye-space z below -111.1 gives a level <= 0, which
//           culls the patch, exactly as the shader would.
//   pn:     the "projected sphere" uses clip-space gl_Position.xyz without dividing by w,
//           and only the y resolution, as the tutorial's tessLevel() does.
// DEVIATIONS (each needed for the crack-freedom contract, documented per function):
//   thesis normal factor: probe offsets come from the edge itself, not from the patch's
//           shared left/right/up/down vectors (equal for a parallelogram grid);
//   cosc422: an outer level uses the z average of its edge's two end points; only the
//           inner level uses the assignment's 4-corner average;
//   lab4:   an edge's level is min (or max) of the zone levels of the two patches beside it,
//           whose centres are computed from the edge alone;
//   pn:     an edge whose two end-point normals are equal gets level 1 (a flat patch,
//           all three normals equal, therefore gets 1 everywhere, as the tutorial asks).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <span>

#include <glm/glm.hpp>

#include "tessref/tessellator.h"

namespace tessref {

// How the float path computes GLSL's built-ins: exact, glm and the C library (acos and log2
// correctly rounded, dot products summed from the first component; what `render`, `mesh`
// and the goldens use unless --math says otherwise), or llvmpipe, bit for bit as Mesa's
// llvmpipe computes them (src/shader/llvmpipe_math.h: its acos and log2 approximations, dot,
// length, distance and normalize summed from the last component, a matrix times a vector
// summed column by column; what `tessref gl` predicts its draws with). The double path
// always uses exact.
enum class MathMode : std::uint8_t { exact, llvmpipe };

// ---------------------------------------------------------------------------------------
// Common types
// ---------------------------------------------------------------------------------------

template <typename T>
using vec2_t = glm::vec<2, T, glm::defaultp>;
template <typename T>
using vec3_t = glm::vec<3, T, glm::defaultp>;
template <typename T>
using vec4_t = glm::vec<4, T, glm::defaultp>;
template <typename T>
using mat3_t = glm::mat<3, 3, T, glm::defaultp>;
template <typename T>
using mat4_t = glm::mat<4, 4, T, glm::defaultp>;

// GLSL's texture(sampler, uv): all four channels of a filtered sample (a one-channel map
// returns its value in .r). Outside a fragment shader texture() samples the base level, so
// the orchestrator wraps the height-field Texture's level-0 lookup in a lambda; tests pass
// analytic functions.
template <typename T>
using Sampler2D = std::function<vec4_t<T>(vec2_t<T> uv)>;
// Sampler2D at many coordinates in one call: out[k] = texture(sampler, uv[k]) for every k
// (uv and out have the same size). The evaluation reads the height and normal maps of a
// block of points through it, one call per block instead of one per point.
template <typename T>
using Sampler2DBatch = std::function<void(std::span<const vec2_t<T>> uv, std::span<vec4_t<T>> out)>;
// Sampler2DBatch's red channel alone: red[k] = texture(sampler, uv[k]).r. The evaluation's
// height reads use nothing else.
template <typename T>
using Sampler2DRedBatch = std::function<void(std::span<const vec2_t<T>> uv, std::span<T> red)>;
// GLSL's textureLod(sampler, uv, lod).
template <typename T>
using Sampler2DLod = std::function<vec4_t<T>(vec2_t<T> uv, T lod)>;

// gl_TessLevelOuter[4] / gl_TessLevelInner[2] in the model's precision. For the primitive
// generator, to_tess_levels() rounds to float (both patches of an edge round the same bits).
template <typename T>
struct PatchLevels {
    std::array<T, 4> outer{T(1), T(1), T(1), T(1)};
    std::array<T, 2> inner{T(1), T(1)};
};
template <typename T>
TessLevels to_tess_levels(const PatchLevels<T>& levels) {
    TessLevels out;
    for (int i = 0; i < 4; ++i) out.outer[i] = static_cast<float>(levels.outer[i]);
    for (int i = 0; i < 2; ++i) out.inner[i] = static_cast<float>(levels.inner[i]);
    return out;
}

// Corner indices of each outer edge, in gl_TessLevelOuter order (see PATCH LAYOUT).
inline constexpr std::array<std::array<int, 2>, 4> kQuadEdges{{{0, 1}, {0, 3}, {3, 2}, {1, 2}}};
inline constexpr std::array<std::array<int, 2>, 3> kTriangleEdges{{{1, 2}, {2, 0}, {0, 1}}};

template <typename T>
using QuadCorners = std::array<vec3_t<T>, 4>;
template <typename T>
using TriangleCorners = std::array<vec3_t<T>, 3>;

// The two end points of an edge in canonical order: a <= b lexicographically on
// (x, y, z). canonical_edge(a, b) and canonical_edge(b, a) return the same pair.
template <typename T>
struct Edge {
    vec3_t<T> a, b;
};
template <typename T>
Edge<T> canonical_edge(const vec3_t<T>& p, const vec3_t<T>& q);

// ---------------------------------------------------------------------------------------
// Constant model: every level = level (the thesis's "constant 1" and "constant 64").
// ---------------------------------------------------------------------------------------
template <typename T>
struct ConstantControl {  // [control] model = "constant"
    T level = T(1);
};
template <typename T>
PatchLevels<T> constant_levels(T level);

// ---------------------------------------------------------------------------------------
// Thesis (Jakobsen 2012), data/shaders/thesis_terrain.{vert,tesc}. z is up; the patch
// corners are the vertex shader's vPosition (x, y, height*scaleZ).
// ---------------------------------------------------------------------------------------

// The vertex shader (thesis_terrain.vert, main): textureCoordinate = position.xy / scaleXY,
// height = texture(heightMap, textureCoordinate).r * scaleZ; returns vec4(x, y, height, 1).
template <typename T>
vec4_t<T> thesis_vertex(const vec2_t<T>& position, const Sampler2D<T>& heightMap, T scaleXY,
                        T scaleZ);

// DistanceFactor (thesis_terrain.tesc, distance_factor): d > limit ? 0 : (limit - d) / divisor,
// with the shader's `int limit = 50` and `/ 10` as defaults: 5 at d = 0, 0 beyond 50.
template <typename T>
struct ThesisDistance {
    T limit = T(50);
    T divisor = T(10);
};
template <typename T>
T distance_factor(T distance, const ThesisDistance<T>& params = {});

// NormalFromTexture as the control shader has it (no normalMatrix): normalize(rgb - 0.5).
template <typename T>
vec3_t<T> normal_from_texture(const vec3_t<T>& rgb, MathMode math = MathMode::exact);

// The weights of formula (2); defaults are the shader's (normal 5, texture 5, distance 5,
// constant 1).
template <typename T>
struct ThesisWeights {
    T constant = T(1);
    T normal = T(5);
    T texture = T(5);
    T distance = T(5);
};

// Which factor drives the levels: each alone, as the commented-out blocks of the shader
// (level = tessellationLevel * factor + 1), or all by formula (2).
enum class ThesisFactor : std::uint8_t { distance, tessellation_map, normal, all };

// The control shader's uniforms that a scene sets ([control] model = "thesis"; STAGE
// PARAMETERS below).
template <typename T>
struct ThesisControlParams {
    ThesisFactor factor = ThesisFactor::all;
    T tessellationLevel = T(1);  // uniform tessellationLevel (the text's userDecidedLevel)
    ThesisDistance<T> distance{};
    ThesisWeights<T> weights{};
    T normalAngleThreshold = T(0.90);  // radians, the shader's `> 0.90`

    template <typename U>
    ThesisControlParams<U> as() const {
        const auto u = [](T x) { return static_cast<U>(x); };
        return {factor, u(tessellationLevel), {u(distance.limit), u(distance.divisor)},
                {u(weights.constant), u(weights.normal), u(weights.texture), u(weights.distance)},
                u(normalAngleThreshold)};
    }
};

// All the control shader's uniforms: the scene's, plus what the pipeline binds from the
// domain, the camera and the textures. A sampler may be empty when the chosen factor does
// not read it (distance alone reads neither map; tessellation_map reads tessellationMap;
// normal reads normalMap; all reads both).
template <typename T>
struct ThesisControl : ThesisControlParams<T> {
    MathMode math = MathMode::exact;  // acos of the normal factor (float only)
    T scaleXY = T(1);
    vec3_t<T> cameraPosition{T(0)};
    Sampler2D<T> tessellationMap;
    Sampler2D<T> normalMap;
};

// The three factors of one edge, each computed from that edge alone.
template <typename T>
struct ThesisEdgeFactors {
    T distanceTessellation = T(0);  // DistanceFactor(distance(midpoint, cameraPosition)), 0..5
    T textureTessellation = T(0);   // texture(tessellationMap, midpoint.xy / scaleXY).r, 0..1
    T normalTessellation = T(0);    // normalTessFactor over the six probes: 0 or sum of angles
};

// Which way an edge runs: along_v for ab and dc (u constant, outer[0] and outer[2]; the
// shader offsets their probes by left = a - b and right = b - a), along_u for ad and bc
// (v constant, outer[1] and outer[3]; offsets down = b - a and up = a - b). The two
// patches of a shared edge always see it running the same way.
enum class ThesisEdgeDirection : std::uint8_t { along_v, along_u };

// The factors of edge (p, q); only those the chosen factor needs are computed (the others
// stay 0). Midpoint: a + (b - a)/2 on the canonical edge (thesis equation (1)).
// Normal probes (the shader's abvertices[0..5] for edge a -> b, with minus = left or down
// and plus = right or up, see ThesisEdgeDirection): a, b, a + minus, b + minus, a + plus,
// b + plus, xy only, each decoded by
// normal_from_texture(texture(normalMap, probe / scaleXY).xyz); the factor is the sum
// of the angles acos(n0.n3), acos(n2.n1), acos(n0.n5), acos(n1.n4) when any exceeds the
// threshold, else 0 (normalTessFactor). The shader takes left/right from edge ab and
// up/down from edge bc for all four edges; here each edge uses its own vector (bit for bit
// the same for ab and bc, and for dc and ad whenever the grid's differences are exact), so
// the factor depends on the edge alone.
// NOT kept: the seed's acos(dot) is unclamped, and in float a unit normal's self-dot that
// rounds above 1 gives NaN, a NaN outer level and a culled patch (a hole). Both precisions
// and the GLSL twin clamp the dot product into [-1, 1].
template <typename T>
ThesisEdgeFactors<T> thesis_edge_factors(const vec3_t<T>& p, const vec3_t<T>& q,
                                         ThesisEdgeDirection direction,
                                         const ThesisControl<T>& control);

// Level from factors: formula (2) for ThesisFactor::all,
//   1 + (cTW + nT*nTW + tT*tTW + DT*dTW) / (cTW + nTW + tTW + dTW) * tessellationLevel
// (the shader's operation order), else tessellationLevel * factor + 1.
template <typename T>
T thesis_level(const ThesisEdgeFactors<T>& factors, const ThesisControl<T>& control);

// The whole control shader: outer[i] from the factors of edge kQuadEdges[i]; inner[0] =
// inner[1] from the average of the four edge factors, (ab + ad + dc + bc) / 4 in that order.
template <typename T>
PatchLevels<T> thesis_levels(const QuadCorners<T>& vPosition, const ThesisControl<T>& control);

// ---------------------------------------------------------------------------------------
// COSC422 terrain exercise, data/shaders/cosc422_terrain.tesc. y is up, the terrain base
// plane is x in [-45, 45], z in [0, -100]; the corners are the pass-through vertex
// shader's output (flat, y = 0).
// ---------------------------------------------------------------------------------------

// level = (z_avg + 100) * 18 / 100 + 2, evaluated in that order: 2 at z_avg = -100,
// 20 at z_avg = 0. Not clamped (see QUIRKS).
template <typename T>
T cosc422_level(T z_avg);

enum class Cosc422Space : std::uint8_t { world, eye };

// outer[i] = cosc422_level((z_a + z_b) / 2) over the end points of edge kQuadEdges[i];
// inner[0] = inner[1] = cosc422_level((z0 + z1 + z2 + z3) / 4), the assignment's formula.
// In eye space z is (modelView * vec4(corner, 1)).z of each corner (modelView is ignored in
// world space).
template <typename T>
PatchLevels<T> cosc422_levels(const QuadCorners<T>& corners, Cosc422Space space,
                              const mat4_t<T>& modelView = mat4_t<T>(T(1)));

// ---------------------------------------------------------------------------------------
// Lab 4 (terrain rendering assignment), data/shaders/lab4_terrain.tesc. y is up; the
// camera-centred grid lies in the x-z plane (y = 0) as the pass-through vertex shader
// hands it over; equal_spacing, power-of-two levels.
// ---------------------------------------------------------------------------------------

// Zones: [0, firstZoneEnd) gets maxLevel; each next zone [end_k, end_k * zoneGrowth) gets
// half the level of the one before, down to minLevel. Zone ends are end_0 = firstZoneEnd,
// end_{k+1} = end_k * zoneGrowth, compared with >= so a distance exactly on a boundary
// belongs to the farther zone. maxLevel and minLevel must be powers of two.
enum class Lab4EdgeRule : std::uint8_t { lower, higher };
template <typename T>
struct Lab4ControlParams {  // [control] model = "lab4"
    T firstZoneEnd = T(50);  // the lab's example zones: 0-50, 50-500, 500-5000 (growth 10)
    T zoneGrowth = T(2);
    T maxLevel = T(64);
    T minLevel = T(1);
    Lab4EdgeRule edgeRule = Lab4EdgeRule::lower;  // "chose the lower or higher one consistently"

    template <typename U>
    Lab4ControlParams<U> as() const {
        return {static_cast<U>(firstZoneEnd), static_cast<U>(zoneGrowth), static_cast<U>(maxLevel),
                static_cast<U>(minLevel), edgeRule};
    }
};
template <typename T>
struct Lab4Control : Lab4ControlParams<T> {
    MathMode math = MathMode::exact;  // log2 of the LOD outputs (float only)
    vec3_t<T> cameraPosition{T(0)};
};

template <typename T>
T lab4_zone_level(T distance, const Lab4Control<T>& control);

// What the lab's TCS passes to its TES besides the levels: log2 of the levels, so the
// evaluation samples mip maxLogTessellationLevel - logTessellationLevel. A vertex on edge i
// uses logOuter[i], a patch corner uses logCorner[corner] (the zone level at the corner's
// own distance, so every patch around a corner picks the same mip), any other vertex uses
// logInner. (The lab suggests one log per patch; that would sample the two sides of an
// edge from different mips and open a crack.)
template <typename T>
struct Lab4Lod {
    T maxLogTessellationLevel = T(0);  // log2(maxLevel)
    std::array<T, 4> logOuter{};
    T logInner = T(0);
    std::array<T, 4> logCorner{};
};

template <typename T>
struct Lab4ControlOutput {
    PatchLevels<T> levels;
    Lab4Lod<T> lod;
};

// The patch's own level: zone level of its centre (c0 + c1 + c2 + c3) * 0.25 -> inner.
// outer[i]: min (lower) or max (higher) of the zone levels of the two patches beside edge
// kQuadEdges[i], whose centres are m +- r with m = (a + b) * 0.5 and
// r = (-(b.z - a.z), 0, b.x - a.x) * 0.5 on the canonical edge (the grid is square).
template <typename T>
Lab4ControlOutput<T> lab4_control(const QuadCorners<T>& corners, const Lab4Control<T>& control);

// ---------------------------------------------------------------------------------------
// PN triangles (tutorial 8), data/shaders/pn_triangles.tesc.
// ---------------------------------------------------------------------------------------

// tessLevel(): the projected-sphere level of the edge between two clip-space positions
// (gl_Position.xyz, not divided by w):
//   v2P1 = (p1.xy + p2.xy) * 0.5; v2P2 = v2P1; v2P2.y += distance(p1, p2);
//   fLength = length((v2P1 - v2P2) * v2Resolution * 0.5); clamp(fLength / 4, 1, 32).
// Symmetric in p1, p2 bit for bit (sum, midpoint and distance are).
template <typename T>
struct PnControlParams {  // [control] model = "pn"
    T fPixelsPerEdge = T(4);
    T minLevel = T(1);
    T maxLevel = T(32);
    bool flatEdgesAtLevel1 = true;  // the tutorial's extra 36, per edge (see DEVIATIONS)

    template <typename U>
    PnControlParams<U> as() const {
        return {static_cast<U>(fPixelsPerEdge), static_cast<U>(minLevel), static_cast<U>(maxLevel),
                flatEdgesAtLevel1};
    }
};
template <typename T>
struct PnControl : PnControlParams<T> {
    MathMode math = MathMode::exact;  // distance and length of the level (float only)
    vec2_t<T> v2Resolution{T(1280), T(800)};  // the camera's viewport
};
template <typename T>
T pn_tess_level(const vec3_t<T>& v3Point1, const vec3_t<T>& v3Point2,
                const PnControl<T>& control = {});

// outer[0] = tessLevel(gl_in[1], gl_in[2]), outer[1] = (2, 0), outer[2] = (0, 1);
// inner[0] = max(outer[0], max(outer[1], outer[2])). With flatEdgesAtLevel1, an edge whose
// two vertex normals compare equal gets 1. outer[3] and inner[1] are unused and set to 1.
template <typename T>
PatchLevels<T> pn_levels(const std::array<vec4_t<T>, 3>& glPosition,
                         const TriangleCorners<T>& v3VertexNormal, const PnControl<T>& control = {});

// The PN control points the tutorial's TCS writes (per invocation i, next = (i+1) % 3):
//   v3PatchE1[i] = (2*P_i + projectToPlane(P_next, P_i, N_i)) / 3
//   v3PatchE2[i] = (2*P_next + projectToPlane(P_i, P_next, N_next)) / 3
// with N = normalize(v3VertexNormal), and the centre v3P111 = E + (E - V) / 2 where E is the
// average of the six edge points and V of the three corners. Named as in the tutorial:
//   P030 = pos[0], P021 = E1[0], P012 = E2[0], P003 = pos[1], P102 = E1[1], P201 = E2[1],
//   P300 = pos[2], P210 = E1[2], P120 = E2[2].
// The Vlachos quadratic normal coefficients are added (not in the tutorial), one per edge i
// (from P_i to P_next): n_i = normalize(N_i + N_next - v * (P_next - P_i)) with
// v = 2 * dot(P_next - P_i, N_i + N_next) / dot(P_next - P_i, P_next - P_i); swapping the
// end points negates both v and the edge vector exactly, so both patches of an edge get
// the same bits (as E1/E2, whose swap gives E2/E1 by the same operations).
template <typename T>
struct PnPatch {
    std::array<vec3_t<T>, 3> v3VertexPos{};
    std::array<vec3_t<T>, 3> v3VertexNormal{};  // as given (the evaluation's linear normal)
    std::array<vec2_t<T>, 3> v2VertexUV{};
    std::array<vec3_t<T>, 3> v3PatchE1{};
    std::array<vec3_t<T>, 3> v3PatchE2{};
    vec3_t<T> v3P111{T(0)};
    std::array<vec3_t<T>, 3> v3EdgeNormal{};  // quadratic normal midpoint terms, edge i -> i+1
};

template <typename T>
vec3_t<T> project_to_plane(const vec3_t<T>& v3Point, const vec3_t<T>& v3PlanePoint,
                           const vec3_t<T>& v3PlaneNormal);

template <typename T>
PnPatch<T> pn_patch(const TriangleCorners<T>& v3VertexPos, const TriangleCorners<T>& v3VertexNormal,
                    const std::array<vec2_t<T>, 3>& v2VertexUV = {});

}  // namespace tessref
