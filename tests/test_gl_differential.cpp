// Differential test: tessref's primitive generator (Precision::gpu) against the one that
// really runs in OpenGL — Mesa llvmpipe through OSMesa, captured by transform feedback
// (tessref/gl_backend.h). The contract is bit-exact agreement of every primitive of every
// patch, for every domain x spacing x winding x point mode and for any float level:
// NaN, infinities, negatives, zero, denormals, values a hair off an integer, huge values.
//
// Per patch, the MULTISET of primitives must be equal: a primitive is the sequence of its
// vertices' float bits (u, v, w); primitive order may differ, and a triangle may start at
// any of its vertices (a,b,c) == (b,c,a), but never be reflected (the winding must match).
// Lines are ordered pairs, points single vertices. Culled (nothing emitted) must agree too.
//
// The first tests below check the capture itself against hand facts, so that a failure of
// the differential part can be trusted to point at the CPU generator.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cfloat>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <ostream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#if defined(__SSE__) || defined(__x86_64__)
#include <xmmintrin.h>
#define TESSREF_HAVE_MXCSR 1
#endif

#include "gl_test_context.h"
#include "float_bits.h"
#include "tessref/error.h"
#include "tessref/gl_backend.h"
#include "tessref/tessellator.h"

namespace {

using tessref::Domain;
using tessref::Spacing;
using tessref::TessCoord;
using tessref::TessLevels;
using tessref::TessSettings;
using tessref::Winding;
namespace gl = tessref::gl;

gl::Context* context() { return gl_test_context(); }

// A primitive as bit patterns: vertex k occupies words 3k..3k+2 (u, v, w); unused words 0.
using Prim = std::array<std::uint32_t, 9>;

Prim make_prim(const TessCoord* v, int vpp) {
    Prim p{};
    for (int k = 0; k < vpp; ++k) {
        p[3 * k + 0] = bits(v[k].u);
        p[3 * k + 1] = bits(v[k].v);
        p[3 * k + 2] = bits(v[k].w);
    }
    return p;
}

// Triangles start at their lexicographically smallest vertex (a rotation, never a reflection).
Prim canonical(const Prim& p, int vpp) {
    if (vpp != 3) return p;
    Prim best = p;
    for (int r = 1; r < 3; ++r) {
        Prim q{};
        for (int k = 0; k < 3; ++k)
            for (int c = 0; c < 3; ++c) q[3 * k + c] = p[3 * ((k + r) % 3) + c];
        best = std::min(best, q);
    }
    return best;
}

std::vector<Prim> sorted_prims(const std::vector<TessCoord>& flat, int vpp) {
    std::vector<Prim> out;
    out.reserve(flat.size() / static_cast<std::size_t>(vpp));
    for (std::size_t i = 0; i + static_cast<std::size_t>(vpp) <= flat.size(); i += vpp)
        out.push_back(canonical(make_prim(&flat[i], vpp), vpp));
    std::sort(out.begin(), out.end());
    return out;
}

std::vector<Prim> sorted_prims(const tessref::Pattern& pattern) {
    const int vpp = pattern.vertices_per_primitive();
    const auto points = pattern.points();
    std::vector<TessCoord> flat;
    flat.reserve(pattern.indices().size());
    for (std::uint32_t index : pattern.indices())
        flat.push_back(index < points.size() ? points[index] : TessCoord{NAN, NAN, NAN});
    return sorted_prims(flat, vpp);
}

std::string prim_text(const Prim& p, int vpp) {
    std::string s;
    char buf[96];
    for (int k = 0; k < vpp; ++k) {
        std::snprintf(buf, sizeof buf, "%s(%.9g, %.9g, %.9g)", k ? " " : "", from_bits(p[3 * k]),
                      from_bits(p[3 * k + 1]), from_bits(p[3 * k + 2]));
        s += buf;
    }
    s += "  [";
    for (int k = 0; k < 3 * vpp; ++k) {
        std::snprintf(buf, sizeof buf, "%s%08x", k ? " " : "", p[k]);
        s += buf;
    }
    return s + "]";
}

std::string levels_text(const TessLevels& l) {
    std::string s;
    char buf[128];
    const float all[6] = {l.outer[0], l.outer[1], l.outer[2], l.outer[3], l.inner[0], l.inner[1]};
    for (int i = 0; i < 6; ++i) {
        std::snprintf(buf, sizeof buf, "%s%s[%d] = %a (%.9g, 0x%08x)\n", "      ",
                      i < 4 ? "outer" : "inner", i < 4 ? i : i - 4, all[i], all[i], bits(all[i]));
        s += buf;
    }
    return s;
}

std::string settings_text(const TessSettings& s) {
    std::string name = std::string(s.domain == Domain::quads       ? "quads"
                                   : s.domain == Domain::triangles ? "triangles"
                                                                   : "isolines") +
                       "_" +
                       (s.spacing == Spacing::equal            ? "equal"
                        : s.spacing == Spacing::fractional_odd ? "fractional_odd"
                                                               : "fractional_even") +
                       "_" + (s.winding == Winding::ccw ? "ccw" : "cw");
    if (s.point_mode) name += "_point_mode";
    return name;
}

// ---------------------------------------------------------------------------------------
// The level values. Every special value the brief of the generator names, the integers
// 1..64 and their neighbours at +-2^-17 and +-2^-16 (where the 16.16 rounding and the
// picture-frame rule turn), the top of the range in small steps, and random values.

std::vector<float> special_values() {
    const float inf = std::numeric_limits<float>::infinity();
    return {std::numeric_limits<float>::quiet_NaN(),
            -std::numeric_limits<float>::quiet_NaN(),
            from_bits(0x7f800001u),  // signalling-pattern NaN with a payload
            inf,
            -inf,
            -1.0f,
            -64.0f,
            -0.0f,
            0.0f,
            1e-40f,                                    // denormal
            std::numeric_limits<float>::denorm_min(),  // smallest denormal
            -std::numeric_limits<float>::denorm_min(),
            -1e-40f,
            FLT_MIN,  // smallest normal
            1e-20f,
            0.25f,
            0.5f,
            0.999f,
            1.0f,
            std::nextafter(1.0f, 0.0f),
            std::nextafter(1.0f, 2.0f),
            1.5f,
            2.0f,
            1e9f,
            FLT_MAX};
}

std::vector<float> structured_values() {
    std::vector<float> v;
    for (int i = 1; i <= 64; ++i) {
        const float f = static_cast<float>(i);
        v.push_back(f);
        for (float d : {0x1p-17f, 0x1p-16f}) {
            v.push_back(f + d);
            v.push_back(f - d);
        }
    }
    for (float f = 62.5f; f <= 65.0f; f += 0.0625f) v.push_back(f);  // exact steps
    v.push_back(std::nextafter(64.0f, 0.0f));
    v.push_back(std::nextafter(64.0f, 100.0f));
    v.push_back(std::nextafter(63.0f, 100.0f));
    v.push_back(std::nextafter(2.0f, 0.0f));
    v.push_back(std::nextafter(2.0f, 3.0f));
    return v;
}

// Deterministic on every platform: mt19937 is fully specified, the mapping below too.
struct Random {
    std::mt19937 engine;
    explicit Random(std::uint32_t seed) : engine(seed) {}
    float unit() { return static_cast<float>(engine() >> 8) * 0x1p-24f; }  // [0, 1)
    float range(float lo, float hi) { return lo + (hi - lo) * unit(); }
    std::size_t index(std::size_t n) { return static_cast<std::size_t>(engine() % n); }
    float level() {  // mostly the whole range, sometimes small (where fractions matter most)
        return unit() < 0.7f ? range(0.0f, 66.0f) : range(-0.5f, 4.0f);
    }
};

TessLevels uniform_levels(float f) {
    TessLevels l;
    l.outer = {f, f, f, f};
    l.inner = {f, f};
    return l;
}

std::vector<TessLevels> level_sets(std::uint32_t seed) {
    const auto specials = special_values();
    const auto structured = structured_values();
    Random rnd(seed);
    std::vector<TessLevels> sets;
    // Uniform sets: all six levels equal.
    for (float f : specials) sets.push_back(uniform_levels(f));
    for (float f : structured) sets.push_back(uniform_levels(f));
    for (int i = 0; i < 100; ++i) sets.push_back(uniform_levels(rnd.level()));
    // Mixed sets: each level drawn independently, so one edge culls, inner levels clamp,
    // the picture-frame rule fires, edges of very different density meet, ...
    auto draw = [&]() {
        const float r = rnd.unit();
        if (r < 0.15f) return specials[rnd.index(specials.size())];
        if (r < 0.55f) return structured[rnd.index(structured.size())];
        return rnd.level();
    };
    for (int i = 0; i < 700; ++i) {
        TessLevels l;
        for (float& x : l.outer) x = draw();
        for (float& x : l.inner) x = draw();
        sets.push_back(l);
    }
    return sets;
}

// ---------------------------------------------------------------------------------------
// Hand facts about the capture itself (independent of tessref's generator).

TEST(GlCapture, ReportsAnOpenGl45CoreContext) {
    gl::Context* ctx = context();
    ASSERT_NE(ctx, nullptr);
    EXPECT_FALSE(ctx->renderer().empty());
    EXPECT_EQ(ctx->version().rfind("4.", 0), 0u) << ctx->version();
}

TEST(GlCapture, MinimalQuadIsTwoTriangles) {
    gl::Context* ctx = context();
    ASSERT_NE(ctx, nullptr);
    // GL spec / TESSELLATION.md: points (0,0),(1,0),(1,1),(0,1), triangles (0,1,3),(1,2,3).
    const auto got = gl::capture_pattern(*ctx, TessSettings{}, uniform_levels(1.0f));
    ASSERT_FALSE(got.emitted_nothing);
    ASSERT_EQ(got.vertices_per_primitive, 3);
    const std::vector<TessCoord> expected = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0},
                                             {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    EXPECT_EQ(sorted_prims(got.vertices, 3), sorted_prims(expected, 3)) << gl::dump(got);
}

TEST(GlCapture, MinimalTriangleIsOneTriangle) {
    gl::Context* ctx = context();
    ASSERT_NE(ctx, nullptr);
    TessSettings s;
    s.domain = Domain::triangles;
    const auto got = gl::capture_pattern(*ctx, s, uniform_levels(1.0f));
    const std::vector<TessCoord> expected = {{0, 1, 0}, {0, 0, 1}, {1, 0, 0}};
    EXPECT_EQ(sorted_prims(got.vertices, 3), sorted_prims(expected, 3)) << gl::dump(got);
}

TEST(GlCapture, QuadCountsFollowTheFormula) {
    gl::Context* ctx = context();
    ASSERT_NE(ctx, nullptr);
    // triangles = 2(i0-2)(i1-2) + 2(i0-2) + 2(i1-2) + o0+o1+o2+o3 (all inner > 1),
    // points = o0+o1+o2+o3 + (i0-1)(i1-1). Many patches in one call also exercise the
    // batching (64 patches at level 64 are far over one draw's budget) and the attribution
    // of primitives to patches by gl_PrimitiveID.
    std::vector<TessLevels> sets;
    for (int n = 2; n <= 64; ++n) sets.push_back(uniform_levels(static_cast<float>(n)));
    for (int k = 0; k < 64; ++k) sets.push_back(uniform_levels(64.0f));
    for (bool point_mode : {false, true}) {
        TessSettings s;
        s.point_mode = point_mode;
        const auto got = gl::capture_patterns(*ctx, s, sets);
        ASSERT_EQ(got.size(), sets.size());
        for (std::size_t i = 0; i < sets.size(); ++i) {
            const std::size_t n = static_cast<std::size_t>(sets[i].outer[0]);
            const std::size_t expected =
                point_mode ? 4 * n + (n - 1) * (n - 1) : 2 * (n - 2) * (n - 2) + 4 * (n - 2) + 4 * n;
            EXPECT_EQ(got[i].primitive_count(), expected) << "level " << n << " patch " << i;
        }
    }
}

TEST(GlCapture, IsolinesAreLineMajorWithoutTheLastLine) {
    gl::Context* ctx = context();
    ASSERT_NE(ctx, nullptr);
    TessSettings s;
    s.domain = Domain::isolines;
    TessLevels l;
    l.outer = {4.0f, 2.0f, 1.0f, 1.0f};  // 4 lines (v = 0, 1/4, 1/2, 3/4), 2 segments each
    const auto got = gl::capture_pattern(*ctx, s, l);
    std::vector<TessCoord> expected;
    for (float v : {0.0f, 0.25f, 0.5f, 0.75f})
        for (float u : {0.0f, 0.5f}) {
            expected.push_back({u, v, 0.0f});
            expected.push_back({u + 0.5f, v, 0.0f});
        }
    EXPECT_EQ(sorted_prims(got.vertices, 2), sorted_prims(expected, 2)) << gl::dump(got);
}

TEST(GlCapture, CwIsCcwReflected) {
    gl::Context* ctx = context();
    ASSERT_NE(ctx, nullptr);
    for (Domain d : {Domain::quads, Domain::triangles}) {
        TessSettings s;
        s.domain = d;
        const TessLevels l = uniform_levels(5.0f);
        const auto ccw = gl::capture_pattern(*ctx, s, l);
        s.winding = Winding::cw;
        auto cw = gl::capture_pattern(*ctx, s, l);
        for (std::size_t i = 0; i + 3 <= cw.vertices.size(); i += 3)
            std::swap(cw.vertices[i + 1], cw.vertices[i + 2]);
        EXPECT_EQ(sorted_prims(cw.vertices, 3), sorted_prims(ccw.vertices, 3));
    }
}

TEST(GlCapture, NonPositiveOrNanOuterLevelCulls) {
    gl::Context* ctx = context();
    ASSERT_NE(ctx, nullptr);
    std::vector<TessLevels> sets;
    for (float bad : {0.0f, -0.0f, -1.0f, std::numeric_limits<float>::quiet_NaN(),
                      -std::numeric_limits<float>::infinity()}) {
        TessLevels l = uniform_levels(3.0f);
        l.outer[2] = bad;
        sets.push_back(l);
    }
    TessLevels inner_only = uniform_levels(3.0f);
    inner_only.inner = {std::numeric_limits<float>::quiet_NaN(), -5.0f};  // inner never culls
    sets.push_back(inner_only);
    const auto got = gl::capture_patterns(*ctx, TessSettings{}, sets);
    for (std::size_t i = 0; i + 1 < sets.size(); ++i) EXPECT_TRUE(got[i].emitted_nothing) << i;
    EXPECT_FALSE(got.back().emitted_nothing);
}

// ---------------------------------------------------------------------------------------
// The differential test proper.

// The test parameter: a layout, printed by name in gtest's messages.
struct Layout {
    TessSettings settings;
};
void PrintTo(const Layout& layout, std::ostream* os) { *os << settings_text(layout.settings); }

class GlDifferential : public ::testing::TestWithParam<Layout> {};

bool has_denormal(const TessLevels& l) {
    for (float x : l.outer)
        if (std::fpclassify(x) == FP_SUBNORMAL) return true;
    for (float x : l.inner)
        if (std::fpclassify(x) == FP_SUBNORMAL) return true;
    return false;
}

TEST_P(GlDifferential, EveryPrimitiveMatchesLlvmpipe) {
    const TessSettings settings = GetParam().settings;
    gl::Context* ctx = context();
    ASSERT_NE(ctx, nullptr);
    const std::string name = settings_text(settings);
    const std::uint32_t seed = 20240601u + static_cast<std::uint32_t>(settings.domain) * 16u +
                               static_cast<std::uint32_t>(settings.spacing) * 4u +
                               static_cast<std::uint32_t>(settings.winding) * 2u +
                               (settings.point_mode ? 1u : 0u);
    const auto sets = level_sets(seed);
    ASSERT_GE(sets.size(), 1000u);

    const auto t0 = std::chrono::steady_clock::now();
    const auto captured = gl::capture_patterns(*ctx, settings, sets);
    const auto t1 = std::chrono::steady_clock::now();
    ASSERT_EQ(captured.size(), sets.size());

#ifdef TESSREF_HAVE_MXCSR
    // llvmpipe flushes denormals while it draws; the CPU reference must not inherit that.
    ASSERT_EQ(_mm_getcsr() & 0x8040u, 0u) << "FTZ/DAZ left set in the calling thread";
#endif

    std::size_t primitives = 0, culled = 0, mismatches = 0, printed = 0;
    std::size_t culled_differs = 0, count_differs = 0, bits_differ = 0, with_denormal = 0;
    const int expected_vpp = settings.point_mode ? 1 : settings.domain == Domain::isolines ? 2 : 3;
    double cpu_seconds = 0.0;
    for (std::size_t i = 0; i < sets.size(); ++i) {
        const auto c0 = std::chrono::steady_clock::now();
        const tessref::Pattern pattern = tessref::tessellate(settings, sets[i]);
        cpu_seconds +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - c0).count();
        ASSERT_EQ(pattern.vertices_per_primitive(), expected_vpp);

        const auto want = sorted_prims(captured[i].vertices, expected_vpp);  // llvmpipe
        const auto have = sorted_prims(pattern);                             // tessref
        primitives += want.size();
        culled += captured[i].emitted_nothing ? 1 : 0;
        const bool culled_ok = pattern.culled() == captured[i].emitted_nothing;
        if (culled_ok && want == have) continue;

        ++mismatches;
        if (!culled_ok)
            ++culled_differs;
        else if (want.size() != have.size())
            ++count_differs;
        else
            ++bits_differ;
        if (has_denormal(sets[i])) ++with_denormal;
        if (printed >= 5) continue;
        ++printed;

        std::vector<Prim> only_gl, only_cpu;
        std::set_difference(want.begin(), want.end(), have.begin(), have.end(),
                            std::back_inserter(only_gl));
        std::set_difference(have.begin(), have.end(), want.begin(), want.end(),
                            std::back_inserter(only_cpu));
        std::string msg = "MISMATCH " + name + ", level set " + std::to_string(i) + ":\n" +
                          levels_text(sets[i]);
        char buf[256];
        std::snprintf(buf, sizeof buf,
                      "    llvmpipe: %zu primitives%s; tessref: %zu primitives%s "
                      "(%zu only in llvmpipe, %zu only in tessref)\n",
                      want.size(), captured[i].emitted_nothing ? " (nothing emitted)" : "",
                      have.size(), pattern.culled() ? " (culled)" : "", only_gl.size(),
                      only_cpu.size());
        msg += buf;
        for (std::size_t k = 0; k < std::min<std::size_t>(4, only_gl.size()); ++k)
            msg += "    only llvmpipe: " + prim_text(only_gl[k], expected_vpp) + "\n";
        for (std::size_t k = 0; k < std::min<std::size_t>(4, only_cpu.size()); ++k)
            msg += "    only tessref:  " + prim_text(only_cpu[k], expected_vpp) + "\n";
        ADD_FAILURE() << msg;
    }
    const double gl_seconds = std::chrono::duration<double>(t1 - t0).count();
    std::printf(
        "[ summary  ] %-40s %zu patches (%zu culled), %zu primitives (llvmpipe %.2f s, "
        "tessref %.2f s): "
        "%zu mismatching patches (culled status %zu, count %zu, bits %zu; %zu of them with a "
        "denormal level)\n",
        name.c_str(), sets.size(), culled, primitives, gl_seconds, cpu_seconds, mismatches,
        culled_differs, count_differs, bits_differ, with_denormal);
    EXPECT_EQ(mismatches, 0u) << name << ": " << mismatches << " of " << sets.size()
                              << " patches differ from llvmpipe";
}

std::vector<Layout> all_layouts() {
    std::vector<Layout> all;
    for (Domain d : {Domain::quads, Domain::triangles, Domain::isolines})
        for (Spacing s : {Spacing::equal, Spacing::fractional_odd, Spacing::fractional_even})
            for (Winding w : {Winding::ccw, Winding::cw})
                for (bool point_mode : {false, true}) all.push_back(Layout{TessSettings{d, s, w, point_mode}});
    return all;
}

INSTANTIATE_TEST_SUITE_P(AllLayouts, GlDifferential, ::testing::ValuesIn(all_layouts()),
                         [](const ::testing::TestParamInfo<Layout>& info) {
                             return settings_text(info.param.settings);
                         });

}  // namespace
