// src/sweep/report_data.h — what the sweep report (report.h) reads and decides, apart from
// how it draws: DIR/sweep.csv read strictly into rows, and the rules the report states in its
// header (the Pareto front, the level at which the image error stops improving -- the knee --,
// the best level under a triangle budget, the level that dominates the scene's own, the
// gpu-vs-exact error ratio). Pure functions over plain data, so that each rule is tested by
// hand-derived examples (tests/test_sweep_report.cpp) and not only through the HTML.
#pragma once

#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace tessref::sweep {

// ---------------------------------------------------------------------------------------
// sweep.csv

// One run (one line of sweep.csv). An empty cell is nullopt / "". Timings are kept only for
// the error-vs-time plot: they differ between two runs of the same sweep, so nothing else in
// the report shows them (a merged set of shards gives the same index.html as one run).
struct SweepRow {
    std::size_t line = 0;        // 1-based line in sweep.csv (the header is line 1)
    std::string scene;
    std::string model;           // "uniform", geomip_level, geomip_bound, or the scene's own control model
    // uniform rows: in [1, 64], not always whole; geomip_level rows: 0..4; geomip_bound rows:
    // the screen-error bound in pixels (>= 0); the scene's own rows: none
    std::optional<double> level;
    std::string spacing;         // empty on a geomipmapped scene's rows (no generator)
    std::string precision;       // "gpu" or "exact" (others are shown as given)
    bool camera_relative = false;  // the optional camera_relative column (0/1)
    std::optional<double> patches, triangles, points;
    std::optional<double> total_ms;
    std::optional<double> geo_max, geo_rms, geo_max_px;
    std::optional<double> mean_edge_px, triangles_per_px;  // optional columns (older sweeps lack them)
    std::optional<double> img_rmse, img_psnr, img_fail_px;
    std::optional<double> gpu_exact_max_pos, gpu_exact_image_differs;
    std::string image, diff_image, wire_image, truth_image;  // relative to DIR

    bool uniform() const { return model == "uniform"; }
    // A geomipmapped scene's swept rows: a forced level or a screen-error bound.
    bool geomip_axis() const { return model == "geomip_level" || model == "geomip_bound"; }
    // Any row of a geomipmapped scene (its own rows' model is "geomipmap").
    bool geomip() const { return geomip_axis() || model == "geomipmap"; }
};

struct SweepTable {
    std::vector<SweepRow> rows;          // in canonical order (sort_key), whatever the file's order
    bool has_camera_relative = false;    // the file has the camera_relative column
};

// Reads `path` (sweep.csv). Columns are found by header name; unknown ones are ignored.
// Required: scene, model, level, spacing, precision, triangles, total_ms, img_rmse. Throws
// tessref::Error naming path:line (and the column, as the key) for: a missing or unreadable
// file; an empty file; a header without a required column or with a column twice; a row with
// another number of fields than the header; a quote (fields are never quoted); a non-number
// in a numeric column (the writer's "nan" and "inf" are numbers); a negative number; a level
// outside [1, 64]; a count, a time or img_rmse that is not finite (the measurements only
// shown may be nan or inf, e.g. img_psnr); a uniform or geomip_* row without a level (a
// geomip_level outside 0..4, a geomip_bound below 0); an empty spacing outside a
// geomipmapped scene's rows; a picture path that
// is absolute or climbs out of DIR (".."); two rows of the same run (same scene, model,
// level, spacing, precision, camera_relative). Rows come back sorted by scene, spacing,
// precision, camera_relative, then the scene's own rows before the uniform ones by level
// (geomip_level rows, then geomip_bound rows, each by level, after any uniform ones): a
// merged set of shards reads as one unsharded file.
SweepTable read_sweep_csv(const std::string& path);

// ---------------------------------------------------------------------------------------
// The rules

// A point of a speed/accuracy plot: cost (time or triangles) and image error.
struct CostError {
    double cost = 0.0;
    double error = 0.0;
};

// For each point, whether it is on the Pareto front of `points`: no other point has cost <=
// and error <= with at least one of the two strictly less. Equal points do not dominate each
// other, so both stay on the front. The report applies it per scene (all its spacings,
// precisions and models together).
std::vector<bool> pareto_front(std::span<const CostError> points);

// One point of an error curve: a uniform level and its image error.
struct LevelError {
    double level = 0.0;
    double error = 0.0;
};

// The tolerance under which a change of image error does not count as an improvement:
// 1% of the minimum error, but never less than half an 8-bit code value (0.5/255, in the
// [0, 1] units of img_rmse), since an 8-bit picture cannot show less.
double stop_tolerance(double minimum_error);

// The level at which the image error stops improving: the smallest level whose error is
// within stop_tolerance(m) of m, the minimum error over all levels of the curve. Raising the
// level beyond it buys at most that tolerance. nullopt for an empty curve. (The points need
// not be sorted.)
std::optional<double> stop_improving_level(std::span<const LevelError> curve);

// A uniform level's cost and image error, for the rules that weigh both.
struct LevelRun {
    double level = 0.0;
    double triangles = 0.0;
    double error = 0.0;
};

// The best level under a triangle budget: the least image error among the levels whose
// triangle count is at most `budget`, the smaller level on a tie. nullopt when none fits. The
// report's budget is the triangle count of the scene's own levels (same spacing and
// precision): what a uniform level gives for the triangles the scene's control stage spends.
std::optional<double> best_level_under_budget(std::span<const LevelRun> runs, double budget);

// The uniform level that dominates `own` (the scene's own levels; own.level is not read): the
// smallest level with triangles <= and error <= own's, at least one of the two strictly less.
// nullopt when none does: then the scene's control stage buys something no uniform level does.
std::optional<double> dominating_level(std::span<const LevelRun> runs, const LevelRun& own);

// gpu-vs-exact: the ratio gpu img_rmse / exact img_rmse at each level both precisions ran
// (levels where the exact error is 0 count only when the gpu error is 0 too, as ratio 1).
struct ErrorRatio {
    std::size_t levels = 0;  // how many levels the ratios come from; 0 = no shared level
    double median = 0.0, min = 0.0, max = 0.0;
};
ErrorRatio gpu_exact_ratio(std::span<const LevelError> gpu, std::span<const LevelError> exact);

}  // namespace tessref::sweep
