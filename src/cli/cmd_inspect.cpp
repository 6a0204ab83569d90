// tessref inspect — where one pixel of a rendered scene came from: the patch, the triangle,
// the tess coord, the tessellation levels, the world position, the depth and the colour
// (include/tessref/render.h, pixel_provenance).
//
//   tessref inspect SCENE --pixel X,Y [--capture FILE] [--json] [--size WxH]
//                   [--precision gpu|exact] [--wireframe] [--threads N]
//   tessref inspect SCENE --ground X,Y|camera [--json] [--size WxH] [--precision gpu|exact]
//
// X, Y: column from the left and row from the top of the image `tessref render` writes with
// the same options (as an image viewer shows it). --capture FILE (a capture of `tessref gl
// --capture` or `tessref mesh --capture`, capture.h): that capture's values for the same
// patch and the same tess coords beside the reference's, the patch's levels and each corner
// of the pixel's triangle, so a pixel that differs leads to the stage that differs.
//
// --ground: lab 4's camera collision question. The height of the height map and of the
// tessellated surface (the levels the scene's camera gives) at ground point X,Y ((x, y) on
// plane xy, (x, z) on plane xz; `camera`: under the eye), their difference, and with
// `camera` the eye's clearance above each (render.h, ground_height).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "tessref/capture.h"
#include "tessref/error.h"
#include "tessref/prepare.h"
#include "tessref/render.h"
#include "tessref/scene.h"
#include "tessref/tessellator.h"

namespace tessref::cli {

namespace {

struct InspectOptions {
    std::string scene;
    std::string pixel;
    std::string ground;
    std::string capture;
    bool json = false;
    std::string size;
    std::string precision = "gpu";
    bool wireframe = false;
    int threads = 0;
};

// "X,Y" (non-negative integers; the image's bounds are checked after rendering).
glm::ivec2 parse_pixel(const std::string& text) {
    const std::size_t comma = text.find(',');
    const std::optional<long long> x = comma == std::string::npos ? std::nullopt : parse_integer(text.substr(0, comma));
    const std::optional<long long> y = comma == std::string::npos ? std::nullopt : parse_integer(text.substr(comma + 1));
    if (!x || !y) throw Error("pixel '" + text + "' is not X,Y (e.g. 640,400)", Where::in_file("--pixel"));
    if (*x < 0 || *y < 0 || *x > 16383 || *y > 16383)
        throw Error("pixel " + text + " is outside the image (coordinates start at 0,0 top left)", Where::in_file("--pixel"));
    return {static_cast<int>(*x), static_cast<int>(*y)};
}

using Json = nlohmann::ordered_json;

Json number(float x) {
    if (std::isfinite(x)) return x;
    return format_float(x);  // JSON has no NaN or infinity
}
Json number(double x) {
    if (std::isfinite(x)) return x;
    return format_double(x);
}
template <int N, typename T>
Json vector_json(const glm::vec<N, T>& v) {
    Json a = Json::array();
    for (int i = 0; i < N; ++i) a.push_back(number(v[i]));
    return a;
}
template <int N, typename T>
std::string vector_text(const glm::vec<N, T>& v) {
    std::string s;
    for (int i = 0; i < N; ++i) {
        if (i) s += " ";
        if constexpr (std::is_same_v<T, float>) s += format_float(v[i]);
        else s += format_double(v[i]);
    }
    return s;
}

std::string levels_text(const TessLevels& l) {
    return "outer " + vector_text(glm::vec4(l.outer[0], l.outer[1], l.outer[2], l.outer[3])) + ", inner " +
           vector_text(glm::vec2(l.inner[0], l.inner[1]));
}

// "X,Y" (finite reals) or "camera".
std::optional<glm::dvec2> parse_ground(const std::string& text) {
    if (text == "camera") return std::nullopt;
    const std::size_t comma = text.find(',');
    const std::optional<double> x = comma == std::string::npos ? std::nullopt : parse_double(text.substr(0, comma));
    const std::optional<double> y = comma == std::string::npos ? std::nullopt : parse_double(text.substr(comma + 1));
    if (!x || !y || !std::isfinite(*x) || !std::isfinite(*y))
        throw Error("ground point '" + text + "' is not X,Y (two finite numbers) or camera", Where::in_file("--ground"));
    return glm::dvec2(*x, *y);
}

int run_ground(const InspectOptions& options) {
    const std::optional<glm::dvec2> point = parse_ground(options.ground);
    const Precision precision = parse_precision_flag(options.precision);
    const ThreadLimit thread_limit(options.threads);
    Scene scene = load_scene(options.scene);
    if (!options.size.empty() && scene.camera) scene.camera->viewport = parse_image_size(options.size);
    if (!point && !scene.camera) throw Error("--ground camera needs a [camera] in the scene", Where::at_key(scene.file, "camera"));
    const bool xy = !scene.grid || scene.grid->plane == GroundPlane::xy;
    const glm::dvec2 ground = point ? *point
                                    : (xy ? glm::dvec2(scene.camera->eye.x, scene.camera->eye.y)
                                          : glm::dvec2(scene.camera->eye.x, scene.camera->eye.z));
    PipelineOptions pipeline_options;
    pipeline_options.precision = precision;
    const PipelineResult pipeline = run_pipeline(scene, pipeline_options);
    const GroundHeight h = ground_height(scene, pipeline, ground);
    const double eye_height = scene.camera ? (xy ? scene.camera->eye.z : scene.camera->eye.y) : 0.0;

    if (options.json) {
        Json doc;
        doc["scene"] = scene.name;
        doc["ground"] = vector_json(h.ground);
        doc["under_camera"] = !point;
        doc["height_map"] = number(h.height_map);
        doc["on_surface"] = h.on_surface;
        if (h.on_surface) {
            doc["tessellated"] = number(h.tessellated);
            doc["difference"] = number(h.difference());
            doc["patch_id"] = h.patch_id;
            doc["triangle_id"] = h.triangle_id;
            Json outer = Json::array(), inner = Json::array();
            for (const float x : h.patch_levels.outer) outer.push_back(number(x));
            for (const float x : h.patch_levels.inner) inner.push_back(number(x));
            doc["patch_levels"] = {{"outer", outer}, {"inner", inner}};
        }
        if (!point) {
            doc["eye_height"] = number(eye_height);
            doc["clearance_height_map"] = number(eye_height - h.height_map);
            if (h.on_surface) doc["clearance_tessellated"] = number(eye_height - h.tessellated);
        }
        std::cout << doc.dump(2) << "\n";
        return 0;
    }
    std::ostringstream out;
    out << "ground " << vector_text(h.ground) << " of " << scene.name
        << (point ? "" : " (under the camera)") << ", " << (precision == Precision::gpu ? "gpu" : "exact")
        << " precision\n";
    out << "height map: " << format_double(h.height_map) << "\n";
    if (!h.on_surface) {
        out << "tessellated: none (no triangle covers the point: a culled patch)\n";
    } else {
        out << "tessellated: " << format_double(h.tessellated) << " (patch " << h.patch_id << ", levels "
            << levels_text(h.patch_levels) << "; triangle " << h.triangle_id << ")\n";
        out << "difference: " << format_double(h.difference()) << " (tessellated - height map)\n";
    }
    if (!point) {
        out << "eye height: " << format_double(eye_height) << "; clearance above the height map "
            << format_double(eye_height - h.height_map);
        if (h.on_surface) out << ", above the tessellated surface " << format_double(eye_height - h.tessellated);
        out << "\n";
    }
    std::cout << out.str();
    return 0;
}

// The capture's side of a covered pixel: the patch's levels and the triangle's corners, each
// found by patch id and tess coord (exact float bits, as compare_captures matches them).
struct CapturedCorner {
    glm::vec3 tess_coord{0.0f};
    const CapturedVertex* vertex = nullptr;  // null: the capture has no such vertex
    glm::vec3 reference_position{0.0f}, reference_normal{0.0f};
    bool has_reference_normal = false;
};
struct CaptureSide {
    std::string file;
    bool has_levels = false;
    std::size_t patch_vertices = 0;          // the capture's vertices of the pixel's patch
    const CapturedVertex* patch = nullptr;   // one of them (its levels), null: none
    std::array<CapturedCorner, 3> corners{};
};

bool same_bits(glm::vec3 a, glm::vec3 b) { return std::memcmp(&a, &b, sizeof a) == 0; }

CaptureSide capture_side(const Capture& capture, const std::string& file, const PixelProvenance& p,
                         const PipelineResult& pipeline) {
    CaptureSide side;
    side.file = file;
    side.has_levels = capture.has_levels;
    for (int k = 0; k < 3; ++k) {
        CapturedCorner& c = side.corners[static_cast<std::size_t>(k)];
        c.tess_coord = p.vertex_tess_coords[static_cast<std::size_t>(k)];
        const std::uint32_t v = p.vertices[static_cast<std::size_t>(k)];
        c.reference_position = glm::vec3(pipeline.mesh.positions[v]);
        c.has_reference_normal = v < pipeline.mesh.normals.size();
        if (c.has_reference_normal) c.reference_normal = glm::vec3(pipeline.mesh.normals[v]);
    }
    for (const CapturedVertex& v : capture.vertices) {
        if (v.patch_id != p.patch_id) continue;
        ++side.patch_vertices;
        if (!side.patch) side.patch = &v;
        for (CapturedCorner& c : side.corners)
            if (!c.vertex && same_bits(v.tess_coord, c.tess_coord)) c.vertex = &v;
    }
    return side;
}

std::uint64_t largest_ulps(glm::vec3 a, glm::vec3 b) {
    std::uint64_t most = 0;
    for (int i = 0; i < 3; ++i) most = std::max(most, ulp_distance(a[i], b[i]));
    return most;
}

std::string ulps_text(std::uint64_t ulps) { return ulps == kInfiniteUlps ? "NaN against a number" : std::to_string(ulps); }

Json capture_json(const CaptureSide& side, const PixelProvenance& p) {
    Json doc;
    doc["file"] = utf8_for_json(side.file);
    doc["patch_vertices"] = side.patch_vertices;
    if (side.patch && side.has_levels) {
        Json outer = Json::array(), inner = Json::array();
        for (const float x : side.patch->levels.outer) outer.push_back(number(x));
        for (const float x : side.patch->levels.inner) inner.push_back(number(x));
        doc["patch_levels"] = {{"outer", outer}, {"inner", inner}};
        doc["patch_levels_equal"] = side.patch->levels.outer == p.patch_levels.outer &&
                                    side.patch->levels.inner == p.patch_levels.inner;
    }
    Json corners = Json::array();
    for (const CapturedCorner& c : side.corners) {
        Json corner;
        corner["tess_coord"] = vector_json(c.tess_coord);
        corner["found"] = c.vertex != nullptr;
        corner["reference_position"] = vector_json(c.reference_position);
        if (c.vertex) {
            corner["position"] = vector_json(c.vertex->position);
            corner["position_difference"] = vector_json(c.vertex->position - c.reference_position);
            const std::uint64_t ulps = largest_ulps(c.vertex->position, c.reference_position);
            corner["position_ulps"] = ulps == kInfiniteUlps ? Json("inf") : Json(ulps);
            corner["normal"] = vector_json(c.vertex->normal);
        }
        if (c.has_reference_normal) corner["reference_normal"] = vector_json(c.reference_normal);
        corners.push_back(corner);
    }
    doc["corners"] = corners;
    return doc;
}

std::string capture_text(const CaptureSide& side, const PixelProvenance& p) {
    std::ostringstream out;
    out << "capture " << side.file << ": ";
    if (!side.patch) {
        out << "no vertex of patch " << p.patch_id << "\n";
        return out.str();
    }
    out << side.patch_vertices << " vertices of patch " << p.patch_id << "\n";
    if (side.has_levels) {
        const bool equal = side.patch->levels.outer == p.patch_levels.outer && side.patch->levels.inner == p.patch_levels.inner;
        out << "  levels: " << levels_text(side.patch->levels) << (equal ? " (the reference's)" : " (the reference: " +
                                                                                                      levels_text(p.patch_levels) + ")")
            << "\n";
    } else {
        out << "  levels: unknown (a PLY capture has none)\n";
    }
    for (std::size_t k = 0; k < 3; ++k) {
        const CapturedCorner& c = side.corners[k];
        out << "  corner " << k << " at tess coord " << vector_text(c.tess_coord) << ": ";
        if (!c.vertex) {
            out << "not in the capture (the patch's tessellation differs there)\n";
            continue;
        }
        const std::uint64_t ulps = largest_ulps(c.vertex->position, c.reference_position);
        out << "position " << vector_text(c.vertex->position);
        if (ulps == 0)
            out << " (the reference's)";
        else
            out << " (the reference " << vector_text(c.reference_position) << ", difference "
                << vector_text(c.vertex->position - c.reference_position) << ", " << ulps_text(ulps) << " ulps at most)";
        out << "; normal " << vector_text(c.vertex->normal);
        if (c.has_reference_normal) {
            if (largest_ulps(c.vertex->normal, c.reference_normal) == 0)
                out << " (the reference's)";
            else
                out << " (the reference " << vector_text(c.reference_normal) << ")";
        }
        out << "\n";
    }
    return out.str();
}

int run_inspect(const InspectOptions& options) {
    if (options.pixel.empty() == options.ground.empty())
        throw Error("give exactly one of --pixel X,Y and --ground X,Y|camera", Where::in_file("command line"));
    if (!options.ground.empty()) {
        if (options.wireframe) throw Error("--wireframe is for --pixel", Where::in_file("--wireframe"));
        if (!options.capture.empty()) throw Error("--capture is for --pixel", Where::in_file("--capture"));
        return run_ground(options);
    }
    const glm::ivec2 pixel = parse_pixel(options.pixel);
    const Precision precision = parse_precision_flag(options.precision);
    const ThreadLimit thread_limit(options.threads);
    RenderOptions render_options;
    if (!options.size.empty()) render_options.size = parse_image_size(options.size);
    render_options.precision = precision;
    render_options.mode = options.wireframe ? RenderMode::wireframe : RenderMode::fill;

    // The capture first: a bad file is refused before the render.
    std::optional<Capture> capture;
    if (!options.capture.empty()) {
        (void)capture_format_from_path(options.capture, "--capture");
        capture = read_capture(options.capture);
    }
    // The capture is held to the surface's own vertices, which a streamed render does not keep.
    render_options.keep_surface = capture.has_value();
    const Scene scene = load_scene(options.scene);
    const RenderResult result = render_scene(scene, render_options);
    if (pixel.x >= result.width || pixel.y >= result.height)
        throw Error("pixel " + options.pixel + " is outside the " + std::to_string(result.width) + "x" +
                        std::to_string(result.height) + " image",
                    Where::in_file("--pixel"));
    const PixelProvenance p = pixel_provenance(result, pixel.x, pixel.y);
    std::optional<CaptureSide> side;
    if (capture && p.covered && result.pipeline && !result.pipeline->mesh.positions.empty())
        side = capture_side(*capture, options.capture, p, *result.pipeline);

    if (options.json) {
        Json doc;
        doc["scene"] = scene.name;
        doc["image"] = {result.width, result.height};
        doc["pixel"] = {p.x, p.y};
        doc["window"] = {p.window_x, p.window_y};
        doc["covered"] = p.covered;
        doc["colour"] = vector_json(p.colour);
        doc["depth"] = number(p.depth);
        if (p.covered) {
            doc["patch_id"] = p.patch_id;
            doc["triangle_id"] = p.triangle_id;
            doc["vertices"] = {p.vertices[0], p.vertices[1], p.vertices[2]};
            doc["vertex_tess_coords"] = {vector_json(p.vertex_tess_coords[0]), vector_json(p.vertex_tess_coords[1]),
                                         vector_json(p.vertex_tess_coords[2])};
            doc["barycentric"] = vector_json(p.barycentric);
            doc["tess_coord"] = vector_json(p.tess_coord);
            doc["level"] = number(p.level);
            doc["level_source"] = p.level_source;
            Json outer = Json::array(), inner = Json::array();
            for (const float x : p.patch_levels.outer) outer.push_back(number(x));
            for (const float x : p.patch_levels.inner) inner.push_back(number(x));
            doc["patch_levels"] = {{"outer", outer}, {"inner", inner}};
            doc["world_position"] = vector_json(p.world_position);
            if (p.normal) doc["normal"] = vector_json(*p.normal);
            if (p.uv) doc["uv"] = vector_json(*p.uv);
        }
        if (side) doc["capture"] = capture_json(*side, p);
        std::cout << doc.dump(2) << "\n";
        return 0;
    }

    std::ostringstream out;
    out << "pixel " << p.x << "," << p.y << " (GL window " << p.window_x << "," << p.window_y << ") of "
        << scene.name << " at " << result.width << "x" << result.height << "\n";
    out << "colour: " << vector_text(p.colour) << "\n";
    out << "depth: " << format_float(p.depth) << "\n";
    if (!p.covered) {
        out << "covered: no (background)\n";
        if (capture) out << "capture " << options.capture << ": nothing to compare (the reference draws no surface here)\n";
    } else {
        out << "covered: yes\n";
        out << "patch: " << p.patch_id << " (levels " << levels_text(p.patch_levels) << ")\n";
        out << "triangle: " << p.triangle_id << " (vertices " << p.vertices[0] << " " << p.vertices[1] << " "
            << p.vertices[2] << ")\n";
        out << "vertex tess coords: " << vector_text(p.vertex_tess_coords[0]) << " | "
            << vector_text(p.vertex_tess_coords[1]) << " | " << vector_text(p.vertex_tess_coords[2]) << "\n";
        out << "barycentric: " << vector_text(p.barycentric) << "\n";
        out << "tess coord: " << vector_text(p.tess_coord) << "\n";
        out << "level: " << format_float(p.level) << " (" << p.level_source << ")\n";
        out << "world position: " << vector_text(p.world_position) << "\n";
        if (p.normal) out << "normal: " << vector_text(*p.normal) << "\n";
        if (p.uv) out << "uv: " << vector_text(*p.uv) << "\n";
        if (side) out << capture_text(*side, p);
    }
    std::cout << out.str();
    return 0;
}

}  // namespace

Command add_inspect_command(CLI::App& parent) {
    auto options = std::make_shared<InspectOptions>();
    CLI::App* app = parent.add_subcommand(
        "inspect",
        "Render a scene as `tessref render` does and print where one pixel came from: its patch and the "
        "patch's tessellation levels, its triangle, tess coord, level, world position, depth and colour. Or, with "
        "--ground, the height of the height map and of the tessellated surface at a ground point (lab 4's camera "
        "collision).");
    app->add_option("scene", options->scene, "Scene file (TOML)")->required();
    app->add_option("--pixel", options->pixel,
                    "The pixel: column X from the left, row Y from the top (0,0 is the top-left corner)")
        ->type_name("X,Y");
    app->add_option("--ground", options->ground,
                    "A ground point (x,y on plane xy; x,z on plane xz) or `camera` (under the eye): the heights of the "
                    "height map and of the tessellated surface there")
        ->type_name("X,Y|camera");
    app->add_option("--capture", options->capture,
                    "With --pixel: a capture (`tessref gl --capture`, `tessref mesh --capture`; .txt or .ply) whose "
                    "values for the pixel's patch and its triangle's tess coords are printed beside the reference's")
        ->type_name("FILE");
    app->add_flag("--json", options->json, "Print JSON instead of text");
    app->add_option("--size", options->size, "Image size WIDTHxHEIGHT, as given to `tessref render`")
        ->type_name("WxH");
    app->add_option("--precision", options->precision, "Pipeline precision: gpu or exact")->default_val("gpu");
    app->add_flag("--wireframe", options->wireframe, "Inspect the --wireframe image (the lines' pixels)");
    app->add_option("--threads", options->threads, "Worker threads (0: every core)")->default_val(0);
    return Command{app, [options] { return run_inspect(*options); }};
}

}  // namespace tessref::cli
