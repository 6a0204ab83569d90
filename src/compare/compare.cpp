// The comparison of tessref/compare.h (THE RULE there).
#include "tessref/compare.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "common/parallel.h"

#include "tessref/error.h"

namespace tessref {

namespace {

// |a - b| in double, with equal samples (two NaNs, one infinity twice) 0 and a NaN against
// anything else +inf: a NaN where the reference has a number is a difference, not "no
// information".
double sample_difference(float a, float b) {
    if (a == b || (std::isnan(a) && std::isnan(b))) return 0.0;
    if (std::isnan(a) || std::isnan(b)) return std::numeric_limits<double>::infinity();
    return std::abs(static_cast<double>(a) - static_cast<double>(b));
}

struct Matcher {
    const FloatImage& reference;
    const FloatImage& test;
    const std::vector<int>& channels;
    double threshold;
    int deviation;

    bool match(const FloatImage& p_image, int px, int py, const FloatImage& q_image, int qx, int qy) const {
        for (const int c : channels)
            if (!(sample_difference(p_image.at(px, py, c), q_image.at(qx, qy, c)) <= threshold)) return false;
        return true;
    }

    // Some pixel of `q_image` in N(x, y) matches p_image(x, y).
    bool found_near(const FloatImage& p_image, const FloatImage& q_image, int x, int y) const {
        const int y0 = std::max(0, y - deviation), y1 = std::min(p_image.height - 1, y + deviation);
        const int x0 = std::max(0, x - deviation), x1 = std::min(p_image.width - 1, x + deviation);
        for (int sy = y0; sy <= y1; ++sy)
            for (int sx = x0; sx <= x1; ++sx)
                if (match(p_image, x, y, q_image, sx, sy)) return true;
        return false;
    }

    bool passes(int x, int y) const {
        if (match(reference, x, y, test, x, y)) return true;
        if (deviation == 0) return false;
        return found_near(reference, test, x, y) && found_near(test, reference, x, y);
    }
};

}  // namespace

CompareResult compare_images(const FloatImage& reference, const FloatImage& test, const CompareOptions& options) {
    if (reference.width != test.width || reference.height != test.height)
        throw Error("the images differ in size: " + std::to_string(reference.width) + "x" +
                        std::to_string(reference.height) + " and " + std::to_string(test.width) + "x" +
                        std::to_string(test.height),
                    Where::at_key("size"));
    if (reference.channels != test.channels)
        throw Error("the images differ in channel count: " + std::to_string(reference.channels) + " and " +
                        std::to_string(test.channels),
                    Where::at_key("channels"));
    if (!(options.threshold >= 0.0))
        throw Error("the threshold must be a number >= 0", Where::at_key("--threshold"));
    if (options.max_position_deviation < 0 || options.max_position_deviation > kMaxPositionDeviation)
        throw Error("the position deviation must lie in 0.." + std::to_string(kMaxPositionDeviation) + ", not " +
                        std::to_string(options.max_position_deviation),
                    Where::at_key("--max-position-deviation"));

    CompareResult result;
    result.width = reference.width;
    result.height = reference.height;
    for (int c = 0; c < reference.channels; ++c)
        if (!(options.ignore_alpha && c == reference.alpha_channel)) result.compared_channels.push_back(c);
    const std::size_t channel_count = result.compared_channels.size();
    result.pixels = static_cast<std::uint64_t>(reference.width) * static_cast<std::uint64_t>(reference.height);
    result.failing.assign(static_cast<std::size_t>(result.pixels), 0);
    result.channel_max_error.assign(channel_count, 0.0);

    // Per-row partial results, reduced in row order afterwards: the same sums whatever the
    // number of threads.
    const auto rows = static_cast<std::size_t>(std::max(reference.height, 0));
    std::vector<double> row_squares(rows, 0.0);
    std::vector<std::uint64_t> row_failing(rows, 0);
    std::vector<double> row_channel_max(rows * channel_count, 0.0);
    // Past the image's size, a larger deviation only repeats the clamp.
    const int deviation = std::min(options.max_position_deviation, std::max(reference.width, reference.height));
    const Matcher matcher{reference, test, result.compared_channels, options.threshold, deviation};

    tessref::parallel_for(tbb::blocked_range<int>(0, reference.height), [&](const tbb::blocked_range<int>& range) {
        for (int y = range.begin(); y < range.end(); ++y) {
            const auto row = static_cast<std::size_t>(y);
            double squares = 0.0;
            std::uint64_t failing = 0;
            double* channel_max = row_channel_max.data() + row * channel_count;
            for (int x = 0; x < reference.width; ++x) {
                for (std::size_t k = 0; k < channel_count; ++k) {
                    const int c = result.compared_channels[k];
                    const double e = sample_difference(reference.at(x, y, c), test.at(x, y, c));
                    squares += e * e;
                    channel_max[k] = std::max(channel_max[k], e);
                }
                if (!matcher.passes(x, y)) {
                    result.failing[row * static_cast<std::size_t>(reference.width) + static_cast<std::size_t>(x)] = 1;
                    ++failing;
                }
            }
            row_squares[row] = squares;
            row_failing[row] = failing;
        }
    });

    double squares = 0.0;
    for (std::size_t row = 0; row < rows; ++row) {
        squares += row_squares[row];
        result.failing_pixels += row_failing[row];
        for (std::size_t k = 0; k < channel_count; ++k)
            result.channel_max_error[k] = std::max(result.channel_max_error[k], row_channel_max[row * channel_count + k]);
    }
    for (const double e : result.channel_max_error) result.max_error = std::max(result.max_error, e);
    const double samples = static_cast<double>(result.pixels) * static_cast<double>(channel_count);
    const double mse = samples > 0.0 ? squares / samples : 0.0;
    result.rmse = std::sqrt(mse);
    result.psnr = mse == 0.0 ? std::numeric_limits<double>::infinity() : 10.0 * std::log10(1.0 / mse);
    result.passed = result.failing_pixels <= options.max_failing_pixels;
    return result;
}

FloatImage difference_picture(const FloatImage& reference, const CompareResult& result) {
    if (reference.width != result.width || reference.height != result.height || reference.channels <= 0)
        throw Error("the reference is not the image the comparison was of", Where::at_key("size"));
    FloatImage picture;
    picture.width = reference.width;
    picture.height = reference.height;
    picture.channels = 3;
    picture.channel_names = {"R", "G", "B"};
    picture.samples.resize(picture.index(0, picture.height));
    const auto dimmed = [](float v) { return kDiffDim * (std::isnan(v) ? 0.0f : std::clamp(v, 0.0f, 1.0f)); };
    for (int y = 0; y < picture.height; ++y) {
        for (int x = 0; x < picture.width; ++x) {
            const std::size_t pixel = static_cast<std::size_t>(y) * static_cast<std::size_t>(picture.width) +
                                      static_cast<std::size_t>(x);
            for (int c = 0; c < 3; ++c) {
                float v;
                if (result.failing[pixel])
                    v = c == 0 ? 1.0f : 0.0f;
                else
                    v = dimmed(reference.at(x, y, reference.channels >= 3 ? c : 0));
                picture.samples[picture.index(x, y, c)] = v;
            }
        }
    }
    return picture;
}

}  // namespace tessref
