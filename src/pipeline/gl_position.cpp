// gl_position.cpp — project_vertices, baseline and AVX2.
#include "pipeline/gl_position.h"

#include <cmath>
#include <limits>
#include <type_traits>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

#include "common/simd.h"

namespace tessref::pipeline {

namespace {

template <typename P>
bool project_each(const P* q, std::size_t n, const glm::mat4& m, glm::vec4* clip) {
    bool finite = true;
    for (std::size_t v = 0; v < n; ++v) {
        // No short circuit: a loop without branches.
        finite &= std::isfinite(q[v].x) & std::isfinite(q[v].y) & std::isfinite(q[v].z);
        clip[v] = gl_position(m, glm::vec3(q[v]));
    }
    return finite;
}

#if defined(__x86_64__) && defined(__GNUC__)
// project_each eight vertices at a time with AVX2 (SimdLevel::avx2): the positions loaded
// (double ones rounded to float, vcvtpd2ps as cvtsd2ss) and sorted by component, each clip
// component summed as gl_position sums it, ((m0 x + m1 y) + m2 z) + m3, a rounding a step,
// then transposed back to one vec4 a vertex. Finite: |c| < infinity, false for a NaN, as
// std::isfinite, on the position as given (a double one before its rounding), as
// project_each checks it.
template <typename P>
[[gnu::target("avx2")]] bool project_avx2(const P* q, std::size_t n, const glm::mat4& m, glm::vec4* clip) {
    using S = typename P::value_type;
    static_assert(sizeof(P) == 3 * sizeof(S) && sizeof(glm::vec4) == 16);
    const S* d = &q[0].x;
    __m256d finite_d = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
    __m128 finite_f = _mm_castsi128_ps(_mm_set1_epi32(-1));
    std::size_t v = 0;
    for (; v + 8 <= n; v += 8) {
        // The 24 components of the eight positions as six groups of four in float:
        // (x0 y0 z0 x1), (y1 z1 x2 y2), (z2 x3 y3 z3), then vertices 4-7 likewise: plain
        // loads (gathers of each component measured slower on this project's machine), a
        // double group rounded to float (vcvtpd2ps, as cvtsd2ss) and checked finite.
        __m128 f[6];
        for (int k = 0; k < 6; ++k) {
            if constexpr (std::is_same_v<S, double>) {
                const __m256d q4 = _mm256_loadu_pd(d + 3 * v + 4 * k);
                const __m256d magnitude = _mm256_and_pd(q4, _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffff)));
                finite_d = _mm256_and_pd(
                    finite_d, _mm256_cmp_pd(magnitude, _mm256_set1_pd(std::numeric_limits<double>::infinity()), _CMP_LT_OQ));
                f[k] = _mm256_cvtpd_ps(q4);
            } else {
                f[k] = _mm_loadu_ps(d + 3 * v + 4 * k);
                const __m128 magnitude = _mm_and_ps(f[k], _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff)));
                finite_f = _mm_and_ps(finite_f,
                                      _mm_cmp_ps(magnitude, _mm_set1_ps(std::numeric_limits<float>::infinity()), _CMP_LT_OQ));
            }
        }
        const __m256 a = _mm256_set_m128(f[3], f[0]), b = _mm256_set_m128(f[4], f[1]), cc = _mm256_set_m128(f[5], f[2]);
        // Three-component structures to components, in each half (x2 y2 x3 y3, y0 z0 y1 z1).
        const __m256 x2y2x3y3 = _mm256_shuffle_ps(b, cc, _MM_SHUFFLE(2, 1, 3, 2));
        const __m256 y0z0y1z1 = _mm256_shuffle_ps(a, b, _MM_SHUFFLE(1, 0, 2, 1));
        const __m256 c[3] = {_mm256_shuffle_ps(a, x2y2x3y3, _MM_SHUFFLE(2, 0, 3, 0)),
                             _mm256_shuffle_ps(y0z0y1z1, x2y2x3y3, _MM_SHUFFLE(3, 1, 2, 0)),
                             _mm256_shuffle_ps(y0z0y1z1, cc, _MM_SHUFFLE(3, 0, 3, 1))};  // x, y, z in float
        __m256 out[4];  // clip x, y, z, w of the eight vertices
        for (int r = 0; r < 4; ++r) {
            __m256 sum = _mm256_mul_ps(_mm256_set1_ps(m[0][r]), c[0]);
            sum = _mm256_add_ps(sum, _mm256_mul_ps(_mm256_set1_ps(m[1][r]), c[1]));
            sum = _mm256_add_ps(sum, _mm256_mul_ps(_mm256_set1_ps(m[2][r]), c[2]));
            out[r] = _mm256_add_ps(sum, _mm256_set1_ps(m[3][r]));
        }
        // 4 x 8 -> 8 x 4: within each 128-bit half the usual 4 x 4 transpose, then the halves
        // hold vertices 0-3 and 4-7.
        const __m256 t0 = _mm256_unpacklo_ps(out[0], out[1]), t1 = _mm256_unpackhi_ps(out[0], out[1]);
        const __m256 t2 = _mm256_unpacklo_ps(out[2], out[3]), t3 = _mm256_unpackhi_ps(out[2], out[3]);
        const __m256 v0 = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0));
        const __m256 v1 = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2));
        const __m256 v2 = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(1, 0, 1, 0));
        const __m256 v3 = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(3, 2, 3, 2));
        float* o = &clip[v].x;
        _mm256_storeu_ps(o + 0, _mm256_permute2f128_ps(v0, v1, 0x20));
        _mm256_storeu_ps(o + 8, _mm256_permute2f128_ps(v2, v3, 0x20));
        _mm256_storeu_ps(o + 16, _mm256_permute2f128_ps(v0, v1, 0x31));
        _mm256_storeu_ps(o + 24, _mm256_permute2f128_ps(v2, v3, 0x31));
    }
    const bool all = _mm256_movemask_pd(finite_d) == 0xf && _mm_movemask_ps(finite_f) == 0xf;
    // The upper halves cleared before the baseline code that follows: GCC 12 leaves out its
    // own vzeroupper before this call, and the SSE2 instructions after it (the remainder, the
    // terrain evaluation that called this) would each wait on the dirty upper halves (a
    // level-63 render measured about 8 % more CPU).
    _mm256_zeroupper();
    return project_each(q + v, n - v, m, clip + v) & all;
}
#endif

template <typename P>
bool project(const P* q, std::size_t n, const glm::mat4& m, glm::vec4* clip) {
#if defined(__x86_64__) && defined(__GNUC__)
    if (simd_level() == SimdLevel::avx2) return project_avx2(q, n, m, clip);
#endif
    return project_each(q, n, m, clip);
}

}  // namespace

bool project_vertices(const glm::dvec3* q, std::size_t n, const glm::mat4& m, glm::vec4* clip) {
    return project(q, n, m, clip);
}
bool project_vertices(const glm::vec3* q, std::size_t n, const glm::mat4& m, glm::vec4* clip) {
    return project(q, n, m, clip);
}

}  // namespace tessref::pipeline
