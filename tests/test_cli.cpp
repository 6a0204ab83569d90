// End-to-end tests of the `tessref` command (help, version, `tessellate`): the built binary
// (TESSREF_EXE) runs in a shell with stdout and stderr captured to files.
//
// Expected values come from hand derivations (the minimal patches, isoline spacing, the
// fixed-point centre of a triangle), from the generator's documented counting formulas
// (docs/GENERATOR.md: "Reference counts"), or from the library itself where
// the point is the command's faithfulness (every printed number reads back as the exact
// float the library produced).
#include <gtest/gtest.h>

#include "command_dir_test.h"
#include "run_program.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

#include <OpenImageIO/imageio.h>
#include <nlohmann/json.hpp>

#include "tessref/tessellator.h"

namespace fs = std::filesystem;

namespace {

using tessref::test::read_file;
using tessref::test::run_program;
using tessref::test::RunResult;
using tessref::test::shell_quote;
using tessref::test::write_file;

// A fresh, empty directory per test, removed afterwards (tests/command_dir_test.h).
using CliTest = tessref::test::CommandDirTest;

std::vector<std::string> tessellate_args(const std::string& domain, const std::string& spacing,
                                         const std::string& outer, const std::string& inner,
                                         std::vector<std::string> extra = {}) {
    std::vector<std::string> args{"tessellate", "--domain", domain, "--spacing", spacing,
                                  "--outer",    outer,      "--inner", inner};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
}

using Vertex = std::array<float, 3>;
using Primitive = std::vector<Vertex>;

struct TextPattern {
    std::vector<std::string> comments;
    std::vector<Primitive> primitives;
    std::vector<std::vector<std::string>> raw;  // the printed numbers, per primitive
};

// Parses the text format: '#' lines are comments; every other line is one primitive, its
// vertices separated by two spaces, each vertex "u v w".
TextPattern parse_text(const std::string& text) {
    TextPattern pattern;
    std::istringstream lines(text);
    std::string line;
    while (std::getline(lines, line)) {
        if (!line.empty() && line[0] == '#') {
            pattern.comments.push_back(line);
            continue;
        }
        Primitive primitive;
        std::vector<std::string> raw;
        std::size_t start = 0;
        while (start <= line.size()) {
            const std::size_t end = std::min(line.find("  ", start), line.size());
            const std::string vertex_text = line.substr(start, end - start);
            std::istringstream numbers(vertex_text);
            std::string a, b, c, rest;
            numbers >> a >> b >> c;
            EXPECT_FALSE(c.empty()) << "vertex '" << vertex_text << "' in line '" << line << "'";
            EXPECT_FALSE(numbers >> rest) << "extra text in vertex '" << vertex_text << "'";
            char* stop = nullptr;
            Vertex v{};
            const std::string* parts[3] = {&a, &b, &c};
            for (int k = 0; k < 3; ++k) {
                v[k] = std::strtof(parts[k]->c_str(), &stop);
                EXPECT_EQ(*stop, '\0') << "not a number: '" << *parts[k] << "'";
                raw.push_back(*parts[k]);
            }
            primitive.push_back(v);
            start = end + 2;
        }
        pattern.primitives.push_back(primitive);
        pattern.raw.push_back(raw);
    }
    return pattern;
}

bool has_comment_containing(const TextPattern& pattern, const std::string& needle) {
    return std::any_of(pattern.comments.begin(), pattern.comments.end(),
                       [&](const std::string& c) { return c.find(needle) != std::string::npos; });
}

// Signed area in (u, v), v up: positive when counter-clockwise.
double signed_area(const Primitive& t) {
    return 0.5 * ((double(t[1][0]) - t[0][0]) * (double(t[2][1]) - t[0][1]) -
                  (double(t[2][0]) - t[0][0]) * (double(t[1][1]) - t[0][1]));
}

bool same_bits(float a, float b) {
    return std::memcmp(&a, &b, sizeof a) == 0;
}

}  // namespace

// ---------------------------------------------------------------------------------------
// Help and version

TEST_F(CliTest, HelpListsTessellateAndExitsZero) {
    const RunResult r = run({"--help"});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("tessellate"), std::string::npos) << r.out;
    EXPECT_TRUE(r.err.empty()) << r.err;
}

TEST_F(CliTest, SubcommandHelpListsItsOptions) {
    const RunResult r = run({"tessellate", "--help"});
    EXPECT_EQ(r.status, 0) << r.err;
    for (const char* option : {"--domain", "--spacing", "--winding", "--point-mode", "--outer", "--inner",
                               "--precision", "--format", "--output"}) {
        EXPECT_NE(r.out.find(option), std::string::npos) << option << " missing from\n" << r.out;
    }
}

TEST_F(CliTest, VersionPrintsTheProjectVersion) {
    const RunResult r = run({"--version"});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.out, std::string("tessref ") + TESSREF_VERSION + "\n");
}

TEST_F(CliTest, NoCommandOrUnknownCommandIsBadInput) {
    for (const std::vector<std::string>& args :
         {std::vector<std::string>{}, std::vector<std::string>{"tesselate"}, std::vector<std::string>{"--bogus"}}) {
        const RunResult r = run(args);
        EXPECT_EQ(r.status, 2);
        EXPECT_EQ(r.err.rfind("tessref: error: ", 0), 0u) << r.err;
    }
}

// ---------------------------------------------------------------------------------------
// Text output against hand-derived patterns

TEST_F(CliTest, MinimalQuadIsTwoTrianglesCoveringTheSquare) {
    const RunResult r = run(tessellate_args("quads", "equal", "1,1,1,1", "1,1"));
    ASSERT_EQ(r.status, 0) << r.err;
    const TextPattern p = parse_text(r.out);
    ASSERT_EQ(p.primitives.size(), 2u) << r.out;
    std::set<std::pair<float, float>> corners;
    double area = 0;
    for (const Primitive& t : p.primitives) {
        ASSERT_EQ(t.size(), 3u);
        for (const Vertex& v : t) {
            corners.insert({v[0], v[1]});
            EXPECT_EQ(v[2], 0.0f) << "w is 0 for quads";
        }
        EXPECT_DOUBLE_EQ(signed_area(t), 0.5) << "each half of the square, counter-clockwise";
        area += signed_area(t);
    }
    EXPECT_EQ(corners, (std::set<std::pair<float, float>>{{0, 0}, {1, 0}, {1, 1}, {0, 1}}));
    EXPECT_DOUBLE_EQ(area, 1.0);
    EXPECT_TRUE(r.err.empty()) << r.err;
}

TEST_F(CliTest, MinimalTriangleIsTheDomainCorners) {
    const RunResult r = run(tessellate_args("triangles", "equal", "1,1,1,1", "1,1"));
    ASSERT_EQ(r.status, 0) << r.err;
    const TextPattern p = parse_text(r.out);
    ASSERT_EQ(p.primitives.size(), 1u) << r.out;
    const Primitive& t = p.primitives[0];
    ASSERT_EQ(t.size(), 3u);
    // (0,1,0), (0,0,1), (1,0,0) in some rotation (the order, not the orientation, may rotate).
    const std::vector<Vertex> expected{{0, 1, 0}, {0, 0, 1}, {1, 0, 0}};
    bool rotation_found = false;
    for (int shift = 0; shift < 3; ++shift) {
        bool all = true;
        for (int k = 0; k < 3; ++k) all = all && t[k] == expected[(k + shift) % 3];
        rotation_found = rotation_found || all;
    }
    EXPECT_TRUE(rotation_found) << r.out;
}

TEST_F(CliTest, IsolinesAreDensityTimesDetailSegments) {
    // Density 2 (lines at v = 0 and v = 1/2; v = 1 is never drawn), detail 3 (u = 0, 1/3,
    // 2/3, 1, the thirds in 16.16 fixed point): 2 x 3 = 6 segments.
    const RunResult r = run(tessellate_args("isolines", "equal", "2,3,7,7", "5,5"));
    ASSERT_EQ(r.status, 0) << r.err;
    const TextPattern p = parse_text(r.out);
    ASSERT_EQ(p.primitives.size(), 6u) << r.out;
    std::set<float> line_v;
    for (const Primitive& s : p.primitives) {
        ASSERT_EQ(s.size(), 2u);
        EXPECT_EQ(s[0][1], s[1][1]) << "a segment runs along u";
        EXPECT_NEAR(s[1][0] - s[0][0], 1.0 / 3.0, 1.0 / 65536) << "detail 3: thirds";
        EXPECT_EQ(s[0][2], 0.0f);
        line_v.insert(s[0][1]);
    }
    EXPECT_EQ(line_v, (std::set<float>{0.0f, 0.5f}));
}

TEST_F(CliTest, CulledPatchPrintsNoPrimitivesAndExitsZero) {
    const std::vector<std::vector<std::string>> cases{
        tessellate_args("quads", "equal", "0,1,1,1", "1,1"),
        tessellate_args("quads", "fractional_odd", "nan,1,1,1", "1,1"),
        tessellate_args("triangles", "fractional_even", "4,4,NaN,4", "4,4"),
        tessellate_args("isolines", "equal", "4,-inf,4,4", "4,4"),
        tessellate_args("quads", "equal", "-1,2,3,4", "2,2"),
    };
    for (const auto& args : cases) {
        const RunResult r = run(args);
        EXPECT_EQ(r.status, 0) << r.err;
        const TextPattern p = parse_text(r.out);
        EXPECT_TRUE(p.primitives.empty()) << r.out;
        EXPECT_TRUE(has_comment_containing(p, "culled")) << r.out;
    }
    // A level the domain does not use never culls (triangles ignore outer[3]).
    const RunResult r = run(tessellate_args("triangles", "equal", "1,1,1,nan", "1,1"));
    EXPECT_EQ(r.status, 0);
    EXPECT_EQ(parse_text(r.out).primitives.size(), 1u) << r.out;
}

TEST_F(CliTest, NegativeLevelsParseWithOrWithoutEquals) {
    for (const std::string& form : {"--outer=-1,2,3,4", "--outer"}) {
        std::vector<std::string> args{"tessellate", "--domain", "quads", "--spacing", "equal", "--inner", "1,1", form};
        if (form == "--outer") args.push_back("-1,2,3,4");
        const RunResult r = run(args);
        EXPECT_EQ(r.status, 0) << form << ": " << r.err;
        EXPECT_TRUE(parse_text(r.out).primitives.empty()) << r.out;
    }
}

TEST_F(CliTest, ClockwiseReversesEveryTriangle) {
    for (const auto& [domain, spacing, outer, inner] :
         std::vector<std::array<std::string, 4>>{{"quads", "equal", "3,4,5,6", "3,5"},
                                                 {"triangles", "fractional_odd", "3.5,2,5,1", "4,1"},
                                                 {"quads", "fractional_even", "2.2,7,3,4.5", "6.3,2"},
                                                 {"triangles", "equal", "1,1,1,1", "1,1"}}) {
        const RunResult ccw = run(tessellate_args(domain, spacing, outer, inner, {"--winding", "ccw"}));
        const RunResult cw = run(tessellate_args(domain, spacing, outer, inner, {"--winding", "cw"}));
        ASSERT_EQ(ccw.status, 0) << ccw.err;
        ASSERT_EQ(cw.status, 0) << cw.err;
        const TextPattern a = parse_text(ccw.out), b = parse_text(cw.out);
        ASSERT_EQ(a.primitives.size(), b.primitives.size());
        ASSERT_FALSE(a.primitives.empty());
        for (std::size_t i = 0; i < a.primitives.size(); ++i) {
            EXPECT_GT(signed_area(a.primitives[i]), 0.0) << domain << " " << outer << " triangle " << i;
            EXPECT_LT(signed_area(b.primitives[i]), 0.0) << domain << " " << outer << " triangle " << i;
            std::vector<Vertex> va = a.primitives[i], vb = b.primitives[i];
            std::sort(va.begin(), va.end());
            std::sort(vb.begin(), vb.end());
            EXPECT_EQ(va, vb) << "same vertices, other order";
        }
    }
}

TEST_F(CliTest, QuadCountsFollowTheReferenceFormula) {
    // Integer spacing, every inner level > 1: triangles = 2(i0-2)(i1-2) + 2(i0-2) + 2(i1-2)
    // + sum(outer), points = sum(outer) + (i0-1)(i1-1). Here 3,4,5,6 / 3,5: 32 and 26.
    const RunResult r = run(tessellate_args("quads", "equal", "3,4,5,6", "3,5", {"--format", "json"}));
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json doc = nlohmann::json::parse(r.out);
    EXPECT_EQ(doc["counts"]["primitives"], 32);
    EXPECT_EQ(doc["counts"]["points"], 26);
    // And each outer edge holds 1 + its level points.
    const int levels[4] = {3, 4, 5, 6};
    for (int edge = 0; edge < 4; ++edge) {
        int on_edge = 0;
        for (const auto& p : doc["points"]) {
            const double u = p[0], v = p[1];
            const bool on = edge == 0 ? u == 0 : edge == 1 ? v == 0 : edge == 2 ? u == 1 : v == 1;
            on_edge += on ? 1 : 0;
        }
        EXPECT_EQ(on_edge, levels[edge] + 1) << "edge " << edge;
    }
}

TEST_F(CliTest, PrintedNumbersRoundTripToTheLibrarysFloats) {
    struct Case {
        tessref::TessSettings settings;
        tessref::TessLevels levels;
        tessref::Precision precision;
        std::vector<std::string> args;
    };
    using namespace tessref;
    const std::vector<Case> cases{
        {{Domain::triangles, Spacing::fractional_odd, Winding::ccw, false}, {{3.3f, 7.1f, 2.9f, 1}, {5.7f, 1}},
         Precision::gpu, tessellate_args("triangles", "fractional_odd", "3.3,7.1,2.9,1", "5.7,1")},
        {{Domain::triangles, Spacing::fractional_odd, Winding::ccw, false}, {{3.3f, 7.1f, 2.9f, 1}, {5.7f, 1}},
         Precision::exact,
         tessellate_args("triangles", "fractional_odd", "3.3,7.1,2.9,1", "5.7,1", {"--precision", "exact"})},
        {{Domain::quads, Spacing::fractional_even, Winding::cw, false}, {{2.5e-3f, 9.25f, 1e9f, 4}, {13.3f, 6}},
         Precision::exact,
         tessellate_args("quads", "fractional_even", "2.5e-3,9.25,1e9,4", "13.3,6",
                         {"--precision", "exact", "--winding", "cw"})},
        {{Domain::isolines, Spacing::fractional_odd, Winding::ccw, false}, {{3, 5.5f, 1, 1}, {1, 1}},
         Precision::gpu, tessellate_args("isolines", "fractional_odd", "3,5.5,1,1", "1,1")},
        {{Domain::quads, Spacing::equal, Winding::ccw, true}, {{3, 2, 5, 4}, {3, 3}}, Precision::exact,
         tessellate_args("quads", "equal", "3,2,5,4", "3,3", {"--point-mode", "--precision", "exact"})},
    };
    for (const Case& c : cases) {
        const RunResult r = run(c.args);
        ASSERT_EQ(r.status, 0) << r.err;
        const TextPattern printed = parse_text(r.out);
        const Pattern expected = tessellate(c.settings, c.levels, c.precision);
        ASSERT_EQ(printed.primitives.size(), expected.primitive_count());
        ASSERT_GT(expected.primitive_count(), 0u);
        for (std::size_t i = 0; i < expected.primitive_count(); ++i) {
            const auto indices = expected.primitive(i);
            ASSERT_EQ(printed.primitives[i].size(), indices.size());
            for (std::size_t k = 0; k < indices.size(); ++k) {
                const TessCoord& p = expected.points()[indices[k]];
                const Vertex& q = printed.primitives[i][k];
                EXPECT_TRUE(same_bits(q[0], p.u) && same_bits(q[1], p.v) && same_bits(q[2], p.w))
                    << "primitive " << i << " vertex " << k << ": printed " << printed.raw[i][3 * k] << " "
                    << printed.raw[i][3 * k + 1] << " " << printed.raw[i][3 * k + 2];
            }
        }
    }
}

TEST_F(CliTest, ReportsTheGpuToExactDistanceOfTheTriangleCentre) {
    // Triangles, equal spacing, levels 2: the outer points sit at 0, 1/2, 1 (exact in 16.16)
    // and the centre at u = v = 0x5555 / 65536, w = 1 - u - v = 0x5556 / 65536. The exact
    // centre is 1/3 each, so the largest difference is 0x5556/65536 - 1/3 = 1/98304.
    const RunResult r = run(tessellate_args("triangles", "equal", "2,2,2,2", "2,2", {"--format", "json"}));
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json doc = nlohmann::json::parse(r.out);
    EXPECT_NEAR(doc["gpu_exact_max_difference"].get<double>(), 1.0 / 98304.0, 1e-12);
    // The text header carries it too.
    const RunResult text = run(tessellate_args("triangles", "equal", "2,2,2,2", "2,2"));
    EXPECT_TRUE(has_comment_containing(parse_text(text.out), "gpu vs exact")) << text.out;
}

// ---------------------------------------------------------------------------------------
// json and obj

TEST_F(CliTest, JsonHasConsistentCountsAndSpellsNonFiniteLevels) {
    const RunResult r = run(tessellate_args("triangles", "fractional_even", "5.5,1e9,3,-inf", "nan,inf",
                                            {"--format", "json", "--precision", "exact"}));
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json doc = nlohmann::json::parse(r.out);
    EXPECT_EQ(doc["settings"]["domain"], "triangles");
    EXPECT_EQ(doc["settings"]["spacing"], "fractional_even");
    EXPECT_EQ(doc["settings"]["winding"], "ccw");
    EXPECT_EQ(doc["settings"]["point_mode"], false);
    EXPECT_EQ(doc["settings"]["precision"], "exact");
    EXPECT_EQ(doc["culled"], false);
    const auto& given = doc["levels"]["given"];
    EXPECT_EQ(given["outer"][0].get<double>(), 5.5);
    EXPECT_EQ(given["outer"][1].get<double>(), 1e9);
    EXPECT_EQ(given["outer"][3], "-inf");
    EXPECT_EQ(given["inner"][0], "nan");
    EXPECT_EQ(given["inner"][1], "inf");
    // fractional_even clamps to [2, 64]: 1e9 -> 64; NaN inner -> the lower bound 2.
    EXPECT_EQ(doc["levels"]["effective"]["outer"][1].get<double>(), 64.0);
    EXPECT_EQ(doc["levels"]["effective"]["inner"][0].get<double>(), 2.0);

    const std::size_t points = doc["points"].size();
    EXPECT_EQ(doc["counts"]["points"].get<std::size_t>(), points);
    EXPECT_EQ(doc["counts"]["primitives"].get<std::size_t>(), doc["primitives"].size());
    EXPECT_EQ(doc["counts"]["vertices_per_primitive"], 3);
    EXPECT_GT(points, 3u);
    for (const auto& p : doc["points"]) {
        ASSERT_EQ(p.size(), 3u);
        for (const auto& x : p) EXPECT_TRUE(x.get<double>() >= 0.0 && x.get<double>() <= 1.0);
    }
    for (const auto& t : doc["primitives"]) {
        ASSERT_EQ(t.size(), 3u);
        for (const auto& i : t) EXPECT_LT(i.get<std::size_t>(), points);
    }
    EXPECT_GE(doc["gpu_exact_max_difference"].get<double>(), 0.0);
    // With --precision exact the unquantized doubles come along, point for point, and the
    // floats are those doubles rounded.
    ASSERT_EQ(doc["points_exact"].size(), points);
    for (std::size_t i = 0; i < points; ++i) {
        for (int k = 0; k < 3; ++k) {
            EXPECT_EQ(static_cast<float>(doc["points_exact"][i][k].get<double>()), doc["points"][i][k].get<float>());
        }
    }
}

TEST_F(CliTest, JsonOfACulledPatchIsEmpty) {
    const RunResult r = run(tessellate_args("quads", "equal", "1,nan,1,1", "1,1", {"--format", "json"}));
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json doc = nlohmann::json::parse(r.out);
    EXPECT_EQ(doc["culled"], true);
    EXPECT_EQ(doc["levels"]["given"]["outer"][1], "nan");
    EXPECT_TRUE(doc["points"].empty());
    EXPECT_TRUE(doc["primitives"].empty());
    EXPECT_EQ(doc["counts"]["primitives"], 0);
}

TEST_F(CliTest, ObjIndicesAreOneBasedAndMatchTheText) {
    const auto args = tessellate_args("quads", "fractional_odd", "2.5,3,1.5,4", "3.5,2");
    auto obj_args = args;
    obj_args.insert(obj_args.end(), {"--format", "obj"});
    const RunResult obj = run(obj_args);
    const RunResult text = run(args);
    ASSERT_EQ(obj.status, 0) << obj.err;
    std::vector<Vertex> vertices;
    std::vector<Primitive> faces;
    std::istringstream lines(obj.out);
    std::string line;
    while (std::getline(lines, line)) {
        std::istringstream words(line);
        std::string tag;
        words >> tag;
        if (tag == "v") {
            Vertex v{};
            words >> v[0] >> v[1] >> v[2];
            vertices.push_back(v);
        } else if (tag == "f") {
            Primitive face;
            std::size_t index = 0;
            while (words >> index) {
                ASSERT_GE(index, 1u);
                ASSERT_LE(index, vertices.size());
                face.push_back(vertices[index - 1]);
            }
            faces.push_back(face);
        } else {
            EXPECT_TRUE(tag.empty() || tag[0] == '#') << line;
        }
    }
    EXPECT_EQ(faces, parse_text(text.out).primitives);
}

TEST_F(CliTest, ObjPointModeListsEveryPointOnce) {
    const RunResult r = run(tessellate_args("triangles", "equal", "3,3,3,3", "3,3", {"--point-mode", "--format", "obj"}));
    ASSERT_EQ(r.status, 0) << r.err;
    std::size_t v = 0;
    std::vector<std::size_t> p;
    std::istringstream lines(r.out);
    std::string line;
    while (std::getline(lines, line)) {
        if (line.rfind("v ", 0) == 0) ++v;
        if (line.rfind("p ", 0) == 0) p.push_back(std::stoul(line.substr(2)));
        EXPECT_NE(line.rfind("f ", 0), 0u) << "no faces in point mode";
    }
    // Point mode: every generated point once, in generation order.
    ASSERT_EQ(p.size(), v);
    for (std::size_t i = 0; i < p.size(); ++i) EXPECT_EQ(p[i], i + 1);
}

// ---------------------------------------------------------------------------------------
// Pictures

TEST_F(CliTest, SvgIsAStandaloneDocument) {
    const RunResult r = run(tessellate_args("triangles", "fractional_odd", "3.5,2,5,1", "4,1", {"--format", "svg"}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.out.rfind("<svg", 0), 0u);
    ASSERT_GE(r.out.size(), 7u);
    EXPECT_EQ(r.out.substr(r.out.size() - 7), "</svg>\n");
    EXPECT_NE(r.out.find("<polygon"), std::string::npos);
    EXPECT_NE(r.out.find("<circle"), std::string::npos);
    EXPECT_NE(r.out.find("triangles, fractional_odd, ccw"), std::string::npos);

    // The extension picks the format, and the file equals what stdout got.
    const fs::path file = dir_ / "pattern.svg";
    const RunResult w = run(tessellate_args("triangles", "fractional_odd", "3.5,2,5,1", "4,1", {"-o", file.string()}));
    ASSERT_EQ(w.status, 0) << w.err;
    EXPECT_EQ(read_file(file), r.out);
}

TEST_F(CliTest, PngIsWrittenAndReadable) {
    const fs::path file = dir_ / "pattern.png";
    const RunResult r = run(tessellate_args("quads", "fractional_even", "3.3,5,2.2,7", "4.5,3",
                                            {"--format", "png", "-o", file.string()}));
    ASSERT_EQ(r.status, 0) << r.err;
    if (fs::exists("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf")) {
        EXPECT_TRUE(r.err.empty()) << "with the font installed, text renders without warnings: " << r.err;
    }
    EXPECT_EQ(files(), std::set<std::string>{"pattern.png"}) << "no temporary file left";
    auto input = OIIO::ImageInput::open(file.string());
    ASSERT_TRUE(input) << OIIO::geterror();
    const OIIO::ImageSpec spec = input->spec();
    EXPECT_GT(spec.width, 0);
    EXPECT_GT(spec.height, 0);
    EXPECT_GE(spec.nchannels, 3);
    std::vector<unsigned char> pixels(static_cast<std::size_t>(spec.width) * spec.height * spec.nchannels);
    ASSERT_TRUE(input->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, pixels.data()));
    // Something was drawn: more than a handful of distinct colours.
    std::set<unsigned> colours;
    for (std::size_t i = 0; i + 2 < pixels.size(); i += spec.nchannels)
        colours.insert(pixels[i] << 16 | pixels[i + 1] << 8 | pixels[i + 2]);
    EXPECT_GT(colours.size(), 5u);
}

TEST_F(CliTest, PngFormatWinsOverTheTargetsExtension) {
    const fs::path file = dir_ / "picture.txt";
    const RunResult r = run(tessellate_args("triangles", "equal", "2,2,2,2", "2,2", {"--format", "png", "-o", file.string()}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(read_file(file).substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
    EXPECT_EQ(files(), std::set<std::string>{"picture.txt"});
}

TEST_F(CliTest, PngNeedsAnOutputFile) {
    const RunResult r = run(tessellate_args("quads", "equal", "2,2,2,2", "2,2", {"--format", "png"}));
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err.rfind("tessref: error: ", 0), 0u) << r.err;
    EXPECT_TRUE(r.out.empty());
}

TEST_F(CliTest, OutputIsDeterministic) {
    for (const char* format : {"text", "json", "obj", "svg"}) {
        const auto args = tessellate_args("triangles", "fractional_even", "7.7,3,2.1,1", "5.5,1", {"--format", format});
        const RunResult a = run(args), b = run(args);
        ASSERT_EQ(a.status, 0) << a.err;
        EXPECT_EQ(a.out, b.out) << format;
    }
}

// ---------------------------------------------------------------------------------------
// Output files and bad input

TEST_F(CliTest, OutputFileIsWrittenWithoutLeftovers) {
    const fs::path file = dir_ / "out.txt";
    write_file(file, "old content\n");
    const RunResult r = run(tessellate_args("quads", "equal", "2,2,2,2", "2,2", {"-o", file.string()}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(r.out.empty()) << "the pattern went to the file, not stdout";
    const RunResult stdout_run = run(tessellate_args("quads", "equal", "2,2,2,2", "2,2"));
    EXPECT_EQ(read_file(file), stdout_run.out);
    EXPECT_EQ(files(), std::set<std::string>{"out.txt"});

    const fs::path json = dir_ / "out.json";
    ASSERT_EQ(run(tessellate_args("quads", "equal", "2,2,2,2", "2,2", {"-o", json.string()})).status, 0);
    EXPECT_TRUE(nlohmann::json::accept(read_file(json))) << "format from the extension";
}

TEST_F(CliTest, BadInputExitsTwoAndWritesNothing) {
    struct Bad {
        std::vector<std::string> args;
        std::vector<std::string> message_parts;  // what the error line must name
    };
    const std::vector<Bad> cases{
        {tessellate_args("quads", "equal", "1,2,x,4", "1,1"), {"--outer", "item 3", "'x'"}},
        {tessellate_args("quads", "equal", "abc,1,1,1", "1,1"), {"--outer", "item 1", "'abc'"}},
        {tessellate_args("quads", "equal", "1,,2,3", "1,1"), {"--outer", "item 2"}},
        {tessellate_args("quads", "equal", "1.5x,1,1,1", "1,1"), {"--outer", "'1.5x'"}},
        {tessellate_args("quads", "equal", "1,2,3", "1,1"), {"--outer", "4", "3"}},
        {tessellate_args("quads", "equal", "1,2,3,4,5", "1,1"), {"--outer", "4", "5"}},
        {tessellate_args("quads", "equal", "1,1,1,1", "1"), {"--inner", "2"}},
        {tessellate_args("quads", "equal", "1,1,1,1", "1,--"), {"--inner", "item 2"}},
        {tessellate_args("quad", "equal", "1,1,1,1", "1,1"), {"--domain", "'quad'"}},
        {tessellate_args("quads", "fractional", "1,1,1,1", "1,1"), {"--spacing", "'fractional'"}},
        {tessellate_args("quads", "equal", "1,1,1,1", "1,1", {"--winding", "left"}), {"--winding", "'left'"}},
        {tessellate_args("quads", "equal", "1,1,1,1", "1,1", {"--precision", "double"}), {"--precision"}},
        {tessellate_args("quads", "equal", "1,1,1,1", "1,1", {"--format", "bmp"}), {"--format", "'bmp'"}},
        {tessellate_args("quads", "equal", "1,1,1,1", "1,1", {"--bogus"}), {"--bogus"}},
        {{"tessellate", "--domain", "quads", "--spacing", "equal", "--inner", "1,1"}, {"--outer"}},
        {{"tessellate", "--domain", "triangles", "--spacing", "equal", "--outer", "1,1,1,1"}, {"--inner"}},
    };
    for (const Bad& bad : cases) {
        for (const bool existing : {false, true}) {
            const fs::path target = dir_ / "result.txt";
            fs::remove(target);
            if (existing) write_file(target, "untouched\n");
            std::vector<std::string> args = bad.args;
            args.insert(args.end(), {"-o", target.string()});
            const RunResult r = run(args);
            std::string shown;
            for (const auto& a : bad.args) shown += a + " ";
            EXPECT_EQ(r.status, 2) << shown;
            EXPECT_EQ(r.err.rfind("tessref: error: ", 0), 0u) << shown << "\n" << r.err;
            const std::string first_line = r.err.substr(0, r.err.find('\n'));
            for (const std::string& part : bad.message_parts)
                EXPECT_NE(first_line.find(part), std::string::npos) << "'" << part << "' not in: " << first_line;
            EXPECT_TRUE(r.out.empty()) << r.out;
            if (existing) {
                EXPECT_EQ(read_file(target), "untouched\n") << shown;
                EXPECT_EQ(files(), std::set<std::string>{"result.txt"}) << shown;
            } else {
                EXPECT_TRUE(files().empty()) << shown << ": left " << *files().begin();
            }
        }
    }
}

TEST_F(CliTest, UnwritableOutputIsBadInputAndLeavesNothing) {
    const fs::path target = dir_ / "missing-dir" / "out.png";
    const RunResult r = run(tessellate_args("quads", "equal", "2,2,2,2", "2,2", {"-o", target.string()}));
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err.rfind("tessref: error: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find("out.png"), std::string::npos) << r.err;
    EXPECT_TRUE(files().empty());

    // A directory in the target's place: the rename fails, the temporary file goes.
    fs::create_directories(dir_ / "taken.txt" / "inside");
    const RunResult d = run(tessellate_args("quads", "equal", "2,2,2,2", "2,2", {"-o", (dir_ / "taken.txt").string()}));
    EXPECT_EQ(d.status, 2);
    EXPECT_EQ(files(), std::set<std::string>{"taken.txt"});
}

TEST_F(CliTest, NumbersAcceptSignsExponentsAndNonFinites) {
    // Every one of these is a valid float; equal spacing clamps them to [1, 64] (the culling
    // test !(x > 0) is not triggered since each used outer level is positive).
    const RunResult r = run(tessellate_args("quads", "equal", "1e9,2.5e-3,+3,INF", " 2 , Infinity",
                                            {"--format", "json"}));
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json doc = nlohmann::json::parse(r.out);
    EXPECT_EQ(doc["culled"], false);
    EXPECT_EQ(doc["levels"]["given"]["outer"][0].get<double>(), double(1e9f));
    EXPECT_EQ(doc["levels"]["given"]["outer"][1].get<double>(), double(2.5e-3f));
    EXPECT_EQ(doc["levels"]["given"]["outer"][2].get<double>(), 3.0);
    EXPECT_EQ(doc["levels"]["given"]["outer"][3], "inf");
    EXPECT_EQ(doc["levels"]["given"]["inner"][0].get<double>(), 2.0);
    EXPECT_EQ(doc["levels"]["given"]["inner"][1], "inf");
    const auto& effective = doc["levels"]["effective"]["outer"];
    EXPECT_EQ(effective[0].get<double>(), 64.0);
    EXPECT_EQ(effective[1].get<double>(), 1.0);
    EXPECT_EQ(effective[2].get<double>(), 3.0);
    EXPECT_EQ(effective[3].get<double>(), 64.0);
}
