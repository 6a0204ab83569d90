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
#include <bit>
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

// "00" "01" .. "99".
constexpr auto kPairs = [] {
    std::array<char, 200> pairs{};
    for (int i = 0; i < 100; ++i) {
        pairs[static_cast<std::size_t>(2 * i)] = static_cast<char>('0' + i / 10);
        pairs[static_cast<std::size_t>(2 * i + 1)] = static_cast<char>('0' + i % 10);
    }
    return pairs;
}();

// The two digits of i < 100 as a 16-bit word, the first in the low byte.
std::uint64_t pair(std::uint32_t i) {
    return static_cast<std::uint64_t>(static_cast<unsigned char>(kPairs[2 * i])) |
           static_cast<std::uint64_t>(static_cast<unsigned char>(kPairs[2 * i + 1])) << 8;
}

// Stores v's bytes at p, its lowest byte first, on any machine's byte order.
void store8(char* p, std::uint64_t v) {
    if constexpr (std::endian::native == std::endian::big) v = __builtin_bswap64(v);
    std::memcpy(p, &v, sizeof v);
}

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

    // The nine digits as text: the first, and the other eight as one 64-bit word of four
    // pairs from a table, the second digit in its lowest byte. The digit-at-a-time
    // divisions by ten were half of this function's time, and eight bytes stored one at a
    // time and read back as a word stalled the store buffer.
    const auto whole9 = static_cast<std::uint32_t>(digits);
    const std::uint32_t first = whole9 / 100000000u, rest = whole9 - first * 100000000u;
    const std::uint32_t high = rest / 10000u, low = rest - high * 10000u;
    const char lead = static_cast<char>('0' + first);
    const std::uint64_t tail = pair(high / 100u) | pair(high % 100u) << 16 | pair(low / 100u) << 32 | pair(low % 100u) << 48;
    // Significant digits kept: trailing zeros go, as %g drops them.
    int n = 9;
    if (rest == 0) {
        n = 1;
    } else {
        std::uint32_t last = low;
        if (low == 0) {
            n = 5;
            last = high;
        }
        while (last % 10u == 0) {
            last /= 10u;
            --n;
        }
    }

    // Whole words are stored; the end moves back over what %g drops (kFloatTextMax).
    char* p = out;
    if (x < 0) *p++ = '-';
    if (k < -4 || k >= 9) {  // d.dddddddde+XX
        *p++ = lead;
        if (n > 1) {
            *p++ = '.';
            store8(p, tail);
            p += n - 1;
        }
        *p++ = 'e';
        *p++ = k < 0 ? '-' : '+';
        const int e = k < 0 ? -k : k;
        if (e >= 10) *p++ = static_cast<char>('0' + e / 10);
        else *p++ = '0';
        *p++ = static_cast<char>('0' + e % 10);
    } else if (k >= 0) {  // ddd.ddd: k + 1 digits before the point
        *p = lead;
        store8(p + 1, tail);
        p += k + 1;
        if (n > k + 1) {  // then k <= 7: the digits after the point are the tail's from byte k on
            *p = '.';
            store8(p + 1, tail >> (8 * k));
            p += n - k;
        }
    } else {  // 0.000ddd: -k - 1 zeros after the point
        *p++ = '0';
        *p++ = '.';
        std::memcpy(p, "0000", 4);  // -k - 1 <= 3 zeros
        p += -k - 1;
        *p = lead;
        store8(p + 1, tail);
        p += n;
    }
    return p;
}

}  // namespace tessref
