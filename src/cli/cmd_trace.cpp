// tessref trace — one invocation of one of a scene's shader stages, run through the SPIR-V
// interpreter (tessref/shader.h): every source line it executes, in execution order, with
// the values it stores into its variables (named as the source names them), then the
// stage's outputs. The user's file where the scene's [shaders] (or --shader) names one,
// else the shipped twin of data/shaders/, with the uniforms, textures and inputs the CPU
// pipeline gives it.
//
//   tessref trace SCENE --patch P --stage tesc|tese|vert|geom [--tess-coord U,V | --vertex I | --primitive K]
//                 [--json] [--math exact|llvmpipe] [--shader STAGE=FILE]... [--max-instructions N]
//   tessref trace SCENE --pixel X,Y --stage frag [--size WxH] [--json] [--math ...] [--shader ...]...
//
// A control shader's invocations run to each barrier() before any passes it: each line
// says which invocation ran it, and the outputs are every invocation's, with the levels.
// A fragment shader runs as render runs it (src/render/user_fragment.h): the quad of the
// fragment that the pixel shows, that fragment's lane traced.
#include <algorithm>
#include <bit>
#include <cmath>
#include <memory>
#include <cstdio>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "common/input_file.h"
#include "pipeline/stage_trace.h"
#include "tessref/error.h"
#include "render/user_fragment.h"
#include "tessref/prepare.h"
#include "tessref/render.h"
#include "tessref/scene.h"
#include "tessref/shader.h"

namespace tessref::cli {

namespace {

struct TraceOptions {
    std::string scene;
    std::string patch;
    std::string stage;
    std::string tess_coord;
    std::string vertex;
    std::string primitive;
    std::string pixel;
    std::string size;
    bool json = false;
    std::string math = "exact";
    std::vector<std::string> shaders;
    std::string max_instructions;
};

// One executed line: the invocation that ran it and what it stored.
struct Store {
    std::string name;
    std::uint32_t offset = 0;
    char kind = 'f';
    std::vector<std::uint32_t> words;
};
struct Step {
    int invocation = 0;
    std::string file;
    std::uint32_t line = 0;
    std::vector<Store> stores;
};

class Recorder final : public shader::Observer {
public:
    void invocation(int index) override { invocation_ = index; }
    void line(const std::string& file, std::uint32_t line) override {
        steps.push_back(Step{invocation_, file, line, {}});
    }
    void store(const std::string& name, std::uint32_t offset, char kind, std::span<const std::uint32_t> words) override {
        if (steps.empty()) steps.push_back(Step{invocation_, "", 0, {}});
        steps.back().stores.push_back(Store{name, offset, kind, {words.begin(), words.end()}});
    }
    std::vector<Step> steps;

private:
    int invocation_ = 0;
};

std::string number_text(char kind, std::uint32_t w) {
    char text[32];
    switch (kind) {
        case 'i': std::snprintf(text, sizeof text, "%d", static_cast<int>(w)); break;
        case 'u': std::snprintf(text, sizeof text, "%u", w); break;
        case 'b': return w ? "true" : "false";
        default: std::snprintf(text, sizeof text, "%.9g", static_cast<double>(std::bit_cast<float>(w))); break;
    }
    return text;
}
std::string values_text(char kind, const std::vector<std::uint32_t>& words) {
    if (words.size() == 1) return number_text(kind, words[0]);
    std::string s = "(";
    for (std::size_t k = 0; k < words.size(); ++k) s += (k ? ", " : "") + number_text(kind, words[k]);
    return s + ")";
}
nlohmann::json number_json(char kind, std::uint32_t w) {
    switch (kind) {
        case 'i': return static_cast<int>(w);
        case 'u': return w;
        case 'b': return w != 0;
        default: {
            const float f = std::bit_cast<float>(w);
            if (std::isfinite(f)) return f;
            return std::isnan(f) ? "nan" : f > 0 ? "inf" : "-inf";  // JSON has no such numbers
        }
    }
}
std::string vec_text(const glm::vec4& v, int n) {
    std::vector<std::uint32_t> w;
    for (int k = 0; k < n; ++k) w.push_back(std::bit_cast<std::uint32_t>(v[k]));
    return values_text('f', w);
}
nlohmann::json vec_json(const glm::vec4& v, int n) {
    nlohmann::json a = nlohmann::json::array();
    for (int k = 0; k < n; ++k) a.push_back(number_json('f', std::bit_cast<std::uint32_t>(v[k])));
    return a;
}

// "U,V": two floats.
glm::vec3 parse_tess_coord(const std::string& text) {
    const std::size_t comma = text.find(',');
    const std::optional<float> u = comma == std::string::npos ? std::nullopt : parse_float(text.substr(0, comma));
    const std::optional<float> v = comma == std::string::npos ? std::nullopt : parse_float(text.substr(comma + 1));
    if (!u || !v) throw Error("tess coord '" + text + "' is not U,V (e.g. 0.5,0.25)", Where::in_file("--tess-coord"));
    return {*u, *v, 0.0f};
}

long long parse_index(const std::string& text, const char* flag) {
    const std::optional<long long> n = parse_integer(text);
    if (!n || *n < 0) throw Error(std::string(flag) + " takes a whole number >= 0, not '" + text + "'", Where::in_file(flag));
    return *n;
}

// The source text of each file's lines, for the listing (a file that cannot be read: none).
class Sources {
public:
    const std::string& line(const std::string& file, std::uint32_t n) {
        auto it = files_.find(file);
        if (it == files_.end()) {
            std::vector<std::string> lines;
            try {
                std::istringstream in(read_input_file(file, "shader file", kShaderFileBytes));
                for (std::string l; std::getline(in, l);) lines.push_back(l);
            } catch (const Error&) {
            }
            it = files_.emplace(file, std::move(lines)).first;
        }
        static const std::string none;
        return n >= 1 && n <= it->second.size() ? it->second[n - 1] : none;
    }

private:
    std::map<std::string, std::vector<std::string>> files_;
};

std::string trimmed(const std::string& s) {
    const std::size_t a = s.find_first_not_of(" \t"), b = s.find_last_not_of(" \t\r");
    return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

std::string store_name(const Store& s) {
    std::string n = s.name.empty() ? "(temporary)" : s.name;
    if (s.offset) n += " +" + std::to_string(s.offset);
    return n;
}

// The executed lines as the JSON report's "lines" (each with its invocation where a stage
// runs several per trace: the control stage).
nlohmann::json steps_json(const std::vector<Step>& steps, Sources& sources, bool with_invocation) {
    nlohmann::json lines = nlohmann::json::array();
    for (const Step& s : steps) {
        nlohmann::json stores = nlohmann::json::array();
        for (const Store& st : s.stores) {
            nlohmann::json values = nlohmann::json::array();
            for (std::uint32_t w : st.words) values.push_back(number_json(st.kind, w));
            stores.push_back({{"name", st.name}, {"offset", st.offset}, {"values", values}});
        }
        nlohmann::json j = {{"file", utf8_for_json(s.file)}, {"line", s.line},
                            {"source", utf8_for_json(trimmed(sources.line(s.file, s.line)))}, {"stores", stores}};
        if (with_invocation) j["invocation"] = s.invocation;
        lines.push_back(j);
    }
    return lines;
}

// The executed lines as text: "file:line  source", then each store indented under it.
void print_steps(const std::vector<Step>& steps, Sources& sources, bool with_invocation) {
    for (const Step& s : steps) {
        std::string where = s.file.substr(s.file.find_last_of('/') + 1) + ":" + std::to_string(s.line);
        if (with_invocation) where = "[" + std::to_string(s.invocation) + "] " + where;
        std::cout << where << "  " << trimmed(sources.line(s.file, s.line)) << "\n";
        for (const Store& st : s.stores)
            std::cout << std::string(where.size(), ' ') << "    " << store_name(st) << " = " << values_text(st.kind, st.words) << "\n";
    }
}

// "X,Y": an image pixel, columns from the left and rows from the top, from 0.
glm::ivec2 parse_pixel(const std::string& text) {
    const std::size_t comma = text.find(',');
    const std::optional<long long> x = comma == std::string::npos ? std::nullopt : parse_integer(text.substr(0, comma));
    const std::optional<long long> y = comma == std::string::npos ? std::nullopt : parse_integer(text.substr(comma + 1));
    if (!x || !y || *x < 0 || *y < 0 || *x > 16383 || *y > 16383)
        throw Error("pixel '" + text + "' is not X,Y (e.g. 640,400; 0,0 is the top left)", Where::in_file("--pixel"));
    return {static_cast<int>(*x), static_cast<int>(*y)};
}

// --stage frag: the fragment shader's invocation of the fragment that pixel X,Y shows.
int run_fragment_trace(const TraceOptions& options) {
    for (const auto& [value, flag] : {std::pair{&options.patch, "--patch"}, {&options.tess_coord, "--tess-coord"},
                                      {&options.vertex, "--vertex"}, {&options.primitive, "--primitive"}})
        if (!value->empty()) throw Error(std::string(flag) + " does not belong to --stage frag (it takes --pixel X,Y)",
                                         Where::in_file(flag));
    if (options.pixel.empty()) throw Error("--stage frag needs --pixel X,Y", Where::in_file("--pixel"));
    const glm::ivec2 pixel = parse_pixel(options.pixel);
    RenderOptions render_options;
    render_options.math = parse_math_flag(options.math);
    if (!options.size.empty()) render_options.size = parse_image_size(options.size);
    const std::vector<StageShader> flags = parse_shader_flags(options.shaders);
    apply_max_instructions_flag(options.max_instructions);
    Scene scene = load_scene(options.scene);
    apply_shader_flags(scene, flags);
    const StageShader fragment = render_detail::traced_fragment_shader(scene);
    if (!scene.camera) throw Error("tracing a fragment needs a [camera] in the scene", Where::at_key(scene.file, "camera"));
    const glm::ivec2 size = options.size.empty() ? scene.camera->viewport : render_options.size;
    if (pixel.x >= size.x || pixel.y >= size.y)
        throw Error("pixel " + options.pixel + " is outside the " + std::to_string(size.x) + "x" + std::to_string(size.y) +
                        " image",
                    Where::in_file("--pixel"));
    const render_detail::UserFragmentStage stage(scene, render_options, fragment);
    const std::uint32_t triangle = stage.shown(pixel.x, pixel.y);
    if (triangle == kNoPixelId)
        throw Error("no fragment covers pixel " + options.pixel + " (the background shows there" +
                        (stage.winner(pixel.x, pixel.y) == kNoPixelId ? ")" : ": every fragment there discards)"),
                    Where::in_file("--pixel"));
    const int lane = (pixel.x & 1) + 2 * (pixel.y & 1);
    Recorder recorder;
    std::array<shader::QuadFragment, 4> inputs;
    const std::array<shader::FragmentResult, 4> results =
        stage.quad(pixel.x & ~1, pixel.y & ~1, triangle, &inputs, &recorder, lane);
    const shader::QuadFragment& in = inputs[static_cast<std::size_t>(lane)];
    const shader::FragmentResult& out = results[static_cast<std::size_t>(lane)];
    const std::uint32_t patch = stage.patch_of(triangle);
    const char* math = render_options.math == MathMode::llvmpipe ? "llvmpipe" : "exact";
    Sources sources;
    if (options.json) {
        const nlohmann::json steps = steps_json(recorder.steps, sources, false);
        nlohmann::json in_locations = nlohmann::json::object(), out_locations = nlohmann::json::object();
        for (std::size_t k = 0; k < in.inputs.size(); ++k) in_locations[std::to_string(k)] = vec_json(shader::as_vec4(in.inputs[k]), 4);
        for (std::size_t k = 0; k < out.outputs.size(); ++k)
            out_locations[std::to_string(k)] = vec_json(shader::as_vec4(out.outputs[k]), 4);
        const nlohmann::json report = {{"scene", utf8_for_json(options.scene)},
                                       {"stage", to_string(ShaderStage::fragment)},
                                       {"shader", utf8_for_json(fragment.path)},
                                       {"pixel", {pixel.x, pixel.y}},
                                       {"size", {size.x, size.y}},
                                       {"triangle", triangle},
                                       {"patch", patch},
                                       {"quad_lane", lane},
                                       {"math", math},
                                       {"inputs", {{"gl_FragCoord", vec_json(in.frag_coord, 4)}, {"locations", in_locations}}},
                                       {"lines", steps},
                                       {"outputs", {{"locations", out_locations}, {"discarded", out.discarded}}}};
        std::cout << report.dump(2) << "\n";
        return 0;
    }
    std::cout << "trace of the fragment shader " << fragment.path << ", pixel " << pixel.x << "," << pixel.y << " of "
              << size.x << "x" << size.y << " (triangle " << triangle << " of patch " << patch << ", lane " << lane
              << " of its 2x2 quad), " << math << " math\n";
    std::cout << "inputs:\n  gl_FragCoord = " << vec_text(in.frag_coord, 4) << "\n";
    for (std::size_t k = 0; k < in.inputs.size(); ++k)
        std::cout << "  location " << k << " = " << vec_text(shader::as_vec4(in.inputs[k]), 4) << "\n";
    print_steps(recorder.steps, sources, false);
    std::cout << "outputs:\n";
    if (out.discarded) std::cout << "  (discarded)\n";
    for (std::size_t k = 0; k < out.outputs.size(); ++k)
        std::cout << "  location " << k << " = " << vec_text(shader::as_vec4(out.outputs[k]), 4) << "\n";
    return 0;
}

int run_trace(const TraceOptions& options) {
    pipeline::StageTraceRequest request;
    const std::optional<ShaderStage> stage = shader_stage_from_string(options.stage);
    if (!stage)
        throw Error("--stage takes vert, tesc, tese, geom or frag (or vertex, tess_control, tess_evaluation, geometry, "
                    "fragment), not '" + options.stage + "'",
                    Where::in_file("--stage"));
    if (*stage == ShaderStage::fragment) return run_fragment_trace(options);
    for (const auto& [value, flag] : {std::pair{&options.pixel, "--pixel"}, {&options.size, "--size"}})
        if (!value->empty()) throw Error(std::string(flag) + " belongs to --stage frag", Where::in_file(flag));
    if (options.patch.empty()) throw Error("--stage " + options.stage + " needs --patch P", Where::in_file("--patch"));
    request.stage = *stage;
    request.patch = static_cast<std::size_t>(parse_index(options.patch, "--patch"));
    request.math = parse_math_flag(options.math);
    if (request.stage == ShaderStage::tess_evaluation) {
        if (options.tess_coord.empty())
            throw Error("--stage tese needs --tess-coord U,V", Where::in_file("--tess-coord"));
        request.tess_coord = parse_tess_coord(options.tess_coord);
    } else if (!options.tess_coord.empty()) {
        throw Error("--tess-coord belongs to --stage tese", Where::in_file("--tess-coord"));
    }
    if (request.stage == ShaderStage::vertex) {
        if (options.vertex.empty()) throw Error("--stage vert needs --vertex I", Where::in_file("--vertex"));
        request.vertex = static_cast<int>(std::min<long long>(parse_index(options.vertex, "--vertex"), 1 << 30));
    } else if (!options.vertex.empty()) {
        throw Error("--vertex belongs to --stage vert", Where::in_file("--vertex"));
    }
    const bool geometry = request.stage == ShaderStage::geometry;
    if (geometry) {
        if (options.primitive.empty()) throw Error("--stage geom needs --primitive K", Where::in_file("--primitive"));
        request.primitive = static_cast<std::size_t>(parse_index(options.primitive, "--primitive"));
    } else if (!options.primitive.empty()) {
        throw Error("--primitive belongs to --stage geom", Where::in_file("--primitive"));
    }
    const std::vector<StageShader> flags = parse_shader_flags(options.shaders);
    apply_max_instructions_flag(options.max_instructions);
    Scene scene = load_scene(options.scene);
    apply_shader_flags(scene, flags);

    Recorder recorder;
    const pipeline::StageTrace t = pipeline::trace_stage(scene, request, recorder);
    const bool control = request.stage == ShaderStage::tess_control;
    Sources sources;

    if (options.json) {
        const nlohmann::json steps = steps_json(recorder.steps, sources, control);
        nlohmann::json report = {{"scene", utf8_for_json(options.scene)},
                                 {"stage", to_string(request.stage)},
                                 {"shader", utf8_for_json(t.shader)},
                                 {"patch", request.patch},
                                 {"math", (request.math == MathMode::llvmpipe ? "llvmpipe" : "exact")},
                                 {"lines", steps}};
        if (request.stage == ShaderStage::tess_evaluation) report["tess_coord"] = vec_json(glm::vec4(request.tess_coord, 0.0f), 3);
        if (request.stage == ShaderStage::vertex) report["vertex"] = request.vertex;
        if (geometry) report["primitive"] = request.primitive;
        const auto vertex_json = [&](const shader::ShaderVertex& v) {
            nlohmann::json locations = nlohmann::json::object();
            for (std::size_t k = 0; k < v.locations.size(); ++k)
                locations[std::to_string(k)] = vec_json(shader::as_vec4(v.locations[k]), 4);
            return nlohmann::json{{"gl_Position", vec_json(v.position, 4)}, {"locations", locations}};
        };
        if (control) {
            nlohmann::json outputs = nlohmann::json::array();
            for (const shader::ShaderVertex& v : t.patch.vertices) outputs.push_back(vertex_json(v));
            nlohmann::json patch_locations = nlohmann::json::object();
            for (std::size_t k = 0; k < t.patch.patch_locations.size(); ++k)
                patch_locations[std::to_string(k)] = vec_json(shader::as_vec4(t.patch.patch_locations[k]), 4);
            report["outputs"] = {{"vertices", outputs},
                                 {"patch_locations", patch_locations},
                                 {"outer", vec_json(glm::vec4(t.patch.outer[0], t.patch.outer[1], t.patch.outer[2], t.patch.outer[3]), 4)},
                                 {"inner", vec_json(glm::vec4(t.patch.inner[0], t.patch.inner[1], 0, 0), 2)}};
        } else if (geometry) {
            nlohmann::json inputs = nlohmann::json::array(), vertices = nlohmann::json::array(),
                           primitives = nlohmann::json::array();
            for (const shader::ShaderVertex& v : t.inputs) inputs.push_back(vertex_json(v));
            for (const shader::ShaderVertex& v : t.primitives.vertices) vertices.push_back(vertex_json(v));
            const std::size_t per = static_cast<std::size_t>(t.primitives.per_primitive());
            for (std::size_t k = 0; k + per <= t.primitives.indices.size(); k += per)
                primitives.push_back(std::vector<std::uint32_t>(t.primitives.indices.begin() + static_cast<std::ptrdiff_t>(k),
                                                                t.primitives.indices.begin() + static_cast<std::ptrdiff_t>(k + per)));
            report["inputs"] = inputs;
            report["outputs"] = {{"vertices", vertices}, {"primitives", primitives}};
        } else {
            report["outputs"] = vertex_json(t.vertex);
        }
        std::cout << report.dump(2) << "\n";
        return 0;
    }

    std::cout << "trace of the " << to_string(request.stage) << " shader " << t.shader << ", patch " << request.patch;
    if (request.stage == ShaderStage::tess_evaluation) std::cout << ", tess coord " << vec_text(glm::vec4(request.tess_coord, 0), 3);
    if (request.stage == ShaderStage::vertex) std::cout << ", vertex " << request.vertex;
    if (geometry) std::cout << ", primitive " << request.primitive;
    std::cout << ", " << (request.math == MathMode::llvmpipe ? "llvmpipe" : "exact") << " math\n";
    print_steps(recorder.steps, sources, control);
    const auto print_vertex = [](const shader::ShaderVertex& v, const std::string& indent) {
        std::cout << indent << "gl_Position = " << vec_text(v.position, 4) << "\n";
        for (std::size_t k = 0; k < v.locations.size(); ++k)
            std::cout << indent << "location " << k << " = " << vec_text(shader::as_vec4(v.locations[k]), 4) << "\n";
    };
    std::cout << "outputs:\n";
    if (control) {
        std::cout << "  gl_TessLevelOuter = "
                  << vec_text(glm::vec4(t.patch.outer[0], t.patch.outer[1], t.patch.outer[2], t.patch.outer[3]), 4)
                  << "\n  gl_TessLevelInner = " << vec_text(glm::vec4(t.patch.inner[0], t.patch.inner[1], 0, 0), 2) << "\n";
        for (std::size_t k = 0; k < t.patch.patch_locations.size(); ++k)
            std::cout << "  patch location " << k << " = " << vec_text(shader::as_vec4(t.patch.patch_locations[k]), 4) << "\n";
        for (std::size_t i = 0; i < t.patch.vertices.size(); ++i) {
            std::cout << "  invocation " << i << ":\n";
            print_vertex(t.patch.vertices[i], "    ");
        }
    } else if (geometry) {
        for (std::size_t i = 0; i < t.primitives.vertices.size(); ++i) {
            std::cout << "  vertex " << i << " (EmitVertex):\n";
            print_vertex(t.primitives.vertices[i], "    ");
        }
        const std::size_t per = static_cast<std::size_t>(t.primitives.per_primitive());
        for (std::size_t k = 0; k + per <= t.primitives.indices.size(); k += per) {
            std::cout << "  primitive " << k / per << ": vertices";
            for (std::size_t i = 0; i < per; ++i) std::cout << " " << t.primitives.indices[k + i];
            std::cout << "\n";
        }
    } else {
        print_vertex(t.vertex, "  ");
    }
    return 0;
}

}  // namespace

Command add_trace_command(CLI::App& parent) {
    auto options = std::make_shared<TraceOptions>();
    CLI::App* app = parent.add_subcommand(
        "trace",
        "Run one invocation of one of a scene's shader stages through tessref's SPIR-V interpreter and list every "
        "source line it executes, in order, with the values it stores, then the stage's outputs (the user's file of "
        "[shaders] or --shader, else the shipped GLSL twin); for a fragment shader, the fragment a pixel shows");
    app->add_option("scene", options->scene, "Scene file (TOML)")->required();
    app->add_option("--patch", options->patch, "The patch (0-based, as `tessref inspect` numbers them)");
    app->add_option("--stage", options->stage, "vert, tesc, tese, geom or frag")->required();
    app->add_option("--pixel", options->pixel,
                    "frag: the image pixel (0,0 top left) whose fragment is traced, the one it shows after the depth test")
        ->type_name("X,Y");
    app->add_option("--size", options->size, "frag: the image size (default the camera's viewport)")->type_name("WxH");
    app->add_option("--tess-coord", options->tess_coord, "tese: gl_TessCoord's u,v (w = 1 - u - v on triangles)")
        ->type_name("U,V");
    app->add_option("--vertex", options->vertex, "vert: which of the patch's vertices (0-based)")->type_name("I");
    app->add_option("--primitive", options->primitive,
                    "geom: which of the patch's triangles (0-based, in the generator's order, as gl --capture lists them)")
        ->type_name("K");
    app->add_flag("--json", options->json, "The trace as JSON");
    app->add_option("--math", options->math,
                    "GLSL's built-in functions: exact (correctly rounded) or llvmpipe (Mesa llvmpipe's, bit for bit)")
        ->default_val("exact");
    app->add_option("--shader", options->shaders,
                    "A GLSL file of your own for one stage (repeatable; over the scene's [shaders])")
        ->type_name("STAGE=FILE")
        ->allow_extra_args(false);
    app->add_option("--max-instructions", options->max_instructions,
                    "Instructions the invocation may run before it is stopped (default 10000000)")
        ->type_name("N");
    app->footer("Examples: tessref trace data/scenes/thesis-all-10.toml --patch 17 --stage tese --tess-coord 0.5,0.25\n"
                "          tessref trace data/scenes/cosc422.toml --stage frag --pixel 640,500 --math llvmpipe");
    return {app, [options] { return run_trace(*options); }};
}

}  // namespace tessref::cli
