// Google Benchmark of `tessref mesh`: the scene pipeline (control -> generator ->
// evaluation -> geometry) and the export (bitwise weld, OpenMesh kernel, OpenMesh writer).
//
//  - BM_MeshJacksboro: data/scenes/jacksboro.toml (the Jacksboro fault DEM, 24 x 24 patches,
//    thesis pipeline) with its control stage replaced by a uniform level 64, in gpu (float)
//    and exact (double) precision: the pipeline alone (export = 0); the pipeline's whole
//    surface welded and written as binary PLY to memory (export = 1, what `tessref mesh`
//    does with --capture or --solid); the surface welded as it is evaluated
//    (run_pipeline_welded) and written (export = 2, what `tessref mesh` does otherwise).
//    The scene is loaded once, outside the timing.
//    Counters: patches/s and triangles/s, per second of process CPU time (all threads).
//  - BM_ExportSynthetic / BM_WeldSynthetic: the export alone on a synthetic terrain; for
//    PLY also through OpenMesh's PLY writer (writer = 0, the reference tessref's own PLY
//    writer reproduces byte for byte; writer = 1 is write_mesh's), for a same-run ratio.
//
//   build/bench_mesh --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <ostream>
#include <streambuf>
#include <string>

#include "mesh/openmesh.h"
#include "tessref/mesh.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"

namespace {

// An output stream that counts the bytes written to it and keeps none: the benchmark
// measures producing the file, not the disk or a growing string.
class CountingBuffer : public std::streambuf {
public:
    std::size_t bytes() const { return bytes_; }

protected:
    int_type overflow(int_type c) override {
        if (!traits_type::eq_int_type(c, traits_type::eof())) ++bytes_;
        return traits_type::not_eof(c);
    }
    std::streamsize xsputn(const char*, std::streamsize n) override {
        bytes_ += static_cast<std::size_t>(n);
        return n;
    }

private:
    std::size_t bytes_ = 0;
};

// What the benchmark runs: the shipped scene, every level 64 (the spacing stays the scene's
// fractional_odd, which the generator clamps to 63: 63 x 63 quads, 7938 triangles a patch).
const tessref::Scene& jacksboro_level_64() {
    static const tessref::Scene scene = [] {
        tessref::Scene s = tessref::load_scene(std::string(TESSREF_DATA_DIR) + "/scenes/jacksboro.toml");
        tessref::ControlStage control;
        control.model = tessref::ControlModel::constant;
        control.constant.level = 64.0;
        s.control = control;
        return s;
    }();
    return scene;
}

// range(0): precision (0 gpu, 1 exact); range(1): 0 = the pipeline alone, 1 = the whole
// surface and its export, 2 = streamed into the weld and exported.
void BM_MeshJacksboro(benchmark::State& state) {
    const tessref::Scene& scene = jacksboro_level_64();
    tessref::PipelineOptions pipeline_options;
    pipeline_options.precision = static_cast<tessref::Precision>(state.range(0));
    const int mode = static_cast<int>(state.range(1));
    tessref::MeshWriteOptions write_options;
    write_options.format = tessref::MeshFormat::ply;
    write_options.binary = true;
    std::size_t patches = 0, triangles = 0;
    for (auto _ : state) {
        patches += scene.patch_count();
        CountingBuffer buffer;
        std::ostream out(&buffer);
        if (mode == 2) {
            const tessref::WeldedMesh welded = tessref::run_pipeline_welded(scene, pipeline_options);
            const tessref::MeshWriteReport report = tessref::write_mesh(welded, out, write_options);
            triangles += report.triangles + report.degenerate_triangles;  // the pipeline's count
            benchmark::DoNotOptimize(buffer.bytes());
            continue;
        }
        tessref::PipelineResult result = tessref::run_pipeline(scene, pipeline_options);
        triangles += result.mesh.triangles.size();
        if (mode == 1) {
            const tessref::MeshWriteReport report = tessref::write_mesh(result.mesh, out, write_options);
            benchmark::DoNotOptimize(report.triangles);
            benchmark::DoNotOptimize(buffer.bytes());
        }
        benchmark::DoNotOptimize(result.mesh.positions.data());
    }
    state.counters["patches/s"] = benchmark::Counter(static_cast<double>(patches), benchmark::Counter::kIsRate);
    state.counters["triangles/s"] = benchmark::Counter(static_cast<double>(triangles), benchmark::Counter::kIsRate);
    state.counters["triangles"] = benchmark::Counter(
        static_cast<double>(triangles) / static_cast<double>(std::max<benchmark::IterationCount>(state.iterations(), 1)));
    state.SetLabel(std::string(tessref::to_string(pipeline_options.precision)) +
                   (mode == 2   ? " streamed weld+export(ply binary)"
                    : mode == 1 ? " pipeline+export(ply binary)"
                                : " pipeline only"));
}

BENCHMARK(BM_MeshJacksboro)
    ->ArgsProduct({{0, 1}, {2, 1, 0}})
    ->ArgNames({"exact", "export"})
    ->Unit(benchmark::kMillisecond)
    // CPU time of the whole process (the pipeline runs on TBB workers): the rates are per
    // CPU second, which a machine shared with other work disturbs less than wall time.
    ->MeasureProcessCPUTime();

// side x side quad patches at uniform `level`, each with its own (level+1)^2 vertices;
// positions are float-exact (as the gpu path produces), heights a smooth bump.
tessref::SurfaceMesh synthetic_terrain(int side, int level) {
    tessref::SurfaceMesh mesh;
    const std::size_t per_patch = static_cast<std::size_t>(level + 1) * (level + 1);
    const std::size_t patches = static_cast<std::size_t>(side) * side;
    mesh.positions.reserve(patches * per_patch);
    mesh.normals.reserve(patches * per_patch);
    mesh.uvs.reserve(patches * per_patch);
    mesh.patch_ids.reserve(patches * per_patch);
    mesh.tess_coords.reserve(patches * per_patch);
    mesh.triangles.reserve(patches * 2 * level * level);
    std::uint32_t patch = 0;
    for (int py = 0; py < side; ++py) {
        for (int px = 0; px < side; ++px, ++patch) {
            const auto base = static_cast<std::uint32_t>(mesh.positions.size());
            for (int j = 0; j <= level; ++j) {
                for (int i = 0; i <= level; ++i) {
                    const float u = static_cast<float>(i) / static_cast<float>(level);
                    const float v = static_cast<float>(j) / static_cast<float>(level);
                    const float x = static_cast<float>(px) + u, y = static_cast<float>(py) + v;
                    const float z = std::sin(0.3f * x) * std::cos(0.2f * y);
                    mesh.positions.emplace_back(x, y, z);
                    mesh.normals.emplace_back(0.0, 0.0, 1.0);
                    mesh.uvs.emplace_back(x / static_cast<float>(side), y / static_cast<float>(side));
                    mesh.patch_ids.push_back(patch);
                    mesh.tess_coords.emplace_back(u, v, 0.0f);
                }
            }
            const auto row = static_cast<std::uint32_t>(level + 1);
            for (std::uint32_t j = 0; j < static_cast<std::uint32_t>(level); ++j) {
                for (std::uint32_t i = 0; i < static_cast<std::uint32_t>(level); ++i) {
                    const std::uint32_t a = base + j * row + i;
                    mesh.triangles.push_back({a, a + 1, a + row + 1});
                    mesh.triangles.push_back({a, a + row + 1, a + row});
                }
            }
        }
    }
    return mesh;
}

// Export only: 16 x 16 patches at level 64 (2.1 M triangles), bytes counted and dropped.
void BM_ExportSynthetic(benchmark::State& state) {
    const auto format = static_cast<tessref::MeshFormat>(state.range(0));
    const bool binary = state.range(1) != 0;
    const bool openmesh_writer = state.range(2) == 0;
    const tessref::SurfaceMesh mesh = synthetic_terrain(16, 64);
    tessref::MeshWriteOptions options;
    options.format = format;
    options.binary = binary;
    std::size_t triangles = 0, bytes = 0;
    for (auto _ : state) {
        CountingBuffer buffer;
        std::ostream out(&buffer);
        const tessref::MeshWriteReport report = openmesh_writer
                                                    ? tessref::mesh_detail::write_mesh_through_openmesh(mesh, out, options)
                                                    : tessref::write_mesh(mesh, out, options);
        triangles += report.triangles;
        bytes += buffer.bytes();
    }
    state.counters["triangles/s"] = benchmark::Counter(static_cast<double>(triangles), benchmark::Counter::kIsRate);
    state.counters["bytes/s"] = benchmark::Counter(static_cast<double>(bytes), benchmark::Counter::kIsRate);
    state.SetLabel(std::string(tessref::to_string(format)) + (binary ? " binary" : " ascii") +
                   (format == tessref::MeshFormat::ply ? (openmesh_writer ? ", OpenMesh's writer" : ", tessref's writer")
                                                       : ""));
}

BENCHMARK(BM_ExportSynthetic)
    ->Args({0, 0, 1})
    ->Args({0, 0, 0})
    ->Args({0, 1, 1})
    ->Args({0, 1, 0})
    ->Args({1, 0, 1})
    ->Args({2, 1, 1})
    ->Args({3, 1, 1})
    ->ArgNames({"format", "binary", "writer"})
    ->Unit(benchmark::kMillisecond);

// Welding alone on the same mesh.
void BM_WeldSynthetic(benchmark::State& state) {
    const tessref::SurfaceMesh mesh = synthetic_terrain(16, 64);
    for (auto _ : state) {
        tessref::WeldedMesh welded = tessref::weld_bitwise(mesh);
        benchmark::DoNotOptimize(welded.mesh.positions.data());
    }
    state.counters["vertices/s"] = benchmark::Counter(
        static_cast<double>(mesh.positions.size()) * static_cast<double>(state.iterations()),
        benchmark::Counter::kIsRate);
}

BENCHMARK(BM_WeldSynthetic)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
