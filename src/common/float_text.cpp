// src/common/float_text.h: "%.9g" of a float without printf.
//
// How: a finite non-zero float x is exact in a double. With k = floor(log10 |x|), the nine
// digits are |x| * 10^(8 - k) rounded to the nearest integer (ties to even, as printf
// rounds the exact value). In double that product is off by at most two roundings, the
// power of ten's and the product's: a relative 2^-52, under 2.3e-7 on a value below 1e9.
// So wherever the product is further than 1e-6 from a half, rounding it gives printf's
// digits; the rare rest (and exact ties) go to std::to_chars, which the standard defines
// as printf's "%.*g" (libstdc++'s Ryu, exact but 4x slower than this). tests/test_capture.cpp
// holds the whole function to snprintf on millions of floats.
#include "common/float_text.h"

#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace tessref {

namespace {

// 10^p for p in -31..54: 8 - k over every float's decade k (-45..38), with one to spare on
// each side for the correction of k below. The literals are correctly rounded doubles.
constexpr int kLowestPower = -31;
constexpr std::array<double, 86> kPowers = {
    1e-31, 1e-30, 1e-29, 1e-28, 1e-27, 1e-26, 1e-25, 1e-24, 1e-23, 1e-22, 1e-21, 1e-20, 1e-19, 1e-18, 1e-17,
    1e-16, 1e-15, 1e-14, 1e-13, 1e-12, 1e-11, 1e-10, 1e-9,  1e-8,  1e-7,  1e-6,  1e-5,  1e-4,  1e-3,  1e-2,
    1e-1,  1e0,   1e1,   1e2,   1e3,   1e4,   1e5,   1e6,   1e7,   1e8,   1e9,   1e10,  1e11,  1e12,  1e13,
    1e14,  1e15,  1e16,  1e17,  1e18,  1e19,  1e20,  1e21,  1e22,  1e23,  1e24,  1e25,  1e26,  1e27,  1e28,
    1e29,  1e30,  1e31,  1e32,  1e33,  1e34,  1e35,  1e36,  1e37,  1e38,  1e39,  1e40,  1e41,  1e42,  1e43,
    1e44,  1e45,  1e46,  1e47,  1e48,  1e49,  1e50,  1e51,  1e52,  1e53,  1e54};

char* slow(char* out, float x) {
    return std::to_chars(out, out + kFloatTextMax, x, std::chars_format::general, 9).ptr;
}

}  // namespace

char* write_float_g9(char* out, float x) {
    if (!std::isfinite(x) || x == 0.0f) return slow(out, x);  // "0", "-0", "nan", "inf" and signs
    const double a = std::fabs(static_cast<double>(x));
    // k from the binary exponent (floor(e * log10(2)), 78913 / 2^18 = 0.301029...), then
    // corrected by one either way.
    std::uint64_t bits = 0;
    std::memcpy(&bits, &a, sizeof bits);
    const int e2 = static_cast<int>(bits >> 52) - 1023;  // a = 1.f * 2^e2 (a double: no denormal)
    int k = (e2 * 78913) >> 18;                          // arithmetic shift: floor for negatives too
    double y = a * kPowers[static_cast<std::size_t>(8 - k - kLowestPower)];
    if (y >= 1e9) {
        ++k;
        y = a * kPowers[static_cast<std::size_t>(8 - k - kLowestPower)];
    } else if (y < 1e8) {
        --k;
        y = a * kPowers[static_cast<std::size_t>(8 - k - kLowestPower)];
    }
    const double whole = static_cast<double>(static_cast<std::uint64_t>(y));  // y > 0: floor
    if (std::fabs(y - whole - 0.5) < 1e-6) return slow(out, x);  // too near a tie to tell
    std::uint64_t digits = static_cast<std::uint64_t>(whole) + (y - whole > 0.5 ? 1 : 0);
    if (digits >= 1000000000u) {  // 999999999.5 and up: the next decade's 1
        digits /= 10;
        ++k;
    }
    if (digits < 100000000u) return slow(out, x);  // cannot happen; never guess

    char d[20] = {};  // nine digits, and room for the whole-word copies below
    for (int i = 8; i >= 0; --i) {
        d[i] = static_cast<char>('0' + digits % 10);
        digits /= 10;
    }
    int n = 9;  // significant digits kept: trailing zeros go, as %g drops them
    while (n > 1 && d[n - 1] == '0') --n;

    char* p = out;
    if (x < 0) *p++ = '-';
    if (k < -4 || k >= 9) {  // d.dddddddde+XX
        *p++ = d[0];
        if (n > 1) {
            *p++ = '.';
            std::memcpy(p, d + 1, 8);  // whole words; the end moves back over what %g drops
            p += n - 1;
        }
        *p++ = 'e';
        *p++ = k < 0 ? '-' : '+';
        const int e = k < 0 ? -k : k;
        if (e >= 10) *p++ = static_cast<char>('0' + e / 10);
        else *p++ = '0';
        *p++ = static_cast<char>('0' + e % 10);
    } else if (k >= 0) {  // ddd.ddd: k + 1 digits before the point
        std::memcpy(p, d, 9);
        p += k + 1;
        if (n > k + 1) {
            *p = '.';
            std::memcpy(p + 1, d + k + 1, 8);
            p += n - k;
        }
    } else {  // 0.000ddd: -k - 1 zeros after the point
        *p++ = '0';
        *p++ = '.';
        std::memcpy(p, "0000", 4);  // -k - 1 <= 3 zeros
        p += -k - 1;
        std::memcpy(p, d, 9);
        p += n;
    }
    return p;
}

}  // namespace tessref
