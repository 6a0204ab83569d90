// The comparison of tessref/compare.h (THE RULE there).
#include "tessref/compare.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>

#include "common/parallel.h"
#include "image/draw.h"

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

namespace {

PixelDifference pixel_difference(const FloatImage& reference, const FloatImage& test, const CompareResult& result, int x,
                                 int y) {
    PixelDifference p;
    p.x = x;
    p.y = y;
    for (int c = 0; c < reference.channels; ++c) {
        p.reference.push_back(reference.at(x, y, c));
        p.test.push_back(test.at(x, y, c));
    }
    for (const int c : result.compared_channels) {
        const double d = sample_difference(reference.at(x, y, c), test.at(x, y, c));
        if (d > p.difference) {
            p.difference = d;
            p.channel = c;
        }
    }
    return p;
}

void check_compared(const FloatImage& reference, const FloatImage& test, const CompareResult& result) {
    if (reference.width != result.width || reference.height != result.height || test.width != result.width ||
        test.height != result.height || test.channels != reference.channels || reference.channels <= 0)
        throw Error("the pictures are not those the comparison was of", Where::at_key("size"));
}

}  // namespace

PixelDifference worst_pixel(const FloatImage& reference, const FloatImage& test, const CompareResult& result) {
    check_compared(reference, test, result);
    // The differences first, the pixel's samples only for the one found.
    int worst_x = 0, worst_y = 0;
    double worst = 0.0;
    for (int y = 0; y < result.height; ++y)
        for (int x = 0; x < result.width; ++x)
            for (const int c : result.compared_channels)
                if (const double d = sample_difference(reference.at(x, y, c), test.at(x, y, c)); d > worst) {
                    worst = d;
                    worst_x = x;
                    worst_y = y;
                }
    return pixel_difference(reference, test, result, worst_x, worst_y);
}

std::vector<PixelDifference> first_failing_pixels(const FloatImage& reference, const FloatImage& test,
                                                  const CompareResult& result, std::size_t count) {
    check_compared(reference, test, result);
    std::vector<PixelDifference> out;
    for (int y = 0; y < result.height && out.size() < count; ++y)
        for (int x = 0; x < result.width && out.size() < count; ++x)
            if (result.failing[static_cast<std::size_t>(y) * static_cast<std::size_t>(result.width) + static_cast<std::size_t>(x)])
                out.push_back(pixel_difference(reference, test, result, x, y));
    return out;
}

std::array<float, 3> diff_scale_colour(double t) {
    static constexpr std::array<std::array<float, 3>, 4> stops{{{0.0f, 0.4f, 1.0f}, {0.0f, 0.85f, 0.2f},
                                                                 {1.0f, 0.9f, 0.0f}, {1.0f, 0.0f, 0.0f}}};
    if (!(t > 0.0)) return stops[0];
    if (t >= 1.0) return stops[3];
    const double at = t * 3.0;
    const int i = std::min(2, static_cast<int>(at));
    const float f = static_cast<float>(at - i);
    std::array<float, 3> c{};
    for (int k = 0; k < 3; ++k) c[static_cast<std::size_t>(k)] = stops[i][k] + f * (stops[i + 1][k] - stops[i][k]);
    return c;
}

DiffPicture difference_picture(const FloatImage& reference, const FloatImage& test, const CompareResult& result) {
    check_compared(reference, test, result);
    const int w = reference.width, h = reference.height;
    const auto failing = [&](int x, int y) {
        return result.failing[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)] != 0;
    };
    // Each failing pixel's same-position difference, and the scale's ends.
    std::vector<double> difference(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), 0.0);
    DiffPicture out;
    bool any = false;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (!failing(x, y)) continue;
            double d = 0.0;
            for (const int c : result.compared_channels)
                d = std::max(d, sample_difference(reference.at(x, y, c), test.at(x, y, c)));
            difference[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)] = d;
            out.smallest = any ? std::min(out.smallest, d) : d;
            out.largest = any ? std::max(out.largest, d) : d;
            any = true;
        }
    const auto scale_position = [&](double d) {
        if (std::isinf(d)) return 1.0;
        const double span = (std::isinf(out.largest) ? d : out.largest) - out.smallest;
        return span > 0.0 ? (d - out.smallest) / span : 1.0;
    };

    out.legend = w >= kDiffLegendMinWidth;
    FloatImage& picture = out.image;
    picture.width = w;
    picture.height = h + (out.legend ? kDiffLegendHeight : 0);
    picture.channels = 3;
    picture.channel_names = {"R", "G", "B"};
    picture.samples.assign(picture.index(0, picture.height), 0.0f);
    const auto dimmed = [](float v) { return kDiffDim * (std::isnan(v) ? 0.0f : std::clamp(v, 0.0f, 1.0f)); };
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (failing(x, y)) {
                const auto colour = diff_scale_colour(
                    scale_position(difference[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)]));
                for (int c = 0; c < 3; ++c) picture.samples[picture.index(x, y, c)] = colour[static_cast<std::size_t>(c)];
            } else {
                for (int c = 0; c < 3; ++c)
                    picture.samples[picture.index(x, y, c)] = dimmed(reference.at(x, y, reference.channels >= 3 ? c : 0));
            }
        }

    // Isolated failures, ringed: a pixel or two of colour is lost on a large picture.
    image::Drawing drawing;
    const image::Drawing::Colour magenta{1.0f, 0.0f, 1.0f};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (!failing(x, y)) continue;
            int near = 0;
            for (int sy = std::max(0, y - 3); sy <= std::min(h - 1, y + 3); ++sy)
                for (int sx = std::max(0, x - 3); sx <= std::min(w - 1, x + 3); ++sx) near += failing(sx, sy);
            if (near >= kDiffIsolatedBelow) continue;
            if (out.isolated++ >= kDiffMaxRings) continue;
            const int x0 = x - kDiffRing, y0 = y - kDiffRing, x1 = x + kDiffRing, y1 = y + kDiffRing;
            drawing.line(x0, y0, x1, y0, magenta);
            drawing.line(x1, y0, x1, y1, magenta);
            drawing.line(x1, y1, x0, y1, magenta);
            drawing.line(x0, y1, x0, y0, magenta);
        }

    // The legend: the scale as a bar of pixels, its ends as text.
    if (out.legend) {
        const int bar_x0 = 60, bar_x1 = std::min(w - 60, bar_x0 + 256), bar_y0 = h + 6, bar_y1 = h + 18;
        for (int x = bar_x0; x < bar_x1; ++x) {
            const auto colour = diff_scale_colour(static_cast<double>(x - bar_x0) / std::max(1, bar_x1 - 1 - bar_x0));
            for (int y = bar_y0; y < bar_y1; ++y)
                for (int c = 0; c < 3; ++c) picture.samples[picture.index(x, y, c)] = colour[static_cast<std::size_t>(c)];
        }
        const auto label = [](double v) {
            char text[32];
            std::snprintf(text, sizeof text, "%.3g", v);
            return std::string(text);
        };
        const std::string font = std::filesystem::exists("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf")
                                     ? "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf"
                                     : "";
        const image::Drawing::Colour white{1.0f, 1.0f, 1.0f};
        drawing.text(bar_x0 - 4, bar_y1, any ? label(out.smallest) : "-", 11, font, white, image::TextAlign::right);
        drawing.text(bar_x1 + 4, bar_y1, any ? label(out.largest) : "-", 11, font, white, image::TextAlign::left);
    }
    // Without a font the scale and the rings are still drawn; the labels are a bonus (and
    // the report prints the scale's ends).
    if (!drawing.empty())
        drawing.paint({picture.samples.data(), picture.width, picture.height, 3, image::SampleType::float32}, false,
                      "the diff picture");
    return out;
}

}  // namespace tessref
