// The primitive generator's contract, independent of llvmpipe: the eight invariance
// properties of docs/GENERATOR.md (the ones the Khronos CTS checks with exact
// equality), on both precisions; reference point and primitive counts for integer
// levels; and the level-processing rules (cull, clamp, picture frame, minimal patch).
// Bit-exactness against llvmpipe itself is tests/test_gl_differential.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <functional>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <tuple>
#include <vector>

#include "tessref/tessellator.h"

using namespace tessref;

namespace {

constexpr std::array<Spacing, 3> kSpacings = {Spacing::equal, Spacing::fractional_odd, Spacing::fractional_even};
constexpr std::array<Precision, 2> kPrecisions = {Precision::gpu, Precision::exact};

TessLevels uniform(float x) {
    TessLevels l;
    l.outer = {x, x, x, x};
    l.inner = {x, x};
    return l;
}

TessSettings settings(Domain d, Spacing s, Winding w = Winding::ccw, bool point_mode = false) {
    TessSettings t;
    t.domain = d;
    t.spacing = s;
    t.winding = w;
    t.point_mode = point_mode;
    return t;
}

float random_level(std::mt19937& rng) {
    std::uniform_real_distribution<float> d(0.5f, 66.0f);
    return d(rng);
}

// Inner levels for the properties that find edge points by their coordinates: with
// fractional_odd, an inner level just above 1 puts the first inner ring within 2^-17 of
// the boundary, where 16.16 rounding lands it exactly on the edge (as hardware does),
// and "the points on an edge" stops being a coordinate test. Levels >= 2 avoid that.
float random_inner_level(std::mt19937& rng) {
    std::uniform_real_distribution<float> d(2.0f, 66.0f);
    return d(rng);
}

using Vertex = std::tuple<double, double, double>;
Vertex vertex(const Pattern& p, std::uint32_t i) {
    const auto& q = p.points_exact()[i];
    return {q.u, q.v, q.w};
}

// Point on edge e of the domain, and its parameter along that edge.
bool on_edge(Domain d, const TessCoordExact& q, int e, double& t) {
    if (d == Domain::quads) {
        switch (e) {
            case 0: t = q.v; return q.u == 0.0;
            case 1: t = q.u; return q.v == 0.0;
            case 2: t = q.v; return q.u == 1.0;
            default: t = q.u; return q.v == 1.0;
        }
    }
    switch (e) {
        case 0: t = q.v; return q.u == 0.0;
        case 1: t = q.u; return q.v == 0.0;
        default: t = q.u; return q.w == 0.0;
    }
}

std::vector<double> edge_parameters(const Pattern& p, int e) {
    std::vector<double> out;
    for (const auto& q : p.points_exact()) {
        double t;
        if (on_edge(p.settings().domain, q, e, t)) out.push_back(t);
    }
    std::sort(out.begin(), out.end());
    return out;
}

bool is_boundary(Domain d, const TessCoordExact& q) {
    double t;
    for (int e = 0; e < (d == Domain::quads ? 4 : 3); ++e)
        if (on_edge(d, q, e, t)) return true;
    return false;
}

// A triangle as an orientation-preserving canonical tuple (rotated so the smallest
// vertex comes first).
using Triangle = std::array<Vertex, 3>;
Triangle canonical(Triangle t) {
    int m = 0;
    for (int i = 1; i < 3; ++i)
        if (t[i] < t[m]) m = i;
    return {t[m], t[(m + 1) % 3], t[(m + 2) % 3]};
}

std::multiset<Triangle> triangles_where(const Pattern& p, const std::function<bool(const Triangle&)>& keep) {
    std::multiset<Triangle> out;
    for (std::size_t i = 0; i < p.primitive_count(); ++i) {
        auto pr = p.primitive(i);
        Triangle t = {vertex(p, pr[0]), vertex(p, pr[1]), vertex(p, pr[2])};
        if (keep(t)) out.insert(canonical(t));
    }
    return out;
}

// Expected points on an edge for a processed level: 1 + the level rounded up to the
// spacing's parity (equal: any integer).
int expected_edge_points(Spacing s, float level) {
    float lo = s == Spacing::fractional_even ? 2.0f : 1.0f;
    float hi = s == Spacing::fractional_odd ? 63.0f : 64.0f;
    float x = std::min(hi, std::max(lo, level));
    int n = static_cast<int>(std::ceil(x));
    if (s == Spacing::fractional_odd && n % 2 == 0) ++n;
    if (s == Spacing::fractional_even && n % 2 == 1) ++n;
    return n + 1;
}

}  // namespace

// Property 1: the same levels give the same vertex sequence, whatever else happened.
TEST(TessellatorProperties, PrimitiveSetIsAFunctionOfTheLevels) {
    std::mt19937 rng(1);
    for (Precision prec : kPrecisions)
        for (Domain d : {Domain::quads, Domain::triangles, Domain::isolines})
            for (Spacing s : kSpacings)
                for (int k = 0; k < 20; ++k) {
                    TessLevels l;
                    for (float& x : l.outer) x = random_level(rng);
                    for (float& x : l.inner) x = random_level(rng);
                    Pattern a = tessellate(settings(d, s), l, prec);
                    (void)tessellate(settings(d, s), uniform(random_level(rng)), prec);
                    Pattern b = tessellate(settings(d, s), l, prec);
                    ASSERT_EQ(a.indices().size(), b.indices().size());
                    EXPECT_TRUE(std::equal(a.indices().begin(), a.indices().end(), b.indices().begin()));
                    ASSERT_EQ(a.points().size(), b.points().size());
                    for (std::size_t i = 0; i < a.points().size(); ++i)
                        EXPECT_EQ(vertex(a, i), vertex(b, i));
                }
}

// Properties 2 and 4: an edge's points are 1 + rounded level in number and identical
// whatever the other levels, the winding, point mode, and which edge it is.
TEST(TessellatorProperties, OuterEdgeDivisionAndIndexIndependence) {
    std::mt19937 rng(2);
    for (Precision prec : kPrecisions)
        for (Domain d : {Domain::quads, Domain::triangles})
            for (Spacing s : kSpacings)
                for (int k = 0; k < 40; ++k) {
                    const float level = k < 20 ? static_cast<float>(k * 3 + 1) : random_level(rng);
                    std::vector<double> reference;
                    const int edges = d == Domain::quads ? 4 : 3;
                    for (int e = 0; e < edges; ++e)
                        for (int variant = 0; variant < 4; ++variant) {
                            TessLevels l;
                            for (float& x : l.outer) x = random_level(rng);
                            for (float& x : l.inner) x = random_inner_level(rng);
                            l.outer[e] = level;
                            Pattern p = tessellate(settings(d, s, variant & 1 ? Winding::cw : Winding::ccw, variant & 2),
                                                   l, prec);
                            std::vector<double> t = edge_parameters(p, e);
                            ASSERT_EQ(static_cast<int>(t.size()), expected_edge_points(s, level))
                                << "edge " << e << " level " << level;
                            if (reference.empty())
                                reference = t;
                            else
                                ASSERT_EQ(t, reference) << "edge " << e << " level " << level;
                        }
                }
}

// Property 3: the points on an edge are symmetric: x and 1 - x are both present, bitwise
// (in exact precision too: its positions sit on a 2^-53 grid so that 1 - x is exact).
TEST(TessellatorProperties, OuterEdgeSymmetry) {
    std::mt19937 rng(3);
    for (Precision prec : kPrecisions)
        for (Domain d : {Domain::quads, Domain::triangles})
            for (Spacing s : kSpacings)
                for (int k = 0; k < 60; ++k) {
                    TessLevels l;
                    for (float& x : l.outer) x = random_level(rng);
                    for (float& x : l.inner) x = random_inner_level(rng);
                    Pattern p = tessellate(settings(d, s), l, prec);
                    for (int e = 0; e < (d == Domain::quads ? 4 : 3); ++e) {
                        std::vector<double> t = edge_parameters(p, e);
                        for (std::size_t i = 0; i < t.size(); ++i) {
                            ASSERT_EQ(1.0 - t[i], t[t.size() - 1 - i]) << "edge " << e;
                            const float a = static_cast<float>(t[i]);
                            if (prec == Precision::gpu) ASSERT_EQ(1.0f - a, static_cast<float>(t[t.size() - 1 - i]));
                        }
                    }
                }
}

// Property 5: the triangle set is the same for cw and ccw; each cw triangle is a ccw
// triangle with its winding reversed.
TEST(TessellatorProperties, TriangleSetIndependentOfWinding) {
    std::mt19937 rng(5);
    for (Precision prec : kPrecisions)
        for (Domain d : {Domain::quads, Domain::triangles})
            for (Spacing s : kSpacings)
                for (int k = 0; k < 30; ++k) {
                    TessLevels l;
                    for (float& x : l.outer) x = random_level(rng);
                    for (float& x : l.inner) x = random_inner_level(rng);
                    Pattern ccw = tessellate(settings(d, s, Winding::ccw), l, prec);
                    Pattern cw = tessellate(settings(d, s, Winding::cw), l, prec);
                    auto all = [](const Triangle&) { return true; };
                    std::multiset<Triangle> a = triangles_where(ccw, all);
                    std::multiset<Triangle> reversed_cw;
                    for (Triangle t : triangles_where(cw, all)) reversed_cw.insert(canonical({t[0], t[2], t[1]}));
                    ASSERT_EQ(a, reversed_cw);
                    // ccw really is counter-clockwise in (u right, v up): positive area.
                    for (std::size_t i = 0; i < ccw.primitive_count(); ++i) {
                        auto pr = ccw.primitive(i);
                        const auto &p0 = ccw.points_exact()[pr[0]], &p1 = ccw.points_exact()[pr[1]],
                                   &p2 = ccw.points_exact()[pr[2]];
                        const double area = (p1.u - p0.u) * (p2.v - p0.v) - (p2.u - p0.u) * (p1.v - p0.v);
                        ASSERT_GT(area, 0.0) << "triangle " << i;
                    }
                }
}

// Property 6: triangles touching no boundary point do not depend on the outer levels.
TEST(TessellatorProperties, InnerTriangleSetIndependentOfOuterLevels) {
    std::mt19937 rng(6);
    for (Precision prec : kPrecisions)
        for (Domain d : {Domain::quads, Domain::triangles})
            for (Spacing s : kSpacings)
                for (int k = 0; k < 30; ++k) {
                    TessLevels a, b;
                    for (float& x : a.outer) x = random_level(rng);
                    for (float& x : b.outer) x = random_level(rng);
                    a.inner = b.inner = {random_inner_level(rng), random_inner_level(rng)};
                    auto interior = [d](const Triangle& t) {
                        for (const Vertex& v : t) {
                            TessCoordExact q{std::get<0>(v), std::get<1>(v), std::get<2>(v)};
                            if (is_boundary(d, q)) return false;
                        }
                        return true;
                    };
                    ASSERT_EQ(triangles_where(tessellate(settings(d, s), a, prec), interior),
                              triangles_where(tessellate(settings(d, s), b, prec), interior));
                }
}

// Property 7: the triangles touching the interior of one edge do not depend on the
// other edges' levels.
TEST(TessellatorProperties, OuterTriangleSetIndependentOfOtherEdges) {
    std::mt19937 rng(7);
    for (Precision prec : kPrecisions)
        for (Domain d : {Domain::quads, Domain::triangles})
            for (Spacing s : kSpacings)
                for (int k = 0; k < 20; ++k) {
                    const int edges = d == Domain::quads ? 4 : 3;
                    for (int e = 0; e < edges; ++e) {
                        TessLevels a, b;
                        for (float& x : a.outer) x = random_level(rng);
                        for (float& x : b.outer) x = random_level(rng);
                        a.inner = b.inner = {random_inner_level(rng), random_inner_level(rng)};
                        b.outer[e] = a.outer[e];
                        auto touches_edge = [d, e](const Triangle& t) {
                            for (const Vertex& v : t) {
                                TessCoordExact q{std::get<0>(v), std::get<1>(v), std::get<2>(v)};
                                double param;
                                if (on_edge(d, q, e, param) && param > 0.0 && param < 1.0) return true;
                            }
                            return false;
                        };
                        ASSERT_EQ(triangles_where(tessellate(settings(d, s), a, prec), touches_edge),
                                  triangles_where(tessellate(settings(d, s), b, prec), touches_edge))
                            << "edge " << e;
                    }
                }
}

// Property 8: every component lies in [0, 1] and c + (1 - c) == 1 exactly (in float,
// what gl_TessCoord holds), and every index names one of the points.
TEST(TessellatorProperties, ComponentsInUnitIntervalAndComplementExact) {
    std::mt19937 rng(8);
    for (Precision prec : kPrecisions)
        for (Domain d : {Domain::quads, Domain::triangles, Domain::isolines})
            for (Spacing s : kSpacings)
                for (int k = 0; k < 40; ++k) {
                    TessLevels l;
                    for (float& x : l.outer) x = random_level(rng);
                    for (float& x : l.inner) x = random_level(rng);
                    Pattern p = tessellate(settings(d, s), l, prec);
                    for (const TessCoord& q : p.points())
                        for (float c : {q.u, q.v, q.w}) {
                            ASSERT_GE(c, 0.0f);
                            ASSERT_LE(c, 1.0f);
                            ASSERT_EQ(c + (1.0f - c), 1.0f);
                        }
                    for (const TessCoordExact& q : p.points_exact())
                        for (double c : {q.u, q.v, q.w}) {
                            ASSERT_GE(c, 0.0);
                            ASSERT_LE(c, 1.0);
                        }
                    // Every primitive names the pattern's own points: the streamed render
                    // draws a pattern's indices without scanning them (RasterChunk).
                    for (const std::uint32_t index : p.indices()) ASSERT_LT(index, p.points().size());
                }
}

// Reference counts for integer levels (equal spacing), from the formulas of
// docs/GENERATOR.md; triangle domains use Euler's formula for a triangulated disk
// (T = 2V - B - 2) with the interior point count of nested rings.
TEST(TessellatorCounts, IntegerLevels) {
    std::mt19937 rng(9);
    std::uniform_int_distribution<int> level(1, 64), inner_level(2, 64);
    for (int k = 0; k < 400; ++k) {
        const int o[4] = {level(rng), level(rng), level(rng), level(rng)};
        const int i0 = inner_level(rng), i1 = inner_level(rng);
        TessLevels l;
        for (int e = 0; e < 4; ++e) l.outer[e] = static_cast<float>(o[e]);
        l.inner = {static_cast<float>(i0), static_cast<float>(i1)};

        Pattern quads = tessellate(settings(Domain::quads, Spacing::equal), l);
        const int sum = o[0] + o[1] + o[2] + o[3];
        EXPECT_EQ(quads.primitive_count(),
                  static_cast<std::size_t>(2 * (i0 - 2) * (i1 - 2) + 2 * (i0 - 2) + 2 * (i1 - 2) + sum));
        EXPECT_EQ(quads.points().size(), static_cast<std::size_t>(sum + (i0 - 1) * (i1 - 1)));

        Pattern tri = tessellate(settings(Domain::triangles, Spacing::equal), l);
        const int boundary = o[0] + o[1] + o[2];
        int interior = i0 % 2 == 0 ? 1 : 0;
        for (int r = 1; i0 - 2 * r > 0; ++r) interior += 3 * (i0 - 2 * r);
        EXPECT_EQ(tri.points().size(), static_cast<std::size_t>(boundary + interior)) << i0;
        EXPECT_EQ(tri.primitive_count(), static_cast<std::size_t>(2 * interior + boundary - 2));

        Pattern iso = tessellate(settings(Domain::isolines, Spacing::equal), l);
        EXPECT_EQ(iso.primitive_count(), static_cast<std::size_t>(o[0] * o[1]));
        EXPECT_EQ(iso.points().size(), static_cast<std::size_t>(o[0] * (o[1] + 1)));

        Pattern points = tessellate(settings(Domain::quads, Spacing::equal, Winding::ccw, true), l);
        EXPECT_EQ(points.primitive_count(), quads.points().size());
        EXPECT_EQ(points.vertices_per_primitive(), 1);
    }
}

TEST(TessellatorRules, CullingOnlyByUsedOuterLevels) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    for (Spacing s : kSpacings) {
        for (float bad : {nan, 0.0f, -0.0f, -1.0f, -inf, 1e-40f}) {
            for (int e = 0; e < 4; ++e) {
                TessLevels l = uniform(5.0f);
                l.outer[e] = bad;
                EXPECT_TRUE(tessellate(settings(Domain::quads, s), l).culled());
                EXPECT_EQ(tessellate(settings(Domain::quads, s), l).primitive_count(), 0u);
                EXPECT_EQ(tessellate(settings(Domain::triangles, s), l).culled(), e < 3);
                EXPECT_EQ(tessellate(settings(Domain::isolines, s), l).culled(), e < 2);
            }
            TessLevels l = uniform(5.0f);
            l.inner = {bad, bad};  // inner levels never cull
            EXPECT_FALSE(tessellate(settings(Domain::quads, s), l).culled());
        }
        // +inf clamps to the maximum.
        Pattern p = tessellate(settings(Domain::quads, s), uniform(inf));
        EXPECT_FALSE(p.culled());
        EXPECT_EQ(p.effective_levels().outer[0], s == Spacing::fractional_odd ? 63.0f : 64.0f);
    }
}

TEST(TessellatorRules, MinimalPatches) {
    Pattern q = tessellate(settings(Domain::quads, Spacing::equal), uniform(1.0f));
    ASSERT_EQ(q.points().size(), 4u);
    EXPECT_EQ(q.primitive_count(), 2u);
    Pattern t = tessellate(settings(Domain::triangles, Spacing::fractional_odd), uniform(1.0f));
    ASSERT_EQ(t.points().size(), 3u);
    EXPECT_EQ(t.primitive_count(), 1u);
    // fractional_even has no minimal patch: its levels are at least 2.
    Pattern e = tessellate(settings(Domain::quads, Spacing::fractional_even), uniform(1.0f));
    EXPECT_EQ(e.primitive_count(), 8u);
}

// fractional_odd: a subdivided edge forces an inner ring (the "picture frame").
TEST(TessellatorRules, PictureFrame) {
    TessLevels l = uniform(1.0f);
    l.outer[2] = 1.0f + 0x1p-16f;  // rounds above 1 in 16.16
    Pattern p = tessellate(settings(Domain::quads, Spacing::fractional_odd), l);
    EXPECT_EQ(p.effective_levels().inner[0], 1.0f + 0x1p-16f);
    EXPECT_GT(p.points().size(), 4u);
    l.outer[2] = 1.0f + 0x1p-17f;  // exactly the threshold: rounds to 1, stays minimal
    EXPECT_EQ(tessellate(settings(Domain::quads, Spacing::fractional_odd), l).points().size(), 4u);
}

// gpu positions carry the 16.16 reciprocal table; exact ones do not.
TEST(TessellatorPrecision, GpuQuantizesExactDoesNot) {
    TessLevels l = uniform(3.0f);
    Pattern gpu = tessellate(settings(Domain::quads, Spacing::equal), l, Precision::gpu);
    Pattern exact = tessellate(settings(Domain::quads, Spacing::equal), l, Precision::exact);
    std::vector<double> g = edge_parameters(gpu, 1), x = edge_parameters(exact, 1);
    ASSERT_EQ(g.size(), 4u);
    EXPECT_EQ(g[1], 0x5555 / 65536.0);  // round(65536/3) / 65536
    EXPECT_NEAR(x[1], 1.0 / 3.0, 0x1p-54);  // on the 2^-53 grid, not 16.16
    EXPECT_EQ(x[2], 1.0 - x[1]);
    EXPECT_NEAR(max_point_difference(gpu, exact), std::fabs(0x5555 / 65536.0 - 1.0 / 3.0), 1e-12);

    // The triangle centre: 0x5555 in gpu, exactly 1/3 in exact.
    Pattern tg = tessellate(settings(Domain::triangles, Spacing::equal), uniform(2.0f), Precision::gpu);
    Pattern te = tessellate(settings(Domain::triangles, Spacing::equal), uniform(2.0f), Precision::exact);
    EXPECT_EQ(tg.points().back().u, 0x5555 / 65536.0f);
    EXPECT_EQ(te.points_exact().back().u, 1.0 / 3.0);
    EXPECT_EQ(te.points_exact().back().v, 1.0 / 3.0);
    // Same topology in both precisions.
    EXPECT_TRUE(std::equal(tg.indices().begin(), tg.indices().end(), te.indices().begin(), te.indices().end()));
}

TEST(TessellatorCache, SharesPatternsByExactInputs) {
    PatternCache cache;
    auto a = cache.get(settings(Domain::quads, Spacing::equal), uniform(4.0f));
    auto b = cache.get(settings(Domain::quads, Spacing::equal), uniform(4.0f));
    auto c = cache.get(settings(Domain::quads, Spacing::equal), uniform(4.0f), Precision::exact);
    auto d = cache.get(settings(Domain::quads, Spacing::equal, Winding::cw), uniform(4.0f));
    EXPECT_EQ(a.get(), b.get());
    EXPECT_NE(a.get(), c.get());
    EXPECT_NE(a.get(), d.get());
    EXPECT_EQ(cache.size(), 3u);
    EXPECT_EQ(cache.hits(), 1u);
    EXPECT_EQ(cache.misses(), 3u);
}
