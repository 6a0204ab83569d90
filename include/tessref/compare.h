// tessref/compare.h — is a picture the same as a reference picture, up to rasterization?
//
// Two renderers that both follow GL's rules still disagree on a few pixels along edges
// (sub-pixel precision, the order of additions in the interpolation) and by a code or two
// in colour (8-bit rounding). This is the comparison the Khronos conformance tests (the
// dEQP/CTS "threshold position deviation" compare) use for rasterized pictures, so that a
// GPU's or llvmpipe's picture can be held against tessref's golden image without hiding a
// missing line or a wrong colour.
//
// ======================================================================================
// THE RULE. REF and TEST have the same width, height and channel count (else an Error).
// Every sample is a float; an 8-bit file's samples are code/255, a 16-bit file's
// code/65535, float and half files as stored; colour is not premultiplied by alpha (the
// file's values as stored, as a GL upload sees them). Every channel counts, alpha included
// (CompareOptions::ignore_alpha leaves out the channel the file names as alpha).
//
//   match(P, Q)  <=>  for EVERY compared channel c:  |P[c] - Q[c]| <= T       (T = threshold)
//
// computed in double from the two float samples, so a difference exactly equal to T
// passes. Two samples that are equal (two NaNs, the same infinity) differ by 0; a NaN
// against a number differs by +inf and never matches. For an 8-bit file, code/255 is
// rounded to float, so a difference of k codes is not exactly k/255: give T with slack,
// e.g. (k + 0.5) / 255 to accept k codes.
//
// N(x, y) is the neighbourhood of (x, y) with position deviation PX: the pixels (sx, sy)
// with |sx - x| <= PX and |sy - y| <= PX that lie inside the image, at most (2*PX+1)^2 of
// them (fewer at the borders: nothing outside the image is compared).
//
// Pixel (x, y) PASSES when
//   match(REF(x, y), TEST(x, y))                                  (same position), or
//   [ some (sx, sy) in N(x, y) has match(REF(x, y), TEST(sx, sy))  and
//     some (sx, sy) in N(x, y) has match(TEST(x, y), REF(sx, sy)) ]      (both ways)
// and FAILS otherwise. "Both ways" is what catches a thin line present in REF and missing
// in TEST: every TEST pixel (background) finds background in REF next to the line, but the
// line's REF pixels find no line in TEST. PX = 0 is a plain per-pixel threshold compare.
// The comparison PASSES when failing_pixels <= max_failing_pixels.
//
// STATISTICS are of the same-position differences, whatever PX is, over every pixel and
// every compared channel: RMSE = sqrt(mean of (REF - TEST)^2); PSNR = 10 log10(1 / MSE) dB
// with peak 1 (the unit of an 8-bit file's code/255), +inf when RMSE is 0; max error = the
// largest |REF - TEST|, also per channel. A NaN against a number makes them +inf (PSNR
// -inf).
// ======================================================================================
//
// Pixel (x, y) means column x from the left, row y from the top (row 0 first, as image
// files store it), as in render.h.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace tessref {

// A picture in float: width * height pixels of `channels` interleaved samples, row 0 on
// top. channel_names and alpha_channel come from the file (alpha_channel -1: none).
struct FloatImage {
    int width = 0;
    int height = 0;
    int channels = 0;
    std::vector<float> samples;
    std::vector<std::string> channel_names;
    int alpha_channel = -1;

    std::size_t index(int x, int y, int c = 0) const {
        return (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)) *
                   static_cast<std::size_t>(channels) +
               static_cast<std::size_t>(c);
    }
    float at(int x, int y, int c) const { return samples[index(x, y, c)]; }
};

// The largest position deviation: a rasterization difference moves an edge by a pixel or
// two (the CTS and tessref golden use 1); a picture shifted by more than this is not the
// same picture. It also bounds the search: a pixel that fails at its own position is
// matched against up to (2*PX+1)^2 pixels each way, 1089 at PX = 16 (1024^2 RGBA noise at
// PX = 16: 2.7 s of CPU).
constexpr int kMaxPositionDeviation = 16;

struct CompareOptions {
    int max_position_deviation = 0;         // 0 <= PX <= kMaxPositionDeviation
    double threshold = 0.0;                 // T >= 0, per channel, in the samples' units
    std::uint64_t max_failing_pixels = 0;
    bool ignore_alpha = false;              // leave out REF's alpha channel (when it has one)
};

struct CompareResult {
    int width = 0;
    int height = 0;
    std::vector<int> compared_channels;     // channel indices that counted
    std::uint64_t pixels = 0;               // width * height
    std::uint64_t failing_pixels = 0;
    bool passed = true;                     // failing_pixels <= max_failing_pixels
    double rmse = 0.0;
    double psnr = 0.0;                      // +inf when rmse == 0
    double max_error = 0.0;
    std::vector<double> channel_max_error;  // one per compared channel, in that order
    std::vector<std::uint8_t> failing;      // width * height, row 0 on top: 1 = fails
};

// Compares TEST against REF by THE RULE above. Throws tessref::Error (key "size" or
// "channels") when the sizes or channel counts differ, and (key "--threshold",
// "--max-position-deviation") for a negative or NaN option or a deviation above
// kMaxPositionDeviation.
CompareResult compare_images(const FloatImage& reference, const FloatImage& test,
                             const CompareOptions& options = {});

// Reads subimage 0, mip level 0 of an image file (PNG, PNM, and through OpenImageIO TIFF,
// EXR and whatever else it reads) into floats as THE RULE says. Throws tessref::Error naming the
// path when the file is missing, unreadable, empty, deep or a volume, or when its pixels
// would exceed the memory limit (limits.h).
FloatImage read_float_image(const std::string& path);

// The bytes read_float_image(path) holds at its peak (the file's codes and the floats), from
// the file's header alone: what a command adds up before it reads anything (limits.h).
// Throws tessref::Error as read_float_image does for a file it cannot read.
std::uint64_t float_image_memory(const std::string& path, int* width = nullptr, int* height = nullptr);

// One pixel of a comparison with both pictures' samples there: where to look first.
struct PixelDifference {
    int x = 0;
    int y = 0;
    std::vector<float> reference;  // every channel, in the file's order
    std::vector<float> test;
    double difference = 0.0;  // the largest same-position |REF - TEST| over the compared channels
    int channel = 0;          // the channel of that difference
};

// The pixel with the largest same-position difference, the first in row order among equal
// ones (pixel (0, 0), difference 0, when the pictures are equal).
PixelDifference worst_pixel(const FloatImage& reference, const FloatImage& test, const CompareResult& result);
// The first `count` failing pixels, in row order.
std::vector<PixelDifference> first_failing_pixels(const FloatImage& reference, const FloatImage& test,
                                                  const CompareResult& result, std::size_t count);

// The diff picture, RGB. Pixel (x, y) of the pictures is pixel (x, y) of the diff:
//  - a passing pixel is the reference dimmed to a quarter: kDiffDim * REF's colour clamped
//    to [0, 1] (channels 0..2; a one- or two-channel REF is grey from channel 0);
//  - a failing pixel shows how much it differs: its same-position difference d on the colour
//    scale diff_scale_colour((d - smallest) / (largest - smallest)), from blue (the smallest
//    difference of a failing pixel) through green and yellow to red (the largest);
//  - an isolated failing pixel (fewer than kDiffIsolatedBelow failing pixels, itself
//    included, within 3 pixels) is ringed in magenta (a square outline kDiffRing pixels
//    out), so that a handful of failures are seen on a large picture; at most kDiffMaxRings;
//  - below the pictures' rows, when they are at least kDiffLegendMinWidth wide, a legend band
//    of kDiffLegendHeight rows: the scale, labelled with its ends (text by OpenImageIO when
//    a font is found; the scale itself always).
constexpr float kDiffDim = 0.25f;
constexpr int kDiffIsolatedBelow = 4;
constexpr int kDiffRing = 5;
constexpr std::size_t kDiffMaxRings = 256;
constexpr int kDiffLegendMinWidth = 160;
constexpr int kDiffLegendHeight = 24;
struct DiffPicture {
    FloatImage image;
    double smallest = 0.0;  // the scale's ends: the smallest and largest d of a failing pixel
    double largest = 0.0;
    std::size_t isolated = 0;  // isolated failing pixels (ringed: min(isolated, kDiffMaxRings))
    bool legend = false;       // the band is there
};
DiffPicture difference_picture(const FloatImage& reference, const FloatImage& test, const CompareResult& result);
// The scale's colour at t in [0, 1] (clamped): blue (0, 0.4, 1), green (0, 0.85, 0.2),
// yellow (1, 0.9, 0), red (1, 0, 0) at t = 0, 1/3, 2/3, 1, linear between.
std::array<float, 3> diff_scale_colour(double t);

// Writes the picture in the format the extension of `path` names (PNG by tessref itself,
// any other through OpenImageIO): 8-bit
// for formats that have it (PNG, TIFF: round(v * 255) of v clamped to [0, 1]), float for
// EXR. Writes `path` directly (callers wanting atomicity write to a temporary name).
// Throws tessref::Error naming `path`.
void write_float_image(const FloatImage& image, const std::string& path);

}  // namespace tessref
