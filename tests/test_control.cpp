// The control stage (tessref/control.h): every level model against values derived by hand
// from the seeds' formulas, the crack-freedom contract (a shared edge gets bitwise-equal
// outer levels from both patches, whichever way round each holds it) as a randomized
// property over every model in float and double, and the GLSL twins: every shader in
// data/shaders compiles with glslangValidator as its stage, each pipeline links, and every
// "GLSL: file:line name" comment in the C++ stages points at a shader line naming it.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "tessref/control.h"

namespace {

using namespace tessref;
namespace fs = std::filesystem;

template <typename T>
auto bits(T x) {
    if constexpr (sizeof(T) == 4) {
        return std::bit_cast<std::uint32_t>(x);
    } else {
        return std::bit_cast<std::uint64_t>(x);
    }
}

// ---------------------------------------------------------------------------------------
// Hand values
// ---------------------------------------------------------------------------------------

TEST(CanonicalEdge, OrdersLexicographicallyAndIsSymmetric) {
    const glm::vec3 p(1, 2, 3), q(1, 2, 4), r(0, 9, 9);
    EXPECT_EQ(canonical_edge(p, q).a, p);
    EXPECT_EQ(canonical_edge(q, p).a, p);
    EXPECT_EQ(canonical_edge(p, r).a, r);
    EXPECT_EQ(canonical_edge(r, p).b, p);
}

TEST(Constant, EveryLevelIsTheConstant) {
    const PatchLevels<float> levels = constant_levels(64.0f);
    for (float level : levels.outer) EXPECT_EQ(level, 64.0f);
    for (float level : levels.inner) EXPECT_EQ(level, 64.0f);
    const TessLevels tess = to_tess_levels(constant_levels(1.0));
    EXPECT_EQ(tess.outer[3], 1.0f);
    EXPECT_EQ(tess.inner[1], 1.0f);
}

TEST(Thesis, VertexShaderLooksUpTheHeight) {
    const Sampler2D<float> heightMap = [](glm::vec2 uv) { return glm::vec4(uv.x + uv.y, 0, 0, 1); };
    // uv = (20, 10) / 40 = (0.5, 0.25): r = 0.75, height = 0.75 * 8 = 6.
    EXPECT_EQ(thesis_vertex(glm::vec2(20, 10), heightMap, 40.0f, 8.0f), glm::vec4(20, 10, 6, 1));
}

TEST(Thesis, DistanceFactorAtKnownDistances) {
    // (50 - d) / 10 for d <= 50, else 0: the shader's constants.
    EXPECT_EQ(distance_factor(0.0f), 5.0f);
    EXPECT_EQ(distance_factor(10.0f), 4.0f);
    EXPECT_EQ(distance_factor(25.0f), 2.5f);
    EXPECT_EQ(distance_factor(50.0f), 0.0f);   // 50 > 50 is false: (50 - 50) / 10
    EXPECT_EQ(distance_factor(50.5f), 0.0f);   // beyond the limit
    EXPECT_EQ(distance_factor(1000.0), 0.0);
    EXPECT_EQ(distance_factor(45.0), 0.5);
}

TEST(Thesis, NormalFromTextureSubtractsHalfAndNormalizes) {
    EXPECT_EQ(normal_from_texture(glm::vec3(0.5f, 0.5f, 1.0f)), glm::vec3(0, 0, 1));
    const glm::dvec3 n = normal_from_texture(glm::dvec3(0.75, 0.5, 0.6875));  // (0.25, 0, 0.1875)
    EXPECT_NEAR(n.x, 0.8, 1e-15);
    EXPECT_NEAR(n.z, 0.6, 1e-15);
    // The thesis's 8-bit encoding has no exact zero: 127/255 - 0.5 < 0 < 128/255 - 0.5.
    EXPECT_LT(normal_from_texture(glm::vec3(127 / 255.0f, 127 / 255.0f, 1.0f)).x, 0.0f);
}

TEST(Thesis, FormulaTwoWithTheShaderWeights) {
    ThesisControl<double> control;
    control.factor = ThesisFactor::all;
    control.tessellationLevel = 10;
    ThesisEdgeFactors<double> f;
    // All factors 0: 1 + (1 / 16) * 10 = 1.625.
    EXPECT_EQ(thesis_level(f, control), 1.625);
    // n = 0.5, t = 0.25, d = 2: (1 + 2.5 + 1.25 + 10) / 16 = 0.921875, level 10.21875.
    f.normalTessellation = 0.5;
    f.textureTessellation = 0.25;
    f.distanceTessellation = 2;
    EXPECT_EQ(thesis_level(f, control), 10.21875);
    // Distance factor 5 (at the camera) and everything else 1: (1+5+5+25)/16 = 2.25 -> 23.5,
    // above what the text's "0..1 factors" promise (the generator clamps to 64 later).
    f = {5.0, 1.0, 1.0};
    control.tessellationLevel = 10;
    EXPECT_EQ(thesis_level(f, control), 23.5);
}

TEST(Thesis, SingleFactorLevelsAreLevelTimesFactorPlusOne) {
    ThesisControl<float> control;
    control.tessellationLevel = 4;
    const ThesisEdgeFactors<float> f{2.5f, 0.5f, 1.75f};
    control.factor = ThesisFactor::distance;
    EXPECT_EQ(thesis_level(f, control), 11.0f);
    control.factor = ThesisFactor::tessellation_map;
    EXPECT_EQ(thesis_level(f, control), 3.0f);
    control.factor = ThesisFactor::normal;
    EXPECT_EQ(thesis_level(f, control), 8.0f);
}

QuadCorners<double> square(double x0, double y0, double size, double z = 0) {
    // The thesis layout: u along +x, v along +y.
    return {glm::dvec3(x0, y0, z), glm::dvec3(x0, y0 + size, z), glm::dvec3(x0 + size, y0 + size, z),
            glm::dvec3(x0 + size, y0, z)};
}

TEST(Thesis, DistanceLevelsOfOnePatch) {
    ThesisControl<double> control;
    control.factor = ThesisFactor::distance;
    control.tessellationLevel = 4;
    control.cameraPosition = glm::dvec3(0, 5, 0);
    const PatchLevels<double> levels = thesis_levels(square(0, 0, 10), control);
    // Edge midpoints: ab (0,5) at 0 -> factor 5 -> 21; ad (5,0) at sqrt(50); dc (10,5) at
    // 10 -> factor 4 -> 17; bc (5,10) at sqrt(50).
    const double diagonal = (50.0 - std::sqrt(50.0)) / 10.0;
    EXPECT_EQ(levels.outer[0], 21.0);
    EXPECT_NEAR(levels.outer[1], 4.0 * diagonal + 1.0, 1e-12);
    EXPECT_EQ(levels.outer[2], 17.0);
    EXPECT_NEAR(levels.outer[3], 4.0 * diagonal + 1.0, 1e-12);
    const double inner = 4.0 * (5.0 + diagonal + 4.0 + diagonal) / 4.0 + 1.0;
    EXPECT_NEAR(levels.inner[0], inner, 1e-12);
    EXPECT_EQ(levels.inner[0], levels.inner[1]);
}

TEST(Thesis, TessellationMapIsSampledAtTheEdgeMidpoint) {
    ThesisControl<float> control;
    control.factor = ThesisFactor::tessellation_map;
    control.tessellationLevel = 18;
    control.scaleXY = 20;
    std::vector<glm::vec2> seen;
    control.tessellationMap = [&](glm::vec2 uv) {
        seen.push_back(uv);
        return glm::vec4(uv.x + 2 * uv.y, 0, 0, 1);
    };
    const PatchLevels<float> levels = thesis_levels(
        QuadCorners<float>{glm::vec3(0, 0, 3), glm::vec3(0, 10, 4), glm::vec3(10, 10, 5), glm::vec3(10, 0, 6)},
        control);
    // Midpoints / 20: ab (0, 0.25), ad (0.25, 0), dc (0.5, 0.25), bc (0.25, 0.5).
    ASSERT_EQ(seen.size(), 4u);
    EXPECT_EQ(seen[0], glm::vec2(0, 0.25f));
    EXPECT_EQ(seen[1], glm::vec2(0.25f, 0));
    EXPECT_EQ(seen[2], glm::vec2(0.5f, 0.25f));
    EXPECT_EQ(seen[3], glm::vec2(0.25f, 0.5f));
    EXPECT_EQ(levels.outer[0], 18 * 0.5f + 1);
    EXPECT_EQ(levels.outer[1], 18 * 0.25f + 1);
    EXPECT_EQ(levels.outer[2], 18 * 1.0f + 1);
    EXPECT_EQ(levels.outer[3], 18 * 1.25f + 1);
    EXPECT_EQ(levels.inner[0], 18 * ((0.5f + 0.25f + 1.0f + 1.25f) / 4) + 1);
}

// A normal map with a crease at x = 5 (world units, scaleXY 1): (0,0,1) left of it,
// (0.8, 0, 0.6) from it on (angle acos(0.6) = 0.9273 rad > 0.90).
template <typename T>
Sampler2D<T> crease_normal_map() {
    return [](vec2_t<T> uv) {
        return uv.x < T(5) ? vec4_t<T>(0.5, 0.5, 1.0, 1.0) : vec4_t<T>(0.75, 0.5, 0.6875, 1.0);
    };
}

TEST(Thesis, NormalFactorSumsTheProbeAnglesAcrossACrease) {
    ThesisControl<double> control;
    control.factor = ThesisFactor::normal;
    control.normalMap = crease_normal_map<double>();
    // Edge ad from (0,0) to (10,0), along u: probes a=(0,0), b=(10,0), a+down=(10,0),
    // b+down=(20,0), a+up=(-10,0), b+up=(0,0). Normals: n0, n1, n1, n1, n0, n0. Angles:
    // (0,3) crease, (2,1) 0, (0,5) 0, (1,4) crease: sum 2 acos(0.6).
    const ThesisEdgeFactors<double> f = thesis_edge_factors(
        glm::dvec3(0, 0, 0), glm::dvec3(10, 0, 0), ThesisEdgeDirection::along_u, control);
    EXPECT_NEAR(f.normalTessellation, 2 * std::acos(0.6), 1e-12);
    // A flat map: every angle is 0, below the threshold: factor 0.
    control.normalMap = [](glm::dvec2) { return glm::dvec4(0.5, 0.5, 1.0, 1.0); };
    EXPECT_EQ(thesis_edge_factors(glm::dvec3(0, 0, 0), glm::dvec3(10, 0, 0),
                                  ThesisEdgeDirection::along_u, control)
                  .normalTessellation,
              0.0);
    // The same crease in float: the sum, never NaN (the dot is clamped before acos).
    ThesisControl<float> controlF;
    controlF.factor = ThesisFactor::normal;
    controlF.normalMap = crease_normal_map<float>();
    const float nf = thesis_edge_factors(glm::vec3(0, 0, 0), glm::vec3(10, 0, 0),
                                         ThesisEdgeDirection::along_u, controlF)
                         .normalTessellation;
    EXPECT_NEAR(nf, 2 * std::acos(0.6f), 1e-5f);
    // A texel whose decoded unit normal has a float self-dot above 1: the unclamped acos of
    // the seed would give NaN; the clamped one gives a zero angle, so the factor is 0.
    glm::vec3 texel(0.0f);
    bool found = false;
    for (int code = 0; code < 256 * 256 && !found; ++code) {
        texel = glm::vec3((code % 256) / 255.0f, (code / 256) / 255.0f, 1.0f);
        const glm::vec3 n = normal_from_texture(texel);
        found = glm::dot(n, n) > 1.0f;
    }
    ASSERT_TRUE(found);
    ASSERT_TRUE(std::isnan(std::acos(glm::dot(normal_from_texture(texel), normal_from_texture(texel)))));
    controlF.normalMap = [texel](glm::vec2) { return glm::vec4(texel, 1.0f); };
    EXPECT_EQ(thesis_edge_factors(glm::vec3(0, 0, 0), glm::vec3(10, 0, 0), ThesisEdgeDirection::along_u,
                                  controlF)
                  .normalTessellation,
              0.0f);
}

// ---------------------------------------------------------------------------------------
// COSC422
// ---------------------------------------------------------------------------------------

TEST(Cosc422, RampAtTheTerrainEnds) {
    EXPECT_EQ(cosc422_level(-100.0f), 2.0f);
    EXPECT_EQ(cosc422_level(0.0f), 20.0f);
    EXPECT_EQ(cosc422_level(-50.0), 11.0);
    EXPECT_EQ(cosc422_level(-200.0), -16.0);  // not clamped: such a patch is culled
}

TEST(Cosc422, WorldAndEyeSpaceLevels) {
    // A patch from z = 0 to z = -10 (y up, the base plane y = 0): corners c0 (x0,0), c1
    // (x0,-10), c2 (x1,-10), c3 (x1,0) in (x, z).
    const QuadCorners<float> corners{glm::vec3(-45, 0, 0), glm::vec3(-45, 0, -10),
                                     glm::vec3(-35, 0, -10), glm::vec3(-35, 0, 0)};
    const PatchLevels<float> world = cosc422_levels(corners, Cosc422Space::world);
    EXPECT_EQ(world.outer[0], cosc422_level(-5.0f));   // c0-c1
    EXPECT_EQ(world.outer[1], 20.0f);                  // c0-c3 at z = 0
    EXPECT_EQ(world.outer[2], cosc422_level(-5.0f));   // c3-c2
    EXPECT_EQ(world.outer[3], cosc422_level(-10.0f));  // c1-c2: (90 * 18) / 100 + 2 = 18.2
    EXPECT_EQ(world.inner[0], cosc422_level(-5.0f));
    EXPECT_NEAR(world.outer[3], 18.2f, 1e-5f);
    // Eye space: the camera 30 units behind z = 0 looking down -z: z_eye = z - 30.
    const glm::mat4 view = glm::translate(glm::mat4(1.0f), glm::vec3(0, 0, -30));
    const PatchLevels<float> eye = cosc422_levels(corners, Cosc422Space::eye, view);
    EXPECT_EQ(eye.outer[1], cosc422_level(-30.0f));  // (70 * 18) / 100 + 2 = 14.6
    EXPECT_NEAR(eye.outer[1], 14.6f, 1e-5f);
    EXPECT_EQ(eye.outer[3], cosc422_level(-40.0f));
    EXPECT_EQ(eye.inner[1], cosc422_level(-35.0f));
}

// ---------------------------------------------------------------------------------------
// Lab 4
// ---------------------------------------------------------------------------------------

TEST(Lab4, PowerOfTwoZonesAtTheirBoundaries) {
    Lab4Control<float> control;  // max 64, min 1
    control.firstZoneEnd = 50;
    control.zoneGrowth = 10;     // the lab's zones: 0-50, 50-500, 500-5000
    EXPECT_EQ(lab4_zone_level(0.0f, control), 64.0f);
    EXPECT_EQ(lab4_zone_level(49.999f, control), 64.0f);
    EXPECT_EQ(lab4_zone_level(50.0f, control), 32.0f);  // a boundary belongs to the farther zone
    EXPECT_EQ(lab4_zone_level(499.99f, control), 32.0f);
    EXPECT_EQ(lab4_zone_level(500.0f, control), 16.0f);
    EXPECT_EQ(lab4_zone_level(5000.0f, control), 8.0f);
    Lab4Control<double> halving;  // growth 2: 50, 100, 200, 400, 800, 1600
    EXPECT_EQ(lab4_zone_level(99.0, halving), 32.0);
    EXPECT_EQ(lab4_zone_level(100.0, halving), 16.0);
    EXPECT_EQ(lab4_zone_level(800.0, halving), 2.0);
    EXPECT_EQ(lab4_zone_level(1600.0, halving), 1.0);
    EXPECT_EQ(lab4_zone_level(1e30, halving), 1.0);  // never below minLevel
}

TEST(Lab4, SharedEdgeTakesTheLowerOrHigherNeighbourLevel) {
    // y up, the grid in x-z. Patch A: x in [0,10], z in [0,10] (centre (5,0,5)); its right
    // neighbour B: x in [10,20] (centre (15,0,5)). Camera at (-40,0,5): A's centre at 45
    // (zone 0, level 64), B's at 55 (zone 1, level 32).
    Lab4Control<double> control;
    control.cameraPosition = glm::dvec3(-40, 0, 5);
    const QuadCorners<double> a{glm::dvec3(0, 0, 0), glm::dvec3(0, 0, 10), glm::dvec3(10, 0, 10),
                                glm::dvec3(10, 0, 0)};  // u along +x, v along +z
    const Lab4ControlOutput<double> out = lab4_control(a, control);
    EXPECT_EQ(out.levels.inner[0], 64.0);
    EXPECT_EQ(out.levels.outer[2], 32.0);  // c3-c2, x = 10: shared with B
    EXPECT_EQ(out.levels.outer[0], 64.0);  // x = 0: neighbour centre (-5,0,5) at 35
    // Edge v = 0 (z = 0): the patches beside it have centres (5,0,5) and (5,0,-5), at 45 and
    // sqrt(45^2 + 10^2) = 46.1: both 64.
    EXPECT_EQ(out.levels.outer[1], 64.0);
    control.edgeRule = Lab4EdgeRule::higher;
    EXPECT_EQ(lab4_control(a, control).levels.outer[2], 64.0);
    // log2 of the levels for the mip selection, exact for powers of two.
    EXPECT_EQ(out.lod.maxLogTessellationLevel, 6.0);
    EXPECT_EQ(out.lod.logOuter[2], 5.0);
    EXPECT_EQ(out.lod.logInner, 6.0);
    // Corners: c2 = (10,0,10) at sqrt(50^2 + 5^2) = 50.2 -> 32; c0 at sqrt(40^2+5^2) -> 64.
    EXPECT_EQ(out.lod.logCorner[2], 5.0);
    EXPECT_EQ(out.lod.logCorner[0], 6.0);
}

// ---------------------------------------------------------------------------------------
// PN triangles
// ---------------------------------------------------------------------------------------

TEST(Pn, ProjectedSphereLevelOfAKnownEdge) {
    // Clip-space edge of length 0.1 along x: |v2P1 - v2P2| = 0.1 in y, times 800 * 0.5 = 40
    // pixels, over 4 pixels per edge: level 10.
    EXPECT_NEAR(pn_tess_level(glm::vec3(0, 0, 0), glm::vec3(0.1f, 0, 0)), 10.0f, 1e-5f);
    // Length 0.0625: 0.0625 * 800 * 0.5 = 25 pixels, level 6.25 exactly.
    EXPECT_EQ(pn_tess_level(glm::dvec3(0.5, 0.5, 0.5), glm::dvec3(0.5, 0.5, 0.5625)), 6.25);
    // Clamped to [1, 32].
    EXPECT_EQ(pn_tess_level(glm::vec3(0), glm::vec3(0.001f, 0, 0)), 1.0f);
    EXPECT_EQ(pn_tess_level(glm::vec3(0), glm::vec3(5, 0, 0)), 32.0f);
}

TEST(Pn, QuirksOnlyTheYResolutionAndNoPerspectiveDivide) {
    PnControl<double> control;
    const glm::dvec3 p(0.1, 0.2, 0.3), q(0.12, 0.19, 0.31);
    const double level = pn_tess_level(p, q, control);
    control.v2Resolution.x = 4000;  // x resolution never matters
    EXPECT_EQ(pn_tess_level(p, q, control), level);
    // The level reads gl_Position.xyz; w is ignored (no divide): a patch twice as far in w
    // but with the same xyz keeps its levels.
    const TriangleCorners<double> normals{glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1)};
    const std::array<glm::dvec4, 3> near{glm::dvec4(p, 1), glm::dvec4(q, 1), glm::dvec4(0, 0, 0, 1)};
    const std::array<glm::dvec4, 3> far{glm::dvec4(p, 2), glm::dvec4(q, 2), glm::dvec4(0, 0, 0, 2)};
    EXPECT_EQ(pn_levels(near, normals).outer[2], pn_levels(far, normals).outer[2]);
}

TEST(Pn, InnerIsTheMaxOfTheOutersAndFlatPatchesGetOne) {
    const std::array<glm::vec4, 3> clip{glm::vec4(0, 0, 0, 1), glm::vec4(0.1f, 0, 0, 1),
                                        glm::vec4(0, 0.05f, 0, 1)};
    const TriangleCorners<float> curved{glm::vec3(0, 0, 1), glm::normalize(glm::vec3(1, 0, 1)),
                                        glm::normalize(glm::vec3(0, 1, 1))};
    const PatchLevels<float> levels = pn_levels(clip, curved);
    EXPECT_EQ(levels.outer[0], pn_tess_level(glm::vec3(clip[1]), glm::vec3(clip[2])));
    EXPECT_EQ(levels.outer[1], pn_tess_level(glm::vec3(clip[2]), glm::vec3(clip[0])));
    EXPECT_EQ(levels.outer[2], pn_tess_level(glm::vec3(clip[0]), glm::vec3(clip[1])));
    EXPECT_EQ(levels.inner[0], std::max({levels.outer[0], levels.outer[1], levels.outer[2]}));
    EXPECT_GT(levels.inner[0], 1.0f);

    const TriangleCorners<float> flat{glm::vec3(0, 0, 1), glm::vec3(0, 0, 1), glm::vec3(0, 0, 1)};
    const PatchLevels<float> flatLevels = pn_levels(clip, flat);
    for (int i = 0; i < 3; ++i) EXPECT_EQ(flatLevels.outer[i], 1.0f);
    EXPECT_EQ(flatLevels.inner[0], 1.0f);
}

TEST(Pn, ControlPointsOfAFlatPatchLieOnItsEdges) {
    // All normals equal to the face normal: each projection is the point itself, so E1 =
    // (2 Pi + Pj) / 3 and E2 = (2 Pj + Pi) / 3, and P111 = E + (E - V) / 2 = the centroid.
    const TriangleCorners<double> p{glm::dvec3(0, 0, 0), glm::dvec3(3, 0, 0), glm::dvec3(0, 3, 0)};
    const TriangleCorners<double> n{glm::dvec3(0, 0, 2), glm::dvec3(0, 0, 2), glm::dvec3(0, 0, 2)};
    const PnPatch<double> patch = pn_patch(p, n);
    EXPECT_EQ(patch.v3PatchE1[0], glm::dvec3(1, 0, 0));
    EXPECT_EQ(patch.v3PatchE2[0], glm::dvec3(2, 0, 0));
    EXPECT_EQ(patch.v3PatchE1[1], glm::dvec3(2, 1, 0));
    EXPECT_EQ(patch.v3PatchE2[2], glm::dvec3(0, 1, 0));
    EXPECT_NEAR(glm::distance(patch.v3P111, glm::dvec3(1, 1, 0)), 0.0, 1e-15);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(glm::distance(patch.v3EdgeNormal[i], glm::dvec3(0, 0, 1)), 0.0, 1e-15);
    // project_to_plane: (1, 2, 5) onto the plane z = 1 with normal +z.
    EXPECT_EQ(project_to_plane(glm::dvec3(1, 2, 5), glm::dvec3(7, 7, 1), glm::dvec3(0, 0, 1)),
              glm::dvec3(1, 2, 1));
}

// ---------------------------------------------------------------------------------------
// Crack-freedom: a shared edge gets the same outer level bits from both patches.
// ---------------------------------------------------------------------------------------

template <typename T>
struct Random {
    std::mt19937 engine{12345};
    T uniform(T lo, T hi) { return std::uniform_real_distribution<T>(lo, hi)(engine); }
    vec3_t<T> point(T extent) { return vec3_t<T>(uniform(-extent, extent), uniform(-extent, extent), uniform(-extent, extent)); }
    int index(int n) { return std::uniform_int_distribution<int>(0, n - 1)(engine); }
};

// A smooth, non-symmetric field for the maps (normal map channels in 0..1).
template <typename T>
vec4_t<T> field(vec2_t<T> uv) {
    using std::sin;
    using std::cos;
    return vec4_t<T>(T(0.5) + T(0.5) * sin(T(3.1) * uv.x + T(1.7) * uv.y),
                     T(0.5) + T(0.5) * cos(T(2.3) * uv.x - T(0.9) * uv.y),
                     T(0.5) + T(0.5) * sin(T(1.3) * uv.x * uv.y + T(0.4)), T(1));
}

// For a quad edge slot, the slots a neighbour can hold the same edge in: the thesis's
// probes depend on the edge's direction class (u constant: slots 0 and 2; v constant: 1
// and 3), and a grid neighbour holds it in the opposite slot of the same class.
int neighbour_slot(int slot) { return (slot + 2) % 4; }

// Builds patch B: random corners, except that its edge `slot` is (q, p).
template <typename T>
QuadCorners<T> quad_with_edge(Random<T>& random, T extent, int slot, const vec3_t<T>& first,
                              const vec3_t<T>& second) {
    QuadCorners<T> corners{random.point(extent), random.point(extent), random.point(extent),
                           random.point(extent)};
    corners[kQuadEdges[slot][0]] = first;
    corners[kQuadEdges[slot][1]] = second;
    return corners;
}

template <typename T>
void expect_quad_model_crack_free(const char* name,
                                  const std::function<PatchLevels<T>(const QuadCorners<T>&)>& model,
                                  Random<T>& random, T extent, bool any_slot) {
    int checked = 0;
    for (int trial = 0; trial < 400; ++trial) {
        const vec3_t<T> p = random.point(extent);
        const vec3_t<T> q = random.point(extent);
        const int slotA = random.index(4);
        const int slotB = any_slot ? random.index(4) : neighbour_slot(slotA);
        const QuadCorners<T> a = quad_with_edge(random, extent, slotA, p, q);
        const QuadCorners<T> b = quad_with_edge(random, extent, slotB, q, p);  // opposite order
        const T levelA = model(a).outer[slotA];
        const T levelB = model(b).outer[slotB];
        ASSERT_EQ(bits(levelA), bits(levelB))
            << name << " trial " << trial << ": " << levelA << " vs " << levelB;
        ++checked;
    }
    EXPECT_EQ(checked, 400);
}

template <typename T>
void crack_freedom_all_quad_models() {
    Random<T> random;
    const T extent = T(60);  // within the thesis's 50-unit distance limit often enough
    ThesisControl<T> thesis;
    thesis.tessellationLevel = T(10);
    thesis.scaleXY = T(37);
    thesis.cameraPosition = vec3_t<T>(T(3), T(-7), T(11));
    thesis.tessellationMap = [](vec2_t<T> uv) { return field<T>(uv); };
    thesis.normalMap = [](vec2_t<T> uv) { return field<T>(uv * T(9)); };
    for (ThesisFactor factor : {ThesisFactor::distance, ThesisFactor::tessellation_map,
                                ThesisFactor::normal, ThesisFactor::all}) {
        thesis.factor = factor;
        expect_quad_model_crack_free<T>(
            "thesis", [&](const QuadCorners<T>& c) { return thesis_levels(c, thesis); }, random,
            extent, false);
    }
    expect_quad_model_crack_free<T>(
        "constant", [](const QuadCorners<T>&) { return constant_levels(T(7)); }, random, extent, true);
    expect_quad_model_crack_free<T>(
        "cosc422 world",
        [](const QuadCorners<T>& c) { return cosc422_levels(c, Cosc422Space::world); }, random,
        extent, true);
    const mat4_t<T> view = glm::lookAt(vec3_t<T>(T(10), T(20), T(30)), vec3_t<T>(T(0), T(0), T(-50)),
                                       vec3_t<T>(T(0), T(1), T(0)));
    expect_quad_model_crack_free<T>(
        "cosc422 eye",
        [&](const QuadCorners<T>& c) { return cosc422_levels(c, Cosc422Space::eye, view); },
        random, extent, true);
    Lab4Control<T> lab4;
    lab4.cameraPosition = vec3_t<T>(T(4), T(9), T(-2));
    lab4.firstZoneEnd = T(8);
    for (Lab4EdgeRule rule : {Lab4EdgeRule::lower, Lab4EdgeRule::higher}) {
        lab4.edgeRule = rule;
        expect_quad_model_crack_free<T>(
            "lab4", [&](const QuadCorners<T>& c) { return lab4_control(c, lab4).levels; }, random,
            extent, true);
    }
}

TEST(CrackFreedom, QuadModelsFloat) { crack_freedom_all_quad_models<float>(); }
TEST(CrackFreedom, QuadModelsDouble) { crack_freedom_all_quad_models<double>(); }

// Grid neighbours, as a scene lays them out: a regular grid with random heights at the
// vertices (the thesis's vertex shader output), every interior edge compared.
template <typename T>
void crack_freedom_on_a_grid() {
    Random<T> random;
    const int n = 6;
    const T spacing = T(7.25);
    std::vector<T> height((n + 1) * (n + 1));
    for (T& h : height) h = random.uniform(T(0), T(30));
    auto corner = [&](int i, int j) {
        return vec3_t<T>(T(i) * spacing - T(20), T(j) * spacing - T(20), height[j * (n + 1) + i]);
    };
    auto patch = [&](int i, int j) {
        return QuadCorners<T>{corner(i, j), corner(i, j + 1), corner(i + 1, j + 1), corner(i + 1, j)};
    };
    ThesisControl<T> thesis;
    thesis.factor = ThesisFactor::all;
    thesis.tessellationLevel = T(16);
    thesis.scaleXY = T(50);
    thesis.cameraPosition = vec3_t<T>(T(1), T(2), T(25));
    thesis.tessellationMap = [](vec2_t<T> uv) { return field<T>(uv); };
    thesis.normalMap = [](vec2_t<T> uv) { return field<T>(uv * T(20)); };
    int compared = 0;
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            const PatchLevels<T> here = thesis_levels(patch(i, j), thesis);
            if (i + 1 < n) {  // right neighbour: our outer[2] (u = 1) is its outer[0] (u = 0)
                EXPECT_EQ(bits(here.outer[2]), bits(thesis_levels(patch(i + 1, j), thesis).outer[0]));
                ++compared;
            }
            if (j + 1 < n) {  // upper neighbour: our outer[3] (v = 1) is its outer[1] (v = 0)
                EXPECT_EQ(bits(here.outer[3]), bits(thesis_levels(patch(i, j + 1), thesis).outer[1]));
                ++compared;
            }
        }
    }
    EXPECT_EQ(compared, 2 * n * (n - 1));
}

TEST(CrackFreedom, ThesisGridFloat) { crack_freedom_on_a_grid<float>(); }
TEST(CrackFreedom, ThesisGridDouble) { crack_freedom_on_a_grid<double>(); }

template <typename T>
void crack_freedom_pn() {
    Random<T> random;
    PnControl<T> control;
    control.v2Resolution = vec2_t<T>(T(1920), T(1080));
    for (int trial = 0; trial < 1000; ++trial) {
        const vec3_t<T> p = random.point(T(0.5));
        const vec3_t<T> q = random.point(T(0.5));
        vec3_t<T> np = glm::normalize(random.point(T(1)));
        const vec3_t<T> nq = trial % 4 == 0 ? np : glm::normalize(random.point(T(1)));  // some flat edges
        const int slotA = random.index(3);
        const int slotB = random.index(3);
        std::array<vec4_t<T>, 3> clipA, clipB;
        TriangleCorners<T> normalA, normalB;
        for (int k = 0; k < 3; ++k) {
            clipA[k] = vec4_t<T>(random.point(T(0.5)), T(1));
            clipB[k] = vec4_t<T>(random.point(T(0.5)), T(2));
            normalA[k] = glm::normalize(random.point(T(1)));
            normalB[k] = glm::normalize(random.point(T(1)));
        }
        clipA[kTriangleEdges[slotA][0]] = vec4_t<T>(p, T(1));
        clipA[kTriangleEdges[slotA][1]] = vec4_t<T>(q, T(1));
        normalA[kTriangleEdges[slotA][0]] = np;
        normalA[kTriangleEdges[slotA][1]] = nq;
        clipB[kTriangleEdges[slotB][0]] = vec4_t<T>(q, T(1));  // opposite order
        clipB[kTriangleEdges[slotB][1]] = vec4_t<T>(p, T(1));
        normalB[kTriangleEdges[slotB][0]] = nq;
        normalB[kTriangleEdges[slotB][1]] = np;
        const T levelA = pn_levels(clipA, normalA, control).outer[slotA];
        const T levelB = pn_levels(clipB, normalB, control).outer[slotB];
        ASSERT_EQ(bits(levelA), bits(levelB)) << "trial " << trial;
    }
}

TEST(CrackFreedom, PnFloat) { crack_freedom_pn<float>(); }
TEST(CrackFreedom, PnDouble) { crack_freedom_pn<double>(); }

// The PN control points of a shared edge: the neighbour's E1/E2 are ours swapped, and the
// quadratic-normal coefficient is the same, bit for bit.
template <typename T>
void pn_edge_control_points_shared() {
    Random<T> random;
    for (int trial = 0; trial < 500; ++trial) {
        const vec3_t<T> p = random.point(T(2)), q = random.point(T(2));
        const vec3_t<T> np = random.point(T(1)), nq = random.point(T(1));
        // A = (p, q, r): edge 0 -> 1 is p -> q. B = (q, p, s): edge 0 -> 1 is q -> p.
        const PnPatch<T> a = pn_patch(TriangleCorners<T>{p, q, random.point(T(2))},
                                      TriangleCorners<T>{np, nq, random.point(T(1))});
        const PnPatch<T> b = pn_patch(TriangleCorners<T>{q, p, random.point(T(2))},
                                      TriangleCorners<T>{nq, np, random.point(T(1))});
        for (int k = 0; k < 3; ++k) {
            ASSERT_EQ(bits(a.v3PatchE1[0][k]), bits(b.v3PatchE2[0][k]));
            ASSERT_EQ(bits(a.v3PatchE2[0][k]), bits(b.v3PatchE1[0][k]));
            ASSERT_EQ(bits(a.v3EdgeNormal[0][k]), bits(b.v3EdgeNormal[0][k]));
        }
    }
}

TEST(CrackFreedom, PnEdgeControlPointsFloat) { pn_edge_control_points_shared<float>(); }
TEST(CrackFreedom, PnEdgeControlPointsDouble) { pn_edge_control_points_shared<double>(); }

// ---------------------------------------------------------------------------------------
// Float vs double: the same formulas agree within a stated tolerance.
// ---------------------------------------------------------------------------------------

TEST(Precision, FloatAndDoubleLevelsAgree) {
    Random<double> random;
    ThesisControl<float> f;
    ThesisControl<double> d;
    f.factor = ThesisFactor::all;
    d.factor = ThesisFactor::all;
    f.tessellationLevel = 16;
    d.tessellationLevel = 16;
    f.scaleXY = 40;
    d.scaleXY = 40;
    f.tessellationMap = [](glm::vec2 uv) { return field<float>(uv); };
    d.tessellationMap = [](glm::dvec2 uv) { return field<double>(uv); };
    // A normal map whose angles stay far from the 0.90 threshold and from acos(1): all
    // normals within 0.1 rad of +z, so the normal factor is 0 in both precisions.
    f.normalMap = [](glm::vec2 uv) { return glm::vec4(0.5f + 0.02f * std::sin(uv.x), 0.5f, 1.0f, 1.0f); };
    d.normalMap = [](glm::dvec2 uv) { return glm::dvec4(0.5 + 0.02 * std::sin(uv.x), 0.5, 1.0, 1.0); };
    for (int trial = 0; trial < 200; ++trial) {
        const glm::dvec3 c(random.uniform(-30, 30), random.uniform(-30, 30), random.uniform(0, 10));
        const double s = 5;
        const QuadCorners<double> cd{c, c + glm::dvec3(0, s, 0), c + glm::dvec3(s, s, 0), c + glm::dvec3(s, 0, 0)};
        QuadCorners<float> cf;
        for (int k = 0; k < 4; ++k) cf[k] = glm::vec3(cd[k]);
        const PatchLevels<float> lf = thesis_levels(cf, f);
        const PatchLevels<double> ld = thesis_levels(cd, d);
        // Levels up to ~40; float carries ~7 digits: 1e-4 absolute is ~100 ulp of slack.
        for (int i = 0; i < 4; ++i) EXPECT_NEAR(lf.outer[i], ld.outer[i], 1e-4) << trial;
        EXPECT_NEAR(lf.inner[0], ld.inner[0], 1e-4) << trial;
    }
    PnControl<float> pf;
    PnControl<double> pd;
    for (int trial = 0; trial < 200; ++trial) {
        const glm::dvec3 p = random.point(1.0), q = random.point(1.0);
        EXPECT_NEAR(pn_tess_level(glm::vec3(p), glm::vec3(q), pf), pn_tess_level(p, q, pd), 1e-4);
    }
}

// ---------------------------------------------------------------------------------------
// The GLSL twins
// ---------------------------------------------------------------------------------------

std::string run(const std::string& command, int& status) {
    std::string output;
    FILE* pipe = popen((command + " 2>&1").c_str(), "r");
    if (!pipe) {
        status = -1;
        return "popen failed";
    }
    char buffer[4096];
    while (std::fgets(buffer, sizeof buffer, pipe)) output += buffer;
    status = pclose(pipe);
    return output;
}

bool have_glslang() {
    int status = 0;
    run("glslangValidator --version", status);
    return status == 0;
}

const fs::path shader_dir = fs::path(TESSREF_SOURCE_DIR) / "data" / "shaders";

std::vector<fs::path> shaders() {
    std::vector<fs::path> out;
    const std::set<std::string> stages{".vert", ".tesc", ".tese", ".geom", ".frag", ".comp"};
    for (const auto& entry : fs::directory_iterator(shader_dir)) {
        if (stages.count(entry.path().extension().string())) out.push_back(entry.path());
    }
    std::sort(out.begin(), out.end());
    return out;
}

TEST(Shaders, EveryShaderCompilesAsItsStage) {
    ASSERT_TRUE(have_glslang()) << "glslangValidator not found: scripts/install-deps.sh installs "
                                   "glslang-tools";
    const std::vector<fs::path> files = shaders();
    ASSERT_GE(files.size(), 20u);
    for (const fs::path& file : files) {
        // The extension names the stage (glslangValidator's own rule); -S makes it explicit.
        const std::string stage = file.extension().string().substr(1);
        int status = 0;
        const std::string output =
            run("glslangValidator -S " + stage + " \"" + file.string() + "\"", status);
        EXPECT_EQ(status, 0) << file.filename() << ":\n" << output;
        std::ifstream in(file);
        std::string first_line;
        std::getline(in, first_line);
        if (file.filename().string().rfind("capture_tess_coord", 0) != 0) {
            EXPECT_EQ(first_line, "#version 450 core") << file.filename();
        }
    }
}

TEST(Shaders, EveryPipelineLinks) {
    ASSERT_TRUE(have_glslang());
    std::map<std::string, std::vector<fs::path>> pipelines;
    for (const fs::path& file : shaders()) pipelines[file.stem().string()].push_back(file);
    // The thesis's single-texture fragment shader pairs with the same earlier stages.
    for (const fs::path& file : pipelines["thesis_terrain"]) {
        if (file.extension() != ".frag") pipelines["thesis_terrain_single"].push_back(file);
    }
    for (const char* name : {"thesis_terrain", "thesis_terrain_single", "cosc422_terrain",
                             "lab4_terrain", "pn_triangles", "geomip_terrain"}) {
        ASSERT_TRUE(pipelines.count(name)) << name;
        std::string command = "glslangValidator -l";
        for (const fs::path& file : pipelines[name]) command += " \"" + file.string() + "\"";
        int status = 0;
        const std::string output = run(command, status);
        EXPECT_EQ(status, 0) << name << ":\n" << output;
    }
}

// Every "GLSL: <file>:<line> <name>" comment in the C++ stages must point at a shader line
// that contains <name>, so that the side-by-side reading stays true as either side changes.
TEST(Shaders, CppCommentsPointAtTheShaderLinesTheyMirror) {
    const std::regex reference(R"(GLSL: ([A-Za-z0-9_]+\.(?:vert|tesc|tese|geom|frag)):([0-9]+) (.+)$)");
    int references = 0;
    for (const char* stage : {"control", "evaluation", "geometry", "geomipmap"}) {
        for (const auto& entry : fs::directory_iterator(fs::path(TESSREF_SOURCE_DIR) / "src" / stage)) {
            std::ifstream source(entry.path());
            std::string line;
            while (std::getline(source, line)) {
                std::smatch match;
                if (!std::regex_search(line, match, reference)) continue;
                ++references;
                std::ifstream shader(shader_dir / match[1].str());
                ASSERT_TRUE(shader.good()) << entry.path().filename() << ": " << match[1];
                const int wanted = std::stoi(match[2].str());
                std::string shader_line;
                for (int n = 0; n < wanted && std::getline(shader, shader_line); ++n) {
                }
                EXPECT_NE(shader_line.find(match[3].str()), std::string::npos)
                    << entry.path().filename() << " cites " << match[1] << ":" << wanted << " for '"
                    << match[3] << "', but that line is: " << shader_line;
            }
        }
    }
    EXPECT_GE(references, 40);
}

}  // namespace
