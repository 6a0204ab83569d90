// src/shader/llvmpipe_math.h — GLSL's built-in float functions as Mesa's llvmpipe computes
// them (Mesa 22.3, LLVM on an x86-64 host with SSE4.1 and FMA), one lane, bit for bit.
//
// llvmpipe does not call a math library. Mesa's GLSL compiler writes some built-ins as
// arithmetic (acos, asin, the hyperbolic functions, tan), NIR's builder writes others
// (atan, atan2), and gallivm, the LLVM code generator under llvmpipe, expands what is left
// (exp2, log2, pow, sin, cos, sqrt, inversesqrt) into polynomials and bit manipulation. The
// results are not correctly rounded: acos is off by up to a few hundred ulps, sin and cos
// by a few, exp2 and log2 by one or two. Each function here performs the driver's
// operations in the driver's order, in float32, with every operation rounded on its own
// except where the driver multiplies and adds in one fused step (gallivm's polynomial and
// range-reduction helpers ask LLVM for a fused multiply-add, which x86 CPUs with FMA
// execute as one rounding; those steps use std::fma).
//
// The floating-point environment is llvmpipe's: the shader stages before the rasterizer run
// with the SSE control flags "flush to zero" and "denormals are zero" set, so a denormal
// operand of an arithmetic operation counts as a zero of its sign and a denormal result
// becomes a zero of its sign. Bit operations (abs, the sign of sin) see the denormal as it
// is. Every function here applies that rule itself; none depends on the caller's FP mode.
//
// Each function is the driver's result for an operand that arrives as a plain value. NIR's
// algebraic pass rewrites expressions across a call's boundary (it moves a constant factor
// up a product that has no other use, for one), so exp(a * b) or a product of a function's
// result with a constant can be rounded differently in a shader; such rewrites belong to
// whoever evaluates the surrounding expression.
//
// NaN results are NaN; which NaN (sign, payload) is not part of the contract: x86 returns
// the first NaN operand of an operation and LLVM may swap commutative operands. Where the
// driver turns a NaN input into a number (atan, sign, pow, tanh), the same number is
// returned here. tests/test_llvmpipe_math.cpp compares every function with llvmpipe over
// every special value and tens of thousands of sampled floats.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

namespace tessref::llvmpipe_math {

// The floating-point environment of llvmpipe's shaders: a denormal becomes a zero of its sign.
float flush_denormal(float x);

float sqrt(float x);         // the CPU's sqrt (correctly rounded)
float inversesqrt(float x);  // 1 / sqrt(x): two correctly rounded operations
float sign(float x);         // -1, 0 or +1; +0 for zeros, denormals and NaN
float floor(float x);
float fract(float x);           // x - floor(x)
float mod(float x, float y);    // x - y * floor(x / y)

float exp2(float x);
float log2(float x);
float exp(float x);   // exp2(x * log2(e))
float log(float x);   // log2(x) * ln(2)
float pow(float x, float y);

float sin(float x);
float cos(float x);
float tan(float x);   // sin(x) / cos(x)
float asin(float x);
float acos(float x);
float atan(float y_over_x);
float atan2(float y, float x);

// The vector built-ins whose order of operations is not the obvious one: NIR splits a dot
// product into its products and sums them from the last component to the first, so dot of
// two vec3 is (a.z*b.z + a.y*b.y) + a.x*b.x (glm sums from the first). length is
// sqrt(dot(v, v)), distance length(a - b), normalize v * inversesqrt(dot(v, v)).
float dot(const glm::vec2& a, const glm::vec2& b);
float dot(const glm::vec3& a, const glm::vec3& b);
float dot(const glm::vec4& a, const glm::vec4& b);
float length(const glm::vec2& v);
float length(const glm::vec3& v);
float distance(const glm::vec3& a, const glm::vec3& b);
glm::vec3 normalize(const glm::vec3& v);
// A matrix times a vector: the columns scaled by the vector's components and added from the
// first, ((m[0] * v.x + m[1] * v.y) + m[2] * v.z) + m[3] * v.w (glm adds the pairs).
glm::vec4 transform(const glm::mat4& m, const glm::vec4& v);

// Mesa's GLSL compiler can rebalance a chain of one associative operation before NIR sees
// it (opt_rebalance_tree.cpp, the Day-Stout-Warren algorithm): a + b + c + d, written
// ((a + b) + c) + d, then runs as (a + b) + (c + d). The pass takes an expression tree of
// at least three additions (or multiplications) of one type whose leaves are variables and
// at most one constant: no other operation, no array element or struct member among them.
// Which chains reach it in that form depends on where it runs (after built-ins are inlined
// and variables grafted, before user functions are inlined; at a return or an operand, not
// at an assignment's top): src/shader/rebalance.h states the rule, and the interpreter's
// llvmpipe mode applies it to every chain of a user's shader. The thesis control model
// (thesis.cpp) sums its normal factor's four angles in this order, as its twin's chain is.
// balanced_order(n) is the order for n >= 2 operands written left to right: step k
// combines `left` and `right`, each an operand (< n) or the result of step (index - n);
// the last step is the result. balanced_sum adds in that order, each sum rounded.
struct BalancedStep {
    std::uint32_t left = 0, right = 0;
};
std::vector<BalancedStep> balanced_order(std::uint32_t n);
float balanced_sum(std::span<const float> operands);

float sinh(float x);
float cosh(float x);
float tanh(float x);
float asinh(float x);
float acosh(float x);
float atanh(float x);

}  // namespace tessref::llvmpipe_math
