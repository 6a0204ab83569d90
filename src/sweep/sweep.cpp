// `tessref sweep`: see sweep.h for the rows, groups and directory, docs/SWEEP.md for the
// columns.
#include "sweep/sweep.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>

#include <nlohmann/json.hpp>

#include "common/input_file.h"
#include "common/parallel.h"
#include "common/temp_cleanup.h"
#include "common/temp_name.h"
#include "pipeline/stage_uniforms.h"
#include "sweep/geometric_error.h"
#include "sweep/report.h"
#include "sweep/report_data.h"
#include "tessref/compare.h"
#include "tessref/error.h"
#include "tessref/limits.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"
#include "tessref/render.h"
#include "tessref/scene.h"

namespace fs = std::filesystem;

namespace tessref::sweep {

const std::vector<std::string>& csv_columns() {
    static const std::vector<std::string> columns{
        "scene",       "model",       "level",          "spacing",           "precision",
        "camera_relative",            "patches",
        "triangles",   "points",      "control_ms",     "generator_ms",      "evaluation_ms", "geometry_ms",
        "raster_shading_ms",          "total_ms",       "geo_max",           "geo_rms",       "geo_max_px",
        "mean_edge_px", "triangles_per_px",
        "img_rmse",    "img_psnr",    "img_fail_px",    "gpu_exact_max_pos", "gpu_exact_image_differs",
        "image",       "diff_image",  "wire_image",     "truth_image"};
    return columns;
}

namespace {

constexpr int kFormatVersion = 1;

// ---- numbers and CSV ---------------------------------------------------------------------

// Every real number of the CSV: "%.9g", NaN as "nan", infinities "inf" / "-inf".
std::string real(double x) {
    if (std::isnan(x)) return "nan";
    if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
    char text[40];
    std::snprintf(text, sizeof text, "%.9g", x);
    return text;
}
// Timings: milliseconds with three decimals (microseconds).
std::string milliseconds(double ms) {
    char text[40];
    std::snprintf(text, sizeof text, "%.3f", ms);
    return text;
}

// RFC 4180: a field holding a comma, a quote or a line break is quoted, quotes doubled.
std::string csv_field(const std::string& text) {
    if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
    std::string quoted = "\"";
    for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
    return quoted + "\"";
}

// One record of a CSV text: its fields and its raw text (without the final line break).
struct CsvRecord {
    std::vector<std::string> fields;
    std::string raw;
    std::size_t line = 0;
};
// Parses RFC 4180 text whose every record ends with "\n". Throws tessref::Error naming
// `file` and the line for an unterminated quote, text after a closing quote, or a missing
// final line break.
std::vector<CsvRecord> parse_csv(const std::string& text, const std::string& file) {
    std::vector<CsvRecord> records;
    std::size_t i = 0, line = 1;
    while (i < text.size()) {
        CsvRecord record;
        record.line = line;
        const std::size_t start = i;
        std::string field;
        bool done = false;
        while (!done) {
            if (i < text.size() && text[i] == '"') {
                ++i;
                for (;;) {
                    if (i >= text.size()) throw Error("unterminated quoted field", Where::in_file(file, record.line));
                    if (text[i] == '"') {
                        if (i + 1 < text.size() && text[i + 1] == '"') {
                            field += '"';
                            i += 2;
                            continue;
                        }
                        ++i;
                        break;
                    }
                    if (text[i] == '\n') ++line;
                    field += text[i++];
                }
                if (i < text.size() && text[i] != ',' && text[i] != '\n')
                    throw Error("text after a closing quote", Where::in_file(file, line));
            } else {
                while (i < text.size() && text[i] != ',' && text[i] != '\n') {
                    if (text[i] == '"') throw Error("a quote inside an unquoted field", Where::in_file(file, line));
                    field += text[i++];
                }
            }
            record.fields.push_back(std::move(field));
            field.clear();
            if (i >= text.size()) throw Error("the last line has no line break (truncated?)", Where::in_file(file, line));
            if (text[i] == '\n') done = true;
            ++i;
        }
        record.raw = text.substr(start, i - 1 - start);
        ++line;
        records.push_back(std::move(record));
    }
    return records;
}

std::string read_text(const fs::path& path) {
    return read_input_file(path.string(), "sweep file", kTableFileBytes);
}

void write_text(const fs::path& path, const std::string& bytes) {
    std::ofstream out(path, std::ios::binary);
    out << bytes;
    out.close();
    if (!out) throw Error("cannot write the file", Where::in_file(path.string()));
}

// ---- the output directory ----------------------------------------------------------------

// Why `dir` is not verifiably an earlier sweep's output, or "" when it is: its sweep.json
// parses as a sweep's (the sweep's parameters and its shard), and it holds nothing but what
// a sweep writes (sweep.csv, sweep.json, index.html, plots/ of .svg and .png, images/ of
// one directory per scene of .png), every one a plain file or directory, no link. A user's
// directory that merely holds a file named sweep.json is not replaced: replacing removes
// everything in it.
std::string not_a_sweep_output(const fs::path& dir) {
    std::error_code ec;
    if (!fs::is_regular_file(fs::symlink_status(dir / "sweep.json", ec))) return "it holds no sweep.json";
    try {
        const nlohmann::ordered_json j = nlohmann::ordered_json::parse(
            read_input_file((dir / "sweep.json").string(), "sweep file", kTableFileBytes, {}, FileUse::inspection));
        if (!j.is_object() || !j.contains("sweep") || !j.at("sweep").is_object() || !j.contains("shard") ||
            !j.at("shard").is_object() || !j.contains("row_indices"))
            return "its sweep.json is not a sweep's (no sweep, shard and row_indices)";
    } catch (const nlohmann::json::exception&) {
        return "its sweep.json is not valid JSON";
    } catch (const Error& e) {
        return "its sweep.json cannot be read: " + e.message();
    }
    auto plain = [&](const fs::directory_entry& e, bool directory) {
        const fs::file_status st = fs::symlink_status(e.path(), ec);
        return directory ? fs::is_directory(st) : fs::is_regular_file(st);
    };
    auto files_with = [&](const fs::path& sub, std::initializer_list<const char*> extensions) -> std::string {
        for (const auto& e : fs::directory_iterator(sub, ec)) {
            const std::string ext = e.path().extension().string();
            if (!plain(e, false) || std::none_of(extensions.begin(), extensions.end(), [&](const char* x) { return ext == x; }))
                return "it holds " + fs::relative(e.path(), dir, ec).string() + ", which a sweep does not write";
        }
        return {};
    };
    for (const auto& e : fs::directory_iterator(dir, ec)) {
        const std::string name = e.path().filename().string();
        std::string why;
        if (name == "sweep.json" || name == "sweep.csv" || name == "index.html") {
            if (!plain(e, false)) why = "its " + name + " is not a plain file";
        } else if (name == "plots" && plain(e, true)) {
            why = files_with(e.path(), {".svg", ".png"});
        } else if (name == "images" && plain(e, true)) {
            for (const auto& scene : fs::directory_iterator(e.path(), ec)) {
                if (!plain(scene, true)) {
                    why = "it holds " + fs::relative(scene.path(), dir, ec).string() + ", which a sweep does not write";
                    break;
                }
                if (!(why = files_with(scene.path(), {".png"})).empty()) break;
            }
        } else {
            why = "it holds " + name + ", which a sweep does not write";
        }
        if (!why.empty()) return why;
    }
    if (ec) return "it cannot be listed: " + ec.message();
    return {};
}

// Whether DIR may receive a sweep: a new name in an existing directory, an empty directory,
// or an earlier sweep's directory (not_a_sweep_output), which is replaced.
void check_output_dir(const fs::path& given) {
    if (given.empty()) throw Error("no output directory given", Where::in_file("-o"));
    fs::path dir = fs::absolute(given).lexically_normal();
    if (dir.filename().empty()) dir = dir.parent_path();  // "out/"
    std::error_code ec;
    const fs::file_status status = fs::symlink_status(dir, ec);
    if (fs::exists(status)) {
        if (!fs::is_directory(status))
            throw Error("the output exists and is not a directory", Where::in_file(given.string()));
        if (!fs::is_empty(dir, ec)) {
            if (const std::string why = not_a_sweep_output(dir); !why.empty())
                throw Error("the output directory is not empty and not an earlier sweep's output (" + why +
                                "); refusing to replace it",
                            Where::in_file(given.string()));
        }
    }
    if (!fs::is_directory(dir.parent_path()))
        throw Error("the output's parent directory does not exist", Where::in_file(given.string()));
}

// A fresh directory beside the target, ".<DIR>.tmp-<pid>-XXXXXX" (temp_name.h); removed
// unless commit() put it in place, also when a signal kills the process (temp_cleanup.h).
// Those that a killed run left beside the same target are removed first.
class TempDir {
public:
    explicit TempDir(const fs::path& target) : target_(fs::absolute(target).lexically_normal()) {
        if (target_.filename().empty()) target_ = target_.parent_path();
        const std::string base = target_.filename().string();
        remove_stale_temporaries(target_.parent_path(), ".", base, ".tmp-");
        std::string pattern =
            (target_.parent_path() / temporary_name(".", base, ".tmp-" + std::to_string(::getpid()) + "-", "XXXXXX")).string();
        std::vector<char> name(pattern.begin(), pattern.end());
        name.push_back('\0');
        if (!::mkdtemp(name.data()))
            throw Error("cannot create a temporary directory beside the output", Where::in_file(target_.string()));
        path_ = fs::path(name.data());
        slot_ = register_temporary(path_, true);
        name_temporary(path_, target.filename().empty() ? target.parent_path() : target);
    }
    ~TempDir() {
        std::error_code ec;
        if (!committed_) fs::remove_all(path_, ec);
        unregister_temporary(slot_);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    const fs::path& path() const { return path_; }

    void commit() {
        check_output_dir(target_);
        std::error_code ec;
        // Nothing the replaced directory holds may be an input of this sweep (`sweep merge a b
        // -o a`, a scene's texture kept among an earlier sweep's pictures).
        for (const auto& entry : fs::recursive_directory_iterator(target_, ec))
            if (const std::string input = input_named_by(entry.path().string()); !input.empty())
                throw Error("the output directory holds the input " + input + " of this sweep; refusing to replace it",
                            Where::in_file(target_.string()));
        std::optional<fs::path> old;
        if (fs::exists(fs::symlink_status(target_, ec))) {
            if (fs::is_empty(target_, ec)) {
                fs::remove(target_, ec);
            } else {  // an earlier sweep: out of the way first, removed once the new one is in
                old = path_.string() + ".old";
                fs::rename(target_, *old, ec);
                if (ec) throw Error("cannot replace the output directory: " + ec.message(), Where::in_file(target_.string()));
            }
        }
        fs::rename(path_, target_, ec);
        if (ec) {
            if (old) fs::rename(*old, target_, ec);
            throw Error("cannot put the output directory in place: " + ec.message(), Where::in_file(target_.string()));
        }
        unregister_temporary(slot_);
        slot_ = -1;
        committed_ = true;
        if (old) fs::remove_all(*old, ec);
    }

private:
    fs::path target_, path_;
    int slot_ = -1;
    bool committed_ = false;
};

// ---- scenes and rows ---------------------------------------------------------------------

struct SweepScene {
    std::string file;
    std::string name;   // [scene] name (the CSV's scene column)
    std::string slug;   // name for file names
    Scene scene;        // the camera's viewport set to the sweep's size
    bool terrain = false;
    bool geomip = false;  // a geomipmapped terrain: geomip rows in place of uniform ones
};

struct Row {
    std::size_t index = 0;  // CSV position in the unsharded run
    std::size_t group = 0;
    std::size_t scene = 0;
    bool own = false;
    // A geomipmapped scene's rows other than its own: a forced level (level = 0..4) or a
    // screen-error bound (level = the bound in pixels).
    enum class Geomip : std::uint8_t { none, level, bound } geomip = Geomip::none;
    double level = 0.0;     // uniform rows; geomip rows: the level or the bound
    Spacing spacing = Spacing::equal;
    Precision precision = Precision::gpu;
    bool camera_relative = false;
};

std::string level_text(double level) { return real(level); }

std::string slug_of(const std::string& name) {
    std::string s;
    for (char c : name) s += (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.') ? c : '_';
    if (s.empty() || s == "." || s == "..") s = "scene";
    return s;
}

std::string control_model_name(const Scene& scene) {
    if (scene.evaluation.model == EvaluationModel::geomipmap) return "geomipmap";
    return scene.control ? to_string(scene.control->model) : "none";
}

std::vector<SweepScene> load_scenes(const SweepParameters& p) {
    if (p.scenes.empty()) throw Error("no scene given", Where::in_file("command line"));
    std::vector<SweepScene> scenes;
    std::map<std::string, std::string> names;
    for (const std::string& file : p.scenes) {
        SweepScene s;
        s.file = file;
        s.scene = load_scene(file);
        s.scene.shaders = pipeline::with_shader_flags(s.scene.shaders, p.shaders);
        if (!s.scene.camera)
            throw Error("the sweep renders every row: the scene needs a [camera]", Where::at_key(file, "camera"));
        s.geomip = s.scene.evaluation.model == EvaluationModel::geomipmap;
        s.scene.camera->viewport = p.size;
        s.name = s.scene.name.empty() ? fs::path(file).stem().string() : s.scene.name;
        s.slug = slug_of(s.name);
        s.terrain = s.scene.grid.has_value();
        if (!names.emplace(s.slug, file).second)
            throw Error("two scenes are named '" + s.name + "' (also " + names[s.slug] +
                            "): the sweep tells rows and pictures apart by the scene name",
                        Where::at_key(file, "scene.name"));
        scenes.push_back(std::move(s));
    }
    return scenes;
}

std::vector<Spacing> spacings_for(const SweepParameters& p, const Scene& scene) {
    return p.spacings.empty() ? std::vector<Spacing>{scene.generator.spacing} : p.spacings;
}

// Every row of the sweep, in CSV order, with its group.
std::vector<Row> plan_rows(const SweepParameters& p, const std::vector<SweepScene>& scenes) {
    std::vector<Row> rows;
    std::size_t group = 0;
    for (std::size_t s = 0; s < scenes.size(); ++s) {
        const Scene& scene = scenes[s].scene;
        for (const bool relative : p.camera_relative) {
            for (Precision precision : p.precisions) {
                Row r;
                r.group = group;
                r.scene = s;
                r.own = true;
                r.spacing = scene.generator.spacing;
                r.precision = precision;
                r.camera_relative = relative;
                rows.push_back(r);
            }
            ++group;
            if (scenes[s].geomip) {
                // Forced levels, then bounds; per axis per precision per value, one group per value.
                const auto axis = [&](Row::Geomip kind, const std::vector<double>& values) {
                    for (Precision precision : p.precisions) {
                        for (std::size_t l = 0; l < values.size(); ++l) {
                            Row r;
                            r.group = group + l;
                            r.scene = s;
                            r.geomip = kind;
                            r.level = values[l];
                            r.spacing = scene.generator.spacing;
                            r.precision = precision;
                            r.camera_relative = relative;
                            rows.push_back(r);
                        }
                    }
                    group += values.size();
                };
                axis(Row::Geomip::level, std::vector<double>(p.geomip_levels.begin(), p.geomip_levels.end()));
                axis(Row::Geomip::bound, p.error_bounds);
                continue;
            }
            const std::vector<Spacing> spacings = spacings_for(p, scene);
            for (std::size_t k = 0; k < spacings.size(); ++k) {
                const std::size_t first_group = group;
                for (Precision precision : p.precisions) {
                    for (std::size_t l = 0; l < p.levels.size(); ++l) {
                        Row r;
                        r.group = first_group + l;
                        r.scene = s;
                        r.level = p.levels[l];
                        r.spacing = spacings[k];
                        r.precision = precision;
                        r.camera_relative = relative;
                        rows.push_back(r);
                    }
                }
                group += p.levels.size();
            }
        }
    }
    for (std::size_t i = 0; i < rows.size(); ++i) rows[i].index = i;
    return rows;
}

// The scene with its control stage replaced by a uniform level (sweep.h).
Scene uniform_scene(const Scene& base, double level, Spacing spacing) {
    Scene s = base;
    s.generator.spacing = spacing;
    ControlStage control = base.control.value_or(ControlStage{});
    if (base.evaluation.model == EvaluationModel::lab4) {
        // Lab 4's evaluation reads its control stage's log levels (mip selection): every
        // zone gets the level, and log2(max_level) - log2(level) = 0 samples mip 0.
        control.model = ControlModel::lab4;
        control.lab4.minLevel = level;
        control.lab4.maxLevel = level;
    } else {
        control.model = ControlModel::constant;
        control.constant.level = level;
    }
    s.control = control;
    return s;
}

// A geomipmapped scene at a forced level (no tween) or with another screen-error bound (its
// own adapt and tween kept).
Scene geomip_scene(const Scene& base, const Row& row) {
    Scene s = base;
    geomip::Params& g = s.evaluation.geomipmap;
    if (row.geomip == Row::Geomip::level) {
        g.level = static_cast<int>(row.level);
        g.tween.reset();
    } else {
        g.level.reset();
        g.error_bound_px = row.level;
    }
    return s;
}

// The part of a picture's name that tells the row apart (images/<scene>/<this>-<precision>).
std::string row_stem(const Row& row) {
    if (row.own) return "own";
    if (row.geomip == Row::Geomip::level) return "geomip-L" + level_text(row.level);
    if (row.geomip == Row::Geomip::bound) return "geomip-B" + level_text(row.level);
    return std::string(to_string(row.spacing)) + "-L" + level_text(row.level);
}

// A uniform level whose pictures are kept whatever the errors: a power of two.
bool keeps_level(double level) {
    int exponent = 0;
    return std::frexp(level, &exponent) == 0.5;
}

// The rows whose pictures run_row() keeps; the recommended levels are added once the whole
// sweep has run (run_sweep, merge_sweeps).
bool keeps_pictures(const Row& row, double largest_level) {
    if (row.own) return true;
    if (row.geomip != Row::Geomip::none) return true;  // at most 5 levels and a few bounds
    return row.level == largest_level || keeps_level(row.level);
}

std::string row_description(const Row& row, const std::vector<SweepScene>& scenes) {
    const SweepScene& s = scenes[row.scene];
    std::string d = s.name + " " + (row.own ? control_model_name(s.scene) + " (own)" : "uniform " + level_text(row.level));
    if (row.geomip == Row::Geomip::level) d = s.name + " geomip level " + level_text(row.level);
    if (row.geomip == Row::Geomip::bound) d = s.name + " geomip error bound " + level_text(row.level) + " px";
    if (!s.geomip) d += " " + std::string(to_string(row.spacing));  // a geomipmapped terrain has no generator
    return d + " " + std::string(to_string(row.precision)) + (row.camera_relative ? " camera-relative" : "");
}

// The parameters that make two shards parts of one sweep.
nlohmann::ordered_json parameters_json(const SweepParameters& p, const std::vector<SweepScene>& scenes,
                                       std::size_t rows, std::size_t groups) {
    nlohmann::ordered_json j;
    j["format"] = kFormatVersion;
    j["tessref"] = TESSREF_VERSION;
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const SweepScene& s : scenes) list.push_back({{"file", s.file}, {"name", s.name}});
    j["scenes"] = list;
    nlohmann::ordered_json levels = nlohmann::ordered_json::array();
    for (double l : p.levels) levels.push_back(level_text(l));
    j["levels"] = levels;
    if (std::any_of(scenes.begin(), scenes.end(), [](const SweepScene& s) { return s.geomip; })) {
        // Only when a geomipmapped scene runs, so a sweep without one keeps its sweep.json.
        nlohmann::ordered_json geomip_levels = nlohmann::ordered_json::array();
        for (int l : p.geomip_levels) geomip_levels.push_back(l);
        j["geomip_levels"] = geomip_levels;
        nlohmann::ordered_json bounds = nlohmann::ordered_json::array();
        for (double b : p.error_bounds) bounds.push_back(level_text(b));
        j["error_bounds"] = bounds;
    }
    nlohmann::ordered_json precisions = nlohmann::ordered_json::array();
    for (Precision x : p.precisions) precisions.push_back(std::string(to_string(x)));
    j["precisions"] = precisions;
    if (p.spacings.empty()) {
        j["spacings"] = "each scene's own";
    } else {
        nlohmann::ordered_json spacings = nlohmann::ordered_json::array();
        for (Spacing x : p.spacings) spacings.push_back(std::string(to_string(x)));
        j["spacings"] = spacings;
    }
    nlohmann::ordered_json relative = nlohmann::ordered_json::array();
    for (const bool r : p.camera_relative) relative.push_back(r);
    j["camera_relative"] = relative;
    j["repeat"] = p.repeat;
    j["size"] = std::to_string(p.size.x) + "x" + std::to_string(p.size.y);
    j["rows"] = rows;
    j["groups"] = groups;
    return j;
}

std::string sweep_json_text(const nlohmann::ordered_json& parameters, const Shard& shard,
                            const std::vector<std::size_t>& row_indices) {
    nlohmann::ordered_json j;
    j["sweep"] = parameters;
    j["shard"] = {{"index", shard.index}, {"count", shard.count}};
    j["row_indices"] = row_indices;
    return j.dump(2) + "\n";
}

std::string csv_header() {
    std::string h;
    for (const std::string& c : csv_columns()) h += (h.empty() ? "" : ",") + c;
    return h + "\n";
}

// ---- running rows --------------------------------------------------------------------------

FloatImage float_image(const RenderResult& image) {
    const std::vector<std::uint8_t> rgba = to_rgba8(image);
    FloatImage f;
    f.width = image.width;
    f.height = image.height;
    f.channels = 4;
    f.channel_names = {"R", "G", "B", "A"};
    f.alpha_channel = 3;
    f.samples.resize(rgba.size());
    for (std::size_t i = 0; i < rgba.size(); ++i) f.samples[i] = static_cast<float>(rgba[i]) / 255.0f;  // as an 8-bit file reads
    return f;
}

double median(std::vector<double> values) {
    std::sort(values.begin(), values.end());
    const std::size_t n = values.size();
    return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

// What a scene's rows share: the ground truth (terrain scenes).
struct SceneTruth {
    std::optional<TruthSurface> surface;
    std::optional<FloatImage> image;
    std::string image_path;  // relative to DIR
};

// One row's results, as CSV fields (by column name).
using Fields = std::map<std::string, std::string>;

struct PairData {
    std::vector<glm::dvec3> positions;
    std::vector<std::array<std::uint32_t, 3>> triangles;
    std::vector<std::uint8_t> rgba;
};

class Runner {
public:
    // every_picture: a shard of several, which keeps every row's pictures for the merge to choose.
    Runner(const SweepParameters& p, const std::vector<SweepScene>& scenes, const fs::path& dir, bool every_picture)
        : p_(p), scenes_(scenes), dir_(dir), largest_level_(p.levels.empty() ? 0.0 : p.levels.back()),
          every_picture_(every_picture) {}

    // Runs one group's rows (one per precision), returns their fields in row order.
    std::vector<Fields> run_group(const std::vector<const Row*>& rows, const std::function<void(const Row&)>& starting) {
        std::vector<Fields> out;
        std::vector<PairData> pair;
        for (const Row* row : rows) {
            starting(*row);
            PairData data;
            out.push_back(run_row(*row, data));
            pair.push_back(std::move(data));
        }
        if (rows.size() == 2 && rows[0]->precision != rows[1]->precision) {
            std::string max_pos;
            if (pair[0].positions.size() == pair[1].positions.size() && pair[0].triangles == pair[1].triangles) {
                double m = 0.0;
                for (std::size_t v = 0; v < pair[0].positions.size(); ++v)
                    m = std::max(m, glm::length(pair[0].positions[v] - pair[1].positions[v]));
                max_pos = real(m);
            }
            const std::string differs = pair[0].rgba == pair[1].rgba ? "0" : "1";
            for (Fields& f : out) {
                f["gpu_exact_max_pos"] = max_pos;
                f["gpu_exact_image_differs"] = differs;
            }
        }
        return out;
    }

private:
    SceneTruth& truth_of(std::size_t scene) {
        if (truth_scene_ == scene) return truth_;
        truth_ = SceneTruth{};
        truth_scene_ = scene;
        const SweepScene& s = scenes_[scene];
        if (!s.terrain) return truth_;
        truth_.surface = truth_surface(s.scene);
        RenderOptions options;
        options.size = p_.size;
        const RenderResult image = raytrace_scene(s.scene, options);
        truth_.image = float_image(image);
        truth_.image_path = "images/" + s.slug + "/truth.png";
        fs::create_directories(dir_ / "images" / s.slug);
        write_image(image, (dir_ / truth_.image_path).string(), ImageFormat::png);
        return truth_;
    }

    Fields run_row(const Row& row, PairData& pair) {
        const SweepScene& s = scenes_[row.scene];
        const Scene scene = row.own                           ? s.scene
                            : row.geomip != Row::Geomip::none ? geomip_scene(s.scene, row)
                                                              : uniform_scene(s.scene, row.level, row.spacing);
        SceneTruth& truth = truth_of(row.scene);
        Fields f;
        f["scene"] = s.name;
        f["model"] = row.own                              ? control_model_name(s.scene)
                     : row.geomip == Row::Geomip::level ? "geomip_level"
                     : row.geomip == Row::Geomip::bound ? "geomip_bound"
                                                        : "uniform";
        f["level"] = row.own ? "" : level_text(row.level);
        f["spacing"] = s.geomip ? "" : std::string(to_string(row.spacing));  // no generator
        f["precision"] = std::string(to_string(row.precision));
        f["camera_relative"] = row.camera_relative ? "1" : "0";
        f["patches"] = std::to_string(scene.patch_count());

        // The timed runs: pipeline (per pass) and rasterizer + shading, median of repeat.
        using Clock = std::chrono::steady_clock;
        const auto ms = [](Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); };
        std::array<std::vector<double>, 6> times;
        // Not const: once the row is done, its positions and triangles move to the group's
        // comparison (no copy of the row's largest arrays).
        std::shared_ptr<PipelineResult> pipeline;
        RenderResult image;
        RenderOptions render_options;
        render_options.size = p_.size;
        render_options.precision = row.precision;
        render_options.camera_relative = row.camera_relative;
        for (int r = 0; r < p_.repeat; ++r) {
            PipelineTimings timings;
            PipelineOptions options;
            options.precision = row.precision;
            options.camera_relative = row.camera_relative;
            options.timings = &timings;
            image = RenderResult{};
            pipeline.reset();
            const Clock::time_point t0 = Clock::now();
            pipeline = std::make_shared<PipelineResult>(run_pipeline(scene, options));
            const Clock::time_point t1 = Clock::now();
            image = render_surface(scene, pipeline, render_options);
            const Clock::time_point t2 = Clock::now();
            times[0].push_back(timings.control * 1e3);
            times[1].push_back(timings.generator * 1e3);
            times[2].push_back(timings.evaluation * 1e3);
            times[3].push_back(timings.geometry * 1e3);
            times[4].push_back(ms(t2 - t1));
            times[5].push_back(ms(t2 - t0));
        }
        const char* time_columns[] = {"control_ms", "generator_ms", "evaluation_ms", "geometry_ms", "raster_shading_ms",
                                      "total_ms"};
        for (std::size_t k = 0; k < 6; ++k) f[time_columns[k]] = milliseconds(median(times[k]));
        const SurfaceMesh& mesh = pipeline->mesh;
        f["triangles"] = std::to_string(mesh.triangles.size());
        f["points"] = std::to_string(mesh.positions.size());

        // The untimed measures, after the timed runs and side by side: the geometric error
        // (parallel over patches), the screen edge measure (its sum serial, in triangle
        // order, so that it is the same on any thread count) and the image against the
        // truth's, then the row's pictures (their serial parts, the PNG files and the
        // difference picture, beside the other two).
        // Each writes only its own results, so they are what they would be one after the
        // other; none overlaps a timed run, whose times stay those of the row alone.
        std::optional<GeometricError> geometric;
        double mean_edge = 0.0;
        std::optional<FloatImage> picture;
        std::optional<CompareResult> compared;
        Fields pictures;  // the pictures' columns
        tessref::parallel_for(0, 3, [&](int job) {
            if (job == 0 && truth.surface) geometric = geometric_error(*truth.surface, mesh, &*scene.camera);
            // The surface as the rasterizer drew it (image.mvp, which holds the
            // camera-relative origin where the run has one).
            if (job == 1) mean_edge = mean_edge_pixels(mesh, glm::dmat4(image.mvp), p_.size);
            if (job == 2) {
                picture = float_image(image);
                if (truth.image) compared = compare_images(*truth.image, *picture);
                pair.rgba = to_rgba8(image);  // for the group's comparison of its precisions
                if (every_picture_ || keeps_pictures(row, largest_level_))
                    write_pictures(row, scene, pipeline, render_options, image, *picture, compared, pictures);
            }
        });
        if (geometric) {
            f["geo_max"] = real(geometric->max);
            f["geo_rms"] = real(geometric->rms);
            f["geo_max_px"] = real(geometric->max_px);
        }
        f["mean_edge_px"] = real(mean_edge);
        f["triangles_per_px"] =
            image.stats.covered_pixels
                ? real(static_cast<double>(mesh.triangles.size()) / static_cast<double>(image.stats.covered_pixels))
                : std::string();
        if (compared) {
            f["img_rmse"] = real(compared->rmse);
            f["img_psnr"] = real(compared->psnr);
            f["img_fail_px"] = std::to_string(compared->failing_pixels);
            f["truth_image"] = truth.image_path;
        }
        f.merge(pictures);
        // The group's comparison takes the row's positions and triangles; nothing else holds
        // the result now (the image's reference is dropped first).
        image = RenderResult{};
        pair.positions = std::move(pipeline->mesh.positions);
        pair.triangles = std::move(pipeline->mesh.triangles);
        return f;
    }

public:
    // The pictures of a row that run_row() did not keep (a recommended level that is not a
    // power of two), into its fields: the row's surface once more, untimed.
    void add_pictures(const Row& row, Fields& f) {
        const SweepScene& s = scenes_[row.scene];
        const Scene scene = uniform_scene(s.scene, row.level, row.spacing);
        SceneTruth& truth = truth_of(row.scene);
        PipelineOptions options;
        options.precision = row.precision;
        options.camera_relative = row.camera_relative;
        const auto pipeline = std::make_shared<const PipelineResult>(run_pipeline(scene, options));
        RenderOptions render_options;
        render_options.size = p_.size;
        render_options.precision = row.precision;
        render_options.camera_relative = row.camera_relative;
        const RenderResult image = render_surface(scene, pipeline, render_options);
        const FloatImage picture = float_image(image);
        std::optional<CompareResult> compared;
        if (truth.image) compared = compare_images(*truth.image, picture);
        write_pictures(row, scene, pipeline, render_options, image, picture, compared, f);
    }

private:
    void write_pictures(const Row& row, const Scene& scene, const std::shared_ptr<const PipelineResult>& pipeline,
                        const RenderOptions& render_options, const RenderResult& image, const FloatImage& picture,
                        const std::optional<CompareResult>& compared, Fields& f) {
        const SweepScene& s = scenes_[row.scene];
        const std::string stem = "images/" + s.slug + "/" + row_stem(row) + "-" +
                                 std::string(to_string(row.precision)) + (row.camera_relative ? "-cr" : "");
        fs::create_directories(dir_ / "images" / s.slug);
        write_image(image, (dir_ / (stem + ".png")).string(), ImageFormat::png);
        f["image"] = stem + ".png";
        RenderOptions wire_options = render_options;
        wire_options.mode = RenderMode::wireframe;
        const RenderResult wire = render_surface(scene, pipeline, wire_options);
        write_image(wire, (dir_ / (stem + "-wire.png")).string(), ImageFormat::png);
        f["wire_image"] = stem + "-wire.png";
        if (compared) {
            write_float_image(difference_picture(*truth_.image, picture, *compared).image,
                              (dir_ / (stem + "-diff.png")).string());
            f["diff_image"] = stem + "-diff.png";
        }
    }

    const SweepParameters& p_;
    const std::vector<SweepScene>& scenes_;
    fs::path dir_;
    double largest_level_;
    bool every_picture_ = false;
    std::size_t truth_scene_ = static_cast<std::size_t>(-1);
    SceneTruth truth_;
};

std::string csv_line(const Fields& f) {
    std::string line;
    bool first = true;
    for (const std::string& c : csv_columns()) {
        const auto it = f.find(c);
        line += (first ? "" : ",") + csv_field(it == f.end() ? std::string() : it->second);
        first = false;
    }
    return line + "\n";
}

// Which rows the report recommends (report_data.h: the knee, and the best level under the
// triangle budget of the scene's own levels), per series: the rows of one scene, spacing,
// precision and camera_relative value. From the rows' CSV cells (cell(row, column)), so that a
// whole sweep and a merge of its shards choose the same rows.
using CellOf = std::function<std::string(std::size_t row, const char* column)>;

// A cell as the sweep writes numbers, the whole of it; else nullopt (a merge reads shards'
// cells before the report's strict reading names what is wrong with them).
std::optional<double> cell_number(const std::string& text) {
    double x = 0.0;
    const auto [stop, error] = std::from_chars(text.data(), text.data() + text.size(), x, std::chars_format::general);
    if (text.empty() || error != std::errc() || stop != text.data() + text.size()) return std::nullopt;
    return x;
}

std::vector<bool> recommended_rows(std::size_t count, const CellOf& cell) {
    const auto number = [&](std::size_t row, const char* column) { return cell_number(cell(row, column)); };
    std::map<std::string, std::vector<std::size_t>> series;
    for (std::size_t row = 0; row < count; ++row) {
        const std::string model = cell(row, "model");
        if (model == "geomip_level" || model == "geomip_bound" || model == "geomipmap") continue;
        series[cell(row, "scene") + "\n" + cell(row, "spacing") + "\n" + cell(row, "precision") + "\n" +
               cell(row, "camera_relative")]
            .push_back(row);
    }
    std::vector<bool> out(count, false);
    for (const auto& [key, members] : series) {
        std::vector<LevelError> curve;
        std::vector<LevelRun> runs;
        std::optional<double> budget;
        for (std::size_t row : members) {
            const std::optional<double> error = number(row, "img_rmse"), triangles = number(row, "triangles");
            if (cell(row, "model") != "uniform") {
                budget = triangles;
            } else if (const std::optional<double> level = number(row, "level"); error && triangles && level) {
                curve.push_back({*level, *error});
                runs.push_back({*level, *triangles, *error});
            }
        }
        const std::optional<double> knee = stop_improving_level(curve);
        const std::optional<double> best = budget ? best_level_under_budget(runs, *budget) : std::nullopt;
        for (std::size_t row : members)
            if (cell(row, "model") == "uniform" && (number(row, "level") == knee || number(row, "level") == best))
                out[row] = true;
    }
    return out;
}

// Refuses, before any work, a uniform level that would exceed a scene's triangle budget.
void check_budgets(const SweepParameters& p, const std::vector<SweepScene>& scenes) {
    for (const SweepScene& s : scenes) {
        if (s.geomip) {
            // Level k: 2 (16 / 2^k)^2 triangles per patch. The own and bound rows may put
            // every patch at level 0 (a bound of 0 does), so their worst case is level 0's.
            const auto per_patch = [](int k) { return std::uint64_t(2) * (16u >> k) * (16u >> k); };
            const std::uint64_t patches = s.scene.patch_count();
            const auto refuse = [&](const std::string& what, std::uint64_t estimate) {
                if (estimate > s.scene.max_triangles)
                    throw Error(what + " for up to " + std::to_string(estimate) +
                                    " triangles, more than the scene's limits.max_triangles = " +
                                    std::to_string(s.scene.max_triangles),
                                s.scene.max_triangles_where);
            };
            refuse("the geomipmapped terrain's own and error-bound rows (every patch at level 0 at worst) ask",
                   per_patch(0) * patches);
            for (int k : p.geomip_levels) refuse("geomip level " + std::to_string(k) + " asks", per_patch(k) * patches);
            continue;
        }
        for (Spacing spacing : spacings_for(p, s.scene)) {
            for (double level : p.levels) {
                TessSettings settings = s.scene.generator;
                settings.spacing = spacing;
                TessLevels levels;
                levels.outer.fill(static_cast<float>(level));
                levels.inner.fill(static_cast<float>(level));
                const std::uint64_t estimate = estimate_triangles(settings, levels) * s.scene.patch_count();
                if (estimate > s.scene.max_triangles)
                    throw Error("uniform level " + level_text(level) + " (" + std::string(to_string(spacing)) +
                                    ") asks for up to " + std::to_string(estimate) +
                                    " triangles, more than the scene's limits.max_triangles = " +
                                    std::to_string(s.scene.max_triangles),
                                s.scene.max_triangles_where);
            }
        }
    }
}

}  // namespace

std::vector<std::string> split_list(const std::string& text, const std::string& flag) {
    std::vector<std::string> items;
    std::size_t start = 0;
    for (;;) {
        const std::size_t comma = text.find(',', start);
        std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
        const auto b = item.find_first_not_of(" \t"), e = item.find_last_not_of(" \t");
        item = b == std::string::npos ? std::string() : item.substr(b, e - b + 1);
        if (item.empty()) throw Error("an empty item in '" + text + "'", Where::in_file(flag));
        items.push_back(item);
        if (comma == std::string::npos) break;
        start = comma + 1;
    }
    return items;
}

namespace {

// A comma-separated list of numbers and ranges A..B (whole numbers, both ends included),
// each in [lo, hi] (whole numbers too); sorted, duplicates dropped. Errors name the flag.
struct NumberList {
    const char* flag;   // "--levels"
    const char* noun;   // "level"
    const char* forms;  // what an item may be, for the error
    int lo, hi;
    bool integers;      // every item a whole number
};

// The decimal number at the start of item (an optional sign, digits, a fraction, an
// exponent), its length in used (0: none there). Decimal only, as every other number of the
// command line (parse_integer): std::stod would also read "0x10" as 16.
double leading_number(const std::string& item, std::size_t& used) {
    used = 0;
    const char* begin = item.data();
    const char* const end = item.data() + item.size();
    const bool plus = begin != end && *begin == '+';  // from_chars takes '-' only
    if (plus) ++begin;
    double x = 0.0;
    const auto [stop, error] = std::from_chars(begin, end, x, std::chars_format::general);
    if (error == std::errc::result_out_of_range) {
        // Beyond double's range: strtod of the same decimal text gives +-inf or 0, for the
        // range check to judge.
        x = std::strtod(std::string(begin, stop).c_str(), nullptr);
    } else if (error != std::errc()) {
        return 0.0;
    }
    used = static_cast<std::size_t>(stop - item.data());
    return x;
}

std::vector<double> parse_number_list(const std::string& text, const NumberList& rule) {
    const Where where = Where::in_file(rule.flag);
    const std::string noun = rule.noun;
    std::vector<double> values;
    const auto number = [&](const std::string& item, const std::string& whole) {
        std::size_t used = 0;
        const double x = leading_number(item, used);
        const auto rest = item.find_first_not_of(" \t", used);
        if (used == 0 || rest != std::string::npos || (rule.integers && std::isfinite(x) && x != std::floor(x)))
            throw Error("'" + whole + "' is not a " + noun + " (" + rule.forms + ")", where);
        if (std::isnan(x)) throw Error("'" + whole + "': a " + noun + " must be a number, not NaN", where);
        if (!(x >= rule.lo && x <= rule.hi))
            throw Error("'" + whole + "': " + noun + "s lie in " + std::to_string(rule.lo) + ".." +
                            std::to_string(rule.hi),
                        where);
        return x;
    };
    for (const std::string& item : split_list(text, rule.flag)) {
        const std::size_t dots = item.find("..");
        if (dots != std::string::npos) {
            const double lo = number(item.substr(0, dots), item), hi = number(item.substr(dots + 2), item);
            if (lo != std::floor(lo) || hi != std::floor(hi))
                throw Error("'" + item + "': a range runs over whole " + noun + "s (A..B, integers)", where);
            if (lo > hi) throw Error("'" + item + "': the range is reversed", where);
            for (double v = lo; v <= hi; v += 1.0) values.push_back(v);
        } else {
            values.push_back(number(item, item));
        }
    }
    std::sort(values.begin(), values.end());
    values.erase(std::unique(values.begin(), values.end()), values.end());
    return values;
}

}  // namespace

std::vector<double> parse_levels(const std::string& text) {
    return parse_number_list(text, {"--levels", "level", "a number, or a range A..B", 1, 64, false});
}

std::vector<int> parse_geomip_levels(const std::string& text) {
    if (text == "none") return {};
    const std::vector<double> values = parse_number_list(
        text, {"--geomip-levels", "geomip level", "an integer 0..4, a range A..B, or none", 0, geomip::kLevels - 1, true});
    return std::vector<int>(values.begin(), values.end());
}

std::vector<double> parse_error_bounds(const std::string& text) {
    const Where where = Where::in_file("--error-bounds");
    std::vector<double> bounds;
    if (text == "none") return bounds;
    for (const std::string& item : split_list(text, "--error-bounds")) {
        std::size_t used = 0;
        const double x = leading_number(item, used);
        if (used == 0 || used != item.size())
            throw Error("'" + item + "' is not an error bound (a number of pixels, or none)", where);
        if (!(x >= 0.0 && x <= 1e6)) throw Error("'" + item + "': error bounds lie in [0, 1e6] pixels", where);
        bounds.push_back(x);
    }
    std::sort(bounds.begin(), bounds.end());
    bounds.erase(std::unique(bounds.begin(), bounds.end()), bounds.end());
    return bounds;
}

std::size_t run_sweep(const SweepParameters& p, const Shard& shard, const std::string& dir,
                      const SweepProgress& progress) {
    if (p.levels.empty()) throw Error("no levels", Where::in_file("--levels"));
    if (p.precisions.empty()) throw Error("no precision", Where::in_file("--precision"));
    if (p.repeat < 1) throw Error("--repeat must be at least 1", Where::in_file("--repeat"));
    if (shard.count < 1 || shard.index < 0 || shard.index >= shard.count)
        throw Error("shard " + std::to_string(shard.index) + "/" + std::to_string(shard.count) +
                        " is not one of 0/N .. N-1/N",
                    Where::in_file("--shard"));
    check_output_dir(dir);
    const std::vector<SweepScene> scenes = load_scenes(p);
    check_budgets(p, scenes);
    require_memory(estimate_render_memory(p.size, RenderMode::fill, true, ImageFormat::png, {}) * 3,
                   "images of " + std::to_string(p.size.x) + "x" + std::to_string(p.size.y) + " pixels",
                   Where::in_file("--size"));
    const std::vector<Row> rows = plan_rows(p, scenes);
    const std::size_t groups = rows.empty() ? 0 : rows.back().group + 1;
    // This shard's groups, each with its rows in row order.
    std::map<std::size_t, std::vector<const Row*>> mine;
    std::size_t mine_rows = 0;
    for (const Row& r : rows)
        if (r.group % static_cast<std::size_t>(shard.count) == static_cast<std::size_t>(shard.index)) {
            mine[r.group].push_back(&r);
            ++mine_rows;
        }

    TempDir temp(dir);
    fs::create_directories(temp.path() / "images");
    Runner runner(p, scenes, temp.path(), shard.count > 1);
    std::map<std::size_t, Fields> fields;  // row index -> its columns
    std::size_t done = 0;
    for (const auto& [group, group_rows] : mine) {
        std::vector<Fields> group_fields = runner.run_group(group_rows, [&](const Row& row) {
            if (progress) progress(done++, mine_rows, row_description(row, scenes));
        });
        for (std::size_t k = 0; k < group_rows.size(); ++k) fields[group_rows[k]->index] = std::move(group_fields[k]);
    }
    // The report recommends levels by rules over whole series (report_data.h); their pictures
    // are kept whatever the level. A shard holds only some of a series' levels: it keeps the
    // pictures of every row, and the merge keeps those of the rows a whole sweep keeps.
    if (shard.count == 1) {
        std::vector<Fields*> by_position;
        for (auto& [index, f] : fields) by_position.push_back(&f);
        const std::vector<bool> recommended =
            recommended_rows(by_position.size(), [&](std::size_t k, const char* column) {
                const auto it = by_position[k]->find(column);
                return it == by_position[k]->end() ? std::string() : it->second;
            });
        std::size_t k = 0;
        for (auto& [index, f] : fields)
            if (recommended[k++] && f["image"].empty()) runner.add_pictures(rows[index], f);
    }
    if (progress) progress(done, mine_rows, "");
    std::string csv = csv_header();
    std::vector<std::size_t> indices;
    for (const auto& [index, f] : fields) {
        csv += csv_line(f);
        indices.push_back(index);
    }
    write_text(temp.path() / "sweep.csv", csv);
    write_text(temp.path() / "sweep.json", sweep_json_text(parameters_json(p, scenes, rows.size(), groups), shard, indices));
    write_sweep_report(temp.path().string());
    temp.commit();
    return fields.size();
}

// ---- merge -------------------------------------------------------------------------------

namespace {

struct ShardDir {
    fs::path dir;
    nlohmann::ordered_json parameters;
    Shard shard;
    std::vector<std::size_t> indices;
    std::vector<CsvRecord> rows;  // without the header
};

// A count or index of sweep.json: a whole number from 0 to the type's maximum. nlohmann's
// get<int>() of 2e+82 or 1.5 converts a double (out of range: undefined behaviour, a fuzzer's
// finding) or truncates it; sweep.json never holds anything but whole numbers there.
template <class T>
T whole_number(const nlohmann::ordered_json& value, const std::string& what, const fs::path& file) {
    const auto max = static_cast<std::uint64_t>(std::numeric_limits<T>::max());
    if (value.is_number_unsigned() && value.get<std::uint64_t>() <= max) return static_cast<T>(value.get<std::uint64_t>());
    if (value.is_number_integer() && value.get<std::int64_t>() >= 0 && static_cast<std::uint64_t>(value.get<std::int64_t>()) <= max)
        return static_cast<T>(value.get<std::int64_t>());
    throw Error("corrupt sweep.json: " + what + " is " + value.dump() + ", not a whole number from 0 to " +
                    std::to_string(max),
                Where::in_file(file.string()));
}

ShardDir read_shard(const fs::path& dir) {
    const Where where = Where::in_file(dir.string());
    if (!fs::is_directory(dir)) throw Error("not a directory", where);
    if (!fs::exists(dir / "sweep.json") || !fs::exists(dir / "sweep.csv"))
        throw Error("not a sweep directory (no sweep.json or sweep.csv)", where);
    ShardDir s;
    s.dir = dir;
    try {
        const nlohmann::ordered_json j = nlohmann::ordered_json::parse(read_text(dir / "sweep.json"));
        s.parameters = j.at("sweep");
        const fs::path file = dir / "sweep.json";
        s.shard.index = whole_number<int>(j.at("shard").at("index"), "the shard's index", file);
        s.shard.count = whole_number<int>(j.at("shard").at("count"), "the shard count", file);
        for (const auto& index : j.at("row_indices")) s.indices.push_back(whole_number<std::size_t>(index, "a row index", file));
        (void)whole_number<std::size_t>(s.parameters.at("rows"), "the row count", file);
    } catch (const nlohmann::json::exception& e) {
        throw Error(std::string("corrupt sweep.json: ") + e.what(), Where::in_file((dir / "sweep.json").string()));
    }
    if (s.shard.count < 1 || s.shard.index < 0 || s.shard.index >= s.shard.count)
        throw Error("corrupt sweep.json: shard " + std::to_string(s.shard.index) + "/" + std::to_string(s.shard.count),
                    Where::in_file((dir / "sweep.json").string()));
    const std::string csv_path = (dir / "sweep.csv").string();
    std::vector<CsvRecord> records = parse_csv(read_text(dir / "sweep.csv"), csv_path);
    if (records.empty() || records[0].raw + "\n" != csv_header())
        throw Error("corrupt sweep.csv: the header is not the sweep's", Where::in_file(csv_path, 1));
    const std::size_t columns = csv_columns().size();
    for (std::size_t k = 1; k < records.size(); ++k)
        if (records[k].fields.size() != columns)
            throw Error("corrupt sweep.csv: " + std::to_string(records[k].fields.size()) + " fields, the header has " +
                            std::to_string(columns),
                        Where::in_file(csv_path, records[k].line));
    // Every picture a row names must be in the shard: the merged report links to it.
    for (std::size_t k = 1; k < records.size(); ++k)
        for (const char* column : {"image", "diff_image", "wire_image", "truth_image"}) {
            const auto at = std::find(csv_columns().begin(), csv_columns().end(), column) - csv_columns().begin();
            const std::string& picture = records[k].fields[static_cast<std::size_t>(at)];
            if (picture.empty()) continue;
            const fs::path relative(picture);
            const bool inside = relative.is_relative() && !picture.empty() &&
                                std::none_of(relative.begin(), relative.end(), [](const fs::path& part) { return part == ".."; }) &&
                                *relative.begin() == "images";
            std::error_code ec;
            if (!inside || !fs::is_regular_file(dir / relative, ec))
                throw Error("the row's " + std::string(column) + " '" + picture + "' is " +
                                (inside ? "missing from the shard" : "not a picture under images/"),
                            Where::in_file(csv_path, records[k].line));
        }
    records.erase(records.begin());
    if (records.size() != s.indices.size())
        throw Error("corrupt sweep.csv: " + std::to_string(records.size()) + " rows, sweep.json lists " +
                        std::to_string(s.indices.size()),
                    Where::in_file(csv_path));
    s.rows = std::move(records);
    return s;
}

// Copies every file under from/images into to/images but those in `leave_out` (paths
// relative to the sweep directory); a file both shards wrote (a scene's truth picture) must
// hold the same bytes.
void copy_images(const fs::path& from, const fs::path& to, const std::set<std::string>& leave_out) {
    const fs::path images = from / "images";
    if (!fs::is_directory(images)) return;
    for (const auto& entry : fs::recursive_directory_iterator(images)) {
        const fs::path relative = fs::relative(entry.path(), from);
        const fs::path target = to / relative;
        if (entry.is_directory()) {
            fs::create_directories(target);
        } else if (entry.is_regular_file()) {
            if (leave_out.count(relative.generic_string())) continue;
            fs::create_directories(target.parent_path());
            if (fs::exists(target)) {
                if (read_text(target) != read_text(entry.path()))
                    throw Error("this picture differs from the one another shard wrote", Where::in_file(entry.path().string()));
                continue;
            }
            fs::copy_file(entry.path(), target);
        }
    }
}

}  // namespace

void merge_sweeps(const std::vector<std::string>& dirs, const std::string& out) {
    if (dirs.empty()) throw Error("no shard directories given", Where::in_file("command line"));
    check_output_dir(out);
    std::vector<ShardDir> shards;
    for (const std::string& d : dirs) shards.push_back(read_shard(d));
    const ShardDir& first = shards.front();
    std::map<int, std::string> seen;
    for (const ShardDir& s : shards) {
        if (s.parameters != first.parameters || s.shard.count != first.shard.count)
            throw Error("belongs to another sweep than " + first.dir.string() +
                            " (its parameters or shard count differ; see sweep.json)",
                        Where::in_file(s.dir.string()));
        const auto [it, fresh] = seen.emplace(s.shard.index, s.dir.string());
        if (!fresh)
            throw Error("is shard " + std::to_string(s.shard.index) + "/" + std::to_string(s.shard.count) + ", as is " +
                            it->second,
                        Where::in_file(s.dir.string()));
    }
    for (int i = 0; i < first.shard.count; ++i)
        if (!seen.count(i))
            throw Error("shard " + std::to_string(i) + "/" + std::to_string(first.shard.count) + " is missing",
                        Where::in_file(dirs.front()));
    const std::size_t total = whole_number<std::size_t>(first.parameters.at("rows"), "the row count", first.dir / "sweep.json");
    std::vector<const CsvRecord*> rows(total, nullptr);
    for (const ShardDir& s : shards) {
        for (std::size_t k = 0; k < s.indices.size(); ++k) {
            const std::size_t i = s.indices[k];
            if (i >= total || rows[i])
                throw Error("corrupt sweep.json: row " + std::to_string(i) + " is out of range or held twice",
                            Where::in_file((s.dir / "sweep.json").string()));
            rows[i] = &s.rows[k];
        }
    }
    for (std::size_t i = 0; i < total; ++i)
        if (!rows[i]) throw Error("row " + std::to_string(i) + " is in no shard", Where::in_file(dirs.front()));

    // Shards keep every row's pictures (run_sweep); the merge keeps those a whole sweep keeps:
    // the rows keeps_pictures() chooses and the recommended ones.
    const auto column = [](const char* name) {
        return static_cast<std::size_t>(std::find(csv_columns().begin(), csv_columns().end(), name) -
                                        csv_columns().begin());
    };
    const auto cell = [&](std::size_t row, const char* name) { return rows[row]->fields[column(name)]; };
    const std::vector<bool> recommended = recommended_rows(total, cell);
    std::string largest;  // the largest level swept, as sweep.json spells it
    try {
        const auto& levels = first.parameters.at("levels");
        if (!levels.empty()) largest = levels.back().get<std::string>();
    } catch (const nlohmann::json::exception& e) {
        throw Error(std::string("corrupt sweep.json: ") + e.what(), Where::in_file((first.dir / "sweep.json").string()));
    }
    std::set<std::string> leave_out;
    TempDir temp(out);
    fs::create_directories(temp.path() / "images");
    std::string csv = csv_header();
    std::vector<std::size_t> indices(total);
    for (std::size_t i = 0; i < total; ++i) {
        indices[i] = i;
        const std::string level = cell(i, "level");
        const std::optional<double> level_number = cell_number(level);
        if (first.shard.count == 1 || cell(i, "model") != "uniform" || recommended[i] || level == largest ||
            !level_number || keeps_level(*level_number)) {
            csv += rows[i]->raw + "\n";
            continue;
        }
        std::vector<std::string> fields = rows[i]->fields;
        for (const char* name : {"image", "diff_image", "wire_image"}) {
            if (!fields[column(name)].empty()) leave_out.insert(fields[column(name)]);
            fields[column(name)].clear();
        }
        for (std::size_t k = 0; k < fields.size(); ++k) csv += (k ? "," : "") + csv_field(fields[k]);
        csv += "\n";
    }
    for (const ShardDir& s : shards) copy_images(s.dir, temp.path(), leave_out);
    write_text(temp.path() / "sweep.csv", csv);
    write_text(temp.path() / "sweep.json", sweep_json_text(first.parameters, Shard{0, 1}, indices));
    write_sweep_report(temp.path().string());
    temp.commit();
}

}  // namespace tessref::sweep
