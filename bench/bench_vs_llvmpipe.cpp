// Side by side: tessref's primitive generator against the one in Mesa llvmpipe (OSMesa,
// transform feedback), on the same level sets.
//
//   bench_vs_llvmpipe [--reps N] [--copies N]
//       For quads / triangles / isolines x the three spacings, with and without point mode,
//       the uniform level sets 1, 2, ..., 64 (each repeated --copies times): the time of
//       tessref::tessellate() (Precision::gpu, cold: no PatternCache) and of
//       tessref::gl::capture_patterns() (draws, transform-feedback readback, attribution
//       to patches; context creation and shader compilation excluded by a warm-up call).
//       Medians over --reps repetitions. Both run on one thread of this machine.
//
//   bench_vs_llvmpipe --dump DOMAIN SPACING WINDING POINT_MODE O0 O1 O2 O3 I0 I1
//       Prints what llvmpipe emits for one level set (one primitive a line, coordinates
//       as %.9g and as float bits) and tessref's primitive count: a debugging aid.
//       Levels accept nan, inf, -inf and hexadecimal floats (0x1.0002p+0).
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "tessref/error.h"
#include "tessref/gl_backend.h"
#include "tessref/tessellator.h"

namespace {

using Clock = std::chrono::steady_clock;
using tessref::Domain;
using tessref::Spacing;
using tessref::TessLevels;
using tessref::TessSettings;
using tessref::Winding;

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

const char* domain_name(Domain d) {
    return d == Domain::quads ? "quads" : d == Domain::triangles ? "triangles" : "isolines";
}
const char* spacing_name(Spacing s) {
    return s == Spacing::equal ? "equal" : s == Spacing::fractional_odd ? "fractional_odd"
                                                                         : "fractional_even";
}

int run_table(int reps, int copies) {
    auto context = tessref::gl::Context::create();
    std::printf("GL_RENDERER: %s\nGL_VERSION:  %s\n", context.renderer().c_str(),
                context.version().c_str());
    std::printf("level sets: uniform 1..64, x%d copies; medians of %d repetitions; "
                "tessref: tessellate(), gpu precision, no cache; llvmpipe: capture_patterns()\n\n",
                copies, reps);
    std::printf("%-38s %10s %10s %16s %16s %8s\n", "config", "primitives", "points",
                "tessref points/s", "llvmpipe points/s", "ratio");

    std::vector<TessLevels> sets;
    for (int c = 0; c < copies; ++c)
        for (int n = 1; n <= 64; ++n) {
            const float f = static_cast<float>(n);
            TessLevels l;
            l.outer = {f, f, f, f};
            l.inner = {f, f};
            sets.push_back(l);
        }

    for (bool point_mode : {false, true})
        for (Domain d : {Domain::quads, Domain::triangles, Domain::isolines})
            for (Spacing s : {Spacing::equal, Spacing::fractional_odd, Spacing::fractional_even}) {
                const TessSettings settings{d, s, Winding::ccw, point_mode};
                std::size_t primitives = 0, points = 0, gl_primitives = 0;
                std::vector<double> cpu, gpu;
                tessref::gl::capture_patterns(context, settings,
                                              std::span<const TessLevels>(sets.data(), 1));
                for (int r = 0; r < reps; ++r) {
                    primitives = points = 0;
                    const auto t0 = Clock::now();
                    for (const TessLevels& l : sets) {
                        const tessref::Pattern p = tessref::tessellate(settings, l);
                        primitives += p.primitive_count();
                        points += p.points().size();
                    }
                    const auto t1 = Clock::now();
                    const auto captured = tessref::gl::capture_patterns(context, settings, sets);
                    const auto t2 = Clock::now();
                    gl_primitives = 0;
                    for (const auto& c : captured) gl_primitives += c.primitive_count();
                    cpu.push_back(std::chrono::duration<double>(t1 - t0).count());
                    gpu.push_back(std::chrono::duration<double>(t2 - t1).count());
                }
                // Both sides generate the same domain points (tests/test_gl_differential.cpp
                // holds them bit-identical), so both rates count the pattern's points.
                const double cpu_rate = static_cast<double>(points) / median(cpu);
                const double gl_rate = static_cast<double>(points) / median(gpu);
                std::string config = std::string(domain_name(d)) + " " + spacing_name(s) +
                                     (point_mode ? " point_mode" : "");
                std::printf("%-38s %10zu %10zu %16.3e %16.3e %7.2fx%s\n", config.c_str(),
                            primitives, points, cpu_rate, gl_rate, cpu_rate / gl_rate,
                            gl_primitives == primitives ? "" : "  (primitive counts differ!)");
                std::fflush(stdout);
            }
    std::printf("\npoints/s: the patterns' domain points per second (the same points on both sides);\n"
                "ratio = tessref rate / llvmpipe rate; in point mode primitives are points.\n");
    return 0;
}

int run_dump(const std::vector<std::string>& args) {
    TessSettings s;
    const auto domain = tessref::parse_domain(args[0]);
    const auto spacing = tessref::parse_spacing(args[1]);
    const auto winding = tessref::parse_winding(args[2]);
    if (!domain || !spacing || !winding)
        throw tessref::Error("unknown domain, spacing or winding (quads|triangles|isolines, "
                             "equal|fractional_odd|fractional_even, ccw|cw)");
    s.domain = *domain;
    s.spacing = *spacing;
    s.winding = *winding;
    s.point_mode = args[3] == "1" || args[3] == "true" || args[3] == "point_mode";
    TessLevels l;
    for (int i = 0; i < 6; ++i) {
        const std::string& text = args[static_cast<std::size_t>(4 + i)];
        char* end = nullptr;
        const float x = std::strtof(text.c_str(), &end);
        if (end == text.c_str() || *end != '\0') throw tessref::Error("bad level '" + text + "'");
        (i < 4 ? l.outer[static_cast<std::size_t>(i)] : l.inner[static_cast<std::size_t>(i - 4)]) = x;
    }
    auto context = tessref::gl::Context::create();
    std::printf("# %s\n# llvmpipe:\n", context.renderer().c_str());
    std::fputs(tessref::gl::dump(tessref::gl::capture_pattern(context, s, l)).c_str(), stdout);
    const tessref::Pattern p = tessref::tessellate(s, l);
    std::printf("# tessref: %zu primitives, %zu points%s\n", p.primitive_count(),
                p.points().size(), p.culled() ? " (culled)" : "");
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"tessref's primitive generator side by side with Mesa llvmpipe"};
    int reps = 7, copies = 4;
    std::vector<std::string> dump_args;
    app.add_option("--reps", reps, "repetitions (the median is reported)")->check(CLI::Range(1, 1000));
    app.add_option("--copies", copies, "copies of the level sets 1..64 per repetition")
        ->check(CLI::Range(1, 1000));
    app.add_option("--dump", dump_args,
                   "DOMAIN SPACING WINDING POINT_MODE O0 O1 O2 O3 I0 I1: dump llvmpipe's "
                   "output for one level set")
        ->expected(10);
    CLI11_PARSE(app, argc, argv);
    try {
        return dump_args.empty() ? run_table(reps, copies) : run_dump(dump_args);
    } catch (const tessref::Error& e) {
        std::fprintf(stderr, "bench_vs_llvmpipe: error: %s\n", e.message().c_str());
        return 2;
    }
}
