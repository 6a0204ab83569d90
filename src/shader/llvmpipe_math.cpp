// GLSL's built-in float functions as llvmpipe computes them; see llvmpipe_math.h. Each
// function's comment says where in Mesa its expansion is made and how it goes; the code
// performs the same operations in the same order.
#include "shader/llvmpipe_math.h"

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

namespace tessref::llvmpipe_math {

namespace {

// ---- One SSE operation under "denormals are zero" and "flush to zero" ----------------------

std::uint32_t bits(float x) { return std::bit_cast<std::uint32_t>(x); }
float from_bits(std::uint32_t b) { return std::bit_cast<float>(b); }

float z(float x) { return flush_denormal(x); }

float add(float a, float b) { return z(z(a) + z(b)); }
float sub(float a, float b) { return z(z(a) - z(b)); }
float mul(float a, float b) { return z(z(a) * z(b)); }
float div(float a, float b) { return z(z(a) / z(b)); }
// LLVM's fmuladd, which the host's FMA unit computes with one rounding.
float mad(float a, float b, float c) { return z(std::fma(z(a), z(b), z(c))); }
float root(float a) { return z(std::sqrt(z(a))); }

// The comparisons gallivm emits, on zeroed denormals. "Ordered" ones are false when either
// side is NaN, "unordered" ones true.
bool olt(float a, float b) { return z(a) < z(b); }
bool oge(float a, float b) { return z(a) >= z(b); }
bool oeq(float a, float b) { return z(a) == z(b); }
bool ueq(float a, float b) { return !(z(a) < z(b) || z(a) > z(b)); }
bool ult(float a, float b) { return !(z(a) >= z(b)); }
bool isnan(float a) { return a != a; }

// SSE's minps/maxps: the second operand unless the first is strictly smaller (larger), so
// a NaN on either side gives the second operand.
float minps(float a, float b) { return olt(a, b) ? z(a) : z(b); }
float maxps(float a, float b) { return olt(b, a) ? z(a) : z(b); }

float fabs_bits(float x) { return from_bits(bits(x) & 0x7fffffffu); }

// cvttps2dq: truncation toward zero; NaN and out-of-range values give INT32_MIN.
std::int32_t to_int(float x) {
    x = z(x);
    if (!(x > -2147483904.0f && x < 2147483648.0f)) return std::numeric_limits<std::int32_t>::min();
    return static_cast<std::int32_t>(x);
}

// lp_build_polynomial: coefficients c[0] + c[1] x + ..., evaluated as an even and an odd
// part in x^2 by fused multiply-adds, then odd * x + even.
template <int N>
float polynomial(float x, const float (&c)[N]) {
    const float x2 = mul(x, x);
    float even = 0.0f, odd = 0.0f;
    bool have_even = false, have_odd = false;
    for (int i = N - 1; i >= 0; --i) {
        if (i % 2 == 0) {
            even = have_even ? mad(x2, even, c[i]) : c[i];
            have_even = true;
        } else {
            odd = have_odd ? mad(x2, odd, c[i]) : c[i];
            have_odd = true;
        }
    }
    return have_odd ? mad(odd, x, even) : even;
}

constexpr float kHalfPi = static_cast<float>(1.57079632679489661923);     // M_PI_2, in float
constexpr float kQuarterPi = static_cast<float>(0.78539816339744830962);  // M_PI_4, in float
constexpr float kLog2E = static_cast<float>(1.4426950408889634074);       // M_LOG2E, in float
constexpr float kLn2 = static_cast<float>(1.0 / 1.4426950408889634074);   // 1 / M_LOG2E, in float

// GLSL IR's asin_expr (builtin_functions.cpp): sign(x) * (pi/2 - sqrt(1 - |x|) * (pi/2 +
// |x| * (pi/4 - 1 + |x| * (p0 + |x| * p1)))), each operation rounded, from the innermost
// product outwards. asin and acos use different p0, p1.
float asin_expr(float x, float p0, float p1) {
    const float a = fabs_bits(x);
    float t = mul(a, p1);
    t = add(p0, t);
    t = mul(a, t);
    t = add(kQuarterPi - 1.0f, t);
    t = mul(a, t);
    t = add(kHalfPi, t);
    const float s = root(sub(1.0f, a));
    return mul(sign(x), sub(kHalfPi, mul(s, t)));
}

}  // namespace

float flush_denormal(float x) {
    return (bits(x) & 0x7f800000u) == 0 ? from_bits(bits(x) & 0x80000000u) : x;
}

// llvm.sqrt: the CPU's sqrtps, correctly rounded.
float sqrt(float x) { return root(x); }

// lp_build_rsqrt: gallivm's fast rsqrtps path is disabled, so 1.0 / sqrt(x), each rounded.
float inversesqrt(float x) { return div(1.0f, root(x)); }

// lp_build_sgn: 1.0 with x's sign bit (a bit operation), then +0 where x == 0 in an
// unordered comparison, which holds for zeros, denormals (zero to the comparison) and NaN.
float sign(float x) {
    const float r = from_bits((bits(x) & 0x80000000u) | bits(1.0f));
    return ueq(x, 0.0f) ? 0.0f : r;
}

// roundps toward minus infinity (SSE4.1), on a zeroed denormal.
float floor(float x) { return std::floor(z(x)); }

// NIR's ffract: x - floor(x).
float fract(float x) { return sub(x, floor(x)); }

// NIR lowers fmod (llvmpipe asks it to) to x - y * floor(x / y).
float mod(float x, float y) { return sub(x, mul(y, floor(div(x, y)))); }

// lp_build_exp2: x clamped to [-126.99999, 128] (min/max that keep a NaN), split into
// ipart = floor(x) and fpart = x - ipart; 2^ipart is built in the exponent bits and 2^fpart
// by a degree-5 minimax polynomial, then multiplied. x below -126 gives 2^-127 as the
// exponent part, which is zero: exp2 returns 0 for x < -126.
float exp2(float x) {
    static constexpr float c[] = {1.000000000000000000000f, 0.693153073200168932794f,
                                  0.240153617044375388211f, 0.0558263180532956664775f,
                                  0.00898934009049466391101f, 0.00187757667519147912699f};
    x = olt(128.0f, x) ? 128.0f : z(x);
    x = olt(x, -126.99999f) ? -126.99999f : z(x);
    const float ipart = floor(x);
    const float fpart = sub(x, ipart);
    const std::uint32_t e = (static_cast<std::uint32_t>(to_int(ipart)) + 127u) << 23;
    return mul(from_bits(e), polynomial(fpart, c));
}

// lp_build_log2_safe: x = 2^e * m with m in [1, 2) read from the bits (a denormal has
// e = -127); y = (m - 1) / (m + 1); log2(x) = e + y * P(y^2), P of degree 4, the last step
// fused. Then +inf for x >= +inf, -inf for x == 0 (denormals included), NaN for x < 0 or
// NaN (both comparisons unordered).
float log2(float x) {
    static constexpr float c[] = {2.88539009343309178325f, 0.961791550404184197881f,
                                  0.577440339438736392009f, 0.403343858251329912514f,
                                  0.406718052498846252698f};
    const std::uint32_t i = bits(x);
    const float logexp =
        static_cast<float>(static_cast<std::int32_t>((i & 0x7f800000u) >> 23) - 127);
    const float mant = from_bits((i & 0x007fffffu) | bits(1.0f));
    const float y = div(sub(mant, 1.0f), add(mant, 1.0f));
    const float zz = mul(y, y);
    float res = mad(y, polynomial(zz, c), logexp);
    if (!ult(x, std::numeric_limits<float>::infinity())) res = std::numeric_limits<float>::infinity();
    if (ueq(x, 0.0f)) res = -std::numeric_limits<float>::infinity();
    if (ult(x, 0.0f)) res = std::numeric_limits<float>::quiet_NaN();
    return res;
}

// GLSL's exp reaches NIR as exp2(x * log2(e)) (glsl_to_nir), the constant in float.
float exp(float x) { return exp2(mul(x, kLog2E)); }

// GLSL's log reaches NIR as log2(x) * (1 / log2(e)) (glsl_to_nir), the constant in float.
float log(float x) { return mul(log2(x), kLn2); }

// lp_build_pow: exp2(log2(x) * y), except 0 where x == 0 in an unordered comparison (zeros,
// denormals and NaN x give 0, whatever y).
float pow(float x, float y) {
    if (ueq(x, 0.0f)) return 0.0f;
    return exp2(mul(log2(x), y));
}

namespace {

// lp_build_sin_or_cos, the Cephes single-precision sinf/cosf as SSE code: |x| * 4/pi
// truncated to an integer j, made even (j + 1 rounded down to even); x reduced by j * pi/4
// in three fused steps; one polynomial for the cosine near 0 and one for the sine, chosen
// by bit 1 of j (shifted by 2 for cos); the sign from bit 2 of j (and x's own sign for sin);
// the result clamped to [-1, 1]; NaN for an infinite or NaN x.
float sin_or_cos(float a, bool cosine) {
    const std::uint32_t a_bits = bits(a);
    const float x_abs = fabs_bits(a);
    const float scale_y = mul(x_abs, static_cast<float>(1.27323954473516));
    const std::uint32_t emm2_add = static_cast<std::uint32_t>(to_int(scale_y)) + 1u;
    const std::uint32_t emm2_and = emm2_add & ~1u;
    const float y_2 = static_cast<float>(static_cast<std::int32_t>(emm2_and));
    const std::uint32_t emm2_2 = cosine ? emm2_and - 2u : emm2_and;
    const std::uint32_t sign_bit = cosine ? ((~emm2_2 & 4u) << 29)
                                          : ((a_bits ^ (emm2_add << 29)) & 0x80000000u);
    const bool sine_polynomial = (emm2_2 & 2u) == 0;

    const float x_1 = mad(y_2, static_cast<float>(-0.78515625), x_abs);
    const float x_2 = mad(y_2, static_cast<float>(-2.4187564849853515625e-4), x_1);
    const float x_3 = mad(y_2, static_cast<float>(-3.77489497744594108e-8), x_2);
    const float zz = mul(x_3, x_3);

    const float y_4 = mad(zz, static_cast<float>(2.443315711809948E-005),
                          static_cast<float>(-1.388731625493765E-003));
    const float y_6 = mad(y_4, zz, static_cast<float>(4.166664568298827E-002));
    const float y_8 = mul(mul(y_6, zz), zz);
    const float y_10 = add(sub(y_8, mul(zz, 0.5f)), 1.0f);

    const float y2_4 = mad(zz, static_cast<float>(-1.9515295891E-4),
                           static_cast<float>(8.3321608736E-3));
    const float y2_6 = mad(y2_4, zz, static_cast<float>(-1.6666654611E-1));
    const float y2_9 = mad(mul(y2_6, zz), x_3, x_3);

    float y = from_bits(bits(sine_polynomial ? y2_9 : y_10) ^ sign_bit);
    y = minps(y, 1.0f);
    y = maxps(y, -1.0f);
    if ((a_bits & 0x7f800000u) == 0x7f800000u) return std::numeric_limits<float>::quiet_NaN();
    return y;
}

// NIR's atan (nir_builtin_builder.c) of t >= 0 or NaN, before the sign: x = min(|t|, 1) /
// max(|t|, 1) (a NaN gives 1 / 1), an odd polynomial of degree 11 in x summed term by term
// from the lowest power, then pi/2 - p for |t| > 1.
float atan_abs(float v) {
    const float a = fabs_bits(v);
    const float x = div(minps(a, 1.0f), maxps(a, 1.0f));
    const float x_2 = mul(x, x);
    const float x_3 = mul(x_2, x);
    const float x_5 = mul(x_3, x_2);
    const float x_7 = mul(x_5, x_2);
    const float x_9 = mul(x_7, x_2);
    float tmp = mul(x, 0.9999793128310355f);
    tmp = add(tmp, mul(x_3, -0.3326756418091246f));
    tmp = add(tmp, mul(x_5, 0.1938924977115610f));
    tmp = add(tmp, mul(x_7, -0.1173503194786851f));
    tmp = add(tmp, mul(x_9, 0.0536813784310406f));
    // x^11 * c, where x^11 = x^9 * x^2 has no other use: NIR's algebraic pass moves the
    // constant up the product, (x^9 * c) * x^2.
    tmp = add(tmp, mul(mul(x_9, -0.0121323213173444f), x_2));
    // ffma(b2f(1 < |t|), ffma(tmp, -2, pi/2), tmp), each ffma split into a multiply and an add
    // (llvmpipe has NIR lower ffma).
    const float fixup = olt(1.0f, a) ? 1.0f : 0.0f;
    return add(mul(fixup, add(mul(tmp, -2.0f), kHalfPi)), tmp);
}

}  // namespace

float sin(float x) { return sin_or_cos(x, false); }
float cos(float x) { return sin_or_cos(x, true); }

// GLSL IR's tan: sin(x) / cos(x).
float tan(float x) { return div(sin(x), cos(x)); }

// GLSL IR's asin: asin_expr with p0 = 0.086566724, p1 = -0.03102955.
float asin(float x) { return asin_expr(x, 0.086566724f, -0.03102955f); }

// GLSL IR's acos: pi/2 - asin_expr with p0 = 0.08132463, p1 = -0.02363318.
float acos(float x) { return sub(kHalfPi, asin_expr(x, 0.08132463f, -0.02363318f)); }

// NIR's atan: the polynomial of |t|, times sign(t) (so a NaN t gives +0, sign's zero).
float atan(float y_over_x) { return mul(atan_abs(y_over_x), sign(y_over_x)); }

// NIR's atan2 (nir_builtin_builder.c): in the left half-plane (0 >= x) the point is turned
// by pi/2 so that atan never divides by x near 0; both coordinates are scaled by 1/4 when
// the denominator is at least 1e18; tan = |s / t| computed as s * (1 / t), or 1 where
// |x| == |y|; the angle is atan(tan) (+ pi/2 when turned) and negated when min(y, 1/t) < 0,
// that min keeping the non-NaN side.
float atan2(float y, float x) {
    const bool flip = oge(0.0f, x);
    const float s = flip ? fabs_bits(x) : y;
    const float t = flip ? y : fabs_bits(x);
    const float scale = oge(fabs_bits(t), 1e18f) ? 0.25f : 1.0f;
    const float rcp_scaled_t = div(1.0f, mul(t, scale));
    const float s_over_t = mul(mul(s, scale), rcp_scaled_t);
    const float tan = oeq(fabs_bits(x), fabs_bits(y)) ? 1.0f : fabs_bits(s_over_t);
    const float arc = add(mul(flip ? 1.0f : 0.0f, kHalfPi), atan(tan));
    const float m = isnan(rcp_scaled_t) ? z(y) : minps(y, rcp_scaled_t);
    return olt(m, 0.0f) ? from_bits(bits(arc) ^ 0x80000000u) : arc;
}

// NIR's lowering of fdot (nir_lower_alu_width's reduction): the products from the last
// component down, each added to the sum so far.
float dot(const glm::vec2& a, const glm::vec2& b) { return add(mul(a.y, b.y), mul(a.x, b.x)); }
float dot(const glm::vec3& a, const glm::vec3& b) {
    return add(add(mul(a.z, b.z), mul(a.y, b.y)), mul(a.x, b.x));
}
float dot(const glm::vec4& a, const glm::vec4& b) {
    return add(add(add(mul(a.w, b.w), mul(a.z, b.z)), mul(a.y, b.y)), mul(a.x, b.x));
}
// GLSL IR's length and distance: sqrt(dot(v, v)), of p0 - p1 for distance.
float length(const glm::vec2& v) { return root(dot(v, v)); }
float length(const glm::vec3& v) { return root(dot(v, v)); }
float distance(const glm::vec3& a, const glm::vec3& b) {
    return length(glm::vec3(sub(a.x, b.x), sub(a.y, b.y), sub(a.z, b.z)));
}
// GLSL IR's normalize: v * inversesqrt(dot(v, v)), the factor computed once.
glm::vec3 normalize(const glm::vec3& v) {
    const float f = inversesqrt(dot(v, v));
    return glm::vec3(mul(v.x, f), mul(v.y, f), mul(v.z, f));
}

// GLSL IR's lowering of a matrix product to vector operations: column 0 times v.x, then
// each further column times its component added in turn.
glm::vec4 transform(const glm::mat4& m, const glm::vec4& v) {
    glm::vec4 r;
    for (int i = 0; i < 4; ++i) {
        float sum = mul(m[0][i], v.x);
        for (int c = 1; c < 4; ++c) sum = add(sum, mul(m[c][i], v[c]));
        r[i] = sum;
    }
    return r;
}

// GLSL IR's hyperbolic functions, each exp and log as above.
// sinh: 0.5 * (exp(x) - exp(-x)).
float sinh(float x) { return mul(0.5f, sub(exp(x), exp(-x))); }
// cosh: 0.5 * (exp(x) + exp(-x)).
float cosh(float x) { return mul(0.5f, add(exp(x), exp(-x))); }
// tanh: x clamped to [-10, 10] (max then min, SSE's: a NaN becomes -10), then
// (exp(t) - exp(-t)) / (exp(t) + exp(-t)).
float tanh(float x) {
    const float t = minps(maxps(x, -10.0f), 10.0f);
    return div(sub(exp(t), exp(-t)), add(exp(t), exp(-t)));
}
// asinh: sign(x) * log(|x| + sqrt(x * x + 1)).
float asinh(float x) {
    return mul(sign(x), log(add(fabs_bits(x), root(add(mul(x, x), 1.0f)))));
}
// acosh: log(x + sqrt(x * x - 1)).
float acosh(float x) { return log(add(x, root(sub(mul(x, x), 1.0f)))); }
// atanh: 0.5 * log((1 + x) / (1 - x)).
float atanh(float x) { return mul(0.5f, log(div(add(1.0f, x), sub(1.0f, x)))); }

// opt_rebalance_tree.cpp on a tree of indices: nodes [0, n) are the operands, nodes n and
// up the operations (two children each), the pseudo-root above the tree as Mesa adds it.
std::vector<BalancedStep> balanced_order(std::uint32_t n) {
    if (n < 2) return {};
    constexpr std::uint32_t kNone = 0xffffffffu;
    struct Node {
        std::uint32_t child[2] = {kNone, kNone};
    };
    std::vector<Node> nodes(n);  // operands: no children
    const auto op = [&](std::uint32_t l, std::uint32_t r) {
        nodes.push_back(Node{{l, r}});
        return static_cast<std::uint32_t>(nodes.size() - 1);
    };
    const auto is_op = [&](std::uint32_t i) { return i != kNone && nodes[i].child[0] != kNone; };
    // The chain as written: ((o0 + o1) + o2) + ..., under the pseudo-root (0 + chain).
    std::uint32_t chain = 0;
    for (std::uint32_t k = 1; k < n; ++k) chain = op(chain, k);
    const std::uint32_t zero = op(kNone, kNone);  // the pseudo-root's constant operand (a leaf)
    nodes[zero] = Node{};
    const std::uint32_t root = op(zero, chain);
    // tree_to_vine: right rotations until every operation's left child is a leaf.
    std::uint32_t size = 0, tail = root, rest = nodes[root].child[1];
    while (rest != kNone) {
        const std::uint32_t left = is_op(rest) ? nodes[rest].child[0] : kNone;
        if (!is_op(left)) {
            tail = rest;
            rest = is_op(rest) ? nodes[rest].child[1] : kNone;
            ++size;
        } else {
            nodes[rest].child[0] = nodes[left].child[1];
            nodes[left].child[1] = rest;
            rest = left;
            nodes[tail].child[1] = left;
        }
    }
    // vine_to_tree: left rotations in rounds of compression.
    const auto compression = [&](std::uint32_t count) {
        std::uint32_t scanner = root;
        for (std::uint32_t i = 0; i < count; ++i) {
            const std::uint32_t child = nodes[scanner].child[1];
            nodes[scanner].child[1] = nodes[child].child[1];
            scanner = nodes[scanner].child[1];
            nodes[child].child[1] = nodes[scanner].child[0];
            nodes[scanner].child[0] = child;
        }
    };
    for (int m = (static_cast<int>(size) - 1) / 2, left = static_cast<int>(size) - 1; m > 0; m = left / 2) {
        compression(static_cast<std::uint32_t>(m));
        left -= m + 1;
    }
    // The rebalanced tree under the pseudo-root, as steps in post-order.
    std::vector<BalancedStep> steps;
    const auto emit = [&](auto& self, std::uint32_t node) -> std::uint32_t {
        if (!is_op(node)) return node;  // an operand
        const std::uint32_t l = self(self, nodes[node].child[0]), r = self(self, nodes[node].child[1]);
        steps.push_back(BalancedStep{l, r});
        return n + static_cast<std::uint32_t>(steps.size() - 1);
    };
    emit(emit, nodes[root].child[1]);
    return steps;
}

float balanced_sum(std::span<const float> operands) {
    const auto n = static_cast<std::uint32_t>(operands.size());
    if (n == 0) return 0.0f;
    if (n == 1) return operands[0];
    const std::vector<BalancedStep> steps = balanced_order(n);
    std::vector<float> value(operands.begin(), operands.end());
    for (const BalancedStep& s : steps) value.push_back(add(value[s.left], value[s.right]));
    return value.back();
}

}  // namespace tessref::llvmpipe_math
