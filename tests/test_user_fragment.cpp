// `render` with a user's fragment shader (src/render/user_fragment.cpp): the shader runs on
// the CPU's SPIR-V interpreter, its inputs interpolated as llvmpipe interpolates them, and
// its picture is llvmpipe's (`tessref gl` with the same file) pixel for pixel, every
// difference counted and explained.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "command_dir_test.h"
#include "image/image_io.h"
#include "pipeline/raster_stage.h"
#include "run_program.h"
#include "tessref/error.h"
#include "tessref/prepare.h"
#include "tessref/render.h"
#include "tessref/scene.h"

namespace {

namespace fs = std::filesystem;
using tessref::test::RunResult;

const fs::path kSource = TESSREF_SOURCE_DIR;
const fs::path kUserShaders = kSource / "tests" / "data" / "gl";

fs::path scene_path(const std::string& name) { return kSource / "data" / "scenes" / (name + ".toml"); }

// The scene with `file` as its fragment shader (as --shader frag=FILE gives it) and the
// image size `size`.
tessref::Scene with_fragment(const std::string& scene, const fs::path& file, glm::ivec2 size) {
    tessref::Scene s = tessref::load_scene(scene_path(scene).string());
    s.shaders.push_back(tessref::StageShader{tessref::ShaderStage::fragment, file.string(), "--shader frag=" + file.string(),
                                             tessref::Where::in_file("--shader")});
    s.camera->viewport = size;
    return s;
}

tessref::RenderOptions llvmpipe_math() {
    tessref::RenderOptions o;
    o.math = tessref::MathMode::llvmpipe;
    return o;
}

// The red shader paints every covered pixel red and leaves the others the background: the
// render ran the user's shader, not the scene's shading model (cosc422's grey light).
TEST(UserFragment, TheUsersShaderPaintsTheCoveredPixels) {
    const tessref::Scene scene = with_fragment("cosc422", kUserShaders / "red.frag", {128, 80});
    const tessref::RenderResult r = tessref::render_scene(scene);
    std::size_t covered = 0;
    for (std::size_t i = 0; i < r.colour.size(); ++i) {
        if (r.triangle_id[i] == tessref::kNoPixelId) {
            EXPECT_EQ(r.colour[i], scene.shading.background) << i;
            continue;
        }
        ++covered;
        EXPECT_EQ(r.colour[i], glm::vec4(1.0f, 0.0f, 0.0f, 1.0f)) << i;
    }
    EXPECT_GT(covered, 5000u);
    EXPECT_LT(covered, r.colour.size());
}

// The twin's own file keeps the built-in model (the fast path); the same text with a
// comment added runs on the interpreter and gives the model's picture, in llvmpipe math,
// but for the model's own rounding: the model (shading.h) normalizes and lights in its own
// order of operations, so its unquantized colours differ in about one pixel in six and, at
// 160x100, one 8-bit code by one step (pixel 107, row 90: 157 for the model, 156 for the
// interpreter and for llvmpipe, UserFragmentCommand.TheTwinsCopyIsLlvmpipesPicture).
TEST(UserFragment, TheTwinsTextThroughTheInterpreterIsTheModelsPicture) {
    tessref::Scene twin = with_fragment("cosc422", kSource / "data" / "shaders" / "cosc422_terrain.frag", {160, 100});
    EXPECT_EQ(tessref::user_fragment_shader(twin), nullptr);
    const tessref::Scene model = with_fragment("cosc422", kUserShaders / "red.frag", {160, 100});
    ASSERT_NE(tessref::user_fragment_shader(model), nullptr);

    const tessref::RenderResult built_in = tessref::render_scene(twin, llvmpipe_math());
    const fs::path copy = fs::temp_directory_path() / ("tessref_user_fragment_" + std::to_string(::getpid()) + ".frag");
    tessref::test::write_file(copy, tessref::test::read_file(kSource / "data" / "shaders" / "cosc422_terrain.frag") +
                                        "// a user's copy\n");
    const tessref::Scene user = with_fragment("cosc422", copy, {160, 100});
    const tessref::RenderResult interpreted = tessref::render_scene(user, llvmpipe_math());
    fs::remove(copy);
    ASSERT_EQ(built_in.colour.size(), interpreted.colour.size());
    const std::vector<std::uint8_t> a = tessref::to_rgba8(built_in), b = tessref::to_rgba8(interpreted);
    std::size_t covered = 0, differ = 0;
    for (std::size_t i = 0; i < built_in.colour.size(); ++i) {
        EXPECT_EQ(built_in.triangle_id[i], interpreted.triangle_id[i]) << i;
        covered += built_in.triangle_id[i] != tessref::kNoPixelId;
        bool same = true;
        for (std::size_t k = 0; k < 4; ++k) {
            EXPECT_LE(std::abs(int(a[4 * i + k]) - int(b[4 * i + k])), 1) << i;
            same = same && a[4 * i + k] == b[4 * i + k];
        }
        differ += !same;
    }
    EXPECT_GT(covered, 8000u);
    EXPECT_LE(differ, 1u);
}

// What the CPU does not run is refused, naming the shader's flag.
TEST(UserFragment, ExactPrecisionAndWireframeAreRefused) {
    const tessref::Scene scene = with_fragment("cosc422", kUserShaders / "red.frag", {64, 40});
    tessref::RenderOptions exact;
    exact.precision = tessref::Precision::exact;
    EXPECT_THROW(tessref::render_scene(scene, exact), tessref::Error);
    tessref::RenderOptions lines;
    lines.mode = tessref::RenderMode::wireframe;
    EXPECT_THROW(tessref::render_scene(scene, lines), tessref::Error);
}

class UserFragmentCommand : public tessref::test::CommandDirTest {
protected:
    struct Comparison {
        std::size_t pixels = 0, covered = 0, differ = 0, differ_unclipped = 0;
        int max_step = 0;  // largest difference of a channel, in 8-bit steps
        std::string first;
    };

    // `render` and `gl` of cosc422 with `frag` at `size`: the pictures compared pixel by
    // pixel, each difference classed by the winning triangle: cut by the clipper (a corner
    // outside -w <= x, y, z <= w, which llvmpipe sets up as the clipped polygon's fan with
    // new vertices, render as the whole triangle) or not.
    Comparison compare(const fs::path& frag, glm::ivec2 size) {
        const std::string s = std::to_string(size.x) + "x" + std::to_string(size.y);
        const RunResult gl = run({"gl", scene_path("cosc422").string(), "-o", path("gl.png"), "--size", s, "--shader",
                                  "frag=" + frag.string()});
        EXPECT_EQ(gl.status, 0) << gl.out << gl.err;
        const RunResult cpu = run({"render", scene_path("cosc422").string(), "-o", path("cpu.png"), "--size", s,
                                   "--math", "llvmpipe", "--shader", "frag=" + frag.string()});
        EXPECT_EQ(cpu.status, 0) << cpu.out << cpu.err;
        const tessref::image::Image a = tessref::image::read_image(path("gl.png"));
        const tessref::image::Image b = tessref::image::read_image(path("cpu.png"));
        // The same picture from the library, for each pixel's triangle.
        const tessref::Scene scene = with_fragment("cosc422", frag, size);
        const tessref::RenderResult r = tessref::render_scene(scene, llvmpipe_math());
        Comparison c;
        if (!r.pipeline || r.pipeline->mesh.triangles.empty()) {
            ADD_FAILURE() << "the render kept no surface: it did not run the user's fragment shader";
            return c;
        }
        const auto corners = tessref::pipeline::raster_stage_corners(scene, r.pipeline->mesh, tessref::MathMode::llvmpipe);
        const auto clipped = [&](std::uint32_t t) {
            for (int k = 0; k < 3; ++k) {
                const glm::vec4 p = corners.corners[3 * static_cast<std::size_t>(t) + static_cast<std::size_t>(k)].position;
                if (std::abs(p.x) > p.w || std::abs(p.y) > p.w || std::abs(p.z) > p.w) return true;
            }
            return false;
        };
        EXPECT_EQ(a.header.width, size.x);
        EXPECT_EQ(b.header.width, size.x);
        c.pixels = static_cast<std::size_t>(size.x) * static_cast<std::size_t>(size.y);
        for (std::size_t i = 0; i < c.pixels; ++i) {
            const std::uint8_t* p = &a.u8[i * static_cast<std::size_t>(a.channels)];
            const std::uint8_t* q = &b.u8[i * static_cast<std::size_t>(b.channels)];
            c.covered += r.triangle_id[i] != tessref::kNoPixelId;
            int step = 0;
            for (int k = 0; k < 3; ++k) step = std::max(step, std::abs(int(p[k]) - int(q[k])));
            if (step == 0) continue;
            ++c.differ;
            c.max_step = std::max(c.max_step, step);
            const bool cut = r.triangle_id[i] != tessref::kNoPixelId && clipped(r.triangle_id[i]);
            if (!cut) {
                ++c.differ_unclipped;
                if (c.first.empty())
                    c.first = "pixel " + std::to_string(i % static_cast<std::size_t>(size.x)) + ", row " +
                              std::to_string(i / static_cast<std::size_t>(size.x)) + ": llvmpipe " + std::to_string(p[0]) +
                              " " + std::to_string(p[1]) + " " + std::to_string(p[2]) + ", render " + std::to_string(q[0]) +
                              " " + std::to_string(q[1]) + " " + std::to_string(q[2]);
            }
        }
        std::cout << frag.filename().string() << " at " << s << ": " << c.differ << " of " << c.covered
                  << " covered pixels differ from llvmpipe's (" << c.differ_unclipped
                  << " on unclipped triangles), by at most " << c.max_step << " 8-bit steps\n";
        return c;
    }
};

// The twin's text with a comment added, through the interpreter: llvmpipe's picture on
// every pixel, clipped triangles included.
TEST_F(UserFragmentCommand, TheTwinsCopyIsLlvmpipesPicture) {
    const fs::path copy = path("cosc422_copy.frag");
    tessref::test::write_file(copy, tessref::test::read_file(kSource / "data" / "shaders" / "cosc422_terrain.frag") +
                                        "// a user's copy\n");
    const Comparison c = compare(copy, {160, 100});
    EXPECT_GT(c.covered, 8000u);
    EXPECT_EQ(c.differ, 0u) << c.first;
}

// fract(texCoord * 65536): an ulp of an interpolated input is about one 8-bit step, so every
// pixel whose triangle llvmpipe sets up whole is interpolated to the bit.
TEST_F(UserFragmentCommand, InterpolatedInputsAreLlvmpipesToTheBit) {
    const Comparison c = compare(kUserShaders / "interpolation_bits.frag", {320, 200});
    EXPECT_GT(c.covered, 30000u);
    EXPECT_EQ(c.differ_unclipped, 0u) << c.first;
    // The clipped triangles along the image's edges: bounded.
    EXPECT_LT(c.differ, c.covered / 20) << c.differ;
}

// dFdx, dFdy and fwidth: the quad's differences of llvmpipe's interpolation.
TEST_F(UserFragmentCommand, DerivativesAreLlvmpipes) {
    const Comparison c = compare(kUserShaders / "derivatives.frag", {320, 200});
    EXPECT_GT(c.covered, 30000u);
    EXPECT_EQ(c.differ_unclipped, 0u) << c.first;
    EXPECT_LT(c.differ, c.covered / 20) << c.differ;
}

// texture() with its implicit lod over a mirrored, minified height map: the same texels and
// filter weights as llvmpipe's sampler on every pixel.
TEST_F(UserFragmentCommand, ImplicitLodTexturingIsLlvmpipes) {
    const Comparison c = compare(kUserShaders / "texture_lod.frag", {320, 200});
    EXPECT_GT(c.covered, 30000u);
    EXPECT_EQ(c.differ_unclipped, 0u) << c.first;
    EXPECT_LT(c.differ, c.covered / 20) << c.differ;
}

// discard: the pixel shows what GL's depth test keeps of the other fragments there (the
// terrain behind a discarded hillside), or the background.
TEST_F(UserFragmentCommand, DiscardShowsWhatIsBehind) {
    const Comparison c = compare(kUserShaders / "discard.frag", {320, 200});
    EXPECT_GT(c.covered, 20000u);
    EXPECT_EQ(c.differ_unclipped, 0u) << c.first;
    EXPECT_LT(c.differ, c.covered / 20) << c.differ;
    // Some discarded pixels show a triangle behind the one that was in front: the red
    // shader (no discard) has another triangle there.
    const tessref::Scene red = with_fragment("cosc422", kUserShaders / "red.frag", {320, 200});
    const tessref::Scene discard = with_fragment("cosc422", kUserShaders / "discard.frag", {320, 200});
    const tessref::RenderResult a = tessref::render_scene(red, llvmpipe_math());
    const tessref::RenderResult b = tessref::render_scene(discard, llvmpipe_math());
    std::size_t behind = 0, background = 0;
    for (std::size_t i = 0; i < a.triangle_id.size(); ++i) {
        if (a.triangle_id[i] == b.triangle_id[i]) continue;
        if (b.triangle_id[i] == tessref::kNoPixelId) ++background;
        else ++behind;
    }
    EXPECT_GT(behind, 20u);
    EXPECT_GT(background + behind, 1000u);
}

}  // namespace

namespace {

// `trace --stage frag --pixel X,Y`: quad_derivatives.frag's v = floor(x) * floor(y) of the
// window position, so at image pixel (X, Y) of a 64x40 image (window y = 39 - Y) the traced
// fragment stores v = X * (39 - Y), and its quad's dFdx (along its row) is the row's window
// y and dFdy (top minus bottom of its column) the column's x: the output is
// (mod(39 - Y, 256) / 255, mod(X, 256) / 255, 1, 1).
TEST_F(UserFragmentCommand, TraceOfAPixelGivesTheHandDerivedValues) {
    const fs::path frag = kUserShaders / "quad_derivatives.frag";
    const int x = 33, y = 30, wy = 39 - y;
    const RunResult r = run({"trace", scene_path("cosc422").string(), "--stage", "frag", "--pixel",
                             std::to_string(x) + "," + std::to_string(y), "--size", "64x40", "--math", "llvmpipe",
                             "--shader", "frag=" + frag.string(), "--json"});
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["math"], "llvmpipe");
    EXPECT_EQ(j["stage"], "fragment");
    EXPECT_EQ(j["pixel"], nlohmann::json::array({x, y}));
    EXPECT_EQ(j["quad_lane"], (x & 1) + 2 * (y & 1));
    EXPECT_EQ(j["inputs"]["gl_FragCoord"][0], x + 0.5);
    EXPECT_EQ(j["inputs"]["gl_FragCoord"][1], wy + 0.5);
    bool stored = false;
    for (const auto& line : j["lines"])
        for (const auto& s : line["stores"])
            if (s["name"] == "v") {
                stored = true;
                EXPECT_EQ(s["values"][0], static_cast<double>(x * wy));
                EXPECT_EQ(line["line"], 10);
            }
    EXPECT_TRUE(stored) << r.out;
    const auto& colour = j["outputs"]["locations"]["0"];
    EXPECT_EQ(colour[0].get<float>(), static_cast<float>(wy % 256) / 255.0f);
    EXPECT_EQ(colour[1].get<float>(), static_cast<float>(x % 256) / 255.0f);
    EXPECT_EQ(colour[2].get<float>(), 1.0f);
    EXPECT_FALSE(j["outputs"]["discarded"].get<bool>());

    // The text form names the math mode and lists the line with its value.
    const RunResult text = run({"trace", scene_path("cosc422").string(), "--stage", "frag", "--pixel",
                                std::to_string(x) + "," + std::to_string(y), "--size", "64x40", "--shader",
                                "frag=" + frag.string()});
    ASSERT_EQ(text.status, 0) << text.err;
    EXPECT_NE(text.out.find("exact math"), std::string::npos) << text.out;
    EXPECT_NE(text.out.find("v = " + std::to_string(x * wy)), std::string::npos) << text.out;
}

// A pixel no fragment covers (the sky at the top left) and one outside the image: exit 2
// naming the pixel.
TEST_F(UserFragmentCommand, TraceOfAnUncoveredPixelNamesIt) {
    const RunResult sky = run({"trace", scene_path("cosc422").string(), "--stage", "frag", "--pixel", "0,0", "--size",
                               "64x40", "--shader", "frag=" + (kUserShaders / "red.frag").string()});
    EXPECT_EQ(sky.status, 2);
    EXPECT_NE(sky.err.find("no fragment covers pixel 0,0"), std::string::npos) << sky.err;
    const RunResult outside = run({"trace", scene_path("cosc422").string(), "--stage", "frag", "--pixel", "64,3",
                                   "--size", "64x40", "--shader", "frag=" + (kUserShaders / "red.frag").string()});
    EXPECT_EQ(outside.status, 2);
    EXPECT_NE(outside.err.find("pixel 64,3 is outside the 64x40 image"), std::string::npos) << outside.err;
}

}  // namespace
