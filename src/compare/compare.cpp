// The comparison of tessref/compare.h (THE RULE there).
#include "tessref/compare.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/parallel.h"

#include "tessref/error.h"
#include "tessref/limits.h"

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

bool match(const FloatImage& p_image, int px, int py, const FloatImage& q_image, int qx, int qy,
           const std::vector<int>& channels, double threshold) {
    for (const int c : channels)
        if (!(sample_difference(p_image.at(px, py, c), q_image.at(qx, qy, c)) <= threshold)) return false;
    return true;
}

// The pixels of every row of one image sorted by each compared channel's value (NaN last),
// so that the pixels of a row that can match a given sample in that channel are one run,
// found by two binary searches. The neighbourhood search then walks, per row of the
// neighbourhood, the shortest of those runs, or the row's 2*PX+1 pixels when that is
// shorter: where colours vary (noise, texture) a run holds a few pixels, where they do not
// (a flat background) the first pixel looked at matches. Brute force costs (2*PX+1)^2
// matches per failing pixel; this, about (2*PX+1) * (C log W + run), the same verdicts.
class RowIndex {
public:
    struct Entry {
        float value;
        std::int32_t x;
    };

    RowIndex(const FloatImage& image, const std::vector<int>& channels)
        : width_(image.width), channels_(channels.size()) {
        entries_.resize(static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height) * channels_);
        tessref::parallel_for(tbb::blocked_range<int>(0, image.height), [&](const tbb::blocked_range<int>& range) {
            for (int y = range.begin(); y < range.end(); ++y)
                for (std::size_t k = 0; k < channels_; ++k) {
                    Entry* row = entries_.data() + offset(k, y);
                    for (int x = 0; x < width_; ++x) row[x] = {image.at(x, y, channels[k]), x};
                    std::sort(row, row + width_, [](const Entry& a, const Entry& b) {
                        const bool a_nan = std::isnan(a.value), b_nan = std::isnan(b.value);
                        if (a_nan != b_nan) return b_nan;
                        return !a_nan && a.value < b.value;
                    });
                }
        });
    }

    // The run of row y's pixels whose channel k matches `sample` (sample_difference <= t).
    std::pair<const Entry*, const Entry*> run(std::size_t k, int y, float sample, double threshold) const {
        const Entry* first = entries_.data() + offset(k, y);
        const Entry* numbers_end = std::partition_point(first, first + width_, [](const Entry& e) { return !std::isnan(e.value); });
        if (std::isnan(sample)) return {numbers_end, first + width_};  // a NaN matches NaN only
        // Along the sorted numbers, |sample - q| in double (sample_difference) falls and then
        // rises: "too small" is a prefix and "too large" a suffix, whatever the infinities.
        const double p = sample;
        const Entry* lo = std::partition_point(first, numbers_end, [&](const Entry& e) {
            return e.value < sample && p - static_cast<double>(e.value) > threshold;
        });
        const Entry* hi = std::partition_point(lo, numbers_end, [&](const Entry& e) {
            return !(e.value > sample && static_cast<double>(e.value) - p > threshold);
        });
        return {lo, hi};
    }

private:
    std::size_t offset(std::size_t k, int y) const {
        return (static_cast<std::size_t>(y) * channels_ + k) * static_cast<std::size_t>(width_);
    }

    int width_;
    std::size_t channels_;
    std::vector<Entry> entries_;  // per row, per channel: width_ entries
};

// Below this neighbourhood width a row is scanned directly: the binary searches would cost
// more than the pixels.
constexpr int kIndexedWidth = 17;

struct Matcher {
    const FloatImage& reference;
    const FloatImage& test;
    const std::vector<int>& channels;
    double threshold;
    int deviation;
    const RowIndex* reference_index = nullptr;  // set when 2*deviation+1 >= kIndexedWidth
    const RowIndex* test_index = nullptr;

    // Some pixel of `q_image` in N(x, y) matches p_image(x, y).
    bool found_near(const FloatImage& p_image, const FloatImage& q_image, const RowIndex* q_index, int x, int y) const {
        const int y0 = std::max(0, y - deviation), y1 = std::min(p_image.height - 1, y + deviation);
        const int x0 = std::max(0, x - deviation), x1 = std::min(p_image.width - 1, x + deviation);
        for (int sy = y0; sy <= y1; ++sy) {
            if (q_index) {
                // The shortest run of this row's pixels that match in one channel; an empty
                // one rules the row out.
                std::size_t shortest = static_cast<std::size_t>(x1 - x0 + 1);
                const RowIndex::Entry *first = nullptr, *last = nullptr;
                bool empty = false;
                for (std::size_t k = 0; k < channels.size() && !empty; ++k) {
                    const auto [lo, hi] = q_index->run(k, sy, p_image.at(x, y, channels[k]), threshold);
                    const auto length = static_cast<std::size_t>(hi - lo);
                    empty = length == 0;
                    if (length < shortest) {
                        shortest = length;
                        first = lo;
                        last = hi;
                    }
                }
                if (empty) continue;
                if (first) {
                    for (const RowIndex::Entry* e = first; e != last; ++e)
                        if (e->x >= x0 && e->x <= x1 && match(p_image, x, y, q_image, e->x, sy, channels, threshold))
                            return true;
                    continue;
                }
            }
            for (int sx = x0; sx <= x1; ++sx)
                if (match(p_image, x, y, q_image, sx, sy, channels, threshold)) return true;
        }
        return false;
    }

    bool passes(int x, int y) const {
        if (match(reference, x, y, test, x, y, channels, threshold)) return true;
        if (deviation == 0) return false;
        return found_near(reference, test, test_index, x, y) && found_near(test, reference, reference_index, x, y);
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
    Matcher matcher{reference, test, result.compared_channels, options.threshold, deviation};
    std::optional<RowIndex> reference_index, test_index;
    if (2 * deviation + 1 >= kIndexedWidth && channel_count > 0) {
        require_memory(saturating_bytes(saturating_bytes(result.pixels, channel_count), 2 * sizeof(RowIndex::Entry)),
                       "the position-deviation search of two " + std::to_string(reference.width) + "x" +
                           std::to_string(reference.height) + " images",
                       Where::at_key("--max-position-deviation"));
        reference_index.emplace(reference, result.compared_channels);
        test_index.emplace(test, result.compared_channels);
        matcher.reference_index = &*reference_index;
        matcher.test_index = &*test_index;
    }

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
