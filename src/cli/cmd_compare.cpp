// tessref compare — a picture against a reference picture, by the rule of the Khronos CTS
// (tessref/compare.h). Exit status: 0 it passes, 1 it fails, 2 an image cannot be read,
// the two differ in size or channel count, or a flag is wrong (then nothing is written).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <system_error>

#include <CLI/CLI.hpp>
#include <OpenImageIO/imageio.h>
#include <nlohmann/json.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "tessref/compare.h"
#include "tessref/error.h"

namespace tessref::cli {

namespace {

struct CompareCommandOptions {
    std::string reference;
    std::string test;
    std::string max_position_deviation = "0";
    std::string threshold = "0";
    std::string max_failing_pixels = "0";
    std::string diff;
    bool json = false;
    bool ignore_alpha = false;
};

// A count flag as typed: a whole number >= 0.
long long parse_count(const std::string& text, const std::string& flag) {
    const std::optional<long long> value = parse_integer(text);
    if (!value || *value < 0) throw Error("'" + text + "' is not a whole number >= 0", where_file(flag));
    return *value;
}

double parse_threshold(const std::string& text) {
    const std::optional<double> value = parse_double(text);
    if (!value) throw Error("'" + text + "' is not a number", where_file("--threshold"));
    if (!std::isfinite(*value) || *value < 0.0)
        throw Error("'" + text + "' is not a threshold: give a finite number >= 0", where_file("--threshold"));
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

std::string report_text(const CompareCommandOptions& options, const FloatImage& reference,
                        const CompareOptions& compare, const CompareResult& result) {
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
    if (!options.diff.empty()) text += "diff       " + options.diff + "\n";
    text += result.passed ? "PASS\n" : "FAIL\n";
    return text;
}

std::string report_json(const CompareCommandOptions& options, const FloatImage& reference,
                        const CompareOptions& compare, const CompareResult& result) {
    nlohmann::json channels = nlohmann::json::array(), maxima = nlohmann::json::array();
    for (std::size_t k = 0; k < result.compared_channels.size(); ++k) {
        channels.push_back(channel_name(reference, result.compared_channels[k]));
        maxima.push_back(number_json(result.channel_max_error[k]));
    }
    nlohmann::json report = {
        {"reference", options.reference},
        {"test", options.test},
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
        {"diff", options.diff.empty() ? nlohmann::json(nullptr) : nlohmann::json(options.diff)},
        {"passed", result.passed},
    };
    return report.dump(2) + "\n";
}

int run_compare(const CompareCommandOptions& options) {
    // Flags first: nothing is read for a command line that cannot succeed.
    CompareOptions compare;
    const long long deviation = parse_count(options.max_position_deviation, "--max-position-deviation");
    if (deviation > 1'000'000'000)
        throw Error("'" + options.max_position_deviation + "' is too large", where_file("--max-position-deviation"));
    compare.max_position_deviation = static_cast<int>(deviation);
    compare.threshold = parse_threshold(options.threshold);
    compare.max_failing_pixels = static_cast<std::uint64_t>(parse_count(options.max_failing_pixels, "--max-failing-pixels"));
    compare.ignore_alpha = options.ignore_alpha;
    if (!options.diff.empty() && !OIIO::ImageOutput::create(options.diff)) {
        throw Error("no image format for '" + options.diff +
                        "': give the name an extension OpenImageIO writes, such as .png, .tif or .exr",
                    where_file("--diff"));
    }

    // A diff written over an input would destroy the golden image it was compared with.
    for (const std::string* input : {&options.reference, &options.test}) {
        std::error_code ec;
        if (!options.diff.empty() && std::filesystem::equivalent(options.diff, *input, ec))
            throw Error("'" + options.diff + "' is the image " + *input + ": the diff would overwrite it",
                        where_file("--diff"));
    }

    const FloatImage reference = read_float_image(options.reference);
    const FloatImage test = read_float_image(options.test);
    if (reference.width != test.width || reference.height != test.height)
        throw Error("the images differ in size: " + options.reference + " is " + std::to_string(reference.width) +
                        "x" + std::to_string(reference.height) + ", " + options.test + " is " +
                        std::to_string(test.width) + "x" + std::to_string(test.height),
                    where_file(options.test));
    if (reference.channels != test.channels)
        throw Error("the images differ in channel count: " + options.reference + " has " +
                        std::to_string(reference.channels) + ", " + options.test + " has " +
                        std::to_string(test.channels),
                    where_file(options.test));
    const CompareResult result = compare_images(reference, test, compare);

    if (!options.diff.empty()) {
        AtomicOutput output(options.diff);
        try {
            write_float_image(difference_picture(reference, result), output.temp_path().string());
        } catch (const Error& error) {
            throw Error(error.what(), where_file(options.diff));  // the name given, not the temporary one
        }
        output.commit();
    }
    std::cout << (options.json ? report_json(options, reference, compare, result)
                               : report_text(options, reference, compare, result))
              << std::flush;
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
        "Exit status 0: it passes, 1: it fails, 2: an image cannot be read or the two differ in size or channels.");
    app->add_option("reference", options->reference, "The reference image (PNG, TIFF, EXR, ...)")->required();
    app->add_option("test", options->test, "The image to check against it")->required();
    app->add_option("--max-position-deviation", options->max_position_deviation,
                    "How far, in pixels (x and y), a matching pixel may lie: the neighbourhood is (2*PX+1)^2 pixels")
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
                    "Write a picture of the failing pixels (red) over the reference dimmed to a quarter "
                    "(PNG, TIFF, EXR)");
    app->add_flag("--ignore-alpha", options->ignore_alpha, "Leave the alpha channel out of the comparison");
    app->add_flag("--json", options->json,
                  "Print the result as JSON (a statistic that is not finite, such as the PSNR of identical images, is null)");
    return Command{app, [options] { return run_compare(*options); }};
}

}  // namespace tessref::cli
