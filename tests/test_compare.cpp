// Tests of tessref/compare.h and `tessref compare`: the CTS threshold / position-deviation
// rule checked both ways, the statistics, the diff picture, the reading of 8-bit, 16-bit
// and float files, and the command's exit statuses and outputs. Every expected value is
// derived by hand in the comment beside it. Images are a few pixels, made here with OIIO.
#include <gtest/gtest.h>

#include "command_dir_test.h"
#include "run_program.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <OpenImageIO/imageio.h>
#include <nlohmann/json.hpp>

#include "tessref/compare.h"
#include "tessref/error.h"
#include "tessref/render.h"

namespace fs = std::filesystem;

namespace {

using tessref::CompareOptions;
using tessref::CompareResult;
using tessref::FloatImage;
using tessref::test::run_program;
using tessref::test::RunResult;

const fs::path kSource = TESSREF_SOURCE_DIR;

FloatImage filled(int width, int height, int channels, float value) {
    FloatImage image;
    image.width = width;
    image.height = height;
    image.channels = channels;
    image.samples.assign(static_cast<std::size_t>(width * height * channels), value);
    return image;
}

void set(FloatImage& image, int x, int y, int c, float v) { image.samples[image.index(x, y, c)] = v; }

// One channel, 8 x 4: 0 left of column `edge`, 1 from it on (a sharp vertical edge).
FloatImage edge_at(int edge) {
    FloatImage image = filled(8, 4, 1, 0.0f);
    for (int y = 0; y < 4; ++y)
        for (int x = edge; x < 8; ++x) set(image, x, y, 0, 1.0f);
    return image;
}

CompareResult compare(const FloatImage& a, const FloatImage& b, int deviation = 0, double threshold = 0.0) {
    CompareOptions options;
    options.max_position_deviation = deviation;
    options.threshold = threshold;
    return tessref::compare_images(a, b, options);
}

// ---- the rule and the statistics --------------------------------------------------------

// THE RULE of compare.h written out as it reads, pixel by pixel over the whole (2*PX+1)^2
// neighbourhood, independently of compare.cpp's search: the reference for the property
// test below.
bool rule_match(const FloatImage& p, int px, int py, const FloatImage& q, int qx, int qy, double t) {
    for (int c = 0; c < p.channels; ++c) {
        const float a = p.at(px, py, c), b = q.at(qx, qy, c);
        double d;
        if (a == b || (std::isnan(a) && std::isnan(b))) d = 0.0;
        else if (std::isnan(a) || std::isnan(b)) d = std::numeric_limits<double>::infinity();
        else d = std::abs(static_cast<double>(a) - static_cast<double>(b));
        if (!(d <= t)) return false;
    }
    return true;
}
std::vector<std::uint8_t> rule_failing(const FloatImage& ref, const FloatImage& test, int n, double t) {
    std::vector<std::uint8_t> failing(static_cast<std::size_t>(ref.width * ref.height), 0);
    const auto near = [&](const FloatImage& p, const FloatImage& q, int x, int y) {
        for (int sy = std::max(0, y - n); sy <= std::min(ref.height - 1, y + n); ++sy)
            for (int sx = std::max(0, x - n); sx <= std::min(ref.width - 1, x + n); ++sx)
                if (rule_match(p, x, y, q, sx, sy, t)) return true;
        return false;
    };
    for (int y = 0; y < ref.height; ++y)
        for (int x = 0; x < ref.width; ++x) {
            const bool pass = rule_match(ref, x, y, test, x, y, t) || (n > 0 && near(ref, test, x, y) && near(test, ref, x, y));
            failing[static_cast<std::size_t>(y * ref.width + x)] = pass ? 0 : 1;
        }
    return failing;
}

// compare_images gives THE RULE's verdict for every pixel (a property that any faster search
// must keep): random images of few levels (so that matches near and far both happen), NaN
// and infinities among them, every deviation up to the bound, thresholds 0, between the
// levels, on them and infinite.
TEST(CompareImages, TheNeighbourhoodSearchGivesTheBruteForceVerdicts) {
    std::uint32_t state = 12345;
    const auto next = [&] { return state = state * 1664525u + 1013904223u; };
    const float specials[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                              -std::numeric_limits<float>::infinity(), -0.0f};
    int cases = 0;
    for (int round = 0; round < 60; ++round) {
        const int width = 1 + static_cast<int>(next() % 37), height = 1 + static_cast<int>(next() % 29);
        const int channels = 1 + static_cast<int>(next() % 4);
        const int levels = 2 + static_cast<int>(next() % 6);
        FloatImage a = filled(width, height, channels, 0.0f), b = a;
        for (FloatImage* image : {&a, &b})
            for (float& v : image->samples)
                v = next() % 50 == 0 ? specials[next() % 4] : static_cast<float>(next() % levels) / static_cast<float>(levels);
        // b is mostly a moved by a few pixels, so that the search finds matches at a distance.
        const int dx = static_cast<int>(next() % 7) - 3, dy = static_cast<int>(next() % 7) - 3;
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x)
                if (next() % 4 != 0 && x + dx >= 0 && x + dx < width && y + dy >= 0 && y + dy < height)
                    for (int c = 0; c < channels; ++c) b.samples[b.index(x, y, c)] = a.at(x + dx, y + dy, c);
        const double thresholds[] = {0.0, 0.5 / levels, 1.0 / levels, std::numeric_limits<double>::infinity()};
        const int deviation = static_cast<int>(next() % (tessref::kMaxPositionDeviation + 1));
        const double t = thresholds[next() % 4];
        const CompareResult r = compare(a, b, deviation, t);
        ASSERT_EQ(r.failing, rule_failing(a, b, deviation, t))
            << "round " << round << ": " << width << "x" << height << "x" << channels << ", PX " << deviation << ", T " << t;
        ++cases;
    }
    EXPECT_EQ(cases, 60);
}

// The deviation is bounded (compare.h kMaxPositionDeviation, 16): 2^31 - 1 was accepted and
// the search costs O(pixels * PX^2).
TEST(CompareImages, APositionDeviationAboveTheBoundIsRefused) {
    const FloatImage a = filled(4, 4, 1, 0.0f);
    EXPECT_NO_THROW(compare(a, a, tessref::kMaxPositionDeviation));
    EXPECT_THROW(compare(a, a, tessref::kMaxPositionDeviation + 1), tessref::Error);
    EXPECT_THROW(compare(a, a, std::numeric_limits<int>::max()), tessref::Error);
}

TEST(CompareImages, IdenticalImagesPassWithZeroErrorAndInfinitePsnr) {
    FloatImage a = filled(5, 3, 4, 0.0f);
    for (std::size_t i = 0; i < a.samples.size(); ++i) a.samples[i] = static_cast<float>(i % 7) / 7.0f;
    const CompareResult r = compare(a, a);
    EXPECT_TRUE(r.passed);
    EXPECT_EQ(r.failing_pixels, 0u);
    EXPECT_EQ(r.pixels, 15u);
    EXPECT_EQ(r.rmse, 0.0);
    EXPECT_EQ(r.max_error, 0.0);
    EXPECT_TRUE(std::isinf(r.psnr) && r.psnr > 0);
    EXPECT_EQ(r.compared_channels, (std::vector<int>{0, 1, 2, 3}));
}

TEST(CompareImages, OnePixelOffByHalfInOneChannel) {
    // 4 x 4 RGB of 0.25; TEST's pixel (1, 2) has G = 0.75. One squared error of 0.25 over
    // 16 * 3 = 48 samples: MSE = 0.25 / 48 = 1/192, RMSE = sqrt(1/192) = 0.0721687836...,
    // PSNR = 10 log10(192) = 22.8330122... dB; max error 0.5, in G only.
    const FloatImage ref = filled(4, 4, 3, 0.25f);
    FloatImage test = ref;
    set(test, 1, 2, 1, 0.75f);
    const CompareResult r = compare(ref, test);
    EXPECT_FALSE(r.passed);
    EXPECT_EQ(r.failing_pixels, 1u);
    EXPECT_EQ(r.failing[2 * 4 + 1], 1);
    EXPECT_NEAR(r.rmse, std::sqrt(1.0 / 192.0), 1e-15);
    EXPECT_NEAR(r.rmse, 0.07216878364870322, 1e-15);
    EXPECT_NEAR(r.psnr, 10.0 * std::log10(192.0), 1e-12);
    EXPECT_NEAR(r.psnr, 22.83301228, 1e-7);
    EXPECT_EQ(r.max_error, 0.5);
    EXPECT_EQ(r.channel_max_error, (std::vector<double>{0.0, 0.5, 0.0}));
}

TEST(CompareImages, DifferenceExactlyAtTheThresholdPasses) {
    // 0.75 - 0.25 = 0.5 exactly in binary: T = 0.5 accepts it (<=), the next double below
    // does not. The statistics do not depend on T.
    const FloatImage ref = filled(4, 4, 3, 0.25f);
    FloatImage test = ref;
    set(test, 1, 2, 1, 0.75f);
    EXPECT_TRUE(compare(ref, test, 0, 0.5).passed);
    const CompareResult below = compare(ref, test, 0, std::nextafter(0.5, 0.0));
    EXPECT_FALSE(below.passed);
    EXPECT_EQ(below.failing_pixels, 1u);
    EXPECT_NEAR(below.rmse, std::sqrt(1.0 / 192.0), 1e-15);
}

TEST(CompareImages, EdgeShiftedByOnePixelFailsAtDeviationZeroAndPassesAtOne) {
    // REF's edge at column 4, TEST's at 5: column 4 differs (REF 1, TEST 0) on all 4 rows.
    // PX = 1: REF(4, y) = 1 finds TEST(5, y) = 1; TEST(4, y) = 0 finds REF(3, y) = 0.
    const FloatImage ref = edge_at(4), test = edge_at(5);
    const CompareResult strict = compare(ref, test, 0);
    EXPECT_EQ(strict.failing_pixels, 4u);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 8; ++x) EXPECT_EQ(strict.failing[static_cast<std::size_t>(y * 8 + x)], x == 4 ? 1 : 0);
    const CompareResult loose = compare(ref, test, 1);
    EXPECT_TRUE(loose.passed);
    EXPECT_EQ(loose.failing_pixels, 0u);
    // The statistics stay those of the same-position differences: 4 of 32 samples off by 1.
    EXPECT_DOUBLE_EQ(loose.rmse, std::sqrt(4.0 / 32.0));
    // Two columns away is beyond PX = 1.
    EXPECT_EQ(compare(ref, edge_at(6), 1).failing_pixels, 8u);
    EXPECT_EQ(compare(ref, edge_at(6), 2).failing_pixels, 0u);
}

TEST(CompareImages, ThinLineMissingInTestFailsBothWays) {
    // REF: 7 x 7 black with a white vertical line at column 3; TEST: all black. With PX = 1
    // every TEST pixel (black) finds black in REF's neighbourhood (columns 2 or 4), so a
    // one-way check would pass; REF's line pixels find no white in TEST: 7 failures.
    FloatImage ref = filled(7, 7, 1, 0.0f);
    for (int y = 0; y < 7; ++y) set(ref, 3, y, 0, 1.0f);
    const FloatImage test = filled(7, 7, 1, 0.0f);
    for (int y = 0; y < 7; ++y)
        for (int x = 0; x < 7; ++x) {
            bool found = false;
            for (int sy = std::max(0, y - 1); sy <= std::min(6, y + 1); ++sy)
                for (int sx = std::max(0, x - 1); sx <= std::min(6, x + 1); ++sx)
                    found = found || ref.at(sx, sy, 0) == test.at(x, y, 0);
            ASSERT_TRUE(found) << "the premise: TEST(" << x << ", " << y << ") matches in REF";
        }
    const CompareResult r = compare(ref, test, 1);
    EXPECT_FALSE(r.passed);
    EXPECT_EQ(r.failing_pixels, 7u);
    for (int y = 0; y < 7; ++y) EXPECT_EQ(r.failing[static_cast<std::size_t>(y * 7 + 3)], 1);
    // And the other way round: a line in TEST that REF lacks.
    EXPECT_EQ(compare(test, ref, 1).failing_pixels, 7u);
}

TEST(CompareImages, AMatchNeedsEveryChannelOfOneNeighbour) {
    // REF pixel (1, 0) = (1, 1); TEST has (1, 0) at x = 0 and (0, 1) at x = 2 and (0, 0) at
    // x = 1: each channel has a match nearby, but no single neighbour matches both.
    FloatImage ref = filled(3, 1, 2, 0.0f), test = filled(3, 1, 2, 0.0f);
    set(ref, 0, 0, 0, 1.0f);
    set(ref, 1, 0, 0, 1.0f);
    set(ref, 1, 0, 1, 1.0f);
    set(ref, 2, 0, 1, 1.0f);
    set(test, 0, 0, 0, 1.0f);
    set(test, 2, 0, 1, 1.0f);
    const CompareResult r = compare(ref, test, 1);
    EXPECT_EQ(r.failing_pixels, 1u);
    EXPECT_EQ(r.failing[1], 1);
}

TEST(CompareImages, NanMatchesNanOnlyAndMakesTheStatisticsInfinite) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    FloatImage a = filled(2, 1, 1, nan), b = filled(2, 1, 1, nan);
    EXPECT_TRUE(compare(a, b).passed);
    EXPECT_EQ(compare(a, b).rmse, 0.0);
    set(b, 1, 0, 0, 0.0f);
    const CompareResult r = compare(a, b, 0, 1e30);
    EXPECT_EQ(r.failing_pixels, 1u);
    EXPECT_TRUE(std::isinf(r.rmse));
    EXPECT_TRUE(std::isinf(r.psnr) && r.psnr < 0);
}

TEST(CompareImages, IgnoreAlphaLeavesOutTheAlphaChannel) {
    FloatImage ref = filled(2, 2, 4, 1.0f);
    ref.alpha_channel = 3;
    FloatImage test = ref;
    set(test, 0, 0, 3, 0.0f);
    EXPECT_EQ(compare(ref, test).failing_pixels, 1u);
    CompareOptions options;
    options.ignore_alpha = true;
    const CompareResult r = tessref::compare_images(ref, test, options);
    EXPECT_TRUE(r.passed);
    EXPECT_EQ(r.compared_channels, (std::vector<int>{0, 1, 2}));
}

TEST(CompareImages, MaxFailingPixels) {
    CompareOptions options;  // the edge shift at PX = 0: 4 failing pixels
    options.max_failing_pixels = 4;
    EXPECT_TRUE(tessref::compare_images(edge_at(4), edge_at(5), options).passed);
    options.max_failing_pixels = 3;
    EXPECT_FALSE(tessref::compare_images(edge_at(4), edge_at(5), options).passed);
}

TEST(CompareImages, SizeOrChannelMismatchAndBadOptionsAreErrors) {
    EXPECT_THROW(compare(filled(2, 2, 3, 0.0f), filled(2, 3, 3, 0.0f)), tessref::Error);
    EXPECT_THROW(compare(filled(2, 2, 3, 0.0f), filled(2, 2, 4, 0.0f)), tessref::Error);
    EXPECT_THROW(compare(filled(2, 2, 3, 0.0f), filled(2, 2, 3, 0.0f), -1), tessref::Error);
    EXPECT_THROW(compare(filled(2, 2, 3, 0.0f), filled(2, 2, 3, 0.0f), 0, std::nan("")), tessref::Error);
}

TEST(CompareImages, DiffPictureMarksFailingPixelsOverADimmedReference) {
    // REF (0.8, 0.4, 1.0, 0.5) everywhere but (2, 1) = (2, -1, 0.6): dimmed to a quarter of
    // the colour clamped to [0, 1]: (0.2, 0.1, 0.25) and (0.25, 0, 0.15); alpha not drawn.
    FloatImage ref = filled(3, 2, 4, 0.0f);
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 3; ++x) {
            set(ref, x, y, 0, 0.8f);
            set(ref, x, y, 1, 0.4f);
            set(ref, x, y, 2, 1.0f);
            set(ref, x, y, 3, 0.5f);
        }
    set(ref, 2, 1, 0, 2.0f);
    set(ref, 2, 1, 1, -1.0f);
    set(ref, 2, 1, 2, 0.6f);
    FloatImage test = ref;
    set(test, 0, 1, 2, 0.0f);  // (0, 1) fails
    const CompareResult r = compare(ref, test);
    ASSERT_EQ(r.failing_pixels, 1u);
    // One failing pixel is both ends of the scale: red.
    const FloatImage diff = tessref::difference_picture(ref, test, r).image;
    ASSERT_EQ(diff.channels, 3);
    EXPECT_EQ(diff.at(0, 1, 0), 1.0f);
    EXPECT_EQ(diff.at(0, 1, 1), 0.0f);
    EXPECT_EQ(diff.at(0, 1, 2), 0.0f);
    EXPECT_FLOAT_EQ(diff.at(0, 0, 0), 0.2f);
    EXPECT_FLOAT_EQ(diff.at(0, 0, 1), 0.1f);
    EXPECT_FLOAT_EQ(diff.at(0, 0, 2), 0.25f);
    EXPECT_FLOAT_EQ(diff.at(2, 1, 0), 0.25f);
    EXPECT_FLOAT_EQ(diff.at(2, 1, 1), 0.0f);
    EXPECT_FLOAT_EQ(diff.at(2, 1, 2), 0.15f);
    // A grey reference (one channel) is dimmed into all three.
    FloatImage grey = filled(1, 1, 1, 0.8f);
    const FloatImage grey_diff = tessref::difference_picture(grey, grey, compare(grey, grey)).image;
    EXPECT_FLOAT_EQ(grey_diff.at(0, 0, 0), 0.2f);
    EXPECT_FLOAT_EQ(grey_diff.at(0, 0, 2), 0.2f);
}

// A half-texel bug fails most of a frame, a precision bug four pixels of 256 000: the diff
// shows how much each failing pixel differs (the scale of compare.h, from blue, the
// smallest difference, to red, the largest) and rings isolated failures so that they are
// seen at 640x400; a band below the picture holds the scale.
TEST(CompareImages, DiffPictureShowsMagnitudeAndRingsIsolatedFailures) {
    const int w = 640, h = 400;
    FloatImage ref = filled(w, h, 3, 0.5f);
    FloatImage test = ref;
    struct Spot {
        int x, y;
        float value;  // the test's red there: a difference of |value - 0.5|
    };
    const std::vector<Spot> isolated{{100, 50, 0.6f}, {300, 200, 0.8f}, {500, 350, 1.0f}, {20, 390, 0.7f}};
    for (const Spot& s : isolated) set(test, s.x, s.y, 0, s.value);
    for (int y = 200; y < 205; ++y)  // a 5 x 5 block differing by 0.4: not isolated
        for (int x = 400; x < 405; ++x) set(test, x, y, 1, 0.9f);
    const CompareResult r = compare(ref, test);
    ASSERT_EQ(r.failing_pixels, 4u + 25u);
    const tessref::DiffPicture d = tessref::difference_picture(ref, test, r);
    EXPECT_EQ(d.isolated, 4u);
    EXPECT_NEAR(d.smallest, 0.1, 1e-6);
    EXPECT_NEAR(d.largest, 0.5, 1e-6);
    ASSERT_TRUE(d.legend);
    const FloatImage& p = d.image;
    ASSERT_EQ(p.width, w);
    ASSERT_EQ(p.height, h + tessref::kDiffLegendHeight);
    const auto expect_colour = [&](int x, int y, std::array<float, 3> c, const char* what) {
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(p.at(x, y, k), c[static_cast<std::size_t>(k)], 1e-5) << what << " " << k;
    };
    expect_colour(100, 50, {0.0f, 0.4f, 1.0f}, "the smallest difference: blue");
    expect_colour(500, 350, {1.0f, 0.0f, 0.0f}, "the largest: red");
    // 0.3 is half way up the scale: half way from green (0, 0.85, 0.2) to yellow (1, 0.9, 0).
    expect_colour(300, 200, {0.5f, 0.875f, 0.1f}, "half way");
    // 0.4: three quarters up, a quarter of the way from yellow to red.
    expect_colour(402, 202, {1.0f, 0.675f, 0.0f}, "the block");
    // Each isolated failure is ringed kDiffRing pixels out, in magenta; inside the ring the
    // reference dimmed to a quarter stays.
    for (const Spot& s : isolated) {
        expect_colour(s.x + tessref::kDiffRing, s.y, {1.0f, 0.0f, 1.0f}, "ring, right");
        expect_colour(s.x, s.y - tessref::kDiffRing, {1.0f, 0.0f, 1.0f}, "ring, top");
        expect_colour(s.x + 2, s.y, {0.125f, 0.125f, 0.125f}, "inside the ring");
    }
    // The block is not ringed.
    expect_colour(402 + tessref::kDiffRing, 202, {0.125f, 0.125f, 0.125f}, "no ring around the block");
    // The scale in the band: blue at its left end, red at its right.
    bool blue = false, red = false;
    for (int x = 0; x < w; ++x) {
        blue |= p.at(x, h + 12, 0) == 0.0f && std::abs(p.at(x, h + 12, 1) - 0.4f) < 1e-6f && p.at(x, h + 12, 2) == 1.0f;
        red |= p.at(x, h + 12, 0) == 1.0f && p.at(x, h + 12, 1) == 0.0f && p.at(x, h + 12, 2) == 0.0f;
    }
    EXPECT_TRUE(blue);
    EXPECT_TRUE(red);
    // A picture too narrow for the band keeps the pictures' size.
    const FloatImage small = filled(3, 2, 3, 0.0f);
    EXPECT_FALSE(tessref::difference_picture(small, small, compare(small, small)).legend);
}

// Where to look: the worst pixel and the first failing pixels, with both pictures' values.
TEST(CompareImages, WorstAndFirstFailingPixelsCarryBothValues) {
    FloatImage ref = filled(4, 3, 2, 0.25f);
    FloatImage test = ref;
    set(test, 3, 0, 1, 0.5f);   // 0.25 off in channel 1
    set(test, 1, 2, 0, 0.75f);  // 0.5 off in channel 0: the worst
    const CompareResult r = compare(ref, test);
    const tessref::PixelDifference worst = tessref::worst_pixel(ref, test, r);
    EXPECT_EQ(worst.x, 1);
    EXPECT_EQ(worst.y, 2);
    EXPECT_EQ(worst.channel, 0);
    EXPECT_DOUBLE_EQ(worst.difference, 0.5);
    EXPECT_EQ(worst.reference, (std::vector<float>{0.25f, 0.25f}));
    EXPECT_EQ(worst.test, (std::vector<float>{0.75f, 0.25f}));
    const auto first = tessref::first_failing_pixels(ref, test, r, 10);
    ASSERT_EQ(first.size(), 2u);
    EXPECT_EQ(first[0].x, 3);  // row order: (3, 0) before (1, 2)
    EXPECT_EQ(first[0].y, 0);
    EXPECT_EQ(first[0].channel, 1);
    EXPECT_EQ(tessref::first_failing_pixels(ref, test, r, 1).size(), 1u);
}

TEST(CompareImages, RenderCompareImagesIsTheSameComparisonOverClampedRgb) {
    // Pixel 0: (2, 0, 0) vs (1, 0, 0): equal once clamped. Pixel 1: R 0 vs 0.5, alpha 1 vs
    // 0.3 (alpha not counted): one squared error 0.25 over 2 * 3 samples, RMSE sqrt(1/24).
    tessref::RenderResult a, b;
    a.width = b.width = 2;
    a.height = b.height = 1;
    a.colour = {{2.0f, 0.0f, 0.0f, 1.0f}, {0.0f, 0.0f, 0.0f, 1.0f}};
    b.colour = {{1.0f, 0.0f, 0.0f, 1.0f}, {0.5f, 0.0f, 0.0f, 0.3f}};
    a.triangle_id = {0, tessref::kNoPixelId};
    b.triangle_id = {0, 5};
    const tessref::ImageDifference d = tessref::compare_images(a, b);
    EXPECT_EQ(d.pixels, 2u);
    EXPECT_NEAR(d.rmse, std::sqrt(1.0 / 24.0), 1e-15);
    EXPECT_EQ(d.max_abs, 0.5);
    EXPECT_EQ(d.coverage_mismatch, 1u);
    b.width = 1;
    b.height = 2;
    EXPECT_THROW(tessref::compare_images(a, b), tessref::Error);
}

// ---- files ------------------------------------------------------------------------------

void write_image(const fs::path& path, int width, int height, int channels, OIIO::TypeDesc type, const void* data) {
    auto out = OIIO::ImageOutput::create(path.string());
    ASSERT_TRUE(out) << path;
    OIIO::ImageSpec spec(width, height, channels, type);
    if (channels == 4) spec.alpha_channel = 3;
    ASSERT_TRUE(out->open(path.string(), spec)) << out->geterror();
    ASSERT_TRUE(out->write_image(type, data)) << out->geterror();
    ASSERT_TRUE(out->close());
}

void write_png8(const fs::path& path, int width, int height, int channels, const std::vector<std::uint8_t>& codes) {
    ASSERT_EQ(codes.size(), static_cast<std::size_t>(width * height * channels));
    write_image(path, width, height, channels, OIIO::TypeDesc::UINT8, codes.data());
}

void write_exr(const fs::path& path, const FloatImage& image) {
    write_image(path, image.width, image.height, image.channels, OIIO::TypeDesc::FLOAT, image.samples.data());
}

// A fresh, empty directory per test, removed afterwards (tests/command_dir_test.h).
using CompareFiles = tessref::test::CommandDirTest;

TEST_F(CompareFiles, EightBitSamplesAreCodeOver255AsStoredWithAlpha) {
    // Alpha 0 must not premultiply the colour away: the stored codes, code/255.
    write_png8(path("a.png"), 2, 1, 4, {200, 51, 255, 0, 0, 1, 2, 255});
    const FloatImage image = tessref::read_float_image(path("a.png"));
    ASSERT_EQ(image.width, 2);
    ASSERT_EQ(image.channels, 4);
    EXPECT_EQ(image.alpha_channel, 3);
    EXPECT_EQ(image.at(0, 0, 0), static_cast<float>(200.0 / 255.0));
    EXPECT_EQ(image.at(0, 0, 1), static_cast<float>(51.0 / 255.0));
    EXPECT_EQ(image.at(0, 0, 2), 1.0f);
    EXPECT_EQ(image.at(0, 0, 3), 0.0f);
    EXPECT_EQ(image.at(1, 0, 2), static_cast<float>(2.0 / 255.0));
    const std::vector<std::uint16_t> codes = {0, 32768, 65535};
    write_image(path("b.png"), 3, 1, 1, OIIO::TypeDesc::UINT16, codes.data());
    const FloatImage wide = tessref::read_float_image(path("b.png"));
    EXPECT_EQ(wide.at(1, 0, 0), static_cast<float>(32768.0 / 65535.0));
    EXPECT_EQ(wide.at(2, 0, 0), 1.0f);
}

TEST_F(CompareFiles, PngAndTiffOfTheSameCodesPass) {
    const std::vector<std::uint8_t> codes = {10, 20, 30, 40, 50, 60, 70, 80, 90, 100, 110, 120};
    write_png8(path("a.png"), 2, 2, 3, codes);
    write_png8(path("a.tif"), 2, 2, 3, codes);
    const RunResult r = run({"compare", path("a.png"), path("a.tif")});
    EXPECT_EQ(r.status, 0) << r.out << r.err;
}

TEST_F(CompareFiles, IdenticalPrintsInfInTextAndNullInJson) {
    const FloatImage image = edge_at(4);
    write_exr(path("a.exr"), image);
    const RunResult text = run({"compare", path("a.exr"), path("a.exr")});
    EXPECT_EQ(text.status, 0) << text.err;
    EXPECT_NE(text.out.find("failing    0 of 32 pixels (allowed 0)\n"), std::string::npos) << text.out;
    EXPECT_NE(text.out.find("rmse       0\n"), std::string::npos) << text.out;
    EXPECT_NE(text.out.find("psnr       inf dB\n"), std::string::npos) << text.out;
    EXPECT_NE(text.out.find("PASS\n"), std::string::npos) << text.out;
    const RunResult json = run({"compare", path("a.exr"), path("a.exr"), "--json"});
    EXPECT_EQ(json.status, 0) << json.err;
    const nlohmann::json report = nlohmann::json::parse(json.out);
    EXPECT_TRUE(report["psnr"].is_null());
    EXPECT_EQ(report["rmse"], 0.0);
    EXPECT_EQ(report["failing_pixels"], 0);
    EXPECT_EQ(report["passed"], true);
}

TEST_F(CompareFiles, CommandStatisticsAndThresholdBoundary) {
    // The one-pixel, one-channel 0.5 difference of OnePixelOffByHalfInOneChannel, as EXR.
    const FloatImage ref = filled(4, 4, 3, 0.25f);
    FloatImage test = ref;
    set(test, 1, 2, 1, 0.75f);
    write_exr(path("ref.exr"), ref);
    write_exr(path("test.exr"), test);
    const RunResult fail = run({"compare", path("ref.exr"), path("test.exr"), "--json"});
    EXPECT_EQ(fail.status, 1) << fail.err;
    const nlohmann::json report = nlohmann::json::parse(fail.out);
    EXPECT_EQ(report["failing_pixels"], 1);
    EXPECT_NEAR(report["rmse"].get<double>(), std::sqrt(1.0 / 192.0), 1e-15);
    EXPECT_NEAR(report["psnr"].get<double>(), 10.0 * std::log10(192.0), 1e-12);
    EXPECT_EQ(report["max_error"], 0.5);
    EXPECT_EQ(report["channel_max_error"], nlohmann::json({0.0, 0.5, 0.0}));
    EXPECT_EQ(report["passed"], false);
    EXPECT_NE(run({"compare", path("ref.exr"), path("test.exr")}).out.find("FAIL\n"), std::string::npos);
    EXPECT_EQ(run({"compare", path("ref.exr"), path("test.exr"), "--threshold", "0.5"}).status, 0);
    EXPECT_EQ(run({"compare", path("ref.exr"), path("test.exr"), "--threshold", "0.49999"}).status, 1);
    EXPECT_EQ(run({"compare", path("ref.exr"), path("test.exr"), "--max-failing-pixels", "1"}).status, 0);
}

TEST_F(CompareFiles, CommandEdgeShiftAndMaxFailingPixels) {
    write_exr(path("ref.exr"), edge_at(4));
    write_exr(path("test.exr"), edge_at(5));
    EXPECT_EQ(run({"compare", path("ref.exr"), path("test.exr")}).status, 1);
    EXPECT_EQ(run({"compare", path("ref.exr"), path("test.exr"), "--max-position-deviation", "1"}).status, 0);
    EXPECT_EQ(run({"compare", path("ref.exr"), path("test.exr"), "--max-failing-pixels", "4"}).status, 0);
    EXPECT_EQ(run({"compare", path("ref.exr"), path("test.exr"), "--max-failing-pixels", "3"}).status, 1);
}

TEST_F(CompareFiles, CommandDiffPicturePixels) {
    // REF 3 x 2 RGB codes (255, 204, 0) = (1, 0.8, 0); TEST differs at (1, 0) by 9 codes in
    // blue and at (2, 1) by 255 codes in red. Dimmed: (0.25, 0.2, 0) -> round(63.75, 51, 0)
    // = (64, 51, 0); failing: the smallest difference blue (0, 0.4, 1) -> (0, 102, 255), the
    // largest red (255, 0, 0).
    std::vector<std::uint8_t> ref(3 * 2 * 3), test;
    for (std::size_t i = 0; i < ref.size(); i += 3) {
        ref[i] = 255;
        ref[i + 1] = 204;
        ref[i + 2] = 0;
    }
    test = ref;
    test[(0 * 3 + 1) * 3 + 2] = 9;
    test[(1 * 3 + 2) * 3 + 0] = 0;
    write_png8(path("ref.png"), 3, 2, 3, ref);
    write_png8(path("test.png"), 3, 2, 3, test);
    const RunResult r = run({"compare", path("ref.png"), path("test.png"), "--diff", path("diff.png")});
    EXPECT_EQ(r.status, 1) << r.err;
    const FloatImage diff = tessref::read_float_image(path("diff.png"));
    ASSERT_EQ(diff.width, 3);
    ASSERT_EQ(diff.height, 2);
    ASSERT_EQ(diff.channels, 3);
    const auto code = [&](int x, int y, int c) { return std::lround(diff.at(x, y, c) * 255.0f); };
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 3; ++x) {
            const bool small = x == 1 && y == 0, large = x == 2 && y == 1;
            EXPECT_EQ(code(x, y, 0), small ? 0 : large ? 255 : 64) << x << ", " << y;
            EXPECT_EQ(code(x, y, 1), small ? 102 : large ? 0 : 51) << x << ", " << y;
            EXPECT_EQ(code(x, y, 2), small ? 255 : 0) << x << ", " << y;
        }
    // The report names the worst pixel and lists the failing ones with both values.
    EXPECT_NE(r.out.find("worst      (2, 1)  reference (1, 0.8, 0), test (0, 0.8, 0), difference 1 in R\n"),
              std::string::npos) << r.out;
    EXPECT_NE(r.out.find("failing pixels (x, y), the first 2 of 2 in row order:\n"
                         "  (1, 0)  reference (1, 0.8, 0), test (1, 0.8, 0.0352941), difference 0.0352941 in B\n"
                         "  (2, 1)  reference (1, 0.8, 0), test (0, 0.8, 0), difference 1 in R\n"),
              std::string::npos) << r.out;
    EXPECT_NE(r.out.find("blue 0.0352941 to red 1"), std::string::npos) << r.out;
    const RunResult one = run({"compare", path("ref.png"), path("test.png"), "--list", "1"});
    EXPECT_NE(one.out.find("the first 1 of 2 in row order:\n  (1, 0) "), std::string::npos) << one.out;
    EXPECT_EQ(one.out.find("\n  (2, 1) "), std::string::npos) << one.out;
    // A passing comparison writes its diff too (all dimmed) and exits 0.
    const RunResult pass = run({"compare", path("ref.png"), path("ref.png"), "--diff", path("same.png")});
    EXPECT_EQ(pass.status, 0) << pass.err;
    EXPECT_EQ(std::lround(tessref::read_float_image(path("same.png")).at(1, 0, 0) * 255.0f), 64);
}

TEST_F(CompareFiles, MismatchedSizesOrChannelsExit2AndWriteNothing) {
    write_png8(path("a.png"), 2, 2, 3, std::vector<std::uint8_t>(12, 7));
    write_png8(path("b.png"), 2, 3, 3, std::vector<std::uint8_t>(18, 7));
    write_png8(path("c.png"), 2, 2, 4, std::vector<std::uint8_t>(16, 7));
    const auto before = files();
    const RunResult size = run({"compare", path("a.png"), path("b.png"), "--diff", path("diff.png")});
    EXPECT_EQ(size.status, 2);
    EXPECT_NE(size.err.find("differ in size"), std::string::npos) << size.err;
    EXPECT_NE(size.err.find("2x2"), std::string::npos) << size.err;
    EXPECT_NE(size.err.find("2x3"), std::string::npos) << size.err;
    EXPECT_TRUE(size.out.empty()) << size.out;
    const RunResult channels = run({"compare", path("a.png"), path("c.png"), "--diff", path("diff.png")});
    EXPECT_EQ(channels.status, 2);
    EXPECT_NE(channels.err.find("channel count"), std::string::npos) << channels.err;
    EXPECT_EQ(files(), before);
}

TEST_F(CompareFiles, UnreadableOrMissingFilesExit2NamingTheFile) {
    write_png8(path("a.png"), 2, 2, 3, std::vector<std::uint8_t>(12, 7));
    const std::string not_image = (kSource / "tests/data/compare/not-an-image.png").string();
    const auto before = files();
    for (const std::vector<std::string>& pair : {std::vector<std::string>{path("missing.png"), path("a.png")},
                                                 std::vector<std::string>{path("a.png"), path("missing.png")},
                                                 std::vector<std::string>{not_image, path("a.png")},
                                                 std::vector<std::string>{path("a.png"), not_image},
                                                 std::vector<std::string>{path("a.png"), dir_.string()}}) {
        const std::string bad = pair[0] == path("a.png") ? pair[1] : pair[0];
        const RunResult r = run({"compare", pair[0], pair[1], "--diff", path("diff.png")});
        EXPECT_EQ(r.status, 2) << bad;
        EXPECT_NE(r.err.find("tessref: error: "), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("(" + bad + ")"), std::string::npos) << r.err;
        EXPECT_TRUE(r.out.empty()) << r.out;
    }
    // A PNG cut short: its header reads, its pixels do not.
    const std::string whole = tessref::test::read_file(path("a.png"));
    tessref::test::write_file(path("cut.png"), whole.substr(0, whole.size() / 2));
    const RunResult cut = run({"compare", path("a.png"), path("cut.png"), "--diff", path("diff.png")});
    EXPECT_EQ(cut.status, 2);
    EXPECT_NE(cut.err.find("(" + path("cut.png") + ")"), std::string::npos) << cut.err;
    fs::remove(path("cut.png"));
    EXPECT_EQ(files(), before);
}

TEST_F(CompareFiles, BadFlagsExit2BeforeReading) {
    // The images do not exist: the flag's error comes first, naming the flag.
    for (const std::vector<std::string>& flag :
         {std::vector<std::string>{"--threshold", "-0.1"}, std::vector<std::string>{"--threshold", "nan"},
          std::vector<std::string>{"--threshold", "x"}, std::vector<std::string>{"--max-position-deviation", "-1"},
          std::vector<std::string>{"--max-position-deviation", "1.5"},
          std::vector<std::string>{"--max-position-deviation", "17"},
          std::vector<std::string>{"--max-position-deviation", "2147483647"},
          std::vector<std::string>{"--max-failing-pixels", "-3"}, std::vector<std::string>{"--diff", "diff.nope"}}) {
        const RunResult r = run({"compare", path("none1.png"), path("none2.png"), flag[0], flag[1]});
        EXPECT_EQ(r.status, 2) << flag[0] << " " << flag[1];
        EXPECT_NE(r.err.find("(" + flag[0] + ")"), std::string::npos) << r.err;
    }
}

TEST_F(CompareFiles, DiffNamingAnInputIsRefused) {
    write_png8(path("a.png"), 1, 1, 3, {10, 20, 30});
    write_png8(path("b.png"), 1, 1, 3, {90, 20, 30});
    fs::create_symlink(path("b.png"), path("link.png"));
    const std::string a = tessref::test::read_file(path("a.png")), b = tessref::test::read_file(path("b.png"));
    for (const std::string& diff : {path("a.png"), path("b.png"), path("link.png")}) {
        const RunResult r = run({"compare", path("a.png"), path("b.png"), "--diff", diff});
        EXPECT_EQ(r.status, 2) << diff;
        EXPECT_NE(r.err.find("(--diff)"), std::string::npos) << r.err;
    }
    EXPECT_EQ(tessref::test::read_file(path("a.png")), a);
    EXPECT_EQ(tessref::test::read_file(path("b.png")), b);
}

TEST_F(CompareFiles, IgnoreAlphaFlag) {
    write_png8(path("a.png"), 1, 1, 4, {10, 20, 30, 255});
    write_png8(path("b.png"), 1, 1, 4, {10, 20, 30, 0});
    EXPECT_EQ(run({"compare", path("a.png"), path("b.png")}).status, 1);
    EXPECT_EQ(run({"compare", path("a.png"), path("b.png"), "--ignore-alpha"}).status, 0);
}

// ---- renders of a shipped scene by tessref itself ---------------------------------------

TEST_F(CompareFiles, TwoRendersOfASceneMatchAndWireframeDoesNot) {
    const std::string scene = (kSource / "data/scenes/thesis-constant-1.toml").string();
    for (const auto& [name, extra] : {std::pair<std::string, std::string>{"a.png", ""}, {"b.png", ""},
                                      {"wire.png", "--wireframe"}}) {
        std::vector<std::string> args = {"render", scene, "-o", path(name), "--size", "64x48"};
        if (!extra.empty()) args.push_back(extra);
        const RunResult r = run(args);
        ASSERT_EQ(r.status, 0) << r.err;
    }
    const RunResult same = run({"compare", path("a.png"), path("b.png")});
    EXPECT_EQ(same.status, 0) << same.out << same.err;
    EXPECT_NE(same.out.find("failing    0 of 3072 pixels"), std::string::npos) << same.out;
    const RunResult wire = run({"compare", path("a.png"), path("wire.png"), "--max-position-deviation", "1",
                                "--threshold", "0.05"});
    EXPECT_EQ(wire.status, 1) << wire.out << wire.err;
}

}  // namespace
