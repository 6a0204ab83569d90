// tessref render — a scene to a picture (include/tessref/render.h): the software
// rasterizer's golden image, or with --raytrace the Embree ground truth of the full-resolution
// height field.
//
//   tessref render SCENE -o OUT.{png,exr,tif} [--wireframe | --overlay-wireframe]
//                  [--aov depth,patch,triangle,tesscoord,level] [--threads N]
//                  [--precision gpu|exact] [--math exact|llvmpipe] [--size WxH] [--raytrace] [--camera-relative]
//
// Every flag and the output name are checked before the scene is loaded; the image goes to a
// temporary file next to OUT and is renamed over it only when complete.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "tessref/error.h"
#include "tessref/limits.h"
#include "tessref/prepare.h"
#include "tessref/render.h"
#include "tessref/scene.h"
#include "tessref/tessellator.h"

namespace tessref::cli {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

struct RenderCommandOptions {
    std::string scene;
    std::string output;
    bool wireframe = false;
    bool overlay_wireframe = false;
    std::string aov;
    int threads = 0;  // 0: every core
    std::string precision = "gpu";
    std::string math = "exact";
    std::string size;  // empty: the camera's viewport
    bool raytrace = false;
    bool camera_relative = false;
    std::vector<std::string> shaders;  // --shader STAGE=FILE, as typed
    std::string max_instructions;      // empty: the interpreter's default
};

int run_render(const RenderCommandOptions& options) {
    // Flags and output first: nothing is computed for a command line that cannot succeed.
    const ImageFormat format = image_format_from_path(options.output);
    const AovSelection aovs = options.aov.empty() ? AovSelection{} : parse_aovs(options.aov);
    if (aovs.any() && format != ImageFormat::exr && !(format == ImageFormat::png && aovs_as_png(aovs)))
        throw Error("--aov writes float channels: the output must be an .exr file (a .png takes --aov level alone: "
                    "the level heat map with its legend)",
                    Where::in_file("--aov"));
    if (aovs.any() && options.raytrace && (aovs.patch || aovs.tesscoord || aovs.level))
        throw Error("a ray-traced image has no patches, tess coords or levels: with --raytrace, --aov takes depth "
                    "and triangle only",
                    Where::in_file("--aov"));
    if (options.wireframe && options.overlay_wireframe)
        throw Error("--wireframe and --overlay-wireframe exclude each other", Where::in_file("--overlay-wireframe"));
    if (options.raytrace && (options.wireframe || options.overlay_wireframe))
        throw Error("--raytrace renders the height field itself: it has no tessellation to draw as lines",
                    Where::in_file("--raytrace"));
    const Precision precision = parse_precision_flag(options.precision);
    if (options.camera_relative && options.raytrace)
        throw Error("--raytrace intersects the height field in double: it has no float evaluation to make "
                    "camera-relative",
                    Where::in_file("--camera-relative"));
    const ThreadLimit thread_limit(options.threads);
    RenderOptions render_options;
    render_options.camera_relative = options.camera_relative;
    if (!options.size.empty()) render_options.size = parse_image_size(options.size);
    render_options.precision = precision;
    render_options.math = parse_math_flag(options.math);
    apply_max_instructions_flag(options.max_instructions);
    const std::vector<StageShader> shader_flags = parse_shader_flags(options.shaders);
    // The provenance buffers only for the channels that write them.
    render_options.provenance = aovs.patch || aovs.tesscoord || aovs.level;
    // A PNG or TIFF holds 8-bit codes: the float colour only for an EXR.
    render_options.colour8 = format != ImageFormat::exr;
    render_options.mode = options.wireframe           ? RenderMode::wireframe
                          : options.overlay_wireframe ? RenderMode::fill_with_wireframe
                                                      : RenderMode::fill;
    AtomicOutput output(options.output);  // fails now on a missing or unwritable directory

    const auto load_start = Clock::now();
    Scene scene = load_scene(options.scene);
    apply_shader_flags(scene, shader_flags);
    const double seconds_load = seconds_since(load_start);
    if (scene.camera) {
        // Refused here, before the pipeline, rather than after it as an "out of memory".
        const glm::ivec2 size = options.size.empty() ? scene.camera->viewport : render_options.size;
        require_memory(estimate_render_memory(size, render_options.mode, options.raytrace, format, aovs),
                       "an image of " + std::to_string(size.x) + "x" + std::to_string(size.y) + " pixels",
                       Where::in_file(options.size.empty() ? options.scene : "--size " + options.size));
    }
    StageProgress stage_progress;
    render_options.progress = [&stage_progress](std::string_view stage, double fraction) {
        stage_progress(stage, fraction);
    };
    if (options.raytrace && user_fragment_shader(scene))
        throw Error("--raytrace shades with the scene's shading model: a user's fragment shader runs in the "
                    "rasterized render only",
                    Where::in_file("--raytrace"));
    RaytraceStats raytrace_stats;
    const RenderResult result = options.raytrace ? raytrace_scene(scene, render_options, &raytrace_stats)
                                                 : render_scene(scene, render_options);
    const auto write_start = Clock::now();
    write_image(result, output.temp_path().string(), format, aovs);
    output.commit();
    const double seconds_write = seconds_since(write_start);
    if (aovs.triangle && result.stats.triangles > (1u << 24))
        std::cerr << "tessref: warning: " << result.stats.triangles
                  << " triangles: ids above 16777216 are not exact in the float channel triangle_id\n";

    std::cout << options.output << ": " << result.width << "x" << result.height << ", ";
    if (const StageShader* fragment = options.raytrace ? nullptr : user_fragment_shader(scene))
        std::cout << "fragment shader " << fragment->path << " (interpreted), ";
    else
        std::cout << to_string(result.shading.model.kind) << " shading, ";
    if (options.raytrace) {
        std::cout << "ray-traced height field of " << raytrace_stats.grid_columns << "x" << raytrace_stats.grid_rows
                  << " vertices (" << raytrace_stats.triangles << " triangles), ";
    } else {
        std::cout << to_string(precision) << " precision" << math_note(render_options.math) << ", "
                  << result.stats.triangles << " triangles, ";
    }
    std::cout << result.stats.covered_pixels << " covered pixels";
    if (!options.raytrace && scene.culling && result.pipeline) {
        // geomipmap [culling]: the patches not drawn, by the step that removed them.
        const CullStats& c = result.pipeline->culled;
        std::cout << ", " << c.total() << " of " << scene.patch_count() << " patches culled (frustum " << c.frustum();
        if (scene.culling->pvs)
            std::cout << ", pvs " << (c.pvs_applied ? std::to_string(c.pvs) : std::string("- (eye outside its cells)"));
        std::cout << ")";
    }
    if (!options.raytrace) {
        char times[200];
        std::snprintf(times, sizeof times, " (load %.3f s, pipeline %.3f s, raster %.3f s, shading %.3f s, write %.3f s)",
                      seconds_load, result.stats.seconds_pipeline, result.stats.seconds_raster,
                      result.stats.seconds_shade, seconds_write);
        std::cout << times;
    }
    std::cout << "\n";
    return 0;
}

}  // namespace

Command add_render_command(CLI::App& parent) {
    auto options = std::make_shared<RenderCommandOptions>();
    CLI::App* app = parent.add_subcommand(
        "render",
        "Render a scene with the software rasterizer (llvmpipe's coverage, depth LESS, the scene's [shading] "
        "fragment stage): the golden image a GPU must reproduce. EXR output can carry the provenance of every "
        "pixel (--aov). --raytrace renders the full-resolution height field with Embree instead: the ground "
        "truth.");
    app->add_option("scene", options->scene, "Scene file (TOML)")->required();
    app->add_option("-o,--output", options->output,
                    "Output image; the format follows the extension: .png and .tif (8-bit RGBA), .exr (float RGBA "
                    "and the --aov channels)")
        ->required();
    app->add_flag("--wireframe", options->wireframe,
                  "Draw the triangles' edges only, as glPolygonMode(GL_FRONT_AND_BACK, GL_LINE) does (the fragment "
                  "stage shades the lines)");
    app->add_flag("--overlay-wireframe", options->overlay_wireframe,
                  "Draw the filled image, then the edges on the visible surface in the [shading] wireframe_colour");
    app->add_option("--aov", options->aov,
                    "EXR channels besides RGBA, comma-separated: depth (Z), patch (patch_id), triangle "
                    "(triangle_id), tesscoord (tess_coord.u/v/w), level (level and the heat map level_heat.R/G/B); "
                    "a .png takes level alone: the level heat map with its legend")
        ->type_name("LIST");
    app->add_option("--threads", options->threads,
                    "Worker threads (0: every core); the image is the same whatever the count")
        ->default_val(0);
    add_math_option(*app, options->math);
    add_cpu_shader_options(*app, options->shaders, options->max_instructions);
    app->add_option("--precision", options->precision,
                    "Pipeline precision: gpu (float stages, as the GPU) or exact (double stages)")
        ->default_val("gpu");
    app->add_option("--size", options->size,
                    "Image size WIDTHxHEIGHT (default: the camera's viewport); it replaces the viewport, so the "
                    "aspect ratio follows it")
        ->type_name("WxH");
    app->add_flag("--raytrace", options->raytrace,
                  "Ground truth: ray-trace the full-resolution height field (two triangles per texel quad, Embree) "
                  "with the same camera and shading, no tessellation (terrain scenes)");
    app->add_flag("--camera-relative", options->camera_relative,
                  "Evaluate relative to the eye (gpu precision): grid corners and texture mapping shifted by "
                  "-eye in double, then float; gl_Position from the eye-relative position and a view matrix "
                  "without its translation. For terrains far from the origin; no effect in exact precision");
    app->footer("Example: tessref render data/scenes/thesis-all-10.toml -o thesis.exr --size 640x400 --aov "
                "depth,patch,level");
    return Command{app, [options] { return run_render(*options); }};
}

}  // namespace tessref::cli
