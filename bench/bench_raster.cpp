// Google Benchmark of the rasterizer (tessref/raster.h): triangles per second and megapixels
// per second, 1 and 2 threads, fill and wireframe, at the scenes' 1280 x 800.
//
//  - BM_RasterScene/<scene>: a shipped scene's tessellated surface (run_pipeline, gpu
//    precision, run once outside the timing), projected with the scene's camera in float
//    (gl_Position = mvp * vec4(position, 1)), normals as 3 varyings, patch ids and tess
//    coords for the provenance AOVs: thesis-all-10, and jacksboro with every level 64.
//  - BM_RasterSoup: a synthetic tessellated-terrain-like triangle soup (a 1024 x 512 quad
//    height field in perspective, 1.05 M triangles, crossing the screen borders and the near
//    plane), which needs no scene.
// Timed: rasterize() alone (clipping, setup, binning, tiles, resolve); clearing the
// framebuffer between iterations is not timed. Counters are per wall-clock second.
// Feed another SurfaceMesh with make_input(mesh, camera).
//
//   build/bench_raster --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <tbb/global_control.h>

#include "tessref/mesh.h"
#include "tessref/prepare.h"
#include "tessref/raster.h"
#include "tessref/pipeline.h"

namespace {

// A surface projected for the rasterizer, owning the arrays RasterInput views.
struct RasterScene {
    int width = 1280;
    int height = 800;
    std::vector<glm::vec4> positions;
    std::vector<std::array<std::uint32_t, 3>> triangles;
    std::vector<float> normals;
    std::vector<std::uint32_t> patch_ids;
    std::vector<glm::vec3> tess_coords;

    tessref::RasterInput input() const {
        tessref::RasterInput in;
        in.positions = positions;
        in.triangles = triangles;
        in.varyings = normals;
        in.varying_count = normals.empty() ? 0 : 3;
        in.patch_ids = patch_ids;
        if (tess_coords.size() == positions.size()) in.tess_coords = tess_coords;
        return in;
    }
};

RasterScene make_input(const tessref::SurfaceMesh& mesh, const tessref::SceneCamera& camera) {
    RasterScene s;
    s.width = camera.viewport.x;
    s.height = camera.viewport.y;
    const glm::mat4 mvp(camera.view_projection());  // the uniform the vertex shader gets
    s.positions.reserve(mesh.positions.size());
    for (const glm::dvec3& p : mesh.positions) s.positions.push_back(mvp * glm::vec4(glm::vec3(p), 1.0f));
    s.triangles = mesh.triangles;
    if (mesh.normals.size() == mesh.positions.size()) {
        s.normals.reserve(mesh.normals.size() * 3);
        for (const glm::dvec3& n : mesh.normals)
            s.normals.insert(s.normals.end(), {static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z)});
    }
    if (mesh.patch_ids.size() == mesh.positions.size()) {
        s.patch_ids.reserve(mesh.triangles.size());
        for (const auto& t : mesh.triangles) s.patch_ids.push_back(mesh.patch_ids[t[0]]);
    }
    s.tess_coords = mesh.tess_coords;
    return s;
}

const RasterScene& scene_input(const std::string& name) {
    static std::map<std::string, RasterScene> cache;
    auto it = cache.find(name);
    if (it != cache.end()) return it->second;
    tessref::Scene scene = tessref::load_scene(std::string(TESSREF_DATA_DIR) + "/scenes/" +
                                               (name == "jacksboro-64" ? "jacksboro" : name) + ".toml");
    if (name == "jacksboro-64") {  // every level 64, as the mesh benchmark
        tessref::ControlStage control;
        control.model = tessref::ControlModel::constant;
        control.constant.level = 64.0;
        scene.control = control;
    }
    const tessref::PipelineResult result = tessref::run_pipeline(scene);
    return cache.emplace(name, make_input(result.mesh, scene.camera.value_or(tessref::SceneCamera{}))).first->second;
}

// Synthetic: a 1024 x 512 quad height field seen from above its near edge.
const RasterScene& soup_input() {
    static const RasterScene soup = [] {
        tessref::SurfaceMesh mesh;
        const int nx = 1024, ny = 512;
        for (int j = 0; j <= ny; ++j)
            for (int i = 0; i <= nx; ++i) {
                const double x = -200.0 + 400.0 * i / nx, y = -20.0 + 400.0 * j / ny;
                const double h = 6.0 * std::sin(x * 0.05) * std::cos(y * 0.07) + 2.0 * std::sin(x * 0.31 + y * 0.23);
                mesh.positions.push_back({x, y, h});
                mesh.normals.push_back(glm::normalize(glm::dvec3(-0.3 * std::cos(x * 0.05), 0.42 * std::sin(y * 0.07), 1.0)));
                mesh.patch_ids.push_back(static_cast<std::uint32_t>((j / 64) * (nx / 64) + i / 64));
                mesh.tess_coords.push_back({(i % 64) / 64.0f, (j % 64) / 64.0f, 0.0f});
            }
        auto at = [&](int i, int j) { return static_cast<std::uint32_t>(j * (nx + 1) + i); };
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i) {
                mesh.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
                mesh.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
            }
        tessref::SceneCamera camera;
        camera.eye = {0.0, -30.0, 25.0};
        camera.center = {0.0, 60.0, 0.0};
        camera.up = {0.0, 0.0, 1.0};
        camera.fov_y_degrees = 45.0;
        camera.near_plane = 1.0;
        camera.far_plane = 1000.0;
        return make_input(mesh, camera);
    }();
    return soup;
}

void run(benchmark::State& state, const RasterScene& scene) {
    const int threads = static_cast<int>(state.range(0));
    const auto mode = static_cast<tessref::PolygonMode>(state.range(1));
    static tbb::global_control allow(tbb::global_control::max_allowed_parallelism, 16);
    tessref::Framebuffer fb = tessref::Framebuffer::create(scene.width, scene.height, 3);
    tessref::RasterSettings settings;
    settings.threads = threads;
    settings.polygon_mode = mode;
    const tessref::RasterInput input = scene.input();
    tessref::RasterStats stats;
    for (auto _ : state) {
        state.PauseTiming();
        fb.clear();
        state.ResumeTiming();
        stats = tessref::rasterize(fb, input, settings);
        benchmark::DoNotOptimize(fb.depth.data());
    }
    const double pixels = static_cast<double>(scene.width) * scene.height;
    state.counters["triangles/s"] = benchmark::Counter(static_cast<double>(scene.triangles.size()),
                                                       benchmark::Counter::kIsIterationInvariantRate);
    state.counters["Mpixels/s"] = benchmark::Counter(pixels / 1e6, benchmark::Counter::kIsIterationInvariantRate);
    state.counters["fragments/s"] = benchmark::Counter(static_cast<double>(stats.fragments),
                                                       benchmark::Counter::kIsIterationInvariantRate);
    state.counters["triangles"] = static_cast<double>(scene.triangles.size());
    state.counters["clipped"] = static_cast<double>(stats.triangles_clipped);
    state.counters["fragments"] = static_cast<double>(stats.fragments);
}

void BM_RasterScene_thesis_all_10(benchmark::State& state) { run(state, scene_input("thesis-all-10")); }
void BM_RasterScene_jacksboro_64(benchmark::State& state) { run(state, scene_input("jacksboro-64")); }
void BM_RasterSoup(benchmark::State& state) { run(state, soup_input()); }

// Args: {threads, polygon mode (0 fill, 1 line)}.
void args(benchmark::internal::Benchmark* b) {
    b->ArgNames({"threads", "wire"});
    for (int mode : {0, 1})
        for (int threads : {1, 2}) b->Args({threads, mode});
    b->Unit(benchmark::kMillisecond)->UseRealTime();
}

BENCHMARK(BM_RasterScene_thesis_all_10)->Apply(args);
BENCHMARK(BM_RasterScene_jacksboro_64)->Apply(args);
BENCHMARK(BM_RasterSoup)->Apply(args);

}  // namespace

BENCHMARK_MAIN();
