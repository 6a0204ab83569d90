// src/common/unorm8.h — float to 8-bit normalized codes, as GL converts a colour for a
// unorm8 framebuffer: NaN to 0, clamp to [0, 1], times 255, rounded to nearest even.
// One place for the rendered image, the rasterizer's framebuffer and written pictures, so
// that their codes cannot drift apart; without a libm call per sample (the build targets
// baseline x86-64, where lrint and nearbyint are calls: a twentieth of a small render).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

namespace tessref {

// static_cast<int>(std::nearbyint(x)) under the default rounding mode, for |x| < 2^31.
inline int round_even(float x) {
#if defined(__SSE2__)
    return _mm_cvtss_si32(_mm_set_ss(x));
#else
    return static_cast<int>(std::nearbyint(x));
#endif
}

inline std::uint8_t unorm8(float v) {
    v = std::isnan(v) ? 0.0f : std::clamp(v, 0.0f, 1.0f);
    return static_cast<std::uint8_t>(round_even(v * 255.0f));
}

// unorm8 of the four channels of one RGBA colour: out[c] = unorm8(v[c]). With SSE2 the four
// at once, the same steps lane by lane: maxps returns its second operand (0) when the first
// is NaN or when both are zeros (clamp keeps a -0, which times 255 rounds to 0 all the
// same), minps clamps to 1, then times 255, rounded to nearest even by the default MXCSR
// mode as round_even is.
inline void unorm8_rgba(const float v[4], std::uint8_t out[4]) {
#if defined(__SSE2__)
    const __m128 x = _mm_min_ps(_mm_max_ps(_mm_loadu_ps(v), _mm_setzero_ps()), _mm_set1_ps(1.0f));
    const __m128i codes = _mm_cvtps_epi32(_mm_mul_ps(x, _mm_set1_ps(255.0f)));
    const __m128i bytes = _mm_packus_epi16(_mm_packs_epi32(codes, codes), codes);
    const int packed = _mm_cvtsi128_si32(bytes);
    std::memcpy(out, &packed, 4);
#else
    for (int c = 0; c < 4; ++c) out[c] = unorm8(v[c]);
#endif
}

}  // namespace tessref
