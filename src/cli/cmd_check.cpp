// tessref check — watertightness and crack checks for any mesh (PLY, OBJ, OFF, STL).
// Exit status: 0 the mesh passes, 1 it has defects, 2 it cannot be read.
#include <cmath>
#include <iostream>
#include <optional>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "image/image_io.h"
#include "tessref/check.h"
#include "tessref/error.h"

namespace tessref::cli {

namespace {

struct CheckCommandOptions {
    std::string mesh;
    std::string expect = "auto";
    std::string tolerance;  // empty: the default, relative to the mesh size
    bool json = false;
    std::string image;
    int probe_resolution = 512;
    bool no_probe = false;
    std::size_t max_locations = 1000;
};

// --tolerance as typed: a finite distance >= 0. Read here rather than by CLI11, whose
// range check words its message with DBL_MAX written out (309 digits) and lets NaN by.
double parse_tolerance(const std::string& text) {
    const std::optional<double> value = parse_double(text);
    if (!value) throw Error("'" + text + "' is not a number", Where::in_file("--tolerance"));
    if (!std::isfinite(*value) || *value < 0.0)
        throw Error("'" + text + "' is not a distance: give a finite number >= 0", Where::in_file("--tolerance"));
    return *value;
}

int run_check(const CheckCommandOptions& options) {
    // Flags first: nothing is read for a command line that cannot succeed.
    const std::optional<double> tolerance =
        options.tolerance.empty() ? std::nullopt : std::optional<double>(parse_tolerance(options.tolerance));
    if (!options.image.empty()) image::require_writable(options.image, "--image");
    StageProgress progress;
    CheckOptions check;
    check.expect = options.expect == "closed" ? Expect::closed : options.expect == "open" ? Expect::open : Expect::automatic;
    if (tolerance) check.tolerance = *tolerance;
    check.ray_probe = !options.no_probe;
    check.probe_resolution = options.probe_resolution;
    check.max_locations = options.max_locations;
    check.progress = [&progress](std::string_view name, double fraction) {
        progress("check: " + std::string(name), fraction);
    };
    // read_mesh_for_check() and check_mesh(), with OpenMesh's import skipped where it cannot refuse a face.
    const CheckedMesh checked = read_and_check_mesh(
        options.mesh, check, [&progress](double fraction) { progress("check: reading", fraction); });
    const IndexedMesh& mesh = checked.mesh;
    const CheckReport& report = checked.report;
    progress = StageProgress();  // clears the last stage's line

    if (!options.image.empty()) {
        AtomicOutput output(options.image);
        try {
            write_defect_image(mesh, report, output.temp_path().string());
        } catch (const Error& error) {
            throw Error(error.what(), Where::in_file(options.image));  // the name given, not the temporary one
        }
        output.commit();
    }
    std::cout << (options.json ? report_json(report) : report_text(report)) << std::flush;
    return report.passed ? 0 : 1;
}

}  // namespace

Command add_check_command(CLI::App& parent) {
    auto options = std::make_shared<CheckCommandOptions>();
    CLI::App* app = parent.add_subcommand(
        "check",
        "Check a mesh (PLY, OBJ, OFF, STL) for holes, cracks, T-junctions, non-manifold edges and vertices, "
        "flipped or degenerate or duplicate faces and unwelded vertices, with an Embree ray-cast probe. "
        "Exit status 0: it passes, 1: it has defects, 2: it cannot be read.");
    app->add_option("mesh", options->mesh, "The mesh file")->required();
    app->add_option("--expect", options->expect,
                    "closed: no boundary edge at all; open: boundary edges only as one outer outline (a terrain); "
                    "auto: closed unless the mesh is open and looks like a terrain")
        ->check(CLI::IsMember({"auto", "closed", "open"}))
        ->default_str("auto");
    app->add_option("--tolerance", options->tolerance,
                    "Distance under which vertices coincide, a vertex lies on an edge and a face is degenerate "
                    "(default: 1e-7 of the larger of the bounding box diagonal and the largest coordinate, about single-precision rounding)")
        ->type_name("DISTANCE");
    app->add_flag("--json", options->json, "Print the whole report as JSON");
    app->add_option("--image", options->image, "Write a top view with the defects marked (PNG, or any image OpenImageIO writes: .tif, .exr, ...)");
    app->add_option("--probe-resolution", options->probe_resolution, "Rays per side of the ray-cast probe's grid")
        ->check(CLI::Range(1, 8192))
        ->default_str("512");
    app->add_flag("--no-probe", options->no_probe, "Skip the ray-cast probe");
    app->add_option("--max-locations", options->max_locations, "Located defects kept per class (counts stay exact)")
        ->default_str("1000");
    return Command{app, [options] { return run_check(*options); }};
}

}  // namespace tessref::cli
