// Google Benchmark of the SPIR-V interpreter against the hand-written model it must match:
// evaluation invocations per second of thesis_terrain.tese through the interpreter
// (tessref/shader.h, one invocation at a time and in batches) and of thesis_evaluate (the C++ model, one
// point at a time, and in the pipeline's batches), on one patch of the thesis height map
// (8 x 8 world units, level 16 fractional odd), at the same domain points.
//   build/bench_shader --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include "tessref/evaluation.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"
#include "tessref/scene.h"
#include "tessref/shader.h"
#include "tessref/tessellator.h"

namespace {

const tessref::Scene& scene() {
    static const tessref::Scene s = tessref::load_scene(std::string(TESSREF_DATA_DIR) + "/scenes/thesis-all-10.toml");
    return s;
}

std::vector<glm::vec3> domain_points() {
    tessref::TessSettings settings;
    settings.domain = tessref::Domain::quads;
    settings.spacing = tessref::Spacing::fractional_odd;
    tessref::TessLevels levels;
    levels.outer = {16.0f, 16.0f, 16.0f, 16.0f};
    levels.inner = {16.0f, 16.0f};
    const tessref::Pattern p = tessref::tessellate(settings, levels, tessref::Precision::gpu);
    std::vector<glm::vec3> points;
    for (const auto& q : p.points()) points.emplace_back(static_cast<float>(q.u), static_cast<float>(q.v), 0.0f);
    return points;
}

const std::array<glm::vec4, 4> kCorners = {glm::vec4(0, 0, 0, 1), glm::vec4(0, 8, 0, 1), glm::vec4(8, 8, 0, 1),
                                           glm::vec4(8, 0, 0, 1)};

// thesis_terrain.tese compiled with the grid scene's uniforms and height map, and one patch
// with kCorners: what both interpreter benchmarks run.
struct ThesisTese {
    tessref::shader::Bindings bindings;
    std::optional<tessref::shader::Executable> run;
    tessref::shader::ShaderPatch patch;

    ThesisTese() {
        const tessref::TerrainGrid& g = *scene().grid;
        std::ifstream in(std::string(TESSREF_DATA_DIR) + "/shaders/thesis_terrain.tese");
        std::ostringstream text;
        text << in.rdbuf();
        tessref::shader::Source source{tessref::ShaderStage::tess_evaluation, "thesis_terrain.tese", text.str(), ""};
        bindings.set("scaleXY", static_cast<float>(g.scale_xy));
        bindings.set("scaleZ", static_cast<float>(g.scale_z));
        bindings.set("mvp", glm::mat4(1.0f));
        bindings.bind_texture(0, &g.heightmap->texture);
        run.emplace(tessref::shader::Module::compile(source), bindings, tessref::shader::RunOptions{});
        patch.vertices.resize(4);
        for (std::size_t k = 0; k < 4; ++k) patch.vertices[k].locations = {tessref::shader::slot(kCorners[k])};
    }
};

void BM_ThesisEvaluationInterpreter(benchmark::State& state) {
    const ThesisTese tese;
    const tessref::shader::Executable& run = *tese.run;
    const tessref::shader::ShaderPatch& patch = tese.patch;
    const std::vector<glm::vec3> points = domain_points();
    std::size_t n = 0;
    for (auto _ : state) {
        for (const glm::vec3& p : points) {
            const tessref::shader::ShaderVertex v = run.evaluate(patch, p, 0);
            benchmark::DoNotOptimize(v.position);
        }
        n += points.size();
    }
    state.counters["invocations/s"] = benchmark::Counter(static_cast<double>(n), benchmark::Counter::kIsRate);
}

// The same invocations through Executable::evaluate's batches (kBatchLanes points each), as
// the pipeline runs a user's evaluation shader.
void BM_ThesisEvaluationInterpreterBatch(benchmark::State& state) {
    const ThesisTese tese;
    const tessref::shader::Executable& run = *tese.run;
    const tessref::shader::ShaderPatch& patch = tese.patch;
    const std::vector<glm::vec3> points = domain_points();
    std::size_t n = 0;
    for (auto _ : state) {
        tessref::shader::ShaderVertices v;  // a fresh one per patch, as the pipeline's
        run.evaluate(patch, points, 0, v);
        benchmark::DoNotOptimize(v.positions.data());
        n += points.size();
    }
    state.counters["invocations/s"] = benchmark::Counter(static_cast<double>(n), benchmark::Counter::kIsRate);
}

void BM_ThesisEvaluationModel(benchmark::State& state) {
    const tessref::TerrainGrid& g = *scene().grid;
    tessref::ThesisEvaluation<float> e;
    const tessref::Texture* t = &g.heightmap->texture;
    e.heightMap = [t](glm::vec2 uv) { return t->texture(uv); };
    e.scaleXY = static_cast<float>(g.scale_xy);
    e.scaleZ = static_cast<float>(g.scale_z);
    const std::vector<glm::vec3> points = domain_points();
    std::size_t n = 0;
    for (auto _ : state) {
        for (const glm::vec3& p : points) {
            const auto v = tessref::thesis_evaluate<float>(kCorners, {p.x, p.y, p.z}, e);
            benchmark::DoNotOptimize(v.glPosition);
        }
        n += points.size();
    }
    state.counters["invocations/s"] = benchmark::Counter(static_cast<double>(n), benchmark::Counter::kIsRate);
}

// The model as the pipeline runs it: the whole patch's points in one batch (SSE2, the height
// map read once per block of points).
void BM_ThesisEvaluationModelBatch(benchmark::State& state) {
    const tessref::TerrainGrid& g = *scene().grid;
    const tessref::Texture* t = &g.heightmap->texture;
    const tessref::Sampler2DRedBatch<float> heightMap = [t](std::span<const glm::vec2> uv, std::span<float> red) {
        t->texture_red(uv, red);
    };
    const std::vector<glm::vec3> points = domain_points();
    std::vector<tessref::DomainPoint<float>> tc;
    for (const glm::vec3& p : points) tc.push_back({p.x, p.y, p.z});
    std::vector<glm::vec3> position(points.size());
    std::vector<glm::vec2> textureCoordinate(points.size());
    std::size_t n = 0;
    for (auto _ : state) {
        tessref::thesis_evaluate_batch<float>(kCorners, tc, heightMap, static_cast<float>(g.scale_xy),
                                              static_cast<float>(g.scale_z), position, textureCoordinate);
        benchmark::DoNotOptimize(position.data());
        n += points.size();
    }
    state.counters["invocations/s"] = benchmark::Counter(static_cast<double>(n), benchmark::Counter::kIsRate);
}

// Whole pipelines (every stage, all threads) of a scene through the model and with a user's
// evaluation shader (the thesis twin's text with a comment added, so that it runs through
// the interpreter): evaluation invocations (emitted vertices) per second. Argument 0:
// data/scenes/jacksboro.toml, 1: bench/scenes/jacksboro-grid-16.toml (64 x 64 patches at
// level 16).
const tessref::Scene& pipeline_scene(std::int64_t which, bool user) {
    static const std::array<std::string, 2> paths = {std::string(TESSREF_DATA_DIR) + "/scenes/jacksboro.toml",
                                                     std::string(TESSREF_SOURCE_DIR) + "/bench/scenes/jacksboro-grid-16.toml"};
    static std::array<std::array<std::unique_ptr<tessref::Scene>, 2>, 2> scenes;
    std::unique_ptr<tessref::Scene>& s = scenes[static_cast<std::size_t>(which)][user ? 1 : 0];
    if (!s) {
        s = std::make_unique<tessref::Scene>(tessref::load_scene(paths[static_cast<std::size_t>(which)]));
        if (user) {
            const std::filesystem::path copy = std::filesystem::temp_directory_path() / "bench_shader_user.tese";
            std::ifstream in(std::string(TESSREF_DATA_DIR) + "/shaders/thesis_terrain.tese");
            std::ofstream(copy) << in.rdbuf() << "// a user's copy\n";
            s->shaders.push_back(tessref::StageShader{tessref::ShaderStage::tess_evaluation, copy.string(), copy.string(),
                                                      tessref::Where::in_file(copy.string())});
        }
    }
    return *s;
}

void pipeline_case(benchmark::State& state, bool user) {
    const tessref::Scene& s = pipeline_scene(state.range(0), user);
    std::size_t n = 0;
    for (auto _ : state) {
        const tessref::PipelineResult r = tessref::run_pipeline(s);
        n += r.mesh.positions.size();
        benchmark::DoNotOptimize(r.mesh.positions.data());
    }
    state.counters["invocations/s"] = benchmark::Counter(static_cast<double>(n), benchmark::Counter::kIsRate);
}
void BM_PipelineModel(benchmark::State& state) { pipeline_case(state, false); }
void BM_PipelineUserEvaluation(benchmark::State& state) { pipeline_case(state, true); }

BENCHMARK(BM_PipelineModel)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PipelineUserEvaluation)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ThesisEvaluationInterpreter)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ThesisEvaluationInterpreterBatch)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ThesisEvaluationModel)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ThesisEvaluationModelBatch)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
