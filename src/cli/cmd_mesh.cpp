// tessref mesh — runs a scene's pipeline and writes the tessellated surface as a mesh file
// (PLY with tessref's writer, byte for byte OpenMesh's; OBJ, OFF, STL through OpenMesh; see
// include/tessref/mesh.h for what each carries and how vertices are welded).
//
//   tessref mesh SCENE [-o OUT.{ply,obj,off,stl}] [--capture CAP.{txt,ply}] [--precision gpu|exact] [--math exact|llvmpipe]
//                [--binary] [--solid [--base B]] [--threads N] [--camera-relative]
//
// --capture writes the CPU reference's capture (tessref/capture.h), the layout `tessref gl
// --capture` writes, for `tessref compare`. At least one of -o and --capture.
//
// Output goes to a temporary file next to OUT and is renamed over it only when complete;
// the output name is checked (extension, writable directory) before the pipeline runs.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

#include <CLI/CLI.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "common/stream_failure.h"
#include "tessref/capture.h"
#include "tessref/error.h"
#include "tessref/mesh.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"
#include "tessref/solid.h"
#include "tessref/tessellator.h"

namespace tessref::cli {

namespace {

struct MeshCommandOptions {
    std::string scene;
    std::string output;
    std::string capture;
    std::string precision = "gpu";
    std::string math = "exact";
    bool binary = false;
    int threads = 0;  // 0: every core
    bool solid = false;
    std::string base;  // --base as typed: the solid's bottom; empty: below the lowest vertex
    bool camera_relative = false;
    std::vector<std::string> shaders;  // --shader STAGE=FILE, as typed
    std::string max_instructions;      // empty: the interpreter's default
};

// Which of the writer's errors are reported at the output's name, the writer knowing a
// stream, not its name: those that name no file (a whole mesh's writer), or those thrown
// once the stream has failed (a streamed writer, whose other errors are the pipeline's and
// stay as they are).
enum class NameErrors { without_file, after_stream_failure };

// Writes the mesh file through `write` into the output's temporary file, with progress;
// returns what `write` returns.
template <typename Write>
auto write_mesh_file(const Write& write, const AtomicOutput& output, const std::string& name,
                     MeshWriteOptions write_options, NameErrors rule = NameErrors::without_file) {
    StageProgress stage_progress;
    write_options.progress = [&stage_progress](std::string_view stage, double fraction) {
        stage_progress(stage, fraction);
    };
    std::ofstream file(output.temp_path(), std::ios::binary | std::ios::trunc);
    if (!file) throw Error("cannot write output file", Where::in_file(name));
    decltype(write(file, write_options)) report;
    try {
        report = write(file, write_options);
    } catch (const Error& error) {
        const bool named = rule == NameErrors::without_file ? !error.where().file.empty() : bool(file);
        if (named) throw;
        throw Error(error.what(), Where::in_file(name));
    }
    file.close();
    if (!file) throw Error("cannot write output file: " + stream_failure(), Where::in_file(name));
    return report;
}

// write_pipeline_ply() into the output's temporary file, with progress: nothing (and no
// file content) where the scene does not stream.
std::optional<MeshWriteReport> stream_mesh_file(const Scene& scene, PipelineOptions pipeline_options,
                                                const AtomicOutput& output, const std::string& name,
                                                const MeshWriteOptions& write_options) {
    return write_mesh_file(
        [&](std::ostream& file, const MeshWriteOptions& o) {
            Progress progress("tessellating patches", scene.patch_count());
            pipeline_options.progress = [&progress](std::size_t done, std::size_t) { progress.set(done); };
            return write_pipeline_ply(scene, pipeline_options, o, file);
        },
        output, name, write_options, NameErrors::after_stream_failure);
}

// The warnings, and the line saying what was written (`captured`: triangles captured, when
// --capture wrote them).
void print_mesh_summary(const MeshCommandOptions& options, const Scene& scene, Precision precision,
                        MeshFormat format, const MeshWriteReport& report, const std::size_t* captured) {
    if (report.degenerate_triangles > 0) {
        std::cerr << "tessref: warning: " << report.degenerate_triangles
                  << " triangles whose corners weld together (zero area) were left out\n";
    }
    if (const std::string lost = report.precision_warning(); !lost.empty())
        std::cerr << "tessref: warning: " << lost << "\n";
    std::cout << options.output << ": " << to_string(format) << (options.binary ? " binary" : " ascii") << ", "
              << to_string(precision) << " precision" << math_note(parse_math_flag(options.math)) << ", "
              << scene.patch_count() << " patches, " << report.triangles
              << " triangles, " << report.vertices << " vertices (welded from " << report.emitted_vertices << ")";
    if (captured) std::cout << ", " << *captured << " triangles captured to " << options.capture;
    std::cout << "\n";
}

int run_mesh(const MeshCommandOptions& options) {
    // Everything about the output is checked before the (possibly long) pipeline runs.
    if (options.output.empty() && options.capture.empty())
        throw Error("nothing to write: give -o MESH, --capture FILE or both", Where::in_file("-o"));
    if (options.output.empty() && (options.solid || options.binary))
        throw Error("shapes the mesh of -o, and there is none (--capture writes the pipeline's surface)",
                    Where::in_file(options.solid ? "--solid" : "--binary"));
    MeshWriteOptions write_options;
    if (!options.output.empty()) write_options.format = mesh_format_from_path(options.output);
    write_options.binary = options.binary;
    if (options.binary && !mesh_format_has_binary(write_options.format)) {
        throw Error("obj has no binary form; drop --binary or write .ply, .off or .stl",
                    Where::in_file("--binary"));
    }
    const Precision precision = parse_precision_flag(options.precision);
    const MathMode math = parse_math_flag(options.math);
    const ThreadLimit thread_limit(options.threads);
    std::optional<double> given_base;
    if (!options.base.empty()) {
        given_base = parse_double(options.base);
        if (!given_base || !std::isfinite(*given_base))
            throw Error("'" + options.base + "' is not a height: give a finite number", Where::in_file("--base"));
    }
    // Both fail now on a missing or unwritable directory.
    std::optional<AtomicOutput> output, capture_output;
    if (!options.output.empty()) output.emplace(options.output);
    CaptureFormat capture_format = CaptureFormat::text;
    if (!options.capture.empty()) {
        capture_format = capture_format_from_path(options.capture, "--capture");
        capture_output.emplace(options.capture);
    }

    const std::vector<StageShader> shader_flags = parse_shader_flags(options.shaders);
    apply_max_instructions_flag(options.max_instructions);
    Scene scene = load_scene(options.scene);
    apply_shader_flags(scene, shader_flags);
    if (options.solid && !scene.grid)
        throw Error("--solid closes a terrain; this scene has no [domain] grid", Where::in_file(options.scene));

    PipelineOptions pipeline_options;
    pipeline_options.precision = precision;
    pipeline_options.math = math;
    pipeline_options.camera_relative = options.camera_relative;
    // The surface is welded as it is evaluated, never held unwelded, unless --capture or
    // --solid needs the pipeline's whole surface (or the scene cannot stream it).
    if (output && !capture_output && !options.solid && surface_streams(scene)) {
        // A PLY is written as the surface is evaluated, where it can be (write_pipeline_ply);
        // otherwise, and for the other formats, from the welded mesh.
        std::optional<MeshWriteReport> streamed;
        if (write_options.format == MeshFormat::ply) {
            streamed = stream_mesh_file(scene, pipeline_options, *output, options.output, write_options);
        }
        if (streamed) {
            output->commit();
            print_mesh_summary(options, scene, precision, write_options.format, *streamed, nullptr);
            return 0;
        }
        WeldedMesh welded;
        {
            Progress progress("tessellating patches", scene.patch_count());
            pipeline_options.progress = [&progress](std::size_t done, std::size_t) { progress.set(done); };
            welded = run_pipeline_welded(scene, pipeline_options);
        }
        const MeshWriteReport report = write_mesh_file(
            [&](std::ostream& file, const MeshWriteOptions& o) { return write_mesh(welded, file, o); }, *output,
            options.output, write_options);
        output->commit();
        print_mesh_summary(options, scene, precision, write_options.format, report, nullptr);
        return 0;
    }

    PipelineResult result;
    {
        Progress progress("tessellating patches", scene.patch_count());
        pipeline_options.progress = [&progress](std::size_t done, std::size_t) { progress.set(done); };
        result = run_pipeline(scene, pipeline_options);
    }

    std::size_t captured = 0;
    if (capture_output) {
        // Of the surface the pipeline made, before --solid adds skirts and a base.
        const std::vector<CapturedVertex> capture = capture_from_pipeline(scene, result);
        captured = capture.size() / 3;
        std::ofstream out(capture_output->temp_path(), std::ios::binary | std::ios::trunc);
        try {
            write_capture(capture, out, capture_format,
                          "tessref mesh " + options.scene + ": the CPU reference, " + std::string(to_string(precision)) +
                              " precision" + math_note(pipeline_options.math));
        } catch (const Error& error) {
            throw Error(error.what(), Where::in_file(options.capture));  // the name given, not the temporary one
        }
    }
    if (!output) {
        capture_output->commit();
        std::cout << options.capture << ": " << to_string(precision) << " precision"
                  << math_note(pipeline_options.math) << ", " << scene.patch_count()
                  << " patches, " << captured << " triangles captured\n";
        return 0;
    }

    if (options.solid) {
        // Skirts from the outline down to a base plane, and the base: a watertight solid
        // that `tessref check --expect closed` passes unless the terrain itself cracks.
        if (result.mesh.triangles.empty())  // every patch culled: no lowest vertex to put a base under
            throw Error("cannot close a terrain without triangles into a solid (every patch is culled)",
                        Where::in_file(options.scene));
        const int up_axis = scene.grid->plane == GroundPlane::xy ? 2 : 1;
        double low = std::numeric_limits<double>::infinity(), high = -low;
        for (const glm::dvec3& p : result.mesh.positions) {
            low = std::min(low, p[up_axis]);
            high = std::max(high, p[up_axis]);
        }
        // Default base: 5 % of the relief (at least 1 unit) below the lowest vertex.
        const double base = given_base.value_or(low - std::max(1.0, 0.05 * (high - low)));
        if (!(base < low)) {
            std::ostringstream what;
            what << "the base " << (given_base ? "'" + options.base + "'" : std::to_string(base))
                 << " must lie below the terrain's lowest vertex, at " << "xyz"[up_axis] << " = " << low;
            throw Error(what.str(), Where::in_file(given_base ? "--base" : options.scene));
        }
        result.mesh = close_terrain_into_solid(result.mesh, base, up_axis);
    }

    const MeshWriteReport report = write_mesh_file(
        [&](std::ostream& file, const MeshWriteOptions& o) { return write_mesh(result.mesh, file, o); }, *output,
        options.output, write_options);
    if (capture_output) capture_output->commit();
    output->commit();
    print_mesh_summary(options, scene, precision, write_options.format, report,
                       capture_output ? &captured : nullptr);
    return 0;
}

}  // namespace

Command add_mesh_command(CLI::App& parent) {
    auto options = std::make_shared<MeshCommandOptions>();
    CLI::App* app = parent.add_subcommand(
        "mesh",
        "Run a scene's pipeline and write the tessellated surface as a mesh (PLY through tessref's "
        "own writer, byte for byte OpenMesh's; OBJ, OFF, STL through OpenMesh). Vertices are welded only where their positions are bitwise equal, so "
        "a crack between patches stays a hole. PLY also carries every vertex's patch_id and "
        "tess coord (tess_u, tess_v, tess_w).");
    app->add_option("scene", options->scene, "Scene file (TOML)")->required();
    app->add_option("-o,--output", options->output,
                    "Output mesh; the format follows the extension: .ply, .obj, .off, .stl");
    app->add_option("--capture", options->capture,
                    "Also (or only) write the CPU reference's capture: every vertex of every triangle with its "
                    "patch id, tess coord, position, normal and the patch's levels, in the layout of `tessref gl "
                    "--capture` (.txt, or .ply without levels), for `tessref compare`")
        ->type_name("FILE");
    add_math_option(*app, options->math);
    app->add_option("--precision", options->precision,
                    "gpu: float stages, as the GPU computes them; exact: double stages. Files "
                    "store 32-bit floats either way (OpenMesh's writers)")
        ->default_val("gpu");
    add_cpu_shader_options(*app, options->shaders, options->max_instructions);
    app->add_flag("--binary", options->binary,
                  "Binary file (PLY little endian, OFF binary, STL binary); OBJ has none");
    app->add_option("--threads", options->threads, "Worker threads (0: every core)")->default_val(0);
    app->add_flag("--solid", options->solid,
                  "Close the terrain into a watertight solid: skirts from its outline down to a base "
                  "plane, and the base (for 3D printing; `tessref check --expect closed` passes it)");
    app->add_option("--base", options->base,
                    "Height of the solid's base plane (default: below the lowest vertex by 5 % of "
                    "the relief, at least 1)")
        ->needs("--solid");
    app->add_flag("--camera-relative", options->camera_relative,
                  "Evaluate relative to the eye (gpu precision): grid corners and texture mapping shifted by "
                  "-eye in double, then float; the file holds world positions (eye added back in double, "
                  "then the writer's 32-bit floats). No effect in exact precision");
    return Command{app, [options] { return run_mesh(*options); }};
}

}  // namespace tessref::cli
