// tessref golden — the CPU reference as the golden output of the GL backend.
//
//   tessref golden update [SCENE...] [--golden DIR] [--scenes DIR] [--size WxH]
//   tessref golden verify [SCENE...] [--golden DIR] [--scenes DIR] [--keep DIR] [--json]
//
// A SCENE is a file stem of --scenes (default data/scenes; "thesis-all-10"); none: every
// *.toml there. What the golden files are, how a scene is verified and what each verdict
// means is the golden room's (tessref/golden.h, src/golden/); this file parses the command
// line, writes the files `update` makes and prints `verify`'s table or JSON.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "tessref/error.h"
#include "tessref/gl_render.h"
#include "tessref/golden.h"
#include "tessref/render.h"

namespace tessref::cli {

namespace {

namespace fs = std::filesystem;

struct GoldenOptions {
    std::string action;  // update | verify
    std::vector<std::string> scenes;
    std::string golden_dir = "golden";
    std::string scenes_dir = "data/scenes";
    std::string size = "320x200";
    std::string keep;
    bool json = false;

    golden::Location location() const { return {scenes_dir, golden_dir}; }
};

// The table's columns: the header, its width and what it means (the legend under the table
// and in --help). Every column but the scene's is right-aligned in a fixed width with a
// space before it, so two numbers never run together.
struct Column {
    const char* header;
    int width;
    const char* meaning;
};
const std::vector<Column>& columns() {
    static const std::vector<Column> c{
        {"triangles", 10, "triangles of the CPU reference capture"},
        {"fail px", 9, "pixels of the GL picture failing compare's rule against image.png, not explained by a level difference"},
        {"lvl px", 8, "failing pixels on or next to a patch whose levels differ (explained: that patch's surface moved)"},
        {"max err", 8, "the largest colour difference of any pixel (0..1)"},
        {"pos ulp", 11, "the largest position difference between the GL and CPU captures, in ulps"},
        {"nrm ulp", 11, "the largest normal difference, in ulps"},
        {"lvl patches", 12, "patches whose levels differ between GL and the CPU (acos: polynomial on llvmpipe)"},
        {"lvl ulp", 11, "the largest level difference of those patches, in ulps"},
        {"lvl diff", 9, "... and in absolute terms (at most 1/64 passes)"},
        {"GL s", 7, "seconds llvmpipe took to draw and capture the scene"},
    };
    return c;
}

std::string legend() {
    std::ostringstream out;
    out << "Columns:\n";
    for (const Column& c : columns()) out << "  " << std::left << std::setw(12) << c.header << c.meaning << "\n";
    out << "Verdicts (the worst decides the exit status):\n"
           "  PASS        the CPU still makes the golden files and llvmpipe matches them (exit 0)\n"
           "  CPU-ONLY    the CPU side passes; the scene is not compared with GL (exit 0)\n"
           "  FAIL        llvmpipe departs from the golden files beyond the tolerances (exit 1)\n"
           "  STALE       the CPU reference no longer makes the golden files: review, then update (exit 1)\n"
           "  MISSING     a golden file is not there (exit 2)\n"
           "  CORRUPT     a golden file is unreadable, malformed or disagrees with itself (exit 2)\n"
           "  ERROR       the scene or its run failed (exit 2)\n";
    return out.str();
}

// ---- update ----------------------------------------------------------------------------

int run_update(const GoldenOptions& options) {
    const glm::ivec2 size = parse_image_size(options.size);
    const golden::Location location = options.location();
    std::vector<std::string> names = options.scenes.empty() ? golden::all_scenes(location) : options.scenes;
    // Every name is checked before anything is written.
    for (const std::string& name : names) {
        golden::check_scene_name(name);
        if (!fs::is_regular_file(location.scene_file(name)))
            throw Error("no scene '" + name + "' (" + location.scene_file(name).string() + ")", Where::in_file(name));
    }
    for (const std::string& name : names) {
        const golden::GoldenFiles files = golden::make_golden_files(name, location, size);
        const fs::path dir = location.golden / name;
        std::error_code ec;
        fs::create_directories(dir, ec);
        if (ec) throw Error("cannot create the directory: " + ec.message(), Where::in_file(dir.string()));
        AtomicOutput image((dir / "image.png").string());
        write_image(files.image, image.temp_path().string(), ImageFormat::png, {});
        write_output((dir / "capture.txt").string(), files.capture_txt);
        write_output((dir / "mesh.txt").string(), files.mesh_txt);
        image.commit();
        std::cout << dir.string() << ": image.png " << size.x << "x" << size.y << ", capture.txt " << files.patches
                  << " patches " << files.triangles << " triangles, mesh.txt " << files.mesh_triangles
                  << " triangles\n";
    }
    return 0;
}

// ---- verify ----------------------------------------------------------------------------

std::string fixed(double x, const char* format) {
    char text[64];
    std::snprintf(text, sizeof text, format, x);
    return text;
}

int run_verify(const GoldenOptions& options) {
    const golden::Location location = options.location();
    const std::vector<std::string> names = options.scenes.empty() ? golden::all_scenes(location) : options.scenes;
    const fs::path keep = options.keep;
    // GL_RENDERER names llvmpipe in the header: from the first scene's own GL child (one
    // process start fewer), else from a child of its own.
    std::string renderer;
    const auto know_renderer = [&](const golden::SceneVerdict& v) {
        if (renderer.empty()) renderer = v.renderer.empty() ? gl::renderer_isolated() : v.renderer;
    };
    std::size_t name_width = 5;
    for (const std::string& n : names) name_width = std::max(name_width, n.size());
    const auto header = [&] {
        std::cout << "golden verify: " << renderer << " against " << options.golden_dir << "/\n"
                  << std::left << std::setw(static_cast<int>(name_width)) << "scene" << std::right;
        for (const Column& c : columns()) std::cout << " " << std::setw(c.width) << c.header;
        std::cout << "  verdict\n";
    };
    std::vector<golden::SceneVerdict> verdicts;
    golden::Verdict worst = golden::Verdict::pass;
    golden::verify_scenes(names, location, keep, [&](golden::SceneVerdict verdict) {
        verdicts.push_back(std::move(verdict));
        const golden::SceneVerdict& v = verdicts.back();
        if (verdicts.size() == 1) {
            know_renderer(v);
            if (!options.json) header();
        }
        worst = std::max(worst, v.verdict());
        // A scene that could not be verified is also an error message on stderr, as every
        // command reports bad input; the run goes on.
        for (const std::string& e : v.missing) std::cerr << "tessref: error: " << e << "\n";
        if (!v.corrupt.empty()) std::cerr << "tessref: error: " << v.corrupt.front() << "\n";
        if (!v.error.empty()) std::cerr << "tessref: error: " << v.error << "\n";
        if (options.json) return;
        const bool measured = v.verdict() != golden::Verdict::missing && v.verdict() != golden::Verdict::error &&
                              v.triangles != 0;
        const bool gl = measured && v.gl_compared && v.seconds_gl > 0;
        const std::vector<std::string> cells{
            measured ? std::to_string(v.triangles) : "-",
            gl ? std::to_string(v.failing_pixels) : "-",
            gl ? std::to_string(v.explained_pixels) : "-",
            gl ? fixed(v.max_error, "%.4f") : "-",
            gl ? std::to_string(v.position_ulps) : "-",
            gl ? std::to_string(v.normal_ulps) : "-",
            gl ? std::to_string(v.level_divergent_patches) : "-",
            gl ? std::to_string(v.level_ulps) : "-",
            gl ? fixed(v.level_difference, "%.2g") : "-",
            gl ? fixed(v.seconds_gl, "%.2f") : "-",
        };
        std::cout << std::left << std::setw(static_cast<int>(name_width)) << v.scene << std::right;
        for (std::size_t i = 0; i < cells.size(); ++i) std::cout << " " << std::setw(columns()[i].width) << cells[i];
        std::cout << "  " << golden::verdict_name(v.verdict()) << "\n";
        // A line that starts with two spaces continues the note above it.
        const auto notes = [](const std::string& label, const std::vector<std::string>& lines) {
            for (const std::string& s : lines) {
                const bool continuation = s.rfind("  ", 0) == 0;
                std::cout << "    " << (continuation ? std::string(label.size(), ' ') + s.substr(2) : label + s) << "\n";
            }
        };
        notes("missing: ", v.missing);
        notes("corrupt: ", v.corrupt);
        if (!v.error.empty()) notes("error: ", {v.error});
        notes("stale: ", v.stale);
        notes("fails: ", v.failures);
    });
    if (verdicts.empty()) {  // no scene: the header all the same
        know_renderer({});
        if (!options.json) header();
    }
    if (options.json) {
        nlohmann::json j;
        j["renderer"] = utf8_for_json(renderer);
        j["passed"] = golden::exit_status(worst) == 0;
        j["worst"] = golden::verdict_name(worst);
        j["scenes"] = nlohmann::json::array();
        const auto texts = [](const std::vector<std::string>& lines) {
            std::vector<std::string> out;
            for (const std::string& line : lines) out.push_back(utf8_for_json(line));
            return out;
        };
        for (const golden::SceneVerdict& v : verdicts)
            j["scenes"].push_back({{"scene", utf8_for_json(v.scene)},
                                   {"triangles", v.triangles},
                                   {"failing_pixels", v.failing_pixels},
                                   {"level_divergent_pixels", v.explained_pixels},
                                   {"max_error", v.max_error},
                                   {"position_ulps", v.position_ulps},
                                   {"normal_ulps", v.normal_ulps},
                                   {"level_divergent_patches", v.level_divergent_patches},
                                   {"level_ulps", v.level_ulps},
                                   {"level_difference", v.level_difference},
                                   {"missing", texts(v.missing)},
                                   {"corrupt", texts(v.corrupt)},
                                   {"error", utf8_for_json(v.error)},
                                   {"stale", texts(v.stale)},
                                   {"failures", texts(v.failures)},
                                   {"verdict", golden::verdict_name(v.verdict())}});
        std::cout << j.dump(2) << "\n";
    } else {
        std::cout << legend();
        std::cout << (golden::exit_status(worst) == 0 ? "every scene passes"
                                                      : std::string("worst verdict: ") + golden::verdict_name(worst))
                  << (keep.empty() ? "" : " (pictures and captures kept in " + keep.string() + ")") << "\n";
    }
    return golden::exit_status(worst);
}

}  // namespace

Command add_golden_command(CLI::App& parent) {
    auto options = std::make_shared<GoldenOptions>();
    CLI::App* app = parent.add_subcommand(
        "golden",
        "The CPU reference as golden output: `update` writes golden/<scene>/ (image.png, capture.txt, mesh.txt) "
        "from the CPU pipeline; `verify` checks the CPU side still makes them, then renders every scene through the "
        "GL backend (llvmpipe) and compares its image and capture with them (tolerances: golden/README.md). Every "
        "scene gets its own verdict and the run goes on; the worst verdict is the exit status.");
    app->add_option("action", options->action, "update | verify")->required()->check(CLI::IsMember({"update", "verify"}));
    app->add_option("scenes", options->scenes, "Scene names: file stems in --scenes (default: every *.toml there)");
    app->add_option("--golden", options->golden_dir, "The golden directory")->capture_default_str();
    app->add_option("--scenes", options->scenes_dir, "Where the scenes are")->capture_default_str();
    app->add_option("--size", options->size, "update: the image size (the viewport the pipeline sees)")
        ->capture_default_str();
    app->add_option("--keep", options->keep,
                    "verify: keep every scene's CPU and GL pictures (and, for failing scenes, the diff picture and "
                    "both captures) under DIR/<scene>/")
        ->type_name("DIR");
    app->add_flag("--json", options->json, "verify: the table as JSON");
    app->footer("Example: tessref golden verify thesis-all-10 jacksboro --keep out/\n\nverify's table. " + legend());
    return Command{app, [options] {
                       if (options->action == "update") return run_update(*options);
                       return run_verify(*options);
                   }};
}

}  // namespace tessref::cli
