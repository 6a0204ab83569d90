// Differential test: shader/llvmpipe_math.h against llvmpipe itself. Every function runs on
// OSMesa (tessref::gl::evaluate: a vertex shader, the operands as raw bits, the result by
// transform feedback) over the special values (+-0, denormals, +-FLT_MIN, +-FLT_MAX, +-inf,
// NaN, 1 +- ulp, the domain edges, the points where a range reduction or a polynomial
// switches) and tens of thousands of sampled floats: uniformly random bit patterns (every
// exponent alike) and uniform samples of the range where the function is used. The results
// must be bit-identical; the one exception is a NaN result, where both sides must be NaN
// but its sign and payload may differ (llvmpipe_math.h: which NaN operand x86 returns
// depends on the operand order LLVM chose).
//
// The first test shows that the comparison can fail: the C library's correctly rounded
// acos, sin, exp2, log2 and pow differ from llvmpipe's on most inputs.
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "shader/llvmpipe_math.h"
#include "gl_test_context.h"
#include "float_bits.h"
#include "tessref/error.h"
#include "tessref/gl_backend.h"

namespace {

namespace gl = tessref::gl;
namespace lm = tessref::llvmpipe_math;

gl::Context* context() { return gl_test_context(); }

bool same(float a, float b) { return bits(a) == bits(b) || (std::isnan(a) && std::isnan(b)); }

// The values every function is tried on, whatever its domain.
std::vector<float> special_values() {
    const float inf = std::numeric_limits<float>::infinity();
    std::vector<float> v = {0.0f, -0.0f, inf, -inf, std::numeric_limits<float>::quiet_NaN(),
                            from_bits(0xffc00000u), from_bits(0x7f800001u),  // -NaN, a signalling NaN
                            from_bits(1u), from_bits(0x80000001u),           // the smallest denormals
                            from_bits(0x007fffffu), from_bits(0x807fffffu),  // the largest denormals
                            FLT_MIN, -FLT_MIN, FLT_MAX, -FLT_MAX, FLT_EPSILON, -FLT_EPSILON};
    // Integers, halves and the points near them, where floor, range reductions and
    // polynomial selections switch.
    for (int i = -140; i <= 140; ++i) {
        for (float base : {static_cast<float>(i), i + 0.5f}) {
            v.push_back(base);
            v.push_back(std::nextafter(base, inf));
            v.push_back(std::nextafter(base, -inf));
        }
    }
    // Multiples of pi/4 (sin and cos switch polynomials there) and powers of two.
    for (int k = -64; k <= 64; ++k) {
        const float p = static_cast<float>(k * 0.78539816339744830962);
        v.push_back(p);
        v.push_back(std::nextafter(p, inf));
        v.push_back(std::nextafter(p, -inf));
    }
    for (int e = -149; e <= 127; ++e) {
        const float p = std::ldexp(1.0f, e);
        for (float s : {p, -p}) {
            v.push_back(s);
            v.push_back(std::nextafter(s, inf));
            v.push_back(std::nextafter(s, -inf));
        }
    }
    for (float s : {1e18f, -1e18f, 128.0f, -126.99999f, -127.0f, 10.0f, -10.0f, 88.7f, -87.3f})
        v.push_back(s);
    return v;
}

// special_values, then `random_bits` uniformly random bit patterns, then `uniform` samples
// uniformly spread over [lo, hi].
std::vector<float> inputs(float lo, float hi, std::uint32_t seed, int random_bits = 20000,
                          int uniform = 20000) {
    std::vector<float> v = special_values();
    std::mt19937 rng(seed);
    for (int i = 0; i < random_bits; ++i) v.push_back(from_bits(static_cast<std::uint32_t>(rng())));
    std::uniform_real_distribution<float> d(lo, hi);
    for (int i = 0; i < uniform; ++i) v.push_back(d(rng));
    return v;
}

struct Outcome {
    std::size_t compared = 0;
    std::size_t matched = 0;
    std::string first_mismatches;
};

// Runs `glsl` on llvmpipe and `model` here over x (and y), counting bit-identical results.
Outcome run(const std::string& glsl, const std::function<float(float, float)>& model,
            const std::vector<float>& x, const std::vector<float>& y = {}) {
    Outcome out;
    gl::Context* ctx = context();
    if (!ctx) return out;
    const std::vector<float> got = gl::evaluate(*ctx, glsl, x, y);
    for (std::size_t i = 0; i < x.size(); ++i) {
        const float yi = y.empty() ? 0.0f : y[i];
        const float want = model(x[i], yi);
        ++out.compared;
        if (same(got[i], want)) {
            ++out.matched;
        } else if (out.first_mismatches.size() < 1500) {
            char line[200];
            std::snprintf(line, sizeof line, "  x=%.9g (%08x) y=%.9g (%08x): llvmpipe %.9g (%08x), model %.9g (%08x)\n",
                          x[i], bits(x[i]), yi, bits(yi), got[i], bits(got[i]), want, bits(want));
            out.first_mismatches += line;
        }
    }
    std::printf("[ math     ] %-22s %6zu inputs, %6zu bit-identical\n", glsl.c_str(), out.compared,
                out.matched);
    return out;
}

#define EXPECT_ALL_MATCH(outcome)                                                            \
    do {                                                                                     \
        const Outcome o_ = (outcome);                                                        \
        EXPECT_GT(o_.compared, 0u);                                                          \
        EXPECT_EQ(o_.matched, o_.compared) << "first mismatches:\n" << o_.first_mismatches;  \
    } while (0)

std::vector<float> pair_operand(const std::vector<float>& x, std::uint32_t seed, float lo, float hi) {
    // Each x meets a special value in turn, a random bit pattern or a uniform sample.
    const std::vector<float> s = special_values();
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> d(lo, hi);
    std::vector<float> y(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) {
        switch (i % 3) {
            case 0: y[i] = s[(i / 3) % s.size()]; break;
            case 1: y[i] = from_bits(static_cast<std::uint32_t>(rng())); break;
            default: y[i] = d(rng); break;
        }
    }
    return y;
}

TEST(LlvmpipeMath, TheLibmFunctionsDifferFromLlvmpipe) {
    // The comparison below is sharp enough to fail: correctly rounded functions disagree with
    // llvmpipe on a large share of the same inputs.
    const std::vector<float> x = inputs(-1.0f, 1.0f, 1);
    const Outcome acos = run("acos(x)", [](float a, float) { return std::acos(a); }, x);
    EXPECT_LT(acos.matched, acos.compared * 3 / 4);
    const std::vector<float> t = inputs(-100.0f, 100.0f, 2);
    const Outcome sin = run("sin(x)", [](float a, float) { return std::sin(a); }, t);
    EXPECT_LT(sin.matched, sin.compared * 3 / 4);
    const Outcome exp2 = run("exp2(x)", [](float a, float) { return std::exp2(a); }, inputs(-20.0f, 20.0f, 3));
    EXPECT_LT(exp2.matched, exp2.compared * 3 / 4);
}

TEST(LlvmpipeMath, BalancedOrderIsMesasRebalancedTree) {
    // The shapes opt_rebalance_tree.cpp gives ((o0 + o1) + o2) + ... of n operands (traced
    // through its tree_to_vine and vine_to_tree; four operands pair up, which is
    // what llvmpipe's levels on jacksboro and olinda show: test_llvmpipe_levels).
    const auto shape = [](std::uint32_t n) {
        const std::vector<lm::BalancedStep> steps = lm::balanced_order(n);
        std::vector<std::string> text;
        for (std::uint32_t k = 0; k < n; ++k) text.push_back("o" + std::to_string(k));
        for (const lm::BalancedStep& s : steps) text.push_back("(" + text[s.left] + " + " + text[s.right] + ")");
        return text.back();
    };
    EXPECT_EQ(shape(2), "(o0 + o1)");
    EXPECT_EQ(shape(3), "((o0 + o1) + o2)");
    EXPECT_EQ(shape(4), "((o0 + o1) + (o2 + o3))");
    EXPECT_EQ(shape(5), "((o0 + o1) + ((o2 + o3) + o4))");
    EXPECT_EQ(shape(6), "(((o0 + o1) + (o2 + o3)) + (o4 + o5))");
    EXPECT_EQ(shape(8), "(((o0 + o1) + (o2 + o3)) + ((o4 + o5) + (o6 + o7)))");
}

TEST(LlvmpipeMath, InverseTrigonometry) {
    const std::vector<float> x = inputs(-1.0f, 1.0f, 10);
    EXPECT_ALL_MATCH(run("acos(x)", [](float a, float) { return lm::acos(a); }, x));
    EXPECT_ALL_MATCH(run("asin(x)", [](float a, float) { return lm::asin(a); }, x));
    // atan's polynomial is most sensitive near |x| = 1, where its last terms weigh most.
    const std::vector<float> t = inputs(-2.0f, 2.0f, 11, 20000, 60000);
    EXPECT_ALL_MATCH(run("atan(x)", [](float a, float) { return lm::atan(a); }, t));
    const std::vector<float> u = inputs(-50.0f, 50.0f, 12, 20000, 60000);
    EXPECT_ALL_MATCH(run("atan(x, y)", [](float a, float b) { return lm::atan2(a, b); }, u,
                         pair_operand(u, 13, -50.0f, 50.0f)));
}

TEST(LlvmpipeMath, Trigonometry) {
    const std::vector<float> x = inputs(-200.0f, 200.0f, 20);
    EXPECT_ALL_MATCH(run("sin(x)", [](float a, float) { return lm::sin(a); }, x));
    EXPECT_ALL_MATCH(run("cos(x)", [](float a, float) { return lm::cos(a); }, x));
    EXPECT_ALL_MATCH(run("tan(x)", [](float a, float) { return lm::tan(a); }, x));
}

TEST(LlvmpipeMath, ExponentialsAndLogarithms) {
    const std::vector<float> e = inputs(-130.0f, 130.0f, 30);
    EXPECT_ALL_MATCH(run("exp2(x)", [](float a, float) { return lm::exp2(a); }, e));
    EXPECT_ALL_MATCH(run("exp(x)", [](float a, float) { return lm::exp(a); }, e));
    const std::vector<float> l = inputs(0.0f, 1000.0f, 31);
    EXPECT_ALL_MATCH(run("log2(x)", [](float a, float) { return lm::log2(a); }, l));
    EXPECT_ALL_MATCH(run("log(x)", [](float a, float) { return lm::log(a); }, l));
    EXPECT_ALL_MATCH(run("pow(x, y)", [](float a, float b) { return lm::pow(a, b); }, l,
                         pair_operand(l, 32, -40.0f, 40.0f)));
}

TEST(LlvmpipeMath, RootsAndRounding) {
    const std::vector<float> x = inputs(-1000.0f, 1000.0f, 40);
    EXPECT_ALL_MATCH(run("sqrt(x)", [](float a, float) { return lm::sqrt(a); }, x));
    EXPECT_ALL_MATCH(run("inversesqrt(x)", [](float a, float) { return lm::inversesqrt(a); }, x));
    EXPECT_ALL_MATCH(run("sign(x)", [](float a, float) { return lm::sign(a); }, x));
    EXPECT_ALL_MATCH(run("floor(x)", [](float a, float) { return lm::floor(a); }, x));
    EXPECT_ALL_MATCH(run("fract(x)", [](float a, float) { return lm::fract(a); }, x));
    EXPECT_ALL_MATCH(run("mod(x, y)", [](float a, float b) { return lm::mod(a, b); }, x,
                         pair_operand(x, 41, -100.0f, 100.0f)));
}

TEST(LlvmpipeMath, Hyperbolic) {
    const std::vector<float> x = inputs(-20.0f, 20.0f, 50);
    EXPECT_ALL_MATCH(run("sinh(x)", [](float a, float) { return lm::sinh(a); }, x));
    EXPECT_ALL_MATCH(run("cosh(x)", [](float a, float) { return lm::cosh(a); }, x));
    EXPECT_ALL_MATCH(run("tanh(x)", [](float a, float) { return lm::tanh(a); }, x));
    EXPECT_ALL_MATCH(run("asinh(x)", [](float a, float) { return lm::asinh(a); }, x));
    EXPECT_ALL_MATCH(run("acosh(x)", [](float a, float) { return lm::acosh(a); }, inputs(1.0f, 100.0f, 51)));
    EXPECT_ALL_MATCH(run("atanh(x)", [](float a, float) { return lm::atanh(a); }, inputs(-1.0f, 1.0f, 52)));
}

}  // namespace
