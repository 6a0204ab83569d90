// The fragment execution model of the SPIR-V interpreter (tessref/shader.h,
// Executable::fragment): a 2x2 quad in lockstep, dFdx/dFdy/fwidth (and their Fine and Coarse
// forms) as llvmpipe computes them, helper invocations, discard, branches whose ways meet
// again, and texture()'s implicit lod from the quad's derivatives. Small GLSL fragment
// shaders with expected values derived by hand.
#include <gtest/gtest.h>

#include <array>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tessref/error.h"
#include "tessref/shader.h"
#include "tessref/texture.h"

namespace tessref::shader {
namespace {

constexpr const char* kPath = "snippet.frag";

// A fragment shader: input v (vec4, location 0), output o (vec4, location 0),
// `declarations`, main() { body }.
Module fragment_module(const std::string& body, const std::string& declarations = "") {
    Source s;
    s.stage = ShaderStage::fragment;
    s.path = kPath;
    s.text = "#version 450 core\n"
             "layout(location = 0) in vec4 v;\n"
             "layout(location = 0) out vec4 o;\n" +
             declarations + "\nvoid main()\n{\n" + body + "\n}\n";
    return Module::compile(s);
}

// The quad at window (10, 20) .. (11, 21): top-left (10.5, 21.5), top-right (11.5, 21.5),
// bottom-left (10.5, 20.5), bottom-right (11.5, 20.5) (the top row has the higher y); v of
// each fragment as given.
std::array<QuadFragment, 4> quad(const std::array<glm::vec4, 4>& v) {
    const glm::vec2 at[4] = {{10.5f, 21.5f}, {11.5f, 21.5f}, {10.5f, 20.5f}, {11.5f, 20.5f}};
    std::array<QuadFragment, 4> q;
    for (int l = 0; l < 4; ++l) {
        q[static_cast<std::size_t>(l)].frag_coord = glm::vec4(at[l], 0.25f, 1.0f);
        q[static_cast<std::size_t>(l)].inputs = {slot(v[static_cast<std::size_t>(l)])};
    }
    return q;
}

struct Shaded {
    std::array<FragmentResult, 4> results;
    std::vector<std::string> warnings;
    glm::vec4 o(int lane) const {
        const FragmentResult& r = results[static_cast<std::size_t>(lane)];
        return r.outputs.empty() ? glm::vec4(0.0f) : as_vec4(r.outputs[0]);
    }
};

Shaded run(const std::string& body, const std::array<QuadFragment, 4>& q, const Bindings& bindings = {},
        const std::string& declarations = "") {
    Shaded r;
    RunOptions options;
    options.warnings = &r.warnings;
    const Executable e(fragment_module(body, declarations), bindings, options);
    r.results = e.fragment(q, true, 3);
    return r;
}

// v.x: top-left 1, top-right 3.5, bottom-left 0.25, bottom-right 10.
const std::array<glm::vec4, 4> kValues = {glm::vec4(1.0f, 1.0f, 0.0f, 0.0f), glm::vec4(3.5f, 3.0f, 0.0f, 0.0f),
                                          glm::vec4(0.25f, 2.0f, 0.0f, 0.0f), glm::vec4(10.0f, 5.0f, 0.0f, 0.0f)};

TEST(ShaderFragment, DerivativesArePerRowAndPerColumnAsLlvmpipes) {
    // dFdx: the top row 3.5 - 1 = 2.5, the bottom row 10 - 0.25 = 9.75. dFdy (top minus
    // bottom): the left column 1 - 0.25 = 0.75, the right 3.5 - 10 = -6.5. fwidth = |dx| +
    // |dy|: 3.25, 9, 10.5, 16.25.
    const Shaded r = run("o = vec4(dFdx(v.x), dFdy(v.x), fwidth(v.x), 0.0);", quad(kValues));
    EXPECT_EQ(r.o(0), glm::vec4(2.5f, 0.75f, 3.25f, 0.0f));
    EXPECT_EQ(r.o(1), glm::vec4(2.5f, -6.5f, 9.0f, 0.0f));
    EXPECT_EQ(r.o(2), glm::vec4(9.75f, 0.75f, 10.5f, 0.0f));
    EXPECT_EQ(r.o(3), glm::vec4(9.75f, -6.5f, 16.25f, 0.0f));
    // The Fine and Coarse forms: llvmpipe computes all three alike.
    const Shaded fine = run("o = vec4(dFdxFine(v.x), dFdyFine(v.x), dFdxCoarse(v.x), dFdyCoarse(v.x));", quad(kValues));
    EXPECT_EQ(fine.o(3), glm::vec4(9.75f, -6.5f, 9.75f, -6.5f));
    EXPECT_EQ(fine.o(0), glm::vec4(2.5f, 0.75f, 2.5f, 0.75f));
    const Shaded widths = run("o = vec4(fwidthFine(v.x), fwidthCoarse(v.x), 0.0, 0.0);", quad(kValues));
    EXPECT_EQ(widths.o(1), glm::vec4(9.0f, 9.0f, 0.0f, 0.0f));
    // gl_FragCoord: one pixel per pixel, y growing upwards.
    const Shaded coord = run("o = vec4(dFdx(gl_FragCoord.xy), dFdy(gl_FragCoord.xy));", quad(kValues));
    for (int l = 0; l < 4; ++l) EXPECT_EQ(coord.o(l), glm::vec4(1.0f, 0.0f, 0.0f, 1.0f)) << l;
    EXPECT_TRUE(r.warnings.empty());
}

TEST(ShaderFragment, ADerivativeIsOneRoundedSubtraction) {
    // Top-right 2^24 + 2, top-left 0.5: 16777217.5 rounds (ties to even) to 16777218.
    std::array<glm::vec4, 4> v = kValues;
    v[1].x = 16777218.0f;
    v[0].x = 0.5f;
    EXPECT_EQ(run("o = vec4(dFdx(v.x));", quad(v)).o(0).x, 16777218.0f);
}

TEST(ShaderFragment, HelperInvocationsRunForTheDerivatives) {
    // The bottom-right fragment is not covered: it runs (gl_HelperInvocation true) and its
    // v still makes the bottom row's dFdx (9.75); its result is marked a helper's.
    std::array<QuadFragment, 4> q = quad(kValues);
    q[3].covered = false;
    const Shaded r = run("o = vec4(dFdx(v.x), float(gl_HelperInvocation), 0.0, 0.0);", q);
    EXPECT_EQ(r.o(2), glm::vec4(9.75f, 0.0f, 0.0f, 0.0f));
    EXPECT_EQ(r.o(3), glm::vec4(9.75f, 1.0f, 0.0f, 0.0f));
    EXPECT_TRUE(r.results[3].helper);
    EXPECT_FALSE(r.results[2].helper);
}

TEST(ShaderFragment, DiscardingFragmentsKeepTheQuadsDerivatives) {
    // v.x > 2: the top-right (3.5) and bottom-right (10) discard; as on llvmpipe they go on
    // masked, so dFdx after the discard is still the quad's: 2.5 and 9.75.
    const Shaded r = run("if (v.x > 2.0) discard;\no = vec4(dFdx(v.x), 1.0, 0.0, 0.0);", quad(kValues));
    EXPECT_FALSE(r.results[0].discarded);
    EXPECT_TRUE(r.results[1].discarded);
    EXPECT_FALSE(r.results[2].discarded);
    EXPECT_TRUE(r.results[3].discarded);
    EXPECT_EQ(r.o(0), glm::vec4(2.5f, 1.0f, 0.0f, 0.0f));
    EXPECT_EQ(r.o(2), glm::vec4(9.75f, 1.0f, 0.0f, 0.0f));
    EXPECT_TRUE(r.warnings.empty());
    // Every fragment discards: all four results say so.
    const Shaded all = run("if (v.x > 0.0) discard;\no = vec4(1.0);", quad(kValues));
    for (int l = 0; l < 4; ++l) EXPECT_TRUE(all.results[static_cast<std::size_t>(l)].discarded) << l;
}

TEST(ShaderFragment, TheWaysOfABranchMeetAgainForDerivatives) {
    // t = 2 v.x where v.x > 2, else v.x: 1, 7, 0.25, 20. After the if the quad is whole
    // again: dFdx 6 (top), 19.75 (bottom); dFdy 0.75 (left), -13 (right).
    const Shaded r = run("float t;\nif (v.x > 2.0) t = v.x * 2.0; else t = v.x;\no = vec4(dFdx(t), dFdy(t), t, 0.0);",
                      quad(kValues));
    EXPECT_EQ(r.o(0), glm::vec4(6.0f, 0.75f, 1.0f, 0.0f));
    EXPECT_EQ(r.o(1), glm::vec4(6.0f, -13.0f, 7.0f, 0.0f));
    EXPECT_EQ(r.o(2), glm::vec4(19.75f, 0.75f, 0.25f, 0.0f));
    EXPECT_EQ(r.o(3), glm::vec4(19.75f, -13.0f, 20.0f, 0.0f));
    EXPECT_TRUE(r.warnings.empty());
    // A loop the fragments leave after 1, 3, 2 and 5 iterations (v.y): s = 1, 3, 2, 5; after
    // it dFdx 2 (top), 3 (bottom), dFdy -1 (left), -2 (right).
    const Shaded loop = run("float s = 0.0;\nfor (int i = 0; i < int(v.y); i++) s += 1.0;\no = vec4(dFdx(s), dFdy(s), s, 0.0);",
                         quad(kValues));
    EXPECT_EQ(loop.o(0), glm::vec4(2.0f, -1.0f, 1.0f, 0.0f));
    EXPECT_EQ(loop.o(3), glm::vec4(3.0f, -2.0f, 5.0f, 0.0f));
    EXPECT_TRUE(loop.warnings.empty());
}

TEST(ShaderFragment, ALoopLeftByBreakMeetsAgainAfterIt) {
    // The fragments break out of the loop at i = v.y: after 1, 3, 2 and 5 iterations, so
    // s = 1, 3, 2, 5. The lanes that break wait at the loop's end for the others (as
    // llvmpipe's masked lanes do), so after it the quad is whole: dFdx 3 - 1 = 2 (top),
    // 5 - 2 = 3 (bottom); dFdy (top minus bottom) 1 - 2 = -1 (left), 3 - 5 = -2 (right).
    const Shaded r = run("float s = 0.0;\nfor (int i = 0; i < 10; i++) {\n    if (float(i) >= v.y) break;\n    s += 1.0;\n}\n"
                         "o = vec4(dFdx(s), dFdy(s), s, 0.0);",
                         quad(kValues));
    EXPECT_EQ(r.o(0), glm::vec4(2.0f, -1.0f, 1.0f, 0.0f));
    EXPECT_EQ(r.o(1), glm::vec4(2.0f, -2.0f, 3.0f, 0.0f));
    EXPECT_EQ(r.o(2), glm::vec4(3.0f, -1.0f, 2.0f, 0.0f));
    EXPECT_EQ(r.o(3), glm::vec4(3.0f, -2.0f, 5.0f, 0.0f));
    EXPECT_TRUE(r.warnings.empty()) << (r.warnings.empty() ? "" : r.warnings[0]);
}

TEST(ShaderFragment, ADerivativeInsideAPartedBranchIsZeroWithAWarning) {
    // Inside the if only the right column runs: no quad, no derivative (undefined in GLSL).
    const Shaded r = run("o = vec4(5.0);\nif (v.x > 2.0) o.x = dFdx(v.x);", quad(kValues));
    EXPECT_EQ(r.o(1).x, 0.0f);
    EXPECT_EQ(r.o(0).x, 5.0f);
    ASSERT_EQ(r.warnings.size(), 1u);
    EXPECT_NE(r.warnings[0].find("OpDPdx"), std::string::npos) << r.warnings[0];
    EXPECT_NE(r.warnings[0].find("snippet.frag:8"), std::string::npos) << r.warnings[0];
}

// A 4x4 one-channel checkerboard of 0 and 1 (texel (x, y) is (x + y) % 2): its level 1
// averages each 2x2 block to 0.5.
Texture checkerboard() {
    std::vector<float> texels(16);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) texels[static_cast<std::size_t>(y * 4 + x)] = static_cast<float>((x + y) % 2);
    return Texture::from_float(4, 4, 1, texels);
}

TEST(ShaderFragment, ImplicitLodComesFromTheQuadsDerivatives) {
    // A 4x4 checkerboard (0 and 1): level 1 averages every 2x2 block, 0.5 everywhere. With
    // texture coordinates half a texture apart across the quad (dPdx = (0.5, 0), dPdy =
    // (0, 0.5) in magnitude: rho = 4 * 0.5 = 2 texels per pixel) the lod is log2 2 = 1:
    // every fragment reads 0.5. With the same coordinate at every fragment (derivatives 0:
    // magnification) each reads level 0 at a texel's centre: 1 at texel (1, 0).
    const Texture checker = checkerboard();
    Bindings b;
    b.bind_texture(0, &checker);
    const std::string declarations = "layout(binding = 0) uniform sampler2D map;";
    const std::array<glm::vec4, 4> spread = {glm::vec4(0.375f, 0.125f, 0, 0), glm::vec4(0.875f, 0.125f, 0, 0),
                                             glm::vec4(0.375f, 0.625f, 0, 0), glm::vec4(0.875f, 0.625f, 0, 0)};
    const Shaded minified = run("o = texture(map, v.xy);", quad(spread), b, declarations);
    for (int l = 0; l < 4; ++l) EXPECT_EQ(minified.o(l).x, 0.5f) << l;
    const std::array<glm::vec4, 4> same = {spread[0], spread[0], spread[0], spread[0]};
    const Shaded magnified = run("o = texture(map, v.xy);", quad(same), b, declarations);
    for (int l = 0; l < 4; ++l) EXPECT_EQ(magnified.o(l).x, 1.0f) << l;
    EXPECT_TRUE(minified.warnings.empty());
}

TEST(ShaderFragment, FrontFacingPrimitiveIdAndDepth) {
    const Shaded r = run("o = vec4(float(gl_FrontFacing), float(gl_PrimitiveID), gl_FragCoord.z, 0.0);\n"
                      "gl_FragDepth = gl_FragCoord.z * 2.0;",
                      quad(kValues));
    EXPECT_EQ(r.o(2), glm::vec4(1.0f, 3.0f, 0.25f, 0.0f));
    EXPECT_TRUE(r.results[2].depth_written);
    EXPECT_EQ(r.results[2].depth, 0.5f);
}

TEST(ShaderFragment, OtherStagesRunNoFragments) {
    Source s;
    s.stage = ShaderStage::vertex;
    s.path = "x.vert";
    s.text = "#version 450 core\nvoid main() { gl_Position = vec4(1.0); }\n";
    const Executable e(Module::compile(s), {}, {});
    EXPECT_THROW(e.fragment(quad(kValues), true, 0), Error);
}

TEST(ShaderFragment, UnsupportedImageOperandsAndEndlessQuadsAreErrors) {
    // texture() with a bias: an image operand the interpreter does not run, named with its line.
    try {
        run("o = texture(map, v.xy, 1.0);", quad(kValues), {}, "layout(binding = 0) uniform sampler2D map;");
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("bias"), std::string::npos) << e.what();
        EXPECT_EQ(e.where().file, kPath);
        EXPECT_EQ(e.where().line, 7) << e.message();
    }
    // A loop that never ends stops at the budget, naming the fragment's quad.
    RunOptions options;
    options.max_instructions = 5000;
    const Executable e(fragment_module("float s = 0.0;\nwhile (v.x > 0.0) s += 1.0;\no = vec4(s);"), {}, options);
    try {
        e.fragment(quad(kValues), true, 9);
        FAIL() << "no error";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("fragment shader snippet.frag, primitive 9"), std::string::npos)
            << error.what();
    }
}

// Every shipped fragment and geometry twin loads and runs (a quad, a triangle) without an
// opcode, capability or built-in the interpreter does not run: uniforms at their defaults,
// samplers without a texture (reading (0, 0, 0, 1)), inputs zero but for gl_FragCoord.
TEST(ShaderFragment, EveryShippedFragmentAndGeometryTwinRuns) {
    const std::string dir = std::string(TESSREF_DATA_DIR) + "/shaders/";
    const std::pair<const char*, ShaderStage> twins[] = {
        {"thesis_terrain.frag", ShaderStage::fragment},        {"thesis_terrain_single.frag", ShaderStage::fragment},
        {"cosc422_terrain.frag", ShaderStage::fragment},       {"lab4_terrain.frag", ShaderStage::fragment},
        {"pn_triangles.frag", ShaderStage::fragment},          {"geomip_terrain.frag", ShaderStage::fragment},
        {"pom.frag", ShaderStage::fragment},                   {"thesis_terrain.geom", ShaderStage::geometry},
        {"cosc422_terrain.geom", ShaderStage::geometry},
    };
    for (const auto& [file, stage] : twins) {
        Source s;
        s.stage = stage;
        s.path = dir + file;
        std::ifstream in(s.path);
        std::ostringstream text;
        text << in.rdbuf();
        s.text = text.str();
        ASSERT_FALSE(s.text.empty()) << s.path;
        try {
            const Executable e(Module::compile(s), {}, {});
            if (stage == ShaderStage::fragment) {
                const std::array<FragmentResult, 4> r = e.fragment(quad(kValues), true, 0);
                EXPECT_FALSE(r[0].outputs.empty()) << file;
            } else {
                const std::vector<ShaderVertex> triangle(3);
                EXPECT_EQ(e.geometry(triangle, 0).primitive_count(), 1u) << file;
            }
        } catch (const Error& error) {
            ADD_FAILURE() << file << ": " << error.what();
        }
    }
}

TEST(ShaderFragment, TextureGradTakesTheGivenGradients) {
    // The checkerboard of ImplicitLodComesFromTheQuadsDerivatives: gradients (0.5, 0) and
    // (0, 0.5) give lod 1 (0.5 everywhere), gradients zero lod -inf (level 0: 1 at texel
    // (1, 0)), whatever the quad's own derivatives (here none: every fragment at one place).
    const Texture checker = checkerboard();
    Bindings b;
    b.bind_texture(0, &checker);
    const std::string declarations = "layout(binding = 0) uniform sampler2D map;";
    const glm::vec4 at(0.375f, 0.125f, 0.0f, 0.0f);
    const Shaded half = run("o = textureGrad(map, v.xy, vec2(0.5, 0.0), vec2(0.0, 0.5));", quad({at, at, at, at}), b, declarations);
    for (int l = 0; l < 4; ++l) EXPECT_EQ(half.o(l).x, 0.5f) << l;
    const Shaded zero = run("o = textureGrad(map, v.xy, vec2(0.0), vec2(0.0));", quad({at, at, at, at}), b, declarations);
    for (int l = 0; l < 4; ++l) EXPECT_EQ(zero.o(l).x, 1.0f) << l;
}

}  // namespace
}  // namespace tessref::shader
