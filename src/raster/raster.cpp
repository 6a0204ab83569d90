// src/raster/raster.cpp — the rasterizer's driver: vertex preparation, clipping, setup and
// binning in chunks, 64x64 tiles rasterized in parallel (oneTBB), and the deferred resolve of
// ids, tess coords and varyings of the visible surface.
//
// Determinism: a chunk's primitives keep the submission order (an input triangle's clipped
// fan, then the next triangle), every tile walks the chunks in order, and no pixel is touched
// by two tiles, so the buffers do not depend on the thread count or on scheduling.
#include "tessref/raster.h"

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstddef>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>

#include "common/huge_pages.h"
#include "common/parallel.h"
#include "common/simd.h"
#include "common/unorm8.h"

#include "raster/raster_internal.h"
#include "tessref/error.h"

namespace tessref {

namespace raster {

#if defined(__SSE2__)
namespace {

// Four clip positions, transposed: x, y, z and w of each.
struct ClipBlock {
    __m128 x, y, z, w;
};
[[gnu::always_inline]] inline ClipBlock load_block(const glm::vec4* p) {
    __m128 r0 = _mm_loadu_ps(reinterpret_cast<const float*>(p + 0));
    __m128 r1 = _mm_loadu_ps(reinterpret_cast<const float*>(p + 1));
    __m128 r2 = _mm_loadu_ps(reinterpret_cast<const float*>(p + 2));
    __m128 r3 = _mm_loadu_ps(reinterpret_cast<const float*>(p + 3));
    _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
    return {r0, r1, r2, r3};
}

// prepare_vertex of four vertices from their window positions (wx, wy, wz, 1/w).
//
// `inside` without the clip mask itself: the six sums of draw's cliptest (-x + w is w - x,
// the same IEEE sum) compared >= 0 in the ordered sense (false for NaN), w < infinity and
// |1/w| < infinity. That is finite4(clip) && clipmask == 0 && finite4(win): a NaN anywhere
// in the clip position makes a sum NaN; w >= |x|, |y|, |z| with w finite makes them finite;
// 1/w finite (w not 0, not too small) makes x * (1/w) at most about 1 in magnitude and the
// window position finite; conversely finite positions give sums that are not NaN.
[[gnu::always_inline]] inline void finish_block(const ClipBlock& c, __m128 wx, __m128 wy, __m128 wz, __m128 oow,
                                                const Viewport& vp, glm::vec4* win, FixedXY* fixed,
                                                BoxBounds* bounds) {
    const __m128 zero = _mm_setzero_ps();
    const __m128 magnitude = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
    const __m128 infinity = _mm_set1_ps(INFINITY);
    __m128 inside = _mm_and_ps(_mm_and_ps(_mm_cmpge_ps(_mm_sub_ps(c.w, c.x), zero), _mm_cmpge_ps(_mm_add_ps(c.x, c.w), zero)),
                               _mm_and_ps(_mm_cmpge_ps(_mm_sub_ps(c.w, c.y), zero), _mm_cmpge_ps(_mm_add_ps(c.y, c.w), zero)));
    inside = _mm_and_ps(inside, _mm_and_ps(_mm_cmpge_ps(_mm_add_ps(c.z, c.w), zero), _mm_cmpge_ps(_mm_sub_ps(c.w, c.z), zero)));
    inside = _mm_and_ps(inside, _mm_and_ps(_mm_cmplt_ps(c.w, infinity), _mm_cmplt_ps(_mm_and_ps(oow, magnitude), infinity)));

    // snap_fixed: cvtps2dq itself.
    const __m128 half = _mm_set1_ps(0.5f), one = _mm_set1_ps(static_cast<float>(kFixedOne));
    const __m128i fixed_x = _mm_cvtps_epi32(_mm_mul_ps(_mm_sub_ps(wx, half), one));
    const __m128i fixed_y = _mm_cvtps_epi32(_mm_mul_ps(_mm_sub_ps(wy, half), one));

    // The window positions, transposed back, and the snapped ones.
    __m128 w0 = wx, w1 = wy, w2 = wz, w3 = oow;
    _MM_TRANSPOSE4_PS(w0, w1, w2, w3);
    _mm_storeu_ps(reinterpret_cast<float*>(win + 0), w0);
    _mm_storeu_ps(reinterpret_cast<float*>(win + 1), w1);
    _mm_storeu_ps(reinterpret_cast<float*>(win + 2), w2);
    _mm_storeu_ps(reinterpret_cast<float*>(win + 3), w3);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(fixed + 0), _mm_unpacklo_epi32(fixed_x, fixed_y));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(fixed + 2), _mm_unpackhi_epi32(fixed_x, fixed_y));

    // box_bounds, in 32 bits, then saturated to 16 (an inside vertex's are small), then -1 in
    // every lane of a vertex that is not inside (kAnywhereBox).
    const __m128i x0 = _mm_srai_epi32(_mm_add_epi32(fixed_x, _mm_set1_epi32(kFixedOne - 1)), kFixedOrder);
    const __m128i y0 = _mm_srai_epi32(_mm_add_epi32(fixed_y, _mm_set1_epi32(kFixedOne)), kFixedOrder);
    const __m128i neg_x1 = _mm_srai_epi32(_mm_sub_epi32(_mm_set1_epi32(kFixedOne), fixed_x), kFixedOrder);
    const __m128i neg_y1 = _mm_srai_epi32(_mm_sub_epi32(_mm_set1_epi32(kFixedOne - 1), fixed_y), kFixedOrder);
    const auto w = static_cast<short>(vp.width), h = static_cast<short>(vp.height);
    const __m128i not_inside = _mm_xor_si128(_mm_castps_si128(inside), _mm_set1_epi32(-1));
    const __m128i not_inside16 = _mm_packs_epi32(not_inside, not_inside);
    __m128i lower = _mm_max_epi16(_mm_packs_epi32(x0, y0), _mm_setzero_si128());
    __m128i upper = _mm_max_epi16(_mm_packs_epi32(neg_x1, neg_y1),
                                  _mm_set_epi16(static_cast<short>(1 - h), static_cast<short>(1 - h),
                                                static_cast<short>(1 - h), static_cast<short>(1 - h),
                                                static_cast<short>(1 - w), static_cast<short>(1 - w),
                                                static_cast<short>(1 - w), static_cast<short>(1 - w)));
    lower = _mm_or_si128(lower, not_inside16);
    upper = _mm_or_si128(upper, not_inside16);
    lower = _mm_unpacklo_epi16(lower, _mm_srli_si128(lower, 8));  // x0, y0 of vertex 0, 1, 2, 3
    upper = _mm_unpacklo_epi16(upper, _mm_srli_si128(upper, 8));  // -x1, -y1 of each
    _mm_storeu_si128(reinterpret_cast<__m128i*>(bounds + 0), _mm_unpacklo_epi32(lower, upper));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(bounds + 2), _mm_unpackhi_epi32(lower, upper));
}

// Blocks of four from first to last (a multiple of four apart); window_position's unfused
// path: (x * (1/w)) * scale + translate, two roundings, lane by lane.
void prepare_blocks(const glm::vec4* positions, std::size_t first, std::size_t last, const Viewport& vp,
                    glm::vec4* win, FixedXY* fixed, BoxBounds* bounds) {
    const __m128 sx = _mm_set1_ps(vp.scale[0]), sy = _mm_set1_ps(vp.scale[1]), sz = _mm_set1_ps(vp.scale[2]);
    const __m128 tx = _mm_set1_ps(vp.translate[0]), ty = _mm_set1_ps(vp.translate[1]), tz = _mm_set1_ps(vp.translate[2]);
    for (std::size_t i = first; i < last; i += 4) {
        const ClipBlock c = load_block(positions + i);
        const __m128 oow = _mm_div_ps(_mm_set1_ps(1.0f), c.w);
        const __m128 wx = _mm_add_ps(_mm_mul_ps(_mm_mul_ps(c.x, oow), sx), tx);
        const __m128 wy = _mm_add_ps(_mm_mul_ps(_mm_mul_ps(c.y, oow), sy), ty);
        const __m128 wz = _mm_add_ps(_mm_mul_ps(_mm_mul_ps(c.z, oow), sz), tz);
        finish_block(c, wx, wy, wz, oow, vp, win + i, fixed + i, bounds + i);
    }
}

#if defined(__x86_64__) && defined(__GNUC__)
// The 4 x 4 transpose of _MM_TRANSPOSE4_PS in each 128-bit half.
[[gnu::target("avx2"), gnu::always_inline]] inline void transpose_halves(__m256& r0, __m256& r1, __m256& r2,
                                                                        __m256& r3) {
    const __m256 t0 = _mm256_unpacklo_ps(r0, r1), t1 = _mm256_unpacklo_ps(r2, r3);
    const __m256 t2 = _mm256_unpackhi_ps(r0, r1), t3 = _mm256_unpackhi_ps(r2, r3);
    r0 = _mm256_castpd_ps(_mm256_unpacklo_pd(_mm256_castps_pd(t0), _mm256_castps_pd(t1)));
    r1 = _mm256_castpd_ps(_mm256_unpackhi_pd(_mm256_castps_pd(t0), _mm256_castps_pd(t1)));
    r2 = _mm256_castpd_ps(_mm256_unpacklo_pd(_mm256_castps_pd(t2), _mm256_castps_pd(t3)));
    r3 = _mm256_castpd_ps(_mm256_unpackhi_pd(_mm256_castps_pd(t2), _mm256_castps_pd(t3)));
}
// Vertex k in the low half, vertex k + 4 in the high one.
[[gnu::target("avx2"), gnu::always_inline]] inline __m256 load_pair(const float* p, int k) {
    return _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(p + 4 * k)), _mm_loadu_ps(p + 4 * k + 16), 1);
}
[[gnu::target("avx2"), gnu::always_inline]] inline __m256 ge0(__m256 v) {
    return _mm256_cmp_ps(v, _mm256_setzero_ps(), _CMP_GE_OQ);
}

// prepare_blocks eight vertices at a time with AVX2 (SimdLevel::avx2), from first to last (a
// multiple of eight apart): the same IEEE operations lane by lane as prepare_blocks and
// finish_block (no FMA: the unfused path rounds twice), so the same bits. Each 256-bit
// register holds vertices 0-3 in its low half and 4-7 in its high half, so the 4 x 4
// transposes and the packs of the SSE2 blocks work on both halves at once; the stores put
// the halves back in vertex order. The SSE2 loop was 9 % of a level-63 render.
[[gnu::target("avx2")]] void prepare_blocks_avx2(const glm::vec4* positions, std::size_t first, std::size_t last,
                                                 const Viewport& vp, glm::vec4* win, FixedXY* fixed,
                                                 BoxBounds* bounds) {
    const __m256 sx = _mm256_set1_ps(vp.scale[0]), sy = _mm256_set1_ps(vp.scale[1]), sz = _mm256_set1_ps(vp.scale[2]);
    const __m256 tx = _mm256_set1_ps(vp.translate[0]), ty = _mm256_set1_ps(vp.translate[1]),
                 tz = _mm256_set1_ps(vp.translate[2]);
    const __m256 magnitude = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    const __m256 infinity = _mm256_set1_ps(INFINITY);
    const __m256 half = _mm256_set1_ps(0.5f), one = _mm256_set1_ps(static_cast<float>(kFixedOne));
    const auto w = static_cast<short>(vp.width), h = static_cast<short>(vp.height);
    const __m256i upper_limit = _mm256_broadcastsi128_si256(
        _mm_set_epi16(static_cast<short>(1 - h), static_cast<short>(1 - h), static_cast<short>(1 - h),
                      static_cast<short>(1 - h), static_cast<short>(1 - w), static_cast<short>(1 - w),
                      static_cast<short>(1 - w), static_cast<short>(1 - w)));
    for (std::size_t i = first; i < last; i += 8) {
        const float* p = reinterpret_cast<const float*>(positions + i);
        __m256 cx = load_pair(p, 0), cy = load_pair(p, 1), cz = load_pair(p, 2), cw = load_pair(p, 3);
        transpose_halves(cx, cy, cz, cw);
        const __m256 oow = _mm256_div_ps(_mm256_set1_ps(1.0f), cw);
        __m256 wx = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(cx, oow), sx), tx);
        __m256 wy = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(cy, oow), sy), ty);
        __m256 wz = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(cz, oow), sz), tz);

        // finish_block's `inside`: the six sums of draw's cliptest >= 0 (ordered), w and 1/w finite.
        __m256 inside = _mm256_and_ps(_mm256_and_ps(ge0(_mm256_sub_ps(cw, cx)), ge0(_mm256_add_ps(cx, cw))),
                                      _mm256_and_ps(ge0(_mm256_sub_ps(cw, cy)), ge0(_mm256_add_ps(cy, cw))));
        inside = _mm256_and_ps(inside, _mm256_and_ps(ge0(_mm256_add_ps(cz, cw)), ge0(_mm256_sub_ps(cw, cz))));
        inside = _mm256_and_ps(inside, _mm256_and_ps(_mm256_cmp_ps(cw, infinity, _CMP_LT_OQ),
                                                     _mm256_cmp_ps(_mm256_and_ps(oow, magnitude), infinity, _CMP_LT_OQ)));
        const __m256i fixed_x = _mm256_cvtps_epi32(_mm256_mul_ps(_mm256_sub_ps(wx, half), one));
        const __m256i fixed_y = _mm256_cvtps_epi32(_mm256_mul_ps(_mm256_sub_ps(wy, half), one));

        __m256 w3 = oow;
        transpose_halves(wx, wy, wz, w3);  // (vertex k | vertex k + 4) in each
        float* out = reinterpret_cast<float*>(win + i);
        _mm256_storeu_ps(out + 0, _mm256_permute2f128_ps(wx, wy, 0x20));
        _mm256_storeu_ps(out + 8, _mm256_permute2f128_ps(wz, w3, 0x20));
        _mm256_storeu_ps(out + 16, _mm256_permute2f128_ps(wx, wy, 0x31));
        _mm256_storeu_ps(out + 24, _mm256_permute2f128_ps(wz, w3, 0x31));
        const __m256i xy_low = _mm256_unpacklo_epi32(fixed_x, fixed_y), xy_high = _mm256_unpackhi_epi32(fixed_x, fixed_y);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(fixed + i), _mm256_permute2x128_si256(xy_low, xy_high, 0x20));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(fixed + i + 4), _mm256_permute2x128_si256(xy_low, xy_high, 0x31));

        // finish_block's box_bounds, half by half as there.
        const __m256i x0 = _mm256_srai_epi32(_mm256_add_epi32(fixed_x, _mm256_set1_epi32(kFixedOne - 1)), kFixedOrder);
        const __m256i y0 = _mm256_srai_epi32(_mm256_add_epi32(fixed_y, _mm256_set1_epi32(kFixedOne)), kFixedOrder);
        const __m256i neg_x1 = _mm256_srai_epi32(_mm256_sub_epi32(_mm256_set1_epi32(kFixedOne), fixed_x), kFixedOrder);
        const __m256i neg_y1 = _mm256_srai_epi32(_mm256_sub_epi32(_mm256_set1_epi32(kFixedOne - 1), fixed_y), kFixedOrder);
        const __m256i not_inside = _mm256_xor_si256(_mm256_castps_si256(inside), _mm256_set1_epi32(-1));
        const __m256i not_inside16 = _mm256_packs_epi32(not_inside, not_inside);
        __m256i lower = _mm256_max_epi16(_mm256_packs_epi32(x0, y0), _mm256_setzero_si256());
        __m256i upper = _mm256_max_epi16(_mm256_packs_epi32(neg_x1, neg_y1), upper_limit);
        lower = _mm256_or_si256(lower, not_inside16);
        upper = _mm256_or_si256(upper, not_inside16);
        lower = _mm256_unpacklo_epi16(lower, _mm256_srli_si256(lower, 8));
        upper = _mm256_unpacklo_epi16(upper, _mm256_srli_si256(upper, 8));
        const __m256i b_low = _mm256_unpacklo_epi32(lower, upper), b_high = _mm256_unpackhi_epi32(lower, upper);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(bounds + i), _mm256_permute2x128_si256(b_low, b_high, 0x20));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(bounds + i + 4), _mm256_permute2x128_si256(b_low, b_high, 0x31));
    }
}
#endif

}  // namespace
#endif

void prepare_vertices(const glm::vec4* positions, std::size_t first, std::size_t last, const Viewport& vp,
                      bool fused, glm::vec4* win, FixedXY* fixed, BoxBounds* bounds) {
    static_assert(sizeof(glm::vec4) == 16 && sizeof(FixedXY) == 8 && sizeof(BoxBounds) == 8);
    std::size_t i = first;
#if defined(__SSE2__)
    // The fused path (llvmpipe's vertex shader on an FMA host) vertex by vertex: std::fma.
    if (!fused) {
#if defined(__x86_64__) && defined(__GNUC__)
        if (simd_level() == SimdLevel::avx2) {
            i = first + (last - first) / 8 * 8;
            prepare_blocks_avx2(positions, first, i, vp, win, fixed, bounds);
        }
#endif
        const std::size_t blocks_end = i + (last - i) / 4 * 4;
        prepare_blocks(positions, i, blocks_end, vp, win, fixed, bounds);
        i = blocks_end;
    }
#endif
    for (; i < last; ++i) prepare_vertex(positions[i], vp, fused, win[i], fixed[i], bounds[i]);
}

}  // namespace raster

using raster::ClipVertex;
using raster::finite4;
using raster::Primitive;
using raster::Viewport;


namespace {
void check_framebuffer_size(int width, int height) {
    if (width < 1 || height < 1 || width > 16384 || height > 16384) {
        throw Error("framebuffer size " + std::to_string(width) + "x" + std::to_string(height) +
                        " is outside 1..16384",
                    Where::at_key("framebuffer"));
    }
}
}  // namespace

Framebuffer Framebuffer::create(int width, int height, int varying_count) {
    check_framebuffer_size(width, height);
    if (varying_count < 0 || varying_count > kMaxVaryings) {
        throw Error("varying count " + std::to_string(varying_count) + " is outside 0..16",
                    Where::at_key("varying_count"));
    }
    Framebuffer fb;
    fb.width = width;
    fb.height = height;
    fb.varying_count = varying_count;
    const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    fb.colour.resize(n);
    fb.depth.resize(n);
    fb.triangle_id.resize(n);
    fb.patch_id.resize(n);
    fb.barycentric.resize(n);
    fb.tess_coord.resize(n);
    fb.varyings.resize(n * static_cast<std::size_t>(varying_count));
    fb.front_facing.resize(n);
    fb.fragment_count.resize(n);
    fb.clear();
    return fb;
}

Framebuffer Framebuffer::create_visibility(int width, int height) {
    check_framebuffer_size(width, height);
    Framebuffer fb;
    fb.width = width;
    fb.height = height;
    const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    assign_on_huge_pages(fb.depth, n, 1.0f);
    assign_on_huge_pages(fb.triangle_id, n, kNoTriangle);
    return fb;
}

void Framebuffer::clear() {
    std::fill(colour.begin(), colour.end(), glm::vec4(0.0f));
    std::fill(depth.begin(), depth.end(), 1.0f);
    std::fill(triangle_id.begin(), triangle_id.end(), kNoTriangle);
    std::fill(patch_id.begin(), patch_id.end(), kNoTriangle);
    std::fill(barycentric.begin(), barycentric.end(), glm::vec3(0.0f));
    std::fill(barycentric_dx.begin(), barycentric_dx.end(), glm::vec3(0.0f));
    std::fill(barycentric_dy.begin(), barycentric_dy.end(), glm::vec3(0.0f));
    std::fill(tess_coord.begin(), tess_coord.end(), glm::vec3(0.0f));
    std::fill(varyings.begin(), varyings.end(), 0.0f);
    std::fill(front_facing.begin(), front_facing.end(), std::uint8_t{0});
    std::fill(fragment_count.begin(), fragment_count.end(), 0u);
}

std::int32_t snap_subpixel(float window_coordinate) {
    return raster::cvt_rne((window_coordinate - 0.5f) * 256.0f);
}

std::vector<std::uint8_t> to_rgba8(const Framebuffer& fb) {
    std::vector<std::uint8_t> out(fb.colour.size() * 4);
    for (std::size_t i = 0; i < fb.colour.size(); ++i) {
        unorm8_rgba(&fb.colour[i][0], &out[i * 4]);
    }
    return out;
}

namespace {

constexpr int kTileSize = 64;
constexpr std::size_t kChunkTriangles = 2048;       // input triangles set up by one task
constexpr std::size_t kChunksPerWave = 32;          // chunks set up in parallel at once
constexpr std::size_t kBatchPrimitives = 1u << 18;  // primitives kept before rasterizing (~50 MB)
constexpr std::size_t kMaxChunksPerBatch = 1024;

// The prepared vertices of a draw in three arrays: the box test, which every triangle takes,
// reads only the bounds (8 bytes a vertex), setup, which a triangle in two reaches, the
// snapped positions (8 bytes), and the attribute planes of a triangle that covers a pixel the
// window positions.
struct PreparedVertices {
    std::vector<glm::vec4> win;
    std::vector<raster::FixedXY> fixed;
    std::vector<raster::BoxBounds> bounds;  // kAnywhereBox where not inside

    void resize(std::size_t n) {
        win.resize(n);
        fixed.resize(n);
        bounds.resize(n);
    }
    // Vertices [first, last) of positions.
    void prepare(std::span<const glm::vec4> positions, std::size_t first, std::size_t last, const Viewport& viewport,
                 bool fused) {
        raster::prepare_vertices(positions.data(), first, last, viewport, fused, win.data(), fixed.data(),
                                 bounds.data());
    }
};

// A covered pixel of a primitive whose box holds at most four pixels, with its depth and
// weights computed at setup (as the tiles would compute them, fragment_depth and
// fragment_weights): the tiles only test its depth and write it. A seventh of a Primitive's
// memory, one tile to bin it in, and no edge functions to evaluate again.
struct Fragment {
    std::uint16_t x, y;
    float z;
    glm::vec3 weights;
    std::uint32_t source;
    bool front;
};

// A growable array of trivially copyable values whose push_back stays inline (std::vector's,
// called out of line from setup's large loop, cost a call per fragment) and whose growth
// leaves the new elements uninitialized.
template <class T>
class Buffer {
public:
    std::size_t size() const { return size_; }
    T* data() { return data_.get(); }
    const T* data() const { return data_.get(); }
    T& operator[](std::size_t i) { return data_[i]; }
    const T& operator[](std::size_t i) const { return data_[i]; }
    void clear() { size_ = 0; }
    void reserve(std::size_t n) {
        if (n > capacity_) reallocate(n);
    }
    [[gnu::always_inline]] void push_back(const T& value) {
        if (size_ == capacity_) [[unlikely]]
            reallocate(std::max<std::size_t>(64, 2 * capacity_));
        data_[size_++] = value;
    }

private:
    [[gnu::noinline]] void reallocate(std::size_t n) {
        std::unique_ptr<T[]> fresh = std::make_unique_for_overwrite<T[]>(n);
        std::copy_n(data_.get(), size_, fresh.get());
        data_ = std::move(fresh);
        capacity_ = n;
    }
    std::unique_ptr<T[]> data_;
    std::size_t size_ = 0, capacity_ = 0;
};

// The chunk's primitives and fragments in submission order (items), each item an index into
// prims, or into frags with kFragmentItem set.
constexpr std::uint32_t kFragmentItem = 1u << 31;
constexpr std::uint32_t kBoxTiles = UINT32_MAX;

struct Chunk {
    std::vector<Primitive> prims;
    Buffer<Fragment> frags;
    Buffer<std::uint32_t> items;
    Buffer<std::uint32_t> item_tiles;  // per item: its tile, or kBoxTiles (every tile its box overlaps)
    std::vector<std::uint32_t> tile_start;  // tile t's items: tile_items[start[t]..start[t+1])
    std::vector<std::uint32_t> tile_items;
    std::vector<std::uint32_t> candidates, fill;  // setup's working memory
    std::vector<raster::BoxBounds> boxes;         // of the candidates
    std::vector<std::uint8_t> kinds;              // of the candidates setup keeps: one pixel (and facing) or other
    RasterStats stats;
};

// Working memory of one rasterize() call, kept in a small pool and reused: allocating tens of
// megabytes per call costs more in page faults (serialized in the kernel) than the work.
struct Scratch {
    PreparedVertices vertices;
    std::vector<std::uint32_t> source;  // per pixel: input triangle written by this pass
    std::vector<Chunk> chunks;
};

class ScratchPool {
public:
    std::unique_ptr<Scratch> acquire() {
        std::lock_guard<std::mutex> lock(mutex_);
        if (free_.empty()) return std::make_unique<Scratch>();
        std::unique_ptr<Scratch> s = std::move(free_.back());
        free_.pop_back();
        return s;
    }
    void release(std::unique_ptr<Scratch> s) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (free_.size() < 2) free_.push_back(std::move(s));
    }

private:
    std::mutex mutex_;
    std::vector<std::unique_ptr<Scratch>> free_;
};

ScratchPool& scratch_pool() {
    static ScratchPool pool;
    return pool;
}

struct Context {
    const RasterSettings& settings;
    Framebuffer& fb;
    Viewport viewport;
    int tiles_x;
    int tiles_y;
    std::uint32_t* source;  // per pixel: the input triangle of the visible primitive
    bool all_buffers = true;  // false: a visibility framebuffer (no colour, count, facing)
    // Where a passing fragment's weights go: pixel (px, py) at weights[(py - weights_y0) *
    // weights_stride + (px - weights_x0)]; the framebuffer's barycentric, or the buffer of
    // the tile being rasterized (Rasterizer::State::TileWeights).
    glm::vec3* weights = nullptr;
    std::size_t weights_stride = 0;
    int weights_x0 = 0, weights_y0 = 0;
};

// LLVM fuses llvmpipe's viewport multiply-add only where the CPU has FMA.
bool host_has_fma() {
#if defined(__x86_64__) || defined(__i386__)
    static const bool fma = __builtin_cpu_supports("fma");
    return fma;
#else
    return true;
#endif
}

// Whether a triangle names a vertex at or past n, without an exit per index (SSE2: unsigned
// compares as signed ones with the top bit flipped).
bool any_index_at_least(std::span<const std::array<std::uint32_t, 3>> triangles, std::size_t n) {
    static_assert(sizeof(std::array<std::uint32_t, 3>) == 3 * sizeof(std::uint32_t));
    if (triangles.empty()) return false;
    if (n == 0 || n > UINT32_MAX) return n == 0;
    const std::uint32_t* index = triangles.data()->data();
    const std::size_t count = triangles.size() * 3;
    const auto limit = static_cast<std::uint32_t>(n - 1);  // the largest index in range
    std::size_t i = 0;
    bool beyond = false;
#if defined(__SSE2__)
    const __m128i flip = _mm_set1_epi32(INT32_MIN);
    const __m128i largest = _mm_xor_si128(_mm_set1_epi32(static_cast<int>(limit)), flip);
    __m128i any = _mm_setzero_si128();
    for (; i + 4 <= count; i += 4) {
        const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(index + i));
        any = _mm_or_si128(any, _mm_cmpgt_epi32(_mm_xor_si128(v, flip), largest));
    }
    beyond = _mm_movemask_epi8(any) != 0;
#endif
    for (; i < count; ++i) beyond |= index[i] > limit;
    return beyond;
}

// A fragment's position relative to the primitive's attribute origin.
inline float offset_x(const Primitive& p, int px) { return static_cast<float>(px) - p.ox; }
inline float offset_y(const Primitive& p, int py) { return static_cast<float>(py) - p.oy; }

// Depth at a pixel centre, clamped to the depth range.
inline float fragment_depth(const Primitive& p, float fx, float fy) { return raster::depth_value(raster::eval_plane(p.z, fx, fy)); }

// The perspective-correct weights at (wx, wy) relative to the origin.
inline glm::vec3 fragment_weights(const Primitive& p, float wx, float wy) {
    const float oow = raster::eval_plane(p.oow, wx, wy);
    glm::vec3 b;
    for (int k = 0; k < 3; ++k) b[k] = raster::eval_plane(p.bw[k], wx, wy) / oow;
    return b;
}

void push_primitive(const Primitive& prim, Chunk& chunk) {
    chunk.items.push_back(static_cast<std::uint32_t>(chunk.prims.size()));
    chunk.item_tiles.push_back(kBoxTiles);
    chunk.prims.push_back(prim);
}

[[gnu::always_inline]] inline void push_fragment(const Context& ctx, const Fragment& fragment, Chunk& chunk) {
    chunk.items.push_back(static_cast<std::uint32_t>(chunk.frags.size()) | kFragmentItem);
    chunk.item_tiles.push_back(static_cast<std::uint32_t>((fragment.y / kTileSize) * ctx.tiles_x + fragment.x / kTileSize));
    chunk.frags.push_back(fragment);
}

raster::Face face_of(const RasterSettings& s) {
    if (s.cull == CullMode::back) return raster::Face::front_only;
    if (s.cull == CullMode::front) return raster::Face::back_only;
    return raster::Face::both;
}

// A filled triangle into a primitive, or the fragments of its box of at most four pixels
// (without quad derivatives, which need the planes at the tiles), or nothing.

void emit_filled(const Context& ctx, const raster::SetupCorner& a, const raster::SetupCorner& b,
                 const raster::SetupCorner& c, std::uint32_t source, Chunk& chunk) {
    const raster::Face face = face_of(ctx.settings);
    Primitive prim;
    ++chunk.stats.primitives;
    switch (raster::setup_triangle(a, b, c, face, ctx.viewport, prim)) {
        case raster::Setup::culled: ++chunk.stats.primitives_culled; break;
        case raster::Setup::empty: break;  // set up, no pixel to draw
        case raster::Setup::drawn:
            prim.source = source;
            if (prim.small_coverage == raster::kLargeBox || ctx.settings.quad_derivatives) {
                push_primitive(prim, chunk);
                break;
            }
            // The covered pixels in row order, as raster_primitive visits them.
            for (int py = prim.y0, bit = 0; py <= prim.y1; ++py)
                for (int px = prim.x0; px <= prim.x1; ++px, ++bit) {
                    if (!(prim.small_coverage & (1 << bit))) continue;
                    const float fx = offset_x(prim, px), fy = offset_y(prim, py);
                    push_fragment(ctx,
                                  {static_cast<std::uint16_t>(px), static_cast<std::uint16_t>(py),
                                   fragment_depth(prim, fx, fy), fragment_weights(prim, fx, fy), source, prim.front},
                                  chunk);
                }
            break;
    }
}

raster::SetupCorner corner(const ClipVertex& v) {
    return {&v.win, &v.bary, raster::snap_fixed(v.win.x), raster::snap_fixed(v.win.y)};
}

// One triangle that left the clipper (or never needed it), with draw's edge flags
// (bit 0: v0->v1, bit 1: v1->v2, bit 2: v2->v0), into primitives.
void emit_triangle(const Context& ctx, const ClipVertex& a, const ClipVertex& b,
                   const ClipVertex& c, unsigned edge_flags, std::uint32_t source, Chunk& chunk) {
    if (!finite4(a.win) || !finite4(b.win) || !finite4(c.win)) {
        ++chunk.stats.primitives_culled;
        return;
    }
    const RasterSettings& s = ctx.settings;
    if (s.polygon_mode == PolygonMode::fill) {
        emit_filled(ctx, corner(a), corner(b), corner(c), source, chunk);
        return;
    }
    // glPolygonMode(GL_LINE) runs draw's cull stage (draw_pipe_cull.c) on every triangle the
    // clipper emits: the determinant in float window coordinates, det < 0 counter-clockwise
    // in GL terms, and a zero determinant counts as back-facing (so a degenerate triangle's
    // edges are drawn unless back faces are culled).
    const float ex = a.win.x - c.win.x, ey = a.win.y - c.win.y;
    const float fx = b.win.x - c.win.x, fy = b.win.y - c.win.y;
    const float det = ex * fy - ey * fx;
    const bool front = det < 0.0f;
    if ((s.cull == CullMode::back && !front) || (s.cull == CullMode::front && front)) {
        ++chunk.stats.primitives_culled;
        return;
    }
    // draw_pipe_unfilled.c lines(): v2->v0, v0->v1, v1->v2, each if flagged and the start
    // vertex's edge flag is set.
    auto line = [&](const ClipVertex& p, const ClipVertex& q) {
        Primitive prim;
        ++chunk.stats.primitives;
        if (raster::setup_line(p, q, ctx.viewport, prim)) {
            prim.source = source;
            prim.front = front;
            push_primitive(prim, chunk);
        } else {
            ++chunk.stats.primitives_culled;
        }
    };
    if ((edge_flags & 4u) && c.edgeflag) line(c, a);
    if ((edge_flags & 1u) && a.edgeflag) line(a, b);
    if ((edge_flags & 2u) && b.edgeflag) line(b, c);
}

// An unclipped triangle's corners weigh its own vertices.
const glm::vec3 kUnitWeights[3] = {glm::vec3(1.0f, 0.0f, 0.0f), glm::vec3(0.0f, 1.0f, 0.0f), glm::vec3(0.0f, 0.0f, 1.0f)};

// setup_chunk's path for a triangle other than an unclipped one whose box is one pixel: setup
// of a larger box, the clipper, the lines of glPolygonMode(GL_LINE). Apart: the common path's
// loop keeps its registers.
[[gnu::noinline]] void setup_other(const Context& ctx, std::span<const glm::vec4> positions,
                                   const PreparedVertices& prepared, const std::array<std::uint32_t, 3>& tri,
                                   bool unclipped, std::uint32_t source, Chunk& chunk) {
    const glm::vec4* const win = prepared.win.data();
    const raster::FixedXY* const fixed = prepared.fixed.data();
    if (unclipped) {
        // Every vertex inside: emit_triangle's path with the vertices themselves as
        // corners.
        auto corner = [&](int k) -> raster::SetupCorner {
            const std::uint32_t v = tri[static_cast<std::size_t>(k)];
            return {&win[v], &kUnitWeights[k], fixed[v].x, fixed[v].y};
        };
        emit_filled(ctx, corner(0), corner(1), corner(2), source, chunk);
        return;
    }
    ClipVertex cv[3];
    bool finite = true;
    for (int k = 0; k < 3; ++k) {
        cv[k].clip = positions[tri[static_cast<std::size_t>(k)]];
        cv[k].win = win[tri[static_cast<std::size_t>(k)]];
        cv[k].clipmask = raster::compute_clipmask(cv[k].clip);
        cv[k].bary = glm::vec3(0.0f);
        cv[k].bary[k] = 1.0f;
        cv[k].edgeflag = true;
        finite = finite && finite4(cv[k].clip);
    }
    const unsigned mask_or = cv[0].clipmask | cv[1].clipmask | cv[2].clipmask;
    const unsigned mask_and = cv[0].clipmask & cv[1].clipmask & cv[2].clipmask;
    if (!finite || mask_and != 0) {
        ++chunk.stats.triangles_rejected;
        return;
    }
    if (mask_or == 0) {
        emit_triangle(ctx, cv[0], cv[1], cv[2], 7u, source, chunk);
        return;
    }
    ++chunk.stats.triangles_clipped;
    ClipVertex poly[raster::kMaxClipVertices];
    bool edges[raster::kMaxClipVertices];
    const int n = raster::clip_polygon(cv, mask_or, ctx.viewport, poly, edges);
    if (n < 3) return;
    // draw_pipe_clip.c emit_poly() with the provoking vertex last: the fan
    // (i-1, i, 0), edge flags FLAG_2 first, FLAG_0 middle, FLAG_1 last.
    unsigned edge_first = edges[0] ? 4u : 0u;
    const unsigned edge_middle = 1u, edge_last = 2u;
    unsigned flags = edge_first | edge_middle;
    for (int i = 2; i < n; ++i, flags = edge_middle) {
        if (!edges[i - 1]) flags &= ~edge_middle;
        if (i == n - 1 && edges[i]) flags |= edge_last;
        emit_triangle(ctx, poly[i - 1], poly[i], poly[0], flags, source, chunk);
    }
}

// Whether a block of triangles (TriangleBlock) can hold no pixel centre: the lane-wise min of
// its runs' vertex bounds, the box of all their vertices, holds none. Then neither does any
// of its triangles' boxes, which lie in it (each bound is a min, so the block's sums
// x0 + (-x1) and y0 + (-y1) are at most each triangle's). A block with a vertex that is not
// inside (kAnywhereBox) never is.
[[gnu::always_inline]] inline bool block_has_no_pixels(const raster::BoxBounds* bounds, const TriangleBlock& block) {
    if (block.count[0] == 0) return false;
#if defined(__SSE2__)
    // Each run of 2 to 8 vertices as four pairs, the last ones overlapping: the same loads
    // whatever the run's length, without a branch.
    static_assert(kMaxTriangleBlockRun == 8);
    __m128i box = _mm_set1_epi16(INT16_MAX);
    for (int r = 0; r < 2; ++r) {
        const raster::BoxBounds* p = bounds + block.first[r];
        const std::uint32_t last_pair = block.count[r] - 2;
        for (std::uint32_t k = 0; k < 8; k += 2)
            box = _mm_min_epi16(box, _mm_loadu_si128(reinterpret_cast<const __m128i*>(p + std::min(k, last_pair))));
    }
    box = _mm_min_epi16(box, _mm_shuffle_epi32(box, _MM_SHUFFLE(1, 0, 3, 2)));
    const __m128i ends = _mm_add_epi16(box, _mm_shuffle_epi32(box, _MM_SHUFFLE(2, 3, 0, 1)));
    return (_mm_movemask_epi8(_mm_cmpgt_epi16(ends, _mm_setzero_si128())) & 0xF) != 0;
#else
    raster::BoxBounds box = bounds[block.first[0]];
    for (int r = 0; r < 2; ++r)
        for (std::uint32_t k = 0; k < block.count[r]; ++k) box = raster::triangle_box(box, box, bounds[block.first[r] + k]);
    return !raster::box_has_pixels(box);
#endif
}

// Sets up triangles [first, last) of tris, whose ids start at first_id (the chunk's first
// triangle is first_id + 0), with their vertices at `positions`, prepared in `prepared`.
// `blocks`: triangle_blocks(tris) with first = 0, or empty.
void setup_chunk(const Context& ctx, std::span<const glm::vec4> positions, const PreparedVertices& prepared,
                 std::span<const std::array<std::uint32_t, 3>> tris, std::size_t first, std::size_t last,
                 std::uint32_t first_id, std::span<const TriangleBlock> blocks, Chunk& chunk) {
    chunk.prims.clear();
    chunk.frags.clear();
    chunk.items.clear();
    chunk.item_tiles.clear();
    // At most one primitive a triangle unless clipped: no reallocation (and copy into fresh
    // pages) as the chunk fills; pages are only touched as primitives are written.
    chunk.prims.reserve(last - first);
    chunk.stats = {};
    chunk.stats.triangles_in = last - first;
    const bool filled = ctx.settings.polygon_mode == PolygonMode::fill;
    const glm::vec4* const win = prepared.win.data();
    const raster::FixedXY* const fixed = prepared.fixed.data();
    const raster::BoxBounds* const bounds = prepared.bounds.data();

    // Most triangles of a finely tessellated surface hold no pixel centre: the snapped
    // bounding box (setup's own test, on positions snapped once per vertex) rejects them
    // before any setup, the same triangles setup_triangle culls. A first pass keeps the
    // others' indices, in order, without a branch per triangle (about half of them pass,
    // at random: a branch would mispredict every other time). A triangle with a vertex
    // that is not inside (kAnywhere) always passes, to the clipper's path below.
    // The box of a candidate goes with it: the one-pixel boxes (half the triangles of a
    // surface tessellated to about a triangle a pixel, all that survive at finer levels) are
    // set up from it directly.
    chunk.candidates.resize(last - first);
    std::uint32_t* const candidates = chunk.candidates.data();
    std::size_t count = 0;
    if (filled) {
        chunk.boxes.resize(last - first);
        const raster::BoxBounds* b = bounds;
        raster::BoxBounds* box_out = chunk.boxes.data();
        // Triangles [t, end) one by one.
        auto box_test = [&](std::size_t t, std::size_t end) {
#if defined(__SSE2__)
            // Two triangles a step, one in each half of the registers: the box is the lane-wise
            // min of the vertices' bounds; lanes 0 and 1 of each half of box + (its halves'
            // 32-bit pairs swapped) are x0 + (-x1) and y0 + (-y1).
            for (; t + 2 <= end; t += 2) {
                const auto& p = tris[t];
                const auto& q = tris[t + 1];
                auto load = [&](std::uint32_t u, std::uint32_t v) {
                    const __m128 low = _mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(b + u)));
                    return _mm_castps_si128(_mm_loadh_pi(low, reinterpret_cast<const __m64*>(b + v)));
                };
                const __m128i box = _mm_min_epi16(_mm_min_epi16(load(p[0], q[0]), load(p[1], q[1])), load(p[2], q[2]));
                const __m128i ends = _mm_add_epi16(box, _mm_shuffle_epi32(box, _MM_SHUFFLE(2, 3, 0, 1)));
                const int empty = _mm_movemask_epi8(_mm_cmpgt_epi16(ends, _mm_setzero_si128()));
                candidates[count] = static_cast<std::uint32_t>(t);
                _mm_storel_epi64(reinterpret_cast<__m128i*>(box_out + count), box);
                count += (empty & 0xF) == 0;
                candidates[count] = static_cast<std::uint32_t>(t + 1);
                _mm_storeh_pi(reinterpret_cast<__m64*>(box_out + count), _mm_castsi128_ps(box));
                count += (empty & 0xF00) == 0;
            }
#endif
            for (; t < end; ++t) {
                const auto& tri = tris[t];
                const raster::BoxBounds box = raster::triangle_box(b[tri[0]], b[tri[1]], b[tri[2]]);
                candidates[count] = static_cast<std::uint32_t>(t);
                box_out[count] = box;
                count += raster::box_has_pixels(box);
            }
        };
        if (blocks.empty()) {
            box_test(first, last);
        } else {
            // At 30 triangles a pixel three blocks in four hold no pixel centre, at random: the
            // blocks that may are listed first, without a branch on each, then tested triangle
            // by triangle.
            std::uint32_t maybe[64];
            for (std::size_t k0 = 0; k0 < blocks.size(); k0 += std::size(maybe)) {
                const std::size_t k_end = std::min(blocks.size(), k0 + std::size(maybe));
                std::size_t n = 0;
                for (std::size_t k = k0; k < k_end; ++k) {
                    maybe[n] = static_cast<std::uint32_t>(k);
                    n += !block_has_no_pixels(b, blocks[k]);
                }
                for (std::size_t j = 0; j < n; ++j) {
                    const std::size_t t = first + maybe[j] * kTriangleBlock;
                    box_test(t, std::min(t + kTriangleBlock, last));
                }
            }
        }
        const std::size_t rejected = (last - first) - count;
        chunk.stats.primitives += rejected;
        chunk.stats.primitives_culled += rejected;
    } else {
        chunk.boxes.assign(last - first, raster::kAnywhereBox);  // unread, but the candidates carry one
        for (std::size_t t = first; t < last; ++t) candidates[count++] = static_cast<std::uint32_t>(t);
    }

    // emit_filled's path for an unclipped triangle whose box is one pixel, in two passes (see
    // one_pixel_coverage): first every such candidate's outcome, keeping the drawn ones and the
    // others in order (in place: a candidate is written at or before its own slot); then the
    // fragments of the drawn ones and setup_other for the others, in the candidates' order.
    const bool one_pixel_fragments = filled && !ctx.settings.quad_derivatives;
    const raster::Face face = face_of(ctx.settings);
    raster::BoxBounds* const boxes = chunk.boxes.data();
    chunk.kinds.resize(count);
    std::uint8_t* const kinds = chunk.kinds.data();
    constexpr std::uint8_t kOther = 0, kOnePixel = 1, kClockwise = 2, kFront = 4;
    std::uint64_t one_pixel = 0, one_pixel_culled = 0;
    std::size_t kept = 0;
    // Candidate t with its box, its one-pixel outcome from coverage() if its box is one pixel.
    auto keep = [&](std::uint32_t t, raster::BoxBounds box, auto&& coverage) {
        candidates[kept] = t;
        boxes[kept] = box;
        if (one_pixel_fragments & raster::one_pixel_box(box)) {
            const auto& tri = tris[t];
            const raster::OnePixelCoverage c = coverage(fixed[tri[0]], fixed[tri[1]], fixed[tri[2]], box.x0, box.y0);
            ++one_pixel;
            one_pixel_culled += c.setup == raster::Setup::culled;
            kinds[kept] = static_cast<std::uint8_t>(kOnePixel | (c.cw << 1) | (c.front << 2));
            kept += c.setup == raster::Setup::drawn;
        } else {
            kinds[kept++] = kOther;
        }
    };
    std::size_t i = 0;
#if defined(__SSE2__)
    if (one_pixel_fragments) {
        for (; i + 4 <= count; i += 4) {
            // Read before the writes at kept <= i.
            const std::uint32_t t[4] = {candidates[i], candidates[i + 1], candidates[i + 2], candidates[i + 3]};
            const raster::BoxBounds box[4] = {boxes[i], boxes[i + 1], boxes[i + 2], boxes[i + 3]};
            const raster::OnePixelCoverage4 c4 = raster::one_pixel_coverage4(fixed, tris.data(), t, box, face);
            for (int l = 0; l < 4; ++l)
                keep(t[l], box[l], [&](const raster::FixedXY& v0, const raster::FixedXY& v1, const raster::FixedXY& v2,
                                       int px, int py) { return c4.lane(l, v0, v1, v2, px, py); });
        }
    }
#endif
    for (; i < count; ++i) {
        keep(candidates[i], boxes[i],
             [&](const raster::FixedXY& v0, const raster::FixedXY& v1, const raster::FixedXY& v2, int px, int py) {
                 return raster::one_pixel_coverage(v0, v1, v2, px, py, face);
             });
    }
    // At most one fragment a candidate unless its box is larger or it is clipped.
    chunk.frags.reserve(kept);
    chunk.items.reserve(kept);
    chunk.item_tiles.reserve(kept);
    for (std::size_t i = 0; i < kept; ++i) {
        const std::size_t t = candidates[i];
        const auto& tri = tris[t];
        const auto id = static_cast<std::uint32_t>(first_id + (t - first));
        if (kinds[i] == kOther) {
            setup_other(ctx, positions, prepared, tri, filled && boxes[i].x0 >= 0, id, chunk);
            continue;
        }
        const raster::BoxBounds box = boxes[i];
        raster::OnePixelFragment f;
        raster::one_pixel_fragment(win[tri[0]], win[tri[1]], win[tri[2]], (kinds[i] & kClockwise) != 0,
                                   (kinds[i] & kFront) != 0, box.x0, box.y0, f);
        push_fragment(ctx,
                      {static_cast<std::uint16_t>(box.x0), static_cast<std::uint16_t>(box.y0), f.z,
                       glm::vec3(f.weights[0], f.weights[1], f.weights[2]), id, f.front},
                      chunk);
    }
    chunk.stats.primitives += one_pixel;
    chunk.stats.primitives_culled += one_pixel_culled;

    // Bin the chunk's items by tile (a stable counting sort): a fragment in its pixel's
    // tile, a primitive in every tile its box overlaps.
    const int tile_count = ctx.tiles_x * ctx.tiles_y;
    chunk.tile_start.assign(static_cast<std::size_t>(tile_count) + 1, 0u);
    const std::size_t item_count = chunk.items.size();
    const std::uint32_t* items = chunk.items.data();
    const std::uint32_t* item_tiles = chunk.item_tiles.data();
    auto for_each_tile = [&](std::size_t i, auto&& f) {
        if (item_tiles[i] != kBoxTiles) {
            f(item_tiles[i]);
            return;
        }
        const Primitive& p = chunk.prims[items[i]];
        for (int ty = p.y0 / kTileSize; ty <= p.y1 / kTileSize; ++ty)
            for (int tx = p.x0 / kTileSize; tx <= p.x1 / kTileSize; ++tx)
                f(static_cast<std::size_t>(ty * ctx.tiles_x + tx));
    };
    std::uint32_t* start = chunk.tile_start.data();
    for (std::size_t i = 0; i < item_count; ++i) for_each_tile(i, [&](std::size_t tile) { ++start[tile + 1]; });
    for (int t = 0; t < tile_count; ++t) start[t + 1] += start[t];
    chunk.tile_items.resize(start[tile_count]);
    chunk.fill.assign(start, start + tile_count);
    std::uint32_t* fill = chunk.fill.data();
    std::uint32_t* tile_items = chunk.tile_items.data();
    for (std::size_t i = 0; i < item_count; ++i)
        for_each_tile(i, [&](std::size_t tile) { tile_items[fill[tile]++] = items[i]; });
}

// floor(n / d) for d > 0.
inline std::int64_t floor_div(std::int64_t n, std::int64_t d) {
    return n >= 0 ? n / d : -((-n + d - 1) / d);
}

// One covered pixel sample at depth z: the depth test, then the visible surface's data,
// with weights() (the perspective-correct weights) asked for only when it passes. Whether
// it passed.
template <class Weights>
inline bool fragment(Context& ctx, int px, int py, float z, std::uint32_t source, bool front, Weights&& weights,
                     RasterStats& stats) {
    Framebuffer& fb = ctx.fb;
    const RasterSettings& s = ctx.settings;
    const std::size_t idx = static_cast<std::size_t>(py) * static_cast<std::size_t>(fb.width) +
                            static_cast<std::size_t>(px);
    if (ctx.all_buffers) ++fb.fragment_count[idx];
    ++stats.fragments;
    bool pass = true;
    if (s.depth_func == DepthFunc::less) pass = z < fb.depth[idx];
    else if (s.depth_func == DepthFunc::lequal) pass = z <= fb.depth[idx];
    if (!pass) return false;
    ++stats.fragments_passed;
    if (s.depth_write) fb.depth[idx] = z;
    ctx.weights[static_cast<std::size_t>(py - ctx.weights_y0) * ctx.weights_stride +
                static_cast<std::size_t>(px - ctx.weights_x0)] = weights();
    if (ctx.all_buffers) {
        fb.colour[idx] = s.colour;
        fb.front_facing[idx] = front ? 1 : 0;
    }
    ctx.source[idx] = source;
    return true;
}

// A covered pixel of a primitive, its depth and weights from the primitive's planes.
inline void fragment(Context& ctx, const Primitive& p, int px, int py, RasterStats& stats) {
    const float fx = offset_x(p, px), fy = offset_y(p, py);
    if (!fragment(ctx, px, py, fragment_depth(p, fx, fy), p.source, p.front,
                  [&] { return fragment_weights(p, fx, fy); }, stats))
        return;
    if (ctx.settings.quad_derivatives) {
        const std::size_t idx = static_cast<std::size_t>(py) * static_cast<std::size_t>(ctx.fb.width) +
                                static_cast<std::size_t>(px);
        const float qx = static_cast<float>(px & ~1) - p.ox;
        const float qy = static_cast<float>(py & ~1) - p.oy;
        const glm::vec3 top_left = fragment_weights(p, qx, qy);
        ctx.fb.barycentric_dx[idx] = fragment_weights(p, qx + 1.0f, qy) - top_left;
        ctx.fb.barycentric_dy[idx] = top_left - fragment_weights(p, qx, qy + 1.0f);
    }
}

// Every pixel (px, py) of the primitive's box within the tile with all edge functions
// E = c + dcdy * py - dcdx * px > 0, in row order. Narrow boxes test pixel by pixel; wider
// ones solve each row's span exactly in integers (the same set, fewer tests).
template <int Planes>
void raster_primitive(Context& ctx, const Primitive& p, int tx0, int ty0, int tx1, int ty1,
                      RasterStats& stats) {
    const int x0 = std::max(p.x0, tx0), x1 = std::min(p.x1, tx1);
    const int y0 = std::max(p.y0, ty0), y1 = std::min(p.y1, ty1);
    if (x0 > x1 || y0 > y1) return;
    const bool narrow = x1 - x0 < 6;
    for (int py = y0; py <= y1; ++py) {
        std::int64_t e[Planes];
        for (int k = 0; k < Planes; ++k) e[k] = p.c[k] + p.dcdy[k] * py;
        if (narrow) {
            for (int k = 0; k < Planes; ++k) e[k] -= p.dcdx[k] * x0;
            for (int px = x0; px <= x1; ++px) {
                bool inside = true;
                for (int k = 0; k < Planes; ++k) inside = inside && e[k] > 0;
                for (int k = 0; k < Planes; ++k) e[k] -= p.dcdx[k];
                if (inside) fragment(ctx, p, px, py, stats);
            }
            continue;
        }
        std::int64_t lo = x0, hi = x1;
        for (int k = 0; k < Planes && lo <= hi; ++k) {
            const std::int64_t b = p.dcdx[k];
            if (b > 0) {
                hi = std::min(hi, floor_div(e[k] - 1, b));  // b * px < e
            } else if (b < 0) {
                lo = std::max(lo, -floor_div(e[k] - 1, -b));  // -b * px > -e
            } else if (e[k] <= 0) {
                hi = lo - 1;
            }
        }
        for (std::int64_t px = lo; px <= hi; ++px) fragment(ctx, p, static_cast<int>(px), py, stats);
    }
}

// The pixels (inclusive bounds) a tile's items of one flush can touch: the union of their
// boxes within the tile. Empty while x1 < x0.
struct PixelBox {
    int x0 = INT_MAX, y0 = INT_MAX, x1 = -1, y1 = -1;
    void add(int ax0, int ay0, int ax1, int ay1) {
        x0 = std::min(x0, ax0);
        y0 = std::min(y0, ay0);
        x1 = std::max(x1, ax1);
        y1 = std::max(y1, ay1);
    }
};

void raster_tile(Context& ctx, int tile, const std::vector<Chunk>& chunks, std::size_t chunk_count,
                 RasterStats& stats, PixelBox& touched) {
    const int tx = tile % ctx.tiles_x, ty = tile / ctx.tiles_x;
    const int x0 = tx * kTileSize, y0 = ty * kTileSize;
    const int x1 = std::min(x0 + kTileSize, ctx.fb.width) - 1;
    const int y1 = std::min(y0 + kTileSize, ctx.fb.height) - 1;
    const auto t = static_cast<std::size_t>(tile);
    for (std::size_t c = 0; c < chunk_count; ++c) {
        const Chunk& chunk = chunks[c];
        for (std::uint32_t i = chunk.tile_start[t]; i < chunk.tile_start[t + 1]; ++i) {
            const std::uint32_t item = chunk.tile_items[i];
            if (item & kFragmentItem) {
                const Fragment& g = chunk.frags[item & ~kFragmentItem];
                touched.add(g.x, g.y, g.x, g.y);
                fragment(ctx, g.x, g.y, g.z, g.source, g.front, [&] { return g.weights; }, stats);
                continue;
            }
            const Primitive& p = chunk.prims[item];
            touched.add(std::max(p.x0, x0), std::max(p.y0, y0), std::min(p.x1, x1), std::min(p.y1, y1));
            if (p.plane_count == 3) raster_primitive<3>(ctx, p, x0, y0, x1, y1, stats);
            else raster_primitive<4>(ctx, p, x0, y0, x1, y1, stats);
        }
    }
}

void validate(const Framebuffer& fb, const RasterInput& in) {
    if (fb.width < 1 || fb.height < 1 ||
        fb.depth.size() != static_cast<std::size_t>(fb.width) * static_cast<std::size_t>(fb.height)) {
        throw Error("framebuffer is not allocated (use Framebuffer::create)", Where::at_key("framebuffer"));
    }
    if (fb.colour.size() != fb.depth.size() || fb.fragment_count.size() != fb.depth.size())
        throw Error("rasterize() writes every buffer: a visibility framebuffer is for the Rasterizer class",
                    Where::at_key("framebuffer"));
    if (in.varying_count < 0 || in.varying_count > kMaxVaryings) {
        throw Error("varying count " + std::to_string(in.varying_count) + " is outside 0..16",
                    Where::at_key("varying_count"));
    }
    if (in.varying_count > fb.varying_count) {
        throw Error("input has " + std::to_string(in.varying_count) + " varyings, framebuffer " +
                        std::to_string(fb.varying_count),
                    Where::at_key("varying_count"));
    }
    const std::size_t nv = in.positions.size();
    if (in.varyings.size() != nv * static_cast<std::size_t>(in.varying_count)) {
        throw Error("varyings hold " + std::to_string(in.varyings.size()) + " floats, expected " +
                        std::to_string(nv * static_cast<std::size_t>(in.varying_count)),
                    Where::at_key("varyings"));
    }
    if (!in.tess_coords.empty() && in.tess_coords.size() != nv) {
        throw Error("tess_coords must have one entry per vertex", Where::at_key("tess_coords"));
    }
    if (!in.triangle_ids.empty() && in.triangle_ids.size() != in.triangles.size()) {
        throw Error("triangle_ids must have one entry per triangle", Where::at_key("triangle_ids"));
    }
    if (!in.patch_ids.empty() && in.patch_ids.size() != in.triangles.size()) {
        throw Error("patch_ids must have one entry per triangle", Where::at_key("patch_ids"));
    }
    for (std::size_t t = 0; t < in.triangles.size(); ++t) {
        for (std::uint32_t v : in.triangles[t]) {
            if (v >= nv) {
                throw Error("vertex index " + std::to_string(v) + " out of range (" + std::to_string(nv) +
                                " vertices)",
                            Where::at_key("triangles[" + std::to_string(t) + "]"));
            }
        }
    }
}

// Ids, tess coords and varyings of the visible surface from the input triangle each pixel
// kept (source) and its weights.
void resolve(Framebuffer& fb, const RasterInput& in, const std::uint32_t* source) {
    const auto vc = static_cast<std::size_t>(fb.varying_count);
    const auto ivc = static_cast<std::size_t>(in.varying_count);
    tessref::parallel_for(tbb::blocked_range<int>(0, fb.height), [&](const tbb::blocked_range<int>& rows) {
        for (int y = rows.begin(); y < rows.end(); ++y) {
            for (int x = 0; x < fb.width; ++x) {
                const std::size_t idx = static_cast<std::size_t>(y) * static_cast<std::size_t>(fb.width) +
                                        static_cast<std::size_t>(x);
                const std::uint32_t src = source[idx];
                if (src == kNoTriangle) continue;
                const auto& tri = in.triangles[src];
                const glm::vec3 b = fb.barycentric[idx];
                fb.triangle_id[idx] = in.triangle_ids.empty() ? src : in.triangle_ids[src];
                fb.patch_id[idx] = in.patch_ids.empty() ? kNoTriangle : in.patch_ids[src];
                glm::vec3 tc(0.0f);
                if (!in.tess_coords.empty()) {
                    tc = b[0] * in.tess_coords[tri[0]] + b[1] * in.tess_coords[tri[1]] +
                         b[2] * in.tess_coords[tri[2]];
                }
                fb.tess_coord[idx] = tc;
                float* out = vc ? &fb.varyings[idx * vc] : nullptr;
                for (std::size_t j = 0; j < vc; ++j) {
                    out[j] = j < ivc ? b[0] * in.varyings[tri[0] * ivc + j] +
                                           b[1] * in.varyings[tri[1] * ivc + j] +
                                           b[2] * in.varyings[tri[2] * ivc + j]
                                     : 0.0f;
                }
            }
        }
    });
}

}  // namespace

// The machinery both entry points share: chunks set up in parallel, binned by tile, and
// rasterized tile by tile once a batch has piled up.
struct Rasterizer::State {
    State(Framebuffer& framebuffer, const RasterSettings& s, std::uint32_t* source)
        : settings(s),
          ctx{settings, framebuffer, raster::make_viewport(framebuffer.width, framebuffer.height), 0, 0, source} {
        ctx.tiles_x = (framebuffer.width + kTileSize - 1) / kTileSize;
        ctx.tiles_y = (framebuffer.height + kTileSize - 1) / kTileSize;
        ctx.all_buffers = framebuffer.colour.size() == framebuffer.depth.size() &&
                          framebuffer.fragment_count.size() == framebuffer.depth.size() &&
                          framebuffer.front_facing.size() == framebuffer.depth.size();
        tile_stats.resize(static_cast<std::size_t>(ctx.tiles_x * ctx.tiles_y));
        fused = settings.window_transform == WindowTransform::vertex_shader && host_has_fma();
        if (settings.quad_derivatives) {
            framebuffer.barycentric_dx.resize(framebuffer.depth.size(), glm::vec3(0.0f));
            framebuffer.barycentric_dy.resize(framebuffer.depth.size(), glm::vec3(0.0f));
        }
        if (framebuffer.barycentric.empty()) {
            tile_weights.emplace();
            tile_weights->of_tile.resize(tile_stats.size());
        } else {
            ctx.weights = framebuffer.barycentric.data();
            ctx.weights_stride = static_cast<std::size_t>(framebuffer.width);
        }
    }

    // A framebuffer without barycentric (create_visibility): the weights of the last flush
    // in one buffer per tile it drew in, taken from a pool of free ones and given back at the
    // next flush. They are needed only between a draw and the resolve of what it drew, so a
    // render clears and faults in a buffer per tile a batch touches instead of 12 bytes for
    // every pixel of the image (at 1280x800, 12 MB: 12 % of the CPU time of a level-16
    // render of the bench terrain).
    struct TileWeights {
        static constexpr std::size_t kSize = std::size_t{kTileSize} * kTileSize;  // row stride kTileSize
        std::vector<std::unique_ptr<glm::vec3[]>> of_tile;  // per tile: null where the flush drew nothing
        std::vector<std::unique_ptr<glm::vec3[]>> free;
    };

    // Gives every tile that has items among the chunks [0, used) a weights buffer.
    void assign_tile_weights() {
        TileWeights& w = *tile_weights;
        for (std::unique_ptr<glm::vec3[]>& buffer : w.of_tile)
            if (buffer) w.free.push_back(std::move(buffer));
        for (std::size_t t = 0; t < w.of_tile.size(); ++t) {
            bool items = false;
            for (std::size_t c = 0; c < used && !items; ++c) items = chunks[c].tile_start[t + 1] > chunks[c].tile_start[t];
            if (!items) continue;
            if (w.free.empty()) {
                // Not cleared: a pixel's weights are read only where its fragment wrote them.
                w.of_tile[t] = std::make_unique_for_overwrite<glm::vec3[]>(TileWeights::kSize);
            } else {
                w.of_tile[t] = std::move(w.free.back());
                w.free.pop_back();
            }
        }
    }

    // Rasterizes the set-up chunks [0, used) into the tiles, then forgets them.
    void flush() {
        if (used == 0) return;
        const int tile_count = ctx.tiles_x * ctx.tiles_y;
        drawn.assign(static_cast<std::size_t>(tile_count), PixelBox{});
        if (tile_weights) assign_tile_weights();
        tessref::parallel_for(0, tile_count, [&](int tile) {
            RasterStats& stats = tile_stats[static_cast<std::size_t>(tile)];
            const std::uint64_t passed = stats.fragments_passed;
            PixelBox touched;
            Context tile_ctx = ctx;
            if (tile_weights) {
                tile_ctx.weights = tile_weights->of_tile[static_cast<std::size_t>(tile)].get();
                tile_ctx.weights_stride = kTileSize;
                tile_ctx.weights_x0 = tile % ctx.tiles_x * kTileSize;
                tile_ctx.weights_y0 = tile / ctx.tiles_x * kTileSize;
            }
            raster_tile(tile_ctx, tile, chunks, used, stats, touched);
            if (stats.fragments_passed != passed) drawn[static_cast<std::size_t>(tile)] = touched;
        });
        for (std::size_t c = 0; c < used; ++c) {
            const RasterStats& s = chunks[c].stats;
            total.triangles_in += s.triangles_in;
            total.triangles_clipped += s.triangles_clipped;
            total.triangles_rejected += s.triangles_rejected;
            total.primitives += s.primitives;
            total.primitives_culled += s.primitives_culled;
        }
        used = 0;
    }

    RasterStats stats() const {
        RasterStats out = total;
        for (const RasterStats& s : tile_stats) {
            out.fragments += s.fragments;
            out.fragments_passed += s.fragments_passed;
        }
        return out;
    }

    RasterSettings settings;
    Context ctx;
    bool fused = false;
    std::vector<Chunk> chunks;  // storage reused across batches
    std::size_t used = 0;
    RasterStats total;
    std::vector<RasterStats> tile_stats;
    // Per tile: where the last flush's items lie, if a fragment of theirs passed (else empty).
    std::vector<PixelBox> drawn;
    std::optional<TileWeights> tile_weights;  // a framebuffer without barycentric
};

namespace {

RasterStats run(Framebuffer& fb, const RasterInput& input, const RasterSettings& settings) {
    std::unique_ptr<Scratch> scratch = scratch_pool().acquire();
    scratch->source.assign(fb.depth.size(), kNoTriangle);
    Rasterizer::State state(fb, settings, scratch->source.data());
    state.chunks = std::move(scratch->chunks);

    PreparedVertices& vertices = scratch->vertices;
    vertices.resize(input.positions.size());
    tessref::parallel_for(tbb::blocked_range<std::size_t>(0, input.positions.size(), 4096),
                          [&](const tbb::blocked_range<std::size_t>& r) {
                              vertices.prepare(input.positions, r.begin(), r.end(), state.ctx.viewport, state.fused);
                          });

    // Set up chunks in parallel waves and rasterize the tiles once enough primitives have
    // piled up. Batches must be large: a batch of consecutive triangles of a tessellated
    // surface covers few tiles, which would leave the tile phase to one thread.
    std::size_t batch_prims = 0;
    const std::size_t tri_count = input.triangles.size();
    for (std::size_t wave_first = 0; wave_first < tri_count; wave_first += kChunkTriangles * kChunksPerWave) {
        const std::size_t wave_last = std::min(tri_count, wave_first + kChunkTriangles * kChunksPerWave);
        const std::size_t wave = (wave_last - wave_first + kChunkTriangles - 1) / kChunkTriangles;
        const std::size_t used = state.used;
        if (state.chunks.size() < used + wave) state.chunks.resize(used + wave);
        tessref::parallel_for(std::size_t{0}, wave, [&](std::size_t c) {
            const std::size_t first = wave_first + c * kChunkTriangles;
            setup_chunk(state.ctx, input.positions, vertices, input.triangles, first, std::min(wave_last, first + kChunkTriangles),
                        static_cast<std::uint32_t>(first), {}, state.chunks[used + c]);
        });
        for (std::size_t c = 0; c < wave; ++c) batch_prims += state.chunks[used + c].items.size();
        state.used += wave;
        if (batch_prims >= kBatchPrimitives || state.used >= kMaxChunksPerBatch) {
            state.flush();
            batch_prims = 0;
        }
    }
    state.flush();
    resolve(fb, input, scratch->source.data());
    const RasterStats total = state.stats();
    scratch->chunks = std::move(state.chunks);
    scratch_pool().release(std::move(scratch));
    return total;
}

}  // namespace

RasterStats rasterize(Framebuffer& fb, const RasterInput& input, const RasterSettings& settings) {
    validate(fb, input);
    if (settings.threads > 0) {
        tbb::task_arena arena(settings.threads);
        RasterStats stats;
        tessref::execute(arena, [&] { stats = run(fb, input, settings); });
        return stats;
    }
    return run(fb, input, settings);
}

std::vector<TriangleBlock> triangle_blocks(std::span<const std::array<std::uint32_t, 3>> triangles) {
    std::vector<TriangleBlock> blocks((triangles.size() + kTriangleBlock - 1) / kTriangleBlock);
    std::uint32_t max_index = 0;
    for (const auto& tri : triangles) max_index = std::max({max_index, tri[0], tri[1], tri[2]});
    std::vector<std::uint32_t> v;
    for (std::size_t k = 0; k < blocks.size(); ++k) {
        v.clear();
        const std::size_t end = std::min(triangles.size(), (k + 1) * kTriangleBlock);
        for (std::size_t t = k * kTriangleBlock; t < end; ++t) v.insert(v.end(), triangles[t].begin(), triangles[t].end());
        std::sort(v.begin(), v.end());
        v.erase(std::unique(v.begin(), v.end()), v.end());
        // The largest gap between neighbouring indices splits them into two runs.
        std::size_t split = v.size();  // the second run's first element
        for (std::size_t i = 1; i < v.size(); ++i)
            if (split == v.size() || v[i] - v[i - 1] > v[split] - v[split - 1]) split = i;
        TriangleBlock block;
        block.first = {v.front(), v[split % v.size()]};
        block.count = {v[split - 1] - v.front() + 1, v.back() - v[split % v.size()] + 1};
        for (int r = 0; r < 2; ++r) {
            if (block.count[r] > 1) continue;
            // A run of one vertex, and a neighbour that some triangle indexes too (every
            // index is below the vertex count).
            if (block.first[r] < max_index) {
                block.count[r] = 2;
            } else if (block.first[r] > 0) {
                --block.first[r];
                block.count[r] = 2;
            }
        }
        if (block.count[0] >= 2 && block.count[1] >= 2 && block.count[0] <= kMaxTriangleBlockRun &&
            block.count[1] <= kMaxTriangleBlockRun)
            blocks[k] = block;
    }
    return blocks;
}

Rasterizer::Rasterizer(Framebuffer& fb, const RasterSettings& settings) {
    if (fb.width < 1 || fb.height < 1 ||
        fb.depth.size() != static_cast<std::size_t>(fb.width) * static_cast<std::size_t>(fb.height) ||
        fb.triangle_id.size() != fb.depth.size() ||
        (!fb.barycentric.empty() && fb.barycentric.size() != fb.depth.size()))
        throw Error("framebuffer is not allocated (use Framebuffer::create or create_visibility)",
                    Where::at_key("framebuffer"));
    state_ = std::make_unique<State>(fb, settings, fb.triangle_id.data());
}
Rasterizer::~Rasterizer() = default;

void Rasterizer::draw(std::span<const RasterChunk> chunks) {
    draw(chunks.size(), [&](std::size_t c) { return chunks[c]; });
}

void Rasterizer::draw(std::size_t count, const std::function<RasterChunk(std::size_t)>& make) {
    State& s = *state_;
    const std::size_t used = s.used;
    if (s.chunks.size() < used + count) s.chunks.resize(used + count);
    tessref::parallel_for(std::size_t{0}, count, [&](std::size_t c) {
        const RasterChunk chunk = make(c);
        thread_local PreparedVertices vertices;
        vertices.resize(chunk.positions.size());
        vertices.prepare(chunk.positions, 0, chunk.positions.size(), s.ctx.viewport, s.fused);
        // Whether an index is out of range first (a loop without an exit), then the first one
        // only when there is one.
        if (!chunk.indices_in_range && any_index_at_least(chunk.triangles, chunk.positions.size())) {
            for (const auto& tri : chunk.triangles)
                for (const std::uint32_t v : tri)
                    if (v >= chunk.positions.size())
                        throw Error("vertex index " + std::to_string(v) + " out of range (" +
                                        std::to_string(chunk.positions.size()) + " vertices in the chunk)",
                                    Where::at_key("triangles"));
        }
        if (!chunk.blocks.empty() && chunk.blocks.size() != (chunk.triangles.size() + kTriangleBlock - 1) / kTriangleBlock)
            throw Error("a chunk's triangle blocks are not its triangles'", Where::at_key("triangles"));
        setup_chunk(s.ctx, chunk.positions, vertices, chunk.triangles, 0, chunk.triangles.size(), chunk.first_id,
                    chunk.blocks, s.chunks[used + c]);
    });
    s.used += count;
    s.flush();
}

RasterStats Rasterizer::stats() const { return state_->stats(); }

std::vector<Rasterizer::Rect> Rasterizer::drawn() const {
    const State& s = *state_;
    std::vector<Rect> out;
    for (std::size_t tile = 0; tile < s.drawn.size(); ++tile) {
        const PixelBox& box = s.drawn[tile];
        if (box.x1 < box.x0) continue;
        // Whole 2x2 quads: tiles start on even pixels, so the quads stay inside the tile.
        const int x = box.x0 & ~1, row = box.y0 & ~1;
        const int x_end = std::min((box.x1 | 1) + 1, s.ctx.fb.width), row_end = std::min((box.y1 | 1) + 1, s.ctx.fb.height);
        const auto t = static_cast<int>(tile);
        const WeightsView weights = s.tile_weights ? WeightsView{s.tile_weights->of_tile[tile].get(), kTileSize,
                                                                 t % s.ctx.tiles_x * kTileSize, t / s.ctx.tiles_x * kTileSize}
                                                   : WeightsView::of(s.ctx.fb);
        out.push_back({x, row, x_end - x, row_end - row, weights});
    }
    return out;
}

}  // namespace tessref
