// tessref compare — a picture against a reference picture, by the rule of the Khronos CTS
// (tessref/compare.h), or, for two captures (.txt, .ply: tessref/capture.h), every vertex
// of every patch in ulps. Exit status: 0 it passes, 1 it fails, 2 an input cannot be read,
// two images differ in size or channel count, or a flag is wrong (then nothing is written).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <system_error>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "image/image_io.h"
#include "tessref/capture.h"
#include "tessref/compare.h"
#include "common/input_file.h"
#include "tessref/error.h"
#include "tessref/limits.h"

namespace tessref::cli {

namespace {

struct CompareCommandOptions {
    std::string reference;
    std::string test;
    std::string max_position_deviation = "0";
    std::string threshold = "0";
    std::string max_failing_pixels = "0";
    std::string diff;
    std::string max_position_ulps;  // captures; empty: the default
    std::string max_normal_ulps;
    std::string max_position_abs;  // captures; empty: not used
    std::string max_normal_abs;
    bool json = false;
    bool ignore_alpha = false;
    std::string list = "10";  // failing pixels listed with their values
};

// A count flag as typed: a whole number >= 0.
long long parse_count(const std::string& text, const std::string& flag) {
    const std::optional<long long> value = parse_integer(text);
    if (!value || *value < 0) throw Error("'" + text + "' is not a whole number >= 0", Where::in_file(flag));
    return *value;
}

double parse_threshold(const std::string& text) {
    const std::optional<double> value = parse_double(text);
    if (!value) throw Error("'" + text + "' is not a number", Where::in_file("--threshold"));
    if (!std::isfinite(*value) || *value < 0.0)
        throw Error("'" + text + "' is not a threshold: give a finite number >= 0", Where::in_file("--threshold"));
    return *value;
}

std::string channel_name(const FloatImage& image, int channel) {
    const auto c = static_cast<std::size_t>(channel);
    if (c < image.channel_names.size() && !image.channel_names[c].empty()) return image.channel_names[c];
    return std::to_string(channel);
}

// "%.6g", with infinities as "inf" / "-inf" (printf's spelling, kept whatever the libc).
std::string number_text(double x) {
    if (std::isnan(x)) return "nan";
    if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.6g", x);
    return buffer;
}

// JSON has no infinity or NaN: a statistic that is not finite is null.
nlohmann::json number_json(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

// What the report says of the pixels themselves: the worst one, the first failing ones, the
// diff picture's scale.
struct PixelReport {
    PixelDifference worst;
    std::vector<PixelDifference> failing;
    std::optional<DiffPicture> diff;
};

std::string samples_text(const std::vector<float>& samples) {
    std::string s = "(";
    for (std::size_t c = 0; c < samples.size(); ++c) s += (c ? ", " : "") + number_text(samples[c]);
    return s + ")";
}

std::string pixel_text(const FloatImage& reference, const PixelDifference& p) {
    return "(" + std::to_string(p.x) + ", " + std::to_string(p.y) + ")  reference " + samples_text(p.reference) +
           ", test " + samples_text(p.test) + ", difference " + number_text(p.difference) + " in " +
           channel_name(reference, p.channel);
}

nlohmann::json pixel_json(const FloatImage& reference, const PixelDifference& p) {
    nlohmann::json ref = nlohmann::json::array(), test = nlohmann::json::array();
    for (const float v : p.reference) ref.push_back(number_json(v));
    for (const float v : p.test) test.push_back(number_json(v));
    return {{"x", p.x}, {"y", p.y}, {"reference", ref}, {"test", test}, {"difference", number_json(p.difference)},
            {"channel", utf8_for_json(channel_name(reference, p.channel))}};
}

std::string report_text(const CompareCommandOptions& options, const FloatImage& reference,
                        const CompareOptions& compare, const CompareResult& result, const PixelReport& pixels) {
    std::string channels, maxima;
    for (std::size_t k = 0; k < result.compared_channels.size(); ++k) {
        const std::string name = channel_name(reference, result.compared_channels[k]);
        channels += (k ? ", " : "") + name;
        maxima += (k ? ", " : "") + name + " " + number_text(result.channel_max_error[k]);
    }
    std::string text;
    text += "reference  " + options.reference + "  (" + std::to_string(result.width) + "x" +
            std::to_string(result.height) + ", " + std::to_string(reference.channels) + " channels)\n";
    text += "test       " + options.test + "\n";
    text += "compared   " + channels + "; threshold " + number_text(compare.threshold) + ", position deviation " +
            std::to_string(compare.max_position_deviation) + " px\n";
    text += "failing    " + std::to_string(result.failing_pixels) + " of " + std::to_string(result.pixels) +
            " pixels (allowed " + std::to_string(compare.max_failing_pixels) + ")\n";
    text += "rmse       " + number_text(result.rmse) + "\n";
    text += "psnr       " + number_text(result.psnr) + " dB\n";
    text += "max error  " + number_text(result.max_error) + "  (" + maxima + ")\n";
    if (pixels.worst.difference > 0) text += "worst      " + pixel_text(reference, pixels.worst) + "\n";
    if (!pixels.failing.empty()) {
        text += "failing pixels (x, y), the first " + std::to_string(pixels.failing.size()) + " of " +
                std::to_string(result.failing_pixels) + " in row order:\n";
        for (const PixelDifference& p : pixels.failing) text += "  " + pixel_text(reference, p) + "\n";
    }
    if (pixels.diff) {
        const DiffPicture& d = *pixels.diff;
        text += "diff       " + options.diff + ": passing pixels the reference dimmed, failing pixels by their largest "
                "channel difference, blue " + number_text(d.smallest) + " to red " + number_text(d.largest);
        if (d.isolated)
            text += "; " + std::to_string(d.isolated) + " isolated failing pixels ringed in magenta" +
                    (d.isolated > kDiffMaxRings ? " (the first " + std::to_string(kDiffMaxRings) + ")" : std::string());
        if (d.legend) text += "; the scale below row " + std::to_string(result.height - 1);
        text += "\n";
    }
    text += result.passed ? "PASS\n" : "FAIL\n";
    return text;
}

std::string report_json(const CompareCommandOptions& options, const FloatImage& reference,
                        const CompareOptions& compare, const CompareResult& result, const PixelReport& pixels) {
    nlohmann::json channels = nlohmann::json::array(), maxima = nlohmann::json::array();
    for (std::size_t k = 0; k < result.compared_channels.size(); ++k) {
        channels.push_back(utf8_for_json(channel_name(reference, result.compared_channels[k])));
        maxima.push_back(number_json(result.channel_max_error[k]));
    }
    nlohmann::json report = {
        {"reference", utf8_for_json(options.reference)},
        {"test", utf8_for_json(options.test)},
        {"width", result.width},
        {"height", result.height},
        {"channels", channels},
        {"threshold", compare.threshold},
        {"max_position_deviation", compare.max_position_deviation},
        {"max_failing_pixels", compare.max_failing_pixels},
        {"pixels", result.pixels},
        {"failing_pixels", result.failing_pixels},
        {"rmse", number_json(result.rmse)},
        {"psnr", number_json(result.psnr)},
        {"max_error", number_json(result.max_error)},
        {"channel_max_error", maxima},
        {"diff", options.diff.empty() ? nlohmann::json(nullptr) : nlohmann::json(utf8_for_json(options.diff))},
        {"passed", result.passed},
    };
    report["worst_pixel"] = pixels.worst.difference > 0 ? pixel_json(reference, pixels.worst) : nlohmann::json(nullptr);
    report["failing_pixel_list"] = nlohmann::json::array();
    for (const PixelDifference& p : pixels.failing) report["failing_pixel_list"].push_back(pixel_json(reference, p));
    if (pixels.diff) {
        report["diff_scale"] = {number_json(pixels.diff->smallest), number_json(pixels.diff->largest)};
        report["isolated_failing_pixels"] = pixels.diff->isolated;
    }
    return report.dump(2) + "\n";
}

// ---- captures --------------------------------------------------------------------------

std::string ulps_text(std::uint64_t ulps) { return ulps == kInfiniteUlps ? "inf" : std::to_string(ulps); }
nlohmann::json ulps_json(std::uint64_t ulps) { return ulps == kInfiniteUlps ? nlohmann::json(nullptr) : nlohmann::json(ulps); }

std::string vec_text(const glm::vec3& v) {
    return "(" + format_float(v.x) + ", " + format_float(v.y) + ", " + format_float(v.z) + ")";
}
nlohmann::json vec_json(const glm::vec3& v) {
    return {number_json(v.x), number_json(v.y), number_json(v.z)};
}
std::string levels_text(const TessLevels& l) {
    std::string s;
    for (float x : l.outer) s += (s.empty() ? "" : " ") + format_float(x);
    s += " |";
    for (float x : l.inner) s += " " + format_float(x);
    return s;
}
nlohmann::json levels_json(const TessLevels& l) {
    return {{"outer", {number_json(l.outer[0]), number_json(l.outer[1]), number_json(l.outer[2]), number_json(l.outer[3])}},
            {"inner", {number_json(l.inner[0]), number_json(l.inner[1])}}};
}

// |reference - test| of one component, as the ulps beside it count it.
double abs_of(float reference, float test) {
    if (reference == test) return 0.0;
    if (std::isnan(reference) || std::isnan(test)) return std::isnan(reference) && std::isnan(test) ? 0.0 : std::numeric_limits<double>::infinity();
    return std::abs(static_cast<double>(reference) - static_cast<double>(test));
}
double abs_of(const glm::vec3& reference, const glm::vec3& test) {
    double d = 0.0;
    for (int k = 0; k < 3; ++k) d = std::max(d, abs_of(reference[k], test[k]));
    return d;
}

std::string worst_text(const WorstUlps& w) {
    if (!w.found) return "none compared";
    return ulps_text(w.ulps) + " ulps (|difference| " +
           number_text(abs_of(w.reference[w.component], w.test[w.component])) + ") at patch " + std::to_string(w.patch_id) + ", tess coord " + vec_text(w.tess_coord) +
           ", " + "xyz"[w.component] + ": reference " + format_float(w.reference[w.component]) + ", test " +
           format_float(w.test[w.component]) + "  (reference " + vec_text(w.reference) + ", test " + vec_text(w.test) + ")";
}
nlohmann::json worst_json(const WorstUlps& w) {
    if (!w.found) return nullptr;
    return {{"ulps", ulps_json(w.ulps)},          {"abs", number_json(abs_of(w.reference[w.component], w.test[w.component]))},
            {"patch", w.patch_id},
            {"tess_coord", vec_json(w.tess_coord)}, {"component", std::string(1, "xyz"[w.component])},
            {"reference", vec_json(w.reference)},   {"test", vec_json(w.test)}};
}

std::string diverging_text(const DivergingPatch& d, const Capture& reference, const Capture& test) {
    std::string s = "  patch " + std::to_string(d.patch_id) + "  " + to_string(d.kind) + ": ";
    const auto levels = [&] {
        std::string l = "levels reference " + (reference.has_levels ? levels_text(d.reference_levels) : "unknown") +
                        ", test " + (test.has_levels ? levels_text(d.test_levels) : "unknown");
        if (d.levels_known) l += " (" + ulps_text(d.level_ulps) + " ulps apart)";
        return l;
    };
    switch (d.kind) {
        case PatchDivergence::missing_in_test:
        case PatchDivergence::missing_in_reference:
            s += std::to_string(d.kind == PatchDivergence::missing_in_test ? d.reference_vertices : d.test_vertices) +
                 " vertices on one side only; " + levels();
            break;
        case PatchDivergence::tess_coords:
            s += "tess coord " + vec_text(d.tess_coord) + " only in the " +
                 (d.tess_coord_in_reference ? "reference" : "test") + " (" + std::to_string(d.reference_vertices) +
                 " vs " + std::to_string(d.test_vertices) + " vertices); " + levels();
            break;
        case PatchDivergence::triangles:
            s += "the same tess coords in other triangles, first at " + vec_text(d.tess_coord);
            break;
        case PatchDivergence::orientation:
            s += std::to_string(d.flipped_triangles) + " of " + std::to_string(d.reference_vertices / 3) +
                 " triangles the other way round (cw against ccw), first at " + vec_text(d.tess_coord);
            break;
        case PatchDivergence::values:
            s += std::to_string(d.failing_vertices) + " of " + std::to_string(d.reference_vertices) +
                 " vertices fail; first at tess coord " + vec_text(d.tess_coord) + ": position reference " +
                 vec_text(d.reference_position) + ", test " + vec_text(d.test_position) + " (" +
                 ulps_text(d.position_ulps) + " ulps, |difference| " +
                 number_text(abs_of(d.reference_position, d.test_position)) + "); normal reference " +
                 vec_text(d.reference_normal) + ", test " + vec_text(d.test_normal) + " (" + ulps_text(d.normal_ulps) +
                 " ulps, |difference| " + number_text(abs_of(d.reference_normal, d.test_normal)) + ")";
            break;
    }
    return s + "\n";
}

nlohmann::json diverging_json(const DivergingPatch& d, const Capture& reference, const Capture& test) {
    nlohmann::json j = {{"patch", d.patch_id},
                        {"kind", to_string(d.kind)},
                        {"reference_vertices", d.reference_vertices},
                        {"test_vertices", d.test_vertices},
                        {"reference_levels", reference.has_levels && d.kind != PatchDivergence::missing_in_reference
                                                 ? levels_json(d.reference_levels) : nlohmann::json(nullptr)},
                        {"test_levels", test.has_levels && d.kind != PatchDivergence::missing_in_test
                                            ? levels_json(d.test_levels) : nlohmann::json(nullptr)},
                        {"level_ulps", d.levels_known ? ulps_json(d.level_ulps) : nlohmann::json(nullptr)},
                        {"tess_coord", vec_json(d.tess_coord)}};
    if (d.kind == PatchDivergence::tess_coords) j["tess_coord_only_in"] = d.tess_coord_in_reference ? "reference" : "test";
    if (d.kind == PatchDivergence::orientation) j["flipped_triangles"] = d.flipped_triangles;
    if (d.kind == PatchDivergence::values) {
        j["failing_vertices"] = d.failing_vertices;
        j["reference_position"] = vec_json(d.reference_position);
        j["test_position"] = vec_json(d.test_position);
        j["position_ulps"] = ulps_json(d.position_ulps);
        j["reference_normal"] = vec_json(d.reference_normal);
        j["test_normal"] = vec_json(d.test_normal);
        j["normal_ulps"] = ulps_json(d.normal_ulps);
    }
    return j;
}

std::string capture_report_text(const CompareCommandOptions& options, const Capture& reference, const Capture& test,
                                const CaptureCompareOptions& compare, const CaptureCompareResult& r) {
    std::string text;
    text += "reference  " + options.reference + "  (" + std::to_string(r.reference_patches) + " patches, " +
            std::to_string(reference.vertices.size()) + " vertices" + (reference.has_levels ? "" : ", no levels") + ")\n";
    text += "test       " + options.test + "  (" + std::to_string(r.test_patches) + " patches, " +
            std::to_string(test.vertices.size()) + " vertices" + (test.has_levels ? "" : ", no levels") + ")\n";
    text += "tolerance  position " + std::to_string(compare.max_position_ulps) + " ulps" +
            (compare.max_position_abs > 0 ? " or " + number_text(compare.max_position_abs) : std::string()) +
            ", normal " + std::to_string(compare.max_normal_ulps) + " ulps" +
            (compare.max_normal_abs > 0 ? " or " + number_text(compare.max_normal_abs) : std::string()) + "\n";
    text += "patches    " + std::to_string(r.compared_patches) + " compared vertex by vertex; diverging: " +
            std::to_string(r.missing_in_test) + " missing in test, " + std::to_string(r.missing_in_reference) +
            " missing in reference, " + std::to_string(r.tess_coord_divergences) + " other tess coords (" +
            std::to_string(r.tess_coord_divergences_with_equal_levels) + " of them with equal levels), " +
            std::to_string(r.triangle_divergences) + " other triangles, " + std::to_string(r.orientation_divergences) +
            " other orientation (" + std::to_string(r.flipped_triangles) + " triangles), " +
            std::to_string(r.value_divergences) +
            " beyond the tolerance\n";
    text += "vertices   " + std::to_string(r.vertices_compared) + " compared, " + std::to_string(r.failing_vertices) +
            " beyond the tolerance\n";
    if (r.vertices_compared) {
        text += "per component over the " + std::to_string(r.vertices_compared) +
                " compared corners (normal: each corner's largest normal component):\n"
                "  component  max |difference|  mean |difference|    max ulps  beyond tolerance\n";
        static const char* const names[] = {"x", "y", "z", "normal"};
        for (std::size_t k = 0; k < r.components.size(); ++k) {
            const ComponentSummary& c = r.components[k];
            char line[160];
            std::snprintf(line, sizeof line, "  %-9s  %16s  %17s  %10s  %16zu\n", names[k], number_text(c.max_abs).c_str(),
                          number_text(c.compared ? c.sum_abs / static_cast<double>(c.compared) : 0.0).c_str(),
                          ulps_text(c.max_ulps).c_str(), c.beyond);
            text += line;
        }
    }
    text += "worst position  " + worst_text(r.worst_position) + "\n";
    text += "worst normal    " + worst_text(r.worst_normal) + "\n";
    if (!r.listed.empty()) {
        text += "diverging patches (the first " + std::to_string(r.listed.size()) + " of " +
                std::to_string(r.diverging_patches()) + "):\n";
        for (const DivergingPatch& d : r.listed) text += diverging_text(d, reference, test);
    }
    if (!r.failing_vertices_per_patch.empty()) {
        text += "failing vertices per patch (patch:count):";
        for (std::size_t k = 0; k < r.failing_vertices_per_patch.size(); ++k)
            text += std::string(k % 12 == 0 ? "\n  " : " ") + std::to_string(r.failing_vertices_per_patch[k].first) +
                    ":" + std::to_string(r.failing_vertices_per_patch[k].second);
        text += "\n";
    }
    text += r.passed ? "PASS\n" : "FAIL\n";
    return text;
}

nlohmann::json components_json(const CaptureCompareResult& r) {
    nlohmann::json out = nlohmann::json::object();
    static const char* const names[] = {"x", "y", "z", "normal"};
    for (std::size_t k = 0; k < r.components.size(); ++k) {
        const ComponentSummary& c = r.components[k];
        out[names[k]] = {{"compared", c.compared},
                         {"max_abs", number_json(c.max_abs)},
                         {"mean_abs", number_json(c.compared ? c.sum_abs / static_cast<double>(c.compared) : 0.0)},
                         {"max_ulps", ulps_json(c.max_ulps)},
                         {"beyond", c.beyond}};
    }
    return out;
}

std::string capture_report_json(const CompareCommandOptions& options, const Capture& reference, const Capture& test,
                                const CaptureCompareOptions& compare, const CaptureCompareResult& r) {
    nlohmann::json per_patch = nlohmann::json::array(), listed = nlohmann::json::array();
    for (const auto& [patch, count] : r.failing_vertices_per_patch)
        per_patch.push_back({{"patch", patch}, {"failing_vertices", count}});
    for (const DivergingPatch& d : r.listed) listed.push_back(diverging_json(d, reference, test));
    nlohmann::json report = {
        {"reference", utf8_for_json(options.reference)},
        {"test", utf8_for_json(options.test)},
        {"reference_has_levels", reference.has_levels},
        {"test_has_levels", test.has_levels},
        {"max_position_ulps", compare.max_position_ulps},
        {"max_normal_ulps", compare.max_normal_ulps},
        {"max_position_abs", compare.max_position_abs},
        {"max_normal_abs", compare.max_normal_abs},
        {"reference_patches", r.reference_patches},
        {"test_patches", r.test_patches},
        {"compared_patches", r.compared_patches},
        {"vertices_compared", r.vertices_compared},
        {"failing_vertices", r.failing_vertices},
        {"missing_in_test", r.missing_in_test},
        {"missing_in_reference", r.missing_in_reference},
        {"tess_coord_divergences", r.tess_coord_divergences},
        {"tess_coord_divergences_with_equal_levels", r.tess_coord_divergences_with_equal_levels},
        {"triangle_divergences", r.triangle_divergences},
        {"orientation_divergences", r.orientation_divergences},
        {"flipped_triangles", r.flipped_triangles},
        {"value_divergences", r.value_divergences},
        {"components", components_json(r)},
        {"worst_position", worst_json(r.worst_position)},
        {"worst_normal", worst_json(r.worst_normal)},
        {"failing_vertices_per_patch", per_patch},
        {"diverging_patches", r.diverging_patches()},
        {"listed", listed},
        {"passed", r.passed},
    };
    return report.dump(2) + "\n";
}

double parse_threshold_flag(const std::string& text, const std::string& flag) {
    const std::optional<double> value = parse_double(text);
    if (!value || !std::isfinite(*value) || *value < 0.0)
        throw Error("'" + text + "' is not a distance (a finite number >= 0)", Where::in_file(flag));
    return *value;
}

std::uint64_t parse_ulps(const std::string& text, const std::string& flag, std::uint64_t default_value) {
    return text.empty() ? default_value : static_cast<std::uint64_t>(parse_count(text, flag));
}

int run_compare_captures(const CompareCommandOptions& options) {
    for (const std::string* input : {&options.reference, &options.test})
        if (!is_capture_path(*input))
            throw Error("'" + *input + "' is not a capture (.txt, .ply) and the other input is: compare two captures "
                        "or two images",
                        Where::in_file(*input));
    const bool image_flags = options.max_position_deviation != "0" || options.threshold != "0" ||
                             options.max_failing_pixels != "0" || !options.diff.empty() || options.ignore_alpha ||
                             options.list != "10";
    if (image_flags)
        throw Error("--max-position-deviation, --threshold, --max-failing-pixels, --diff, --list and --ignore-alpha compare "
                    "images; for captures give --max-position-ulps and --max-normal-ulps",
                    Where::in_file(options.test));
    CaptureCompareOptions compare;
    compare.max_position_ulps = parse_ulps(options.max_position_ulps, "--max-position-ulps", kDefaultMaxPositionUlps);
    compare.max_normal_ulps = parse_ulps(options.max_normal_ulps, "--max-normal-ulps", kDefaultMaxNormalUlps);
    if (!options.max_position_abs.empty()) compare.max_position_abs = parse_threshold_flag(options.max_position_abs, "--max-position-abs");
    if (!options.max_normal_abs.empty()) compare.max_normal_abs = parse_threshold_flag(options.max_normal_abs, "--max-normal-abs");
    const Capture reference = read_capture(options.reference);
    const Capture test = read_capture(options.test);
    const CaptureCompareResult result = compare_captures(reference, test, compare);
    std::cout << (options.json ? capture_report_json(options, reference, test, compare, result)
                               : capture_report_text(options, reference, test, compare, result))
              << std::flush;
    return result.passed ? 0 : 1;
}

// ---- images ----------------------------------------------------------------------------

int run_compare(const CompareCommandOptions& options) {
    if (is_capture_path(options.reference) || is_capture_path(options.test)) return run_compare_captures(options);
    if (!options.max_position_ulps.empty() || !options.max_normal_ulps.empty() || !options.max_position_abs.empty() ||
        !options.max_normal_abs.empty())
        throw Error("--max-position-ulps, --max-normal-ulps, --max-position-abs and --max-normal-abs compare captures "
                    "(.txt, .ply), not images",
                    Where::in_file(!options.max_position_ulps.empty() ? "--max-position-ulps"
                               : !options.max_normal_ulps.empty() ? "--max-normal-ulps"
                               : !options.max_position_abs.empty() ? "--max-position-abs"
                                                                   : "--max-normal-abs"));
    // Flags first: nothing is read for a command line that cannot succeed.
    CompareOptions compare;
    const long long deviation = parse_count(options.max_position_deviation, "--max-position-deviation");
    if (deviation > kMaxPositionDeviation)
        throw Error("'" + options.max_position_deviation + "' is more than " + std::to_string(kMaxPositionDeviation) +
                        " pixels: a position deviation allows for rasterization differences, a pixel or two",
                    Where::in_file("--max-position-deviation"));
    compare.max_position_deviation = static_cast<int>(deviation);
    compare.threshold = parse_threshold(options.threshold);
    compare.max_failing_pixels = static_cast<std::uint64_t>(parse_count(options.max_failing_pixels, "--max-failing-pixels"));
    compare.ignore_alpha = options.ignore_alpha;
    const auto listed = static_cast<std::size_t>(parse_count(options.list, "--list"));
    if (!options.diff.empty()) image::require_writable(options.diff, "--diff");

    // A diff written over an input would destroy the golden image it was compared with: the
    // inputs are named before anything is read, so AtomicOutput refuses it at once.
    note_input(options.reference);
    note_input(options.test);
    std::optional<AtomicOutput> output;
    try {
        if (!options.diff.empty()) output.emplace(options.diff);
    } catch (const Error& e) {
        throw Error(e.what(), Where::in_file("--diff"));  // the flag that named it
    }

    // The whole command's memory, from the two headers, before any pixel is read (each
    // image alone may fit where both, the failing-pixel mask and the diff do not).
    int width = 0, height = 0;
    const std::uint64_t inputs = float_image_memory(options.reference, &width, &height);
    const std::uint64_t pixels = saturating_bytes(static_cast<std::uint64_t>(std::max(width, 0)),
                                                  static_cast<std::uint64_t>(std::max(height, 0)));
    const std::uint64_t diff = options.diff.empty() ? 0 : saturating_bytes(pixels, 3 * 4 + 3 + 3);  // floats, codes, PNG rows
    const std::uint64_t total = std::min<std::uint64_t>(UINT64_MAX / 4, inputs) +
                                std::min<std::uint64_t>(UINT64_MAX / 4, float_image_memory(options.test)) +
                                std::min<std::uint64_t>(UINT64_MAX / 4, pixels) + std::min<std::uint64_t>(UINT64_MAX / 4, diff);
    require_memory(total,
                   "comparing two images of " + std::to_string(width) + " x " + std::to_string(height) + " pixels" +
                       (options.diff.empty() ? std::string() : " and writing their diff"),
                   Where::in_file(options.test));

    const FloatImage reference = read_float_image(options.reference);
    const FloatImage test = read_float_image(options.test);
    if (reference.width != test.width || reference.height != test.height)
        throw Error("the images differ in size: " + options.reference + " is " + std::to_string(reference.width) +
                        "x" + std::to_string(reference.height) + ", " + options.test + " is " +
                        std::to_string(test.width) + "x" + std::to_string(test.height),
                    Where::in_file(options.test));
    if (reference.channels != test.channels)
        throw Error("the images differ in channel count: " + options.reference + " has " +
                        std::to_string(reference.channels) + ", " + options.test + " has " +
                        std::to_string(test.channels),
                    Where::in_file(options.test));
    const CompareResult result = compare_images(reference, test, compare);
    PixelReport found;
    found.worst = worst_pixel(reference, test, result);
    found.failing = first_failing_pixels(reference, test, result, listed);
    if (output) found.diff = difference_picture(reference, test, result);
    // The report is made before the diff is put in place: a report that cannot be made
    // leaves no diff behind.
    const std::string report = options.json ? report_json(options, reference, compare, result, found)
                                            : report_text(options, reference, compare, result, found);
    if (output) {
        try {
            write_float_image(found.diff->image, output->temp_path().string());
        } catch (const Error& error) {
            throw Error(error.what(), Where::in_file(options.diff));  // the name given, not the temporary one
        }
        output->commit();
    }
    std::cout << report << std::flush;
    return result.passed ? 0 : 1;
}

}  // namespace

Command add_compare_command(CLI::App& parent) {
    auto options = std::make_shared<CompareCommandOptions>();
    CLI::App* app = parent.add_subcommand(
        "compare",
        "Compare an image (TEST) with a reference image (REF) as the Khronos CTS compares rasterized pictures: "
        "a pixel passes when every channel is within the threshold of the reference pixel, or, both ways, of a "
        "pixel within the position deviation. Every channel counts, alpha included; 8-bit images compare as "
        "code/255. Prints the failing pixels, RMSE, PSNR and max error. "
        "Two captures (.txt, .ply of `tessref mesh --capture` / `tessref gl --capture`) are compared patch by "
        "patch: the same tess coords (exact bits), then every vertex's position and normal within the ulps given. "
        "Exit status 0: it passes, 1: it fails, 2: an input cannot be read or two images differ in size or channels.");
    app->add_option("reference", options->reference, "The reference image (PNG, TIFF, EXR, ...) or capture (.txt, .ply)")
        ->required();
    app->add_option("test", options->test, "The image or capture to check against it")->required();
    app->add_option("--max-position-deviation", options->max_position_deviation,
                    "How far, in pixels (x and y), a matching pixel may lie (0..16): the neighbourhood is (2*PX+1)^2 pixels")
        ->type_name("PX")
        ->default_str("0");
    app->add_option("--threshold", options->threshold,
                    "Largest accepted difference per channel, inclusive, in [0, 1] units for 8-bit images "
                    "(one code is 1/255; give (k+0.5)/255 to accept k codes)")
        ->type_name("T")
        ->default_str("0");
    app->add_option("--max-failing-pixels", options->max_failing_pixels, "Failing pixels allowed for a pass")
        ->type_name("N")
        ->default_str("0");
    app->add_option("--diff", options->diff,
                    "Write a picture of the failing pixels over the reference dimmed to a quarter (PNG, TIFF, EXR): "
                    "each failing pixel coloured by its largest channel difference on a scale from blue (the "
                    "smallest) to red (the largest), isolated failing pixels ringed in magenta, the scale with its "
                    "ends in a band below the picture (when it is at least 160 pixels wide)");
    app->add_option("--list", options->list, "Images: list the first N failing pixels with both values")
        ->type_name("N")
        ->default_str("10");
    app->add_flag("--ignore-alpha", options->ignore_alpha, "Leave the alpha channel out of the comparison");
    app->add_option("--max-position-ulps", options->max_position_ulps,
                    "Captures: largest accepted difference of a position component, in ulps")
        ->type_name("N")
        ->default_str(std::to_string(kDefaultMaxPositionUlps));
    app->add_option("--max-normal-ulps", options->max_normal_ulps,
                    "Captures: largest accepted difference of a normal component, in ulps")
        ->type_name("N")
        ->default_str(std::to_string(kDefaultMaxNormalUlps));
    app->add_option("--max-position-abs", options->max_position_abs,
                    "Captures: a position component also passes within this distance (world units), for values "
                    "near zero where ulps are tiny")
        ->type_name("D");
    app->add_option("--max-normal-abs", options->max_normal_abs,
                    "Captures: a normal component also passes within this distance")
        ->type_name("D");
    app->add_flag("--json", options->json,
                  "Print the result as JSON (a statistic that is not finite, such as the PSNR of identical images, is null)");
    return Command{app, [options] { return run_compare(*options); }};
}

}  // namespace tessref::cli
