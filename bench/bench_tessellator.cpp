// Google Benchmark of the primitive generator, cold (no cache): points generated per
// second for uniform levels 1..64, per domain and spacing, in both precisions.
//   build/bench_tessellator --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include "tessref/tessellator.h"

namespace {

void BM_Tessellate(benchmark::State& state) {
    tessref::TessSettings settings;
    settings.domain = static_cast<tessref::Domain>(state.range(0));
    settings.spacing = static_cast<tessref::Spacing>(state.range(1));
    const auto precision = static_cast<tessref::Precision>(state.range(2));
    // Every level 1..64 (plus a fractional offset for the fractional spacings) once per
    // iteration: the cost of a terrain whose patches use all levels.
    const float offset = settings.spacing == tessref::Spacing::equal ? 0.0f : 0.37f;
    std::size_t points = 0;
    for (auto _ : state) {
        for (int level = 1; level <= 64; ++level) {
            tessref::TessLevels levels;
            const float x = static_cast<float>(level) - offset;
            levels.outer = {x, x, x, x};
            levels.inner = {x, x};
            tessref::Pattern p = tessref::tessellate(settings, levels, precision);
            points += p.points().size();
            benchmark::DoNotOptimize(p.indices().data());
        }
    }
    state.counters["points/s"] = benchmark::Counter(static_cast<double>(points), benchmark::Counter::kIsRate);
    state.SetLabel(std::string(tessref::to_string(settings.domain)) + "/" +
                   std::string(tessref::to_string(settings.spacing)) + "/" +
                   std::string(tessref::to_string(precision)));
}

BENCHMARK(BM_Tessellate)
    ->ArgsProduct({{0, 1, 2}, {0, 1, 2}, {0, 1}})
    ->ArgNames({"domain", "spacing", "precision"})
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
