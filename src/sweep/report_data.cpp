// src/sweep/report_data.cpp — see report_data.h.
#include "sweep/report_data.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>
#include <map>
#include <tuple>
#include <utility>

#include "common/input_file.h"
#include "tessref/error.h"

namespace tessref::sweep {

namespace {

std::vector<std::string> split_fields(const std::string& line) {
    std::vector<std::string> fields;
    std::size_t start = 0;
    while (true) {
        const std::size_t comma = line.find(',', start);
        std::string field = line.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
        // Surrounding blanks are layout, not content (a hand-edited file). Quotes (CSV quoting,
        // which sweep.csv never needs) are refused by the caller.
        field.erase(0, field.find_first_not_of(" \t"));
        field.erase(field.find_last_not_of(" \t") + 1);
        fields.push_back(std::move(field));
        if (comma == std::string::npos) return fields;
        start = comma + 1;
    }
}

// The whole text as a double (from_chars: no locale, no leading '+', "inf"/"nan" allowed).
std::optional<double> parse_number(const std::string& text) {
    double value = 0.0;
    const char* first = text.data();
    const char* last = first + text.size();
    const auto [end, ec] = std::from_chars(first, last, value);
    if (ec != std::errc() || end != last || text.empty()) return std::nullopt;
    return value;
}

// A picture path must stay a relative link under DIR: index.html links it as written.
bool safe_relative_path(const std::string& path) {
    if (path.empty()) return true;
    if (path.front() == '/' || path.find('\\') != std::string::npos || path.find(':') != std::string::npos)
        return false;
    std::size_t start = 0;
    while (start <= path.size()) {
        const std::size_t slash = std::min(path.find('/', start), path.size());
        if (path.compare(start, slash - start, "..") == 0 && slash - start == 2) return false;
        start = slash + 1;
    }
    return true;
}

// The order of the report: scene, spacing, precision, camera_relative, the scene's own
// rows (no level) before the uniform ones, then level, then model name.
int axis_rank(const SweepRow& row) { return row.model == "geomip_level" ? 1 : row.model == "geomip_bound" ? 2 : 0; }
auto sort_key(const SweepRow& row) {
    return std::make_tuple(std::cref(row.scene), std::cref(row.spacing), std::cref(row.precision), row.camera_relative,
                           row.level.has_value(), axis_rank(row), row.level.value_or(0), std::cref(row.model));
}

}  // namespace

SweepTable read_sweep_csv(const std::string& path) {
    std::istringstream in(read_input_file(path, "sweep table", kTableFileBytes));

    std::string line;
    if (!std::getline(in, line))
        throw Error("the sweep table is empty: expected a header line", Where::in_file(path, 1));
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::vector<std::string> header = split_fields(line);
    std::map<std::string, std::size_t> column;
    for (std::size_t i = 0; i < header.size(); ++i) {
        if (header[i].empty()) continue;
        if (!column.emplace(header[i], i).second)
            throw Error("column '" + header[i] + "' appears twice in the header", Where::at(path, 1, 0, header[i]));
    }
    for (const char* required :
         {"scene", "model", "level", "spacing", "precision", "triangles", "total_ms", "img_rmse"})
        if (!column.count(required))
            throw Error(std::string("the header has no '") + required + "' column", Where::in_file(path, 1));

    SweepTable table;
    table.has_camera_relative = column.count("camera_relative") > 0;
    std::size_t line_number = 1;
    std::size_t first_blank = 0;  // blank lines are allowed only at the end of the file
    while (std::getline(in, line)) {
        ++line_number;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.find_first_not_of(" \t") == std::string::npos) {
            if (!first_blank) first_blank = line_number;
            continue;
        }
        if (first_blank) throw Error("a blank line inside the sweep table", Where::in_file(path, first_blank));
        if (line.find('"') != std::string::npos)
            throw Error("a quote: sweep.csv fields are never quoted (they hold no commas)",
                        Where::in_file(path, line_number));
        const std::vector<std::string> fields = split_fields(line);
        if (fields.size() != header.size())
            throw Error("expected " + std::to_string(header.size()) + " fields (as the header), got " +
                            std::to_string(fields.size()),
                        Where::in_file(path, line_number));

        auto text = [&](const char* name) -> std::string {
            const auto it = column.find(name);
            return it == column.end() ? std::string() : fields[it->second];
        };
        // The key is the column's name: "sweep.csv:7, key img_rmse".
        auto where = [&](const char* name) { return Where::at(path, line_number, 0, name); };
        // Empty, or a number >= 0. What the report plots or counts with (counts, times,
        // img_rmse) must be finite; a measurement it only shows may be nan or inf as the
        // writer spells them (img_psnr of identical pictures is inf).
        auto number = [&](const char* name, bool finite = true) -> std::optional<double> {
            const std::string t = text(name);
            if (t.empty()) return std::nullopt;
            const std::optional<double> value = parse_number(t);
            if (!value) throw Error(std::string("column ") + name + ": '" + t + "' is not a number", where(name));
            if (*value < 0 || (finite && !std::isfinite(*value)))
                throw Error(std::string("column ") + name + ": '" + t + "' is not a " + (finite ? "finite " : "") +
                                "number >= 0",
                            where(name));
            return value;
        };

        SweepRow row;
        row.line = line_number;
        row.scene = text("scene");
        row.model = text("model");
        row.spacing = text("spacing");
        row.precision = text("precision");
        for (const char* name : {"scene", "model", "spacing", "precision"})
            if (text(name).empty() && !(row.geomip() && std::string(name) == "spacing"))
                throw Error(std::string("column ") + name + " is empty", where(name));
        if (const std::string t = text("level"); !t.empty()) {
            const std::optional<double> level = parse_number(t);
            if (row.model == "geomip_level") {
                if (!level || !(*level >= 0 && *level <= 4 && *level == std::floor(*level)))
                    throw Error("column level: '" + t + "' is not a geomip level 0..4", where("level"));
            } else if (row.model == "geomip_bound") {
                if (!level || !(*level >= 0 && std::isfinite(*level)))
                    throw Error("column level: '" + t + "' is not a screen-error bound >= 0", where("level"));
            } else if (!level || !(*level >= 1 && *level <= 64)) {  // NaN fails too
                throw Error("column level: '" + t + "' is not a level in [1, 64]", where("level"));
            }
            row.level = *level;
        }
        if ((row.uniform() || row.geomip_axis()) && !row.level)
            throw Error("a " + row.model + " row needs a level", where("level"));
        if (const std::string t = text("camera_relative"); !t.empty()) {
            if (t != "0" && t != "1")
                throw Error("column camera_relative: '" + t + "' is not 0 or 1", where("camera_relative"));
            row.camera_relative = t == "1";
        }
        row.patches = number("patches");
        row.triangles = number("triangles");
        row.points = number("points");
        for (const char* name : {"control_ms", "generator_ms", "evaluation_ms", "geometry_ms", "raster_shading_ms"})
            (void)number(name);  // not shown, but a malformed cell is still a malformed file
        row.total_ms = number("total_ms");
        row.geo_max = number("geo_max", false);
        row.geo_rms = number("geo_rms", false);
        row.geo_max_px = number("geo_max_px", false);
        row.mean_edge_px = number("mean_edge_px", false);
        row.triangles_per_px = number("triangles_per_px", false);
        row.img_rmse = number("img_rmse");
        row.img_psnr = number("img_psnr", false);
        row.img_fail_px = number("img_fail_px");
        row.gpu_exact_max_pos = number("gpu_exact_max_pos", false);
        row.gpu_exact_image_differs = number("gpu_exact_image_differs");
        row.image = text("image");
        row.diff_image = text("diff_image");
        row.wire_image = text("wire_image");
        row.truth_image = text("truth_image");
        for (const char* name : {"image", "diff_image", "wire_image", "truth_image"})
            if (!safe_relative_path(text(name)))
                throw Error(std::string("column ") + name + ": '" + text(name) +
                                "' is not a relative path inside the sweep directory",
                            where(name));
        table.rows.push_back(std::move(row));
    }
    if (in.bad()) throw Error("cannot read the sweep table", Where::in_file(path, line_number));

    std::stable_sort(table.rows.begin(), table.rows.end(),
                     [](const SweepRow& a, const SweepRow& b) { return sort_key(a) < sort_key(b); });
    for (std::size_t i = 1; i < table.rows.size(); ++i) {
        const SweepRow& a = table.rows[i - 1];
        const SweepRow& b = table.rows[i];
        if (sort_key(a) == sort_key(b))
            throw Error("the same run as line " + std::to_string(std::min(a.line, b.line)),
                        Where::in_file(path, std::max(a.line, b.line)));
    }
    return table;
}

std::vector<bool> pareto_front(std::span<const CostError> points) {
    std::vector<bool> front(points.size(), true);
    for (std::size_t i = 0; i < points.size(); ++i) {
        for (std::size_t j = 0; j < points.size() && front[i]; ++j) {
            const CostError& p = points[i];
            const CostError& q = points[j];
            if (q.cost <= p.cost && q.error <= p.error && (q.cost < p.cost || q.error < p.error)) front[i] = false;
        }
    }
    return front;
}

double stop_tolerance(double minimum_error) { return std::max(0.01 * minimum_error, 0.5 / 255.0); }

std::optional<double> stop_improving_level(std::span<const LevelError> curve) {
    if (curve.empty()) return std::nullopt;
    double minimum = curve[0].error;
    for (const LevelError& p : curve) minimum = std::min(minimum, p.error);
    const double bound = minimum + stop_tolerance(minimum);
    std::optional<double> level;
    for (const LevelError& p : curve)
        if (p.error <= bound && (!level || p.level < *level)) level = p.level;
    return level;
}

std::optional<double> best_level_under_budget(std::span<const LevelRun> runs, double budget) {
    const LevelRun* best = nullptr;
    for (const LevelRun& r : runs)
        if (r.triangles <= budget &&
            (!best || r.error < best->error || (r.error == best->error && r.level < best->level)))
            best = &r;
    return best ? std::optional<double>(best->level) : std::nullopt;
}

std::optional<double> dominating_level(std::span<const LevelRun> runs, const LevelRun& own) {
    std::optional<double> level;
    for (const LevelRun& r : runs)
        if (r.triangles <= own.triangles && r.error <= own.error &&
            (r.triangles < own.triangles || r.error < own.error) && (!level || r.level < *level))
            level = r.level;
    return level;
}

ErrorRatio gpu_exact_ratio(std::span<const LevelError> gpu, std::span<const LevelError> exact) {
    std::vector<double> ratios;
    for (const LevelError& g : gpu) {
        for (const LevelError& e : exact) {
            if (e.level != g.level) continue;
            if (e.error > 0) ratios.push_back(g.error / e.error);
            else if (g.error == 0) ratios.push_back(1.0);
        }
    }
    ErrorRatio ratio;
    ratio.levels = ratios.size();
    if (ratios.empty()) return ratio;
    std::sort(ratios.begin(), ratios.end());
    const std::size_t n = ratios.size();
    ratio.min = ratios.front();
    ratio.max = ratios.back();
    ratio.median = n % 2 ? ratios[n / 2] : 0.5 * (ratios[n / 2 - 1] + ratios[n / 2]);
    return ratio;
}

}  // namespace tessref::sweep
