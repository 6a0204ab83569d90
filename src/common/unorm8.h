// src/common/unorm8.h — float to 8-bit normalized codes, as GL converts a colour for a
// unorm8 framebuffer: NaN to 0, clamp to [0, 1], times 255, rounded to nearest even.
// One place for the rendered image, the rasterizer's framebuffer and written pictures, so
// that their codes cannot drift apart; without a libm call per sample (the build targets
// baseline x86-64, where lrint and nearbyint are calls: a twentieth of a small render).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

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

}  // namespace tessref
