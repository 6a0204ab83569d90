// tessref tessellate — runs the fixed-function primitive generator for one set of levels
// and writes its pattern: text (default), json, obj, or a picture (svg, png).
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "cli/pattern_picture.h"
#include "tessref/error.h"
#include "tessref/tessellator.h"

namespace tessref::cli {

namespace {

enum class Format { text, json, obj, svg, png };

struct TessellateOptions {
    std::string domain;
    std::string spacing;
    std::string winding = "ccw";
    bool point_mode = false;
    std::string outer;
    std::string inner;
    std::string precision = "gpu";
    std::string format;  // empty: from the -o extension, else text
    std::string output;  // empty or "-": stdout
};

std::optional<Format> parse_format(const std::string& name) {
    if (name == "text" || name == "txt") return Format::text;
    if (name == "json") return Format::json;
    if (name == "obj") return Format::obj;
    if (name == "svg") return Format::svg;
    if (name == "png") return Format::png;
    return std::nullopt;
}

// Everything the command writes, resolved from the options before anything is written.
struct TessellateRequest {
    TessSettings settings;
    TessLevels levels;
    Precision precision = Precision::gpu;
    Format format = Format::text;
    std::string output;
    bool inner_given = true;   // false: isolines without --inner (they have no inner levels)
    std::string command_line;  // canonical form of the request, for headers and pictures
};

using Json = nlohmann::ordered_json;

std::string join_levels(const float* values, std::size_t count, const char* separator, bool shortest = false) {
    std::string out;
    for (std::size_t i = 0; i < count; ++i) {
        if (i) out += separator;
        out += shortest ? format_float_short(values[i]) : format_float(values[i]);
    }
    return out;
}

TessellateRequest resolve(const TessellateOptions& options, bool inner_given) {
    TessellateRequest request;

    const auto domain = parse_domain(options.domain);
    if (!domain)
        throw Error("unknown domain '" + options.domain + "'; expected quads, triangles or isolines",
                    Where::in_file("--domain"));
    const auto spacing = parse_spacing(options.spacing);
    if (!spacing)
        throw Error("unknown spacing '" + options.spacing +
                        "'; expected equal, fractional_odd or fractional_even",
                    Where::in_file("--spacing"));
    const auto winding = parse_winding(options.winding);
    if (!winding)
        throw Error("unknown winding '" + options.winding + "'; expected ccw or cw", Where::in_file("--winding"));
    const Precision precision = parse_precision_flag(options.precision);

    request.settings = {*domain, *spacing, *winding, options.point_mode};
    request.inner_given = inner_given;
    request.precision = precision;

    const std::vector<float> outer = parse_float_list(options.outer, 4, "--outer");
    std::copy(outer.begin(), outer.end(), request.levels.outer.begin());
    if (inner_given) {
        const std::vector<float> inner = parse_float_list(options.inner, 2, "--inner");
        std::copy(inner.begin(), inner.end(), request.levels.inner.begin());
    } else if (*domain != Domain::isolines) {
        throw Error("--inner is required for the " + std::string(to_string(*domain)) + " domain",
                    Where::in_file("--inner"));
    }

    if (!options.format.empty()) {
        const auto format = parse_format(options.format);
        if (!format)
            throw Error("unknown format '" + options.format + "'; expected text, json, obj, svg or png",
                        Where::in_file("--format"));
        request.format = *format;
    } else if (!is_stdout(options.output)) {
        request.format = parse_format(lowercase_extension(options.output)).value_or(Format::text);
    }
    request.output = options.output;
    if (request.format == Format::png && is_stdout(request.output))
        throw Error("the png format writes a file: give one with -o FILE", Where::in_file("--format"));

    std::string& cmd = request.command_line;
    cmd = "tessref tessellate --domain " + std::string(to_string(request.settings.domain)) + " --spacing " +
          std::string(to_string(request.settings.spacing)) + " --winding " +
          std::string(to_string(request.settings.winding));
    if (request.settings.point_mode) cmd += " --point-mode";
    cmd += " --outer " + join_levels(request.levels.outer.data(), 4, ",", true);
    if (inner_given) cmd += " --inner " + join_levels(request.levels.inner.data(), 2, ",", true);
    cmd += " --precision " + std::string(to_string(request.precision));
    return request;
}

// "triangle", "segment" or "point"; plural() adds the "s".
std::string primitive_kind(const Pattern& pattern) {
    if (pattern.settings().point_mode) return "point primitive";
    return pattern.vertices_per_primitive() == 2 ? "segment" : "triangle";
}

std::string counted(std::size_t count, const std::string& noun) {
    return std::to_string(count) + " " + noun + (count == 1 ? "" : "s");
}

// The '#' header shared by the text and obj formats.
std::string comment_header(const TessellateRequest& request, const Pattern& pattern, double difference) {
    const TessSettings& s = pattern.settings();
    std::string out;
    out += "# " + request.command_line + "\n";
    out += "# settings: domain " + std::string(to_string(s.domain)) + ", spacing " +
           std::string(to_string(s.spacing)) + ", winding " + std::string(to_string(s.winding)) +
           ", point_mode " + (s.point_mode ? "on" : "off") + ", precision " +
           std::string(to_string(pattern.precision())) + "\n";
    const TessLevels& given = pattern.levels();
    const TessLevels& effective = pattern.effective_levels();
    out += "# levels given: outer " + join_levels(given.outer.data(), 4, " ") + ", inner " +
           (request.inner_given ? join_levels(given.inner.data(), 2, " ")
                                : std::string("not given (isolines have no inner levels)")) +
           "\n";
    out += "# levels effective: outer " + join_levels(effective.outer.data(), 4, " ") + ", inner " +
           join_levels(effective.inner.data(), 2, " ") + "\n";
    out += "# counts: " + counted(pattern.points().size(), "point") + ", " +
           counted(pattern.primitive_count(), primitive_kind(pattern)) + "\n";
    out += "# gpu vs exact max point difference: " + format_double(difference) + "\n";
    if (pattern.culled()) out += "# culled: an outer level the domain uses is NaN or <= 0; nothing is emitted\n";
    return out;
}

std::string vertex_text(const TessCoord& p) {
    return format_float(p.u) + " " + format_float(p.v) + " " + format_float(p.w);
}

std::string to_text(const TessellateRequest& request, const Pattern& pattern, double difference) {
    std::string out = comment_header(request, pattern, difference);
    out += "# one " + primitive_kind(pattern) + " per line: each vertex as \"u v w\" (gl_TessCoord), vertices separated by two spaces\n";
    const auto points = pattern.points();
    for (std::size_t i = 0; i < pattern.primitive_count(); ++i) {
        const auto primitive = pattern.primitive(i);
        for (std::size_t k = 0; k < primitive.size(); ++k) {
            if (k) out += "  ";
            out += vertex_text(points[primitive[k]]);
        }
        out += '\n';
    }
    return out;
}

std::string to_obj(const TessellateRequest& request, const Pattern& pattern, double difference) {
    std::string out = comment_header(request, pattern, difference);
    out += "# v: u v w of each point; ";
    out += pattern.settings().point_mode                   ? "p: one point each (1-based)\n"
           : pattern.vertices_per_primitive() == 2 ? "l: isoline segments (1-based)\n"
                                                   : "f: triangles in winding order (1-based)\n";
    for (const TessCoord& p : pattern.points()) out += "v " + vertex_text(p) + "\n";
    const char* tag = pattern.settings().point_mode ? "p" : pattern.vertices_per_primitive() == 2 ? "l" : "f";
    for (std::size_t i = 0; i < pattern.primitive_count(); ++i) {
        out += tag;
        for (const std::uint32_t index : pattern.primitive(i)) out += " " + std::to_string(index + 1);
        out += '\n';
    }
    return out;
}

// JSON has no NaN or infinity: those levels are written as the strings "nan", "inf", "-inf".
Json level_json(float x) {
    if (std::isfinite(x)) return x;
    return format_float(x);
}

// `inner_given` false: "inner" is null (isolines without --inner).
Json levels_json(const TessLevels& levels, bool inner_given = true) {
    Json outer = Json::array(), inner = Json::array();
    for (const float x : levels.outer) outer.push_back(level_json(x));
    for (const float x : levels.inner) inner.push_back(level_json(x));
    return {{"outer", outer}, {"inner", inner_given ? inner : Json(nullptr)}};
}

// The document with one top-level key per line and one point or primitive per line:
// readable in a terminal, compact for large patterns. Every value is nlohmann's dump.
std::string layout_json(const Json& doc) {
    std::string out = "{\n";
    std::size_t i = 0;
    for (const auto& [key, value] : doc.items()) {
        out += "  " + Json(key).dump() + ": ";
        const bool list_of_lists = value.is_array() && !value.empty() && value.front().is_array();
        if (list_of_lists) {
            out += "[\n";
            for (std::size_t k = 0; k < value.size(); ++k) {
                out += "    " + value[k].dump() + (k + 1 < value.size() ? ",\n" : "\n");
            }
            out += "  ]";
        } else {
            out += value.dump();
        }
        out += ++i < doc.size() ? ",\n" : "\n";
    }
    out += "}\n";
    return out;
}

std::string to_json(const TessellateRequest& request, const Pattern& pattern, double difference) {
    const TessSettings& s = pattern.settings();
    Json doc;
    doc["command"] = request.command_line;
    doc["settings"] = {{"domain", to_string(s.domain)},
                       {"spacing", to_string(s.spacing)},
                       {"winding", to_string(s.winding)},
                       {"point_mode", s.point_mode},
                       {"precision", to_string(pattern.precision())}};
    doc["levels"] = {{"given", levels_json(pattern.levels(), request.inner_given)}, {"effective", levels_json(pattern.effective_levels())}};
    doc["culled"] = pattern.culled();
    Json points = Json::array();
    for (const TessCoord& p : pattern.points()) points.push_back({p.u, p.v, p.w});
    doc["points"] = std::move(points);
    if (pattern.precision() == Precision::exact) {
        Json exact = Json::array();
        for (const TessCoordExact& p : pattern.points_exact()) exact.push_back({p.u, p.v, p.w});
        doc["points_exact"] = std::move(exact);
    }
    Json primitives = Json::array();
    for (std::size_t i = 0; i < pattern.primitive_count(); ++i) {
        Json primitive = Json::array();
        for (const std::uint32_t index : pattern.primitive(i)) primitive.push_back(index);
        primitives.push_back(std::move(primitive));
    }
    doc["primitives"] = std::move(primitives);
    doc["counts"] = {{"points", pattern.points().size()},
                     {"primitives", pattern.primitive_count()},
                     {"vertices_per_primitive", pattern.vertices_per_primitive()},
                     {"primitive_kind", pattern.settings().point_mode ? "points" : primitive_kind(pattern) + "s"}};
    doc["gpu_exact_max_difference"] = difference;
    return layout_json(doc);
}

int run_tessellate(const TessellateOptions& options, bool inner_given) {
    const TessellateRequest request = resolve(options, inner_given);

    const Pattern pattern = tessellate(request.settings, request.levels, request.precision);
    const Pattern other = tessellate(request.settings, request.levels,
                                     request.precision == Precision::gpu ? Precision::exact : Precision::gpu);
    const double difference = max_point_difference(pattern, other);

    switch (request.format) {
        case Format::text: write_output(request.output, to_text(request, pattern, difference)); break;
        case Format::obj: write_output(request.output, to_obj(request, pattern, difference)); break;
        case Format::json: write_output(request.output, to_json(request, pattern, difference)); break;
        case Format::svg: {
            const Picture picture = draw_pattern(pattern, {difference, request.command_line});
            write_output(request.output, picture_to_svg(picture));
            break;
        }
        case Format::png: {
            const Picture picture = draw_pattern(pattern, {difference, request.command_line});
            AtomicOutput output(request.output, ".png");  // PNG whatever the target's name
            const std::vector<std::string> warnings =
                write_picture_image(picture, output.temp_path().string(), request.output);
            output.commit();
            for (const std::string& warning : warnings) std::cerr << "tessref: warning: " << warning << "\n";
            break;
        }
    }
    return 0;
}

}  // namespace

Command add_tessellate_command(CLI::App& parent) {
    auto options = std::make_shared<TessellateOptions>();
    CLI::App* app = parent.add_subcommand(
        "tessellate",
        "Run the fixed-function primitive generator for one set of tessellation levels and write its "
        "pattern: the domain points (gl_TessCoord) and the primitives connecting them.");
    app->add_option("--domain", options->domain, "Domain: quads, triangles or isolines")
        ->required()
        ->type_name("{quads,triangles,isolines}");
    app->add_option("--spacing", options->spacing, "Spacing: equal, fractional_odd or fractional_even")
        ->required()
        ->type_name("{equal,fractional_odd,fractional_even}");
    app->add_option("--winding", options->winding, "Winding order of triangles")
        ->type_name("{ccw,cw}")
        ->capture_default_str();
    app->add_flag("--point-mode", options->point_mode, "Emit every point once instead of primitives");
    CLI::Option* outer =
        app->add_option("--outer", options->outer,
                        "gl_TessLevelOuter[0..3], exactly four comma-separated floats (nan, inf, -inf, "
                        "negatives and exponents allowed; levels the domain does not use are ignored)")
            ->required()
            ->type_name("A,B,C,D")
            ->allow_extra_args(false);
    CLI::Option* inner = app->add_option("--inner", options->inner,
                                         "gl_TessLevelInner[0..1], exactly two comma-separated floats "
                                         "(required for quads and triangles; ignored for isolines)")
                             ->type_name("E,F")
                             ->allow_extra_args(false);
    app->add_option("--precision", options->precision,
                    "gpu: bit-exact 16.16 fixed point as GPUs run it; exact: the same topology in double")
        ->type_name("{gpu,exact}")
        ->capture_default_str();
    app->add_option("--format", options->format,
                    "Output format (default: from the -o extension, else text). text: one primitive per "
                    "line, '#' comments; json; obj; svg or png: a picture of the pattern")
        ->type_name("{text,json,obj,svg,png}");
    app->add_option("-o,--output", options->output,
                    "Output file, written atomically (default: stdout; png needs a file)")
        ->type_name("FILE");
    app->footer("Example: tessref tessellate --domain triangles --spacing fractional_odd --outer 3.5,2,5,1 "
                "--inner 4,1 --format svg -o pattern.svg");
    static_cast<void>(outer);

    return Command{app, [options, inner] { return run_tessellate(*options, inner->count() > 0); }};
}

}  // namespace tessref::cli
