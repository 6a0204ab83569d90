// tessref check — watertightness and crack checks for any mesh (PLY, OBJ, OFF, STL).
// Exit status: 0 the mesh passes, 1 it has defects, 2 it cannot be read.
#include <cmath>
#include <cstdio>
#include <functional>
#include <iostream>
#include <optional>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "common/input_file.h"
#include "image/image_io.h"
#include "tessref/capture.h"
#include "tessref/check.h"
#include "tessref/error.h"
#include "tessref/mesh_io.h"

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
    std::string weld_tolerance;  // captures; empty: bitwise
};

// A PLY that `tessref gl --capture` or `tessref mesh --capture` wrote: its header lists the
// capture's vertex properties (a welded export of `tessref mesh` lists them too; read_capture
// then refuses it, and it is checked as the mesh it is).
bool ply_with_capture_properties(const std::string& path) {
    std::string header;
    try {
        header = InputFile(path, "mesh file").head(8192);  // never blocks on a FIFO
    } catch (const Error&) {
        return false;  // the mesh reader names what is wrong with it
    }
    const std::size_t end = header.find("end_header");
    if (header.rfind("ply", 0) != 0 || end == std::string::npos) return false;
    header.resize(end);
    return header.find(" patch_id\n") != std::string::npos && header.find(" tess_u\n") != std::string::npos;
}

// What `path` holds, when reading it to tell was reading it: a capture (a .txt, or a .ply
// with the capture's properties that capture_from_ply_mesh takes), or a PLY with those
// properties that is not a capture (a welded export of `tessref mesh`), read once and
// checked as the mesh it is. Neither for any other file.
struct CheckInput {
    std::optional<Capture> capture;
    std::optional<IndexedMesh> mesh;
};

// Whether capture_from_ply_mesh could take `mesh` once its normals and tess coords are read
// too: it refuses a PLY without patch ids (or without tess coords or normals, which the
// second reading finds out), a face that is not a triangle, and a face whose corners belong
// to different patches (a welded export's faces along a patch border).
bool may_be_capture(const IndexedMesh& mesh) {
    if (mesh.patch_ids.empty()) return false;
    for (std::size_t f = 0; f < mesh.face_count(); ++f) {
        const auto face = mesh.face(f);
        if (face.size() != 3) return false;
        for (const std::uint32_t v : face)
            if (mesh.patch_ids[v] != mesh.patch_ids[face[0]]) return false;
    }
    return true;
}

CheckInput input_to_check(const std::string& path, const std::function<void(double)>& read_progress) {
    if (!is_capture_path(path)) return {};
    if (capture_format_from_path(path) == CaptureFormat::text) return {read_capture(path), std::nullopt};
    if (!ply_with_capture_properties(path)) return {};
    // First as read_and_check_mesh() reads it: the positions, faces and patch ids, without
    // the normals, uvs and tess coords that only a capture needs (on a 2.4 M-triangle
    // export, 38 MB of fresh pages and a tenth of the check's time). A welded export is then
    // checked as read; only what may be a capture is read again with them.
    MeshFileOptions read_options;
    read_options.provenance = true;
    read_options.tess_coords = false;
    read_options.progress = read_progress;
    IndexedMesh mesh;
    try {
        mesh = read_mesh_file(path, read_options);
    } catch (const Error&) {
        return {};  // the check's reading names what is wrong with it
    }
    if (!may_be_capture(mesh)) return {std::nullopt, std::move(mesh)};
    read_options.vertex_attributes = true;  // read_capture's, with the check's progress
    read_options.tess_coords = true;
    try {
        return {capture_from_ply_mesh(read_mesh_file(path, read_options), path), std::nullopt};
    } catch (const Error&) {
    }
    return {std::nullopt, std::move(mesh)};
}

std::string short_number(double x) {
    char text[32];
    std::snprintf(text, sizeof text, "%.7g", x);
    return text;
}

std::string vec_text(const glm::dvec3& p) {
    return "(" + short_number(p.x) + ", " + short_number(p.y) + ", " + short_number(p.z) + ")";
}

std::string crack_text(const SharedEdgeCrack& c, bool levels) {
    const auto level = [&](std::uint32_t patch, int side, float value) {
        return "patch " + std::to_string(patch) + " outer[" + std::to_string(side) + "]" +
               (levels ? " = " + format_float_short(value) : std::string());
    };
    return level(c.patch_a, c.side_a, c.level_a) + ", " + level(c.patch_b, c.side_b, c.level_b) +
           ": their shared edge cracks (" + std::to_string(c.points_a) + " and " + std::to_string(c.points_b) +
           " vertices on it), from " + vec_text(c.from) + " to " + vec_text(c.to);
}

// --tolerance as typed: a finite distance >= 0. Read here rather than by CLI11, whose
// range check words its message with DBL_MAX written out (309 digits) and lets NaN by.
double parse_distance(const std::string& text, const std::string& flag) {
    const std::optional<double> value = parse_double(text);
    if (!value) throw Error("'" + text + "' is not a number", Where::in_file(flag));
    if (!std::isfinite(*value) || *value < 0.0)
        throw Error("'" + text + "' is not a distance: give a finite number >= 0", Where::in_file(flag));
    return *value;
}

int run_check(const CheckCommandOptions& options) {
    // Flags first: nothing is read for a command line that cannot succeed.
    const std::optional<double> tolerance =
        options.tolerance.empty() ? std::nullopt : std::optional<double>(parse_distance(options.tolerance, "--tolerance"));
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
    const std::optional<double> weld =
        options.weld_tolerance.empty() ? std::nullopt : std::optional<double>(parse_distance(options.weld_tolerance, "--weld-tolerance"));
    // A capture is welded first (each patch emits its own copies of its vertices), and its
    // patches' sides are held against each other.
    const auto read_progress = [&progress](double fraction) { progress("check: reading", fraction); };
    CheckInput input = input_to_check(options.mesh, read_progress);
    const std::optional<Capture>& capture = input.capture;
    if (weld && !capture)
        throw Error("--weld-tolerance welds a capture (.txt, or .ply of --capture); " + options.mesh + " is a mesh",
                    Where::in_file("--weld-tolerance"));
    const double weld_distance = weld ? *weld : 0.0;
    std::vector<SharedEdgeCrack> cracks;
    if (capture) cracks = shared_edge_cracks(*capture);
    // read_mesh_for_check() and check_mesh(), with OpenMesh's import skipped where it cannot refuse a face.
    const CheckedMesh checked =
        capture      ? check_indexed_mesh(weld_capture(*capture, weld_distance, options.mesh), check)
        : input.mesh ? check_indexed_mesh(std::move(*input.mesh), check)
                     : read_and_check_mesh(options.mesh, check, read_progress);
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
    const bool passed = report.passed && cracks.empty();
    if (options.json) {
        nlohmann::json j = nlohmann::json::parse(report_json(report));
        if (capture) {
            j["capture"] = {{"triangles", capture->vertices.size() / 3},
                            {"weld_tolerance", weld_distance},
                            {"welded_vertices", mesh.vertex_count()}};
            j["shared_edge_cracks"] = nlohmann::json::array();
            for (const SharedEdgeCrack& c : cracks)
                j["shared_edge_cracks"].push_back(
                    {{"patches", {c.patch_a, c.patch_b}},
                     {"outer", {c.side_a, c.side_b}},
                     {"levels", capture->has_levels ? nlohmann::json{c.level_a, c.level_b} : nlohmann::json(nullptr)},
                     {"vertices_on_edge", {c.points_a, c.points_b}},
                     {"from", {c.from.x, c.from.y, c.from.z}},
                     {"to", {c.to.x, c.to.y, c.to.z}}});
            j["passed"] = passed;
        }
        std::cout << j.dump(2) << "\n" << std::flush;
    } else {
        std::string text;
        if (capture) {
            text += "capture " + options.mesh + ": " + std::to_string(capture->vertices.size() / 3) +
                    " triangles, their " + std::to_string(capture->vertices.size()) + " corners welded " +
                    (weld_distance > 0 ? "within " + short_number(weld_distance) : std::string("bitwise")) +
                    " into " + std::to_string(mesh.vertex_count()) + " vertices (ids below are the welded mesh's, 0-based)\n";
            text += "shared edges whose sides the two patches tessellated differently: " + std::to_string(cracks.size()) + "\n";
            for (std::size_t k = 0; k < cracks.size() && k < 20; ++k) text += "  " + crack_text(cracks[k], capture->has_levels) + "\n";
            if (cracks.size() > 20) text += "  ... and " + std::to_string(cracks.size() - 20) + " more\n";
        }
        std::cout << text << report_text(report) << (capture && report.passed && !passed ? "FAIL: shared edges crack\n" : "")
                  << std::flush;
    }
    return passed ? 0 : 1;
}

}  // namespace

Command add_check_command(CLI::App& parent) {
    auto options = std::make_shared<CheckCommandOptions>();
    CLI::App* app = parent.add_subcommand(
        "check",
        "Check a mesh (PLY, OBJ, OFF, STL) for holes, cracks, T-junctions, non-manifold edges and vertices, "
        "flipped or degenerate or duplicate faces and unwelded vertices, with an Embree ray-cast probe. "
        "Exit status 0: it passes, 1: it has defects, 2: it cannot be read.");
    app->add_option("mesh", options->mesh,
                    "The mesh file, or a capture (.txt, or the unwelded .ply of --capture): welded first (bitwise, "
                    "or --weld-tolerance), and its patches' shared edges checked for differing tessellations")
        ->required();
    app->add_option("--weld-tolerance", options->weld_tolerance,
                    "Captures: weld corners within this distance instead of bitwise-equal ones")
        ->type_name("DISTANCE");
    app->add_option("--expect", options->expect,
                    "closed: no boundary edge at all; open: boundary edges only as one outer outline (a terrain); "
                    "auto: closed unless the mesh is open and looks like a terrain, and on an open mesh that does "
                    "not, per component (an open sheet seen from one side, a plate under a model, may have its "
                    "outline)")
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
