// Extremes suite (issue 10): tessellation levels at and beyond their limits, through the
// whole pipeline (scene -> control -> generator -> evaluation -> render) and, where a scene
// cannot express the level, the primitive generator's API.
//
// Where the expected answers come from:
//  - the GL 4.6 core specification, section 11.2.2 (Tessellation Primitive Generation): a
//    patch whose relevant outer level is <= 0 or NaN is discarded; equal_spacing clamps to
//    [1, 64] and rounds up to an integer; fractional_odd clamps to [1, 63], fractional_even
//    to [2, 64] (the clamps are min(hi, max(lo, x)), so +inf meets the upper bound);
//  - the hardware generator tessref reproduces (docs/GENERATOR.md): levels are 16.16 fixed
//    point rounded to nearest even, so an offset of 2^-17 (half a unit) from an odd integer
//    vanishes and one of 2^-16 (one unit) does not; the fractional_odd "picture frame" rule
//    raises the inner levels only above 1 + 2^-17 (strictly); a denormal level is zero;
//  - the number of triangles of a quad patch whose six levels all end at the integer n:
//    2 for n = 1 (the minimal patch), else 2(n-2)^2 + 4(n-2) + 4n (docs/GENERATOR.md:
//    inner rings 2(i0-2)(i1-2) + 2(i0-2) + 2(i1-2), plus one triangle per outer segment);
//  - a flat terrain covers the same pixels whatever its tessellation: the ray-traced
//    ground truth (render --raytrace), computed once;
//  - llvmpipe (tessref gl, Mesa's software GPU) for the same scene: its capture and its
//    picture, which the CPU reference must match bit for bit on these flat scenes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "extremes.h"
#include "tessref/render.h"
#include "tessref/scene.h"
#include "tessref/tessellator.h"

namespace {

using tessref::test::RunResult;
using tessref::test::write_file;
using namespace tessref::test::extremes;

std::uint64_t quad_triangles(int n) { return n == 1 ? 2 : 2ull * (n - 2) * (n - 2) + 4ull * (n - 2) + 4ull * n; }

struct LevelCase {
    const char* level;    // as written in the scene
    const char* spacing;
    int n;                // the integer segment count every level ends at; 0: culled
    const char* why;
};

// The first float below 1 is 1 - 2^-24, the first above 1 + 2^-23 (written exactly).
const LevelCase kCases[] = {
    {"0.0", "equal", 0, "an outer level <= 0 discards the patch (GL 11.2.2)"},
    {"-0.0", "fractional_odd", 0, "-0 <= 0: discarded"},
    {"-1.0", "fractional_even", 0, "a negative outer level discards the patch"},
    {"-1e6", "equal", 0, "a negative outer level discards the patch"},
    {"1e-40", "fractional_odd", 0, "a denormal is flushed to zero (llvmpipe, GPUs): discarded"},
    {"0.999999940395355224609375", "equal", 1, "1 - 2^-24 clamps to 1 and rounds up to 1: the minimal patch"},
    {"0.999999940395355224609375", "fractional_odd", 1, "1 - 2^-24 clamps to 1: the minimal patch"},
    {"0.999999940395355224609375", "fractional_even", 2, "fractional_even clamps to [2, 64]"},
    {"1.00000011920928955078125", "equal", 2, "equal spacing rounds 1 + 2^-23 up to 2"},
    {"1.00000011920928955078125", "fractional_odd", 1,
     "1 + 2^-23 is 1 in 16.16 and not above 1 + 2^-17 (no picture frame): the minimal patch"},
    {"1.00000011920928955078125", "fractional_even", 2, "fractional_even clamps to [2, 64]"},
    {"1.00000762939453125", "fractional_odd", 1,
     "1 + 2^-17 is half a 16.16 unit: ties to even give 1, and the picture frame needs more than 1 + 2^-17"},
    {"1.0000152587890625", "fractional_odd", 3,
     "1 + 2^-16 is one 16.16 unit above 1: fractional_odd rounds up to 3 segments, the frame raises the inner levels"},
    {"3.00000762939453125", "fractional_odd", 3, "3 + 2^-17 rounds (ties to even) to 3.0 in 16.16"},
    {"3.0000152587890625", "fractional_odd", 5, "3 + 2^-16 is one 16.16 unit above 3: 5 segments, two of them tiny"},
    {"63.0000152587890625", "fractional_odd", 63, "clamped to 63 before the fixed-point rounding"},
    {"63.5", "equal", 64, "equal spacing rounds 63.5 up to 64"},
    {"63.5", "fractional_odd", 63, "fractional_odd clamps to 63"},
    {"63.5", "fractional_even", 64, "fractional_even rounds up to the even 64"},
    {"65.0", "equal", 64, "clamped to 64"},
    {"65.0", "fractional_odd", 63, "clamped to 63"},
    {"65.0", "fractional_even", 64, "clamped to 64"},
    {"1e6", "equal", 64, "clamped to 64"},
};

Terrain level_scene(const std::string& level, const std::string& spacing) {
    Terrain t;
    t.spacing = spacing;
    t.control = "model = \"constant\"\nlevel = " + level;
    return t;
}

// Triangles of each patch in a pipeline result (patch ids 0..3 of the 2 x 2 grid).
std::vector<std::size_t> per_patch(const tessref::PipelineResult& p, std::size_t patches) {
    std::vector<std::size_t> n(patches, 0);
    for (const auto& tri : p.mesh.triangles) ++n.at(p.mesh.patch_ids.at(tri[0]));
    return n;
}

class ExtremeLevels : public ExtremesTest {
protected:
    void SetUp() override {
        ExtremesTest::SetUp();
        write_flat_pgm(dir_ / "flat.pgm");
    }

    // Runs the scene through `tessref gl` (llvmpipe) and holds the CPU reference to it: the
    // capture bit for bit (same triangles, same tess coords, positions 0 ulps apart) and the
    // picture byte for byte. The CPU side runs in this process (the same functions `mesh
    // --capture` and `render` call): one program start per case keeps the suite fast.
    void expect_llvmpipe_agrees(const Terrain& t, std::size_t expected_triangles) {
        write_scene(t);
        const RunResult r = run({"gl", "scene.toml", "-o", "gl.png", "--capture", "gl.txt"});
        ASSERT_EQ(r.status, 0) << r.err;
        const tessref::Scene scene = load(t);
        tessref::RenderOptions keep;
        keep.keep_surface = true;  // the capture reads the surface
        const tessref::RenderResult image = tessref::render_scene(scene, keep);
        tessref::Capture cpu;
        cpu.vertices = tessref::capture_from_pipeline(scene, *image.pipeline);
        EXPECT_EQ(cpu.vertices.size(), 3 * expected_triangles);
        const tessref::CaptureCompareResult same = tessref::compare_captures(cpu, tessref::read_capture(path("gl.txt")));
        EXPECT_TRUE(same.passed) << same.diverging_patches() << " patches diverge, worst position "
                                 << same.worst_position.ulps << " ulps";
        EXPECT_EQ(pixels_differing(read_picture(path("gl.png")), image), 0) << "pixels differ from llvmpipe's picture";
    }
};

// Every case through control, generator, evaluation and the rasterizer, in both precisions:
// each patch has the triangles the spec's rule gives, and the picture covers exactly the
// pixels the ray-traced flat terrain covers (or none when the patches are discarded).
TEST_F(ExtremeLevels, SceneLevelsThroughPipelineAndRender) {
    const tessref::RenderResult truth = tessref::raytrace_scene(load(level_scene("1.0", "equal")));
    const std::vector<bool> reference = covered(truth);
    ASSERT_GT(count(reference), 3000u);  // the terrain fills a good part of the picture
    for (const LevelCase& c : kCases) {
        for (const tessref::Precision precision : {tessref::Precision::gpu, tessref::Precision::exact}) {
            SCOPED_TRACE(std::string("level ") + c.level + ", " + c.spacing + ", precision " +
                         std::string(tessref::to_string(precision)) + ": " + c.why);
            const tessref::Scene scene = load(level_scene(c.level, c.spacing));
            tessref::RenderOptions options;
            options.precision = precision;
            options.keep_surface = true;  // per_patch counts the surface's triangles
            const tessref::RenderResult image = tessref::render_scene(scene, options);
            const std::size_t expected = c.n == 0 ? 0 : quad_triangles(c.n);
            EXPECT_EQ(per_patch(*image.pipeline, 4), std::vector<std::size_t>(4, expected));
            EXPECT_EQ(image.stats.triangles, 4 * expected);
            const std::vector<bool> mask = covered(image);
            if (c.n == 0)
                EXPECT_EQ(count(mask), 0u);
            else
                EXPECT_EQ(count_different(mask, reference), 0u) << count(mask) << " pixels covered, ray-traced "
                                                                << count(reference);
        }
    }
}

// The cases where rounding decides, against llvmpipe: the same triangles at the same tess
// coords and positions (0 ulps), and the same picture.
TEST_F(ExtremeLevels, RoundingCasesMatchLlvmpipe) {
    for (const auto& [level, spacing, n] :
         std::vector<std::tuple<std::string, std::string, int>>{{"1e-40", "fractional_odd", 0},
                                                                {"1.00000011920928955078125", "fractional_odd", 1},
                                                                {"1.00000762939453125", "fractional_odd", 1},
                                                                {"1.0000152587890625", "fractional_odd", 3},
                                                                {"3.0000152587890625", "fractional_odd", 5}}) {
        SCOPED_TRACE("level " + level + ", " + spacing);
        expect_llvmpipe_agrees(level_scene(level, spacing), n == 0 ? 0 : 4 * quad_triangles(n));
    }
    // 65 clamps to 63 under fractional_odd: one patch keeps the capture small.
    Terrain t = level_scene("65.0", "fractional_odd");
    t.nu = t.nv = 1;
    expect_llvmpipe_agrees(t, quad_triangles(63));
}

// NaN, +inf and -inf reach the generator from a control stage: the thesis distance factor
// (limit - d) / divisor with distance_limit = 1e39, which as the shader's float uniform is
// +inf (FLT_MAX is about 3.4e38). level * inf + 1 is then +inf for level 1, -inf for level -1
// and NaN for level 0 (0 * inf). NaN and -inf discard every patch; +inf clamps to 63.
TEST_F(ExtremeLevels, NonFiniteLevelsFromTheControlStage) {
    struct Case {
        const char* level;
        const char* what;
        int n;
    };
    for (const Case& c : {Case{"0.0", "nan", 0}, Case{"1.0", "inf", 63}, Case{"-1.0", "-inf", 0}}) {
        SCOPED_TRACE(std::string("thesis distance, level ") + c.level + " -> " + c.what);
        Terrain t;
        t.nu = t.nv = 1;
        t.control = std::string("model = \"thesis\"\nfactor = \"distance\"\nlevel = ") + c.level +
                    "\ndistance_limit = 1e39";
        const tessref::Scene scene = load(t);
        const tessref::RenderResult image = tessref::render_scene(scene);
        ASSERT_EQ(image.pipeline->levels.size(), 1u);
        const float written = image.pipeline->levels[0].outer[0];
        EXPECT_EQ(std::string(c.what), std::isnan(written) ? "nan" : written > 0 ? "inf" : "-inf") << written;
        const std::size_t expected = c.n == 0 ? 0 : quad_triangles(c.n);
        EXPECT_EQ(image.stats.triangles, expected);
        if (c.n == 0) EXPECT_EQ(image.stats.covered_pixels, 0u);
        expect_llvmpipe_agrees(t, expected);
    }
}

// A scene cannot write NaN or an infinity as a level (TOML has them): refused with exit 2,
// naming the file, the line and the key, and no output written.
TEST_F(ExtremeLevels, NonFiniteLevelInSceneIsRefused) {
    for (const char* level : {"nan", "inf", "-inf"}) {
        SCOPED_TRACE(level);
        write_scene(level_scene(level, "equal"));
        std::vector<std::vector<std::string>> commands{{"mesh", "scene.toml", "-o", "out.ply"}};
        if (std::string(level) == "nan") commands.push_back({"render", "scene.toml", "-o", "out.png"});
        for (const std::vector<std::string>& args : commands) {
            const RunResult r = run(args);
            EXPECT_EQ(r.status, 2) << r.err;
            EXPECT_NE(r.err.find("control.level must be finite"), std::string::npos) << r.err;
            EXPECT_NE(r.err.find("scene.toml:"), std::string::npos) << r.err;  // file:line:column
            EXPECT_EQ(files(), (std::set<std::string>{"flat.pgm", "scene.toml"}));
        }
    }
}

// A discarded terrain is not an error: the mesh is written with no faces, the picture is
// the background (GL's default clear colour, transparent black) everywhere.
TEST_F(ExtremeLevels, CulledTerrainGivesEmptyMeshAndBackground) {
    write_scene(level_scene("0.0", "equal"));
    RunResult r = run({"mesh", "scene.toml", "-o", "culled.ply"});
    ASSERT_EQ(r.status, 0) << r.err;
    const std::string ply = tessref::test::read_file(path("culled.ply"));
    EXPECT_NE(ply.find("element face 0\n"), std::string::npos) << ply.substr(0, 400);
    r = run({"render", "scene.toml", "-o", "culled.png"});
    ASSERT_EQ(r.status, 0) << r.err;
    const Picture p = read_picture(path("culled.png"));
    ASSERT_EQ(p.width, 160);
    float largest = 0.0f;
    for (float v : p.pixels) largest = std::max(largest, std::abs(v));
    EXPECT_EQ(largest, 0.0f);
}

// A discarded terrain has nothing to close into a solid: `mesh --solid` must say so (exit 2,
// nothing written), in words about the terrain, not about a base the user never gave.
// (This failed without --base until cmd_mesh.cpp refused an empty terrain first: it took the
// lowest vertex of no vertices as +inf and printed "the base inf must lie below the
// terrain's lowest vertex, at z = inf".)
TEST_F(ExtremeLevels, CulledTerrainHasNoSolidToClose) {
    write_scene(level_scene("0.0", "equal"));
    for (const std::vector<std::string>& args :
         {std::vector<std::string>{"mesh", "scene.toml", "--solid", "-o", "solid.ply"},
          std::vector<std::string>{"mesh", "scene.toml", "--solid", "--base", "-5", "-o", "solid.ply"}}) {
        const RunResult r = run(args);
        EXPECT_EQ(r.status, 2) << r.err;
        EXPECT_EQ(r.err.find("inf"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("without triangles"), std::string::npos) << r.err;
        EXPECT_EQ(files(), (std::set<std::string>{"flat.pgm", "scene.toml"}));
    }
}

// 3 + 2^-16 under fractional_odd: the two tiny segments of each edge have no length in 16.16
// (the level's fraction is 2^-16, split in two), so 32 of each patch's 50 triangles have
// coincident corners. The exported mesh leaves them out (mesh.h) and says so, and what
// remains is crack-free: one boundary loop, no T-junction, no ray through it.
TEST_F(ExtremeLevels, ZeroLengthSegmentsLeaveACrackFreeMesh) {
    write_scene(level_scene("3.0000152587890625", "fractional_odd"));
    RunResult r = run({"mesh", "scene.toml", "-o", "slivers.ply"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.err.find("128 triangles whose corners weld together"), std::string::npos) << r.err;
    r = run({"check", "slivers.ply", "--expect", "open"});
    EXPECT_EQ(r.status, 0) << r.out << r.err;
}

// The generator's own API takes any float (a control shader can write anything): NaN and
// -inf discard the patch in every domain, +inf meets each spacing's upper bound.
TEST(ExtremeLevelsGenerator, NonFiniteLevels) {
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    for (const tessref::Domain domain : {tessref::Domain::quads, tessref::Domain::triangles, tessref::Domain::isolines}) {
        for (const tessref::Spacing spacing :
             {tessref::Spacing::equal, tessref::Spacing::fractional_odd, tessref::Spacing::fractional_even}) {
            SCOPED_TRACE(std::string(tessref::to_string(domain)) + ", " + std::string(tessref::to_string(spacing)));
            tessref::TessSettings s;
            s.domain = domain;
            s.spacing = spacing;
            for (const float bad : {nan, -inf}) {
                tessref::TessLevels l;
                l.outer = {bad, bad, bad, bad};
                l.inner = {bad, bad};
                for (const tessref::Precision precision : {tessref::Precision::gpu, tessref::Precision::exact}) {
                    const tessref::Pattern p = tessref::tessellate(s, l, precision);
                    EXPECT_TRUE(p.culled());
                    EXPECT_EQ(p.points().size(), 0u);
                    EXPECT_EQ(p.primitive_count(), 0u);
                }
            }
            tessref::TessLevels l;
            l.outer = {inf, inf, inf, inf};
            l.inner = {inf, inf};
            const tessref::Pattern p = tessref::tessellate(s, l);
            EXPECT_FALSE(p.culled());
            // Isolines: the line count is always processed as equal spacing (clamped to 64),
            // the segment count per line follows the spacing.
            const float top = spacing == tessref::Spacing::fractional_odd ? 63.0f : 64.0f;
            if (domain == tessref::Domain::isolines) {
                EXPECT_EQ(p.effective_levels().outer[0], 64.0f);
                EXPECT_EQ(p.effective_levels().outer[1], top);
                EXPECT_EQ(p.primitive_count(), static_cast<std::size_t>(64 * top));
            } else {
                for (int i = 0; i < (domain == tessref::Domain::quads ? 4 : 3); ++i)
                    EXPECT_EQ(p.effective_levels().outer[i], top) << i;
                EXPECT_EQ(p.effective_levels().inner[0], top);
                if (domain == tessref::Domain::quads) EXPECT_EQ(p.primitive_count(), quad_triangles(static_cast<int>(top)));
            }
        }
    }
}

}  // namespace
