// Google Benchmark of the SPIR-V interpreter against the hand-written model it must match:
// evaluation invocations per second of thesis_terrain.tese through the interpreter
// (tessref/shader.h, one invocation at a time and in batches) and of thesis_evaluate (the C++ model, one
// point at a time, and in the pipeline's batches), on one patch of the thesis height map
// (8 x 8 world units, level 16 fractional odd), at the same domain points.
//   build/bench_shader --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <fstream>
#include <sstream>

#include "tessref/evaluation.h"
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

void BM_ThesisEvaluationInterpreter(benchmark::State& state) {
    const tessref::TerrainGrid& g = *scene().grid;
    std::ifstream in(std::string(TESSREF_DATA_DIR) + "/shaders/thesis_terrain.tese");
    std::ostringstream text;
    text << in.rdbuf();
    tessref::shader::Source source{tessref::ShaderStage::tess_evaluation, "thesis_terrain.tese", text.str(), ""};
    tessref::shader::Bindings b;
    b.set("scaleXY", static_cast<float>(g.scale_xy));
    b.set("scaleZ", static_cast<float>(g.scale_z));
    b.set("mvp", glm::mat4(1.0f));
    b.bind_texture(0, &g.heightmap->texture);
    const tessref::shader::Executable run(tessref::shader::Module::compile(source), b, {});
    tessref::shader::ShaderPatch patch;
    patch.vertices.resize(4);
    for (int k = 0; k < 4; ++k) patch.vertices[static_cast<std::size_t>(k)].locations = {tessref::shader::slot(kCorners[static_cast<std::size_t>(k)])};
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
    const tessref::TerrainGrid& g = *scene().grid;
    std::ifstream in(std::string(TESSREF_DATA_DIR) + "/shaders/thesis_terrain.tese");
    std::ostringstream text;
    text << in.rdbuf();
    tessref::shader::Source source{tessref::ShaderStage::tess_evaluation, "thesis_terrain.tese", text.str(), ""};
    tessref::shader::Bindings b;
    b.set("scaleXY", static_cast<float>(g.scale_xy));
    b.set("scaleZ", static_cast<float>(g.scale_z));
    b.set("mvp", glm::mat4(1.0f));
    b.bind_texture(0, &g.heightmap->texture);
    const tessref::shader::Executable run(tessref::shader::Module::compile(source), b, {});
    tessref::shader::ShaderPatch patch;
    patch.vertices.resize(4);
    for (int k = 0; k < 4; ++k) patch.vertices[static_cast<std::size_t>(k)].locations = {tessref::shader::slot(kCorners[static_cast<std::size_t>(k)])};
    const std::vector<glm::vec3> points = domain_points();
    std::size_t n = 0;
    for (auto _ : state) {
        const std::vector<tessref::shader::ShaderVertex> v = run.evaluate(patch, points, 0);
        benchmark::DoNotOptimize(v.data());
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
    const tessref::Sampler2DBatch<float> heightMap = [t](std::span<const glm::vec2> uv, std::span<glm::vec4> out) {
        t->texture(uv, out);
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

BENCHMARK(BM_ThesisEvaluationInterpreter)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ThesisEvaluationInterpreterBatch)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ThesisEvaluationModel)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ThesisEvaluationModelBatch)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
