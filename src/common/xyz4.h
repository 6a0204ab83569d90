#pragma once
// Four 3-vectors held as SSE2 registers of their x, y and z components (four lanes each),
// written to memory as four consecutive glm::vec3 (48 bytes: x0 y0 z0 x1 | y1 z1 x2 y2 |
// z2 x3 y3 z3). The batched evaluation and geometry stages compute four points at a time
// that way and store them where the scalar code writes one.
#if defined(__SSE2__)
#include <emmintrin.h>

namespace tessref {

inline void store_xyz4(float* dst, __m128 x, __m128 y, __m128 z) {
    const __m128 xy01 = _mm_unpacklo_ps(x, y);                             // x0 y0 x1 y1
    const __m128 xy23 = _mm_unpackhi_ps(x, y);                             // x2 y2 x3 y3
    const __m128 z0x1 = _mm_shuffle_ps(z, x, _MM_SHUFFLE(1, 1, 0, 0));     // z0 z0 x1 x1
    const __m128 y1z1 = _mm_shuffle_ps(y, z, _MM_SHUFFLE(1, 1, 1, 1));     // y1 y1 z1 z1
    const __m128 z2z3 = _mm_shuffle_ps(z, xy23, _MM_SHUFFLE(3, 2, 3, 2));  // z2 z3 x3 y3
    _mm_storeu_ps(dst, _mm_shuffle_ps(xy01, z0x1, _MM_SHUFFLE(2, 0, 1, 0)));
    _mm_storeu_ps(dst + 4, _mm_shuffle_ps(y1z1, xy23, _MM_SHUFFLE(1, 0, 2, 0)));
    _mm_storeu_ps(dst + 8, _mm_shuffle_ps(z2z3, z2z3, _MM_SHUFFLE(1, 3, 2, 0)));
}

}  // namespace tessref
#endif
