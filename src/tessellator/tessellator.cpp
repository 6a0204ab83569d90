// The primitive generator: level processing, point generation and connectivity for the
// quad, triangle and isoline domains, as the D3D11 functional specification defines the
// fixed-function tessellator that GPUs and llvmpipe implement (docs/GENERATOR.md
// states the facts this follows).
//
// Where the reference formulation patches point indices on the fly so that its stitch
// routines can pretend two rings are consecutive runs of indices, this implementation
// hands the stitchers explicit index arrays for the inside and outside edge of each
// ring segment. The triangles produced are the same; the bookkeeping is visible.
#include "tessref/tessellator.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "tessellator/fixed_point.h"

namespace tessref {

using detail::Fixed;
using detail::kHalf;
using detail::kOne;
using detail::kOneThird;
using detail::kTwoThirds;
using detail::LevelContext;
using detail::Location;

// ---------------------------------------------------------------------------------
// Names

std::string_view to_string(Domain d) {
    switch (d) {
        case Domain::quads: return "quads";
        case Domain::triangles: return "triangles";
        case Domain::isolines: return "isolines";
    }
    return "?";
}
std::string_view to_string(Spacing s) {
    switch (s) {
        case Spacing::equal: return "equal";
        case Spacing::fractional_odd: return "fractional_odd";
        case Spacing::fractional_even: return "fractional_even";
    }
    return "?";
}
std::string_view to_string(Winding w) { return w == Winding::ccw ? "ccw" : "cw"; }
std::string_view to_string(Precision p) { return p == Precision::gpu ? "gpu" : "exact"; }

std::optional<Domain> parse_domain(std::string_view n) {
    for (Domain d : {Domain::quads, Domain::triangles, Domain::isolines})
        if (n == to_string(d)) return d;
    return std::nullopt;
}
std::optional<Spacing> parse_spacing(std::string_view n) {
    for (Spacing s : {Spacing::equal, Spacing::fractional_odd, Spacing::fractional_even})
        if (n == to_string(s)) return s;
    return std::nullopt;
}
std::optional<Winding> parse_winding(std::string_view n) {
    for (Winding w : {Winding::ccw, Winding::cw})
        if (n == to_string(w)) return w;
    return std::nullopt;
}
std::optional<Precision> parse_precision(std::string_view n) {
    for (Precision p : {Precision::gpu, Precision::exact})
        if (n == to_string(p)) return p;
    return std::nullopt;
}

// ---------------------------------------------------------------------------------
// Level processing

namespace {

// llvmpipe runs its draws with denormals flushed to zero, and GPUs flush shader outputs
// the same way: a denormal level is a zero level (so an outer one culls the patch).
float flush_denormal(float x) { return std::fpclassify(x) == FP_SUBNORMAL ? std::copysign(0.0f, x) : x; }

// min(hi, max(lo, x)) with the hardware's NaN rule: NaN becomes lo.
float clamp_level(float x, float lo, float hi) {
    const float m = (x > lo) ? x : lo;  // NaN > lo is false
    return (hi < m) ? hi : m;
}

bool is_even(float x) { return (static_cast<int>(x) & 1) == 0; }

// A level after processing: its value (float, as the generator sees it), its 16.16
// rounding, its parity and its placement context.
struct Level {
    float value = 0;
    Fixed fixed = 0;
    bool odd = false;
    LevelContext ctx;
    int num_points = 0;
};

Level make_level(float value, bool odd) {
    Level l;
    l.value = value;
    l.fixed = detail::float_to_fixed(value);
    l.odd = odd;
    l.ctx = detail::make_level_context(l.fixed, static_cast<double>(value), odd);
    l.num_points = detail::num_points_for_level(l.fixed, odd);
    return l;
}

struct SpacingRange {
    float lo, hi;
};
SpacingRange range_of(Spacing s) {
    switch (s) {
        case Spacing::equal: return {1.0f, 64.0f};
        case Spacing::fractional_even: return {2.0f, 64.0f};
        case Spacing::fractional_odd: return {1.0f, 63.0f};
    }
    return {1.0f, 64.0f};
}

// Half of the smallest fixed-point step above 1: a level that rounds to more than 1 in
// 16.16 is greater than this.
constexpr float kOddPictureFrameThreshold = 1.0f + 0.0000152587890625f / 2.0f;  // 1 + 2^-17
constexpr float kOddInnerMinimum = 1.0f + 0.0000152587890625f;                   // 1 + 2^-16

// ---------------------------------------------------------------------------------
// Pattern assembly

class Builder {
public:
    Builder(const TessSettings& settings, Precision precision) : settings_(settings), precision_(precision) {}

    std::uint32_t add_point(Fixed u, Fixed v, double u_exact, double v_exact) {
        fixed_u_.push_back(u);
        fixed_v_.push_back(v);
        exact_u_.push_back(u_exact);
        exact_v_.push_back(v_exact);
        return static_cast<std::uint32_t>(fixed_u_.size() - 1);
    }
    std::uint32_t add_point(Location u, Location v) { return add_point(u.fixed, v.fixed, u.exact, v.exact); }
    std::uint32_t point_count() const { return static_cast<std::uint32_t>(fixed_u_.size()); }

    // Sizes the buffers once: a level-64 quad pattern is about 100 KB per array, and
    // growing it by doubling costs more in page faults than the tessellation itself.
    void reserve(std::size_t points, std::size_t indices) {
        fixed_u_.reserve(points);
        fixed_v_.reserve(points);
        exact_u_.reserve(points);
        exact_v_.reserve(points);
        indices_.reserve(indices);
    }

    // The generator thinks in triangles wound counter-clockwise in (u right, v up);
    // layout(cw) swaps the last two vertices.
    void triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
        indices_.push_back(a);
        if (settings_.winding == Winding::ccw) {
            indices_.push_back(b);
            indices_.push_back(c);
        } else {
            indices_.push_back(c);
            indices_.push_back(b);
        }
    }
    void segment(std::uint32_t a, std::uint32_t b) {
        indices_.push_back(a);
        indices_.push_back(b);
    }

    void finish(Pattern& out, std::vector<std::uint32_t>& out_indices, std::vector<TessCoord>& out_points,
                std::vector<TessCoordExact>& out_exact, int& vertices_per_primitive) {
        const bool triangles = settings_.domain == Domain::triangles;
        const std::size_t n = fixed_u_.size();
        out_points.resize(n);
        out_exact.resize(n);
        for (std::size_t i = 0; i < n; ++i) {
            if (precision_ == Precision::gpu) {
                const float u = detail::fixed_to_float(fixed_u_[i]);
                const float v = detail::fixed_to_float(fixed_v_[i]);
                const float w = triangles ? (1.0f - u) - v : 0.0f;
                out_points[i] = {u, v, w};
                out_exact[i] = {u, v, w};
            } else {
                const double u = exact_u_[i];
                const double v = exact_v_[i];
                const double w = triangles ? (1.0 - u) - v : 0.0;
                out_exact[i] = {u, v, w};
                out_points[i] = {static_cast<float>(u), static_cast<float>(v), static_cast<float>(w)};
            }
        }
        if (settings_.point_mode) {
            vertices_per_primitive = 1;
            out_indices.resize(n);
            for (std::size_t i = 0; i < n; ++i) out_indices[i] = static_cast<std::uint32_t>(i);
        } else {
            vertices_per_primitive = settings_.domain == Domain::isolines ? 2 : 3;
            out_indices = std::move(indices_);
        }
        (void)out;
    }

private:
    TessSettings settings_;
    Precision precision_;
    std::vector<Fixed> fixed_u_, fixed_v_;
    std::vector<double> exact_u_, exact_v_;
    std::vector<std::uint32_t> indices_;
};

using Row = std::vector<std::uint32_t>;

// Stitching between the outer ring and the first inner ring, where the two edges may
// have any point counts. Points are added on each half of the edge in "ruler" order
// (finalPointPositionTable: where the i-th split lands at the maximum level), advancing
// inside or outside whichever the table says exists at the current level.
void stitch_transition(Builder& b, const Row& inside, int inside_half_points, bool inside_odd, const Row& outside,
                       int outside_half_points, bool outside_odd) {
    static constexpr int kFinalPointPosition[33] = {0,  32, 16, 8,  17, 4,  18, 9,  19, 2,  20,
                                                    10, 21, 5,  22, 11, 23, 1,  24, 12, 25, 6,
                                                    26, 13, 27, 3,  28, 14, 29, 7,  30, 15, 31};
    // First and last entries of the table below a given half-point count: loop bounds.
    static constexpr int kLoopStart[33] = {1, 1, 17, 9, 9, 5, 5, 5, 5, 3, 3, 3, 3, 3, 3, 3, 3,
                                           2, 2, 2,  2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2};
    static constexpr int kLoopEnd[33] = {0,  0,  17, 17, 25, 25, 25, 25, 29, 29, 29, 29, 29, 29, 29, 29, 31,
                                         31, 31, 31, 31, 31, 31, 31, 31, 31, 31, 31, 31, 31, 31, 31, 32};
    if (inside_odd) inside_half_points -= 1;
    if (outside_odd) outside_half_points -= 1;
    std::size_t in = 0, out = 0;
    auto advance_outside = [&] {
        b.triangle(outside[out], outside[out + 1], inside[in]);
        ++out;
    };
    auto advance_inside = [&] {
        b.triangle(inside[in], outside[out], inside[in + 1]);
        ++in;
    };
    const int i_start = std::min(kLoopStart[inside_half_points], kLoopStart[outside_half_points]);
    const int i_end = std::max(kLoopEnd[inside_half_points], kLoopEnd[outside_half_points]);

    if (kFinalPointPosition[0] < outside_half_points) advance_outside();
    for (int i = i_start; i <= i_end; ++i) {
        if (kFinalPointPosition[i] < inside_half_points) advance_inside();
        if (kFinalPointPosition[i] < outside_half_points) advance_outside();
    }
    // The middle: a quad when both edges are odd, a single triangle when parities differ.
    if (inside_odd != outside_odd || inside_odd) {
        if (inside_odd == outside_odd) {
            b.triangle(inside[in], outside[out], inside[in + 1]);
            b.triangle(inside[in + 1], outside[out], outside[out + 1]);
            ++in;
            ++out;
        } else if (!inside_odd) {
            b.triangle(inside[in], outside[out], outside[out + 1]);
            ++out;
        } else {
            b.triangle(inside[in], outside[out], inside[in + 1]);
            ++in;
        }
    }
    for (int i = i_end; i >= i_start; --i) {
        if (kFinalPointPosition[i] < outside_half_points) advance_outside();
        if (kFinalPointPosition[i] < inside_half_points) advance_inside();
    }
    if (kFinalPointPosition[0] < outside_half_points) advance_outside();
}

enum class Diagonals { inside_to_outside, inside_to_outside_except_middle, mirrored };

// Stitching between two rows whose point counts differ by two (a trapezoid: one extra
// triangle at each end) or are equal (the centre strip of a quad).
void stitch_regular(Builder& b, bool trapezoid, Diagonals diagonals, const Row& inside, const Row& outside) {
    const int n_inside = static_cast<int>(inside.size());
    std::size_t in = 0, out = 0;
    if (trapezoid) {
        b.triangle(outside[out], outside[out + 1], inside[in]);
        ++out;
    }
    auto diagonal_from_inside = [&] {  // diagonal from inside[in] to outside[out+1]
        b.triangle(inside[in], outside[out], outside[out + 1]);
        b.triangle(inside[in], outside[out + 1], inside[in + 1]);
        ++in;
        ++out;
    };
    auto diagonal_from_outside = [&] {  // diagonal from outside[out] to inside[in+1]
        b.triangle(outside[out], inside[in + 1], inside[in]);
        b.triangle(outside[out], outside[out + 1], inside[in + 1]);
        ++in;
        ++out;
    };
    int p = 0;
    switch (diagonals) {
        case Diagonals::inside_to_outside:
            for (p = 0; p < n_inside - 1; ++p) diagonal_from_inside();
            break;
        case Diagonals::inside_to_outside_except_middle:
            for (p = 0; p < n_inside / 2 - 1; ++p) diagonal_from_inside();
            diagonal_from_outside();
            p += 2;
            for (; p < n_inside; ++p) diagonal_from_inside();
            break;
        case Diagonals::mirrored:
            for (p = 0; p < n_inside / 2; ++p) diagonal_from_outside();
            for (; p < n_inside - 1; ++p) diagonal_from_inside();
            break;
    }
    if (trapezoid) b.triangle(outside[out], outside[out + 1], inside[in]);
}

// A closed ring of points stored consecutively, split into edges whose lengths (point
// counts, both corners included) are given; the last edge wraps to the first point.
std::vector<Row> ring_edges(std::uint32_t first, std::uint32_t count, std::initializer_list<int> edge_points) {
    std::vector<Row> edges;
    std::uint32_t offset = 0;
    for (int n : edge_points) {
        Row row(static_cast<std::size_t>(n));
        for (int j = 0; j < n; ++j) row[j] = first + (offset + static_cast<std::uint32_t>(j)) % count;
        offset += static_cast<std::uint32_t>(n - 1);
        edges.push_back(std::move(row));
    }
    return edges;
}

Row reversed(Row r) {
    std::reverse(r.begin(), r.end());
    return r;
}

// ---------------------------------------------------------------------------------
// Quads

void tessellate_quads(Builder& b, const Level outer[4], const Level inner[2]) {
    {
        // Exact point count: the outer ring plus (nU - 2)(nV - 2) inside it; a triangulated
        // disk has fewer than two triangles per point.
        const int nu = std::max(inner[0].odd ? 4 : 3, inner[0].num_points);
        const int nv = std::max(inner[1].odd ? 4 : 3, inner[1].num_points);
        std::size_t points = static_cast<std::size_t>((nu - 2) * (nv - 2));
        for (int e = 0; e < 4; ++e) points += static_cast<std::size_t>(outer[e].num_points - 1);
        b.reserve(points, 6 * points);
    }
    // Outer ring, edges 0..3 (u=0 v down, v=0 u up, u=1 v up, v=1 u down).
    int outer_points[4];
    for (int e = 0; e < 4; ++e) {
        outer_points[e] = outer[e].num_points;
        const int end = outer_points[e] - 1;
        for (int p = 0; p < end; ++p) {
            const int q = (e == 1 || e == 2) ? p : end - p;
            const Location loc = detail::place_point(outer[e].ctx, q);
            if (e & 1)
                b.add_point(loc, e == 3 ? Location{kOne, 1.0} : Location{0, 0.0});
            else
                b.add_point(e == 2 ? Location{kOne, 1.0} : Location{0, 0.0}, loc);
        }
    }
    const std::uint32_t outer_count = b.point_count();

    // Inner axis point counts: at least 3 (even) or 4 (odd) so that a transition ring
    // always exists, even for an inner level of 1.
    const int n[2] = {std::max(inner[0].odd ? 4 : 3, inner[0].num_points),
                      std::max(inner[1].odd ? 4 : 3, inner[1].num_points)};

    // Inner rings, outside in; ring r insets every edge by r points.
    const int generated_rings = std::min(n[0], n[1]) >> 1;
    std::vector<std::uint32_t> ring_first(1, 0);
    for (int ring = 1; ring < generated_rings; ++ring) {
        ring_first.push_back(b.point_count());
        const int start = ring;
        const int end[2] = {n[0] - 1 - start, n[1] - 1 - start};
        for (int e = 0; e < 4; ++e) {
            const int perp_axis = e & 1;
            const int along_axis = (e + 1) & 1;
            const Location perp = detail::place_point(inner[perp_axis].ctx, e < 2 ? start : end[perp_axis]);
            for (int p = start; p < end[along_axis]; ++p) {
                const int q = (e == 1 || e == 2) ? p : end[along_axis] - (p - start);
                const Location loc = detail::place_point(inner[along_axis].ctx, q);
                if (along_axis == 1)
                    b.add_point(perp, loc);
                else
                    b.add_point(loc, perp);
            }
        }
    }
    // Even parity on the smaller axis leaves a degenerate innermost ring: a single row
    // (v = 1/2) or column (u = 1/2) of points.
    Row middle;
    if (n[0] > n[1] && !inner[1].odd) {
        const int start = generated_rings, end = n[0] - 1 - start;
        for (int p = start; p <= end; ++p)
            middle.push_back(b.add_point(detail::place_point(inner[0].ctx, p), Location{kHalf, 0.5}));
    } else if (n[1] >= n[0] && !inner[0].odd) {
        const int start = generated_rings, end = n[1] - 1 - start;
        for (int p = end; p >= start; --p)
            middle.push_back(b.add_point(Location{kHalf, 0.5}, detail::place_point(inner[1].ctx, p)));
    }

    // Connectivity: stitch each ring to the one outside it.
    const int rings = std::min((n[0] + 1) >> 1, (n[1] + 1) >> 1);
    std::vector<Row> outside =
        ring_edges(0, outer_count, {outer_points[0], outer_points[1], outer_points[2], outer_points[3]});
    for (int ring = 1; ring < rings; ++ring) {
        const int mu = n[0] - 2 * ring, mv = n[1] - 2 * ring;
        std::vector<Row> inside;
        if (mu == 1 && mv == 1) {
            inside = {middle, middle, middle, middle};
        } else if (mv == 1) {  // row along u, ascending
            inside = {Row{middle.front()}, middle, Row{middle.back()}, reversed(middle)};
        } else if (mu == 1) {  // column along v, descending
            inside = {middle, Row{middle.back()}, reversed(middle), Row{middle.front()}};
        } else {
            const std::uint32_t count = static_cast<std::uint32_t>(2 * (mu - 1) + 2 * (mv - 1));
            inside = ring_edges(ring_first[ring], count, {mv, mu, mv, mu});
        }
        for (int e = 0; e < 4; ++e) {
            const int along_axis = (e + 1) & 1;
            if (ring == 1)
                stitch_transition(b, inside[e], inner[along_axis].ctx.num_half_points, inner[along_axis].odd,
                                  outside[e], outer[e].ctx.num_half_points, outer[e].odd);
            else
                stitch_regular(b, true, Diagonals::mirrored, inside[e], outside[e]);
        }
        outside = std::move(inside);
    }

    // Odd parity on the smaller axis leaves a two-row band in the middle: a strip of quads.
    if (n[0] > n[1] && inner[1].odd) {
        stitch_regular(b, false, Diagonals::inside_to_outside, reversed(outside[3]), outside[1]);
    } else if (n[1] >= n[0] && inner[0].odd) {
        const Diagonals d = inner[1].odd ? Diagonals::inside_to_outside_except_middle : Diagonals::inside_to_outside;
        stitch_regular(b, false, d, reversed(outside[2]), outside[0]);
    }
}

// ---------------------------------------------------------------------------------
// Triangles

void tessellate_triangles(Builder& b, const Level outer[3], const Level& inner) {
    {
        // An upper bound: the outer ring plus an n x n grid inside it.
        const std::size_t n = static_cast<std::size_t>(std::max(4, inner.num_points));
        std::size_t points = n * n;
        for (int e = 0; e < 3; ++e) points += static_cast<std::size_t>(outer[e].num_points - 1);
        b.reserve(points, 6 * points);
    }
    int outer_points[3];
    for (int e = 0; e < 3; ++e) {
        outer_points[e] = outer[e].num_points;
        const int end = outer_points[e] - 1;
        for (int p = 0; p < end; ++p) {
            const int q = (e & 1) ? p : end - p;
            const Location loc = detail::place_point(outer[e].ctx, q);
            if (e == 0)
                b.add_point(Location{0, 0.0}, loc);
            else if (e == 1)
                b.add_point(loc, Location{0, 0.0});
            else
                b.add_point(loc, Location{kOne - loc.fixed, 1.0 - loc.exact});
        }
    }
    const std::uint32_t outer_count = b.point_count();
    const int n = std::max(inner.odd ? 4 : 3, inner.num_points);

    // Inner rings: a ring r points in from an edge sits at a perpendicular distance of
    // 2/3 of the 1D location of point r (the barycentric height of the inset triangle),
    // and slides half that distance along the edge.
    const int generated_rings = n >> 1;
    std::vector<std::uint32_t> ring_first(1, 0);
    for (int ring = 1; ring < generated_rings; ++ring) {
        ring_first.push_back(b.point_count());
        const int start = ring, end = n - 1 - start;
        const Location perp_1d = detail::place_point(inner.ctx, start);
        const Fixed perp = (perp_1d.fixed * kTwoThirds + kHalf) >> 16;
        const double perp_exact = perp_1d.exact * (2.0 / 3.0);
        const Fixed slide = (perp + 1) / 2;
        const double slide_exact = perp_exact / 2.0;
        for (int e = 0; e < 3; ++e) {
            for (int p = start; p < end; ++p) {
                const int q = (e & 1) ? p : end - (p - start);
                const Location x = detail::place_point(inner.ctx, q);
                const Fixed along = x.fixed - slide;
                const double along_exact = x.exact - slide_exact;
                if (e == 0)
                    b.add_point(perp, along, perp_exact, along_exact);
                else if (e == 1)
                    b.add_point(along, perp, along_exact, perp_exact);
                else
                    b.add_point(along, kOne - along - perp, along_exact, 1.0 - along_exact - perp_exact);
            }
        }
    }
    std::uint32_t centre = 0;
    if (!inner.odd) centre = b.add_point(kOneThird, kOneThird, 1.0 / 3.0, 1.0 / 3.0);

    const int rings = (n + 1) >> 1;
    std::vector<Row> outside = ring_edges(0, outer_count, {outer_points[0], outer_points[1], outer_points[2]});
    for (int ring = 1; ring < rings; ++ring) {
        const int m = n - 2 * ring;
        std::vector<Row> inside;
        if (m == 1) {
            inside = {Row{centre}, Row{centre}, Row{centre}};
        } else {
            inside = ring_edges(ring_first[ring], static_cast<std::uint32_t>(3 * (m - 1)), {m, m, m});
        }
        for (int e = 0; e < 3; ++e) {
            if (ring == 1)
                stitch_transition(b, inside[e], inner.ctx.num_half_points, inner.odd, outside[e],
                                  outer[e].ctx.num_half_points, outer[e].odd);
            else
                stitch_regular(b, true, Diagonals::mirrored, inside[e], outside[e]);
        }
        outside = std::move(inside);
    }
    if (inner.odd) b.triangle(outside[0][0], outside[1][0], outside[2][0]);
}

// ---------------------------------------------------------------------------------
// Isolines

void tessellate_isolines(Builder& b, const Level& density, const Level& detail_level) {
    const int lines = density.num_points - 1;  // the v = 1 line is never drawn
    const int per_line = detail_level.num_points;
    b.reserve(static_cast<std::size_t>(lines) * per_line, 2 * static_cast<std::size_t>(lines) * per_line);
    for (int line = 0; line < lines; ++line) {
        const Location v = detail::place_point(density.ctx, line);
        for (int p = 0; p < per_line; ++p) {
            const std::uint32_t index = b.add_point(detail::place_point(detail_level.ctx, p), v);
            if (p > 0) b.segment(index - 1, index);
        }
    }
}

}  // namespace

// ---------------------------------------------------------------------------------

class PatternBuilder {
public:
    static Pattern build(const TessSettings& settings, const TessLevels& given, Precision precision);
};

Pattern PatternBuilder::build(const TessSettings& settings, const TessLevels& given, Precision precision) {
    Pattern pattern;
    pattern.settings_ = settings;
    pattern.levels_ = given;
    pattern.precision_ = precision;
    pattern.vertices_per_primitive_ =
        settings.point_mode ? 1 : (settings.domain == Domain::isolines ? 2 : 3);

    TessLevels raw = given;
    for (float& x : raw.outer) x = flush_denormal(x);
    for (float& x : raw.inner) x = flush_denormal(x);

    const int outer_used = settings.domain == Domain::quads ? 4 : settings.domain == Domain::triangles ? 3 : 2;
    TessLevels eff{};
    eff.outer.fill(0.0f);
    eff.inner.fill(0.0f);

    // 1. Cull: any used outer level that is NaN or <= 0.
    for (int i = 0; i < outer_used; ++i) {
        if (!(raw.outer[i] > 0.0f)) {
            pattern.culled_ = true;
            pattern.effective_levels_ = eff;
            return pattern;
        }
    }

    Builder b(settings, precision);
    const SpacingRange range = range_of(settings.spacing);
    const bool integer = settings.spacing == Spacing::equal;
    const bool spacing_odd = settings.spacing == Spacing::fractional_odd;

    if (settings.domain == Domain::isolines) {
        // Density is always integer spacing in [1, 64]; detail follows the spacing.
        float density = std::ceil(clamp_level(raw.outer[0], 1.0f, 64.0f));
        float detail_value = clamp_level(raw.outer[1], range.lo, range.hi);
        if (integer) detail_value = std::ceil(detail_value);
        eff.outer[0] = density;
        eff.outer[1] = detail_value;
        const Level density_level = make_level(density, !is_even(density));
        const Level detail_level = make_level(detail_value, integer ? !is_even(detail_value) : spacing_odd);
        tessellate_isolines(b, density_level, detail_level);
    } else {
        const int inner_used = settings.domain == Domain::quads ? 2 : 1;
        float outer[4] = {0, 0, 0, 0};
        float inner[2] = {0, 0};
        for (int i = 0; i < outer_used; ++i) {
            outer[i] = clamp_level(raw.outer[i], range.lo, range.hi);
            if (integer) outer[i] = std::ceil(outer[i]);
        }
        // 3. Picture frame: with fractional_odd, a subdivided edge forces an inner ring.
        float inner_lo = range.lo;
        if (spacing_odd) {
            bool frame = false;
            for (int i = 0; i < outer_used; ++i) frame = frame || outer[i] > kOddPictureFrameThreshold;
            if (settings.domain == Domain::quads)
                for (int i = 0; i < inner_used; ++i) frame = frame || raw.inner[i] > kOddPictureFrameThreshold;
            if (frame) inner_lo = kOddInnerMinimum;
        }
        for (int i = 0; i < inner_used; ++i) {
            inner[i] = clamp_level(raw.inner[i], inner_lo, range.hi);
            if (integer) inner[i] = std::ceil(inner[i]);
        }
        for (int i = 0; i < outer_used; ++i) eff.outer[i] = outer[i];
        for (int i = 0; i < inner_used; ++i) eff.inner[i] = inner[i];

        // 4. Parity.
        Level outer_levels[4], inner_levels[2];
        for (int i = 0; i < outer_used; ++i)
            outer_levels[i] = make_level(outer[i], integer ? !is_even(outer[i]) : spacing_odd);
        for (int i = 0; i < inner_used; ++i)
            inner_levels[i] =
                make_level(inner[i], integer ? !(is_even(inner[i]) || inner[i] == 1.0f) : spacing_odd);

        // 5. Minimal patch: every level exactly 1 (after 16.16 rounding).
        bool minimal = integer || spacing_odd;
        for (int i = 0; i < outer_used; ++i) minimal = minimal && outer_levels[i].fixed == kOne;
        for (int i = 0; i < inner_used; ++i) minimal = minimal && inner_levels[i].fixed == kOne;

        if (minimal && settings.domain == Domain::quads) {
            b.add_point(0, 0, 0.0, 0.0);
            b.add_point(kOne, 0, 1.0, 0.0);
            b.add_point(kOne, kOne, 1.0, 1.0);
            b.add_point(0, kOne, 0.0, 1.0);
            b.triangle(0, 1, 3);
            b.triangle(1, 2, 3);
        } else if (minimal) {
            b.add_point(0, kOne, 0.0, 1.0);
            b.add_point(0, 0, 0.0, 0.0);
            b.add_point(kOne, 0, 1.0, 0.0);
            b.triangle(0, 1, 2);
        } else if (settings.domain == Domain::quads) {
            tessellate_quads(b, outer_levels, inner_levels);
        } else {
            tessellate_triangles(b, outer_levels, inner_levels[0]);
        }
    }
    pattern.effective_levels_ = eff;
    b.finish(pattern, pattern.indices_, pattern.points_, pattern.points_exact_, pattern.vertices_per_primitive_);
    return pattern;
}

Pattern tessellate(const TessSettings& settings, const TessLevels& levels, Precision precision) {
    return PatternBuilder::build(settings, levels, precision);
}

double max_point_difference(const Pattern& a, const Pattern& b) {
    const auto pa = a.points_exact();
    const auto pb = b.points_exact();
    if (pa.size() != pb.size()) return std::numeric_limits<double>::infinity();
    double worst = 0.0;
    for (std::size_t i = 0; i < pa.size(); ++i) {
        worst = std::max({worst, std::fabs(pa[i].u - pb[i].u), std::fabs(pa[i].v - pb[i].v),
                          std::fabs(pa[i].w - pb[i].w)});
    }
    return worst;
}

// ---------------------------------------------------------------------------------
// Queries

LevelBits level_bits(const TessLevels& levels) {
    LevelBits bits{};
    std::memcpy(bits.data(), levels.outer.data(), sizeof(float) * 4);
    std::memcpy(bits.data() + 4, levels.inner.data(), sizeof(float) * 2);
    return bits;
}

namespace {

// Segments an edge of level f is cut into (after the generator's clamping and rounding to
// its spacing's parity); an upper bound for fractional levels (their two short segments
// are counted).
std::uint64_t segments(float f, Spacing spacing) {
    float lo = 1.0f, hi = 64.0f;
    if (spacing == Spacing::fractional_odd) hi = 63.0f;
    if (spacing == Spacing::fractional_even) lo = 2.0f;
    const float clamped = std::isnan(f) ? lo : std::min(hi, std::max(lo, f));
    std::uint64_t n = static_cast<std::uint64_t>(std::ceil(clamped));
    if (spacing == Spacing::fractional_odd && n % 2 == 0) ++n;
    if (spacing == Spacing::fractional_even && n % 2 == 1) ++n;
    return n;
}

}  // namespace

std::uint64_t estimate_triangles(const TessSettings& settings, const TessLevels& levels) {
    const int used_outer = settings.domain == Domain::quads ? 4 : settings.domain == Domain::triangles ? 3 : 2;
    for (int i = 0; i < used_outer; ++i)
        if (!(levels.outer[i] > 0.0f)) return 0;  // culled
    std::uint64_t outer_sum = 0;
    for (int i = 0; i < used_outer; ++i) outer_sum += segments(levels.outer[i], settings.spacing);
    if (settings.domain == Domain::quads) {
        // Inner rings (at least 3 segments per axis once any ring exists) plus the stitching
        // of each outer edge to the first ring.
        const std::uint64_t a = std::max<std::uint64_t>(3, segments(levels.inner[0], settings.spacing));
        const std::uint64_t b = std::max<std::uint64_t>(3, segments(levels.inner[1], settings.spacing));
        return 2 * a * b + 2 * outer_sum;
    }
    if (settings.domain == Domain::triangles) {
        // About 1.5 n^2 for the rings; 2 n^2 bounds it with the stitching.
        const std::uint64_t n = std::max<std::uint64_t>(3, segments(levels.inner[0], settings.spacing));
        return 2 * n * n + 2 * outer_sum;
    }
    return 0;  // isolines make no triangles
}

// ---------------------------------------------------------------------------------
// Cache

std::size_t PatternCache::KeyHash::operator()(const Key& k) const noexcept {
    std::uint64_t h = 1469598103934665603ull;  // FNV-1a over the key's words
    auto mix = [&h](std::uint32_t x) {
        for (int i = 0; i < 4; ++i) {
            h ^= (x >> (8 * i)) & 0xffu;
            h *= 1099511628211ull;
        }
    };
    for (std::uint32_t x : k.level_bits) mix(x);
    mix(k.mode);
    return static_cast<std::size_t>(h);
}

std::shared_ptr<const Pattern> PatternCache::get(const TessSettings& settings, const TessLevels& levels,
                                                 Precision precision) {
    Key key{};
    key.level_bits = level_bits(levels);
    key.mode = static_cast<std::uint32_t>(settings.domain) | static_cast<std::uint32_t>(settings.spacing) << 4 |
               static_cast<std::uint32_t>(settings.winding) << 8 | static_cast<std::uint32_t>(settings.point_mode) << 12 |
               static_cast<std::uint32_t>(precision) << 16;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        auto it = map_.find(key);
        if (it != map_.end()) {
            ++hits_;
            return it->second;
        }
    }
    // Tessellate outside the lock; if two threads race on one key, both results are
    // identical and the first one inserted wins.
    auto pattern = std::make_shared<const Pattern>(tessellate(settings, levels, precision));
    std::lock_guard<std::mutex> lock(mutex_);
    ++misses_;
    return map_.emplace(key, std::move(pattern)).first->second;
}

std::size_t PatternCache::size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return map_.size();
}
std::size_t PatternCache::hits() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return hits_;
}
std::size_t PatternCache::misses() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return misses_;
}

}  // namespace tessref
