// A user's vertex, control and evaluation shaders run by the CPU pipeline through the SPIR-V
// interpreter ([shaders], --shader on render, mesh and gl): what they compute against what
// the models compute (a change whose effect is exact in float), against llvmpipe's capture
// of the same shaders, and the shipped twins given as user files.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <unistd.h>
#include <filesystem>
#include <functional>
#include <set>
#include <string>
#include <algorithm>
#include <cstdio>
#include <vector>

#include "command_dir_test.h"
#include "image/image_io.h"
#include "run_program.h"
#include "pipeline/program.h"
#include "tessref/capture.h"
#include "tessref/error.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"
#include "tessref/scene.h"
#include "tessref/shader.h"

namespace {

namespace fs = std::filesystem;
using tessref::test::read_file;
using tessref::test::RunResult;
using tessref::test::write_file;

const fs::path kSource = TESSREF_SOURCE_DIR;
const fs::path kUserShaders = kSource / "tests" / "data" / "gl";

fs::path scene_path(const std::string& name) { return kSource / "data" / "scenes" / (name + ".toml"); }

tessref::Scene with_shader(const std::string& scene, tessref::ShaderStage stage, const fs::path& file) {
    tessref::Scene s = tessref::load_scene(scene_path(scene).string());
    s.shaders.push_back(tessref::StageShader{stage, file.string(), "--shader " + file.string(), tessref::Where::in_file("--shader")});
    return s;
}

std::uint32_t bits(double v) { return std::bit_cast<std::uint32_t>(static_cast<float>(v)); }

// double_height.tese is the thesis twin with the height times 2.0, which is exact in float:
// at every vertex the CPU must give the model's x and y and twice the model's z, bit for
// bit (the models ignore [shaders]; the interpreter runs the user's file).
TEST(UserShaders, DoubledHeightIsTwiceTheModelsHeightAtEveryVertex) {
    const tessref::Scene model_scene = tessref::load_scene(scene_path("thesis-all-10").string());
    const tessref::Scene user_scene =
        with_shader("thesis-all-10", tessref::ShaderStage::tess_evaluation, kUserShaders / "double_height.tese");
    const tessref::PipelineResult model = tessref::run_pipeline(model_scene);
    const tessref::PipelineResult user = tessref::run_pipeline(user_scene);
    ASSERT_EQ(model.mesh.positions.size(), user.mesh.positions.size());
    ASSERT_GT(model.mesh.positions.size(), 1000u);
    std::size_t same_xy = 0, doubled_z = 0, raised = 0;
    for (std::size_t v = 0; v < model.mesh.positions.size(); ++v) {
        const glm::dvec3 m = model.mesh.positions[v], u = user.mesh.positions[v];
        same_xy += bits(m.x) == bits(u.x) && bits(m.y) == bits(u.y);
        doubled_z += bits(2.0 * m.z) == bits(u.z);
        raised += m.z != 0.0;
    }
    EXPECT_GT(raised, model.mesh.positions.size() / 2);  // the terrain is not flat
    EXPECT_EQ(same_xy, model.mesh.positions.size());
    EXPECT_EQ(doubled_z, model.mesh.positions.size());
    // The levels are the model's: the user changed no stage that makes them.
    ASSERT_EQ(model.levels.size(), user.levels.size());
    for (std::size_t p = 0; p < model.levels.size(); ++p)
        EXPECT_EQ(std::memcmp(&model.levels[p], &user.levels[p], sizeof(tessref::TessLevels)), 0) << p;
}

// The twins themselves through the interpreter (a copy with a comment appended is not the
// twin's text, so it is interpreted): the very mesh of the model path, positions, normals
// (the thesis's normal-map geometry stage runs as the model on the interpreter's texture
// coordinates) and uvs, bit for bit, in the math mode where the twin tests hold each twin
// to its model.
struct TwinCase {
    const char* scene;
    const char* base;
    bool control;
    tessref::MathMode math = tessref::MathMode::exact;
    // PN's positions and normals are the model's in neither math mode as a whole scene: in
    // exact math the correctly rounded inversesqrt of normalize() moves a few ulps (the
    // model rounds 1 / sqrt twice); in llvmpipe math the interpreter sums its evaluation's
    // dot products in llvmpipe's order, the model's evaluation in glm's (202 positions and
    // 13391 normals of 18407 vertices differ). Its levels and triangles are compared, in
    // exact math.
    bool values = true;
    // lab 4's normal is its evaluation shader's normalize(), which its model computes with
    // glm (dot from the first component, 1 / sqrt): the interpreter's exact math rounds the
    // inversesqrt once, its llvmpipe math sums the dot from the last component, as llvmpipe
    // does. Its positions, uvs and levels are compared, in llvmpipe math.
    bool normals = true;
};

class InterpretedTwins : public ::testing::TestWithParam<TwinCase> {};

TEST_P(InterpretedTwins, GiveTheModelsMeshBitForBit) {
    const TwinCase c = GetParam();
    const fs::path dir = fs::temp_directory_path() / ("tessref-test-twins-" + std::to_string(::getpid()) + "-" + c.scene);
    fs::create_directories(dir);
    tessref::Scene user = tessref::load_scene(scene_path(c.scene).string());
    const tessref::Scene model_scene = user;
    std::vector<std::pair<tessref::ShaderStage, std::string>> stages = {
        {tessref::ShaderStage::vertex, ".vert"}, {tessref::ShaderStage::tess_evaluation, ".tese"}};
    if (c.control) stages.push_back({tessref::ShaderStage::tess_control, ".tesc"});
    for (const auto& [stage, ext] : stages) {
        const fs::path copy = dir / (std::string(c.base) + ext);
        write_file(copy, read_file(kSource / "data" / "shaders" / (std::string(c.base) + ext)) + "// a copy\n");
        user.shaders.push_back(tessref::StageShader{stage, copy.string(), copy.string(), tessref::Where::in_file(copy.string())});
    }
    ASSERT_EQ(tessref::pipeline::interpreted_stages(user).size(), stages.size());
    tessref::PipelineOptions options;
    options.math = c.math;
    const tessref::PipelineResult a = tessref::run_pipeline(model_scene, options);
    const tessref::PipelineResult b = tessref::run_pipeline(user, options);
    fs::remove_all(dir);
    ASSERT_EQ(a.mesh.positions.size(), b.mesh.positions.size());
    std::size_t positions = 0, normals = 0, uvs = 0, levels = 0;
    for (std::size_t v = 0; v < a.mesh.positions.size(); ++v) {
        positions += a.mesh.positions[v] != b.mesh.positions[v];
        if (!a.mesh.normals.empty()) normals += a.mesh.normals[v] != b.mesh.normals[v];
        if (!a.mesh.uvs.empty()) uvs += a.mesh.uvs[v] != b.mesh.uvs[v];
    }
    for (std::size_t p = 0; p < a.levels.size(); ++p)
        levels += std::memcmp(&a.levels[p], &b.levels[p], sizeof(tessref::TessLevels)) != 0;
    EXPECT_EQ(a.mesh.normals.size(), b.mesh.normals.size());
    EXPECT_EQ(a.mesh.uvs.size(), b.mesh.uvs.size());
    EXPECT_EQ(levels, 0u);
    EXPECT_EQ(uvs, 0u);
    if (!c.values) return;
    EXPECT_EQ(positions, 0u);
    if (c.normals) EXPECT_EQ(normals, 0u);
    EXPECT_EQ(a.mesh.triangles, b.mesh.triangles);
}

INSTANTIATE_TEST_SUITE_P(
    Scenes, InterpretedTwins,
    ::testing::Values(TwinCase{"thesis-map-4", "thesis_terrain", true}, TwinCase{"thesis-constant-1", "thesis_terrain", false},
                      TwinCase{"cosc422", "cosc422_terrain", true}, TwinCase{"lab4-canyon", "lab4_terrain", true, tessref::MathMode::llvmpipe, true, false},
                      TwinCase{"pn-triangles", "pn_triangles", true, tessref::MathMode::exact, false}),
    [](const auto& info) {
        std::string name = info.param.scene;
        for (char& ch : name) ch = std::isalnum(static_cast<unsigned char>(ch)) ? ch : '_';
        return name;
    });

// A user file whose text is exactly the twin's is the twin: the model's fast path.
TEST(UserShaders, TheTwinsOwnTextKeepsTheModelPath) {
    const tessref::Scene s = with_shader("thesis-all-10", tessref::ShaderStage::tess_evaluation,
                                         kSource / "data" / "shaders" / "thesis_terrain.tese");
    EXPECT_TRUE(tessref::pipeline::interpreted_stages(s).empty());
}

class UserShaderCommand : public tessref::test::CommandDirTest {};

// `tessref mesh --shader` with the shipped twin's own file writes the very bytes of the
// run without it; with the doubled height, other bytes.
TEST_F(UserShaderCommand, MeshWithTheTwinsFileIsByteIdentical) {
    const std::string scene = scene_path("thesis-all-10").string();
    ASSERT_EQ(run({"mesh", scene, "-o", path("model.ply")}).status, 0);
    const RunResult twin = run({"mesh", scene, "-o", path("twin.ply"), "--shader",
                                "tese=" + (kSource / "data" / "shaders" / "thesis_terrain.tese").string()});
    ASSERT_EQ(twin.status, 0) << twin.err;
    const RunResult user = run({"mesh", scene, "-o", path("user.ply"), "--shader",
                                "tese=" + (kUserShaders / "double_height.tese").string()});
    ASSERT_EQ(user.status, 0) << user.err;
    EXPECT_EQ(read_file(path("model.ply")), read_file(path("twin.ply")));
    EXPECT_NE(read_file(path("model.ply")), read_file(path("user.ply")));
}

// A shader that never ends: exit 2 naming the stage, the patch and the budget, no file.
TEST_F(UserShaderCommand, EndlessShaderStopsAtTheInstructionBudget) {
    const RunResult r = run({"mesh", scene_path("thesis-constant-1").string(), "-o", path("x.ply"), "--shader",
                             "tese=" + (kUserShaders / "endless.tese").string(), "--max-instructions", "5000"});
    EXPECT_EQ(r.status, 2) << r.out << r.err;
    EXPECT_NE(r.err.find("evaluation shader"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("patch "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("instruction budget of 5000"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("endless.tese"), std::string::npos) << r.err;
    EXPECT_TRUE(files().empty());
    const RunResult bad = run({"mesh", scene_path("thesis-constant-1").string(), "-o", path("x.ply"),
                               "--max-instructions", "0"});
    EXPECT_EQ(bad.status, 2);
    EXPECT_NE(bad.err.find("--max-instructions"), std::string::npos) << bad.err;
}

// An instruction the interpreter does not run: exit 2 naming the opcode (once "Op") and
// the file and line of the source (the bitfieldExtract line of unsupported_op.tese).
TEST_F(UserShaderCommand, UnsupportedOpcodeNamesItAndTheSourceLine) {
    const fs::path tese = kUserShaders / "unsupported_op.tese";
    const std::string text = read_file(tese);
    const std::size_t at = text.find("bitfieldExtract");
    ASSERT_NE(at, std::string::npos);
    const std::size_t line = static_cast<std::size_t>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n')) + 1;
    const RunResult r = run({"mesh", scene_path("thesis-constant-1").string(), "-o", path("x.ply"), "--shader",
                             "tese=" + tese.string()});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("OpBitFieldSExtract is not supported"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("OpOp"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("unsupported_op.tese:" + std::to_string(line)), std::string::npos) << r.err;
    EXPECT_TRUE(files().empty());
}

// Exact precision runs the double models; a user's shader runs in float only.
TEST_F(UserShaderCommand, ExactPrecisionWithAUsersShaderIsRefused) {
    const RunResult r = run({"mesh", scene_path("thesis-all-10").string(), "-o", path("x.ply"), "--precision", "exact",
                             "--shader", "tese=" + (kUserShaders / "double_height.tese").string()});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("gpu precision only"), std::string::npos) << r.err;
    EXPECT_TRUE(files().empty());
}

// ---- tessref trace ------------------------------------------------------------------------

// thesis-constant-1: 16 x 16 patches over [0, 128]^2, so patch 17 (column 1, row 1) has the
// corners (8, 8), (8, 16), (16, 16), (16, 8) in the twin's order c0..c3. At tess coord
// (0.5, 0.25): adPosition = mix(c0, c3, 0.5) = (12, 8), bcPosition = mix(c1, c2, 0.5) =
// (12, 16), position = mix(ad, bc, 0.25) = (12, 10), and textureCoordinate = position.xy /
// scaleXY (128) = (0.09375, 0.078125); every step exact in float.
TEST_F(UserShaderCommand, TraceOfTheTwinsEvaluationGivesTheHandComputedValues) {
    const RunResult r = run({"trace", scene_path("thesis-constant-1").string(), "--patch", "17", "--stage", "tese",
                             "--tess-coord", "0.5,0.25", "--json"});
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["math"], "exact");
    EXPECT_EQ(j["stage"], "tess_evaluation");
    const auto stored = [&](const std::string& name) {
        std::vector<double> values;
        for (const auto& line : j["lines"])
            for (const auto& s : line["stores"])
                if (s["name"] == name && s["offset"] == 0) {
                    values.clear();
                    for (const auto& v : s["values"]) values.push_back(v.get<double>());
                }
        return values;
    };
    const std::vector<double> ad = stored("adPosition"), bc = stored("bcPosition"), position = stored("position"),
                              st = stored("evaluationOut");
    ASSERT_EQ(ad.size(), 4u) << r.out;
    ASSERT_EQ(position.size(), 4u) << r.out;
    ASSERT_EQ(st.size(), 2u) << r.out;
    EXPECT_EQ(ad[0], 12.0);
    EXPECT_EQ(ad[1], 8.0);
    EXPECT_EQ(bc[0], 12.0);
    EXPECT_EQ(bc[1], 16.0);
    EXPECT_EQ(position[0], 12.0);
    EXPECT_EQ(position[1], 10.0);
    EXPECT_EQ(st[0], 0.09375);
    EXPECT_EQ(st[1], 0.078125);
    // The lines in execution order: the mix of ad comes before the one of position.
    std::vector<unsigned> lines;
    for (const auto& line : j["lines"]) lines.push_back(line["line"].get<unsigned>());
    ASSERT_FALSE(lines.empty());
    // The outputs: gl_Position with the capture's mvp (the identity) is the position with its height.
    EXPECT_EQ(j["outputs"]["gl_Position"][0], 12.0);
    EXPECT_EQ(j["outputs"]["gl_Position"][1], 10.0);

    const RunResult text = run({"trace", scene_path("thesis-constant-1").string(), "--patch", "17", "--stage", "tese",
                                "--tess-coord", "0.5,0.25", "--math", "llvmpipe"});
    ASSERT_EQ(text.status, 0) << text.err;
    EXPECT_NE(text.out.find("llvmpipe math"), std::string::npos) << text.out;
    EXPECT_NE(text.out.find("position = (12, 10, "), std::string::npos) << text.out;
}

// A control shader: each invocation's lines and the levels; corner_max.tesc's outer level 0
// is (max(z0, z1) + 100) * 18 / 100 + 2 of its corners 0 and 1.
TEST_F(UserShaderCommand, TraceOfAUsersControlShaderListsEveryInvocation) {
    const std::string scene = scene_path("cosc422").string();
    const RunResult r = run({"trace", scene, "--patch", "10", "--stage", "tesc", "--json", "--shader",
                             "tesc=" + (kUserShaders / "corner_max.tesc").string()});
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    std::set<int> invocations;
    for (const auto& line : j["lines"]) invocations.insert(line["invocation"].get<int>());
    EXPECT_EQ(invocations, (std::set<int>{0, 1, 2, 3}));
    const tessref::Scene s = tessref::load_scene(scene);
    const tessref::TerrainGrid& g = *s.grid;
    const std::size_t row = 10 / static_cast<std::size_t>(g.patches_u);
    const float z0 = static_cast<float>(g.v_coords[row]), z1 = static_cast<float>(g.v_coords[row + 1]);
    const float z = std::max(z0, z1);
    const float level = (z + 100.0f) * 18.0f / 100.0f + 2.0f;
    EXPECT_EQ(j["outputs"]["outer"][0].get<float>(), level) << r.out;
    EXPECT_EQ(j["outputs"]["vertices"].size(), 4u);
}

// Bad requests: exit 2 naming the flag.
TEST_F(UserShaderCommand, TraceRefusesABadPatchCoordOrStage) {
    const std::string scene = scene_path("thesis-constant-1").string();
    struct Case {
        std::vector<std::string> args;
        const char* flag;
    };
    const Case cases[] = {
        {{"--patch", "256", "--stage", "tese", "--tess-coord", "0.5,0.5"}, "--patch"},
        {{"--patch", "-1", "--stage", "tese", "--tess-coord", "0.5,0.5"}, "--patch"},
        {{"--patch", "0", "--stage", "tese", "--tess-coord", "1.5,0.5"}, "--tess-coord"},
        {{"--patch", "0", "--stage", "tese", "--tess-coord", "half"}, "--tess-coord"},
        {{"--patch", "0", "--stage", "tese"}, "--tess-coord"},
        {{"--patch", "0", "--stage", "vert", "--vertex", "4"}, "--vertex"},
        {{"--patch", "0", "--stage", "frag"}, "--stage"},
    };
    for (const Case& c : cases) {
        std::vector<std::string> args = {"trace", scene};
        args.insert(args.end(), c.args.begin(), c.args.end());
        const RunResult r = run(args);
        EXPECT_EQ(r.status, 2) << c.flag << "\n" << r.out << r.err;
        EXPECT_NE(r.err.find(c.flag), std::string::npos) << r.err;
    }
}

// ---- against llvmpipe (tessref gl) ----------------------------------------------------------

// Positions bit for bit; normals within 3 ulps: they are the geometry stage's (thesis
// normal_map, COSC422 face), which the CPU computes with its models, not the interpreter,
// and which differ from llvmpipe's geometry shader by up to that much without any user
// shader as well (the goldens' kGoldenMaxNormalUlps; thesis-all-10: 1303 of 39900 vertices).
tessref::CaptureCompareResult compare(const std::string& cpu, const std::string& gl, std::uint64_t normal_ulps = 3) {
    tessref::CaptureCompareOptions options;
    options.max_normal_ulps = normal_ulps;
    return tessref::compare_captures(tessref::read_capture(cpu), tessref::read_capture(gl), options);
}

// A user's control shader with a loop, a constant array, a per-patch output array and
// barrier(): the CPU runs it to predict llvmpipe's counts, so every draw is as predicted,
// and its levels are llvmpipe's on every patch.
TEST_F(UserShaderCommand, GlPredictsTheCountsOfAUsersControlShader) {
    const std::string scene = scene_path("cosc422").string(), tesc = "tesc=" + (kUserShaders / "corner_max.tesc").string();
    const RunResult gl = run({"gl", scene, "-o", path("gl.png"), "--size", "160x100", "--capture", path("gl.txt"),
                              "--shader", tesc});
    ASSERT_EQ(gl.status, 0) << gl.out << gl.err;
    EXPECT_NE(gl.out.find("every count as predicted"), std::string::npos) << gl.out;
    const RunResult cpu = run({"mesh", scene, "--capture", path("cpu.txt"), "--math", "llvmpipe", "--shader", tesc});
    ASSERT_EQ(cpu.status, 0) << cpu.err;
    const tessref::CaptureCompareResult c = compare(path("cpu.txt"), path("gl.txt"));
    EXPECT_EQ(c.missing_in_test + c.missing_in_reference, 0u);
    EXPECT_EQ(c.tess_coord_divergences, 0u);
    EXPECT_EQ(c.triangle_divergences, 0u);
    EXPECT_EQ(c.orientation_divergences, 0u);
    EXPECT_GT(c.vertices_compared, 1000u);
    EXPECT_EQ(c.worst_position.ulps, 0u);
    EXPECT_EQ(c.failing_vertices, 0u);
}

// A user's evaluation shader (the height doubled), on the CPU and on llvmpipe, in the
// llvmpipe math mode: the same tess coords and triangles on every patch, and every position
// bit-identical (the issue asks for 99 % of the vertices; the normals are the model's
// geometry stage, see compare()).
TEST_F(UserShaderCommand, DoubledHeightCaptureIsLlvmpipes) {
    const std::string scene = scene_path("thesis-all-10").string(),
                      tese = "tese=" + (kUserShaders / "double_height.tese").string();
    const RunResult gl = run({"gl", scene, "-o", path("gl.png"), "--size", "160x100", "--capture", path("gl.txt"),
                              "--shader", tese});
    ASSERT_EQ(gl.status, 0) << gl.out << gl.err;
    const RunResult cpu = run({"mesh", scene, "--capture", path("cpu.txt"), "--math", "llvmpipe", "--shader", tese});
    ASSERT_EQ(cpu.status, 0) << cpu.err;
    const tessref::CaptureCompareResult c = compare(path("cpu.txt"), path("gl.txt"));
    EXPECT_EQ(c.tess_coord_divergences + c.triangle_divergences + c.orientation_divergences, 0u);
    ASSERT_GT(c.vertices_compared, 10000u);
    EXPECT_EQ(c.worst_position.ulps, 0u);
    EXPECT_EQ(c.failing_vertices, 0u);
    const tessref::CaptureCompareResult exact = compare(path("cpu.txt"), path("gl.txt"), 0);
    std::printf("doubled height: positions bit-identical on all %zu vertices; normals on %zu (worst %llu ulps)\n",
                exact.vertices_compared, exact.vertices_compared - exact.failing_vertices,
                static_cast<unsigned long long>(exact.worst_normal.ulps));
}

// `cw` in a user's evaluation shader where the scene says `ccw`: llvmpipe emits the same
// triangles the other way round, and compare on the captures says so. thesis-constant-1 at
// level 1: two triangles in each of the 256 patches, every one flipped.
TEST_F(UserShaderCommand, FlippedWindingIsReportedByCompare) {
    const std::string scene = scene_path("thesis-constant-1").string();
    const RunResult gl = run({"gl", scene, "-o", path("gl.png"), "--size", "160x100", "--capture", path("gl.txt"),
                              "--shader", "tese=" + (kUserShaders / "flipped_winding.tese").string()});
    ASSERT_EQ(gl.status, 0) << gl.out << gl.err;
    ASSERT_EQ(run({"mesh", scene, "--capture", path("cpu.txt")}).status, 0);
    const RunResult cmp = run({"compare", path("cpu.txt"), path("gl.txt")});
    EXPECT_EQ(cmp.status, 1) << cmp.out << cmp.err;
    EXPECT_NE(cmp.out.find("256 other orientation (512 triangles)"), std::string::npos) << cmp.out;
    const tessref::CaptureCompareResult c = compare(path("cpu.txt"), path("gl.txt"));
    EXPECT_EQ(c.orientation_divergences, 256u);
    EXPECT_EQ(c.flipped_triangles, 512u);
}

}  // namespace

namespace {

// sweep.csv with every timing (*_ms) field emptied: what two sweeps of the same surfaces
// share byte for byte.
std::string sweep_without_timings(const fs::path& csv) {
    const std::string text = read_file(csv);
    std::vector<std::string> lines;
    for (std::size_t at = 0; at < text.size();) {
        const std::size_t end = text.find('\n', at);
        lines.push_back(text.substr(at, end - at));
        at = end == std::string::npos ? text.size() : end + 1;
    }
    const auto fields = [](const std::string& line) {
        std::vector<std::string> out(1);
        for (const char ch : line) {
            if (ch == ',') out.emplace_back();
            else out.back() += ch;
        }
        return out;
    };
    const std::vector<std::string> header = fields(lines.at(0));
    std::string out;
    for (const std::string& line : lines) {
        const std::vector<std::string> f = fields(line);
        for (std::size_t k = 0; k < f.size(); ++k) {
            const bool timing = k < header.size() && header[k].size() > 3 && header[k].ends_with("_ms");
            out += (k ? "," : "") + (timing ? std::string() : f[k]);
        }
        out += "\n";
    }
    return out;
}

}  // namespace

// `tessref sweep --shader`: every row runs the user's stage. A copy of the twin (a comment
// added, so the interpreter runs it) measures the very surfaces the model does; the doubled
// height other ones; exact precision, which the interpreter does not compute, is refused.
TEST_F(UserShaderCommand, SweepRunsTheShaderInEveryRow) {
    const std::string scene = scene_path("thesis-constant-1").string();
    const fs::path copy = path("copy.tese");
    write_file(copy, read_file(kSource / "data" / "shaders" / "thesis_terrain.tese") + "// a copy\n");
    const std::vector<std::string> common = {"sweep", scene, "--levels", "1,3", "--size", "64x40"};
    const auto sweep = [&](const std::string& out, std::vector<std::string> extra) {
        std::vector<std::string> args = common;
        args.push_back("-o");
        args.push_back(path(out));
        args.insert(args.end(), extra.begin(), extra.end());
        return run(args);
    };
    const RunResult model = sweep("model", {});
    ASSERT_EQ(model.status, 0) << model.err;
    const RunResult twin = sweep("twin", {"--shader", "tese=" + copy.string()});
    ASSERT_EQ(twin.status, 0) << twin.err;
    const RunResult doubled = sweep("doubled", {"--shader", "tese=" + (kUserShaders / "double_height.tese").string()});
    ASSERT_EQ(doubled.status, 0) << doubled.err;
    const std::string rows = sweep_without_timings(fs::path(path("model")) / "sweep.csv");
    EXPECT_EQ(sweep_without_timings(fs::path(path("twin")) / "sweep.csv"), rows);
    EXPECT_NE(sweep_without_timings(fs::path(path("doubled")) / "sweep.csv"), rows);
    const RunResult exact = sweep("exact", {"--precision", "exact", "--shader", "tese=" + copy.string()});
    EXPECT_EQ(exact.status, 2) << exact.err;
    EXPECT_NE(exact.err.find("copy.tese"), std::string::npos) << exact.err;
    EXPECT_FALSE(fs::exists(fs::path(path("exact"))));
}

// `tessref golden` runs a scene's [shaders] on both sides: update writes the capture of the
// user's evaluation shader (not the model's), and verify, whose llvmpipe side draws with the
// same file, passes.
TEST_F(UserShaderCommand, GoldenRunsTheScenesShadersOnBothSides) {
    // thesis-constant-1 in a scenes directory of its own, its files named absolutely.
    std::string toml = read_file(scene_path("thesis-constant-1"));
    for (std::size_t at = 0; (at = toml.find("\"../", at)) != std::string::npos;)
        toml.replace(at, 4, "\"" + (kSource / "data").string() + "/");
    fs::create_directories(fs::path(path("scenes")));
    write_file(fs::path(path("scenes")) / "model.toml", toml);
    write_file(fs::path(path("scenes")) / "user.toml",
               toml + "\n[shaders]\ntess_evaluation = \"" + (kUserShaders / "double_height.tese").string() + "\"\n");
    const std::vector<std::string> where = {"--scenes", path("scenes"), "--golden", path("golden")};
    const auto golden = [&](const std::string& action, const std::string& scene) {
        std::vector<std::string> args = {"golden", action, scene};
        args.insert(args.end(), where.begin(), where.end());
        return run(args);
    };
    ASSERT_EQ(golden("update", "model").status, 0);
    const RunResult update = golden("update", "user");
    ASSERT_EQ(update.status, 0) << update.err;
    // The captures' vertex lines: the user's heights are twice the model's.
    const auto vertex_lines = [](const std::string& text) {
        std::string out;
        for (std::size_t at = 0; at < text.size();) {
            const std::size_t end = text.find('\n', at);
            const std::string line = text.substr(at, end - at);
            if (!line.empty() && line[0] != '#' && line.rfind("capture", 0) != 0 && line.rfind("size", 0) != 0 &&
                line.rfind("tessref", 0) != 0)
                out += line + "\n";
            at = end == std::string::npos ? text.size() : end + 1;
        }
        return out;
    };
    EXPECT_NE(vertex_lines(read_file(fs::path(path("golden")) / "user" / "capture.txt")),
              vertex_lines(read_file(fs::path(path("golden")) / "model" / "capture.txt")));
    const RunResult verify = golden("verify", "user");
    EXPECT_EQ(verify.status, 0) << verify.out << verify.err;
}

// golden and sweep run a scene's user geometry shader too: drop_steep.geom in [shaders]
// makes golden update record the 21303 triangles it emits (of the generator's 24246), and
// verify, whose llvmpipe side draws with the same file, pass; a sweep's row counts them.
TEST_F(UserShaderCommand, GoldenAndSweepRunAUsersGeometryShader) {
    std::string toml = read_file(scene_path("cosc422"));
    for (std::size_t at = 0; (at = toml.find("\"../", at)) != std::string::npos;)
        toml.replace(at, 4, "\"" + (kSource / "data").string() + "/");
    fs::create_directories(fs::path(path("scenes")));
    write_file(fs::path(path("scenes")) / "user.toml",
               toml + "\n[shaders]\ngeometry = \"" + (kUserShaders / "drop_steep.geom").string() + "\"\n");
    const std::vector<std::string> where = {"--scenes", path("scenes"), "--golden", path("golden")};
    std::vector<std::string> update = {"golden", "update", "user"};
    update.insert(update.end(), where.begin(), where.end());
    const RunResult updated = run(update);
    ASSERT_EQ(updated.status, 0) << updated.err;
    EXPECT_NE(updated.out.find("capture.txt 81 patches 21303 triangles"), std::string::npos) << updated.out;
    std::vector<std::string> verify = {"golden", "verify", "user"};
    verify.insert(verify.end(), where.begin(), where.end());
    const RunResult verified = run(verify);
    EXPECT_EQ(verified.status, 0) << verified.out << verified.err;

    const RunResult sweep = run({"sweep", (fs::path(path("scenes")) / "user.toml").string(), "--levels", "2", "--size",
                                 "64x40", "-o", path("sweep")});
    ASSERT_EQ(sweep.status, 0) << sweep.err;
    EXPECT_NE(read_file(fs::path(path("sweep")) / "sweep.csv").find(",81,21303,"), std::string::npos);
}

// The shipped pn-culling scene: the PN tutorial's control shader with frustum and back-face
// patch culling (data/shaders/pn_culling.tesc, no C++ model) runs through the interpreter,
// and the CPU discards exactly the patches llvmpipe discards: the two captures hold the same
// patches with the same tess coords and triangles. (Positions are compared elsewhere: PN's
// evaluation differs from llvmpipe's by a few ulps without any culling.)
TEST_F(UserShaderCommand, PnCullingDiscardsLlvmpipesPatches) {
    const std::string scene = scene_path("pn-culling").string();
    const RunResult gl = run({"gl", scene, "-o", path("gl.png"), "--capture", path("gl.txt")});
    ASSERT_EQ(gl.status, 0) << gl.out << gl.err;
    EXPECT_NE(gl.out.find("every count as predicted"), std::string::npos) << gl.out;
    const RunResult cpu = run({"mesh", scene, "--capture", path("cpu.txt"), "--math", "llvmpipe"});
    ASSERT_EQ(cpu.status, 0) << cpu.err;
    tessref::CaptureCompareOptions options;
    options.max_position_ulps = 1u << 20;
    options.max_normal_ulps = 1u << 20;
    const tessref::CaptureCompareResult c = tessref::compare_captures(tessref::read_capture(path("cpu.txt")),
                                                                      tessref::read_capture(path("gl.txt")), options);
    EXPECT_EQ(c.missing_in_test, 0u);
    EXPECT_EQ(c.missing_in_reference, 0u);
    EXPECT_EQ(c.tess_coord_divergences + c.triangle_divergences + c.orientation_divergences, 0u);
    // Of the scene's 104 patches some are culled (the icosahedron's left part beyond the
    // frustum, the back faces of the icosahedron and the cube), most are not.
    const tessref::Scene s = tessref::load_scene(scene);
    EXPECT_EQ(s.patch_count(), 104u);
    EXPECT_LT(c.reference_patches, s.patch_count());
    EXPECT_GT(c.reference_patches, s.patch_count() / 2);
    EXPECT_EQ(c.compared_patches, c.reference_patches);
}

// ---- the geometry stage against llvmpipe's ------------------------------------------------

namespace {

// A geometry twin's normal at every vertex of every triangle of llvmpipe's capture, the
// triangle's three captured vertices handed to the twin as llvmpipe's evaluation stage
// handed them on: gl_Position the world position (thesis: mvp the identity in the capture
// pass), EvaluationData from `block`. Counts the vertices whose normal (location 0) differs
// from the captured one in any bit.
struct GeometryAgainstCapture {
    std::size_t vertices = 0, differing = 0;
    std::string first;
};

GeometryAgainstCapture geometry_against_capture(const tessref::Capture& capture, const std::string& twin,
                                                const tessref::shader::Bindings& bindings, tessref::shader::MathMode math,
                                                const std::function<std::vector<tessref::shader::Slot>(glm::vec3)>& block) {
    const fs::path file = kSource / "data" / "shaders" / twin;
    tessref::shader::Source source;
    source.stage = tessref::ShaderStage::geometry;
    source.path = file.string();
    source.text = read_file(file);
    tessref::shader::RunOptions options;
    options.math = math;
    const tessref::shader::Executable geom(tessref::shader::Module::compile(source), bindings, options);
    GeometryAgainstCapture n;
    for (std::size_t t = 0; t + 2 < capture.vertices.size(); t += 3) {
        std::vector<tessref::shader::ShaderVertex> in(3);
        for (std::size_t i = 0; i < 3; ++i) {
            const glm::vec3 p = capture.vertices[t + i].position;
            in[i].position = glm::vec4(p, 1.0f);
            in[i].locations = block(p);
        }
        const tessref::shader::ShaderPrimitives out = geom.geometry(in, static_cast<long long>(t / 3));
        if (out.vertices.size() != 3) {
            ADD_FAILURE() << twin << " emitted " << out.vertices.size() << " vertices";
            return n;
        }
        for (std::size_t i = 0; i < 3; ++i) {
            const glm::vec3 shader(tessref::shader::as_vec4(out.vertices[i].locations.at(0)));
            const glm::vec3 gl = capture.vertices[t + i].normal;
            ++n.vertices;
            if (std::memcmp(&shader, &gl, sizeof shader) == 0) continue;
            ++n.differing;
            if (n.first.empty()) {
                char text[200];
                std::snprintf(text, sizeof text, "vertex %zu: interpreter (%.9g %.9g %.9g) llvmpipe (%.9g %.9g %.9g)", t + i,
                              shader.x, shader.y, shader.z, gl.x, gl.y, gl.z);
                n.first = text;
            }
        }
    }
    return n;
}

}  // namespace

// The geometry twins run by the interpreter in the llvmpipe mode give llvmpipe's own
// normals bit for bit (thesis normal map: normalMatrix * normalize(texel - 0.5); COSC422:
// normalize(cross(p1 - p0, p2 - p0))), from llvmpipe's own evaluation outputs. The C++
// models differ from llvmpipe there by up to 3 ulps (golden/README.md), and from these
// interpreter runs by as much (ThesisTwins.GeometryNormalsAreTheModelsButForNormalize):
// normalize as glm computes it, its dot product from the first component and 1 / sqrt,
// is not llvmpipe's, whose dot product sums from the last component.
TEST_F(UserShaderCommand, GeometryTwinsGiveLlvmpipesNormals) {
    using tessref::shader::MathMode;
    {
        const std::string scene = scene_path("thesis-all-10").string();
        ASSERT_EQ(run({"gl", scene, "-o", path("thesis.png"), "--capture", path("thesis.txt"), "--size", "160x100"}).status, 0);
        const tessref::Scene s = tessref::load_scene(scene);
        const float scale_xy = static_cast<float>(s.grid->scale_xy);
        tessref::shader::Bindings b;
        b.set("normalMatrix", glm::mat3(1.0f));
        b.bind_texture(2, s.grid->normal_map.get());
        // textureCoordinate = position.xy / scaleXY (thesis_terrain.tese; the height moves z only).
        const auto block = [&](glm::vec3 p) {
            return std::vector<tessref::shader::Slot>{tessref::shader::slot(glm::vec4(p.x / scale_xy, p.y / scale_xy, 0.0f, 0.0f))};
        };
        const tessref::Capture capture = tessref::read_capture(path("thesis.txt"));
        const GeometryAgainstCapture llvmpipe =
            geometry_against_capture(capture, "thesis_terrain.geom", b, MathMode::llvmpipe, block);
        EXPECT_GT(llvmpipe.vertices, 10000u);
        EXPECT_EQ(llvmpipe.differing, 0u) << llvmpipe.first;
        const GeometryAgainstCapture exact = geometry_against_capture(capture, "thesis_terrain.geom", b, MathMode::exact, block);
        std::printf("thesis-all-10 normals: llvmpipe mode %zu of %zu differ from llvmpipe's, exact mode %zu\n",
                    llvmpipe.differing, llvmpipe.vertices, exact.differing);
    }
    {
        const std::string scene = scene_path("cosc422").string();
        ASSERT_EQ(run({"gl", scene, "-o", path("cosc422.png"), "--capture", path("cosc422.txt"), "--size", "160x100"}).status, 0);
        // EvaluationData: worldPosition (location 0), texCoord (1, unread by the normal).
        const auto block = [](glm::vec3 p) {
            return std::vector<tessref::shader::Slot>{tessref::shader::slot(glm::vec4(p, 0.0f)), tessref::shader::Slot{}};
        };
        const tessref::Capture capture = tessref::read_capture(path("cosc422.txt"));
        const GeometryAgainstCapture llvmpipe =
            geometry_against_capture(capture, "cosc422_terrain.geom", {}, MathMode::llvmpipe, block);
        EXPECT_GT(llvmpipe.vertices, 10000u);
        EXPECT_EQ(llvmpipe.differing, 0u) << llvmpipe.first;
        const GeometryAgainstCapture exact = geometry_against_capture(capture, "cosc422_terrain.geom", {}, MathMode::exact, block);
        std::printf("cosc422 face normals: llvmpipe mode %zu of %zu differ from llvmpipe's, exact mode %zu\n",
                    llvmpipe.differing, llvmpipe.vertices, exact.differing);
    }
}

// A user's geometry shader runs in the CPU pipeline (mesh --capture, render, gl's
// prediction), batched over each patch's triangles, and what it emits is llvmpipe's:
// face_normal.geom passes every triangle through with a face normal of its own
// (cross/normalize), drop_steep.geom drops the triangles that lean more than a threshold
// (fewer triangles than the generator makes, a count that hangs on the normals' last bits).
// In llvmpipe math the CPU's capture equals `gl --capture` bit for bit, positions and
// normals, on every vertex, and gl draws with every count as the CPU predicted.
TEST_F(UserShaderCommand, UserGeometryShaderCaptureIsLlvmpipes) {
    const std::string scene = scene_path("cosc422").string();
    std::size_t triangles[2] = {0, 0};
    int k = 0;
    for (const char* file : {"face_normal.geom", "drop_steep.geom"}) {
        const std::string geom = "geom=" + (kUserShaders / file).string();
        const RunResult gl = run({"gl", scene, "-o", path("gl.png"), "--size", "160x100", "--capture", path("gl.txt"),
                                  "--shader", geom});
        ASSERT_EQ(gl.status, 0) << file << gl.out << gl.err;
        EXPECT_NE(gl.out.find("every count as predicted"), std::string::npos) << gl.out;
        const RunResult cpu = run({"mesh", scene, "--capture", path("cpu.txt"), "--math", "llvmpipe", "--shader", geom});
        ASSERT_EQ(cpu.status, 0) << cpu.err;
        const tessref::CaptureCompareResult c = compare(path("cpu.txt"), path("gl.txt"), 0);
        EXPECT_EQ(c.tess_coord_divergences + c.triangle_divergences + c.orientation_divergences, 0u) << file;
        EXPECT_GT(c.vertices_compared, 10000u) << file;
        EXPECT_EQ(c.worst_position.ulps, 0u) << file;
        EXPECT_EQ(c.worst_normal.ulps, 0u) << file;
        EXPECT_EQ(c.failing_vertices, 0u) << file;
        triangles[k++] = tessref::read_capture(path("cpu.txt")).vertices.size() / 3;
        std::printf("%s: %zu vertices, positions and normals bit-identical to llvmpipe's on %zu\n", file,
                    c.vertices_compared, c.vertices_compared - c.failing_vertices);
    }
    // The generator's 24246 triangles, all passed through; the steep ones dropped.
    EXPECT_EQ(triangles[0], 24246u);
    EXPECT_GT(triangles[1], 10000u);
    EXPECT_LT(triangles[1], triangles[0]);
}

// The general case, a geometry shader that emits other positions than it reads:
// shrink.geom draws every triangle shrunk toward its centroid, leaving gaps between them.
// The CPU's render (llvmpipe math) is llvmpipe's but for a few pixels on the triangles' edges
// (GL combines the corners in clip space, the CPU in world space and then projects; 3 of
// 64 000 pixels when written, as many as the model's render differs by, 1), and covers
// far fewer pixels than the whole surface does.
TEST_F(UserShaderCommand, AGeometryShaderThatMovesVerticesRendersAsLlvmpipe) {
    const std::string scene = scene_path("cosc422").string();
    const std::string geom = "geom=" + (kUserShaders / "shrink.geom").string();
    const RunResult gl = run({"gl", scene, "-o", path("gl.png"), "--size", "320x200", "--shader", geom});
    ASSERT_EQ(gl.status, 0) << gl.out << gl.err;
    const RunResult cpu = run({"render", scene, "-o", path("cpu.png"), "--size", "320x200", "--math", "llvmpipe",
                               "--shader", geom});
    ASSERT_EQ(cpu.status, 0) << cpu.err;
    const RunResult whole = run({"render", scene, "-o", path("whole.png"), "--size", "320x200", "--math", "llvmpipe"});
    ASSERT_EQ(whole.status, 0) << whole.err;
    const tessref::image::Image a = tessref::image::read_image(path("cpu.png"));
    const tessref::image::Image b = tessref::image::read_image(path("gl.png"));
    const tessref::image::Image c = tessref::image::read_image(path("whole.png"));
    ASSERT_EQ(a.channels, 4);
    ASSERT_EQ(a.u8.size(), b.u8.size());
    std::size_t differing = 0, covered = 0, covered_whole = 0;
    for (std::size_t i = 0; i < a.u8.size(); i += 4) {
        differing += !std::equal(&a.u8[i], &a.u8[i] + 4, &b.u8[i]);
        covered += a.u8[i + 3] != 0;
        covered_whole += c.u8[i + 3] != 0;
    }
    EXPECT_LE(differing, 20u);
    EXPECT_LT(covered, covered_whole / 2);
    EXPECT_GT(covered, 1000u);
    std::printf("shrink.geom: %zu of %zu pixels differ from llvmpipe's; %zu covered (the whole surface %zu)\n", differing,
                a.u8.size() / 4, covered, covered_whole);
}

// A user's copy of a geometry twin under another name (any other text runs through the
// interpreter) renders as the model: cosc422's face normals give the very bytes; the thesis's
// normal-map normals differ from the model's where normalize rounds otherwise (the model's
// glm v * (1 / sqrt(dot)) against GLSL's normalize, ShaderTwins'
// *GeometryNormalsAreTheModelsButForNormalize), which moves a few pixels by one 8-bit step.
TEST_F(UserShaderCommand, AUsersCopyOfAGeometryTwinRendersAsTheModel) {
    for (const auto& [scene, twin] : {std::pair<std::string, std::string>{"cosc422", "cosc422_terrain.geom"},
                                      std::pair<std::string, std::string>{"thesis-all-10", "thesis_terrain.geom"}}) {
        write_file(path("copy.geom"), "// a user's copy\n" + read_file(kSource / "data" / "shaders" / twin));
        ASSERT_EQ(run({"render", scene_path(scene).string(), "-o", path("model.png"), "--size", "320x200"}).status, 0);
        const RunResult user = run({"render", scene_path(scene).string(), "-o", path("user.png"), "--size", "320x200",
                                    "--shader", "geom=" + path("copy.geom")});
        ASSERT_EQ(user.status, 0) << user.err;
        const tessref::image::Image a = tessref::image::read_image(path("model.png"));
        const tessref::image::Image b = tessref::image::read_image(path("user.png"));
        ASSERT_EQ(a.u8.size(), b.u8.size());
        std::size_t differing = 0;
        int worst = 0;
        for (std::size_t i = 0; i < a.u8.size(); ++i) {
            differing += a.u8[i] != b.u8[i];
            worst = std::max(worst, std::abs(int(a.u8[i]) - int(b.u8[i])));
        }
        if (scene == "cosc422") {
            EXPECT_EQ(differing, 0u) << scene;
        } else {
            EXPECT_LE(worst, 1) << scene;
            EXPECT_LE(differing, 10u) << scene;  // 2 of 64000 pixels when written
        }
        std::printf("%s: a user's copy of %s renders %zu samples differently from the model (at most %d)\n",
                    scene.c_str(), twin.c_str(), differing, worst);
    }
    // And the mesh: the same positions, texture coordinates and triangles as the model's,
    // bit for bit (thesis: normals within 3 ulps, the goldens' allowance for normalize).
    const RunResult model = run({"mesh", scene_path("cosc422").string(), "--capture", path("model.txt")});
    ASSERT_EQ(model.status, 0) << model.err;
    write_file(path("copy.geom"), "// a user's copy\n" + read_file(kSource / "data" / "shaders" / "cosc422_terrain.geom"));
    const RunResult user = run({"mesh", scene_path("cosc422").string(), "--capture", path("user.txt"), "--shader",
                                "geom=" + path("copy.geom")});
    ASSERT_EQ(user.status, 0) << user.err;
    const tessref::CaptureCompareResult c = compare(path("model.txt"), path("user.txt"), 3);
    EXPECT_EQ(c.tess_coord_divergences + c.triangle_divergences + c.orientation_divergences, 0u);
    EXPECT_EQ(c.worst_position.ulps, 0u);
    EXPECT_EQ(c.failing_vertices, 0u);
}

// A geometry shader whose output the pipeline cannot take is refused, exit 2, naming the
// file and the layout or the location; nothing is written.
TEST_F(UserShaderCommand, AGeometryShaderThePipelineCannotTakeIsRefused) {
    const std::string scene = scene_path("cosc422").string();
    const std::string body =
        "layout(location = 0) in EvaluationData { vec3 worldPosition; vec2 texCoord; } evaluationIn[];\n"
        "layout(location = 0) out GeometryData { vec3 faceNormal; vec2 texCoord; } geometryOut;\n"
        "void main() { for (int i = 0; i < gl_in.length(); i++) { geometryOut.faceNormal = vec3(0.0, 1.0, 0.0); "
        "geometryOut.texCoord = vec2(0.0); gl_Position = gl_in[i].gl_Position; EmitVertex(); } }\n";
    const struct {
        const char* name;
        std::string text;
        const char* says;
    } cases[] = {
        {"points.geom", "#version 450 core\nlayout(triangles) in;\nlayout(points, max_vertices = 3) out;\n" + body,
         "layout(points) out"},
        {"lines.geom", "#version 450 core\nlayout(triangles) in;\nlayout(line_strip, max_vertices = 3) out;\n" + body,
         "layout(line_strip) out"},
        {"lines_in.geom", "#version 450 core\nlayout(lines) in;\nlayout(triangle_strip, max_vertices = 3) out;\n" + body,
         "layout(triangles) in"},
        {"no_normal.geom",
         "#version 450 core\nlayout(triangles) in;\nlayout(triangle_strip, max_vertices = 3) out;\n"
         "layout(location = 0) in EvaluationData { vec3 worldPosition; vec2 texCoord; } evaluationIn[];\n"
         "layout(location = 1) out vec2 texCoord;\n"
         "void main() { for (int i = 0; i < 3; i++) { texCoord = evaluationIn[i].texCoord; gl_Position = gl_in[i].gl_Position; "
         "EmitVertex(); } }\n",
         "no output at location 0"},
    };
    for (const auto& c : cases) {
        write_file(path(c.name), c.text);
        for (const std::vector<std::string>& command :
             {std::vector<std::string>{"render", scene, "-o", path("out.png"), "--size", "64x40"},
              std::vector<std::string>{"mesh", scene, "-o", path("out.ply")}}) {
            std::vector<std::string> args = command;
            args.insert(args.end(), {"--shader", std::string("geom=") + path(c.name)});
            const RunResult r = run(args);
            EXPECT_EQ(r.status, 2) << c.name << r.out << r.err;
            EXPECT_NE(r.err.find(c.says), std::string::npos) << c.name << ": " << r.err;
            EXPECT_NE(r.err.find(c.name), std::string::npos) << r.err;
        }
        EXPECT_FALSE(fs::exists(path("out.png")));
        EXPECT_FALSE(fs::exists(path("out.ply")));
    }
    // Every triangle twice (48492) under a budget of 40000 that the generator's 24246 (estimated 31518) meet:
    // the budget counts what the geometry shader emits.
    std::string toml = read_file(scene_path("cosc422"));
    for (std::size_t at = 0; (at = toml.find("\"../", at)) != std::string::npos;)
        toml.replace(at, 4, "\"" + (kSource / "data").string() + "/");
    write_file(path("budget.toml"), toml + "\n[limits]\nmax_triangles = 40000\n");
    write_file(path("twice.geom"), "#version 450 core\nlayout(triangles) in;\nlayout(triangle_strip, max_vertices = 6) out;\n" +
                                       body.substr(0, body.find("void main()")) +
                                       "void main() { for (int k = 0; k < 2; k++) { for (int i = 0; i < 3; i++) { "
                                       "geometryOut.faceNormal = vec3(0.0, 1.0, 0.0); geometryOut.texCoord = vec2(0.0); "
                                       "gl_Position = gl_in[i].gl_Position; EmitVertex(); } EndPrimitive(); } }\n");
    ASSERT_EQ(run({"mesh", path("budget.toml"), "-o", path("out.ply")}).status, 0);
    fs::remove(path("out.ply"));
    const RunResult twice = run({"mesh", path("budget.toml"), "-o", path("out.ply"), "--shader", "geom=" + path("twice.geom")});
    EXPECT_EQ(twice.status, 2) << twice.err;
    EXPECT_NE(twice.err.find("limits.max_triangles = 40000"), std::string::npos) << twice.err;
    EXPECT_FALSE(fs::exists(path("out.ply")));
}

// `trace --stage geom`: the geometry shader of one primitive of a patch (its K-th triangle,
// as `gl --capture` lists them), fed by the evaluation shader at the triangle's three tess
// coords. In the llvmpipe mode its face normal is the one llvmpipe captured for that
// triangle, bit for bit (GeometryTwinsGiveLlvmpipesNormals); the lines include the twin's
// face_normal, the stores its normal.
TEST_F(UserShaderCommand, TraceOfTheGeometryStageGivesLlvmpipesNormal) {
    const std::string scene = scene_path("cosc422").string();
    ASSERT_EQ(run({"gl", scene, "-o", path("gl.png"), "--size", "160x100", "--capture", path("gl.txt")}).status, 0);
    const tessref::Capture capture = tessref::read_capture(path("gl.txt"));
    const std::uint32_t patch = 40, primitive = 7;
    std::vector<tessref::CapturedVertex> corners;
    for (const tessref::CapturedVertex& v : capture.vertices)
        if (v.patch_id == patch) corners.push_back(v);
    ASSERT_GE(corners.size(), 3u * (primitive + 1));
    const RunResult r = run({"trace", scene, "--patch", std::to_string(patch), "--stage", "geom", "--primitive",
                             std::to_string(primitive), "--math", "llvmpipe", "--json"});
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["stage"], "geometry");
    EXPECT_EQ(j["math"], "llvmpipe");
    EXPECT_EQ(j["primitive"], primitive);
    const auto& vertices = j["outputs"]["vertices"];
    ASSERT_EQ(vertices.size(), 3u) << r.out;
    EXPECT_EQ(j["outputs"]["primitives"], nlohmann::json::parse("[[0, 1, 2]]")) << r.out;
    for (std::size_t i = 0; i < 3; ++i) {
        const tessref::CapturedVertex& gl = corners[3 * primitive + i];
        const auto& n = vertices[i]["locations"]["0"];
        EXPECT_EQ(bits(n[0].get<double>()), std::bit_cast<std::uint32_t>(gl.normal.x)) << i << " " << r.out;
        EXPECT_EQ(bits(n[1].get<double>()), std::bit_cast<std::uint32_t>(gl.normal.y)) << i;
        EXPECT_EQ(bits(n[2].get<double>()), std::bit_cast<std::uint32_t>(gl.normal.z)) << i;
        // The evaluation's worldPosition as the geometry shader read it: llvmpipe's position.
        EXPECT_EQ(bits(j["inputs"][i]["locations"]["0"][0].get<double>()), std::bit_cast<std::uint32_t>(gl.position.x)) << i;
    }
    bool face_normal_line = false, normal_stored = false;
    for (const auto& line : j["lines"]) {
        face_normal_line = face_normal_line || line["source"].get<std::string>().find("normalize(cross") != std::string::npos;
        for (const auto& s : line["stores"]) normal_stored = normal_stored || s["name"] == "normal";
    }
    EXPECT_TRUE(face_normal_line) << r.out;
    EXPECT_TRUE(normal_stored) << r.out;

    const RunResult text = run({"trace", scene, "--patch", std::to_string(patch), "--stage", "geom", "--primitive",
                                std::to_string(primitive)});
    ASSERT_EQ(text.status, 0) << text.err;
    EXPECT_NE(text.out.find("exact math"), std::string::npos) << text.out;
    EXPECT_NE(text.out.find("primitive 7"), std::string::npos) << text.out;
    // The loop's EmitVertex() line once per vertex, as executed (three times).
    std::size_t emits = 0;
    for (std::size_t at = text.out.find("EmitVertex();"); at != std::string::npos; at = text.out.find("EmitVertex();", at + 1)) ++emits;
    EXPECT_EQ(emits, 3u) << text.out;
    // A primitive the patch does not have, a scene without a geometry stage: exit 2 naming the flag.
    const RunResult far = run({"trace", scene, "--patch", "0", "--stage", "geom", "--primitive", "100000"});
    EXPECT_EQ(far.status, 2);
    EXPECT_NE(far.err.find("--primitive"), std::string::npos) << far.err;
    const RunResult none = run({"trace", scene_path("lab4-canyon").string(), "--patch", "0", "--stage", "geom", "--primitive", "0"});
    EXPECT_EQ(none.status, 2);
    EXPECT_NE(none.err.find("geometry"), std::string::npos) << none.err;
}

// The fragment stage's quads against llvmpipe's: quad_derivatives.frag writes dFdx and
// dFdy of floor(x) * floor(y) of the window position; llvmpipe draws cosc422 with it, and
// the interpreter runs the same file on the quad of every drawn pixel (window rows paired
// from y = 0, the top row the higher y): every pixel's two derivatives are llvmpipe's.
TEST_F(UserShaderCommand, FragmentQuadDerivativesAreLlvmpipes) {
    const fs::path frag = kUserShaders / "quad_derivatives.frag";
    const int width = 64, height = 40;
    const RunResult gl = run({"gl", scene_path("cosc422").string(), "-o", path("gl.png"), "--size", "64x40", "--shader",
                              "frag=" + frag.string()});
    ASSERT_EQ(gl.status, 0) << gl.out << gl.err;
    const tessref::image::Image picture = tessref::image::read_image(path("gl.png"));
    ASSERT_EQ(picture.header.width, width);
    ASSERT_EQ(picture.header.height, height);
    tessref::shader::Source source;
    source.stage = tessref::ShaderStage::fragment;
    source.path = frag.string();
    source.text = read_file(frag);
    const tessref::shader::Executable shader(tessref::shader::Module::compile(source), {}, {});
    std::size_t drawn = 0, same = 0;
    std::string first;
    for (int row = 0; row < height; ++row) {
        for (int x = 0; x < width; ++x) {
            const std::uint8_t* pixel = &picture.u8[static_cast<std::size_t>((row * width + x) * picture.channels)];
            if (pixel[2] != 255) continue;  // not drawn
            ++drawn;
            const int y = height - 1 - row, x0 = x & ~1, y0 = y & ~1;
            // Lanes: top-left, top-right, bottom-left, bottom-right.
            std::array<tessref::shader::QuadFragment, 4> quad;
            const int at[4][2] = {{x0, y0 + 1}, {x0 + 1, y0 + 1}, {x0, y0}, {x0 + 1, y0}};
            int lane = 0;
            for (int l = 0; l < 4; ++l) {
                quad[static_cast<std::size_t>(l)].frag_coord =
                    glm::vec4(static_cast<float>(at[l][0]) + 0.5f, static_cast<float>(at[l][1]) + 0.5f, 0.5f, 1.0f);
                if (at[l][0] == x && at[l][1] == y) lane = l;
            }
            const auto results = shader.fragment(quad, true, 0);
            const glm::vec4 c = tessref::shader::as_vec4(results[static_cast<std::size_t>(lane)].outputs.at(0));
            const auto code = [](float v) { return static_cast<int>(std::lround(v * 255.0f)); };
            if (code(c.x) == pixel[0] && code(c.y) == pixel[1]) {
                ++same;
            } else if (first.empty()) {
                first = "pixel (" + std::to_string(x) + ", row " + std::to_string(row) + "): interpreter " +
                        std::to_string(code(c.x)) + ", " + std::to_string(code(c.y)) + " llvmpipe " +
                        std::to_string(pixel[0]) + ", " + std::to_string(pixel[1]);
            }
        }
    }
    EXPECT_GT(drawn, 500u);
    EXPECT_EQ(same, drawn) << first;
}
