// `tessref render --wireframe` against `tessref gl --wireframe` (glPolygonMode(GL_LINE) on
// Mesa llvmpipe), and the rasterizer's per-quad derivatives that make them agree.
//
// The defect: the fragment shader of a line derives dFdx/dFdy (and so the texture's mip
// level) from the LINE's interpolants: llvmpipe sets a line's attributes up along its major
// axis only (lp_setup_line.c, "the preferred wide-lines formula"), so across the line they
// are constant. render took the derivatives from the visible triangle's plane instead; in
// the far field the triangle's are much larger, the mip level higher and the colour another
// (thesis-all-10 at 320x200: 2230 pixels differed, 876 by more than one code, up to 103
// codes; thesis-map-4: 4463). Fill was right and stays as it was.
#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "run_program.h"
#include "tessref/raster.h"

namespace {

namespace fs = std::filesystem;
using tessref::test::run_program;
using tessref::test::RunResult;

// ---- the rasterizer: a line's quad derivatives are the line's -------------------------

struct LineCase {
    tessref::Framebuffer fb = tessref::Framebuffer::create(64, 48);
    // Vertices in NDC with w = 1 (affine: the weights are linear in window space). Edge
    // v0 -> v1 is x-major, v1 -> v2 and v2 -> v0 are y-major.
    std::vector<glm::vec4> positions{{-0.8f, -0.55f, 0.1f, 1.0f}, {0.7f, -0.4f, 0.2f, 1.0f}, {0.05f, 0.9f, 0.3f, 1.0f}};
    std::vector<std::array<std::uint32_t, 3>> triangles{{0, 1, 2}};

    void draw(tessref::PolygonMode mode) {
        tessref::RasterInput in;
        in.positions = positions;
        in.triangles = triangles;
        tessref::RasterSettings s;
        s.polygon_mode = mode;
        s.depth_func = tessref::DepthFunc::always;
        s.quad_derivatives = true;
        tessref::rasterize(fb, in, s);
    }
    // Window x, y (GL, y up) of vertex k at 64x48.
    glm::vec2 window(int k) const {
        return {(positions[k].x * 0.5f + 0.5f) * 64.0f, (positions[k].y * 0.5f + 0.5f) * 48.0f};
    }
};

TEST(WireframeQuadDerivatives, NotRecordedUnlessAsked) {
    tessref::Framebuffer fb = tessref::Framebuffer::create(8, 8);
    EXPECT_TRUE(fb.barycentric_dx.empty());
    EXPECT_TRUE(fb.barycentric_dy.empty());
}

TEST(WireframeQuadDerivatives, LinePixelsDifferAlongTheLineOnly) {
    LineCase c;
    c.draw(tessref::PolygonMode::line);
    const glm::vec2 a = c.window(0), b = c.window(1), t = c.window(2);
    int x_major_pixels = 0, y_major_pixels = 0;
    for (std::size_t i = 0; i < c.fb.depth.size(); ++i) {
        if (c.fb.triangle_id[i] == tessref::kNoTriangle) continue;
        const glm::vec3 w = c.fb.barycentric[i], dx = c.fb.barycentric_dx[i], dy = c.fb.barycentric_dy[i];
        if (w[2] == 0.0f) {
            // On edge v0 -> v1 (x-major): the line's interpolation does not change across
            // it, bit for bit, and along x the weight moves from v0 to v1 over the edge's
            // width in pixels; the third weight stays 0.
            ++x_major_pixels;
            EXPECT_EQ(dy, glm::vec3(0.0f)) << i;
            EXPECT_NEAR(dx[1], 1.0f / (b.x - a.x), 1e-5f) << i;
            EXPECT_NEAR(dx[0], -1.0f / (b.x - a.x), 1e-5f) << i;
            EXPECT_EQ(dx[2], 0.0f) << i;
        } else if (w[0] == 0.0f) {
            // Edge v1 -> v2 (y-major): constant in x; along y (up) from v1 to v2.
            ++y_major_pixels;
            EXPECT_EQ(dx, glm::vec3(0.0f)) << i;
            EXPECT_NEAR(dy[2], 1.0f / (t.y - b.y), 1e-5f) << i;
        }
    }
    EXPECT_GT(x_major_pixels, 30);
    EXPECT_GT(y_major_pixels, 20);
}

TEST(WireframeQuadDerivatives, FilledPixelsDifferAsTheTrianglesPlane) {
    // The same request in fill mode gives the triangle's plane: the analytic gradient of the
    // weights in window space (here per pixel, y up), the same in every pixel.
    LineCase c;
    c.draw(tessref::PolygonMode::fill);
    const glm::vec2 p0 = c.window(0), p1 = c.window(1), p2 = c.window(2);
    const float area = (p1.x - p0.x) * (p2.y - p0.y) - (p2.x - p0.x) * (p1.y - p0.y);
    // d(w0)/dx = (p1.y - p2.y) / area, d(w0)/dy = (p2.x - p1.x) / area, and so on.
    const glm::vec3 ddx((p1.y - p2.y) / area, (p2.y - p0.y) / area, (p0.y - p1.y) / area);
    const glm::vec3 ddy((p2.x - p1.x) / area, (p0.x - p2.x) / area, (p1.x - p0.x) / area);
    int covered = 0;
    for (std::size_t i = 0; i < c.fb.depth.size(); ++i) {
        if (c.fb.triangle_id[i] == tessref::kNoTriangle) continue;
        ++covered;
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(c.fb.barycentric_dx[i][k], ddx[k], 1e-5f) << i;
            EXPECT_NEAR(c.fb.barycentric_dy[i][k], ddy[k], 1e-5f) << i;
        }
    }
    EXPECT_GT(covered, 500);
}

// ---- end to end: render --wireframe against llvmpipe ---------------------------------

class WireframeAgainstLlvmpipe : public ::testing::TestWithParam<std::array<const char*, 2>> {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("tessref-test-wireframe-" + std::to_string(::getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }
    RunResult run(const std::vector<std::string>& args) { return run_program(TESSREF_EXE, args, dir_); }
    fs::path dir_;
};

// One 8-bit code passes (1/255 and a margin for code/255 in float), two do not: what the
// filled pictures of every shipped scene agree to (tests/test_gl_backend.cpp).
constexpr const char* kOneCode = "0.0040";

TEST_P(WireframeAgainstLlvmpipe, AgreesToOneCodeButForAFewLineEnds) {
    const std::string scene = std::string(TESSREF_SOURCE_DIR) + "/data/scenes/" + GetParam()[0] + ".toml";
    const std::string cpu = (dir_ / "cpu.png").string(), gl = (dir_ / "gl.png").string();
    const RunResult g = run({"gl", scene, "-o", gl, "--size", "320x200", "--wireframe"});
    ASSERT_EQ(g.status, 0) << g.out << g.err;
    const RunResult r = run({"render", scene, "-o", cpu, "--size", "320x200", "--wireframe"});
    ASSERT_EQ(r.status, 0) << r.err;
    const RunResult cmp =
        run({"compare", cpu, gl, "--threshold", kOneCode, "--max-failing-pixels", GetParam()[1]});
    EXPECT_EQ(cmp.status, 0) << cmp.out << cmp.err;
}

// Beyond one code, before the fix: 876 and 1020 pixels; after: thesis-all-10 1 pixel
// (312, 0), thesis-map-4 5, one of them (250, 156), a line end pixel that only render draws.
// What is left are single pixels where a line's end pixel, and so which line wins, follows
// an ulp of gl_Position (llvmpipe evaluates mvp * position in its own order: computing it
// with fused multiply-adds on the CPU side gets (250, 156) right). Allowed: twice that.
INSTANTIATE_TEST_SUITE_P(Textured, WireframeAgainstLlvmpipe,
                         ::testing::Values(std::array<const char*, 2>{"thesis-all-10", "2"},
                                           std::array<const char*, 2>{"thesis-map-4", "10"}),
                         [](const auto& info) {
                             std::string name = info.param[0];
                             for (char& ch : name)
                                 if (ch == '-') ch = '_';
                             return name;
                         });

}  // namespace
