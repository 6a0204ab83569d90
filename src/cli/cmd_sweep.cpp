// tessref sweep — the speed/accuracy trade of tessellation levels, measured
// (src/sweep/sweep.h, docs/SWEEP.md):
//
//   tessref sweep SCENE... -o DIR [--levels 1,2,4,8,16,32,64 | --levels 1..64]
//                 [--precision gpu,exact] [--spacing equal,fractional_odd,fractional_even]
//                 [--geomip-levels 0..4] [--error-bounds 0,0.5,1,2,4,8]
//                 [--repeat N] [--shard I/N] [--size WxH] [--threads N]
//                 [--shader STAGE=FILE] [--max-instructions N]
//   tessref sweep merge DIR... -o OUT
//
// Every flag is checked and every scene loaded before anything runs; DIR is written into a
// temporary directory beside it and renamed into place at the end. Without --shard, a
// SLURM job array (SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_COUNT, SLURM_ARRAY_TASK_MIN) picks
// the shard.
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "sweep/sweep.h"
#include "tessref/error.h"

namespace tessref::cli {

namespace {

// The default levels: the powers of two 1..64 (see docs/SWEEP.md, "Levels").
constexpr const char* kDefaultLevels = "1,2,4,8,16,32,64";
// A geomipmapped scene's axes (docs/SWEEP.md, "Geomipmapped scenes").
constexpr const char* kDefaultGeomipLevels = "0..4";
constexpr const char* kDefaultErrorBounds = "0,0.5,1,2,4,8";

struct SweepCommandOptions {
    std::vector<std::string> scenes;
    std::vector<std::string> shaders;  // --shader STAGE=FILE, as typed
    std::string max_instructions;      // empty: the interpreter's default
    std::string output;
    std::string levels = kDefaultLevels;
    std::string geomip_levels = kDefaultGeomipLevels;
    std::string error_bounds = kDefaultErrorBounds;
    std::string precision = "gpu";
    std::string camera_relative = "off";
    std::string spacing;  // empty: each scene's own
    int repeat = 3;  // the median of three: see docs/SWEEP.md, "Timings"
    std::string shard;
    std::string size = "320x200";
    int threads = 0;
    std::vector<std::string> merge_dirs;
    std::string merge_output;
};

using sweep::split_list;

// "I/N" with 0 <= I < N.
sweep::Shard parse_shard(const std::string& text, const std::string& where) {
    const std::size_t slash = text.find('/');
    const std::optional<long long> i = slash == std::string::npos ? std::nullopt : parse_integer(text.substr(0, slash));
    const std::optional<long long> n = slash == std::string::npos ? std::nullopt : parse_integer(text.substr(slash + 1));
    if (!i || !n) throw Error("'" + text + "' is not a shard I/N (e.g. 0/4)", Where::in_file(where));
    if (*n < 1 || *n > 1'000'000 || *i < 0 || *i >= *n)
        throw Error("'" + text + "': a shard I/N needs N >= 1 and 0 <= I < N", Where::in_file(where));
    return {static_cast<int>(*i), static_cast<int>(*n)};
}

// The shard of a SLURM job array task: SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN (0 when
// unset) of SLURM_ARRAY_TASK_COUNT. No array: the whole sweep.
sweep::Shard shard_from_environment() {
    const char* id = std::getenv("SLURM_ARRAY_TASK_ID");
    if (!id) return {};
    const char* count = std::getenv("SLURM_ARRAY_TASK_COUNT");
    const char* min = std::getenv("SLURM_ARRAY_TASK_MIN");
    const auto integer = [](const char* text, const char* name) {
        const std::optional<long long> v = parse_integer(text ? text : "");
        if (!v) throw Error("'" + std::string(text ? text : "") + "' is not an integer", Where::in_file(name));
        return *v;
    };
    if (!count)
        throw Error("SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not", Where::in_file("SLURM_ARRAY_TASK_COUNT"));
    const long long task = integer(id, "SLURM_ARRAY_TASK_ID");
    const long long n = integer(count, "SLURM_ARRAY_TASK_COUNT");
    const long long offset = min ? integer(min, "SLURM_ARRAY_TASK_MIN") : 0;
    const long long i = task - offset;
    if (n < 1 || n > 1'000'000 || i < 0 || i >= n)
        throw Error("task " + std::to_string(task) + " (minus SLURM_ARRAY_TASK_MIN " + std::to_string(offset) +
                        ") is not one of 0 .. SLURM_ARRAY_TASK_COUNT - 1 = " + std::to_string(n - 1) +
                        " (job arrays with a step other than 1 are not supported)",
                    Where::in_file("SLURM_ARRAY_TASK_ID"));
    return {static_cast<int>(i), static_cast<int>(n)};
}

// Progress on stderr: a bar redrawn in place on a terminal, one line per row otherwise.
class RowProgress {
public:
    RowProgress() : terminal_(stderr_is_terminal()) {}
    ~RowProgress() {
        if (terminal_ && drawn_) std::fprintf(stderr, "\r\033[K");
    }
    void operator()(std::size_t done, std::size_t total, const std::string& row) {
        if (terminal_) {
            constexpr int kWidth = 30;
            const int filled = total ? static_cast<int>(kWidth * done / total) : kWidth;
            std::fprintf(stderr, "\rsweep [%s%s] %zu/%zu %s\033[K", std::string(static_cast<std::size_t>(filled), '#').c_str(),
                         std::string(static_cast<std::size_t>(kWidth - filled), '.').c_str(), done, total, row.c_str());
            drawn_ = true;
        } else if (!row.empty()) {
            std::fprintf(stderr, "tessref sweep: row %zu/%zu: %s\n", done + 1, total, row.c_str());
        }
        std::fflush(stderr);
    }

private:
    bool terminal_ = false;
    bool drawn_ = false;
};

int run_sweep_command(const SweepCommandOptions& o) {
    sweep::SweepParameters p;
    p.scenes = o.scenes;
    if (p.scenes.empty()) throw Error("no scene given: tessref sweep SCENE... -o DIR", Where::in_file("command line"));
    if (o.output.empty()) throw Error("no output directory given", Where::in_file("-o"));
    p.shaders = parse_shader_flags(o.shaders);
    apply_max_instructions_flag(o.max_instructions);
    p.levels = sweep::parse_levels(o.levels);
    p.geomip_levels = sweep::parse_geomip_levels(o.geomip_levels);
    p.error_bounds = sweep::parse_error_bounds(o.error_bounds);
    for (const std::string& item : split_list(o.precision, "--precision")) {
        const Precision precision = parse_precision_flag(item);
        if (std::find(p.precisions.begin(), p.precisions.end(), precision) == p.precisions.end())
            p.precisions.push_back(precision);
    }
    p.camera_relative.clear();
    for (const std::string& item : split_list(o.camera_relative, "--camera-relative")) {
        if (item != "off" && item != "on")
            throw Error("--camera-relative takes off, on or off,on, not '" + item + "'", Where::in_file("--camera-relative"));
        const bool relative = item == "on";
        if (std::find(p.camera_relative.begin(), p.camera_relative.end(), relative) == p.camera_relative.end())
            p.camera_relative.push_back(relative);
    }
    if (!o.spacing.empty()) {
        for (const std::string& item : split_list(o.spacing, "--spacing")) {
            const std::optional<Spacing> spacing = parse_spacing(item);
            if (!spacing)
                throw Error("unknown spacing '" + item + "'; expected equal, fractional_odd or fractional_even",
                            Where::in_file("--spacing"));
            if (std::find(p.spacings.begin(), p.spacings.end(), *spacing) == p.spacings.end())
                p.spacings.push_back(*spacing);
        }
    }
    if (o.repeat < 1 || o.repeat > 1000)
        throw Error("--repeat takes 1..1000, got " + std::to_string(o.repeat), Where::in_file("--repeat"));
    p.repeat = o.repeat;
    p.size = parse_image_size(o.size);
    const sweep::Shard shard = o.shard.empty() ? shard_from_environment() : parse_shard(o.shard, "--shard");
    const ThreadLimit thread_limit(o.threads);
    std::size_t rows = 0;
    {
        RowProgress progress;
        rows = sweep::run_sweep(p, shard, o.output,
                                [&progress](std::size_t done, std::size_t total, const std::string& row) {
                                    progress(done, total, row);
                                });
    }
    std::cout << o.output << ": " << rows << " rows";
    if (shard.count > 1) std::cout << " (shard " << shard.index << "/" << shard.count << ")";
    std::cout << ", sweep.csv and the report\n";
    return 0;
}

}  // namespace

Command add_sweep_command(CLI::App& parent) {
    auto options = std::make_shared<SweepCommandOptions>();
    CLI::App* app = parent.add_subcommand(
        "sweep",
        "Measure the speed/accuracy trade of tessellation levels: every scene at every uniform level, spacing and "
        "precision, plus its own control stage (a geomipmapped terrain: at forced geomip levels and screen-error "
        "bounds); per row the stage timings, the geometric error against the "
        "full-resolution height field, the image error against the ray-traced ground truth, pictures at chosen "
        "levels. Writes DIR/sweep.csv and a report (docs/SWEEP.md).");
    app->add_option("scenes", options->scenes, "Scene files (TOML)");
    app->add_option("-o,--output", options->output, "Output directory (created; an earlier sweep's is replaced)");
    app->add_option("--levels", options->levels,
                    "Uniform levels: numbers and integer ranges A..B, comma-separated, each in 1..64")
        ->default_str(kDefaultLevels);
    app->add_option("--geomip-levels", options->geomip_levels,
                    "Geomipmapped scenes: forced levels (every patch at the level), integers and ranges A..B in "
                    "0..4, or none")
        ->default_str(kDefaultGeomipLevels);
    app->add_option("--error-bounds", options->error_bounds,
                    "Geomipmapped scenes: screen-error bounds in pixels (evaluation.error_bound_px), comma-separated, "
                    "each in [0, 1e6], or none")
        ->default_str(kDefaultErrorBounds);
    app->add_option("--precision", options->precision, "Precisions, comma-separated: gpu, exact")->default_str("gpu");
    app->add_option("--spacing", options->spacing,
                    "Spacings of the uniform rows, comma-separated: equal, fractional_odd, fractional_even "
                    "(default: each scene's own)");
    app->add_option("--camera-relative", options->camera_relative,
                    "Camera-relative evaluation (render --camera-relative), comma-separated: off, on; off,on runs "
                    "every row both ways")
        ->default_str("off");
    add_cpu_shader_options(*app, options->shaders, options->max_instructions);
    app->add_option("--repeat", options->repeat, "Runs per row; timings are the median")->default_val(3);
    app->add_option("--shard", options->shard,
                    "Run shard I of N (0 <= I < N) into DIR (default: SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN of "
                    "SLURM_ARRAY_TASK_COUNT when set, else everything)")
        ->type_name("I/N");
    app->add_option("--size", options->size, "Image size WIDTHxHEIGHT (replaces the cameras' viewports)")
        ->default_str("320x200")
        ->type_name("WxH");
    app->add_option("--threads", options->threads,
                    "Worker threads (0: every core); every output but the timings is the same whatever the count")
        ->default_val(0);
    CLI::App* merge = app->add_subcommand(
        "merge", "Join the shard directories of one sweep into one directory: sweep.csv as the unsharded run writes "
                 "it (timings aside), the pictures, the report");
    merge->add_option("dirs", options->merge_dirs, "Shard directories")->required();
    merge->add_option("-o,--output", options->merge_output, "Output directory")->required();
    app->require_subcommand(0, 1);
    app->footer("Example: tessref sweep data/scenes/jacksboro.toml --levels 1,2,4,8,16,32,64 --precision gpu,exact "
                "-o sweep-out");
    return Command{app, [options, merge] {
                       if (merge->parsed()) {
                           if (!options->scenes.empty() || !options->output.empty())
                               throw Error("'tessref sweep merge' takes shard directories and -o only",
                                           Where::in_file("command line"));
                           sweep::merge_sweeps(options->merge_dirs, options->merge_output);
                           std::cout << options->merge_output << ": merged " << options->merge_dirs.size()
                                     << " shards\n";
                           return 0;
                       }
                       return run_sweep_command(*options);
                   }};
}

}  // namespace tessref::cli
