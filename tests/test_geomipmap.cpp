// tests/test_geomipmap.cpp — geomipmapping and geomorphing (tessref/geomipmap.h).
//
// Where the expected answers come from:
//  - counting: level k of a 17 x 17 patch has (16 / 2^k)^2 cells of two triangles (the
//    article: 2 x 16 x 16 at level 0, one quad of 2 at level 4);
//  - geometry: a triangulation of the patch square has positive triangles whose areas sum
//    to the square's 256 and whose interior edges are each shared by exactly two triangles
//    in opposite directions;
//  - linear interpolation reproduces a plane exactly, so a planar map has no error at any
//    level; a single raised sample that level k drops reads 0 there (its neighbours kept by
//    the level are all 0), so the error is its height;
//  - tessref check (check.h) on the welded mesh is the judge of gaps and T-vertices.
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include "tessref/check.h"
#include "tessref/error.h"
#include "geomip_maps.h"
#include "tessref/geomipmap.h"

using namespace tessref;
using namespace tessref::geomip;

namespace {

using tessref::test::flat_map;

HeightSamples random_map(int width, int height, unsigned seed) {
    HeightSamples m = flat_map(width, height);
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> code(0, 255);  // 8-bit heights, as the article's maps
    for (double& h : m.samples) h = code(rng);
    return m;
}

double signed_area(const PatchMesh& mesh, const std::array<std::uint32_t, 3>& t) {
    const glm::dvec2 a(mesh.vertices[t[0]]), b(mesh.vertices[t[1]]), c(mesh.vertices[t[2]]);
    return 0.5 * ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
}

// Every admissible side-step combination of a level: each side 2^level .. 16.
std::vector<SideSteps> all_sides(int level) {
    std::vector<int> steps;
    for (int s = 1 << level; s <= 16; s *= 2) steps.push_back(s);
    std::vector<SideSteps> all;
    for (int a : steps)
        for (int b : steps)
            for (int c : steps)
                for (int d : steps) all.push_back({a, b, c, d});
    return all;
}

CheckReport check_surface(const SurfaceMesh& surface) {
    CheckOptions options;
    options.expect = Expect::open;
    return check_mesh(indexed_mesh_from(surface), options);
}

}  // namespace

// ---- the patch triangulation ---------------------------------------------------------

TEST(GeoMipPatch, LevelsHaveTheArticlesTriangleCounts) {
    for (int k = 0; k < kLevels; ++k) {
        const int s = 1 << k, cells = 16 / s;
        const PatchMesh mesh = patch_mesh(k, {s, s, s, s});
        EXPECT_EQ(mesh.triangles.size(), static_cast<std::size_t>(2 * cells * cells)) << "level " << k;
        EXPECT_EQ(mesh.vertices.size(), static_cast<std::size_t>((cells + 1) * (cells + 1))) << "level " << k;
    }
}

TEST(GeoMipPatch, EverySideCombinationTilesThePatchSquare) {
    for (int k = 0; k < kLevels; ++k)
        for (const SideSteps& sides : all_sides(k)) {
            SCOPED_TRACE("level " + std::to_string(k) + " sides " + std::to_string(sides[0]) + "," +
                         std::to_string(sides[1]) + "," + std::to_string(sides[2]) + "," + std::to_string(sides[3]));
            const PatchMesh mesh = patch_mesh(k, sides);
            double area = 0.0;
            std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
            for (const auto& t : mesh.triangles) {
                const double a = signed_area(mesh, t);
                ASSERT_GT(a, 0.0);
                area += a;
                for (int e = 0; e < 3; ++e) ++directed[{t[e], t[(e + 1) % 3]}];
            }
            EXPECT_EQ(area, 256.0);
            // Each directed edge once; an edge without its reverse lies on the border, and the
            // border's vertices on each side are exactly the multiples of that side's step.
            std::vector<int> border_count(4, 0);
            for (const auto& [edge, n] : directed) {
                ASSERT_EQ(n, 1);
                if (directed.count({edge.second, edge.first})) continue;
                const glm::ivec2 a = mesh.vertices[edge.first], b = mesh.vertices[edge.second];
                const int side = a.y == 0 && b.y == 0 ? 0 : a.x == 16 && b.x == 16 ? 1 : a.y == 16 && b.y == 16 ? 2
                                 : a.x == 0 && b.x == 0 ? 3 : -1;
                ASSERT_GE(side, 0) << "a border edge inside the patch";
                EXPECT_EQ(std::abs((b - a).x) + std::abs((b - a).y), sides[side]);
                ++border_count[side];
            }
            for (int q = 0; q < 4; ++q) EXPECT_EQ(border_count[q], 16 / sides[q]) << "side " << q;
        }
}

TEST(GeoMipPatch, BadLevelsAndStepsAreRefused) {
    EXPECT_THROW(patch_mesh(5, {32, 32, 32, 32}), Error);
    EXPECT_THROW(patch_mesh(-1, {1, 1, 1, 1}), Error);
    EXPECT_THROW(patch_mesh(2, {2, 4, 4, 4}), Error);  // a side finer than the level
    EXPECT_THROW(patch_mesh(1, {3, 2, 2, 2}), Error);  // not a power of two
}

// ---- pre-processing ------------------------------------------------------------------

TEST(GeoMipPreprocess, APlaneHasNoErrorAtAnyLevel) {
    HeightSamples m = flat_map(33, 17);
    for (int y = 0; y < m.height; ++y)
        for (int x = 0; x < m.width; ++x) m.samples[static_cast<std::size_t>(y) * m.width + x] = 3.0 * x - 2.0 * y + 7.0;
    for (const auto& levels : preprocess(m))
        for (const MaxErrorVertex& v : levels) EXPECT_EQ(v.error(), 0.0);
}

TEST(GeoMipPreprocess, ADroppedSpikeIsTheMaxErrorVertex) {
    // One sample of height 5 at local (4, 6) of patch 1 (map sample (20, 6)). Level 0 is the
    // map: error 0. Level 1 keeps it (4 and 6 are even) but drops its odd neighbours, which
    // then read halfway between it and a 0: error 2.5, next to it. Levels 2..4 keep only
    // samples at multiples of 4 (all 0), so they read 0 at the spike: error 5, at the spike.
    HeightSamples m = flat_map(33, 17);
    m.samples[6 * 33 + 20] = 5.0;
    const MaxErrors e = preprocess(m);
    ASSERT_EQ(e.size(), 2u);
    for (int k = 0; k < kLevels; ++k) {
        EXPECT_EQ(e[0][k].error(), 0.0) << k;
        EXPECT_EQ(e[1][k].error(), k == 0 ? 0.0 : k == 1 ? 2.5 : 5.0) << k;
        if (k >= 2) {
            EXPECT_EQ(e[1][k].sample, glm::ivec2(4, 6));
            EXPECT_EQ(e[1][k].level_height, 0.0);
        }
    }
}

TEST(GeoMipPreprocess, MapsOfOtherSizesOrWithNanAreRefused) {
    EXPECT_THROW(preprocess(flat_map(16, 17)), Error);
    EXPECT_THROW(preprocess(flat_map(17, 18)), Error);
    EXPECT_THROW(preprocess(flat_map(1, 1)), Error);
    HeightSamples m = flat_map(17, 17);
    m.samples[40] = std::nan("");
    EXPECT_THROW(preprocess(m), Error);
}

// ---- level selection -----------------------------------------------------------------

// A projection that maps world z to screen y one-to-one in pixels (x to x), with w = 1:
// a screen error in pixels is then the height error itself, and a bound can be checked by
// hand. clip.y = z * 2 / H so that (y / w + 1) / 2 * H moves by z pixels.
TEST(GeoMipSelect, CoarsestLevelWithinTheBoundAndTheTweenBetween) {
    const glm::ivec2 viewport(100, 100);
    glm::dmat4 vp(0.0);
    vp[0][0] = 2.0 / viewport.x;  // x -> clip x
    vp[2][1] = 2.0 / viewport.y;  // z -> clip y
    vp[3][3] = 1.0;               // w = 1
    const HeightSamples m = flat_map(17, 17);
    MaxErrors e(1);
    const std::array<double, kLevels> errors{0.0, 0.5, 1.5, 4.0, 9.0};
    for (int k = 0; k < kLevels; ++k) e[0][k] = MaxErrorVertex{{3, 3}, errors[k], 0.0};

    Settings s;
    s.params.error_bound_px = 2.0;  // levels 0..2 within; level 3's 4 px is not
    auto f = select_levels(m, e, s, vp, viewport);
    // t = (2 - 1.5) / (4 - 1.5) = 0.2
    EXPECT_NEAR(f[0], 2.2, 1e-12);
    s.params.error_bound_px = 100.0;
    EXPECT_EQ(select_levels(m, e, s, vp, viewport)[0], 4.0);
    s.params.error_bound_px = 0.25;  // not even level 1: t = 0.25 / 0.5
    EXPECT_NEAR(select_levels(m, e, s, vp, viewport)[0], 0.5, 1e-12);
    s.params.error_bound_px = 2.0;
    s.params.tween = 0.75;  // a fixed tween replaces the computed one
    EXPECT_EQ(select_levels(m, e, s, vp, viewport)[0], 2.75);
    s.params.tween = 1.5;
    EXPECT_THROW(select_levels(m, e, s, vp, viewport), Error);
}

TEST(GeoMipSelect, APatchBehindTheNearPlaneStaysFine) {
    // A perspective camera looking down -z from z = 10 onto the map at z in [0, 255]: part
    // of the terrain is above the camera. Patches with a level error there cannot be
    // judged on screen and keep level 0 up to where they are judged.
    const HeightSamples m = random_map(33, 33, 7);
    const MaxErrors e = preprocess(m);
    const glm::dmat4 view = glm::lookAt(glm::dvec3(16, 16, 10), glm::dvec3(16, 16, 0), glm::dvec3(0, 1, 0));
    const glm::dmat4 proj = glm::perspective(glm::radians(60.0), 1.0, 0.1, 1000.0);
    Settings s;
    s.params.error_bound_px = 1e9;
    for (double f : select_levels(m, e, s, proj * view, {64, 64})) EXPECT_EQ(f, 0.0);
}

// ---- neighbours: no gap, no T-vertex ------------------------------------------------

TEST(GeoMipSurface, AdaptingTrianglesLeaveNoTJunctionAndWithoutThemCheckFindsThem) {
    const HeightSamples m = random_map(49, 33, 3);  // 3 x 2 patches
    const std::vector<double> levels{0.0, 2.0, 1.0, 4.0, 3.0, 0.0};
    Settings s;
    const CheckReport adapted = check_surface(build_surface(m, levels, s));
    EXPECT_TRUE(adapted.passed) << report_text(adapted);
    EXPECT_EQ(adapted.count(DefectClass::t_junction), 0u);
    EXPECT_EQ(adapted.boundary_loop_count, 1u);

    s.params.adapt = false;
    const CheckReport plain = check_surface(build_surface(m, levels, s));
    EXPECT_FALSE(plain.passed);
    EXPECT_GT(plain.count(DefectClass::t_junction), 0u) << report_text(plain);
    std::printf("[   INFO   ] 3 x 2 patches at levels 0 2 1 / 4 3 0: %zu T-junctions without adaptation, 0 with\n",
                plain.count(DefectClass::t_junction));
}

TEST(GeoMipSurface, NoCrackAtAnyTween) {
    const HeightSamples m = random_map(65, 65, 11);  // 4 x 4 patches
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> level(0.0, 4.0);
    for (int trial = 0; trial < 12; ++trial) {
        std::vector<double> levels(16);
        for (double& f : levels) f = trial < 4 ? std::floor(level(rng)) + trial * 0.25 : level(rng);
        for (double& f : levels) f = std::min(f, 4.0);
        const CheckReport r = check_surface(build_surface(m, levels, Settings{}));
        EXPECT_TRUE(r.passed) << "trial " << trial << "\n" << report_text(r);
        EXPECT_EQ(r.boundary_loop_count, 1u);
    }
}

// ---- geomorphing ---------------------------------------------------------------------

TEST(GeoMipSurface, TweenZeroIsTheDiscreteLevelAndTweenOneReachesTheNextLevel) {
    const HeightSamples m = random_map(33, 33, 21);  // 2 x 2 patches
    for (int k = 0; k + 1 < kLevels; ++k) {
        SCOPED_TRACE("level " + std::to_string(k));
        // At t = 0 every vertex stands at its sample's true height.
        const SurfaceMesh at_k = build_surface(m, std::vector<double>(4, k), Settings{});
        for (std::size_t v = 0; v < at_k.positions.size(); ++v) {
            const glm::dvec3 p = at_k.positions[v];
            EXPECT_EQ(p.z, m.at(static_cast<int>(p.x), static_cast<int>(p.y)));
        }
        // As t -> 1 every vertex of level k reaches level k + 1's surface: its height equals
        // level k + 1's mesh interpolated at the vertex (the level k + 1 mesh's vertices are
        // all at true heights, so this is the surface the switch to level k + 1 shows).
        const double t = 1.0;
        Settings s;
        s.params.tween = t;
        const SurfaceMesh morphed = build_surface(m, std::vector<double>(4, k + t * 0.999999999), s);
        const SurfaceMesh next = build_surface(m, std::vector<double>(4, k + 1), Settings{});
        double worst = 0.0;
        for (std::size_t v = 0; v < morphed.positions.size(); ++v) {
            const glm::dvec3 p = morphed.positions[v];
            // Find the next level's triangle (of the same patch) holding (p.x, p.y).
            double height = std::nan("");
            for (const auto& tri : next.triangles) {
                if (next.patch_ids[tri[0]] != morphed.patch_ids[v]) continue;
                const glm::dvec3 a = next.positions[tri[0]], b = next.positions[tri[1]], c = next.positions[tri[2]];
                const double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
                const double wa = ((b.x - p.x) * (c.y - p.y) - (b.y - p.y) * (c.x - p.x)) / area;
                const double wb = ((c.x - p.x) * (a.y - p.y) - (c.y - p.y) * (a.x - p.x)) / area;
                const double wc = 1.0 - wa - wb;
                if (wa < -1e-12 || wb < -1e-12 || wc < -1e-12) continue;
                height = wa * a.z + wb * b.z + wc * c.z;
                break;
            }
            ASSERT_FALSE(std::isnan(height));
            worst = std::max(worst, std::abs(p.z - height));
        }
        EXPECT_LT(worst, 1e-6) << "a vertex pops by " << worst << " at the switch to level " << k + 1;
    }
}

// ---- the scene model ([evaluation] model = "geomipmap") --------------------------------

#include "command_dir_test.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"
#include "tessref/scene.h"

namespace {

const std::string kShipped = std::string(TESSREF_SOURCE_DIR) + "/data/scenes/jacksboro-geomipmap.toml";

// The shipped scene's text with one line replaced (or added to its [evaluation] table).
std::string shipped_with(const std::string& from, const std::string& to) {
    std::string text = tessref::test::read_file(kShipped);
    const std::size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
    return text;
}

Scene shipped_scene_with(const std::string& from, const std::string& to) {
    return load_scene_from_string(shipped_with(from, to), kShipped);
}

}  // namespace

TEST(GeoMipScene, TheShippedSceneExportsWithoutTJunctionsAndWithoutAdaptationCheckFindsThem) {
    const Scene scene = load_scene(kShipped);
    const PipelineResult result = run_pipeline(scene);
    // Several levels in one frame, or the adaptation is not exercised.
    std::vector<int> per_level(kLevels, 0);
    for (const TessLevels& l : result.levels) ++per_level[static_cast<int>(l.inner[0])];
    int used = 0;
    for (int n : per_level) used += n > 0;
    EXPECT_GE(used, 3) << per_level[0] << " " << per_level[1] << " " << per_level[2] << " " << per_level[3] << " "
                       << per_level[4];
    const CheckReport adapted = check_surface(result.mesh);
    EXPECT_TRUE(adapted.passed) << report_text(adapted);
    EXPECT_EQ(adapted.count(DefectClass::t_junction), 0u);

    const Scene plain = shipped_scene_with("error_bound_px = 4.0", "error_bound_px = 4.0\nadapt = false");
    const CheckReport r = check_surface(run_pipeline(plain).mesh);
    EXPECT_FALSE(r.passed);
    EXPECT_GT(r.count(DefectClass::t_junction), 0u);
    std::printf("[   INFO   ] jacksboro-geomipmap: patches per level 0..4: %d %d %d %d %d; %zu triangles; "
                "without adaptation %zu T-junctions\n",
                per_level[0], per_level[1], per_level[2], per_level[3], per_level[4], result.mesh.triangles.size(),
                r.count(DefectClass::t_junction));
}

TEST(GeoMipScene, AFixedTweenIsReproducibleAndStillClosed) {
    for (const char* tween : {"0.0", "0.5", "1.0"}) {
        const Scene scene = shipped_scene_with("error_bound_px = 4.0", std::string("error_bound_px = 4.0\ntween = ") + tween);
        const PipelineResult a = run_pipeline(scene), b = run_pipeline(scene);
        EXPECT_EQ(a.mesh.positions, b.mesh.positions) << tween;
        const CheckReport r = check_surface(a.mesh);
        EXPECT_TRUE(r.passed) << "tween " << tween << "\n" << report_text(r);
    }
}

TEST(GeoMipScene, ErrorBoundZeroIsTheFullResolutionMap) {
    const Scene scene = shipped_scene_with("error_bound_px = 4.0", "error_bound_px = 0.0");
    const PipelineResult r = run_pipeline(scene, PipelineOptions{Precision::exact});
    EXPECT_EQ(r.mesh.triangles.size(), 256u * 512u);  // every patch at level 0: 2 x 16 x 16 each
    // Every vertex at its sample's height: v / 65535 * scale_z (texel_exact of a unorm16).
    const Texture& t = scene.grid->heightmap->texture;
    for (std::size_t v = 0; v < r.mesh.positions.size(); v += 97) {
        const glm::vec3 tc = r.mesh.tess_coords[v];
        const std::uint32_t p = r.mesh.patch_ids[v];
        const int x = static_cast<int>(p % 16) * 16 + static_cast<int>(std::lround(tc.x * 16));
        const int y = static_cast<int>(p / 16) * 16 + static_cast<int>(std::lround(tc.y * 16));
        EXPECT_EQ(r.mesh.positions[v].z, t.texel_exact(0, x, y) * 16.8) << v;
    }
}

TEST(GeoMipScene, ScenesThatDoNotFitAreRefusedNamingTheKey) {
    const auto refused = [](const std::string& text, const std::string& key) {
        try {
            load_scene_from_string(text, kShipped);
            ADD_FAILURE() << "loaded: " << key;
        } catch (const Error& e) {
            EXPECT_NE(e.where().str().find(key), std::string::npos) << e.what() << " (" << e.where().str() << ")";
        }
    };
    refused(shipped_with("patches = [16, 16]", "patches = [8, 8]"), "domain.patches");  // 129 samples needed
    refused(shipped_with("error_bound_px = 4.0", "error_bound_px = 4.0\ntween = 1.5"), "evaluation.tween");
    refused(shipped_with("error_bound_px = 4.0", "error_bound_px = -1.0"), "evaluation.error_bound_px");
    refused(shipped_with("[evaluation]", "[control]\nmodel = \"constant\"\nlevel = 4.0\n\n[evaluation]"), "control");
    refused(shipped_with("[evaluation]", "[generator]\nspacing = \"equal\"\n\n[evaluation]"), "generator");
    refused(shipped_with("normals = \"smooth\"", "normals = \"normal_map\""), "geometry.normals");
    refused(shipped_with("heightmap = ", "scale_xy = 1.0\nheightmap = "), "domain.scale_xy");
}

class GeoMipCommand : public tessref::test::CommandDirTest {};

TEST_F(GeoMipCommand, GlDrawsIt) {
    const auto gl = run({"gl", kShipped, "--size", "32x20", "-o", path("gl.png")});
    EXPECT_EQ(gl.status, 0) << gl.err;
    EXPECT_NE(gl.out.find("every count as predicted"), std::string::npos) << gl.out;
    EXPECT_EQ(files(), std::set<std::string>{"gl.png"});
}

// The ray-traced truth of a geomipmapped terrain is its level-0 mesh: vertex lines at the
// samples (texel centres (k + 0.5) / W at world origin + k spacing), the same diagonal, the
// same smooth normals and uv. So `render --raytrace` and `render` with error_bound_px = 0
// (every patch at level 0, tween 0 since no level's error is within a bound of 0 unless it
// is exact) cover the same pixels but one or two on silhouettes, and differ by rounding:
// measured at 320x200, 52812 against 52811 covered pixels, RMSE 0.0038.
TEST_F(GeoMipCommand, RaytraceIsTheLevelZeroMesh) {
    std::string text = tessref::test::read_file(kShipped);
    const std::string data = std::string(TESSREF_SOURCE_DIR) + "/data/";
    for (std::size_t at = text.find("\"../"); at != std::string::npos; at = text.find("\"../", at))
        text.replace(at + 1, 3, data);
    text.replace(text.find("error_bound_px = 4.0"), 20, "error_bound_px = 0.0");
    std::ofstream(path("l0.toml")) << text;
    const auto rt = run({"render", kShipped, "--size", "320x200", "--raytrace", "-o", path("rt.png")});
    ASSERT_EQ(rt.status, 0) << rt.err;
    EXPECT_NE(rt.out.find("257x257 vertices (131072 triangles)"), std::string::npos) << rt.out;
    const auto l0 = run({"render", path("l0.toml"), "--size", "320x200", "-o", path("l0.png")});
    ASSERT_EQ(l0.status, 0) << l0.err;
    EXPECT_NE(l0.out.find("131072 triangles"), std::string::npos) << l0.out;
    const auto cmp = run({"compare", path("rt.png"), path("l0.png")});
    const std::size_t at = cmp.out.find("rmse");
    ASSERT_NE(at, std::string::npos) << cmp.out;
    EXPECT_LT(std::stod(cmp.out.substr(at + 4)), 0.006) << cmp.out;
}

// geomip_terrain.vert's height, by hand: mix(2, 6, 0.25) = 2 + 0.25 * 4 = 3, times scaleZ 3
// is 9; tween 0 keeps the sample's height (1.5 * 2 = 3), tween 1 reaches the target
// (2 + 1 * (6 - 2) = 6, times 0.5 = 3). Every step exact in float.
TEST(GeoMipMorph, MorphHeightIsTheVertexShadersMixTimesScaleZ) {
    EXPECT_EQ(morph_height(2.0f, 6.0f, 0.25f, 3.0f), 9.0f);
    EXPECT_EQ(morph_height(1.5f, 100.0f, 0.0f, 2.0f), 3.0f);
    EXPECT_EQ(morph_height(2.0f, 6.0f, 1.0f, 0.5f), 3.0f);
    // llvmpipe's order, a + t * (b - a) (tests/test_gl_backend.cpp GlEvaluation), each step
    // rounded to float.
    const float a = 3.0e7f, b = -3.0e7f + 2.0f, t = 0.75f;
    EXPECT_EQ(morph_height(a, b, t, 1.0f), a + t * (b - a));
}

// The gpu pipeline's vertex buffer is morph_height of the recorded attributes, and
// build_surface's MorphVertex is what its double z was made of.
TEST(GeoMipMorph, PipelinePositionsAreTheVertexShadersHeights) {
    std::string text = tessref::test::read_file(kShipped);
    text.insert(text.find("error_bound_px = 4.0") + 20, "\ntween = 0.37");
    const Scene scene = load_scene_from_string(text, kShipped);
    const PipelineResult gpu = run_pipeline(scene);
    ASSERT_EQ(gpu.geomorph.size(), gpu.mesh.positions.size());
    const float scaleZ = static_cast<float>(scene.grid->scale_z);
    std::size_t moved = 0;
    for (std::size_t v = 0; v < gpu.geomorph.size(); ++v) {
        const glm::vec3 m = gpu.geomorph[v];
        ASSERT_EQ(static_cast<float>(gpu.mesh.positions[v].z), morph_height(m.x, m.y, m.z, scaleZ)) << v;
        moved += m.z != 0.0f && m.x != m.y;
    }
    EXPECT_GT(moved, 0u);
    PipelineOptions exact;
    exact.precision = Precision::exact;
    const PipelineResult e = run_pipeline(scene, exact);
    ASSERT_EQ(e.mesh.positions.size(), gpu.mesh.positions.size());
    for (std::size_t v = 0; v < e.mesh.positions.size(); v += 97)
        EXPECT_NEAR(e.mesh.positions[v].z, gpu.mesh.positions[v].z, 1e-4 * (1.0 + std::abs(e.mesh.positions[v].z)));
}
