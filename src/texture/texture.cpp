// Texture: the mip pyramid as glGenerateMipmap builds it and texture()/textureLod() as a
// GL 4.5 sampler with clamp-to-edge evaluates them (see tessref/texture.h for the
// conventions and for what was measured against llvmpipe).
//
// The GPU path must not let the compiler fuse a multiply and an add that llvmpipe rounds
// separately (u = s * width - 0.5f), nor split the fma that llvmpipe fuses (the lerp): the
// lerp is written as std::fma and contraction is switched off for this file.
#if defined(__clang__)
#pragma clang fp contract(off)
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <type_traits>
#include <utility>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include "common/parallel.h"
#include "common/simd.h"
#include "common/unorm8.h"
#include "tessref/error.h"
#include "tessref/limits.h"
#include "tessref/texture.h"

namespace tessref {

const char* to_string(TexelFormat format) {
    switch (format) {
        case TexelFormat::unorm8: return "unorm8";
        case TexelFormat::unorm16: return "unorm16";
        case TexelFormat::float32: return "float32";
    }
    return "?";
}

const char* to_string(MipmapRule rule) {
    switch (rule) {
        case MipmapRule::llvmpipe_blit: return "llvmpipe_blit";
        case MipmapRule::mesa_software_box: return "mesa_software_box";
    }
    return "?";
}

namespace {

constexpr float kUnorm8Scale = 1.0f / 255.0f;      // llvmpipe: code * (float)(1/255)
constexpr float kUnorm16Scale = 1.0f / 65535.0f;   // llvmpipe: code * (float)(1/65535)

// ---- GPU path (float), llvmpipe's SoA filter for float32 / unorm16 ----------------------

// mix() as llvmpipe's lp_build_lerp emits it for floats: v0 + w * (v1 - v0), the multiply
// and add fused (LLVM's fmuladd on an FMA CPU).
inline float lerp_gpu(float v0, float v1, float w) { return std::fma(w, v1 - v0, v0); }

// The per-sample arithmetic without a libm call each (the build targets baseline x86-64,
// where fmin, fmax, floor and nearbyint are calls): the same values.
// std::fmax(u, lo) for a number lo: a NaN u gives lo.
inline float max_or(float u, float lo) { return u > lo ? u : lo; }
// std::fmin(u, hi) for u not NaN.
inline float min_of(float u, float hi) { return u < hi ? u : hi; }
// std::floor(u) for |u| < 2^31 (u here is clamped to a texture's size).
inline float floor_small(float u) {
    const float t = static_cast<float>(static_cast<int>(u));
    return t > u ? t - 1.0f : t;
}

struct AxisF {
    int i0 = 0;
    int i1 = 0;
    float weight = 0.0f;
};

// Texel-space coordinate for GL_LINEAR with GL_CLAMP_TO_EDGE: u = s * size - 0.5, the two
// texels floor(u) and floor(u) + 1 clamped to [0, size - 1], weight frac(u).
// Texel index i wrapped into [0, size) (GL_REPEAT: i mod size, for negative i too).
inline int wrap_index(int i, int size) { return ((i % size) + size) % size; }

inline AxisF axis_gpu(float s, int size, bool repeat = false) {
    const float size_f = static_cast<float>(size);
    if (repeat) s = s - std::floor(s);  // GL_REPEAT: fract(s), then the same filter, indices mod size
    float u = s * size_f;
    u = u - 0.5f;
    // Clamping u to [-1, size] changes no result (every texel index outside the texture
    // clamps to the same edge texel, and mix(a, a, w) == a) but keeps NaN and huge
    // coordinates away from the integer conversion: fmax/fmin return the non-NaN operand.
    u = min_of(max_or(u, -1.0f), size_f);
    const float fl = floor_small(u);
    AxisF axis;
    axis.weight = u - fl;
    const int i = static_cast<int>(fl);
    axis.i0 = repeat ? wrap_index(i, size) : std::clamp(i, 0, size - 1);
    axis.i1 = repeat ? wrap_index(i + 1, size) : std::clamp(i + 1, 0, size - 1);
    return axis;
}

// ---- GPU path, llvmpipe's 8-bit fixed-point (AoS) filter for unorm8 ---------------------

struct AxisU8 {
    int i0 = 0;
    int i1 = 0;
    int weight = 0;  // 0..255, 8 fractional bits
};

inline AxisU8 axis_unorm8(float s, int size, bool repeat = false) {
    if (repeat) s = s - std::floor(s);
    // lp_build_sample_image_linear (AoS): s * float(size << 8), rounded to the nearest
    // integer, minus 128 (half a texel), then >> 8 and & 255.
    const float scaled_size = static_cast<float>(size * 256);
    float x = s * scaled_size;
    x = min_of(max_or(x, -1024.0f), scaled_size + 1024.0f);  // no effect; NaN-safe
    const int fixed = round_even(x) - 128;
    AxisU8 axis;
    axis.weight = fixed & 255;
    const int i = fixed >> 8;  // arithmetic shift: floor
    axis.i0 = repeat ? wrap_index(i, size) : std::clamp(i, 0, size - 1);
    axis.i1 = repeat ? wrap_index(i + 1, size) : std::clamp(i + 1, 0, size - 1);
    return axis;
}

// lp_build_lerp on 8-bit unorm codes widened to 16 bits, weights prescaled (0..255 = w/256),
// rounded: v0 + ((w * (v1 - v0) + 128) >> 8).
inline int lerp_unorm8(int v0, int v1, int weight) {
    return v0 + ((weight * (v1 - v0) + 128) >> 8);
}

// ---- double path --------------------------------------------------------------------------

// mix(x, y, a) as x + a * (y - x): exactly x when x == y or a == 0, so a constant image stays
// exactly constant through the pyramid and texel centres return texels.
inline double mix_exact(double x, double y, double a) { return x + a * (y - x); }

struct AxisD {
    int i0 = 0;
    int i1 = 0;
    double weight = 0.0;
};

inline AxisD axis_exact(double s, int size, bool repeat = false) {
    const double size_d = static_cast<double>(size);
    if (repeat) s = s - std::floor(s);
    double u = s * size_d - 0.5;
    u = std::fmin(std::fmax(u, -1.0), size_d);
    const double fl = std::floor(u);
    AxisD axis;
    axis.weight = u - fl;
    const int i = static_cast<int>(fl);
    axis.i0 = repeat ? wrap_index(i, size) : std::clamp(i, 0, size - 1);
    axis.i1 = repeat ? wrap_index(i + 1, size) : std::clamp(i + 1, 0, size - 1);
    return axis;
}

// ---- per-level bilinear samples -----------------------------------------------------------

inline std::size_t index_of(const TextureLevel& level, int channels, int x, int y, int c) {
    return (static_cast<std::size_t>(y) * static_cast<std::size_t>(level.width) +
            static_cast<std::size_t>(x)) * static_cast<std::size_t>(channels) +
           static_cast<std::size_t>(c);
}

// The two filters below are templates on the channel count: the texel offsets and the
// channel loop are then known at compile time (a runtime count left a loop and an index
// multiply around every fetch). The functions after them dispatch on the count once.

// Float filter on a float32/unorm16 level: out[c] for c < C, from the axes of s and t
// (axis_gpu on the level's width and height).
template <int C>
[[gnu::always_inline]] inline void bilinear_gpu_n(const TextureLevel& level, const AxisF& ax, const AxisF& ay,
                                                  float out[4]) {
    for (int c = 0; c < C; ++c) {
        const float t00 = level.texels[index_of(level, C, ax.i0, ay.i0, c)];
        const float t10 = level.texels[index_of(level, C, ax.i1, ay.i0, c)];
        const float t01 = level.texels[index_of(level, C, ax.i0, ay.i1, c)];
        const float t11 = level.texels[index_of(level, C, ax.i1, ay.i1, c)];
        // lp_build_lerp_2d: along s in both rows, then along t.
        out[c] = lerp_gpu(lerp_gpu(t00, t10, ax.weight), lerp_gpu(t01, t11, ax.weight),
                          ay.weight);
    }
}

// 8-bit filter on a unorm8 level: 8-bit codes, from the axes of s and t (axis_unorm8).
template <int C>
[[gnu::always_inline]] inline void bilinear_unorm8_n(const TextureLevel& level, const AxisU8& ax, const AxisU8& ay,
                                                     int out[4]) {
    for (int c = 0; c < C; ++c) {
        const int t00 = level.unorm8[index_of(level, C, ax.i0, ay.i0, c)];
        const int t10 = level.unorm8[index_of(level, C, ax.i1, ay.i0, c)];
        const int t01 = level.unorm8[index_of(level, C, ax.i0, ay.i1, c)];
        const int t11 = level.unorm8[index_of(level, C, ax.i1, ay.i1, c)];
        out[c] = lerp_unorm8(lerp_unorm8(t00, t10, ax.weight), lerp_unorm8(t01, t11, ax.weight),
                             ay.weight);
    }
}

// The functions that reach lerp_gpu (std::fma) are built twice on x86-64, with and without
// FMA instructions, and chosen at load: std::fma is then one instruction instead of a libm
// call (fma is exactly rounded either way: the same values). What they inline is compiled
// for each clone's target. Not under ThreadSanitizer: the clones' resolver runs while the
// dynamic loader relocates the executable, before TSan's runtime is set up, and GCC
// instruments it, so every sanitized program crashed before main.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__SANITIZE_THREAD__)
#define TESSREF_FMA_CLONES __attribute__((target_clones("fma", "default")))
#else
#define TESSREF_FMA_CLONES
#endif

TESSREF_FMA_CLONES
void bilinear_gpu(const TextureLevel& level, int channels, glm::vec2 st, float out[4], bool repeat = false) {
    const AxisF ax = axis_gpu(st.x, level.width, repeat);
    const AxisF ay = axis_gpu(st.y, level.height, repeat);
    switch (channels) {
        case 1: return bilinear_gpu_n<1>(level, ax, ay, out);
        case 2: return bilinear_gpu_n<2>(level, ax, ay, out);
        case 3: return bilinear_gpu_n<3>(level, ax, ay, out);
        default: return bilinear_gpu_n<4>(level, ax, ay, out);
    }
}

void bilinear_unorm8(const TextureLevel& level, int channels, glm::vec2 st, int out[4], bool repeat = false) {
    const AxisU8 ax = axis_unorm8(st.x, level.width, repeat);
    const AxisU8 ay = axis_unorm8(st.y, level.height, repeat);
    switch (channels) {
        case 1: return bilinear_unorm8_n<1>(level, ax, ay, out);
        case 2: return bilinear_unorm8_n<2>(level, ax, ay, out);
        case 3: return bilinear_unorm8_n<3>(level, ax, ay, out);
        default: return bilinear_unorm8_n<4>(level, ax, ay, out);
    }
}

// The axis of the last coordinate asked for, reused while the coordinate keeps its bits:
// consecutive points of a patch share one coordinate along most of a ring of the
// generator's output (the axis is a function of the coordinate's bits alone).
template <bool Unorm8>
struct LastAxis {
    using Axis = std::conditional_t<Unorm8, AxisU8, AxisF>;
    Axis axis;
    std::uint32_t bits = 0;
    bool valid = false;
    [[gnu::always_inline]] const Axis& operator()(float s, int size, bool repeat) {
        const std::uint32_t b = std::bit_cast<std::uint32_t>(s);
        if (!valid || b != bits) {
            if constexpr (Unorm8) axis = axis_unorm8(s, size, repeat);
            else axis = axis_gpu(s, size, repeat);
            bits = b;
            valid = true;
        }
        return axis;
    }
};

// Where a batch's samples go: texture() writes every channel (Out = glm::vec4), texture_red()
// the red one alone (Out = float), for callers that read nothing else (a height map's reads
// in the evaluation). One filter for both: only its last store differs.
[[gnu::always_inline]] inline void put(glm::vec4& out, const glm::vec4& sample) { out = sample; }
[[gnu::always_inline]] inline void put(float& out, const glm::vec4& sample) { out = sample.r; }
// A one-channel float level's sample as texture() returns it, (r, 0, 0, 1), or its r.
[[gnu::always_inline]] inline void put_r(glm::vec4& out, float r) { out = glm::vec4(r, 0.0f, 0.0f, 1.0f); }
[[gnu::always_inline]] inline void put_r(float& out, float r) { out = r; }

#if defined(__SSE2__)
// ---- the 8-bit filter, four coordinates at a time (SSE2) ------------------------------------
//
// The same integers as axis_unorm8 and bilinear_unorm8_n, for GL_CLAMP_TO_EDGE on a level of
// 2 x 2 to 32764 x 32764 texels. Each axis keeps its two texels adjacent: the pair (first,
// first + 1) with first = clamp(i, 0, size - 2), and the weight 0 where i < 0 (the lerp is then
// v0: texel 0, which both clamped indices read) and 256 where i > size - 2 (the lerp
// v0 + ((256 * (v1 - v0) + 128) >> 8) is then v1: texel size - 1, again what both clamped
// indices read). A row's two texels are then 2C consecutive bytes.
//
// The lerps run on 16-bit lanes. Their results are codes (0..255), so they are wanted only
// modulo 256, and v0 + ((w * d + 128) >> 8) modulo 256 needs only bits 8..15 of w * d + 128:
// the low 16 bits of the product (pmullw), a logical shift and a 16-bit add, masked to 8 bits
// (d in [-255, 255], w in [0, 256]).

// What the axes of one level need, set up once per batch.
struct AxisU8Setup {
    __m128 scale;      // float(size * 256)
    __m128 low;        // -1024
    __m128 high;       // float(size * 256) + 1024, as axis_unorm8 rounds it
    __m128i last;      // size - 2
    explicit AxisU8Setup(int size) {
        const float scaled_size = static_cast<float>(size * 256);
        scale = _mm_set1_ps(scaled_size);
        low = _mm_set1_ps(-1024.0f);
        high = _mm_set1_ps(scaled_size + 1024.0f);
        last = _mm_set1_epi32(size - 2);
    }
};

// axis_unorm8 of four coordinates (clamp to edge) as (first, weight), the weight in both
// 16-bit halves of its lane (a pshufd then spreads one point's weight over four or eight lanes).
struct AxesU8x4 {
    __m128i first;
    __m128i weight;
};

[[gnu::always_inline]] inline AxesU8x4 axes_unorm8_x4(__m128 s, const AxisU8Setup& setup) {
    // maxps/minps are max_or/min_of lane by lane (a NaN first operand gives the second);
    // cvtps2dq rounds by MXCSR, as round_even's cvtss2si.
    const __m128 x = _mm_min_ps(_mm_max_ps(_mm_mul_ps(s, setup.scale), setup.low), setup.high);
    const __m128i fixed = _mm_sub_epi32(_mm_cvtps_epi32(x), _mm_set1_epi32(128));
    // i = fixed >> 8 is in [-5, size + 3] and fixed - 256 * first in [-1152, 1535]: both fit
    // 16 bits, where the signed 16-bit max and min on a 32-bit lane (high half the sign) are
    // the 32-bit ones. The weight clamped to [0, 256] is 0 for i < 0, 256 for i > size - 2,
    // fixed & 255 between.
    const __m128i zero = _mm_setzero_si128();
    const __m128i first = _mm_min_epi16(_mm_max_epi16(_mm_srai_epi32(fixed, 8), zero), setup.last);
    const __m128i rest = _mm_sub_epi32(fixed, _mm_slli_epi32(first, 8));
    const __m128i weight = _mm_min_epi16(_mm_max_epi16(rest, zero), _mm_set1_epi32(256));
    return {first, _mm_or_si128(weight, _mm_slli_epi32(weight, 16))};
}

[[gnu::always_inline]] inline __m128i load_bytes4(const std::uint8_t* p) {
    std::uint32_t v;
    std::memcpy(&v, p, 4);
    return _mm_cvtsi32_si128(static_cast<int>(v));
}
[[gnu::always_inline]] inline __m128i load_bytes2(const std::uint8_t* p) {
    std::uint16_t v;
    std::memcpy(&v, p, 2);
    return _mm_cvtsi32_si128(v);
}

// v0 + ((w * (v1 - v0) + 128) >> 8) on 16-bit lanes holding codes, modulo 256 (see above):
// the low 8 bits of each lane are the code, and `mask` keeps them.
[[gnu::always_inline]] inline __m128i lerp_unorm8_x8(__m128i v0, __m128i v1, __m128i weight, __m128i mask) {
    const __m128i product = _mm_mullo_epi16(_mm_sub_epi16(v1, v0), weight);
    const __m128i step = _mm_srli_epi16(_mm_add_epi16(product, _mm_set1_epi16(128)), 8);
    return _mm_and_si128(_mm_add_epi16(v0, step), mask);
}

// One point's two rows lerped along s: lanes 0..C-1 row 0's channels, lanes 4..4+C-1 row 1's.
// row0: texel (first_s, first_t); the next row stride bytes on; wx: the s weight in all lanes.
template <int C>
[[gnu::always_inline]] inline __m128i rows_unorm8(const std::uint8_t* row0, std::size_t stride, __m128i wx) {
    const std::uint8_t* row1 = row0 + stride;
    const __m128i zero = _mm_setzero_si128();
    // v0: lanes 0..3 row 0's texel first_s, lanes 4..7 row 1's; v1 the same for first_s + 1.
    __m128i v0, v1;
    if constexpr (C <= 2) {
        // A row's two texels in one load of 2C bytes; v1 is v0 a texel on.
        const __m128i a = C == 1 ? load_bytes2(row0) : load_bytes4(row0);
        const __m128i b = C == 1 ? load_bytes2(row1) : load_bytes4(row1);
        v0 = _mm_unpacklo_epi8(_mm_unpacklo_epi32(a, b), zero);
        v1 = _mm_srli_si128(v0, 2 * C);
    } else {
        // The first texel from the 4 bytes at the pair's start, the second from the 4 bytes
        // that end the pair (for C = 3 one byte before it: a lane's shift puts it in place).
        v0 = _mm_unpacklo_epi8(_mm_unpacklo_epi32(load_bytes4(row0), load_bytes4(row1)), zero);
        v1 = _mm_unpacklo_epi8(_mm_unpacklo_epi32(load_bytes4(row0 + 2 * C - 4), load_bytes4(row1 + 2 * C - 4)),
                               zero);
        if constexpr (C == 3) v1 = _mm_srli_si128(v1, 2);
    }
    return lerp_unorm8_x8(v0, v1, wx, _mm_set1_epi16(255));
}

// Two points' samples from their rows_unorm8 (a, b) and t weights (wy: a's in lanes 0..3, b's
// in lanes 4..7): lp_build_lerp_2d's lerp along t, then (r, g, b, a) as texture_level0_n's
// scalar loop writes it.
template <int C>
[[gnu::always_inline]] inline void samples_unorm8_x2(__m128i a, __m128i b, __m128i wy, glm::vec4* out_a,
                                                     glm::vec4* out_b) {
    // The lanes of missing channels: g = b = 0 and a = 1 (code 255: 255 * (1/255) is 1.0f).
    const __m128i keep = _mm_set_epi16(C > 3 ? 255 : 0, C > 2 ? 255 : 0, C > 1 ? 255 : 0, 255, C > 3 ? 255 : 0,
                                       C > 2 ? 255 : 0, C > 1 ? 255 : 0, 255);
    __m128i codes = lerp_unorm8_x8(_mm_unpacklo_epi64(a, b), _mm_unpackhi_epi64(a, b), wy, keep);
    if constexpr (C < 4) codes = _mm_or_si128(codes, _mm_set_epi16(255, 0, 0, 0, 255, 0, 0, 0));
    const __m128i zero = _mm_setzero_si128();
    const __m128 scale = _mm_set1_ps(kUnorm8Scale);
    _mm_storeu_ps(&out_a->x, _mm_mul_ps(_mm_cvtepi32_ps(_mm_unpacklo_epi16(codes, zero)), scale));
    _mm_storeu_ps(&out_b->x, _mm_mul_ps(_mm_cvtepi32_ps(_mm_unpackhi_epi16(codes, zero)), scale));
}

// Four points: st[0..3] -> out[0..3].
template <int C>
[[gnu::always_inline]] inline void texture_unorm8_x4(const std::uint8_t* texels, std::size_t stride,
                                                     const AxisU8Setup& s_setup, const AxisU8Setup& t_setup,
                                                     const glm::vec2* st, glm::vec4* out) {
    const __m128 st01 = _mm_loadu_ps(&st[0].x);
    const __m128 st23 = _mm_loadu_ps(&st[2].x);
    const AxesU8x4 ax = axes_unorm8_x4(_mm_shuffle_ps(st01, st23, _MM_SHUFFLE(2, 0, 2, 0)), s_setup);
    const AxesU8x4 ay = axes_unorm8_x4(_mm_shuffle_ps(st01, st23, _MM_SHUFFLE(3, 1, 3, 1)), t_setup);
    // Byte offsets first_t * stride + first_s * C, in 64 bits: points 0 and 2 from the even
    // lanes, 1 and 3 from the odd ones (pmuludq multiplies the low halves of 64-bit lanes).
    __m128i xc = ax.first;
    if constexpr (C == 2) xc = _mm_slli_epi32(xc, 1);
    if constexpr (C == 3) xc = _mm_add_epi32(xc, _mm_slli_epi32(xc, 1));
    if constexpr (C == 4) xc = _mm_slli_epi32(xc, 2);
    const __m128i stride_v = _mm_set1_epi32(static_cast<int>(stride));
    const __m128i even = _mm_add_epi64(_mm_mul_epu32(ay.first, stride_v),
                                       _mm_and_si128(xc, _mm_set_epi32(0, -1, 0, -1)));
    const __m128i odd = _mm_add_epi64(_mm_mul_epu32(_mm_srli_epi64(ay.first, 32), stride_v), _mm_srli_epi64(xc, 32));
    alignas(16) std::uint64_t offset_even[2], offset_odd[2];
    _mm_store_si128(reinterpret_cast<__m128i*>(offset_even), even);
    _mm_store_si128(reinterpret_cast<__m128i*>(offset_odd), odd);
    const __m128i w = ax.weight;
    const __m128i r0 = rows_unorm8<C>(texels + offset_even[0], stride, _mm_shuffle_epi32(w, _MM_SHUFFLE(0, 0, 0, 0)));
    const __m128i r1 = rows_unorm8<C>(texels + offset_odd[0], stride, _mm_shuffle_epi32(w, _MM_SHUFFLE(1, 1, 1, 1)));
    const __m128i r2 = rows_unorm8<C>(texels + offset_even[1], stride, _mm_shuffle_epi32(w, _MM_SHUFFLE(2, 2, 2, 2)));
    const __m128i r3 = rows_unorm8<C>(texels + offset_odd[1], stride, _mm_shuffle_epi32(w, _MM_SHUFFLE(3, 3, 3, 3)));
    samples_unorm8_x2<C>(r0, r1, _mm_shuffle_epi32(ay.weight, _MM_SHUFFLE(1, 1, 0, 0)), out + 0, out + 1);
    samples_unorm8_x2<C>(r2, r3, _mm_shuffle_epi32(ay.weight, _MM_SHUFFLE(3, 3, 2, 2)), out + 2, out + 3);
}

// four(st + k, out + k, n) over points [0, count) four at a time: four reads four points and
// writes the samples of the first n of them (n = 4 but for the last one to three points, which
// are padded with copies of the last; what four writes beyond n is dropped).
template <class Out, class Four>
[[gnu::always_inline]] inline void in_fours(const glm::vec2* st, Out* out, std::size_t count, Four&& four) {
    std::size_t k = 0;
    for (; k + 4 <= count; k += 4) four(st + k, out + k, std::size_t{4});
    if (k < count) {
        glm::vec2 tail_st[4];
        Out tail_out[4];
        for (std::size_t j = 0; j < 4; ++j) tail_st[j] = st[std::min(k + j, count - 1)];
        four(tail_st, tail_out, count - k);
        for (std::size_t j = 0; k + j < count; ++j) out[k + j] = tail_out[j];
    }
}

// texture_level0_n's unorm8 clamp-to-edge case for a level of 2 x 2 to 32764 x 32764.
template <int C, class Out>
[[gnu::always_inline]] inline void texture_level0_unorm8_x4(const TextureLevel& level, const glm::vec2* st,
                                                            Out* out, std::size_t count) {
    const std::uint8_t* texels = level.unorm8.data();
    const std::size_t stride = static_cast<std::size_t>(level.width) * C;
    const AxisU8Setup s_setup(level.width), t_setup(level.height);
    in_fours(st, out, count, [&](const glm::vec2* st4, Out* out4, std::size_t) {
        if constexpr (std::is_same_v<Out, glm::vec4>) {
            texture_unorm8_x4<C>(texels, stride, s_setup, t_setup, st4, out4);
        } else {
            glm::vec4 samples[4];
            texture_unorm8_x4<C>(texels, stride, s_setup, t_setup, st4, samples);
            for (std::size_t j = 0; j < 4; ++j) put(out4[j], samples[j]);
        }
    });
}

// The levels texture_level0_unorm8_x4 takes.
inline bool unorm8_x4_fits(const TextureLevel& level) {
    return level.width >= 2 && level.height >= 2 && level.width <= 32764 && level.height <= 32764;
}

// ---- the float filter of a one-channel level: the axes four coordinates at a time --------
//
// axis_gpu's operations lane by lane, in the same order (multiply, subtract, max_or, min_of,
// floor_small, the clamped indices); the fetches and the lerps (lerp_gpu, an fma) stay
// bilinear_gpu_n<1>'s, point by point. For GL_CLAMP_TO_EDGE on a level of at most
// 32766 x 32766 texels: the index i = floor(u) is in [-1, size] and i + 1 fits 16 bits, where
// the signed 16-bit max and min on a 32-bit lane are the 32-bit ones.
struct AxesFx4 {
    alignas(16) std::int32_t i0[4];
    alignas(16) std::int32_t i1[4];
    alignas(16) float weight[4];
};

[[gnu::always_inline]] inline void axes_gpu_x4(__m128 s, __m128 size_f, __m128i last, AxesFx4& axes) {
    __m128 u = _mm_mul_ps(s, size_f);
    u = _mm_sub_ps(u, _mm_set1_ps(0.5f));
    u = _mm_min_ps(_mm_max_ps(u, _mm_set1_ps(-1.0f)), size_f);
    // floor_small: t = float(int(u)), minus 1 where t > u (the mask, -1 as an integer).
    const __m128i truncated = _mm_cvttps_epi32(u);
    const __m128 t = _mm_cvtepi32_ps(truncated);
    const __m128 above = _mm_cmpgt_ps(t, u);
    const __m128 fl = _mm_sub_ps(t, _mm_and_ps(above, _mm_set1_ps(1.0f)));
    const __m128i i = _mm_add_epi32(truncated, _mm_castps_si128(above));
    const __m128i zero = _mm_setzero_si128();
    _mm_store_ps(axes.weight, _mm_sub_ps(u, fl));
    _mm_store_si128(reinterpret_cast<__m128i*>(axes.i0), _mm_min_epi16(_mm_max_epi16(i, zero), last));
    const __m128i next = _mm_add_epi32(i, _mm_set1_epi32(1));
    _mm_store_si128(reinterpret_cast<__m128i*>(axes.i1), _mm_min_epi16(_mm_max_epi16(next, zero), last));
}

// texture_level0_n<1, false>'s clamp-to-edge case for a level of at most 32766 x 32766.
template <class Out>
[[gnu::always_inline]] inline void texture_level0_float1_x4(const TextureLevel& level, const glm::vec2* st,
                                                            Out* out, std::size_t count) {
    const __m128 width_f = _mm_set1_ps(static_cast<float>(level.width));
    const __m128 height_f = _mm_set1_ps(static_cast<float>(level.height));
    const __m128i last_s = _mm_set1_epi32(level.width - 1);
    const __m128i last_t = _mm_set1_epi32(level.height - 1);
    in_fours(st, out, count, [&](const glm::vec2* st4, Out* out4, std::size_t n) {
        const __m128 st01 = _mm_loadu_ps(&st4[0].x);
        const __m128 st23 = _mm_loadu_ps(&st4[2].x);
        AxesFx4 ax, ay;
        axes_gpu_x4(_mm_shuffle_ps(st01, st23, _MM_SHUFFLE(2, 0, 2, 0)), width_f, last_s, ax);
        axes_gpu_x4(_mm_shuffle_ps(st01, st23, _MM_SHUFFLE(3, 1, 3, 1)), height_f, last_t, ay);
        for (std::size_t j = 0; j < n; ++j) {
            const AxisF x{ax.i0[j], ax.i1[j], ax.weight[j]};
            const AxisF y{ay.i0[j], ay.i1[j], ay.weight[j]};
            float value[4];
            bilinear_gpu_n<1>(level, x, y, value);
            put_r(out4[j], value[0]);
        }
    });
}

// The levels texture_level0_float1_x4 takes.
inline bool float1_x4_fits(const TextureLevel& level) { return level.width <= 32766 && level.height <= 32766; }

// ---- the same, eight points at a time with AVX2 and FMA (SimdLevel::avx2) ----------------
//
// axes_gpu_x4's operations on eight lanes (the same instructions, VEX-encoded: vmaxps and
// vminps keep a NaN first operand's "give the second" rule), then what the four-point path
// leaves to bilinear_gpu_n<1> point by point: the four texels fetched (the index
// y * width + x fits 31 bits for the levels float1_x4_fits takes) and lp_build_lerp_2d's
// three lerps as vfmadd, which rounds once as std::fma does. Where the four-point path
// spends its time on the scalar fetches and lerps (12 % of a level-63 render of the bench
// terrain, the height-map reads of the evaluation), this one takes them eight at a time.
//
// A gather costs about a cycle an element here, so a row's two texels come as one 8-byte
// element: the pair (first, first + 1) with first = min(i0, width - 2), which holds both
// clamped indices (a level at least 2 wide): i0 is first, or first + 1 where i0 is the last
// column; i1 is first + 1, or first where the axis clamped both to column 0. Each texel is
// then the pair's half its index names, the same float either way.
#if defined(__x86_64__) && defined(__GNUC__)
#define TESSREF_HAVE_AVX2_VARIANTS 1

struct Axes8 {
    __m256i i0, i1;
    __m256 weight;
};

[[gnu::target("avx2,fma"), gnu::always_inline]] inline Axes8 axes_gpu_x8(__m256 s, __m256 size_f, __m256i last) {
    __m256 u = _mm256_mul_ps(s, size_f);
    u = _mm256_sub_ps(u, _mm256_set1_ps(0.5f));
    u = _mm256_min_ps(_mm256_max_ps(u, _mm256_set1_ps(-1.0f)), size_f);
    const __m256i truncated = _mm256_cvttps_epi32(u);
    const __m256 t = _mm256_cvtepi32_ps(truncated);
    const __m256 above = _mm256_cmp_ps(t, u, _CMP_GT_OS);
    const __m256 fl = _mm256_sub_ps(t, _mm256_and_ps(above, _mm256_set1_ps(1.0f)));
    const __m256i i = _mm256_add_epi32(truncated, _mm256_castps_si256(above));
    const __m256i zero = _mm256_setzero_si256();
    Axes8 axes;
    axes.weight = _mm256_sub_ps(u, fl);
    axes.i0 = _mm256_min_epi32(_mm256_max_epi32(i, zero), last);
    axes.i1 = _mm256_min_epi32(_mm256_max_epi32(_mm256_add_epi32(i, _mm256_set1_epi32(1)), zero), last);
    return axes;
}

[[gnu::target("avx2,fma"), gnu::always_inline]] inline __m256 lerp_gpu_x8(__m256 v0, __m256 v1, __m256 w) {
    return _mm256_fmadd_ps(w, _mm256_sub_ps(v1, v0), v0);
}

// (v0 v1 v4 v5 v2 v3 v6 v7) -> (v0 .. v7): the 64-bit pairs in order.
[[gnu::target("avx2,fma"), gnu::always_inline]] inline __m256 in_order(__m256 v) {
    return _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(v), _MM_SHUFFLE(3, 1, 2, 0)));
}

// The texel pairs (index, index + 1) of eight points, index[j] the texel of point j: the
// first texels in order (a), the second ones in order (b).
struct TexelPairs8 {
    __m256 a, b;
};
[[gnu::target("avx2,fma"), gnu::always_inline]] inline TexelPairs8 texel_pairs_x8(const float* texels, __m256i index) {
    const auto* base = reinterpret_cast<const long long*>(texels);
    // (a0 b0 a1 b1 a2 b2 a3 b3) and (a4 b4 .. a7 b7), scale 4: the index counts floats.
    const __m256 low = _mm256_castsi256_ps(_mm256_i32gather_epi64(base, _mm256_castsi256_si128(index), 4));
    const __m256 high = _mm256_castsi256_ps(_mm256_i32gather_epi64(base, _mm256_extracti128_si256(index, 1), 4));
    return {in_order(_mm256_shuffle_ps(low, high, _MM_SHUFFLE(2, 0, 2, 0))),
            in_order(_mm256_shuffle_ps(low, high, _MM_SHUFFLE(3, 1, 3, 1)))};
}

// Eight points st[0..7] -> their samples' r, on a level at least 2 texels wide.
[[gnu::target("avx2,fma"), gnu::always_inline]] inline __m256 float1_x8(const float* texels, __m256i width,
                                                                         __m256 width_f, __m256 height_f,
                                                                         __m256i last_s, __m256i last_t,
                                                                         const glm::vec2* st) {
    // (s0 t0 .. s3 t3) and (s4 t4 .. s7 t7): shufps takes the s (t) of each 128-bit half,
    // in the order s0 s1 s4 s5 s2 s3 s6 s7, which vpermpd's 64-bit pairs put back.
    const __m256 a = _mm256_loadu_ps(&st[0].x);
    const __m256 b = _mm256_loadu_ps(&st[4].x);
    const Axes8 ax = axes_gpu_x8(in_order(_mm256_shuffle_ps(a, b, _MM_SHUFFLE(2, 0, 2, 0))), width_f, last_s);
    const Axes8 ay = axes_gpu_x8(in_order(_mm256_shuffle_ps(a, b, _MM_SHUFFLE(3, 1, 3, 1))), height_f, last_t);
    const __m256i first = _mm256_min_epi32(ax.i0, _mm256_sub_epi32(last_s, _mm256_set1_epi32(1)));
    const auto [a0, b0] = texel_pairs_x8(texels, _mm256_add_epi32(_mm256_mullo_epi32(ay.i0, width), first));
    const auto [a1, b1] = texel_pairs_x8(texels, _mm256_add_epi32(_mm256_mullo_epi32(ay.i1, width), first));
    // Where i0 is first, the pair's first texel, else its second; where i1 is first + 1, the
    // second, else the first.
    const __m256 i0_first = _mm256_castsi256_ps(_mm256_cmpeq_epi32(ax.i0, first));
    const __m256 i1_second =
        _mm256_castsi256_ps(_mm256_cmpeq_epi32(ax.i1, _mm256_add_epi32(first, _mm256_set1_epi32(1))));
    const __m256 t00 = _mm256_blendv_ps(b0, a0, i0_first);
    const __m256 t10 = _mm256_blendv_ps(a0, b0, i1_second);
    const __m256 t01 = _mm256_blendv_ps(b1, a1, i0_first);
    const __m256 t11 = _mm256_blendv_ps(a1, b1, i1_second);
    return lerp_gpu_x8(lerp_gpu_x8(t00, t10, ax.weight), lerp_gpu_x8(t01, t11, ax.weight), ay.weight);
}

// Eight samples' r to out[0..n): stored as they are for texture_red(), spread to (r, 0, 0, 1)
// for texture().
template <class Out>
[[gnu::target("avx2,fma"), gnu::always_inline]] inline void put_r_x8(Out* out, __m256 r, std::size_t n) {
    if constexpr (std::is_same_v<Out, float>) {
        if (n == 8) return _mm256_storeu_ps(out, r);
    }
    alignas(32) float value[8];
    _mm256_store_ps(value, r);
    for (std::size_t j = 0; j < n; ++j) put_r(out[j], value[j]);
}

// texture_level0_float1_x4 with SimdLevel::avx2, for a level at least 2 wide. Not inlined
// into its caller, whose clones target less.
template <class Out>
[[gnu::target("avx2,fma"), gnu::noinline]] void texture_level0_float1_x8(const TextureLevel& level,
                                                                         const glm::vec2* st, Out* out,
                                                                         std::size_t count) {
    const float* texels = level.texels.data();
    const __m256i width = _mm256_set1_epi32(level.width);
    const __m256 width_f = _mm256_set1_ps(static_cast<float>(level.width));
    const __m256 height_f = _mm256_set1_ps(static_cast<float>(level.height));
    const __m256i last_s = _mm256_set1_epi32(level.width - 1);
    const __m256i last_t = _mm256_set1_epi32(level.height - 1);
    std::size_t k = 0;
    for (; k + 8 <= count; k += 8)
        put_r_x8(out + k, float1_x8(texels, width, width_f, height_f, last_s, last_t, st + k), 8);
    if (k < count) {  // the last one to seven points, padded with copies of the last
        glm::vec2 tail[8];
        for (std::size_t j = 0; j < 8; ++j) tail[j] = st[std::min(k + j, count - 1)];
        put_r_x8(out + k, float1_x8(texels, width, width_f, height_f, last_s, last_t, tail), count - k);
    }
}
#endif
#endif


// texture(sampler, st[k]) on level 0 for k < count: the texture's C channels, the others as
// GL fills them (g = b = 0, a = 1); unorm8 codes read as code * (1/255). Into out[k] as put()
// writes a sample: all of it, or its r.
template <int C, bool Unorm8, class Out>
[[gnu::always_inline]] inline void texture_level0_n(const TextureLevel& level, const glm::vec2* st, Out* out,
                                                    std::size_t count, bool repeat) {
#if defined(__SSE2__)
    if constexpr (Unorm8) {
        if (!repeat && unorm8_x4_fits(level))
            return texture_level0_unorm8_x4<C>(level, st, out, count);
    } else if constexpr (C == 1) {
        if (!repeat && float1_x4_fits(level)) {
#if defined(TESSREF_HAVE_AVX2_VARIANTS)
            if (simd_level() == SimdLevel::avx2 && level.width >= 2)
                return texture_level0_float1_x8(level, st, out, count);
#endif
            return texture_level0_float1_x4(level, st, out, count);
        }
    }
#endif
    LastAxis<Unorm8> s_axis, t_axis;
    for (std::size_t k = 0; k < count; ++k) {
        const auto& ax = s_axis(st[k].x, level.width, repeat);
        const auto& ay = t_axis(st[k].y, level.height, repeat);
        glm::vec4 sample(0.0f, 0.0f, 0.0f, 1.0f);
        if constexpr (Unorm8) {
            int codes[4];
            bilinear_unorm8_n<C>(level, ax, ay, codes);
            for (int c = 0; c < C; ++c) sample[c] = static_cast<float>(codes[c]) * kUnorm8Scale;
        } else {
            float values[4];
            bilinear_gpu_n<C>(level, ax, ay, values);
            for (int c = 0; c < C; ++c) sample[c] = values[c];
        }
        put(out[k], sample);
    }
}

template <class Out>
[[gnu::always_inline]] inline void texture_level0_any(const TextureLevel& level, int channels, bool unorm8,
                                                      const glm::vec2* st, Out* out, std::size_t count, bool repeat) {
    switch (channels * 2 + (unorm8 ? 1 : 0)) {
        case 2: return texture_level0_n<1, false>(level, st, out, count, repeat);
        case 3: return texture_level0_n<1, true>(level, st, out, count, repeat);
        case 4: return texture_level0_n<2, false>(level, st, out, count, repeat);
        case 5: return texture_level0_n<2, true>(level, st, out, count, repeat);
        case 6: return texture_level0_n<3, false>(level, st, out, count, repeat);
        case 7: return texture_level0_n<3, true>(level, st, out, count, repeat);
        case 8: return texture_level0_n<4, false>(level, st, out, count, repeat);
        default: return texture_level0_n<4, true>(level, st, out, count, repeat);
    }
}

// Every sample (texture()) or the red channels alone (texture_red()).
TESSREF_FMA_CLONES
void texture_level0(const TextureLevel& level, int channels, bool unorm8, const glm::vec2* st, glm::vec4* out,
                    std::size_t count, bool repeat) {
    texture_level0_any(level, channels, unorm8, st, out, count, repeat);
}
TESSREF_FMA_CLONES
void texture_level0(const TextureLevel& level, int channels, bool unorm8, const glm::vec2* st, float* red,
                    std::size_t count, bool repeat) {
    texture_level0_any(level, channels, unorm8, st, red, count, repeat);
}

double unorm_max(TexelFormat format) {
    return format == TexelFormat::unorm8 ? 255.0 : format == TexelFormat::unorm16 ? 65535.0 : 1.0;
}

// The double path's value of a level's sample i: levels >= 1 have their own doubles
// (`exact`, Texture::exact_levels); level 0's (exact null) is derived from the stored float
// (exact: for unorm the code is recovered by rounding, for float32 the float itself).
inline double exact_value(const TextureLevel& level, const double* exact, TexelFormat format, std::size_t i) {
    if (exact) return exact[i];
    const double v = static_cast<double>(level.texels[i]);
    if (format == TexelFormat::float32) return v;
    const double max = unorm_max(format);
    // std::nearbyint(v * max) without a libm call: v * max is in [0, 65535] (a unorm texel
    // times its maximum code), where adding and subtracting 2^52 rounds to the nearest
    // integer, ties to even, as nearbyint does (the sum has no fraction bits left).
    const double code = (v * max + 0x1p52) - 0x1p52;
    return code / max;
}

void bilinear_exact(const TextureLevel& level, const double* exact, TexelFormat format, int channels,
                    glm::dvec2 st, double out[4], bool repeat = false) {
    const AxisD ax = axis_exact(st.x, level.width, repeat);
    const AxisD ay = axis_exact(st.y, level.height, repeat);
    for (int c = 0; c < channels; ++c) {
        const double t00 = exact_value(level, exact, format, index_of(level, channels, ax.i0, ay.i0, c));
        const double t10 = exact_value(level, exact, format, index_of(level, channels, ax.i1, ay.i0, c));
        const double t01 = exact_value(level, exact, format, index_of(level, channels, ax.i0, ay.i1, c));
        const double t11 = exact_value(level, exact, format, index_of(level, channels, ax.i1, ay.i1, c));
        out[c] = mix_exact(mix_exact(t00, t10, ax.weight), mix_exact(t01, t11, ax.weight),
                           ay.weight);
    }
}

// ---- glGenerateMipmap --------------------------------------------------------------------

// llvmpipe's blit draws the destination level as the rectangle v0 = (0, 0), v1 = (n, 0),
// v2 = (n, m), v3 = (0, m) with texture coordinates (0,0), (1,0), (1,1), (0,1), as a
// triangle fan that the draw module splits into (v1, v2, v0) and (v2, v3, v0). For each
// triangle the setup (lp_state_setup.c, calc_coef4) computes a plane a0 + dadx * x + dady * y
// relative to the framebuffer origin, in float, with the pixel centre offset 0.5; the
// fragment shader evaluates it at integer pixel positions with two fmas. Measured bit-exact
// for every level of every size tried (see the header).
struct PlaneCoefficients {
    float a0 = 0.0f;
    float dadx = 0.0f;
    float dady = 0.0f;
};

struct BlitTriangle {
    PlaneCoefficients s;
    PlaneCoefficients t;
};

BlitTriangle blit_triangle_setup(const float position[3][2], const float s[3], const float t[3]) {
    const float dx01 = position[0][0] - position[1][0];
    const float dy01 = position[0][1] - position[1][1];
    const float dx20 = position[2][0] - position[0][0];
    const float dy20 = position[2][1] - position[0][1];
    const float e = dx01 * dy20;
    const float f = dy01 * dx20;
    const float ooa = 1.0f / (e - f);
    const float dx20_ooa = dx20 * ooa;
    const float dy20_ooa = dy20 * ooa;
    const float dx01_ooa = dx01 * ooa;
    const float dy01_ooa = dy01 * ooa;
    const float x0_center = position[0][0] - 0.5f;
    const float y0_center = position[0][1] - 0.5f;
    auto coefficients = [&](const float a[3]) {
        PlaneCoefficients p;
        const float da01 = a[0] - a[1];
        const float da20 = a[2] - a[0];
        p.dadx = da01 * dy20_ooa - da20 * dy01_ooa;
        p.dady = da20 * dx01_ooa - da01 * dx20_ooa;
        p.a0 = a[0] - (p.dadx * x0_center + p.dady * y0_center);
        return p;
    };
    return BlitTriangle{coefficients(s), coefficients(t)};
}

struct BlitSetup {
    int width = 0;
    int height = 0;
    BlitTriangle upper;  // (v1, v2, v0): pixels at or above the diagonal through (0,0)-(n,m)
    BlitTriangle lower;  // (v2, v3, v0)

    explicit BlitSetup(int n, int m) : width(n), height(m) {
        const float w = static_cast<float>(n);
        const float h = static_cast<float>(m);
        const float vx[4] = {0.0f, w, w, 0.0f};
        const float vy[4] = {0.0f, 0.0f, h, h};
        const float vs[4] = {0.0f, 1.0f, 1.0f, 0.0f};
        const float vt[4] = {0.0f, 0.0f, 1.0f, 1.0f};
        auto make = [&](int a, int b, int c) {
            const float position[3][2] = {{vx[a], vy[a]}, {vx[b], vy[b]}, {vx[c], vy[c]}};
            const float s[3] = {vs[a], vs[b], vs[c]};
            const float t[3] = {vt[a], vt[b], vt[c]};
            return blit_triangle_setup(position, s, t);
        };
        upper = make(1, 2, 0);
        lower = make(2, 3, 0);
    }

    // Whether destination pixel (i, j) is in the lower triangle (else the upper).
    bool in_lower(int i, int j) const {
        return static_cast<long long>(2 * i + 1) * height < static_cast<long long>(2 * j + 1) * width;
    }

    // The interpolated texture coordinate at the centre of destination pixel (i, j) in `tri`.
    static glm::vec2 coordinate(const BlitTriangle& tri, int i, int j) {
        const float x = static_cast<float>(i);
        const float y = static_cast<float>(j);
        const float s = std::fma(tri.s.dady, y, std::fma(tri.s.dadx, x, tri.s.a0));
        const float t = std::fma(tri.t.dady, y, std::fma(tri.t.dadx, x, tri.t.a0));
        return {s, t};
    }
};

// The filter axes of a blit, once a column and once a row. In both triangles s is constant
// along y and t along x: the rectangle's texture coordinates follow its edges, so the setup
// gives s a dady and t a dadx of exactly zero (the differences it takes are of equal
// coordinates). coordinate()'s fma with that zero then returns the other term unchanged
// (only a zero's sign may change, and axis_gpu and axis_unorm8 read -0 as 0), so pixel
// (i, j) has column i's s axis and row j's t axis of its triangle.
template <typename Axis>
struct BlitAxes {
    std::vector<Axis> s_upper, s_lower;  // by destination column
    std::vector<Axis> t_upper, t_lower;  // by destination row
};

struct BlitCoordinates {
    std::vector<float> s_upper, s_lower, t_upper, t_lower;
};

TESSREF_FMA_CLONES
BlitCoordinates blit_coordinates(const BlitSetup& setup) {
    if (setup.upper.s.dady != 0.0f || setup.lower.s.dady != 0.0f || setup.upper.t.dadx != 0.0f ||
        setup.lower.t.dadx != 0.0f)
        throw Error("blit of a " + std::to_string(setup.width) + " x " + std::to_string(setup.height) +
                    " level: its texture coordinates are not separable");
    BlitCoordinates out;
    for (int i = 0; i < setup.width; ++i) {
        out.s_upper.push_back(BlitSetup::coordinate(setup.upper, i, 0).x);
        out.s_lower.push_back(BlitSetup::coordinate(setup.lower, i, 0).x);
    }
    for (int j = 0; j < setup.height; ++j) {
        out.t_upper.push_back(BlitSetup::coordinate(setup.upper, 0, j).y);
        out.t_lower.push_back(BlitSetup::coordinate(setup.lower, 0, j).y);
    }
    return out;
}

template <typename Axis, typename AxisOf>
BlitAxes<Axis> blit_axes(const BlitSetup& setup, const TextureLevel& src, AxisOf axis_of) {
    const BlitCoordinates c = blit_coordinates(setup);
    BlitAxes<Axis> axes;
    for (const float s : c.s_upper) axes.s_upper.push_back(axis_of(s, src.width));
    for (const float s : c.s_lower) axes.s_lower.push_back(axis_of(s, src.width));
    for (const float t : c.t_upper) axes.t_upper.push_back(axis_of(t, src.height));
    for (const float t : c.t_lower) axes.t_lower.push_back(axis_of(t, src.height));
    return axes;
}

std::uint16_t float_to_unorm16(float v) {
    // llvmpipe's store: clamp to [0, 1], scale by 65535 in float, round half to even.
    const float clamped = min_of(max_or(v, 0.0f), 1.0f);  // NaN -> 0
    return static_cast<std::uint16_t>(round_even(clamped * 65535.0f));
}

// Destination row j of the blit of src, C channels, from the axes of its columns and rows.
// The filters are inlined rather than called through bilinear_gpu / bilinear_unorm8: the
// channel count is dispatched once a row, and the float lerp's fma is an instruction in the
// FMA clone of blit_row_float.
template <int C, typename Axis>
[[gnu::always_inline]] inline void blit_row_n(const TextureLevel& src, TexelFormat format, const BlitSetup& setup,
                                              const BlitAxes<Axis>& axes, int j, TextureLevel& dst) {
    const Axis& t_upper = axes.t_upper[static_cast<std::size_t>(j)];
    const Axis& t_lower = axes.t_lower[static_cast<std::size_t>(j)];
    for (int i = 0; i < dst.width; ++i) {
        const bool lower = setup.in_lower(i, j);
        const Axis& ax = lower ? axes.s_lower[static_cast<std::size_t>(i)] : axes.s_upper[static_cast<std::size_t>(i)];
        const Axis& ay = lower ? t_lower : t_upper;
        const std::size_t base = index_of(dst, C, i, j, 0);
        if constexpr (std::is_same_v<Axis, AxisU8>) {
            int codes[4];
            bilinear_unorm8_n<C>(src, ax, ay, codes);
            for (int c = 0; c < C; ++c) {
                dst.unorm8[base + c] = static_cast<std::uint8_t>(codes[c]);
                dst.texels[base + c] = static_cast<float>(codes[c]) * kUnorm8Scale;
            }
        } else {
            float values[4];
            bilinear_gpu_n<C>(src, ax, ay, values);
            for (int c = 0; c < C; ++c)
                dst.texels[base + c] = format == TexelFormat::unorm16
                                           ? static_cast<float>(float_to_unorm16(values[c])) * kUnorm16Scale
                                           : values[c];
        }
    }
}

template <typename Axis>
[[gnu::always_inline]] inline void blit_row(const TextureLevel& src, TexelFormat format, int channels,
                                            const BlitSetup& setup, const BlitAxes<Axis>& axes, int j,
                                            TextureLevel& dst) {
    switch (channels) {
        case 1: return blit_row_n<1>(src, format, setup, axes, j, dst);
        case 2: return blit_row_n<2>(src, format, setup, axes, j, dst);
        case 3: return blit_row_n<3>(src, format, setup, axes, j, dst);
        default: return blit_row_n<4>(src, format, setup, axes, j, dst);
    }
}

TESSREF_FMA_CLONES
void blit_row_float(const TextureLevel& src, TexelFormat format, int channels, const BlitSetup& setup,
                    const BlitAxes<AxisF>& axes, int j, TextureLevel& dst) {
    blit_row(src, format, channels, setup, axes, j, dst);
}

TextureLevel blit_level(const TextureLevel& src, TexelFormat format, int channels, int dst_width, int dst_height) {
    TextureLevel dst;
    dst.width = dst_width;
    dst.height = dst_height;
    const std::size_t count = static_cast<std::size_t>(dst_width) *
                              static_cast<std::size_t>(dst_height) *
                              static_cast<std::size_t>(channels);
    dst.texels.resize(count);
    if (format == TexelFormat::unorm8) dst.unorm8.resize(count);
    const BlitSetup setup(dst_width, dst_height);
    // Rows in parallel: each destination texel is a function of the source level alone.
    if (format == TexelFormat::unorm8) {
        const auto axes = blit_axes<AxisU8>(setup, src, [](float s, int size) { return axis_unorm8(s, size); });
        tessref::parallel_for(0, dst_height, [&](int j) { blit_row(src, format, channels, setup, axes, j, dst); });
    } else {
        const auto axes = blit_axes<AxisF>(setup, src, [](float s, int size) { return axis_gpu(s, size); });
        tessref::parallel_for(0, dst_height, [&](int j) { blit_row_float(src, format, channels, setup, axes, j, dst); });
    }
    return dst;
}

// The four source texels that Mesa's do_row (main/mipmap.c) averages into destination texel
// (i, row), channel c: rows a and b, columns j and k of the level below. Along an axis
// where the level keeps its size, the two are the same texel.
struct BoxFootprint {
    int col_k0, col_stride, row_b0, row_stride;
    // do_row: k0 = (srcWidth == dstWidth) ? 0 : 1, colStride = (srcWidth == dstWidth) ? 1 : 2.
    BoxFootprint(const TextureLevel& src, int dst_width, int dst_height)
        : col_k0(src.width == dst_width ? 0 : 1),
          col_stride(src.width == dst_width ? 1 : 2),
          row_b0(src.height == dst_height ? 0 : 1),
          row_stride(src.height == dst_height ? 1 : 2) {}
    // aj, ak, bj, bk
    std::array<std::size_t, 4> texels(const TextureLevel& src, int channels, int i, int row, int c) const {
        const int ya = row * row_stride, yb = ya + row_b0;
        const int xj = i * col_stride, xk = xj + col_k0;
        return {index_of(src, channels, xj, ya, c), index_of(src, channels, xk, ya, c),
                index_of(src, channels, xj, yb, c), index_of(src, channels, xk, yb, c)};
    }
};

// Mesa main/mipmap.c, make_2d_mipmap + do_row.
TextureLevel software_box_level(const TextureLevel& src, TexelFormat format, int channels, int dst_width,
                                int dst_height) {
    TextureLevel dst;
    dst.width = dst_width;
    dst.height = dst_height;
    const std::size_t count = static_cast<std::size_t>(dst_width) *
                              static_cast<std::size_t>(dst_height) *
                              static_cast<std::size_t>(channels);
    dst.texels.resize(count);
    if (format == TexelFormat::unorm8) dst.unorm8.resize(count);
    const BoxFootprint box(src, dst_width, dst_height);
    tessref::parallel_for(0, dst_height, [&](int row) {  // rows in parallel, as blit_level
        for (int i = 0; i < dst_width; ++i) {
            for (int c = 0; c < channels; ++c) {
                const auto [aj, ak, bj, bk] = box.texels(src, channels, i, row, c);
                const std::size_t d = index_of(dst, channels, i, row, c);
                if (format == TexelFormat::unorm8) {
                    const int sum = src.unorm8[aj] + src.unorm8[ak] + src.unorm8[bj] + src.unorm8[bk];
                    dst.unorm8[d] = static_cast<std::uint8_t>(sum / 4);
                    dst.texels[d] = static_cast<float>(dst.unorm8[d]) * kUnorm8Scale;
                } else if (format == TexelFormat::unorm16) {
                    auto code = [&](std::size_t k) {
                        return static_cast<int>(std::nearbyint(src.texels[k] * 65535.0));
                    };
                    const int sum = code(aj) + code(ak) + code(bj) + code(bk);
                    dst.texels[d] = static_cast<float>(sum / 4) * kUnorm16Scale;
                } else {
                    dst.texels[d] = (src.texels[aj] + src.texels[ak] + src.texels[bj] + src.texels[bk]) * 0.25f;
                }
            }
        }
    });
    return dst;
}

// The double path's level above src (dst: its size; out: its doubles) from src's doubles
// (src_exact, null for level 0), by the rule's footprint: llvmpipe_blit samples src
// bilinearly at the ideal sample points, mesa_software_box takes the mean of two means of
// the box's texels; no storage quantization. Serial: it runs under the texture's once flag
// (Texture::exact_levels), where a parallel loop's thread could take up a task that waits
// on that same flag.
void exact_level(const TextureLevel& src, const double* src_exact, TexelFormat format, MipmapRule rule,
                 int channels, const TextureLevel& dst, std::vector<double>& out) {
    const int dst_width = dst.width, dst_height = dst.height;
    out.resize(dst.texels.size());
    if (rule == MipmapRule::llvmpipe_blit) {
        for (int j = 0; j < dst_height; ++j) {
            for (int i = 0; i < dst_width; ++i) {
                const glm::dvec2 ideal((i + 0.5) / dst_width, (j + 0.5) / dst_height);
                double exact[4];
                bilinear_exact(src, src_exact, format, channels, ideal, exact);
                for (int c = 0; c < channels; ++c) out[index_of(dst, channels, i, j, c)] = exact[c];
            }
        }
        return;
    }
    // do_row's footprint, as software_box_level.
    const BoxFootprint box(src, dst_width, dst_height);
    const auto value = [&](std::size_t i) { return exact_value(src, src_exact, format, i); };
    for (int row = 0; row < dst_height; ++row) {
        for (int i = 0; i < dst_width; ++i) {
            for (int c = 0; c < channels; ++c) {
                const auto [aj, ak, bj, bk] = box.texels(src, channels, i, row, c);
                // The mean of two means: exact for equal values (a constant stays constant).
                const double top = 0.5 * (value(aj) + value(ak));
                const double bottom = 0.5 * (value(bj) + value(bk));
                out[index_of(dst, channels, i, row, c)] = 0.5 * (top + bottom);
            }
        }
    }
}

}  // namespace

namespace {

// Bytes of the mip pyramid's levels from `first_lod` on. Per sample: the float the sampler
// reads, the 8-bit code of a unorm8 texture, and on levels >= 1 the double of the
// accuracy path (level 0 derives it from the float).
std::uint64_t pyramid_bytes(int width, int height, int channels, TexelFormat format, int first_lod) {
    if (width < 1 || height < 1 || channels < 1) return 0;
    const std::uint64_t code_bytes = format == TexelFormat::unorm8 ? 1 : 0;
    std::uint64_t total = 0;
    std::uint64_t w = static_cast<std::uint64_t>(width);
    std::uint64_t h = static_cast<std::uint64_t>(height);
    for (int lod = 0;; ++lod) {
        if (lod >= first_lod) {
            const std::uint64_t samples =
                saturating_bytes(saturating_bytes(w, h), static_cast<std::uint64_t>(channels));
            const std::uint64_t each = sizeof(float) + code_bytes + (lod > 0 ? sizeof(double) : 0);
            const std::uint64_t level = saturating_bytes(samples, each);
            total = level > UINT64_MAX - total ? UINT64_MAX : total + level;
        }
        if (w == 1 && h == 1) break;
        w = std::max<std::uint64_t>(1, w / 2);
        h = std::max<std::uint64_t>(1, h / 2);
    }
    return total;
}

}  // namespace

std::uint64_t texture_memory_bytes(int width, int height, int channels, TexelFormat format) {
    return pyramid_bytes(width, height, channels, format, 0);
}

Texture Texture::build(int width, int height, int channels, TexelFormat format, MipmapRule rule,
                       TextureLevel level0) {
    // Level 0 is already held; the levels above it are refused here if they cannot fit
    // (the loaders check the whole texture before reading a file).
    require_memory(pyramid_bytes(width, height, channels, format, 1),
                   "mip chain of a " + std::to_string(width) + " x " + std::to_string(height) + " texture");
    Texture texture;
    texture.channels_ = channels;
    texture.format_ = format;
    texture.rule_ = rule;
    texture.levels_.push_back(std::move(level0));
    texture.exact_ = std::make_shared<ExactPyramid>();
    int w = width;
    int h = height;
    while (w > 1 || h > 1) {
        const int dw = std::max(1, w / 2);
        const int dh = std::max(1, h / 2);
        const TextureLevel& src = texture.levels_.back();
        TextureLevel next = rule == MipmapRule::llvmpipe_blit ? blit_level(src, format, channels, dw, dh)
                                                              : software_box_level(src, format, channels, dw, dh);
        texture.levels_.push_back(std::move(next));
        w = dw;
        h = dh;
    }
    return texture;
}

const std::vector<std::vector<double>>& Texture::exact_levels() const {
    std::call_once(exact_->once, [this] {
        std::vector<std::vector<double>>& exact = exact_->exact;
        exact.resize(levels_.size());
        for (std::size_t lod = 1; lod < levels_.size(); ++lod)
            exact_level(levels_[lod - 1], lod == 1 ? nullptr : exact[lod - 1].data(), format_, rule_, channels_,
                        levels_[lod], exact[lod]);
    });
    return exact_->exact;
}

namespace {
void check_shape(int width, int height, int channels, std::size_t size, const char* what) {
    if (width < 1 || height < 1)
        throw Error(std::string(what) + ": texture size " + std::to_string(width) + "x" +
                    std::to_string(height) + " is empty");
    if (channels < 1 || channels > 4)
        throw Error(std::string(what) + ": " + std::to_string(channels) +
                    " channels (a texture has 1 to 4)");
    const std::size_t expected = static_cast<std::size_t>(width) * static_cast<std::size_t>(height) *
                                 static_cast<std::size_t>(channels);
    if (size != expected)
        throw Error(std::string(what) + ": " + std::to_string(size) + " values for a " +
                    std::to_string(width) + "x" + std::to_string(height) + "x" +
                    std::to_string(channels) + " texture (" + std::to_string(expected) + " expected)");
}
}  // namespace

Texture Texture::from_float(int width, int height, int channels, std::vector<float> texels,
                            MipmapRule rule) {
    check_shape(width, height, channels, texels.size(), "Texture::from_float");
    TextureLevel level0;
    level0.width = width;
    level0.height = height;
    level0.texels = std::move(texels);
    return build(width, height, channels, TexelFormat::float32, rule, std::move(level0));
}

Texture Texture::from_unorm8(int width, int height, int channels, std::vector<std::uint8_t> codes,
                             MipmapRule rule) {
    check_shape(width, height, channels, codes.size(), "Texture::from_unorm8");
    TextureLevel level0;
    level0.width = width;
    level0.height = height;
    level0.texels.resize(codes.size());
    for (std::size_t i = 0; i < codes.size(); ++i)
        level0.texels[i] = static_cast<float>(codes[i]) * kUnorm8Scale;
    level0.unorm8 = std::move(codes);
    return build(width, height, channels, TexelFormat::unorm8, rule, std::move(level0));
}

Texture Texture::from_unorm16(int width, int height, int channels, std::vector<std::uint16_t> codes,
                              MipmapRule rule) {
    check_shape(width, height, channels, codes.size(), "Texture::from_unorm16");
    TextureLevel level0;
    level0.width = width;
    level0.height = height;
    level0.texels.resize(codes.size());
    for (std::size_t i = 0; i < codes.size(); ++i)
        level0.texels[i] = static_cast<float>(codes[i]) * kUnorm16Scale;
    return build(width, height, channels, TexelFormat::unorm16, rule, std::move(level0));
}

const TextureLevel& Texture::level(int lod) const {
    if (lod < 0 || lod >= level_count())
        throw Error("texture level " + std::to_string(lod) + " does not exist (the texture has " +
                    std::to_string(level_count()) + " levels)");
    return levels_[static_cast<std::size_t>(lod)];
}

namespace {
void check_texel(const TextureLevel& level, int channels, int lod, int x, int y, int channel) {
    if (x < 0 || y < 0 || x >= level.width || y >= level.height || channel < 0 ||
        channel >= channels)
        throw Error("texel (" + std::to_string(x) + ", " + std::to_string(y) + ") channel " +
                    std::to_string(channel) + " is outside level " + std::to_string(lod) + " (" +
                    std::to_string(level.width) + "x" + std::to_string(level.height) + "x" +
                    std::to_string(channels) + ")");
}
}  // namespace

float Texture::texel(int lod, int x, int y, int channel) const {
    const TextureLevel& l = level(lod);
    check_texel(l, channels_, lod, x, y, channel);
    return l.texels[index_of(l, channels_, x, y, channel)];
}

double Texture::texel_exact(int lod, int x, int y, int channel) const {
    const TextureLevel& l = level(lod);
    check_texel(l, channels_, lod, x, y, channel);
    const double* exact = lod == 0 ? nullptr : exact_levels()[static_cast<std::size_t>(lod)].data();
    return exact_value(l, exact, format_, index_of(l, channels_, x, y, channel));
}

void Texture::row_exact(int y, int channel, std::span<double> out) const {
    const TextureLevel& l = level(0);
    check_texel(l, channels_, 0, 0, y, channel);
    if (out.size() != static_cast<std::size_t>(l.width))
        throw Error("row_exact: " + std::to_string(out.size()) + " values for a row of " + std::to_string(l.width) +
                    " texels");
    const std::size_t first = index_of(l, channels_, 0, y, channel);
    for (std::size_t x = 0; x < out.size(); ++x)
        out[x] = exact_value(l, nullptr, format_, first + x * static_cast<std::size_t>(channels_));
}

void Texture::set_swizzle(Swizzle swizzle) {
    if (swizzle == Swizzle::luminance && channels_ != 1)
        throw Error("a luminance texture reads one channel; this one has " + std::to_string(channels_));
    swizzle_ = swizzle;
}

namespace {
// A sample's channels as the swizzle returns them.
template <class Vec4>
inline void apply_swizzle(Swizzle swizzle, Vec4& sample) {
    if (swizzle == Swizzle::luminance) sample.g = sample.b = sample.r;
}
}  // namespace

glm::vec4 Texture::texture(glm::vec2 st) const {
    glm::vec4 out;
    texture(std::span<const glm::vec2>(&st, 1), std::span<glm::vec4>(&out, 1));
    return out;
}
void Texture::texture(std::span<const glm::vec2> st, std::span<glm::vec4> out) const {
    // textureLod(st, 0) without the level selection: lod 0 is level 0 with no blend.
    if (empty()) throw Error("texture on an empty texture");
    if (st.size() != out.size()) throw Error("Texture::texture: as many samples as coordinates");
    texture_level0(levels_[0], channels_, format_ == TexelFormat::unorm8, st.data(), out.data(), st.size(),
                   wrap_ == Wrap::repeat);
    if (swizzle_ != Swizzle::rgba)
        for (glm::vec4& sample : out) apply_swizzle(swizzle_, sample);
}
glm::dvec4 Texture::texture(glm::dvec2 st) const { return textureLod(st, 0.0); }
void Texture::texture(std::span<const glm::dvec2> st, std::span<glm::dvec4> out) const {
    if (st.size() != out.size()) throw Error("Texture::texture: as many samples as coordinates");
    for (std::size_t k = 0; k < st.size(); ++k) out[k] = texture(st[k]);
}
void Texture::texture_red(std::span<const glm::vec2> st, std::span<float> red) const {
    // texture() without the swizzle, which leaves r as it is.
    if (empty()) throw Error("texture on an empty texture");
    if (st.size() != red.size()) throw Error("Texture::texture_red: as many samples as coordinates");
    texture_level0(levels_[0], channels_, format_ == TexelFormat::unorm8, st.data(), red.data(), st.size(),
                   wrap_ == Wrap::repeat);
}
void Texture::texture_red(std::span<const glm::dvec2> st, std::span<double> red) const {
    if (st.size() != red.size()) throw Error("Texture::texture_red: as many samples as coordinates");
    for (std::size_t k = 0; k < st.size(); ++k) red[k] = texture(st[k]).r;
}

glm::vec4 Texture::textureLod(glm::vec2 st, float lod) const {
    if (empty()) throw Error("textureLod on an empty texture");
    // GL_LINEAR ignores the pyramid; otherwise lod is clamped to [0, max_level] (a negative
    // lod selects the magnification filter, GL_LINEAR on level 0: the same sample).
    // (max_or and min_of are fmax and fmin here: a NaN lod reads as 0; floor_small is floor
    // on [0, max_level]. A -0 lod may come out +0 where fmax kept it: the level and the
    // fraction, +0, are the same.)
    const float max_lod = static_cast<float>(max_level());
    const float clamped = min_filter_ == MinFilter::linear ? 0.0f : min_of(max_or(lod, 0.0f), max_lod);
    const float floor_lod = floor_small(clamped);
    const int level0 = static_cast<int>(floor_lod);
    const float fraction = clamped - floor_lod;
    const int level1 = std::min(level0 + 1, max_level());
    const bool repeat = wrap_ == Wrap::repeat;
    glm::vec4 out(0.0f, 0.0f, 0.0f, 1.0f);
    if (format_ == TexelFormat::unorm8) {
        int codes[4];
        bilinear_unorm8(levels_[level0], channels_, st, codes, repeat);
        // lp_build_sample_mipmap (AoS): weight trunc(frac * 256), lerp only when it is > 0.
        const int weight = static_cast<int>(fraction * 256.0f);
        if (weight > 0 && level1 != level0) {
            int codes1[4];
            bilinear_unorm8(levels_[level1], channels_, st, codes1, repeat);
            for (int c = 0; c < channels_; ++c) codes[c] = lerp_unorm8(codes[c], codes1[c], weight);
        }
        for (int c = 0; c < channels_; ++c) out[c] = static_cast<float>(codes[c]) * kUnorm8Scale;
        apply_swizzle(swizzle_, out);
        return out;
    }
    float values[4];
    bilinear_gpu(levels_[level0], channels_, st, values, repeat);
    if (fraction > 0.0f && level1 != level0) {
        float values1[4];
        bilinear_gpu(levels_[level1], channels_, st, values1, repeat);
        for (int c = 0; c < channels_; ++c) values[c] = lerp_gpu(values[c], values1[c], fraction);
    }
    for (int c = 0; c < channels_; ++c) out[c] = values[c];
    apply_swizzle(swizzle_, out);
    return out;
}

glm::dvec4 Texture::textureLod(glm::dvec2 st, double lod) const {
    if (empty()) throw Error("textureLod on an empty texture");
    const double max_lod = static_cast<double>(max_level());
    const double clamped = min_filter_ == MinFilter::linear ? 0.0
                                                            : std::fmin(std::fmax(lod, 0.0), max_lod);
    const double floor_lod = std::floor(clamped);
    const int level0 = static_cast<int>(floor_lod);
    const double fraction = clamped - floor_lod;
    const int level1 = std::min(level0 + 1, max_level());
    const bool repeat = wrap_ == Wrap::repeat;
    // Level 0's doubles come from its texels: only a blend with a level above asks for the
    // computed ones.
    const auto exact = [&](int lod) { return lod == 0 ? nullptr : exact_levels()[static_cast<std::size_t>(lod)].data(); };
    double values[4];
    bilinear_exact(levels_[level0], exact(level0), format_, channels_, st, values, repeat);
    if (fraction > 0.0 && level1 != level0) {
        double values1[4];
        bilinear_exact(levels_[level1], exact(level1), format_, channels_, st, values1, repeat);
        for (int c = 0; c < channels_; ++c) values[c] = mix_exact(values[c], values1[c], fraction);
    }
    glm::dvec4 out(0.0, 0.0, 0.0, 1.0);
    for (int c = 0; c < channels_; ++c) out[c] = values[c];
    apply_swizzle(swizzle_, out);
    return out;
}

}  // namespace tessref
