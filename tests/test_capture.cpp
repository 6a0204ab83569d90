// Tests of tessref/capture.h: ulp distances (expected values from std::nextafter steps), the
// text and PLY forms written and read back bit for bit, the reader's errors (file and line),
// compare_captures on hand-made captures, the CPU reference's capture against the primitive
// generator and the geometry shader's face normal, and `tessref mesh --capture` / `tessref
// gl --capture` / `tessref compare` end to end.
#include <gtest/gtest.h>

#include "command_dir_test.h"
#include "run_program.h"

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <span>
#include <utility>
#include <regex>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "common/float_text.h"
#include "tessref/capture.h"
#include "tessref/error.h"
#include "tessref/mesh.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"
#include "tessref/tessellator.h"

namespace fs = std::filesystem;

namespace {

using tessref::Capture;
using tessref::CapturedVertex;
using tessref::CaptureCompareOptions;
using tessref::CaptureCompareResult;
using tessref::PatchDivergence;
using tessref::TessLevels;
using tessref::ulp_distance;
using tessref::test::read_file;
using tessref::test::RunResult;
using tessref::test::write_file;

const fs::path kSource = TESSREF_SOURCE_DIR;
fs::path scene_path(const std::string& name) { return kSource / "data" / "scenes" / (name + ".toml"); }

float step_up(float x, int steps) {
    for (int i = 0; i < steps; ++i) x = std::nextafter(x, std::numeric_limits<float>::infinity());
    return x;
}

bool same_bits(float a, float b) { return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b); }
bool same_bits(const glm::vec3& a, const glm::vec3& b) {
    return same_bits(a.x, b.x) && same_bits(a.y, b.y) && same_bits(a.z, b.z);
}

// ---- ulp distance ------------------------------------------------------------------------

TEST(UlpDistance, CountsNextafterStepsAcrossZeroAndToInfinity) {
    EXPECT_EQ(ulp_distance(1.0f, 1.0f), 0u);
    EXPECT_EQ(ulp_distance(1.0f, step_up(1.0f, 1)), 1u);
    EXPECT_EQ(ulp_distance(step_up(1.0f, 3), 1.0f), 3u);
    // Across a power of two the spacing halves, the count of representable steps does not.
    const float below_two = std::nextafter(2.0f, 0.0f);
    EXPECT_EQ(ulp_distance(below_two, step_up(2.0f, 2)), 3u);
    // +0 and -0 are one point; the smallest subnormals of either sign are one step from it.
    const float tiny = std::numeric_limits<float>::denorm_min();
    EXPECT_EQ(ulp_distance(0.0f, -0.0f), 0u);
    EXPECT_EQ(ulp_distance(-0.0f, tiny), 1u);
    EXPECT_EQ(ulp_distance(-tiny, tiny), 2u);
    EXPECT_EQ(ulp_distance(-1.0f, 1.0f), 2u * std::bit_cast<std::uint32_t>(1.0f));
    // The largest float is one step below infinity.
    EXPECT_EQ(ulp_distance(std::numeric_limits<float>::max(), std::numeric_limits<float>::infinity()), 1u);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    EXPECT_EQ(ulp_distance(nan, 1.0f), tessref::kInfiniteUlps);
    EXPECT_EQ(ulp_distance(0.0f, nan), tessref::kInfiniteUlps);
    EXPECT_EQ(ulp_distance(nan, -nan), 0u);
}

// ---- hand-made captures ------------------------------------------------------------------

TessLevels levels_of(float outer, float inner) {
    TessLevels l;
    l.outer = {outer, outer, outer, outer};
    l.inner = {inner, inner};
    return l;
}

CapturedVertex vertex(std::uint32_t patch, glm::vec3 tc, glm::vec3 position, glm::vec3 normal, TessLevels levels) {
    CapturedVertex v;
    v.patch_id = patch;
    v.tess_coord = tc;
    v.position = position;
    v.normal = normal;
    v.levels = levels;
    return v;
}

// Two quad patches at level 1 side by side (x 0..1 and 1..2), two triangles each, sharing
// the edge x = 1 (bitwise-equal positions there, as a crack-free terrain has them).
Capture two_patches() {
    Capture c;
    const TessLevels l = levels_of(1.0f, 1.0f);
    for (std::uint32_t p = 0; p < 2; ++p) {
        const float x0 = static_cast<float>(p);
        const auto at = [&](float u, float v) {
            return vertex(p, {u, v, 0.0f}, {x0 + u, v, 0.25f * (x0 + u) + 0.5f * v}, {0.0f, 0.0f, 1.0f}, l);
        };
        for (const CapturedVertex& v : {at(0, 0), at(1, 0), at(1, 1), at(0, 0), at(1, 1), at(0, 1)})
            c.vertices.push_back(v);
    }
    return c;
}

void expect_same(const Capture& a, const Capture& b, bool levels) {
    ASSERT_EQ(a.vertices.size(), b.vertices.size());
    for (std::size_t i = 0; i < a.vertices.size(); ++i) {
        const CapturedVertex &x = a.vertices[i], &y = b.vertices[i];
        EXPECT_EQ(x.patch_id, y.patch_id) << i;
        EXPECT_TRUE(same_bits(x.tess_coord, y.tess_coord)) << i;
        EXPECT_TRUE(same_bits(x.position, y.position)) << i;
        EXPECT_TRUE(same_bits(x.normal, y.normal) || (std::isnan(x.normal.x) && std::isnan(y.normal.x))) << i;
        if (levels) {
            EXPECT_EQ(std::memcmp(x.levels.outer.data(), y.levels.outer.data(), sizeof(float) * 4), 0) << i;
            EXPECT_EQ(std::memcmp(x.levels.inner.data(), y.levels.inner.data(), sizeof(float) * 2), 0) << i;
        }
    }
}

class CaptureFiles : public tessref::test::CommandDirTest {};

TEST_F(CaptureFiles, TextRoundTripsEveryFloatBitwise) {
    Capture c = two_patches();
    // Values %.6g would lose, signed zero, a subnormal, a huge number, odd levels.
    c.vertices[0].position = {0.1f, -0.0f, std::numeric_limits<float>::denorm_min()};
    c.vertices[1].position = {3.40282e38f, step_up(1.0f, 1), -123456.789f};
    c.vertices[2].normal = {std::nextafter(0.5f, 0.0f), -0.0f, 1e-30f};
    for (std::size_t i = 6; i < 12; ++i) c.vertices[i].levels = levels_of(3.3f, step_up(7.0f, 5));
    // Patch 0 again after patch 1: a second run of the same patch.
    for (std::size_t i = 0; i < 3; ++i) c.vertices.push_back(c.vertices[i]);
    write_file(path("c.txt"), tessref::capture_text(c.vertices, "test"));
    const Capture back = tessref::read_capture(path("c.txt"));
    EXPECT_TRUE(back.has_levels);
    EXPECT_EQ(back.source, path("c.txt"));
    expect_same(c, back, true);
    // The layout: version line first, then a patch line before each run of a patch.
    const std::string text = read_file(path("c.txt"));
    EXPECT_EQ(text.rfind("tessref-capture 1\n", 0), 0u) << text;
    EXPECT_NE(text.find("\npatch 1 levels 3.29999995 3.29999995 3.29999995 3.29999995 7.00000238 7.00000238\n"),
              std::string::npos)
        << text;
}

// The capture text's numbers are printf's "%.9g" of each float, byte for byte: the golden
// digests hash that text, and tools that read it (grep, awk) see what every earlier version
// wrote. The writer is not printf (src/common/float_text.h), so it is held to printf here:
// special values, every decade's edges, exact ties of the tenth digit (n + 1/8 above 10^6:
// printf rounds those to even), short decimals and a million random bit patterns.
TEST(CaptureText, FloatsAreWrittenAsPrintfWritesThem) {
    std::vector<float> values = {0.0f, -0.0f, std::numeric_limits<float>::quiet_NaN(),
                                 -std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                                 -std::numeric_limits<float>::infinity(), std::numeric_limits<float>::denorm_min(),
                                 std::numeric_limits<float>::min(), std::numeric_limits<float>::max(),
                                 -std::numeric_limits<float>::max(), 1.0f, 0.1f, 1e-4f, 1e-5f, 99999.9999f};
    for (int e = -45; e <= 38; ++e) {
        const float p = static_cast<float>(std::pow(10.0, e));
        float down = p, up = p;
        for (int k = 0; k < 3; ++k) {
            down = std::nextafter(down, 0.0f);
            up = std::nextafter(up, std::numeric_limits<float>::infinity());
            values.insert(values.end(), {down, up});
        }
        values.push_back(p);
        values.push_back(static_cast<float>(9.999999995 * std::pow(10.0, e)));
    }
    for (int n = 1000000; n < 1000000 + 20000; ++n)
        for (int k = 0; k < 8; ++k) values.push_back(static_cast<float>(n) + static_cast<float>(k) / 8.0f);
    for (int i = 0; i < 100000; ++i) values.push_back(static_cast<float>(i) / 1000.0f);
    std::uint64_t state = 0x9e3779b97f4a7c15ull;  // splitmix64: any platform, one sequence
    for (int i = 0; i < 1000000; ++i) {
        std::uint64_t z = (state += 0x9e3779b97f4a7c15ull);
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
        values.push_back(std::bit_cast<float>(static_cast<std::uint32_t>(z ^ (z >> 31))));
    }
    std::size_t wrong = 0;
    for (const float x : values) {
        char expected[64], got[tessref::kFloatTextMax];
        const int n = std::snprintf(expected, sizeof expected, "%.9g", x);
        const std::string written(got, tessref::write_float_g9(got, x));
        if (written != std::string(expected, static_cast<std::size_t>(n)) && wrong++ < 10)
            ADD_FAILURE() << "bits " << std::hex << std::bit_cast<std::uint32_t>(x) << ": printf " << expected
                          << ", written " << written;
    }
    EXPECT_EQ(wrong, 0u) << "of " << values.size();

    // And a vertex line of capture_text is those words.
    Capture c = two_patches();
    c.vertices[0].tess_coord = {1234567.125f, 0.1f, -0.0f};
    c.vertices[0].position = {std::numeric_limits<float>::denorm_min(), -3.40282e38f, 1e-5f};
    c.vertices[0].normal = {std::nextafter(0.5f, 0.0f), 1e9f, 123456789.0f};
    const CapturedVertex& v = c.vertices[0];
    char line[400];
    std::snprintf(line, sizeof line, "\n%u %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", v.patch_id, v.tess_coord.x,
                  v.tess_coord.y, v.tess_coord.z, v.position.x, v.position.y, v.position.z, v.normal.x, v.normal.y,
                  v.normal.z);
    EXPECT_NE(tessref::capture_text(c.vertices).find(line), std::string::npos) << line;
}

TEST_F(CaptureFiles, PlyRoundTripsUnweldedWithoutLevels) {
    const Capture c = two_patches();
    {
        std::ofstream out(path("c.ply"), std::ios::binary);
        tessref::write_capture(c.vertices, out, tessref::CaptureFormat::ply);
    }
    const Capture back = tessref::read_capture(path("c.ply"));
    EXPECT_FALSE(back.has_levels);
    // Patch 1's corners on x = 1 keep patch 1 and u = 0 although patch 0 has the same points.
    expect_same(c, back, false);
    EXPECT_NE(read_file(path("c.ply")).find("element vertex 12\n"), std::string::npos);
}

TEST_F(CaptureFiles, WeldedPlyIsRefusedAsNotACapture) {
    // What `tessref gl --capture x.ply` wrote before: write_mesh's default weld gives the
    // shared corners patch 0's provenance, so patch 1's triangles mix two patches.
    {
        std::ofstream out(path("w.ply"), std::ios::binary);
        tessref::MeshWriteOptions options;
        tessref::write_mesh(tessref::capture_mesh(two_patches().vertices), out, options);
    }
    try {
        tessref::read_capture(path("w.ply"));
        FAIL() << "a welded PLY was read as a capture";
    } catch (const tessref::Error& e) {
        EXPECT_NE(std::string(e.what()).find("welded"), std::string::npos) << e.what();
        EXPECT_EQ(e.where().file, path("w.ply"));
    }
}

// A capture text with one line replaced: the error names the file and that line.
struct BadText {
    const char* name;
    int line;                 // 1-based line replaced (-1: the last line removed instead)
    const char* replacement;  // the new line
    const char* message;      // part of the message
    int error_line;           // the line the error names
};

class CaptureReadErrors : public CaptureFiles, public ::testing::WithParamInterface<BadText> {};

TEST_P(CaptureReadErrors, NameFileAndLine) {
    const BadText b = GetParam();
    std::string text = tessref::capture_text(two_patches().vertices);
    // Lines: 1 version, 2-3 comments, 4 "patch 0 ...", 5-10 patch 0's vertices,
    // 11 "patch 1 ...", 12-17 patch 1's vertices. A vertex line without a patch line fails
    // at the vertex (5); a file ending inside a triangle at its last line (16).
    std::vector<std::string> lines;
    for (std::size_t start = 0; start < text.size();) {
        const std::size_t end = text.find('\n', start);
        lines.push_back(text.substr(start, end - start));
        start = end + 1;
    }
    ASSERT_EQ(lines.size(), 17u);
    ASSERT_EQ(lines[10].rfind("patch 1 levels", 0), 0u);
    if (b.line == -1) {
        lines.pop_back();  // the file ends in the middle of a triangle
    } else {
        lines[static_cast<std::size_t>(b.line - 1)] = b.replacement;
    }
    text.clear();
    for (const std::string& l : lines) text += l + "\n";
    write_file(path("bad.txt"), text);
    try {
        tessref::read_capture(path("bad.txt"));
        FAIL() << b.name << " was read";
    } catch (const tessref::Error& e) {
        const int line = b.error_line;
        EXPECT_EQ(e.where().file, path("bad.txt")) << e.what();
        EXPECT_EQ(e.where().line, line) << e.what();
        EXPECT_NE(std::string(e.what()).find(b.message), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("line " + std::to_string(line)), std::string::npos) << e.what();
    }
}

INSTANTIATE_TEST_SUITE_P(
    Text, CaptureReadErrors,
    ::testing::Values(BadText{"version", 1, "tessref-capture 2", "not a tessref capture", 1},
                      BadText{"truncated", 6, "0 1 0 0 1 0 0.25 0 0", "the line ends where a normal was expected", 6},
                      BadText{"number", 7, "0 1 1 0 1 1 0.75 0 0 1x", "bad number '1x'", 7},
                      BadText{"number out of float range", 7, "0 1 1 0 1 1 0.75 0 0 1e39", "bad number '1e39'", 7},
                      BadText{"extra", 8, "0 0 0 0 0 0 0 0 0 1 5", "unexpected '5'", 8},
                      BadText{"patch header", 11, "patch 1 levels 1 1 1 1 1", "the line ends where a level was expected", 11},
                      BadText{"patch keyword", 11, "patch 1 lvls 1 1 1 1 1 1", "bad patch line", 11},
                      BadText{"patch id", 11, "patch -1 levels 1 1 1 1 1 1", "bad number '-1' (expected a patch id)", 11},
                      BadText{"wrong patch", 12, "0 0 0 0 1 0 0 0 0 1", "vertex of patch 0 under the line 'patch 1'", 12},
                      BadText{"no patch line", 4, "# no patch line", "before any 'patch", 5},
                      BadText{"levels again", 11, "patch 0 levels 2 2 2 2 2 2", "other levels", 11},
                      BadText{"not whole triangles", -1, "", "not whole triangles", 16}),
    [](const auto& info) {
        std::string name = info.param.name;
        for (char& c : name) c = std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
        return name;
    });

// ---- compare_captures --------------------------------------------------------------------

TEST(CompareCaptures, IdenticalPassesWhateverTheTriangleAndCornerOrder) {
    const Capture ref = two_patches();
    Capture test;
    // Triangles reversed, each triangle's corners rotated (the same way round).
    for (std::size_t t = ref.vertices.size() / 3; t-- > 0;)
        for (const int k : {1, 2, 0}) test.vertices.push_back(ref.vertices[3 * t + static_cast<std::size_t>(k)]);
    const CaptureCompareResult r = tessref::compare_captures(ref, test);
    EXPECT_TRUE(r.passed);
    EXPECT_EQ(r.reference_patches, 2u);
    EXPECT_EQ(r.compared_patches, 2u);
    EXPECT_EQ(r.vertices_compared, 12u);
    EXPECT_EQ(r.worst_position.ulps, 0u);
    EXPECT_TRUE(r.worst_position.found);
    EXPECT_TRUE(r.listed.empty());
}

TEST(CompareCaptures, PositionThreeUlpsOffFailsAtTwoNamingPatchAndTessCoord) {
    const Capture ref = two_patches();
    Capture test = ref;
    // Patch 1, corner (1, 1) of its first triangle: y three ulps up. The corner (1, 1) is in
    // both of patch 1's triangles; only this copy moves.
    test.vertices[8].position.y = step_up(ref.vertices[8].position.y, 3);
    CaptureCompareOptions options;
    options.max_position_ulps = 2;
    const CaptureCompareResult r = tessref::compare_captures(ref, test, options);
    EXPECT_FALSE(r.passed);
    EXPECT_EQ(r.value_divergences, 1u);
    EXPECT_EQ(r.failing_vertices, 1u);
    ASSERT_EQ(r.failing_vertices_per_patch.size(), 1u);
    EXPECT_EQ(r.failing_vertices_per_patch[0], (std::pair<std::uint32_t, std::size_t>{1, 1}));
    ASSERT_EQ(r.listed.size(), 1u);
    EXPECT_EQ(r.listed[0].patch_id, 1u);
    EXPECT_EQ(r.listed[0].kind, PatchDivergence::values);
    EXPECT_TRUE(same_bits(r.listed[0].tess_coord, glm::vec3(1.0f, 1.0f, 0.0f)));
    EXPECT_EQ(r.listed[0].position_ulps, 3u);
    EXPECT_TRUE(same_bits(r.listed[0].test_position, test.vertices[8].position));
    EXPECT_EQ(r.worst_position.ulps, 3u);
    EXPECT_EQ(r.worst_position.patch_id, 1u);
    EXPECT_EQ(r.worst_position.component, 1);
    options.max_position_ulps = 3;
    EXPECT_TRUE(tessref::compare_captures(ref, test, options).passed);
}

TEST(CompareCaptures, NormalBeyondItsOwnTolerance) {
    const Capture ref = two_patches();
    Capture test = ref;
    test.vertices[0].normal.z = std::nextafter(1.0f, 0.0f);
    CaptureCompareOptions options;
    options.max_position_ulps = 100;
    EXPECT_FALSE(tessref::compare_captures(ref, test, options).passed);
    options.max_normal_ulps = 1;
    const CaptureCompareResult r = tessref::compare_captures(ref, test, options);
    EXPECT_TRUE(r.passed);
    EXPECT_EQ(r.worst_normal.ulps, 1u);
    EXPECT_EQ(r.worst_normal.component, 2);
}

TEST(CompareCaptures, MissingPatchOnEitherSide) {
    const Capture ref = two_patches();
    Capture test = ref;
    test.vertices.resize(6);  // patch 1 gone
    CaptureCompareResult r = tessref::compare_captures(ref, test);
    EXPECT_FALSE(r.passed);
    EXPECT_EQ(r.missing_in_test, 1u);
    EXPECT_EQ(r.missing_in_reference, 0u);
    ASSERT_EQ(r.listed.size(), 1u);
    EXPECT_EQ(r.listed[0].patch_id, 1u);
    EXPECT_EQ(r.listed[0].kind, PatchDivergence::missing_in_test);
    EXPECT_EQ(r.listed[0].reference_vertices, 6u);
    r = tessref::compare_captures(test, ref);
    EXPECT_EQ(r.missing_in_reference, 1u);
    EXPECT_EQ(r.listed[0].kind, PatchDivergence::missing_in_reference);
}

TEST(CompareCaptures, TessCoordOneBitOffIsATessCoordDivergenceWithLevels) {
    const Capture ref = two_patches();
    Capture test = ref;
    // Patch 0's corner (0, 1) (its last vertex) moves to the next float of v below 1;
    // its levels differ by one ulp of the inner level too.
    const float v = std::bit_cast<float>(std::bit_cast<std::uint32_t>(1.0f) - 1);
    test.vertices[5].tess_coord.y = v;
    for (std::size_t i = 0; i < 6; ++i) test.vertices[i].levels.inner[1] = step_up(1.0f, 1);
    const CaptureCompareResult r = tessref::compare_captures(ref, test);
    EXPECT_FALSE(r.passed);
    EXPECT_EQ(r.tess_coord_divergences, 1u);
    EXPECT_EQ(r.tess_coord_divergences_with_equal_levels, 0u);
    EXPECT_EQ(r.compared_patches, 1u);  // patch 1
    ASSERT_EQ(r.listed.size(), 1u);
    const tessref::DivergingPatch& d = r.listed[0];
    EXPECT_EQ(d.patch_id, 0u);
    EXPECT_EQ(d.kind, PatchDivergence::tess_coords);
    EXPECT_TRUE(d.levels_known);
    EXPECT_EQ(d.level_ulps, 1u);
    // (0, v) sorts before (0, 1): the smallest tess coord that only one side has is the test's.
    EXPECT_FALSE(d.tess_coord_in_reference);
    EXPECT_TRUE(same_bits(d.tess_coord, glm::vec3(0.0f, v, 0.0f)));
}

TEST(CompareCaptures, SameTessCoordsOtherTrianglesIsATriangleDivergence) {
    const Capture ref = two_patches();
    Capture test = ref;
    // Patch 0 is {00, 10, 11} {00, 11, 01}: 00 and 11 twice, 10 and 01 once. The test's
    // {00, 10, 01} {00, 11, 11} holds the same multiset in other sets (the second is
    // degenerate, which the comparison does not care about).
    const CapturedVertex c00 = ref.vertices[0], c10 = ref.vertices[1], c11 = ref.vertices[2], c01 = ref.vertices[5];
    const CapturedVertex other_sets[6] = {c00, c10, c01, c00, c11, c11};
    for (std::size_t i = 0; i < 6; ++i) test.vertices[i] = other_sets[i];
    const CaptureCompareResult r = tessref::compare_captures(ref, test);
    EXPECT_FALSE(r.passed);
    EXPECT_EQ(r.tess_coord_divergences, 0u);
    EXPECT_EQ(r.triangle_divergences, 1u);
    ASSERT_EQ(r.listed.size(), 1u);
    EXPECT_EQ(r.listed[0].patch_id, 0u);
    EXPECT_EQ(r.listed[0].kind, PatchDivergence::triangles);
}

// A `cw` evaluation layout where the reference has `ccw` gives the same triangles with
// their corners the other way round: the comparison must say so, not pass. Patch 1's
// second triangle 00, 11, 01 (vertices 9, 10, 11) is written 00, 01, 11: one swap.
TEST(CompareCaptures, ATriangleTheOtherWayRoundIsAnOrientationDivergence) {
    const Capture ref = two_patches();
    Capture test = ref;
    std::swap(test.vertices[10], test.vertices[11]);
    const CaptureCompareResult r = tessref::compare_captures(ref, test);
    EXPECT_FALSE(r.passed);
    EXPECT_EQ(r.triangle_divergences, 0u);
    EXPECT_EQ(r.orientation_divergences, 1u);
    EXPECT_EQ(r.flipped_triangles, 1u);
    EXPECT_EQ(r.compared_patches, 1u);  // patch 0
    ASSERT_EQ(r.listed.size(), 1u);
    EXPECT_EQ(r.listed[0].patch_id, 1u);
    EXPECT_EQ(r.listed[0].kind, PatchDivergence::orientation);
    EXPECT_EQ(r.listed[0].flipped_triangles, 1u);
    // Every triangle of both patches flipped: two patches, four triangles.
    Capture all = ref;
    for (std::size_t t = 0; t < all.vertices.size() / 3; ++t) std::swap(all.vertices[3 * t + 1], all.vertices[3 * t + 2]);
    const CaptureCompareResult a = tessref::compare_captures(ref, all);
    EXPECT_EQ(a.orientation_divergences, 2u);
    EXPECT_EQ(a.flipped_triangles, 4u);
}

TEST(CompareCaptures, RefusesACaptureOfPartTriangles) {
    Capture c = two_patches();
    c.vertices.pop_back();
    c.source = "x.txt";
    EXPECT_THROW(tessref::compare_captures(two_patches(), c), tessref::Error);
}

// ---- the streamed comparison -------------------------------------------------------------

namespace {

// Patches 0..7 of a 2x2-quad grid each (8 triangles), and what the test side does to them:
// 1 missing, 2 a position 3 ulps off, 3 a tess coord one bit off with other levels, 4 a
// quad's tess coords in other triangles, 5 a triangle the other way round, 6 a normal off,
// 8 only in the test; the rest the same, triangles reversed and corners rotated.
// `reference_order`: the test's triangles and corners as the reference has them, where the
// tess coords allow (llvmpipe's usual capture), instead of reversed and rotated.
std::pair<Capture, Capture> patches_of_every_divergence(bool reference_order = false) {
    Capture ref, test;
    for (std::uint32_t p = 0; p < 9; ++p) {
        std::vector<CapturedVertex> r, t;
        const TessLevels l = levels_of(2.0f + 0.125f * static_cast<float>(p), 2.0f);
        const auto at = [&](int i, int j) {
            const float u = 0.5f * static_cast<float>(i), v = 0.5f * static_cast<float>(j);
            const float x = static_cast<float>(p) + u;
            return vertex(p, {u, v, 0.0f}, {x, v, 0.3f * x + 0.7f * v}, {0.1f * u, 0.2f, 0.9f}, l);
        };
        for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2; ++j) {
                for (const CapturedVertex& v : {at(i, j), at(i + 1, j), at(i + 1, j + 1)}) r.push_back(v);
                for (const CapturedVertex& v : {at(i, j), at(i + 1, j + 1), at(i, j + 1)}) r.push_back(v);
            }
        t = r;
        if (p == 2) t[4].position.y = std::nextafter(std::nextafter(std::nextafter(t[4].position.y, 9.0f), 9.0f), 9.0f);
        if (p == 3) {
            for (CapturedVertex& v : t) v.levels.outer[0] = std::nextafter(v.levels.outer[0], 9.0f);
            t[2].tess_coord.x = std::nextafter(t[2].tess_coord.x, 9.0f);
        }
        if (p == 4) {  // the first quad's {00 10 11} {00 11 01} as {00 10 01} {00 11 11}: same tess coords
            t[0] = at(0, 0), t[1] = at(1, 0), t[2] = at(0, 1);
            t[3] = at(0, 0), t[4] = at(1, 1), t[5] = at(1, 1);
        }
        if (p == 5) std::swap(t[7], t[8]);
        if (p == 6) t[10].normal.z = std::nextafter(std::nextafter(std::nextafter(std::nextafter(t[10].normal.z, 0.0f), 0.0f), 0.0f), 0.0f);
        if (p != 8) ref.vertices.insert(ref.vertices.end(), r.begin(), r.end());
        if (p == 1) continue;
        if (reference_order) {
            test.vertices.insert(test.vertices.end(), t.begin(), t.end());
            continue;
        }
        for (std::size_t k = t.size() / 3; k-- > 0;)
            for (const int c : {1, 2, 0}) test.vertices.push_back(t[3 * k + static_cast<std::size_t>(c)]);
    }
    return {ref, test};
}

void expect_same_result(const CaptureCompareResult& a, const CaptureCompareResult& b) {
    EXPECT_EQ(a.reference_patches, b.reference_patches);
    EXPECT_EQ(a.test_patches, b.test_patches);
    EXPECT_EQ(a.compared_patches, b.compared_patches);
    EXPECT_EQ(a.vertices_compared, b.vertices_compared);
    EXPECT_EQ(a.failing_vertices, b.failing_vertices);
    EXPECT_EQ(a.missing_in_test, b.missing_in_test);
    EXPECT_EQ(a.missing_in_reference, b.missing_in_reference);
    EXPECT_EQ(a.tess_coord_divergences, b.tess_coord_divergences);
    EXPECT_EQ(a.tess_coord_divergences_with_equal_levels, b.tess_coord_divergences_with_equal_levels);
    EXPECT_EQ(a.triangle_divergences, b.triangle_divergences);
    EXPECT_EQ(a.orientation_divergences, b.orientation_divergences);
    EXPECT_EQ(a.flipped_triangles, b.flipped_triangles);
    EXPECT_EQ(a.value_divergences, b.value_divergences);
    EXPECT_EQ(a.passed, b.passed);
    for (const auto& [x, y] : {std::pair{&a.worst_position, &b.worst_position}, std::pair{&a.worst_normal, &b.worst_normal}}) {
        EXPECT_EQ(x->ulps, y->ulps);
        EXPECT_EQ(x->found, y->found);
        EXPECT_EQ(x->patch_id, y->patch_id);
        EXPECT_TRUE(same_bits(x->tess_coord, y->tess_coord));
        EXPECT_EQ(x->component, y->component);
        EXPECT_TRUE(same_bits(x->reference, y->reference));
        EXPECT_TRUE(same_bits(x->test, y->test));
    }
    for (std::size_t k = 0; k < 4; ++k) {
        EXPECT_EQ(a.components[k].compared, b.components[k].compared) << k;
        EXPECT_EQ(a.components[k].max_ulps, b.components[k].max_ulps) << k;
        EXPECT_EQ(a.components[k].max_abs, b.components[k].max_abs) << k;
        EXPECT_EQ(a.components[k].sum_abs, b.components[k].sum_abs) << k;
        EXPECT_EQ(a.components[k].beyond, b.components[k].beyond) << k;
    }
    EXPECT_EQ(a.failing_vertices_per_patch, b.failing_vertices_per_patch);
    ASSERT_EQ(a.listed.size(), b.listed.size());
    for (std::size_t k = 0; k < a.listed.size(); ++k) {
        const tessref::DivergingPatch &x = a.listed[k], &y = b.listed[k];
        EXPECT_EQ(x.patch_id, y.patch_id) << k;
        EXPECT_EQ(x.kind, y.kind) << k;
        EXPECT_EQ(x.reference_vertices, y.reference_vertices) << k;
        EXPECT_EQ(x.test_vertices, y.test_vertices) << k;
        EXPECT_EQ(x.levels_known, y.levels_known) << k;
        EXPECT_EQ(x.level_ulps, y.level_ulps) << k;
        EXPECT_EQ(std::memcmp(&x.reference_levels, &y.reference_levels, sizeof(TessLevels)), 0) << k;
        EXPECT_EQ(std::memcmp(&x.test_levels, &y.test_levels, sizeof(TessLevels)), 0) << k;
        EXPECT_TRUE(same_bits(x.tess_coord, y.tess_coord)) << k;
        EXPECT_EQ(x.tess_coord_in_reference, y.tess_coord_in_reference) << k;
        EXPECT_EQ(x.flipped_triangles, y.flipped_triangles) << k;
        EXPECT_EQ(x.failing_vertices, y.failing_vertices) << k;
        EXPECT_TRUE(same_bits(x.reference_position, y.reference_position)) << k;
        EXPECT_TRUE(same_bits(x.test_position, y.test_position)) << k;
        EXPECT_TRUE(same_bits(x.reference_normal, y.reference_normal)) << k;
        EXPECT_TRUE(same_bits(x.test_normal, y.test_normal)) << k;
        EXPECT_EQ(x.position_ulps, y.position_ulps) << k;
        EXPECT_EQ(x.normal_ulps, y.normal_ulps) << k;
    }
}

// The triangles of each patch of `c`, by patch id (the patch of each triangle's first corner).
std::map<std::uint32_t, std::vector<CapturedVertex>> by_patch(const Capture& c) {
    std::map<std::uint32_t, std::vector<CapturedVertex>> patches;
    for (std::size_t t = 0; t < c.vertices.size() / 3; ++t)
        patches[c.vertices[3 * t].patch_id].insert(patches[c.vertices[3 * t].patch_id].end(),
                                                    c.vertices.begin() + static_cast<std::ptrdiff_t>(3 * t),
                                                    c.vertices.begin() + static_cast<std::ptrdiff_t>(3 * t + 3));
    return patches;
}

}  // namespace

// The streamed comparison, fed the patches one call each or all in one call, gives what
// compare_captures gives on the whole captures, every field, with every kind of
// divergence among the patches (the golden verification compares llvmpipe's capture so).
TEST(StreamedCaptureComparison, GivesTheWholeComparisonsResult) {
    // Also with the test in the reference's order, where the streamed comparison makes and
    // sorts the triangles of a patch whose tess coords match vertex for vertex only once.
    for (const bool reference_order : {false, true}) {
        SCOPED_TRACE(reference_order ? "the test in the reference's order" : "the test reversed and rotated");
        const auto [ref, test] = patches_of_every_divergence(reference_order);
        CaptureCompareOptions options;
        options.max_position_ulps = 2;
        options.max_normal_ulps = 2;
        options.max_listed = 100;
        const CaptureCompareResult whole = tessref::compare_captures(ref, test, options);
        ASSERT_EQ(whole.missing_in_test, 1u);
        ASSERT_EQ(whole.missing_in_reference, 1u);
        ASSERT_EQ(whole.tess_coord_divergences, 1u);
        ASSERT_EQ(whole.triangle_divergences, 1u);
        ASSERT_EQ(whole.orientation_divergences, 1u);
        ASSERT_EQ(whole.value_divergences, 2u);
        ASSERT_EQ(whole.worst_position.ulps, 3u);
        const auto r = by_patch(ref), t = by_patch(test);
        std::set<std::uint32_t> ids;
        for (const auto& [p, v] : r) ids.insert(p);
        for (const auto& [p, v] : t) ids.insert(p);
        const std::vector<CapturedVertex> none;
        std::vector<tessref::StreamedCaptureComparison::PatchPair> pairs;
        for (const std::uint32_t p : ids) {
            tessref::StreamedCaptureComparison::PatchPair pair;
            pair.patch = p;
            pair.reference = r.count(p) ? r.at(p) : none;
            pair.test = t.count(p) ? t.at(p) : none;
            pairs.push_back(pair);
        }
        tessref::StreamedCaptureComparison one_call(options), call_each(options);
        one_call.add(pairs);
        for (const auto& pair : pairs) call_each.add(std::span(&pair, 1));
        expect_same_result(one_call.finish(), whole);
        expect_same_result(call_each.finish(), whole);
    }
}

// A patch given twice, or after a higher one, would be compared without its other triangles.
TEST(StreamedCaptureComparison, RefusesPatchesOutOfOrder) {
    const auto [ref, test] = patches_of_every_divergence();
    const auto r = by_patch(ref);
    tessref::StreamedCaptureComparison compare;
    tessref::StreamedCaptureComparison::PatchPair pair;
    pair.patch = 3;
    pair.reference = pair.test = r.at(3);
    compare.add(std::span(&pair, 1));
    EXPECT_THROW(compare.add(std::span(&pair, 1)), tessref::Error);
    pair.patch = 2;
    pair.reference = pair.test = r.at(2);
    EXPECT_THROW(compare.add(std::span(&pair, 1)), tessref::Error);
}

// ---- the CPU reference's capture ---------------------------------------------------------

// COSC422's terrain (plane xz, z descending: ccw faces up) with face normals, drawn ccw and
// cw: cw makes the pipeline re-orient every triangle to face up. The capture must still be
// the generator's primitives in its order (tessellate() on the patch's levels), and each
// triangle's normal what cosc422_terrain.geom computes from the corners as GL emits them:
// normalize(cross(p1 - p0, p2 - p0)), its x, y, z each 0 ulps away.
class CpuCapture : public ::testing::TestWithParam<const char*> {};

TEST_P(CpuCapture, IsTheGeneratorsOrderWithTheGeometryShadersFaceNormal) {
    std::string toml = read_file(scene_path("cosc422"));
    const std::string ccw = "winding = \"ccw\"";
    const std::size_t at = toml.find(ccw);
    ASSERT_NE(at, std::string::npos);
    toml.replace(at, ccw.size(), std::string("winding = \"") + GetParam() + "\"");
    const tessref::Scene scene = tessref::load_scene_from_string(toml, scene_path("cosc422").string());
    const tessref::PipelineResult result = tessref::run_pipeline(scene);
    const std::vector<CapturedVertex> capture = tessref::capture_from_pipeline(scene, result);
    ASSERT_EQ(capture.size(), result.mesh.triangles.size() * 3);

    std::size_t next = 0, mismatched_tess_coords = 0, mismatched_normals = 0, mismatched_levels = 0;
    for (std::uint32_t p = 0; p < result.levels.size(); ++p) {
        const tessref::Pattern pattern = tessref::tessellate(scene.generator, result.levels[p]);
        const auto points = pattern.points();
        for (std::size_t t = 0; t < pattern.primitive_count(); ++t, next += 3) {
            ASSERT_LE(next + 3, capture.size());
            const auto prim = pattern.primitive(t);
            for (std::size_t k = 0; k < 3; ++k) {
                const CapturedVertex& v = capture[next + k];
                ASSERT_EQ(v.patch_id, p);
                const auto& q = points[prim[k]];
                if (!same_bits(v.tess_coord, glm::vec3(q.u, q.v, q.w))) ++mismatched_tess_coords;
                if (std::memcmp(&v.levels, &result.levels[p], sizeof(TessLevels)) != 0) ++mismatched_levels;
            }
            const glm::vec3 p0 = capture[next].position, p1 = capture[next + 1].position, p2 = capture[next + 2].position;
            const glm::vec3 expected = glm::normalize(glm::cross(p1 - p0, p2 - p0));
            // Up to the sign of a zero component: the pipeline's normal of the re-oriented
            // corners, negated, is exact but for that (ulp distance 0).
            for (std::size_t k = 0; k < 3; ++k)
                for (int c = 0; c < 3; ++c)
                    if (ulp_distance(capture[next + k].normal[c], expected[c]) != 0) ++mismatched_normals;
        }
    }
    EXPECT_EQ(next, capture.size());
    EXPECT_EQ(mismatched_tess_coords, 0u);
    EXPECT_EQ(mismatched_normals, 0u);
    EXPECT_EQ(mismatched_levels, 0u);
    // The face up (+y) whatever the winding asks: ccw's normals point up, cw's down.
    std::size_t up = 0;
    for (const CapturedVertex& v : capture) up += v.normal.y > 0.0f;
    EXPECT_EQ(up, std::string(GetParam()) == "ccw" ? capture.size() : 0u);
}

INSTANTIATE_TEST_SUITE_P(Windings, CpuCapture, ::testing::Values("ccw", "cw"));

// ---- the command, end to end --------------------------------------------------------------

class CaptureCommand : public tessref::test::CommandDirTest {};

TEST_F(CaptureCommand, MeshCaptureAloneWritesOnlyTheCapture) {
    const RunResult r = run({"mesh", scene_path("thesis-constant-1").string(), "--capture", path("cpu.txt")});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(files(), (std::set<std::string>{"cpu.txt"}));
    // 16 x 16 patches at level 1: two triangles each.
    const Capture c = tessref::read_capture(path("cpu.txt"));
    EXPECT_EQ(c.vertices.size(), 16u * 16u * 2u * 3u);
}

TEST_F(CaptureCommand, MeshWithMeshAndCaptureWritesBoth) {
    const RunResult r = run({"mesh", scene_path("thesis-constant-1").string(), "-o", path("m.ply"), "--capture",
                             path("cpu.ply")});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(files(), (std::set<std::string>{"cpu.ply", "m.ply"}));
    EXPECT_EQ(tessref::read_capture(path("cpu.ply")).vertices.size(), 16u * 16u * 2u * 3u);
}

TEST_F(CaptureCommand, MeshWithNothingToWriteOrABadCaptureNameIsExit2AndWritesNothing) {
    for (const std::vector<std::string>& args :
         {std::vector<std::string>{"mesh", scene_path("thesis-constant-1").string()},
          std::vector<std::string>{"mesh", scene_path("thesis-constant-1").string(), "--capture", path("c.obj")},
          std::vector<std::string>{"mesh", scene_path("thesis-constant-1").string(), "--capture", path("c.txt"),
                                   "--solid"}}) {
        const RunResult r = run(args);
        EXPECT_EQ(r.status, 2) << args.back() << r.err;
        EXPECT_NE(r.err.find("tessref: error:"), std::string::npos) << r.err;
        EXPECT_TRUE(files().empty());
    }
}

// The CPU reference against llvmpipe (OSMesa, a build dependency): wherever GL's control
// shader wrote bitwise the CPU's levels, the generator must give bitwise the same tess
// coords and triangles; every patch is on both sides.
class CpuAgainstGl : public CaptureCommand, public ::testing::WithParamInterface<const char*> {};

TEST_P(CpuAgainstGl, SameTessCoordsWhereverTheLevelsAreTheSame) {
    const std::string scene = scene_path(GetParam()).string();
    RunResult r = run({"mesh", scene, "--capture", path("cpu.txt")});
    ASSERT_EQ(r.status, 0) << r.err;
    r = run({"gl", scene, "-o", path("gl.png"), "--size", "64x40", "--capture", path("gl.txt")});
    ASSERT_EQ(r.status, 0) << r.err;
    r = run({"compare", path("cpu.txt"), path("gl.txt"), "--json"});
    ASSERT_TRUE(r.status == 0 || r.status == 1) << r.out << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["missing_in_test"], 0) << r.out;
    EXPECT_EQ(j["missing_in_reference"], 0) << r.out;
    EXPECT_EQ(j["tess_coord_divergences_with_equal_levels"], 0) << r.out;
    EXPECT_EQ(j["triangle_divergences"], 0) << r.out;
    EXPECT_EQ(j["reference_patches"], 256) << r.out;
    EXPECT_EQ(j["passed"], r.status == 0);
    std::printf("[cpu vs gl] %s: %s tess-coord divergences, worst position %s ulps, worst normal %s ulps\n",
                GetParam(), j["tess_coord_divergences"].dump().c_str(), j["worst_position"]["ulps"].dump().c_str(),
                j["worst_normal"]["ulps"].dump().c_str());
    // The text report of the same comparison ends in its verdict.
    r = run({"compare", path("cpu.txt"), path("gl.txt")});
    EXPECT_NE(r.out.find(r.status == 0 ? "PASS\n" : "FAIL\n"), std::string::npos) << r.out;
    EXPECT_TRUE(files() == (std::set<std::string>{"cpu.txt", "gl.png", "gl.txt"}));
}

INSTANTIATE_TEST_SUITE_P(Scenes, CpuAgainstGl, ::testing::Values("thesis-constant-1", "thesis-map-4"),
                         [](const auto& info) {
                             std::string name = info.param;
                             for (char& c : name) c = c == '-' ? '_' : c;
                             return name;
                         });

TEST_F(CaptureCommand, CompareFailsWithExit1NamingThePatchAndPassesWithTheTolerance) {
    const Capture ref = two_patches();
    Capture test = ref;
    test.vertices[8].position.y = step_up(ref.vertices[8].position.y, 3);
    write_file(path("ref.txt"), tessref::capture_text(ref.vertices));
    write_file(path("test.txt"), tessref::capture_text(test.vertices));
    RunResult r = run({"compare", path("ref.txt"), path("test.txt"), "--max-position-ulps", "2"});
    EXPECT_EQ(r.status, 1) << r.out << r.err;
    EXPECT_NE(r.out.find("  patch 1  values: 1 of 6 vertices fail; first at tess coord (1, 1, 0)"), std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find("(3 ulps, |difference| "), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("\n  1:1\n"), std::string::npos) << r.out;
    r = run({"compare", path("ref.txt"), path("test.txt"), "--max-position-ulps", "3", "--json"});
    EXPECT_EQ(r.status, 0) << r.out << r.err;
    EXPECT_EQ(nlohmann::json::parse(r.out)["worst_position"]["ulps"], 3);
}

// Ulps alone say nothing to a reader ("1036026642 ulps" for 0 against 0.094): the absolute
// difference stands beside them, and a per-component summary (x, y, z, normal) covers the
// whole capture. 0.094f's bits are 1036026642 above 0's (struct.pack("<f", 0.094) in Python),
// 0.5f's 1056964608 (0x3f000000);
// 12 corners are compared, so the means are 0.094 / 12 and 0.5 / 12.
TEST_F(CaptureCommand, CompareGivesAbsoluteDifferencesAndAPerComponentSummary) {
    const Capture ref = two_patches();
    Capture test = ref;
    test.vertices[0].position.z = 0.094f;  // patch 0's corner (0, 0), z 0 in the reference
    test.vertices[7].normal.x = 0.5f;      // patch 1's corner (1, 0)
    write_file(path("ref.txt"), tessref::capture_text(ref.vertices));
    write_file(path("test.txt"), tessref::capture_text(test.vertices));
    RunResult r = run({"compare", path("ref.txt"), path("test.txt")});
    EXPECT_EQ(r.status, 1) << r.out << r.err;
    EXPECT_NE(r.out.find("worst position  1036026642 ulps (|difference| 0.094) at patch 0"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("worst normal    1056964608 ulps (|difference| 0.5) at patch 1"), std::string::npos) << r.out;
    EXPECT_TRUE(std::regex_search(r.out, std::regex("\n  x +0 +0 +0 +0\n"))) << r.out;
    EXPECT_TRUE(std::regex_search(r.out, std::regex("\n  z +0\\.094 +0\\.00783333 +1036026642 +1\n"))) << r.out;
    EXPECT_TRUE(std::regex_search(r.out, std::regex("\n  normal +0\\.5 +0\\.0416667 +1056964608 +1\n"))) << r.out;
    r = run({"compare", path("ref.txt"), path("test.txt"), "--json"});
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_FLOAT_EQ(j["worst_position"]["abs"].get<double>(), 0.094f);
    EXPECT_EQ(j["components"]["z"]["max_ulps"], 1036026642u);
    EXPECT_EQ(j["components"]["z"]["compared"], 12u);
    EXPECT_EQ(j["components"]["normal"]["beyond"], 1u);
    EXPECT_EQ(j["components"]["y"]["max_abs"], 0.0);
}

// ---- check on a capture ---------------------------------------------------------------------

// `tessref check` on a capture used to see every patch's own copies of its vertices: one
// boundary loop per patch. It welds first, bitwise as `tessref mesh` does, so a capture of a
// crack-free terrain passes and welds into the exported mesh's vertices (the PLY header's
// count: the exporter's own weld).
TEST_F(CaptureCommand, CheckWeldsACaptureAsTheExporterDoes) {
    const std::string scene = scene_path("thesis-constant-1").string();
    ASSERT_EQ(run({"mesh", scene, "-o", path("m.ply"), "--capture", path("c.txt")}).status, 0);
    ASSERT_EQ(run({"mesh", scene, "--capture", path("c.ply")}).status, 0);
    std::smatch m;
    const std::string header = read_file(path("m.ply")).substr(0, 400);
    ASSERT_TRUE(std::regex_search(header, m, std::regex("element vertex ([0-9]+)")));
    for (const char* capture : {"c.txt", "c.ply"}) {
        const RunResult r = run({"check", path(capture)});
        EXPECT_EQ(r.status, 0) << capture << "\n" << r.out << r.err;
        EXPECT_NE(r.out.find("welded bitwise into " + m[1].str() + " vertices"), std::string::npos) << r.out;
        EXPECT_NE(r.out.find("tessellated differently: 0\n"), std::string::npos) << r.out;
    }
    // The exported (welded) PLY is still read as the mesh it is.
    const RunResult mesh = run({"check", path("m.ply")});
    EXPECT_EQ(mesh.status, 0) << mesh.out << mesh.err;
    EXPECT_EQ(mesh.out.find("welded"), std::string::npos) << mesh.out;
}

// A PLY with the capture's properties is a capture when read_ply_capture would take it: every
// face a triangle whose corners all carry one patch id. That holds for two triangles of one
// patch that share corners (a capture need not keep its corners apart), which `check` then
// welds (6 corners into 4 vertices); it fails for the same square whose triangles mix
// patches 0 and 1, a welded mesh `check` checks as it is. `check` reads such a PLY first
// without its normals and decides from the faces and patch ids alone.
TEST_F(CaptureCommand, CheckTellsACaptureFromAWeldedMeshByItsPatches) {
    const std::string header =
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
        "property float nx\nproperty float ny\nproperty float nz\nproperty int patch_id\nproperty float tess_u\n"
        "property float tess_v\nproperty float tess_w\nelement face 2\nproperty list uchar int vertex_indices\n"
        "end_header\n";
    const auto square = [&](int upper_patch) {
        const std::string p = std::to_string(upper_patch);
        return header + "0 0 0 0 0 1 0 0 0 1\n1 0 0 0 0 1 0 1 0 0\n1 1 0 0 0 1 " + p + " 0 1 0\n0 1 0 0 0 1 " + p +
               " 0 0 1\n3 0 1 2\n3 0 2 3\n";
    };
    write_file(path("one.ply"), square(0));
    write_file(path("two.ply"), square(1));
    RunResult r = run({"check", path("one.ply")});
    EXPECT_EQ(r.status, 0) << r.out << r.err;
    EXPECT_NE(r.out.find("capture " + path("one.ply") + ": 2 triangles, their 6 corners welded bitwise into 4 vertices"),
              std::string::npos)
        << r.out;
    r = run({"check", path("two.ply")});
    EXPECT_EQ(r.status, 0) << r.out << r.err;
    EXPECT_EQ(r.out.find("welded"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("4 vertices, 2 faces"), std::string::npos) << r.out;
}

// Patch 0 (x 0..1) at level 1; patch 1 (x 1..2) splits its u = 0 side, the one it shares
// with patch 0's u = 1 side, at v = 0.5 (outer[0] = 2): patch 0 puts 2 vertices on the edge,
// patch 1 puts 3, and the surface cracks there (a T-junction once welded).
Capture cracked_pair(float shift = 0.0f, float middle_height = 0.0f) {
    Capture c;
    const TessLevels l0 = levels_of(1.0f, 1.0f);
    TessLevels l1 = levels_of(1.0f, 1.0f);
    l1.outer[0] = 2.0f;
    const auto at0 = [&](float u, float v) { return vertex(0, {u, v, 0.0f}, {u, v, 0.0f}, {0, 0, 1}, l0); };
    const auto at1 = [&](float u, float v) {
        const float z = u == 0.0f && v == 0.5f ? middle_height : 0.0f;
        return vertex(1, {u, v, 0.0f}, {1.0f + u + (u == 0.0f ? shift : 0.0f), v, z}, {0, 0, 1}, l1);
    };
    for (const CapturedVertex& v : {at0(0, 0), at0(1, 0), at0(1, 1), at0(0, 0), at0(1, 1), at0(0, 1)})
        c.vertices.push_back(v);
    for (const CapturedVertex& v :
         {at1(0, 0), at1(1, 0), at1(1, 1), at1(0, 0), at1(1, 1), at1(0, 0.5f), at1(0, 0.5f), at1(1, 1), at1(0, 1)})
        c.vertices.push_back(v);
    return c;
}

TEST_F(CaptureCommand, CheckNamesTheSharedEdgesTwoPatchesTessellatedDifferently) {
    write_file(path("c.txt"), tessref::capture_text(cracked_pair().vertices));
    RunResult r = run({"check", path("c.txt")});
    EXPECT_EQ(r.status, 1) << r.out << r.err;
    EXPECT_NE(r.out.find("tessellated differently: 1\n  patch 0 outer[2] = 1, patch 1 outer[0] = 2: their shared edge "
                         "cracks (2 and 3 vertices on it), from (1, 0, 0) to (1, 1, 0)\n"),
              std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find("into 7 vertices"), std::string::npos) << r.out;  // 4 + 5 - 2 shared corners
    EXPECT_NE(r.out.find("t_junction: 1"), std::string::npos) << r.out;      // patch 1's (1, 0.5) on patch 0's edge
    EXPECT_NE(r.out.find("vertex and face ids are 0-based"), std::string::npos) << r.out;
    r = run({"check", path("c.txt"), "--json"});
    const nlohmann::json j = nlohmann::json::parse(r.out);
    ASSERT_EQ(j["shared_edge_cracks"].size(), 1u);
    EXPECT_EQ(j["shared_edge_cracks"][0]["outer"], nlohmann::json({2, 0}));
    EXPECT_EQ(j["passed"], false);
}

// Patch 1's shared side moved 1e-4 along x: bitwise nothing welds across the edge (4 + 5
// vertices); within 1e-3 the two shared corners weld (7), as in the unshifted pair.
TEST_F(CaptureCommand, CheckWeldsACaptureWithinAToleranceWhenAsked) {
    write_file(path("c.txt"), tessref::capture_text(cracked_pair(1e-4f).vertices));
    RunResult r = run({"check", path("c.txt")});
    EXPECT_NE(r.out.find("welded bitwise into 9 vertices"), std::string::npos) << r.out;
    r = run({"check", path("c.txt"), "--weld-tolerance", "0.001"});
    EXPECT_NE(r.out.find("welded within 0.001 into 7 vertices"), std::string::npos) << r.out;
    r = run({"check", path("c.txt"), "--weld-tolerance", "-1"});
    EXPECT_EQ(r.status, 2) << r.err;
    write_file(path("m.off"), "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    r = run({"check", path("m.off"), "--weld-tolerance", "0.001"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("--weld-tolerance"), std::string::npos) << r.err;
}

// A cw where the twin says ccw passes compare and, as a mesh, every topological check: the
// capture's triangles all wound the other way. On a terrain (the thesis's lies in the xy
// plane, z up) every face then faces down, a defect class of its own.
TEST_F(CaptureCommand, CheckReportsATerrainWoundTheOtherWay) {
    ASSERT_EQ(run({"mesh", scene_path("thesis-constant-1").string(), "--capture", path("c.txt")}).status, 0);
    Capture c = tessref::read_capture(path("c.txt"));
    for (std::size_t i = 0; i < c.vertices.size(); i += 3) std::swap(c.vertices[i + 1], c.vertices[i + 2]);
    write_file(path("cw.txt"), tessref::capture_text(c.vertices));
    const RunResult r = run({"check", path("cw.txt")});
    EXPECT_EQ(r.status, 1) << r.out << r.err;
    EXPECT_NE(r.out.find("facing_down: 512  (terrain faces facing down its up axis"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("inconsistent_orientation"), std::string::npos) << r.out;
}

TEST_F(CaptureCommand, CompareBadInputIsExit2) {
    write_file(path("ref.txt"), tessref::capture_text(two_patches().vertices));
    write_file(path("bad.txt"), "tessref-capture 1\npatch 0 levels 1 1 1 1 1 1\n0 0 0 0 1 2 x 0 0 1\n");
    RunResult r = run({"compare", path("ref.txt"), path("bad.txt")});
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("bad number 'x' (expected a position) at line 3"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(path("bad.txt") + ":3"), std::string::npos) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
    // A capture against an image, ulps for images, image flags for captures.
    r = run({"compare", path("ref.txt"), path("x.png")});
    EXPECT_EQ(r.status, 2) << r.err;
    r = run({"compare", path("a.png"), path("b.png"), "--max-normal-ulps", "1"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("--max-normal-ulps"), std::string::npos) << r.err;
    r = run({"compare", path("ref.txt"), path("ref.txt"), "--threshold", "0.5"});
    EXPECT_EQ(r.status, 2) << r.err;
    r = run({"compare", path("ref.txt"), path("ref.txt"), "--max-position-ulps", "-1"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_EQ(files(), (std::set<std::string>{"bad.txt", "ref.txt"}));
}

}  // namespace
