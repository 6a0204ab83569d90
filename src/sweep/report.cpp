// src/sweep/report.cpp — see report.h. The rules it states (Pareto front, the level at which
// the error stops improving, the gpu/exact ratio) live in report_data.h; the drawing in
// plot.h. This file only arranges them into plots/ and index.html.
//
// Everything written is a function of sweep.csv alone, rows taken in report_data.h's
// canonical order: the same table gives the same bytes, and shards merged in any order give
// the report of one run. Timings differ between runs of the same sweep, so they appear only
// in the error-vs-time plot, never in index.html.
#include "sweep/report.h"

#include "common/temp_cleanup.h"
#include "common/temp_name.h"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <system_error>
#include <tuple>

#include "picture/svg.h"
#include "sweep/plot.h"
#include "sweep/report_data.h"
#include "tessref/error.h"

namespace tessref::sweep {

namespace fs = std::filesystem;

namespace {

// ---------------------------------------------------------------------------------------
// Writing files: a temporary name beside the target, renamed into place once complete, so
// that a failure never leaves a half-written file under the real name.

fs::path temp_name(const fs::path& target) {
    fs::path temp = target.parent_path() / temporary_name(".", target.stem().string(), ".tmp-" + std::to_string(::getpid()),
                                                          target.extension().string());
    name_temporary(temp, target);  // an error message names the target (temp_cleanup.h)
    return temp;
}

void replace_with(const fs::path& temp, const fs::path& target) {
    std::error_code ec;
    fs::rename(temp, target, ec);
    if (ec) {
        fs::remove(temp, ec);
        throw Error("cannot put the file in place: " + ec.message(), Where::in_file(target.string()));
    }
}

void write_text_atomically(const fs::path& target, const std::string& bytes) {
    const fs::path temp = temp_name(target);
    {
        std::ofstream out(temp, std::ios::binary | std::ios::trunc);
        out << bytes;
        out.flush();
        if (!out) {
            std::error_code ec;
            fs::remove(temp, ec);
            throw Error("cannot write the file", Where::in_file(target.string()));
        }
    }
    replace_with(temp, target);
}

void write_png_atomically(const fs::path& target, const PlotShapes& shapes) {
    const fs::path temp = temp_name(target);  // keeps ".png": the writer picks the format by it
    try {
        write_plot_png(shapes, temp.string());
    } catch (...) {
        std::error_code ec;
        fs::remove(temp, ec);
        throw;
    }
    replace_with(temp, target);
}

// ---------------------------------------------------------------------------------------
// Text

std::string html(const std::string& s) { return picture::xml_escape(s); }

// A relative path as a URL: bytes outside the unreserved set and '/' percent-encoded.
std::string url(const std::string& path) {
    std::string out;
    for (unsigned char c : path) {
        if (std::isalnum(c) || c == '-' || c == '.' || c == '_' || c == '~' || c == '/') {
            out += static_cast<char>(c);
        } else {
            char buffer[4];
            std::snprintf(buffer, sizeof buffer, "%%%02X", c);
            out += buffer;
        }
    }
    return out;
}

std::string anchor_id(const std::string& scene) {
    std::string id = "scene-";
    for (unsigned char c : scene) id += std::isalnum(c) || c == '-' || c == '_' ? static_cast<char>(c) : '-';
    return id;
}

std::string num(double x, int digits = 4) {
    if (std::isnan(x)) return "nan";  // whatever its sign bit (printf may say "-nan")
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.*g", digits, x);
    return buffer;
}
std::string num(const std::optional<double>& x, int digits = 4) { return x ? num(*x, digits) : "–"; }
// Levels as the sweep wrote them ("%.9g": "8", "2.5").
std::string level_str(double level) { return num(level, 9); }
std::string count(const std::optional<double>& x) { return x ? num(*x, 15) : "–"; }

// ---------------------------------------------------------------------------------------
// Series: the rows of one scene, spacing, precision and camera_relative (contiguous in the
// canonical order).

struct Series {
    std::string scene, spacing, precision;
    bool camera_relative = false;
    std::string axis;  // a geomipmapped scene's geomip_level or geomip_bound rows: that model; else empty
    std::vector<const SweepRow*> rows;

    std::vector<LevelError> curve() const {
        std::vector<LevelError> points;
        for (const SweepRow* row : rows)
            if (row->uniform() && row->img_rmse) points.push_back({*row->level, *row->img_rmse});
        return points;
    }
    std::vector<LevelRun> runs() const {
        std::vector<LevelRun> out;
        for (const SweepRow* row : rows)
            if (row->uniform() && row->img_rmse && row->triangles) out.push_back({*row->level, *row->triangles, *row->img_rmse});
        return out;
    }
    // The scene's own levels (its control model), when the series ran them.
    const SweepRow* own() const {
        for (const SweepRow* row : rows)
            if (!row->uniform() && !row->geomip_axis()) return row;
        return nullptr;
    }
    const SweepRow* at_level(double level) const {
        for (const SweepRow* row : rows)
            if (row->uniform() && row->level == level) return row;
        return nullptr;
    }
};

std::string series_label(const Series& s, bool has_camera_relative) {
    std::string label = s.scene + (s.spacing.empty() ? "" : " " + s.spacing) + " " + s.precision;
    if (!s.axis.empty()) label += " " + s.axis;
    if (has_camera_relative) label += s.camera_relative ? " camera-relative" : " world";
    return label;
}

std::vector<Series> group_series(const SweepTable& table) {
    std::vector<Series> series;
    for (const SweepRow& row : table.rows) {
        const std::string axis = row.geomip_axis() ? row.model : std::string();
        if (series.empty() || series.back().scene != row.scene || series.back().spacing != row.spacing ||
            series.back().precision != row.precision || series.back().camera_relative != row.camera_relative ||
            series.back().axis != axis)
            series.push_back({row.scene, row.spacing, row.precision, row.camera_relative, axis, {}});
        series.back().rows.push_back(&row);
    }
    return series;
}

// ---------------------------------------------------------------------------------------
// Plots

using Column = std::function<std::optional<double>(const SweepRow&)>;

// What a plot's y axis shows: the image error (with the Pareto fronts), or a screen measure
// against the level (with the bands practitioners aim for).
struct YAxis {
    std::string label, name;
    Column value;
    bool fronts = true;
    std::vector<PlotSpec::Band> bands;
};

YAxis image_error_axis() {
    return {"image error (img_rmse, 0..1)", "img_rmse", [](const SweepRow& r) { return r.img_rmse; }, true, {}};
}

PlotSpec make_plot(const SweepTable& table, const std::vector<Series>& series, const std::string& title,
                   const std::string& x_label, const std::string& x_name, const Column& cost,
                   const YAxis& y_axis = image_error_axis()) {
    PlotSpec spec;
    spec.title = title;
    spec.x_label = x_label;
    spec.y_label = y_axis.label;
    spec.bands = y_axis.bands;
    spec.pareto = y_axis.fronts;
    std::vector<std::string> point_scene;
    std::size_t left_out = 0;
    for (std::size_t s = 0; s < series.size(); ++s) {
        spec.series.push_back({series_label(series[s], table.has_camera_relative), series_colour(s)});
        for (const SweepRow* row : series[s].rows) {
            const std::optional<double> x = cost(*row);
            const std::optional<double> y = y_axis.value(*row);
            if (!x || !(*x > 0) || !y || !std::isfinite(*y)) {  // a log axis has no place for 0
                ++left_out;
                continue;
            }
            const std::string label = row->uniform()                  ? level_str(*row->level)
                                      : row->model == "geomip_level" ? "L" + level_str(*row->level)
                                      : row->model == "geomip_bound" ? level_str(*row->level) + " px"
                                                                     : "own";
            spec.points.push_back({*x, *y, s, !row->uniform() && !row->geomip_axis(), false, label});
            point_scene.push_back(row->scene);
        }
    }
    if (left_out)
        spec.note = std::to_string(left_out) + " run" + (left_out == 1 ? "" : "s") + " without " + y_axis.name +
                    (y_axis.fronts ? " or with " + x_name + " 0" : " or " + x_name) + " left out";
    if (!y_axis.fronts) return spec;
    // The front of each scene, over all its series.
    for (std::size_t begin = 0; begin < spec.points.size();) {
        std::size_t end = begin;
        while (end < spec.points.size() && point_scene[end] == point_scene[begin]) ++end;
        std::vector<CostError> points;
        for (std::size_t i = begin; i < end; ++i) points.push_back({spec.points[i].x, spec.points[i].y});
        const std::vector<bool> front = pareto_front(points);
        std::vector<PlotPoint> staircase;
        for (std::size_t i = begin; i < end; ++i) {
            spec.points[i].pareto = front[i - begin];
            if (front[i - begin]) staircase.push_back(spec.points[i]);
        }
        std::sort(staircase.begin(), staircase.end(), [](const PlotPoint& a, const PlotPoint& b) {
            return std::tie(a.x, a.y) < std::tie(b.x, b.y);
        });
        spec.fronts.push_back(std::move(staircase));
        begin = end;
    }
    return spec;
}

// ---------------------------------------------------------------------------------------
// index.html

// Inline: the page must work opened from disk with no network, so no file or font is fetched.
constexpr const char* kStyle = R"(body{font:14px/1.45 system-ui,sans-serif;margin:24px auto;max-width:1200px}
body{padding:0 16px;color:#222}
h1{font-size:24px}
h2{font-size:19px;margin-top:36px;border-bottom:1px solid #ddd}
h3{font-size:15px}
table{border-collapse:collapse;margin:8px 0}
th,td{border:1px solid #ccc;padding:3px 8px;text-align:right}
th{background:#f3f3f3}
td.t,th.t{text-align:left}
.verdict{background:#eef5ff;border-left:4px solid #1f77b4;padding:6px 10px}
figure{margin:6px 10px 6px 0;display:inline-block;vertical-align:top}
figure img{max-width:360px;border:1px solid #ccc}
.plots img{max-width:100%}
.missing{display:inline-block;width:200px;padding:40px 0;text-align:center;color:#888;border:1px dashed #ccc}
figcaption{font-size:12px;color:#444}
.strip{margin:10px 0;border-top:1px dotted #ccc;padding-top:6px}
code{font-size:13px})";

std::string level_text(const SweepRow& row) {
    if (row.model == "geomip_level") return "geomip level " + level_str(*row.level) + " on every patch";
    if (row.model == "geomip_bound") return "geomip error bound " + level_str(*row.level) + " px";
    return row.uniform() ? "level " + level_str(*row.level) : "the scene's own levels (" + row.model + ")";
}

std::string series_words(const Series& s, bool has_camera_relative) {
    std::string words = (s.spacing.empty() ? std::string() : s.spacing + " spacing, ") + s.precision + " precision";
    if (has_camera_relative) words += s.camera_relative ? ", camera-relative" : ", world coordinates";
    return words;
}

// One sentence per scene: where its series stop improving, series that stop at the same
// level named together ("at level 8 (equal gpu, fractional_odd gpu) and at level 12 (...)"),
// or "every spacing and precision" when they all agree. The numbers behind it are in the
// summary table.
std::string verdict(const std::vector<const Series*>& series, bool has_camera_relative) {
    std::map<double, std::vector<std::string>> by_level;
    std::vector<std::string> unknown;
    for (const Series* s : series) {
        std::string name = s->spacing + " " + s->precision;
        if (has_camera_relative) name += s->camera_relative ? " camera-relative" : " world";
        if (const std::optional<double> stop = stop_improving_level(s->curve()))
            by_level[*stop].push_back(name);
        else
            unknown.push_back(name);
    }
    auto list = [](const std::vector<std::string>& names) {
        std::string text;
        for (std::size_t i = 0; i < names.size(); ++i) text += (i ? ", " : "") + html(names[i]);
        return text;
    };
    std::string text = "In <b>" + html(series.front()->scene) + "</b> the image error ";
    const bool geomip = std::all_of(series.begin(), series.end(), [](const Series* s) {
        return std::all_of(s->rows.begin(), s->rows.end(), [](const SweepRow* r) { return r->geomip(); });
    });
    if (geomip)
        return "<b>" + html(series.front()->scene) + "</b> is a geomipmapped terrain: it has no uniform tessellation "
               "level, so the rules on uniform levels do not apply; its forced geomip levels (geomip_level) and "
               "screen-error bounds (geomip_bound) are the runs below and the joined points of the plots.";
    if (by_level.empty()) return text + "cannot be placed: no uniform level has an image error.";
    text += "stops improving";
    std::size_t i = 0;
    for (const auto& [level, names] : by_level) {
        if (i++) text += i == by_level.size() ? " and" : ",";
        text += " at <b>level " + level_str(level) + "</b>";
        if (by_level.size() == 1 && unknown.empty())
            text += series.size() == 1 ? " (" + list(names) + ")" : " with every spacing and precision it ran";
        else
            text += " (" + list(names) + ")";
    }
    if (!unknown.empty()) text += "; no uniform level has an image error with " + list(unknown);
    return text + ".";
}

// The levels the page recommends for one series, by the two stated rules.
struct Advice {
    std::optional<double> knee;    // stop_improving_level
    std::optional<double> budget;  // best_level_under_budget, the budget the own levels' triangles
    bool recommends(const SweepRow& row) const {
        return row.uniform() && (row.level == knee || row.level == budget);
    }
};

Advice advice_of(const Series& s) {
    Advice a;
    a.knee = stop_improving_level(s.curve());
    const SweepRow* own = s.own();
    if (own && own->triangles) a.budget = best_level_under_budget(s.runs(), *own->triangles);
    return a;
}

std::string run_words(const SweepRow& row) {
    return "img_rmse " + num(row.img_rmse) + ", " + count(row.triangles) + " triangles";
}

// Per series with uniform levels: the recommended levels and the rule that chose each, and,
// where a uniform level beats the scene's own control stage on both counts, that sentence.
std::string recommendations(const std::vector<const Series*>& series, bool has_camera_relative) {
    std::string items, dominated;
    for (const Series* s : series) {
        const Advice a = advice_of(*s);
        if (!a.knee) continue;
        const std::vector<LevelError> curve = s->curve();
        const LevelError* best = &curve.front();
        for (const LevelError& p : curve)
            if (p.error < best->error || (p.error == best->error && p.level < best->level)) best = &p;
        const SweepRow& knee = *s->at_level(*a.knee);
        items += "<li>" + html(series_words(*s, has_camera_relative)) + ": <b>level " + level_str(*a.knee) +
                 "</b>, the knee (" + html(run_words(knee)) + "): the least image error is " + num(best->error) +
                 " at level " + level_str(best->level) + ", and level " + level_str(*a.knee) +
                 " is the smallest within " + num(stop_tolerance(best->error)) + " of it";
        const SweepRow* own = s->own();
        if (own && own->triangles) {
            items += "; under the triangle budget of the scene's own levels (" + count(own->triangles) + "), ";
            if (a.budget)
                items += "<b>level " + level_str(*a.budget) + "</b> (" + html(run_words(*s->at_level(*a.budget))) +
                         ")";
            else
                items += "no uniform level fits";
            if (own->img_rmse) {
                if (const std::optional<double> d = dominating_level(s->runs(), {0.0, *own->triangles, *own->img_rmse})) {
                    const SweepRow& u = *s->at_level(*d);
                    dominated += "<p class=verdict>The scene's own control stage (" + html(own->model) +
                                 ") is dominated with " + html(series_words(*s, has_camera_relative)) +
                                 ": uniform level " + level_str(*d) + " draws " +
                                 (*u.triangles < *own->triangles ? "fewer" : "as many") + " triangles (" +
                                 count(u.triangles) + " against " + count(own->triangles) + ") with " +
                                 (*u.img_rmse < *own->img_rmse ? "a lower" : "the same") + " image error (" +
                                 num(u.img_rmse) + " against " + num(own->img_rmse) + ").</p>\n";
                }
            }
        }
        items += ".</li>\n";
    }
    if (items.empty()) return dominated;
    return "<p>Recommended uniform levels (their pictures are below):</p>\n<ul>\n" + items + "</ul>\n" + dominated;
}

std::string coordinates_cell(bool camera_relative) {
    return std::string("<td class=t>") + (camera_relative ? "camera-relative" : "world") + "</td>";
}

void summary_table(std::string& out, const std::vector<const Series*>& series, bool has_camera_relative) {
    out += "<table>\n<tr><th class=t>spacing</th><th class=t>precision</th>";
    if (has_camera_relative) out += "<th class=t>coordinates</th>";
    out += "<th>uniform levels run</th><th>minimum img_rmse (level)</th><th>stops improving at</th>"
           "<th>img_rmse there</th><th>triangles there</th><th>geo_max there</th>"
           "<th>scene's own levels: img_rmse</th><th>triangles</th><th>smallest uniform level as accurate</th></tr>\n";
    for (const Series* s : series) {
        const std::vector<LevelError> curve = s->curve();
        std::set<double> levels;
        for (const SweepRow* row : s->rows)
            if (row->uniform()) levels.insert(*row->level);
        const std::string spacing = !s->spacing.empty() ? s->spacing : !s->axis.empty() ? s->axis : "–";
        out += "<tr><td class=t>" + html(spacing) + "</td><td class=t>" + html(s->precision) + "</td>";
        if (has_camera_relative) out += coordinates_cell(s->camera_relative);
        out += "<td>" + (levels.empty() ? std::string("none")
                                         : std::to_string(levels.size()) + " (" + level_str(*levels.begin()) +
                                               "–" + level_str(*levels.rbegin()) + ")") +
               "</td>";
        const std::optional<double> stop = stop_improving_level(curve);
        if (stop) {
            const LevelError* best = &curve.front();
            for (const LevelError& p : curve)
                if (p.error < best->error) best = &p;
            const SweepRow* at = s->at_level(*stop);
            out += "<td>" + num(best->error) + " (" + level_str(best->level) + ")</td><td>" +
                   level_str(*stop) + "</td><td>" + num(at->img_rmse) + "</td><td>" + count(at->triangles) +
                   "</td><td>" + num(at->geo_max) + "</td>";
        } else {
            out += "<td>–</td><td>–</td><td>–</td><td>–</td><td>–</td>";
        }
        // The scene's own levels, and the cheapest uniform level that matches their error.
        const SweepRow* own = nullptr;
        for (const SweepRow* row : s->rows)
            if (!row->uniform() && !row->geomip_axis()) own = own ? own : row;
        if (own) {
            std::string matched = "none";
            if (own->img_rmse)
                for (const LevelError& p : curve)  // in level order
                    if (p.error <= *own->img_rmse) {
                        matched = level_str(p.level);
                        break;
                    }
            out += "<td>" + num(own->img_rmse) + "</td><td>" + count(own->triangles) + "</td><td>" + matched + "</td>";
        } else {
            out += "<td>–</td><td>–</td><td>–</td>";
        }
        out += "</tr>\n";
    }
    out += "</table>\n";
}

void runs_table(std::string& out, const std::vector<const Series*>& series, bool has_camera_relative) {
    std::size_t runs = 0;
    for (const Series* s : series) runs += s->rows.size();
    out += "<details><summary>All " + std::to_string(runs) + " runs</summary>\n<table>\n<tr>"
           "<th class=t>spacing</th><th class=t>precision</th>";
    if (has_camera_relative) out += "<th class=t>coordinates</th>";
    out += "<th class=t>levels</th><th>patches</th><th>triangles</th><th>points</th><th>geo_max</th><th>geo_rms</th>"
           "<th>geo_max_px</th><th>mean_edge_px</th><th>triangles_per_px</th><th>img_rmse</th><th>img_psnr</th><th>img_fail_px</th><th>gpu_exact_max_pos</th>"
           "<th>gpu_exact_image_differs</th></tr>\n";
    for (const Series* s : series) {
        for (const SweepRow* row : s->rows) {
            out += "<tr><td class=t>" + html(row->spacing.empty() ? std::string("–") : row->spacing) +
                   "</td><td class=t>" + html(row->precision) + "</td>";
            if (has_camera_relative) out += coordinates_cell(row->camera_relative);
            const std::string levels = row->uniform()                  ? level_str(*row->level)
                                       : row->model == "geomip_level" ? "geomip L" + level_str(*row->level)
                                       : row->model == "geomip_bound" ? "bound " + level_str(*row->level) + " px"
                                                                      : row->model;
            out += "<td class=t>" + html(levels) + "</td><td>" +
                   count(row->patches) + "</td><td>" + count(row->triangles) + "</td><td>" + count(row->points) +
                   "</td><td>" + num(row->geo_max) + "</td><td>" + num(row->geo_rms) + "</td><td>" +
                   num(row->geo_max_px) + "</td><td>" + num(row->mean_edge_px) + "</td><td>" +
                   num(row->triangles_per_px) + "</td><td>" + num(row->img_rmse) + "</td><td>" + num(row->img_psnr) +
                   "</td><td>" + count(row->img_fail_px) + "</td><td>" + num(row->gpu_exact_max_pos) + "</td><td>" +
                   count(row->gpu_exact_image_differs) + "</td></tr>\n";
        }
    }
    out += "</table>\n</details>\n";
}

void picture(std::string& out, const std::string& path, const std::string& caption) {
    out += "<figure>";
    if (path.empty())
        out += "<span class=missing>none</span>";
    else
        out += "<a href=\"" + html(url(path)) + "\"><img src=\"" + html(url(path)) + "\" alt=\"" + html(caption) +
               "\" loading=\"lazy\"/></a>";
    out += "<figcaption>" + html(caption) + "</figcaption></figure>";
}

void pictures(std::string& out, const std::vector<const Series*>& series, bool has_camera_relative) {
    const SweepRow* truth = nullptr;
    bool any = false;
    for (const Series* s : series)
        for (const SweepRow* row : s->rows) {
            if (!truth && !row->truth_image.empty()) truth = row;
            any = any || !row->image.empty() || !row->diff_image.empty() || !row->wire_image.empty();
        }
    if (!truth && !any) return;
    out += "<h3>Pictures</h3>\n";
    if (truth) {
        out += "<div class=strip>";
        picture(out, truth->truth_image, "ray-traced truth (Embree)");
        out += "</div>\n";
    }
    for (const Series* s : series) {
        for (const SweepRow* row : s->rows) {
            if (row->image.empty() && row->diff_image.empty() && row->wire_image.empty()) continue;
            const Advice a = advice_of(*s);
            std::string why;
            if (row->uniform() && row->level == a.knee) why = "the knee";
            if (row->uniform() && row->level == a.budget) why += (why.empty() ? "" : " and ") + std::string("the best under the budget");
            const std::string what = series_words(*s, has_camera_relative) + ", " + level_text(*row) +
                                     (why.empty() ? "" : " (recommended: " + why + ")") + ": img_rmse " +
                                     num(row->img_rmse) + ", triangles " + count(row->triangles);
            out += "<div class=strip><p>" + html(what) + "</p>";
            picture(out, row->image, "render");
            picture(out, row->diff_image, "difference to the truth");
            picture(out, row->wire_image, "wireframe");
            out += "</div>\n";
        }
    }
}

std::string make_index(const SweepTable& table, const std::vector<Series>& series) {
    std::vector<std::string> scenes;
    for (const Series& s : series)
        if (scenes.empty() || scenes.back() != s.scene) scenes.push_back(s.scene);

    std::string out = "<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n"
                      "<title>tessref sweep report</title>\n<style>\n";
    out += kStyle;
    out += "\n</style>\n</head>\n<body>\n<h1>tessref sweep report</h1>\n";
    out += "<p>" + std::to_string(table.rows.size()) + " runs of " + std::to_string(scenes.size()) +
           " scene" + (scenes.size() == 1 ? "" : "s") + ", read from <a href=\"sweep.csv\">sweep.csv</a>:";
    for (const std::string& scene : scenes)
        out += " <a href=\"#" + html(anchor_id(scene)) + "\">" + html(scene) + "</a>";
    out += ". Timings differ from run to run, so this page shows none: they are in sweep.csv and the "
           "error-against-time plot.</p>\n";

    out += "<h2>How to read it</h2>\n<ul>\n"
           "<li><b>Image error</b> is <code>img_rmse</code>: the root-mean-square difference between the render and "
           "the ray-traced truth, in the pictures' [0, 1] units.</li>\n"
           "<li><b>The level at which the image error stops improving</b>, for one scene, spacing and precision: with "
           "<i>m</i> the minimum img_rmse over all its uniform levels, the smallest uniform level whose img_rmse is at "
           "most <i>m</i> + max(1% of <i>m</i>, 0.5/255). Half an 8-bit code value is the least change a picture can "
           "show; any higher level improves the error by no more than that tolerance. This is <b>the knee</b>, the "
           "first of the recommended levels.</li>\n"
           "<li><b>The best level under the triangle budget</b>, the second: the budget is the triangle count of the "
           "scene's own levels with the same spacing and precision, and the level is the one with the least img_rmse "
           "among the uniform levels that draw no more triangles (the smaller on a tie). Where a uniform level has no "
           "more triangles and no more error than the scene's own levels, one of the two strictly less, a sentence "
           "says the scene's control stage is dominated.</li>\n"
           "<li><b>Screen measures</b>: <code>geo_max_px</code>, the geometric error's size on screen, against the "
           "shaded band of at most 1 pixel; <code>mean_edge_px</code>, the mean length of the triangles' edges on "
           "screen, against the band of 3 to 6 pixels that hardware-tessellated terrains aim at; "
           "<code>triangles_per_px</code>, triangles per covered pixel, in the table of runs.</li>\n"
           "<li><b>Time</b> in the error-against-time plot is tessref's own CPU reference's (the pipeline and the "
           "rasterizer, median of the sweep's repeats), not a GPU's: it ranks the work each level asks for.</li>\n"
           "<li><b>Pareto front</b>, per scene over all its spacings, precisions and models: the runs that no other "
           "run of the scene dominates, i.e. no other run has cost &le; and img_rmse &le; with one of the two "
           "strictly less (cost: total time in one plot, triangles in the other). Ringed in the plots, joined by a "
           "dashed staircase.</li>\n"
           "<li><b>gpu/exact ratio</b>, where a scene ran both precisions with the same spacing: gpu img_rmse divided "
           "by exact img_rmse at each uniform level both ran (a level whose exact error is 0 counts only if the gpu "
           "error is 0 too, as 1); the median and the range.</li>\n"
           "<li><b>The scene's own levels</b> (its control model, not a uniform level) are diamonds in the plots; "
           "the summary names the smallest uniform level at least as accurate.</li>\n</ul>\n";

    out += "<h2>Plots</h2>\n<div class=plots>\n";
    for (const char* name : {"error-vs-time", "error-vs-triangles", "screen-error-vs-level", "edge-length-vs-level"}) {
        const std::string base = std::string("plots/") + name;
        out += "<figure><img src=\"" + base + ".svg\" alt=\"" + name + "\"/><figcaption>" + name + " (<a href=\"" +
               base + ".svg\">SVG</a>, <a href=\"" + base + ".png\">PNG</a>)</figcaption></figure>\n";
    }
    out += "</div>\n";

    for (const std::string& scene : scenes) {
        std::vector<const Series*> of_scene;
        for (const Series& s : series)
            if (s.scene == scene) of_scene.push_back(&s);
        out += "<h2 id=\"" + html(anchor_id(scene)) + "\">" + html(scene) + "</h2>\n";
        out += "<p class=verdict>" + verdict(of_scene, table.has_camera_relative) + "</p>\n";
        out += recommendations(of_scene, table.has_camera_relative);
        // gpu/exact: pairs of series that differ only in precision.
        for (const Series* gpu : of_scene) {
            if (gpu->precision != "gpu" || gpu->spacing.empty()) continue;  // empty: a geomipmapped scene's
            for (const Series* exact : of_scene) {
                if (exact->precision != "exact" || exact->spacing != gpu->spacing ||
                    exact->camera_relative != gpu->camera_relative)
                    continue;
                const std::vector<LevelError> g = gpu->curve(), e = exact->curve();
                const ErrorRatio r = gpu_exact_ratio(g, e);
                std::string where = gpu->spacing + " spacing";
                if (table.has_camera_relative)
                    where += gpu->camera_relative ? ", camera-relative" : ", world coordinates";
                out += "<p>gpu/exact image error ratio with " + html(where) + ": ";
                if (r.levels == 0)
                    out += "no uniform level ran with both precisions.</p>\n";
                else
                    out += "median " + num(r.median) + " (from " + num(r.min) + " to " + num(r.max) + ") over the " +
                           std::to_string(r.levels) + " level" + (r.levels == 1 ? "" : "s") + " both ran.</p>\n";
            }
        }
        summary_table(out, of_scene, table.has_camera_relative);
        runs_table(out, of_scene, table.has_camera_relative);
        pictures(out, of_scene, table.has_camera_relative);
    }
    out += "</body>\n</html>\n";
    return out;
}

}  // namespace

void write_sweep_report(const std::string& dir) {
    const fs::path root(dir);
    const fs::path csv = root / "sweep.csv";
    if (!fs::is_regular_file(csv)) throw Error("no sweep.csv in the sweep directory", Where::in_file(csv.string()));
    // Read (and so validate) everything before writing anything.
    const SweepTable table = read_sweep_csv(csv.string());
    const std::vector<Series> series = group_series(table);

    const fs::path plots = root / "plots";
    std::error_code ec;
    fs::create_directories(plots, ec);
    if (ec) throw Error("cannot make the plots folder: " + ec.message(), Where::in_file(plots.string()));
    const PlotSpec time_plot =
        make_plot(table, series, "Image error against time",
                  "total time per run of tessref's CPU reference, not a GPU's (ms, median of the runs), log scale",
                  "total_ms",
                  [](const SweepRow& row) { return row.total_ms; });
    const PlotSpec triangle_plot =
        make_plot(table, series, "Image error against triangles", "triangles, log scale", "triangles",
                  [](const SweepRow& row) { return row.triangles; });
    // The screen measures against the uniform level, with the bands hardware-tessellated
    // terrains aim at: a screen error of at most a pixel, triangle edges of 3 to 6 pixels.
    const Column uniform_level = [](const SweepRow& row) { return row.uniform() ? row.level : std::nullopt; };
    const PlotSpec screen_error_plot = make_plot(
        table, series, "Screen error against level", "uniform level, log scale", "a uniform level", uniform_level,
        {"screen size of the geometric error (geo_max_px, pixels)", "geo_max_px",
         [](const SweepRow& r) { return r.geo_max_px; }, false, {{0.0, 1.0, "screen error <= 1 px"}}});
    const PlotSpec edge_plot = make_plot(
        table, series, "Triangle edge length on screen against level", "uniform level, log scale", "a uniform level",
        uniform_level,
        {"mean projected edge length (mean_edge_px, pixels)", "mean_edge_px",
         [](const SweepRow& r) { return r.mean_edge_px; }, false, {{3.0, 6.0, "triangle edges 3-6 px"}}});
    for (const auto& [name, spec] : {std::pair<const char*, const PlotSpec*>{"error-vs-time", &time_plot},
                                     std::pair<const char*, const PlotSpec*>{"error-vs-triangles", &triangle_plot},
                                     std::pair<const char*, const PlotSpec*>{"screen-error-vs-level", &screen_error_plot},
                                     std::pair<const char*, const PlotSpec*>{"edge-length-vs-level", &edge_plot}}) {
        const PlotShapes shapes = layout_plot(*spec);
        write_text_atomically(plots / (std::string(name) + ".svg"), plot_to_svg(shapes));
        write_png_atomically(plots / (std::string(name) + ".png"), shapes);
    }
    // Last, so that an index.html is there only when everything it links is.
    write_text_atomically(root / "index.html", make_index(table, series));
}

}  // namespace tessref::sweep
