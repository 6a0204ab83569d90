// Fixed-point arithmetic and one-dimensional point placement of the primitive generator.
//
// The hardware generator works on unsigned 16.16 fixed point: every tessellation level
// is rounded to a multiple of 2^-16 before anything else happens, and every point's
// position along an edge is a lerp of two reciprocal-table fractions. Those roundings
// are why a GPU's gl_TessCoord is not exactly i/n: reproducing them is what makes
// Precision::gpu bit-identical to llvmpipe. Each placement is computed here twice, in
// fixed point (gpu) and in double from the unrounded level (exact), so both precisions
// share one topology by construction.
#pragma once

#include <cmath>
#include <cstdint>

namespace tessref::detail {

using Fixed = std::uint32_t;

inline constexpr Fixed kOne = 0x10000;
inline constexpr Fixed kHalf = 0x8000;
inline constexpr Fixed kOneThird = 0x5555;
inline constexpr Fixed kTwoThirds = 0xaaaa;

inline constexpr Fixed fixed_floor(Fixed x) { return x & 0xffff0000u; }
inline constexpr Fixed fixed_ceil(Fixed x) { return (x + 0xffffu) & 0xffff0000u; }

// Round to nearest, ties to even (the default FP rounding mode of nearbyint); only
// called on clamped levels in [1, 64], so the product is exact in double.
inline Fixed float_to_fixed(float x) {
    if (!(x > 0.0f)) return 0;
    return static_cast<Fixed>(std::nearbyint(static_cast<double>(x) * 65536.0));
}

inline constexpr float fixed_to_float(Fixed x) { return static_cast<float>(x) / 65536.0f; }

// round(65536 / n) for n = 1..64 (index 0 unused). 65536/n never ends in exactly .5 for
// n <= 64, so adding n/2 before the division is round-to-nearest.
inline constexpr Fixed reciprocal(int n) { return (0x10000u + static_cast<Fixed>(n) / 2) / static_cast<Fixed>(n); }

// A position along an edge in both precisions.
struct Location {
    Fixed fixed;
    double exact;
};

// Everything PlacePointIn1D needs about one level: the "tess factor context".
struct LevelContext {
    bool odd = false;
    Fixed fraction = 0;          // fractional part of the (odd-shifted) half level
    double fraction_exact = 0;   // the same from the unrounded level, in [0, 1]
    int num_half_points = 0;     // points on one half of the edge, midpoint excluded
    int split_point = 0;         // where the floor and ceil placements part ways
    int floor_segments = 1;
    int ceil_segments = 1;
    Fixed inv_floor_segments = 0;
    Fixed inv_ceil_segments = 0;
};

// Clears the most significant set bit: the "ruler" order in which a growing fractional
// level splits its short segments.
inline int remove_msb(int v) {
    if (v <= 0) return 0;
    int msb = 1;
    while ((msb << 1) <= v) msb <<= 1;
    return v & ~msb;
}

// Number of points on an edge (both ends included) for a processed level.
inline int num_points_for_level(Fixed level, bool odd) {
    // "+ 1" is one fixed-point ulp: it rounds the halving so that an exact even level
    // keeps its point count.
    if (odd) return static_cast<int>((fixed_ceil(kHalf + (level + 1) / 2) * 2) >> 16);
    return static_cast<int>((fixed_ceil((level + 1) / 2) * 2) >> 16) + 1;
}

inline LevelContext make_level_context(Fixed level, double level_exact, bool odd) {
    LevelContext c;
    c.odd = odd;
    Fixed half = (level + 1) / 2;
    double half_exact = level_exact / 2.0;
    // A level of 1 with even parity behaves like odd: its half is 1/2 and the lone
    // interior point sits at the midpoint.
    if (odd || half == kHalf) {
        half += kHalf;
        half_exact += 0.5;
    }
    const Fixed floor_half = fixed_floor(half);
    const Fixed ceil_half = fixed_ceil(half);
    c.fraction = half - floor_half;
    // The topology (floor and ceil) comes from the fixed-point level; the exact fraction
    // is measured against the same floor so both precisions place the same points.
    c.fraction_exact = std::fmin(1.0, std::fmax(0.0, half_exact - static_cast<double>(floor_half >> 16)));
    if (ceil_half == floor_half) c.fraction_exact = 0.0;
    c.num_half_points = static_cast<int>(ceil_half >> 16);
    if (ceil_half == floor_half) {
        c.split_point = c.num_half_points + 1;  // never reached: no split
    } else if (odd) {
        c.split_point = floor_half == kOne ? 0 : (remove_msb(static_cast<int>(floor_half >> 16) - 1) << 1) + 1;
    } else {
        c.split_point = (remove_msb(static_cast<int>(floor_half >> 16)) << 1) + 1;
    }
    c.floor_segments = static_cast<int>((floor_half * 2) >> 16);
    c.ceil_segments = static_cast<int>((ceil_half * 2) >> 16);
    if (odd) {
        c.floor_segments -= 1;
        c.ceil_segments -= 1;
    }
    c.inv_floor_segments = c.floor_segments > 0 ? reciprocal(c.floor_segments) : 0;
    c.inv_ceil_segments = c.ceil_segments > 0 ? reciprocal(c.ceil_segments) : 0;
    return c;
}

// Position of point `point` (0 .. num_points-1) along an edge of this level. The two
// halves are mirror images, so the second half is placed as its mirror and flipped.
inline Location place_point(const LevelContext& c, int point) {
    bool flip = false;
    if (point >= c.num_half_points) {
        point = (c.num_half_points << 1) - point;
        if (c.odd) point -= 1;
        flip = true;
    }
    // The midpoint is special-cased: the fixed-point lerp below cannot hit 1/2 exactly.
    if (point == c.num_half_points) return {kHalf, 0.5};
    const unsigned index_on_ceil = static_cast<unsigned>(point);
    const unsigned index_on_floor = index_on_ceil - (point > c.split_point ? 1u : 0u);
    // Both partial locations are <= 1/2, so the 32-bit products cannot overflow.
    const Fixed on_floor = index_on_floor * c.inv_floor_segments;
    const Fixed on_ceil = index_on_ceil * c.inv_ceil_segments;
    Fixed loc = on_floor * (kOne - c.fraction) + on_ceil * c.fraction;
    loc = (loc + kHalf) >> 16;

    const double floor_exact = c.floor_segments > 0 ? static_cast<double>(index_on_floor) / c.floor_segments : 0.0;
    const double ceil_exact = c.ceil_segments > 0 ? static_cast<double>(index_on_ceil) / c.ceil_segments : 0.0;
    double loc_exact = floor_exact * (1.0 - c.fraction_exact) + ceil_exact * c.fraction_exact;
    // Snap to a multiple of 2^-53 (an error below 2^-54): then 1 - loc is exact in double,
    // so the mirrored half is bitwise the complement of the first and a neighbour that
    // walks the shared edge the other way sees exactly the same parameters.
    loc_exact = std::nearbyint(loc_exact * 0x1p53) * 0x1p-53;
    if (flip) {
        loc = kOne - loc;
        loc_exact = 1.0 - loc_exact;
    }
    return {loc, loc_exact};
}

}  // namespace tessref::detail
