// The SIMD variants (src/common/simd.h): every loop with an AVX2 variant must give the
// baseline's bits. Each test runs the same work at every level this CPU runs and compares
// the bytes; on a CPU without AVX2 and FMA there is one level and nothing to compare.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "common/simd.h"
#include "render_compare.h"
#include "tessref/error.h"
#include "tessref/prepare.h"
#include "tessref/render.h"
#include "tessref/scene.h"
#include "tessref/texture.h"

namespace fs = std::filesystem;

namespace {

// Restores the level a test found.
class SimdLevels : public ::testing::Test {
protected:
    void SetUp() override {
        if (tessref::cpu_simd_level() != tessref::SimdLevel::avx2)
            GTEST_SKIP() << "this CPU runs the baseline (SSE2) variants only";
    }
    void TearDown() override { tessref::set_simd_level(saved_); }
    tessref::SimdLevel saved_ = tessref::simd_level();
};

template <typename F>
auto at_level(tessref::SimdLevel level, F&& f) {
    tessref::set_simd_level(level);
    return f();
}

}  // namespace

TEST(Simd, LevelNamesAndTheCpu) {
    EXPECT_EQ(tessref::parse_simd_level("sse2"), tessref::SimdLevel::sse2);
    EXPECT_EQ(tessref::parse_simd_level("avx2"), tessref::SimdLevel::avx2);
    EXPECT_FALSE(tessref::parse_simd_level("avx512"));
    EXPECT_FALSE(tessref::parse_simd_level(""));
    const tessref::SimdLevel saved = tessref::simd_level();
    EXPECT_LE(saved, tessref::cpu_simd_level());
    tessref::set_simd_level(tessref::SimdLevel::sse2);  // every x86-64 CPU runs the baseline
    EXPECT_EQ(tessref::simd_level(), tessref::SimdLevel::sse2);
    if (tessref::cpu_simd_level() == tessref::SimdLevel::sse2)
        EXPECT_THROW(tessref::set_simd_level(tessref::SimdLevel::avx2), tessref::Error);
    tessref::set_simd_level(saved);
}

// The one-channel float filter (a height map's reads): random coordinates in and around
// [0, 1], texel centres and edges, huge, infinite and NaN ones, in runs of 1 to 19 points
// (the eight-point variant's tails), on levels of several shapes. Each sample must be the
// baseline's and the one-point textureLod's, bit for bit, and the red-channel batch
// (texture_red) its r at both levels.
TEST_F(SimdLevels, FloatTextureSamplesAreTheBaselines) {
    std::mt19937 rng(30);
    std::uniform_real_distribution<float> value(-100.0f, 100.0f), coordinate(-0.25f, 1.25f);
    for (const auto [w, h] : {std::pair{1, 1}, {2, 2}, {7, 3}, {64, 64}, {257, 129}}) {
        std::vector<float> texels(static_cast<std::size_t>(w) * h);
        for (float& t : texels) t = value(rng);
        const tessref::Texture tex = tessref::Texture::from_float(w, h, 1, texels);
        std::vector<glm::vec2> st;
        for (int k = 0; k < 4000; ++k) st.emplace_back(coordinate(rng), coordinate(rng));
        for (int x = -1; x <= w + 1; ++x)  // texel centres and edges along s, then t
            for (const float f : {0.0f, 0.5f}) {
                const float s = (static_cast<float>(x) + f) / static_cast<float>(w);
                st.emplace_back(s, coordinate(rng));
                st.emplace_back(coordinate(rng), (static_cast<float>(x) + f) / static_cast<float>(h));
            }
        const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
        for (const float odd : {inf, -inf, nan, 1e30f, -1e30f, 0.0f, -0.0f, 1.0f})
            st.insert(st.end(), {{odd, 0.5f}, {0.5f, odd}, {odd, odd}});
        for (std::size_t first = 0, run = 1; first < st.size(); first += run, run = run % 19 + 1) {
            const std::size_t n = std::min(run, st.size() - first);
            const std::span<const glm::vec2> in(st.data() + first, n);
            const auto sample = [&] {
                std::vector<glm::vec4> out(n);
                tex.texture(in, out);
                return out;
            };
            const auto sample_red = [&] {
                std::vector<float> red(n);
                tex.texture_red(in, red);
                return red;
            };
            const std::vector<glm::vec4> base = at_level(tessref::SimdLevel::sse2, sample);
            const std::vector<glm::vec4> wide = at_level(tessref::SimdLevel::avx2, sample);
            const std::vector<float> base_red = at_level(tessref::SimdLevel::sse2, sample_red);
            const std::vector<float> wide_red = at_level(tessref::SimdLevel::avx2, sample_red);
            for (std::size_t k = 0; k < n; ++k) {
                const glm::vec4 one = tex.textureLod(in[k], 0.0f);
                ASSERT_EQ(std::memcmp(&base_red[k], &base[k].r, sizeof(float)), 0) << k;
                ASSERT_EQ(std::memcmp(&wide_red[k], &base[k].r, sizeof(float)), 0) << k;
                ASSERT_EQ(std::memcmp(&wide[k], &base[k], sizeof(glm::vec4)), 0)
                    << w << "x" << h << " st (" << in[k].x << ", " << in[k].y << "): " << wide[k].r << " against "
                    << base[k].r;
                ASSERT_EQ(std::memcmp(&base[k], &one, sizeof(glm::vec4)), 0)
                    << w << "x" << h << " st (" << in[k].x << ", " << in[k].y << "): " << base[k].r << " against "
                    << one.r;
            }
        }
    }
}

// Every shipped scene with a camera, at its own size, and the bench terrain at level 16
// (1280x800): each render's buffers at every level, byte for byte.
TEST_F(SimdLevels, ShippedScenesRenderTheSameBytes) {
    std::vector<fs::path> scenes;
    for (const auto& e : fs::directory_iterator(fs::path(TESSREF_SOURCE_DIR) / "data" / "scenes"))
        if (e.path().extension() == ".toml") scenes.push_back(e.path());
    std::sort(scenes.begin(), scenes.end());
    scenes.push_back(fs::path(TESSREF_SOURCE_DIR) / "bench" / "scenes" / "jacksboro-grid-16.toml");
    std::size_t compared = 0;
    for (const fs::path& path : scenes) {
        SCOPED_TRACE(path.filename().string());
        const tessref::Scene scene = tessref::load_scene(path.string());
        if (!scene.camera) continue;
        tessref::RenderOptions options;
        options.provenance = true;
        const auto render = [&] { return tessref::render_scene(scene, options); };
        const tessref::RenderResult base = at_level(tessref::SimdLevel::sse2, render);
        const tessref::RenderResult wide = at_level(tessref::SimdLevel::avx2, render);
        expect_identical_renders(wide, base);
        EXPECT_GT(base.stats.covered_pixels, 0u);
        ++compared;
    }
    EXPECT_GE(compared, 15u);  // the shipped scenes with a camera and the bench terrain
}

// A surface with an infinite vertex (tests/data/heightfield/huge_sample.toml: a texel of
// 3e38 times scale_z = 10) is refused by the streamed render at every level, naming it.
TEST_F(SimdLevels, AnInfiniteVertexIsRefusedAtEveryLevel) {
    tessref::Scene scene = tessref::load_scene(
        (fs::path(TESSREF_SOURCE_DIR) / "tests" / "data" / "heightfield" / "huge_sample.toml").string());
    scene.camera = tessref::load_scene((fs::path(TESSREF_SOURCE_DIR) / "data" / "scenes" / "jacksboro.toml").string())
                       .camera;
    const auto refusal = [&] {
        try {
            tessref::render_scene(scene, {});
        } catch (const tessref::Error& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    const std::string base = at_level(tessref::SimdLevel::sse2, refusal);
    EXPECT_NE(base.find("non-finite vertex"), std::string::npos) << base;
    EXPECT_EQ(at_level(tessref::SimdLevel::avx2, refusal), base);
}
