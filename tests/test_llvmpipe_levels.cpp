// Every shipped scene: the CPU pipeline's levels in llvmpipe math (control.h MathMode) are
// the levels llvmpipe's evaluation shader reads, bit for bit, on every patch, and every
// patch's triangle count is llvmpipe's (gl --capture's records, tessref::gl::render_scene).
// In exact math (the C library's acos) they are not: the count of patches that agree in
// exact math is printed beside, for the docs' before/after numbers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <unistd.h>

#include "gl_test_context.h"
#include "tessref/error.h"
#include "tessref/gl_render.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"
#include "tessref/scene.h"

namespace {

namespace fs = std::filesystem;
namespace gl = tessref::gl;
using tessref::MathMode;
using tessref::TessLevels;

const fs::path kScenes = fs::path(TESSREF_SOURCE_DIR) / "data" / "scenes";

gl::Context* context() { return gl_test_context(); }

std::vector<std::string> shipped_scenes() {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(kScenes))
        if (e.path().extension() == ".toml") names.push_back(e.path().stem().string());
    std::sort(names.begin(), names.end());
    return names;
}

// The levels the domain uses, bit for bit (GL leaves the others to the implementation).
bool same_bits(const TessLevels& a, const TessLevels& b, tessref::Domain domain) {
    using tessref::Domain;
    const std::size_t outer = domain == Domain::quads ? 4 : domain == Domain::triangles ? 3 : 2;
    const std::size_t inner = domain == Domain::quads ? 2 : domain == Domain::triangles ? 1 : 0;
    return std::memcmp(a.outer.data(), b.outer.data(), sizeof(float) * outer) == 0 &&
           std::memcmp(a.inner.data(), b.inner.data(), sizeof(float) * inner) == 0;
}

// Per patch: llvmpipe's triangle count and levels from the capture (a patch that emitted
// nothing has no levels there); a patch agrees when its count is the CPU's and, if it
// emitted anything, every captured vertex carries the CPU's levels.
struct Agreement {
    std::size_t levels_and_counts = 0;  // patches whose levels and triangle count agree
    std::size_t counts = 0;             // patches whose triangle count agrees
};

Agreement agreeing_patches(const tessref::PipelineResult& cpu, const std::vector<tessref::CapturedVertex>& capture,
                           tessref::Domain domain, std::string* first_differences) {
    const std::size_t n = cpu.levels.size();
    std::vector<std::uint64_t> cpu_triangles(n, 0), gl_triangles(n, 0);
    std::vector<bool> levels_agree(n, true);
    std::vector<TessLevels> gl_levels(n);
    for (const auto& tri : cpu.mesh.triangles) ++cpu_triangles[cpu.mesh.patch_ids[tri[0]]];
    for (std::size_t v = 0; v < capture.size(); ++v) {
        const std::size_t p = capture[v].patch_id;
        if (p >= n) continue;
        if (v % 3 == 0) ++gl_triangles[p];
        if (!same_bits(capture[v].levels, cpu.levels[p], domain)) levels_agree[p] = false;
        gl_levels[p] = capture[v].levels;
    }
    Agreement agree;
    for (std::size_t p = 0; p < n; ++p) {
        agree.counts += cpu_triangles[p] == gl_triangles[p];
        if (levels_agree[p] && cpu_triangles[p] == gl_triangles[p]) {
            ++agree.levels_and_counts;
        } else if (first_differences && first_differences->size() < 4000) {
            const TessLevels& c = cpu.levels[p];
            const TessLevels& g = gl_levels[p];
            char line[400];
            std::snprintf(line, sizeof line,
                          "  patch %zu: triangles CPU %llu GL %llu; levels CPU %.9g %.9g %.9g %.9g | %.9g %.9g, "
                          "GL %.9g %.9g %.9g %.9g | %.9g %.9g\n",
                          p, static_cast<unsigned long long>(cpu_triangles[p]),
                          static_cast<unsigned long long>(gl_triangles[p]), c.outer[0], c.outer[1], c.outer[2],
                          c.outer[3], c.inner[0], c.inner[1], g.outer[0], g.outer[1], g.outer[2], g.outer[3],
                          g.inner[0], g.inner[1]);
            *first_differences += line;
        }
    }
    return agree;
}

class LlvmpipeLevels : public ::testing::TestWithParam<std::string> {};

TEST_P(LlvmpipeLevels, CpuLevelsInLlvmpipeMathAreLlvmpipesOnEveryPatch) {
    gl::Context* ctx = context();
    if (!ctx) return;
    const tessref::Scene scene = tessref::load_scene((kScenes / (GetParam() + ".toml")).string());
    gl::SceneRenderOptions options;
    options.size = {64, 40};  // the levels do not depend on the pixels drawn, only the viewport's shape
    options.capture = true;
    const gl::SceneRender r = gl::render_scene(*ctx, scene, options);
    EXPECT_TRUE(r.batch_failure.empty()) << r.batch_failure;
    EXPECT_TRUE(r.differences.empty());
    ASSERT_TRUE(r.pipeline);

    std::string differences;
    const tessref::Domain domain = scene.generator.domain;
    const Agreement llvmpipe_math = agreeing_patches(*r.pipeline, r.capture, domain, &differences);
    // The same pipeline in exact math, held against the same capture.
    tessref::Scene sized = scene;
    if (sized.camera) sized.camera->viewport = options.size;
    tessref::PipelineOptions exact;
    exact.math = MathMode::exact;
    const Agreement exact_math = agreeing_patches(tessref::run_pipeline(sized, exact), r.capture, domain, nullptr);
    const std::size_t n = r.pipeline->levels.size();
    std::printf("[ levels   ] %-24s %5zu patches; levels and triangles as llvmpipe's: %5zu in llvmpipe math, "
                "%5zu in exact math; triangle counts: %5zu, %5zu\n",
                GetParam().c_str(), n, llvmpipe_math.levels_and_counts, exact_math.levels_and_counts,
                llvmpipe_math.counts, exact_math.counts);
    if (!differences.empty()) std::printf("%s", differences.c_str());
    // Every patch's triangle count is llvmpipe's: what `gl` predicts its draws with.
    EXPECT_EQ(llvmpipe_math.counts, n) << differences;
    // Levels: bit for bit on every patch (the last 16, on jacksboro and olinda, took the
    // normal factor's four angles summed as Mesa rebalances the chain: llvmpipe_math.h,
    // balanced_order).
    EXPECT_EQ(llvmpipe_math.levels_and_counts, n) << differences;
}

// The scene's control twin (data/shaders/*.tesc) given as a user's file under another name,
// so that the CPU runs it through the SPIR-V interpreter in llvmpipe math (and llvmpipe the
// same file): its levels are llvmpipe's on every patch. The thesis twin's normal factor sums
// four angles as Mesa's GLSL compiler rebalances the chain (src/shader/rebalance.h): added
// from the left, 16 patches differed (jacksboro 14, olinda 2).
const char* control_twin(const tessref::Scene& scene) {
    if (!scene.control) return nullptr;
    switch (scene.control->model) {
        case tessref::ControlModel::thesis: return "thesis_terrain";
        case tessref::ControlModel::cosc422: return "cosc422_terrain";
        case tessref::ControlModel::lab4: return "lab4_terrain";
        case tessref::ControlModel::pn: return "pn_triangles";
        case tessref::ControlModel::constant: break;
    }
    return nullptr;
}

TEST_P(LlvmpipeLevels, InterpretedControlTwinGivesLlvmpipesLevelsOnEveryPatch) {
    gl::Context* ctx = context();
    if (!ctx) return;
    tessref::Scene scene = tessref::load_scene((kScenes / (GetParam() + ".toml")).string());
    const char* twin = control_twin(scene);
    const bool has_control = std::any_of(scene.shaders.begin(), scene.shaders.end(), [](const tessref::StageShader& s) {
        return s.stage == tessref::ShaderStage::tess_control;
    });
    if (!twin || has_control) GTEST_SKIP() << "no control twin to give as a user's file (or the scene gives its own)";
    const fs::path dir = fs::temp_directory_path() / ("tessref-test-levels-" + std::to_string(::getpid()) + "-" + GetParam());
    fs::create_directories(dir);
    const fs::path copy = dir / (std::string(twin) + "_copy.tesc");
    {
        std::ifstream in(fs::path(TESSREF_SOURCE_DIR) / "data" / "shaders" / (std::string(twin) + ".tesc"), std::ios::binary);
        std::ofstream out(copy, std::ios::binary);
        out << in.rdbuf() << "// a copy\n";
    }
    scene.shaders.push_back(tessref::StageShader{tessref::ShaderStage::tess_control, copy.string(), copy.string(),
                                                 tessref::Where::in_file(copy.string())});
    gl::SceneRenderOptions options;
    options.size = {64, 40};
    options.capture = true;
    const gl::SceneRender r = gl::render_scene(*ctx, scene, options);
    fs::remove_all(dir);
    EXPECT_TRUE(r.batch_failure.empty()) << r.batch_failure;
    ASSERT_TRUE(r.pipeline);
    std::string differences;
    const Agreement agree = agreeing_patches(*r.pipeline, r.capture, scene.generator.domain, &differences);
    const std::size_t n = r.pipeline->levels.size();
    std::printf("[ levels   ] %-24s %5zu patches; %s.tesc interpreted, levels and triangles as llvmpipe's: %5zu\n",
                GetParam().c_str(), n, twin, agree.levels_and_counts);
    EXPECT_EQ(agree.levels_and_counts, n) << differences;
}

INSTANTIATE_TEST_SUITE_P(ShippedScenes, LlvmpipeLevels, ::testing::ValuesIn(shipped_scenes()),
                         [](const auto& info) {
                             std::string name = info.param;
                             for (char& c : name)
                                 if (c == '-') c = '_';
                             return name;
                         });

}  // namespace
