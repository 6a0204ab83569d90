// The GLSL.std.450 extended instructions in the two math modes: see std450.h.
//
// Two layers. The elementary functions (sin, cos, tan, asin, acos, atan, atan2, the
// hyperbolic ones, exp, exp2, log, log2, pow, sqrt, inversesqrt) are the ones whose result
// depends on the math mode, and `elementary()` is the one place that chooses:
//   - exact: the float result correctly rounded. sqrt is IEEE's (one rounding). The others
//     are evaluated in double by the C library (glibc: errors below one double ulp) and
//     rounded once to float. That is the correctly rounded float except where the exact
//     result lies within about 2^-28 float ulps of a midpoint between two floats, where the
//     double's own error can put it on the wrong side (double rounding); such arguments are
//     rare and none is known among the shipped scenes' values, but no exhaustive search over
//     all float arguments was run.
//   - llvmpipe: the approximations llvmpipe evaluates (tessref::llvmpipe_math, bit for bit
//     with Mesa 22.3's llvmpipe). Only these functions flush denormals as llvmpipe does;
//     the interpreter's other operations keep them (in both modes).
// Everything else (normalize, length, distance, mix, smoothstep, reflect, cross, ...) is
// written here as GLSL defines it, in elementary operations each rounded to float on its
// own, calling the elementary layer where the definition does, identically in both modes
// but for the order of a dot product's sum:
//   length(v) = sqrt(dot(v, v)), distance(a, b) = length(a - b),
//   normalize(v) = v * inversesqrt(dot(v, v)), mix(x, y, a) = x + a * (y - x),
//   dot(a, b) = ((a0 b0 + a1 b1) + a2 b2) + a3 b3 in exact mode, ((a3 b3 + a2 b2) + a1 b1) +
//   a0 b0 in llvmpipe mode (NIR's order; so length, distance, normalize, reflect and
//   faceforward follow the mode too), fract(x) = x - floor(x),
//   smoothstep: t = clamp((x - e0) / (e1 - e0), 0, 1), t * t * (3 - 2 t).
// min, max and clamp of a NaN return the other operand (IEEE minNum/maxNum; GLSL leaves it
// undefined); round() rounds halves to even, as roundEven().
#include "shader/std450.h"

#include "shader/llvmpipe_math.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include <glslang/SPIRV/GLSL.std.450.h>

namespace tessref::shader {

namespace {

float f(std::uint32_t w) { return std::bit_cast<float>(w); }
std::uint32_t w(float x) { return std::bit_cast<std::uint32_t>(x); }

// The llvmpipe mode's functions (src/shader/llvmpipe_math.h). radians() and degrees(),
// which Mesa's GLSL compiler writes as a product with a float constant, are that product.
float llvmpipe(std::uint32_t op, float x, float y) {
    namespace m = llvmpipe_math;
    switch (op) {
        case GLSLstd450Sin: return m::sin(x);
        case GLSLstd450Cos: return m::cos(x);
        case GLSLstd450Tan: return m::tan(x);
        case GLSLstd450Asin: return m::asin(x);
        case GLSLstd450Acos: return m::acos(x);
        case GLSLstd450Atan: return m::atan(x);
        case GLSLstd450Atan2: return m::atan2(x, y);
        case GLSLstd450Sinh: return m::sinh(x);
        case GLSLstd450Cosh: return m::cosh(x);
        case GLSLstd450Tanh: return m::tanh(x);
        case GLSLstd450Asinh: return m::asinh(x);
        case GLSLstd450Acosh: return m::acosh(x);
        case GLSLstd450Atanh: return m::atanh(x);
        case GLSLstd450Exp: return m::exp(x);
        case GLSLstd450Exp2: return m::exp2(x);
        case GLSLstd450Log: return m::log(x);
        case GLSLstd450Log2: return m::log2(x);
        case GLSLstd450Pow: return m::pow(x, y);
        case GLSLstd450Sqrt: return m::sqrt(x);
        case GLSLstd450InverseSqrt: return m::inversesqrt(x);
        case GLSLstd450Radians: return x * 0.017453292519943295f;
        case GLSLstd450Degrees: return x * 57.29577951308232f;
        default: return 0.0f;
    }
}

// The mode-dependent functions. y is the second argument of pow and atan2.
float elementary(std::uint32_t op, MathMode mode, float x, float y = 0.0f) {
    if (mode == MathMode::llvmpipe) return llvmpipe(op, x, y);
    const double d = x, e = y;
    switch (op) {
        case GLSLstd450Sin: return static_cast<float>(std::sin(d));
        case GLSLstd450Cos: return static_cast<float>(std::cos(d));
        case GLSLstd450Tan: return static_cast<float>(std::tan(d));
        case GLSLstd450Asin: return static_cast<float>(std::asin(d));
        case GLSLstd450Acos: return static_cast<float>(std::acos(d));
        case GLSLstd450Atan: return static_cast<float>(std::atan(d));
        case GLSLstd450Atan2: return static_cast<float>(std::atan2(d, e));
        case GLSLstd450Sinh: return static_cast<float>(std::sinh(d));
        case GLSLstd450Cosh: return static_cast<float>(std::cosh(d));
        case GLSLstd450Tanh: return static_cast<float>(std::tanh(d));
        case GLSLstd450Asinh: return static_cast<float>(std::asinh(d));
        case GLSLstd450Acosh: return static_cast<float>(std::acosh(d));
        case GLSLstd450Atanh: return static_cast<float>(std::atanh(d));
        case GLSLstd450Exp: return static_cast<float>(std::exp(d));
        case GLSLstd450Exp2: return static_cast<float>(std::exp2(d));
        case GLSLstd450Log: return static_cast<float>(std::log(d));
        case GLSLstd450Log2: return static_cast<float>(std::log2(d));
        case GLSLstd450Pow: return static_cast<float>(std::pow(d, e));
        case GLSLstd450Sqrt: return std::sqrt(x);
        case GLSLstd450InverseSqrt: return static_cast<float>(1.0 / std::sqrt(d));
        case GLSLstd450Radians: return static_cast<float>(d * (3.14159265358979323846 / 180.0));
        case GLSLstd450Degrees: return static_cast<float>(d * (180.0 / 3.14159265358979323846));
        default: return 0.0f;
    }
}

bool is_elementary(std::uint32_t op) {
    switch (op) {
        case GLSLstd450Sin: case GLSLstd450Cos: case GLSLstd450Tan: case GLSLstd450Asin: case GLSLstd450Acos:
        case GLSLstd450Atan: case GLSLstd450Atan2: case GLSLstd450Sinh: case GLSLstd450Cosh: case GLSLstd450Tanh:
        case GLSLstd450Asinh: case GLSLstd450Acosh: case GLSLstd450Atanh: case GLSLstd450Exp: case GLSLstd450Exp2:
        case GLSLstd450Log: case GLSLstd450Log2: case GLSLstd450Pow: case GLSLstd450Sqrt:
        case GLSLstd450InverseSqrt: case GLSLstd450Radians: case GLSLstd450Degrees:
            return true;
        default: return false;
    }
}


float clampf(float x, float lo, float hi) { return std::fmin(std::fmax(x, lo), hi); }

// The i-th component of an argument that may be a scalar broadcast to the result's width.
std::uint32_t at(const Std450Args& a, int k, std::uint32_t i) {
    return a.components[k] == 1 ? a.value[k][0] : a.value[k][i * a.stride];
}

}  // namespace

float dot_product(const std::uint32_t* a, const std::uint32_t* b, std::uint32_t n, std::uint32_t stride, MathMode mode) {
    const auto product = [&](std::uint32_t i) { return f(a[i * stride]) * f(b[i * stride]); };
    if (mode == MathMode::llvmpipe) {  // NIR's order: from the last component to the first
        float sum = product(n - 1);
        for (std::uint32_t i = n - 1; i-- > 0;) sum = sum + product(i);
        return sum;
    }
    float sum = product(0);
    for (std::uint32_t i = 1; i < n; ++i) sum = sum + product(i);
    return sum;
}

std::string std450_name(std::uint32_t op) {
    static const char* names[] = {
        "Bad", "Round", "RoundEven", "Trunc", "FAbs", "SAbs", "FSign", "SSign", "Floor", "Ceil", "Fract", "Radians",
        "Degrees", "Sin", "Cos", "Tan", "Asin", "Acos", "Atan", "Sinh", "Cosh", "Tanh", "Asinh", "Acosh", "Atanh",
        "Atan2", "Pow", "Exp", "Log", "Exp2", "Log2", "Sqrt", "InverseSqrt", "Determinant", "MatrixInverse", "Modf",
        "ModfStruct", "FMin", "UMin", "SMin", "FMax", "UMax", "SMax", "FClamp", "UClamp", "SClamp", "FMix", "IMix",
        "Step", "SmoothStep", "Fma", "Frexp", "FrexpStruct", "Ldexp", "PackSnorm4x8", "PackUnorm4x8",
        "PackSnorm2x16", "PackUnorm2x16", "PackHalf2x16", "PackDouble2x32", "UnpackSnorm2x16", "UnpackUnorm2x16",
        "UnpackHalf2x16", "UnpackSnorm4x8", "UnpackUnorm4x8", "UnpackDouble2x32", "Length", "Distance", "Cross",
        "Normalize", "FaceForward", "Reflect", "Refract", "FindILsb", "FindSMsb", "FindUMsb",
        "InterpolateAtCentroid", "InterpolateAtSample", "InterpolateAtOffset", "NMin", "NMax", "NClamp"};
    if (op < sizeof names / sizeof names[0]) return std::string("GLSL.std.450 ") + names[op];
    return "GLSL.std.450 instruction " + std::to_string(op);
}

namespace {

// One lane of instruction `op`: run_std450 with one lane.
bool run_lane(std::uint32_t op, MathMode mode, Kind scalar, std::uint32_t n, const Std450Args& a,
              std::uint32_t* result) {
    // Component i of the result.
    const auto out_at = [&](std::uint32_t i) -> std::uint32_t& { return result[i * a.stride]; };
    if (is_elementary(op)) {
        for (std::uint32_t i = 0; i < n; ++i)
            out_at(i) = w(elementary(op, mode, f(at(a, 0, i)), a.count > 1 ? f(at(a, 1, i)) : 0.0f));
        return true;
    }
    const auto each = [&](auto fn) {
        for (std::uint32_t i = 0; i < n; ++i) out_at(i) = fn(i);
        return true;
    };
    const auto x = [&](std::uint32_t i) { return f(at(a, 0, i)); };
    const auto y = [&](std::uint32_t i) { return f(at(a, 1, i)); };
    const auto z = [&](std::uint32_t i) { return f(at(a, 2, i)); };
    const auto sx = [&](std::uint32_t i) { return static_cast<std::int32_t>(at(a, 0, i)); };
    const auto sy = [&](std::uint32_t i) { return static_cast<std::int32_t>(at(a, 1, i)); };
    const auto sz = [&](std::uint32_t i) { return static_cast<std::int32_t>(at(a, 2, i)); };
    const auto ux = [&](std::uint32_t i) { return at(a, 0, i); };
    const auto uy = [&](std::uint32_t i) { return at(a, 1, i); };
    const auto uz = [&](std::uint32_t i) { return at(a, 2, i); };
    (void)scalar;
    switch (op) {
        case GLSLstd450Round:
        case GLSLstd450RoundEven: return each([&](std::uint32_t i) { return w(std::nearbyint(x(i))); });
        case GLSLstd450Trunc: return each([&](std::uint32_t i) { return w(std::trunc(x(i))); });
        case GLSLstd450FAbs: return each([&](std::uint32_t i) { return w(std::fabs(x(i))); });
        case GLSLstd450SAbs:
            return each([&](std::uint32_t i) { return sx(i) < 0 ? 0u - ux(i) : ux(i); });
        case GLSLstd450FSign:
            return each([&](std::uint32_t i) {
                const float v = x(i);
                return w(v > 0.0f ? 1.0f : v < 0.0f ? -1.0f : v);  // +-0 and NaN as they are
            });
        case GLSLstd450SSign:
            return each([&](std::uint32_t i) { return static_cast<std::uint32_t>(sx(i) > 0 ? 1 : sx(i) < 0 ? -1 : 0); });
        case GLSLstd450Floor: return each([&](std::uint32_t i) { return w(std::floor(x(i))); });
        case GLSLstd450Ceil: return each([&](std::uint32_t i) { return w(std::ceil(x(i))); });
        case GLSLstd450Fract:
            return each([&](std::uint32_t i) {
                const float fl = std::floor(x(i));
                return w(x(i) - fl);
            });
        case GLSLstd450FMin:
        case GLSLstd450NMin: return each([&](std::uint32_t i) { return w(std::fmin(x(i), y(i))); });
        case GLSLstd450FMax:
        case GLSLstd450NMax: return each([&](std::uint32_t i) { return w(std::fmax(x(i), y(i))); });
        case GLSLstd450FClamp:
        case GLSLstd450NClamp: return each([&](std::uint32_t i) { return w(clampf(x(i), y(i), z(i))); });
        case GLSLstd450UMin: return each([&](std::uint32_t i) { return std::min(ux(i), uy(i)); });
        case GLSLstd450UMax: return each([&](std::uint32_t i) { return std::max(ux(i), uy(i)); });
        case GLSLstd450SMin: return each([&](std::uint32_t i) { return static_cast<std::uint32_t>(std::min(sx(i), sy(i))); });
        case GLSLstd450SMax: return each([&](std::uint32_t i) { return static_cast<std::uint32_t>(std::max(sx(i), sy(i))); });
        case GLSLstd450UClamp: return each([&](std::uint32_t i) { return std::min(std::max(ux(i), uy(i)), uz(i)); });
        case GLSLstd450SClamp:
            return each([&](std::uint32_t i) { return static_cast<std::uint32_t>(std::min(std::max(sx(i), sy(i)), sz(i))); });
        case GLSLstd450FMix:
            return each([&](std::uint32_t i) {
                const float difference = y(i) - x(i);
                const float scaled = z(i) * difference;
                return w(x(i) + scaled);
            });
        case GLSLstd450Step: return each([&](std::uint32_t i) { return w(y(i) < x(i) ? 0.0f : 1.0f); });
        case GLSLstd450SmoothStep:
            return each([&](std::uint32_t i) {
                const float t = clampf((z(i) - x(i)) / (y(i) - x(i)), 0.0f, 1.0f);
                const float t2 = t * t;
                const float twice = 2.0f * t;
                return w(t2 * (3.0f - twice));
            });
        case GLSLstd450Fma: return each([&](std::uint32_t i) { return w(std::fma(x(i), y(i), z(i))); });
        case GLSLstd450Ldexp:
            return each([&](std::uint32_t i) { return w(std::ldexp(x(i), std::clamp(sy(i), -300, 300))); });
        case GLSLstd450Length: {
            const float d = dot_product(a.value[0], a.value[0], a.components[0], a.stride, mode);
            out_at(0) = w(elementary(GLSLstd450Sqrt, mode, d));
            return true;
        }
        case GLSLstd450Distance: {
            std::uint32_t diff[4] = {0, 0, 0, 0};
            for (std::uint32_t i = 0; i < a.components[0] && i < 4; ++i) diff[i] = w(x(i) - y(i));
            const float d = dot_product(diff, diff, std::min<std::uint32_t>(a.components[0], 4), 1, mode);
            out_at(0) = w(elementary(GLSLstd450Sqrt, mode, d));
            return true;
        }
        case GLSLstd450Normalize: {
            const float d = dot_product(a.value[0], a.value[0], a.components[0], a.stride, mode);
            const float r = elementary(GLSLstd450InverseSqrt, mode, d);
            return each([&](std::uint32_t i) { return w(x(i) * r); });
        }
        case GLSLstd450Cross: {
            const auto c = [&](int p, int q) {
                const float l = x(static_cast<std::uint32_t>(p)) * y(static_cast<std::uint32_t>(q));
                const float r = y(static_cast<std::uint32_t>(p)) * x(static_cast<std::uint32_t>(q));
                return w(l - r);
            };
            out_at(0) = c(1, 2);
            out_at(1) = c(2, 0);
            out_at(2) = c(0, 1);
            return true;
        }
        case GLSLstd450FaceForward: {
            // faceforward(N, I, Nref) = dot(Nref, I) < 0 ? N : -N
            const float d = dot_product(a.value[2], a.value[1], a.components[0], a.stride, mode);
            return each([&](std::uint32_t i) { return w(d < 0.0f ? x(i) : -x(i)); });
        }
        case GLSLstd450Reflect: {
            // reflect(I, N) = I - 2 * dot(N, I) * N
            const float d = dot_product(a.value[1], a.value[0], a.components[0], a.stride, mode);
            const float twice = 2.0f * d;
            return each([&](std::uint32_t i) {
                const float s = twice * y(i);
                return w(x(i) - s);
            });
        }
        case GLSLstd450FindILsb:
            return each([&](std::uint32_t i) { return ux(i) == 0 ? 0xffffffffu : static_cast<std::uint32_t>(std::countr_zero(ux(i))); });
        case GLSLstd450FindUMsb:
            return each([&](std::uint32_t i) { return ux(i) == 0 ? 0xffffffffu : 31u - static_cast<std::uint32_t>(std::countl_zero(ux(i))); });
        case GLSLstd450FindSMsb:
            return each([&](std::uint32_t i) {
                const std::uint32_t v = sx(i) < 0 ? ~ux(i) : ux(i);
                return v == 0 ? 0xffffffffu : 31u - static_cast<std::uint32_t>(std::countl_zero(v));
            });
        default: return false;
    }
}


// The component-wise float instructions the shipped evaluation shaders use most, over all
// lanes at once: one loop per component that the compiler vectorises (the same operations
// as run_lane's, each rounded on its own). `op` is known at compile time.
template <std::uint32_t kOp>
void each_lane(std::uint32_t n, const Std450Args& a, std::uint32_t lanes, std::uint32_t* result) {
    for (std::uint32_t i = 0; i < n; ++i) {
        // Component i of argument k, lane by lane (a scalar argument is the same component).
        const auto arg = [&](int k) { return a.components[k] == 1 ? a.value[k] : a.value[k] + i * a.stride; };
        const std::uint32_t* __restrict x = arg(0);
        const std::uint32_t* __restrict y = a.count > 1 ? arg(1) : x;
        const std::uint32_t* __restrict z = a.count > 2 ? arg(2) : x;
        std::uint32_t* __restrict out = result + i * a.stride;
        for (std::uint32_t l = 0; l < lanes; ++l) {
            if constexpr (kOp == GLSLstd450FMix) {
                const float difference = f(y[l]) - f(x[l]);
                const float scaled = f(z[l]) * difference;
                out[l] = w(f(x[l]) + scaled);
            } else if constexpr (kOp == GLSLstd450FAbs) {
                out[l] = w(std::fabs(f(x[l])));
            } else if constexpr (kOp == GLSLstd450FMin) {
                out[l] = w(std::fmin(f(x[l]), f(y[l])));
            } else if constexpr (kOp == GLSLstd450FMax) {
                out[l] = w(std::fmax(f(x[l]), f(y[l])));
            } else if constexpr (kOp == GLSLstd450FClamp) {
                out[l] = w(clampf(f(x[l]), f(y[l]), f(z[l])));
            } else if constexpr (kOp == GLSLstd450Floor) {
                out[l] = w(std::floor(f(x[l])));
            }
        }
    }
}

}  // namespace

bool run_std450(std::uint32_t op, MathMode mode, Kind scalar, std::uint32_t n, const Std450Args& a,
                std::uint32_t lanes, std::uint32_t* result) {
    // The lanes of a float result, each component in its own row (result and arguments
    // never overlap: SPIR-V's ids are assigned once, each its own registers).
    if (scalar == Kind::float_ && lanes > 1) {
        switch (op) {
            case GLSLstd450FMix: each_lane<GLSLstd450FMix>(n, a, lanes, result); return true;
            case GLSLstd450FAbs: each_lane<GLSLstd450FAbs>(n, a, lanes, result); return true;
            case GLSLstd450FMin:
            case GLSLstd450NMin: each_lane<GLSLstd450FMin>(n, a, lanes, result); return true;
            case GLSLstd450FMax:
            case GLSLstd450NMax: each_lane<GLSLstd450FMax>(n, a, lanes, result); return true;
            case GLSLstd450FClamp:
            case GLSLstd450NClamp: each_lane<GLSLstd450FClamp>(n, a, lanes, result); return true;
            case GLSLstd450Floor: each_lane<GLSLstd450Floor>(n, a, lanes, result); return true;
            default: break;
        }
    }
    Std450Args lane = a;
    for (std::uint32_t l = 0; l < lanes; ++l) {
        for (std::uint32_t k = 0; k < a.count; ++k) lane.value[k] = a.value[k] + l;
        if (!run_lane(op, mode, scalar, n, lane, result + l)) return false;
    }
    return true;
}

}  // namespace tessref::shader
