// src/sweep/sweep.h — `tessref sweep`: the speed/accuracy trade of tessellation levels,
// measured (docs/SWEEP.md documents the command, every column, sharding and merging).
//
// A sweep runs every scene at every combination of a uniform level (the same level on all
// four outer and both inner levels: the constant control model; lab 4, whose evaluation
// needs its own control stage, gets min_level = max_level = the level), a spacing and a
// precision, plus, per scene and precision, one row for the scene's own control stage. Per
// row it times the pipeline's stages and the rasterizer + shading, measures the geometric
// error against the full-resolution height field (geometric_error.h) and the image error
// against the ray-traced ground truth (render.h raytrace_scene, compare.h), and, where both
// precisions run, how far the gpu run lies from the exact one.
//
// ROWS are numbered in their CSV order: per scene (command-line order), per camera_relative
// value (--camera-relative order), first the scene's own rows (one per precision, in
// --precision order), then per spacing (--spacing order), per precision, per level
// (ascending). A geomipmapped scene's rows: per camera_relative value, its own rows, then
// per precision per forced geomip level (ascending), then per precision per screen-error
// bound (ascending). A GROUP is the rows that differ only in precision
// (they share the gpu-exact comparison); groups are numbered in order of their first row.
// Shard I of N runs the groups g with g % N == I: the unit of sharding is the group, so that
// both rows of a gpu/exact pair are computed in one process.
//
// DIRECTORY. DIR/sweep.csv (the rows the run holds, in row order), DIR/sweep.json (the
// sweep's parameters, the shard and the row numbers it holds), DIR/images/ (pictures), and
// the report (report.h). Everything is written into a temporary directory beside DIR and
// renamed into place at the end: no partial DIR.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/scene.h"
#include "tessref/tessellator.h"

namespace tessref::sweep {

struct SweepParameters {
    std::vector<std::string> scenes;        // scene files, as given
    std::vector<double> levels;             // ascending, distinct, each in [1, 64]
    std::vector<Precision> precisions;      // distinct, in the order given
    std::vector<Spacing> spacings;          // distinct, in the order given; empty: each scene's own
    // Camera-relative evaluation off and/or on (PipelineOptions::camera_relative), distinct,
    // in the order given: every row is run once per value.
    std::vector<bool> camera_relative{false};
    // Geomipmapped scenes ([evaluation] model = "geomipmap") have no tessellation level: in
    // place of the uniform rows they get one row per forced geomip level (every patch at
    // that level, no tween) and one per screen-error bound (the scene's selection with that
    // error_bound_px). Each ascending and distinct; either may be empty. --levels and
    // --spacing do not apply to them.
    std::vector<int> geomip_levels{0, 1, 2, 3, 4};              // each in 0..4
    std::vector<double> error_bounds{0.0, 0.5, 1.0, 2.0, 4.0, 8.0};  // pixels, each in [0, 1e6]
    int repeat = 3;                         // timings: median of this many runs (the command's default)
    glm::ivec2 size{320, 200};              // image size (replaces the cameras' viewports)
    // --shader STAGE=FILE: over every scene's [shaders] (a user's stage runs through the
    // interpreter, tessref/shader.h, in every row; gpu precision only).
    std::vector<StageShader> shaders;
};

struct Shard {
    int index = 0;  // 0 .. count - 1
    int count = 1;
};

// The CSV's columns, in order (report.h finds them by these names).
const std::vector<std::string>& csv_columns();

// Called as each row starts: (rows done in this shard, rows in this shard, the starting
// row's description); and once at the end with done == total and an empty description.
using SweepProgress = std::function<void(std::size_t done, std::size_t total, const std::string& row)>;

// The items of a comma-separated flag value, blanks around each trimmed. Throws
// tessref::Error (where: flag) for an empty item.
std::vector<std::string> split_list(const std::string& text, const std::string& flag);

// Parses --levels: comma-separated items, each a number or an integer range A..B (both
// ends included), e.g. "1..64", "1,2,4,8", "1..4,8,16.5". The result is sorted and
// distinct. Throws tessref::Error (where: --levels) naming the item for a non-number, NaN,
// a level outside 1..64, or an empty or reversed range.
std::vector<double> parse_levels(const std::string& text);

// Parses --geomip-levels: as --levels, items in 0..4 (integers), or "none" (no such rows).
// Throws tessref::Error (where: --geomip-levels).
std::vector<int> parse_geomip_levels(const std::string& text);

// Parses --error-bounds: comma-separated numbers of pixels in [0, 1e6], or "none". Sorted,
// distinct. Throws tessref::Error (where: --error-bounds).
std::vector<double> parse_error_bounds(const std::string& text);

// Runs the sweep's rows of `shard` and writes DIR (see DIRECTORY). Loads and checks every
// scene first (an unknown scene, one without a camera, duplicate scene names, a uniform
// level over a scene's triangle budget: tessref::Error before anything is written), and
// refuses a DIR that is an existing file or a non-empty directory that is not a sweep.
// Returns the number of rows written.
std::size_t run_sweep(const SweepParameters& parameters, const Shard& shard, const std::string& dir,
                      const SweepProgress& progress = {});

// Joins shard directories of one sweep into OUT: sweep.csv and sweep.json exactly as the
// unsharded run writes them (the *_ms columns aside, which are measured), the pictures, the
// report. Throws tessref::Error naming the directory for one that is not a sweep, belongs
// to another sweep (other parameters), repeats a shard, or holds a corrupt sweep.csv; and
// naming the missing shard when one is missing.
void merge_sweeps(const std::vector<std::string>& dirs, const std::string& out);

}  // namespace tessref::sweep
