// tessref pvs — the potentially visible set of a geomipmapped scene (include/tessref/
// geomipmap.h, PVS): cells over the patches in layers, a line of sight from each cell to each
// patch against a lower bound of every level's drawn surface (Embree; conservative at the
// cells' sample points, docs/GEOMIPMAP.md), one bit per cell and patch.
//
//   tessref pvs SCENE -o FILE [--layers N] [--target-step S] [--threads N]
//
// The file goes to a temporary name next to FILE and is renamed over it only when complete;
// a scene names it with [culling] pvs = "FILE".
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "tessref/error.h"
#include "tessref/geomipmap.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"
#include "tessref/scene.h"

namespace tessref::cli {

namespace {

struct PvsCommandOptions {
    std::string scene;
    std::string output;
    int layers = geomip::Pvs::kDefaultLayers;
    int target_step = 4;
    int threads = 0;
};

int run_pvs(const PvsCommandOptions& options) {
    if (options.layers < 1 || options.layers > 4096)
        throw Error("--layers " + std::to_string(options.layers) + " is outside [1, 4096]", Where::in_file("--layers"));
    if (options.target_step < 1 || options.target_step > geomip::kPatchCells ||
        geomip::kPatchCells % options.target_step != 0)
        throw Error("--target-step " + std::to_string(options.target_step) + " must be 1, 2, 4, 8 or 16",
                    Where::in_file("--target-step"));
    const ThreadLimit thread_limit(options.threads);
    AtomicOutput output(options.output);
    const Scene scene = load_scene(options.scene);
    if (scene.evaluation.model != EvaluationModel::geomipmap)
        throw Error("tessref pvs builds the PVS of a geomipmapped terrain (evaluation model geomipmap)",
                    Where::at_key(scene.file, "evaluation.model"));
    const GeomipTerrain terrain = geomip_terrain(scene);
    const auto start = std::chrono::steady_clock::now();
    const std::size_t cells = static_cast<std::size_t>(terrain.map.patches_x()) * terrain.map.patches_y() *
                              static_cast<std::size_t>(options.layers);
    Progress progress("pvs cells", cells);
    const geomip::Pvs pvs = geomip::build_pvs(terrain.map, terrain.settings, options.layers, options.target_step,
                                              [&progress](std::size_t done, std::size_t) { progress.set(done); });
    progress.finish();
    geomip::write_pvs(pvs, output.temp_path().string());
    output.commit();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::size_t visible = 0;
    for (std::size_t c = 0; c < pvs.cell_count(); ++c)
        for (std::size_t p = 0; p < pvs.patch_count(); ++p) visible += pvs.visible(c, p);
    char line[256];
    std::snprintf(line, sizeof line,
                  "%s: %d x %d patches x %d layers (z %.6g to %.6g), %zu of %zu cell-patch pairs visible (%.1f%%), "
                  "%zu bytes of bits, %.2f s\n",
                  options.output.c_str(), pvs.patches_x, pvs.patches_y, pvs.layers, pvs.z_lo, pvs.z_hi, visible,
                  pvs.cell_count() * pvs.patch_count(),
                  100.0 * static_cast<double>(visible) / static_cast<double>(pvs.cell_count() * pvs.patch_count()),
                  pvs.bits.size(), seconds);
    std::cout << line;
    return 0;
}

}  // namespace

Command add_pvs_command(CLI::App& parent) {
    auto options = std::make_shared<PvsCommandOptions>();
    CLI::App* app = parent.add_subcommand(
        "pvs",
        "Build the potentially visible set of a geomipmapped scene (the geomorphing article's PVS): for each cell "
        "(patch x layer, 32 layers over three times the terrain's height) the patches a line of sight from the cell "
        "reaches, conservatively (against a lower bound of every level's surface, to the top of each patch's box). A scene uses it with [culling] pvs = \"FILE\".");
    app->add_option("scene", options->scene, "Scene file (TOML), evaluation model geomipmap")->required();
    app->add_option("-o,--output", options->output, "Output PVS file")->required();
    app->add_option("--layers", options->layers, "Layers of cells over three times the terrain's height")
        ->default_val(geomip::Pvs::kDefaultLayers);
    app->add_option("--target-step", options->target_step,
                    "Step between a patch's target samples (1, 2, 4, 8 or 16; smaller is slower and finer)")
        ->default_val(4);
    app->add_option("--threads", options->threads, "Worker threads (0: every core); the file is the same whatever "
                                                   "the count")
        ->default_val(0);
    app->footer("Example: tessref pvs data/scenes/jacksboro-geomipmap.toml -o jacksboro.pvs");
    return Command{app, [options] { return run_pvs(*options); }};
}

}  // namespace tessref::cli
