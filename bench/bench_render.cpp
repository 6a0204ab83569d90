// Google Benchmark of `tessref render` (include/tessref/render.h) at 1280x800, with 1 and 2
// oneTBB threads (tbb::global_control):
//
//  - BM_RenderSurface: rasterize + resolve + shade an already tessellated surface
//    (render_surface): the renderer alone.
//  - BM_RenderScene: the whole render (render_scene: pipeline, then the above), what the
//    command computes before writing the file.
//  - BM_Raytrace: the Embree ground truth of the same view (raytrace_scene), for scale.
//
// Scenes: data/scenes/thesis-all-10.toml (thesis formula (2), its 1280x800 viewport) and
// data/scenes/jacksboro.toml with its control stage replaced by a uniform level 64
// (fractional_odd: 63 x 63 quads, 7938 triangles a patch, 4.57 M triangles).
// Counters, from the wall-clock time of each iteration (the work is multithreaded):
//   Mtri/s  tessellated triangles drawn per second, millions
//   Mpix/s  image pixels produced per second, millions (1280 x 800 = 1.024 Mpixel)
//
//   build/bench_render --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include <tbb/global_control.h>

#include "tessref/prepare.h"
#include "tessref/render.h"
#include "tessref/pipeline.h"

namespace {

const tessref::Scene& bench_scene(int which) {
    static const tessref::Scene thesis =
        tessref::load_scene(std::string(TESSREF_DATA_DIR) + "/scenes/thesis-all-10.toml");
    static const tessref::Scene jacksboro = [] {
        tessref::Scene s = tessref::load_scene(std::string(TESSREF_DATA_DIR) + "/scenes/jacksboro.toml");
        tessref::ControlStage control;
        control.model = tessref::ControlModel::constant;
        control.constant.level = 64.0;
        s.control = control;
        return s;
    }();
    return which == 0 ? thesis : jacksboro;
}

const char* scene_label(int which) { return which == 0 ? "thesis-all-10" : "jacksboro-level-64"; }

tessref::RenderOptions options_1280x800() {
    tessref::RenderOptions options;
    options.size = {1280, 800};
    return options;
}

// The scene's tessellation, computed once per scene.
std::shared_ptr<const tessref::PipelineResult> tessellation(int which) {
    static std::shared_ptr<const tessref::PipelineResult> cache[2];
    if (!cache[which]) {
        cache[which] = std::make_shared<const tessref::PipelineResult>(tessref::run_pipeline(bench_scene(which)));
    }
    return cache[which];
}

using Clock = std::chrono::steady_clock;

void set_counters(benchmark::State& state, std::uint64_t triangles, std::uint64_t pixels, double wall_seconds) {
    const double iterations = static_cast<double>(state.iterations());
    state.counters["Mtri/s"] = static_cast<double>(triangles) * iterations / wall_seconds * 1e-6;
    state.counters["Mpix/s"] = static_cast<double>(pixels) * iterations / wall_seconds * 1e-6;
    state.counters["triangles"] = static_cast<double>(triangles);
    state.SetLabel(scene_label(static_cast<int>(state.range(0))));
}

// range(0): scene (0 thesis-all-10, 1 jacksboro level 64); range(1): threads.
void BM_RenderSurface(benchmark::State& state) {
    const int which = static_cast<int>(state.range(0));
    const tessref::Scene& scene = bench_scene(which);
    const auto surface = tessellation(which);
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(1)));
    double wall = 0.0;
    std::uint64_t pixels = 0;
    for (auto _ : state) {
        const auto start = Clock::now();
        tessref::RenderResult image = tessref::render_surface(scene, surface, options_1280x800());
        wall += std::chrono::duration<double>(Clock::now() - start).count();
        pixels = image.colour.size();
        benchmark::DoNotOptimize(image.colour.data());
    }
    set_counters(state, surface->mesh.triangles.size(), pixels, wall);
}

// Times `render(scene, options)` at 1280x800 on the state's scene and thread count.
template <typename Render>
void time_scene_renders(benchmark::State& state, Render render) {
    const int which = static_cast<int>(state.range(0));
    const tessref::Scene& scene = bench_scene(which);
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(1)));
    double wall = 0.0;
    std::uint64_t pixels = 0, triangles = 0;
    for (auto _ : state) {
        const auto start = Clock::now();
        tessref::RenderResult image = render(scene, options_1280x800());
        wall += std::chrono::duration<double>(Clock::now() - start).count();
        pixels = image.colour.size();
        triangles = image.stats.triangles;
        benchmark::DoNotOptimize(image.colour.data());
    }
    set_counters(state, triangles, pixels, wall);
}

void BM_RenderScene(benchmark::State& state) {
    time_scene_renders(state, [](const tessref::Scene& s, const tessref::RenderOptions& o) { return tessref::render_scene(s, o); });
}

void BM_Raytrace(benchmark::State& state) {
    time_scene_renders(state, [](const tessref::Scene& s, const tessref::RenderOptions& o) { return tessref::raytrace_scene(s, o); });
}

void scene_and_threads(benchmark::internal::Benchmark* b) {
    b->ArgNames({"scene", "threads"});
    for (const int scene : {0, 1})
        for (const int threads : {1, 2}) b->Args({scene, threads});
    b->Unit(benchmark::kMillisecond)->UseRealTime();
}

BENCHMARK(BM_RenderSurface)->Apply(scene_and_threads);
BENCHMARK(BM_RenderScene)->Apply(scene_and_threads);
BENCHMARK(BM_Raytrace)->Apply(scene_and_threads);

}  // namespace

BENCHMARK_MAIN();
