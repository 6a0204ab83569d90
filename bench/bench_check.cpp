// Google Benchmark of `tessref check`: the whole check of a terrain mesh of about 1M and
// 10M triangles, made from the Jacksboro scene (data/scenes/jacksboro.toml, the Jacksboro
// fault DEM) with its control stage replaced by a uniform level and equal spacing:
//   1M:  16 x 16 patches at level 44 (2 * 44^2 triangles a patch):    991,232 triangles
//   10M: 40 x 40 patches at level 56 (2 * 56^2 triangles a patch): 10,035,200 triangles
// The mesh is built (pipeline, then the exporter's bitwise weld) once, outside the timing.
//
//  - BM_CheckJacksboro/<millions>/<probe>: check_mesh() with the default options (ray probe
//    on, 512 x 512 rays) or without the probe; wall-clock time, triangles per second.
//  - BM_ReadAndCheckJacksboro/<millions>/<path>: what `tessref check mesh.ply` does: read a
//    binary PLY (written once by the exporter to a temporary file), then check; path 1 is
//    read_and_check_mesh() (the command's, OpenMesh's import skipped where it cannot refuse
//    a face), path 0 read_mesh_for_check() then check_mesh() (OpenMesh's import always).
//
//   build/bench_check --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>

#include "tessref/check.h"
#include "tessref/mesh.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"

namespace {

const std::string scene_path = std::string(TESSREF_DATA_DIR) + "/scenes/jacksboro.toml";

// The Jacksboro scene with `patches` x `patches` patches, every level `level`, equal spacing,
// no geometry stage (no normals: the check reads positions only).
tessref::Scene jacksboro(int patches, double level) {
    std::ifstream in(scene_path);
    std::stringstream text;
    text << in.rdbuf();
    std::string toml = text.str();
    toml = std::regex_replace(toml, std::regex(R"(patches = \[24, 24\])"),
                              "patches = [" + std::to_string(patches) + ", " + std::to_string(patches) + "]");
    toml = std::regex_replace(toml, std::regex(R"(spacing = "fractional_odd")"), "spacing = \"equal\"");
    toml = toml.substr(0, toml.find("[control]"));
    toml += "[control]\nmodel = \"constant\"\nlevel = " + std::to_string(level) + "\n\n[evaluation]\nmodel = \"thesis\"\n";
    return tessref::load_scene_from_string(toml, scene_path);
}

const tessref::IndexedMesh& terrain(int millions) {
    static std::map<int, tessref::IndexedMesh> meshes;
    auto it = meshes.find(millions);
    if (it == meshes.end()) {
        const tessref::Scene scene = millions >= 10 ? jacksboro(40, 56.0) : jacksboro(16, 44.0);
        const tessref::PipelineResult result = tessref::run_pipeline(scene);
        it = meshes.emplace(millions, tessref::indexed_mesh_from(result.mesh)).first;
    }
    return it->second;
}

// range(0): millions of triangles (1 or 10); range(1): 1 with the ray probe, 0 without.
void BM_CheckJacksboro(benchmark::State& state) {
    const tessref::IndexedMesh& mesh = terrain(static_cast<int>(state.range(0)));
    tessref::CheckOptions options;
    options.ray_probe = state.range(1) != 0;
    std::size_t triangles = 0;
    bool passed = true;
    for (auto _ : state) {
        const tessref::CheckReport report = tessref::check_mesh(mesh, options);
        triangles += report.triangle_count;
        passed = passed && report.passed;
        benchmark::DoNotOptimize(report.edge_count);
    }
    state.counters["triangles"] = static_cast<double>(mesh.face_count());
    state.counters["triangles/s"] = benchmark::Counter(static_cast<double>(triangles), benchmark::Counter::kIsRate);
    state.SetLabel(std::string(options.ray_probe ? "probe 512^2" : "no probe") + (passed ? ", passes" : ", FAILS"));
}
BENCHMARK(BM_CheckJacksboro)
    ->Args({1, 1})
    ->Args({1, 0})
    ->Args({10, 1})
    ->Args({10, 0})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

// range(0): millions of triangles (1 or 10).
void BM_ReadAndCheckJacksboro(benchmark::State& state) {
    const auto path = std::filesystem::temp_directory_path() / "tessref_bench_check.ply";
    {
        const tessref::Scene scene = state.range(0) >= 10 ? jacksboro(40, 56.0) : jacksboro(16, 44.0);
        const tessref::PipelineResult result = tessref::run_pipeline(scene);
        std::ofstream out(path, std::ios::binary);
        tessref::MeshWriteOptions options;
        options.format = tessref::MeshFormat::ply;
        options.binary = true;
        tessref::write_mesh(result.mesh, out, options);
    }
    const bool together = state.range(1) != 0;
    std::size_t triangles = 0;
    for (auto _ : state) {
        if (together) {
            const tessref::CheckedMesh checked = tessref::read_and_check_mesh(path.string());
            triangles += checked.report.triangle_count;
        } else {
            const tessref::IndexedMesh mesh = tessref::read_mesh_for_check(path.string());
            const tessref::CheckReport report = tessref::check_mesh(mesh);
            triangles += report.triangle_count;
        }
    }
    std::filesystem::remove(path);
    state.counters["triangles/s"] = benchmark::Counter(static_cast<double>(triangles), benchmark::Counter::kIsRate);
    state.SetLabel(together ? "binary PLY: read_and_check_mesh" : "binary PLY: read_mesh_for_check, then check_mesh");
}
BENCHMARK(BM_ReadAndCheckJacksboro)
    ->ArgsProduct({{1, 10}, {1, 0}})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
