// tessref gl — a scene through its GLSL twins (data/shaders/) on an OSMesa 4.5 core context
// (Mesa llvmpipe): the picture a GPU driver makes of the scene, beside `tessref render`'s.
//
//   tessref gl SCENE -o OUT.{png,exr,tif} [--size WxH] [--wireframe] [--capture OUT.{txt,ply}]
//              [--shader STAGE=FILE]... [--max-primitives-per-draw N]
//
// Exit 1 when a draw's GL_PRIMITIVES_GENERATED differs from the CPU primitive generator's
// count (gl_render.h): the image and the capture are written all the same, and the patches
// whose levels or triangle counts differ are listed. TESSREF_GL_CORRUPT_BATCH=N (a test hook)
// makes the prediction of draw N one too high.
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "tessref/capture.h"
#include "tessref/error.h"
#include "tessref/gl_render.h"
#include "tessref/limits.h"
#include "tessref/mesh.h"
#include "tessref/prepare.h"
#include "tessref/render.h"
#include "tessref/scene.h"

namespace tessref::cli {

namespace {

struct GlCommandOptions {
    std::string scene;
    std::string output;
    std::string size;
    bool wireframe = false;
    std::string capture;
    std::vector<std::string> shaders;  // STAGE=FILE, as typed
    std::string max_instructions;      // empty: the interpreter's default
    std::string max_primitives_per_draw;  // empty: SceneRenderOptions' default
    bool camera_relative = false;      // refused (see run_gl)
};


// --max-primitives-per-draw N: 1..2^31-1 (a draw's GL_PRIMITIVES_GENERATED is read as a GLuint).
std::size_t parse_max_primitives_per_draw(const std::string& text) {
    const std::string flag = "--max-primitives-per-draw";
    const std::optional<long long> value = parse_integer(text);
    if (!value || *value < 1 || *value > 2147483647LL)
        throw Error("'" + text + "' is not a whole number in 1..2147483647", Where::in_file(flag));
    return static_cast<std::size_t>(*value);
}

// The draws whose counts differed and the patches behind them: one line a patch, the CPU
// value and llvmpipe's of its levels (%.9g, outer then inner) and triangle count.
void report_differences(std::ostream& err, const gl::SceneRender& r) {
    err << "tessref: gl: " << r.batch_failure << "; image";
    if (!r.capture.empty()) err << " and capture";
    err << " written; " << r.differences.size() << " patch" << (r.differences.size() == 1 ? "" : "es")
        << " whose levels or triangle counts differ from the CPU's (math mode llvmpipe)"
        << (r.differences.empty() ? "" : ":") << "\n";
    const auto levels = [](const TessLevels& l) {
        char text[160];
        std::snprintf(text, sizeof text, "outer %.9g %.9g %.9g %.9g inner %.9g %.9g", l.outer[0], l.outer[1],
                      l.outer[2], l.outer[3], l.inner[0], l.inner[1]);
        return std::string(text);
    };
    for (const gl::PatchDifference& d : r.differences) {
        err << "  patch " << d.patch << ": levels CPU " << levels(d.cpu_levels) << ", GL "
            << (d.gl_levels_known ? levels(d.gl_levels) : std::string("(nothing emitted)")) << "; triangles CPU "
            << d.cpu_triangles << ", GL " << d.gl_triangles << "\n";
    }
}

int run_gl(const GlCommandOptions& options) {
    // Camera-relative evaluation is the CPU pipeline's only (render, mesh): the GLSL twins
    // compute texture coordinates from the world position (thesis xy / scaleXY, COSC422 the
    // extent, lab 4 xz / scale + offset), so the GL side would need shader uniforms the twins
    // do not have, not only a shifted vertex buffer and a translation-free view matrix.
    if (options.camera_relative)
        throw Error("--camera-relative is not implemented for the GL backend: its GLSL twins map world positions "
                    "to texture coordinates, and shifting the vertex buffer alone would move the texture; use "
                    "`tessref render --camera-relative` (the CPU reference)",
                    Where::in_file("--camera-relative"));
    const ImageFormat format = image_format_from_path(options.output);
    CaptureFormat capture_format = CaptureFormat::text;
    if (!options.capture.empty()) capture_format = capture_format_from_path(options.capture, "--capture");
    gl::SceneRenderOptions render_options;
    if (!options.size.empty()) render_options.size = parse_image_size(options.size);
    render_options.wireframe = options.wireframe;
    render_options.capture = !options.capture.empty();
    render_options.shaders = parse_shader_flags(options.shaders);
    apply_max_instructions_flag(options.max_instructions);
    if (!options.max_primitives_per_draw.empty())
        render_options.max_primitives_per_draw = parse_max_primitives_per_draw(options.max_primitives_per_draw);
    if (const char* hook = std::getenv("TESSREF_GL_CORRUPT_BATCH"); hook && *hook)
        render_options.corrupt_prediction_of_batch = std::atoll(hook);
    AtomicOutput output(options.output);
    std::unique_ptr<AtomicOutput> capture_output;
    if (!options.capture.empty()) capture_output = std::make_unique<AtomicOutput>(options.capture);

    const Scene scene = load_scene(options.scene);
    if (scene.camera) {
        const glm::ivec2 size = options.size.empty() ? scene.camera->viewport : render_options.size;
        require_memory(estimate_render_memory(size, RenderMode::fill, false, format, {}),
                       "an image of " + std::to_string(size.x) + "x" + std::to_string(size.y) + " pixels",
                       Where::in_file(options.size.empty() ? options.scene : "--size " + options.size));
    }
    // In a child process with its own limits: a user's shader cannot take tessref down.
    const gl::IsolatedRender isolated = gl::render_scene_isolated(scene, render_options);
    const gl::SceneRender& r = isolated.render;
    for (const std::string& w : r.warnings) std::cerr << "tessref: warning: " << w << "\n";

    RenderResult image;
    image.width = r.width;
    image.height = r.height;
    image.colour = r.colour;
    write_image(image, output.temp_path().string(), format, {});
    if (capture_output) {
        std::ofstream out(capture_output->temp_path(), std::ios::binary);
        try {
            write_capture(r.capture, out, capture_format, "tessref gl " + options.scene + ": " + isolated.renderer +
                                                              ", transform feedback");
        } catch (const Error& error) {
            throw Error(error.what(), Where::in_file(options.capture));  // the name given, not the temporary one
        }
        capture_output->commit();
    }
    output.commit();
    if (!r.batch_failure.empty()) {
        report_differences(std::cerr, r);
        return 1;
    }
    std::cout << options.output << ": " << r.width << "x" << r.height << ", " << to_string(r.shading.model.kind)
              << " shading, " << isolated.renderer << ", " << r.stats.triangles << " triangles in "
              << r.stats.draws << " draws (every count as predicted), " << r.stats.seconds_gl
              << " s GL (CPU pipeline for the predictions " << r.stats.seconds_pipeline << " s)";
    if (capture_output) std::cout << ", " << r.capture.size() / 3 << " triangles captured to " << options.capture;
    for (const StageShader& s : r.user_shaders) std::cout << ", user " << to_string(s.stage) << " shader " << s.path;
    std::cout << "\n";
    return 0;
}

}  // namespace

Command add_gl_command(CLI::App& parent) {
    auto options = std::make_shared<GlCommandOptions>();
    CLI::App* app = parent.add_subcommand(
        "gl",
        "Render a scene through its GLSL 4.50 twins (data/shaders/) on Mesa llvmpipe (OSMesa, OpenGL 4.5 core): "
        "only the stages the scene names, its uniforms and textures, the camera of `tessref render`. Draws are "
        "batched and each one's primitive count is checked against the CPU pipeline's, run with llvmpipe's math "
        "(exit 1 when they differ: the image and capture are written and the patches that differ listed).");
    app->add_option("scene", options->scene, "Scene file (TOML)")->required();
    app->add_option("-o,--output", options->output,
                    "Output image: .png and .tif (8-bit RGBA), .exr (float RGBA)")
        ->required();
    app->add_option("--size", options->size,
                    "Image size WIDTHxHEIGHT (default: the camera's viewport); it replaces the viewport")
        ->type_name("WxH");
    app->add_flag("--wireframe", options->wireframe, "glPolygonMode(GL_FRONT_AND_BACK, GL_LINE)");
    app->add_option("--capture", options->capture,
                    "Also record every vertex of every primitive by transform feedback (patch id, tess coord, "
                    "position, normal): .ply (tessref mesh's layout) or .txt")
        ->type_name("FILE");
    app->add_option("--shader", options->shaders,
                    "A GLSL file of your own in place of the GLSL twin of one stage (repeatable; over the scene's "
                    "[shaders]): STAGE is vertex|vert, tess_control|tesc, tess_evaluation|tese, geometry|geom or "
                    "fragment|frag. Uniforms, textures and the CPU reference's draw counts stay; the file keeps its "
                    "own layout(...) in; (docs/CLI.md: Debugging your own shader)")
        ->type_name("STAGE=FILE")
        ->allow_extra_args(false);  // one file per flag: the scene after it stays the scene
    app->add_option("--max-instructions", options->max_instructions,
                    "Instructions one shader invocation of a user's stage may run before it is stopped (default "
                    "10000000): a shader that never ends is an error naming the stage, patch and invocation")
        ->type_name("N");
    app->add_option("--max-primitives-per-draw", options->max_primitives_per_draw,
                    "Predicted primitives per draw at most (default 32768; a draw holds at least one patch): "
                    "the size of the draws whose counts are checked. Above the default, llvmpipe can draw a wrong "
                    "picture with every count right (docs/PERFORMANCE.md: Benchmarks)")
        ->type_name("N");
    app->add_flag("--camera-relative", options->camera_relative,
                  "Refused (exit 2): camera-relative evaluation is `tessref render` and `tessref mesh`'s only");
    app->footer("Example: tessref gl data/scenes/thesis-all-10.toml -o gl.png --size 320x200\n"
                "         tessref gl data/scenes/thesis-all-10.toml -o mine.png --shader tese=my.tese");
    return Command{app, [options] { return run_gl(*options); }};
}

}  // namespace tessref::cli
