// Google Benchmark of mesh export (tessref::write_mesh: bitwise weld, OpenMesh kernel,
// OpenMesh writer) on a synthetic terrain: patches emitting their own vertex copies, as
// the pipeline does.
//   build/bench_mesh --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>

#include "tessref/mesh.h"

namespace {

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

// Export only: 16 x 16 patches at level 64 (2.1 M triangles) to memory.
void BM_ExportSynthetic(benchmark::State& state) {
    const auto format = static_cast<tessref::MeshFormat>(state.range(0));
    const bool binary = state.range(1) != 0;
    const tessref::SurfaceMesh mesh = synthetic_terrain(16, 64);
    tessref::MeshWriteOptions options;
    options.format = format;
    options.binary = binary;
    std::size_t triangles = 0, bytes = 0;
    for (auto _ : state) {
        std::ostringstream out;
        const tessref::MeshWriteReport report = tessref::write_mesh(mesh, out, options);
        triangles += report.triangles;
        bytes += out.str().size();
    }
    state.counters["triangles/s"] = benchmark::Counter(static_cast<double>(triangles), benchmark::Counter::kIsRate);
    state.counters["bytes/s"] = benchmark::Counter(static_cast<double>(bytes), benchmark::Counter::kIsRate);
    state.SetLabel(std::string(tessref::to_string(format)) + (binary ? " binary" : " ascii"));
}

BENCHMARK(BM_ExportSynthetic)
    ->Args({0, 0})
    ->Args({0, 1})
    ->Args({1, 0})
    ->Args({2, 1})
    ->Args({3, 1})
    ->ArgNames({"format", "binary"})
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
