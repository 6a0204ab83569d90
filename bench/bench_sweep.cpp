// Google Benchmark of the sweep's untimed measures of one row (docs/SWEEP.md): the geometric
// error and the screen edge measure of a uniform level of the two scenes of the issue's
// sweep, the Jacksboro DEM (24 x 24 patches over 403 x 344 texels: a triangle is about a
// quarter of a texel wide at level 64) and thesis-all-10 (16 x 16 patches over 512 x 512
// texels: half a texel at level 64, two texels at level 16), gpu precision, at the scenes'
// own spacing. The pipeline runs once, outside the timing. Level 32 lies between: a texel
// wide in thesis-all-10, half a texel in jacksboro; the sweep over levels 1..64 has
// nine tenths of its triangles at levels 32 to 64 (a row's count grows with the square of
// its level).
//
//  - BM_GeometricError/<scene>/<level>: geometric_error() (scene 0 jacksboro, 1 thesis-all-10).
//  - BM_MeanEdgePixels/<scene>/<level>: mean_edge_pixels() at 320 x 200.
//
//   build/bench_sweep --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <string>
#include <utility>

#include "sweep/geometric_error.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"
#include "tessref/scene.h"

namespace {

struct Row {
    tessref::Scene scene;
    tessref::PipelineResult result;
    tessref::sweep::TruthSurface truth;
};

// The scene with every level `level` (its control stage a constant), as the sweep's uniform rows.
const Row& row(int scene, int level) {
    static std::map<std::pair<int, int>, std::unique_ptr<Row>> rows;
    auto& r = rows[{scene, level}];
    if (!r) {
        r = std::make_unique<Row>();
        const char* file = scene == 0 ? "/scenes/jacksboro.toml" : "/scenes/thesis-all-10.toml";
        r->scene = tessref::load_scene(std::string(TESSREF_DATA_DIR) + file);
        r->scene.camera->viewport = {320, 200};
        tessref::ControlStage control = r->scene.control.value_or(tessref::ControlStage{});
        control.model = tessref::ControlModel::constant;
        control.constant.level = level;
        r->scene.control = control;
        tessref::PipelineOptions options;
        options.precision = tessref::Precision::gpu;
        r->result = tessref::run_pipeline(r->scene, options);
        r->truth = tessref::sweep::truth_surface(r->scene);
    }
    return *r;
}

void BM_GeometricError(benchmark::State& state) {
    const Row& r = row(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    for (auto _ : state)
        benchmark::DoNotOptimize(tessref::sweep::geometric_error(r.truth, r.result.mesh, &*r.scene.camera));
    state.counters["triangles/s"] = benchmark::Counter(static_cast<double>(r.result.mesh.triangles.size()),
                                                       benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_GeometricError)->ArgsProduct({{0, 1}, {16, 32, 64}})->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_MeanEdgePixels(benchmark::State& state) {
    const Row& r = row(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    const glm::dmat4 vp = r.scene.camera->view_projection();
    for (auto _ : state) benchmark::DoNotOptimize(tessref::sweep::mean_edge_pixels(r.result.mesh, vp, {320, 200}));
    state.counters["triangles/s"] = benchmark::Counter(static_cast<double>(r.result.mesh.triangles.size()),
                                                       benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_MeanEdgePixels)->ArgsProduct({{0, 1}, {64}})->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
