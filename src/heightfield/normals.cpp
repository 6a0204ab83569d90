// Normals from a height field: the thesis's normal map and lab 4's appendix A normal
// (see tessref/heightfield.h for the text they follow and the quirks kept).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "common/parallel.h"
#include "tessref/error.h"
#include "tessref/heightfield.h"

namespace tessref {

namespace {

// "Negative goes from 0 to 127, positive goes from 127 to 255."
inline std::uint8_t normal_code(double n) {
    return static_cast<std::uint8_t>(std::clamp((n * 0.5 + 0.5) * 255.0, 0.0, 255.0));
}

#if defined(__SSE2__)
// Two texels' vectors, one texel a lane.
struct Vec3x2 {
    __m128d x, y, z;
};

inline Vec3x2 operator-(const Vec3x2& a, const Vec3x2& b) {
    return {_mm_sub_pd(a.x, b.x), _mm_sub_pd(a.y, b.y), _mm_sub_pd(a.z, b.z)};
}
inline Vec3x2 operator+(const Vec3x2& a, const Vec3x2& b) {
    return {_mm_add_pd(a.x, b.x), _mm_add_pd(a.y, b.y), _mm_add_pd(a.z, b.z)};
}
// glm::cross, its products and differences in its order.
inline Vec3x2 cross(const Vec3x2& a, const Vec3x2& b) {
    return {_mm_sub_pd(_mm_mul_pd(a.y, b.z), _mm_mul_pd(b.y, a.z)), _mm_sub_pd(_mm_mul_pd(a.z, b.x), _mm_mul_pd(b.z, a.x)),
            _mm_sub_pd(_mm_mul_pd(a.x, b.y), _mm_mul_pd(b.x, a.y))};
}

// What the pairs of one row share: the scaled heights of the row (z) and of its clamped
// neighbour rows, and the rows' positions y * spacing.
struct PairRow {
    const double* z;
    const double* up_z;
    const double* down_z;
    __m128d y, y_up, y_down;
};

// The codes of texels x and x + 1 of a row, neither on the left or right edge, into out[0..5]:
// the scalar loop's doubles (the same operations in the same order, lane by lane). xs: every
// column's position x * spacing.
inline void normal_codes_x2(const PairRow& row, const double* xs, int x, std::uint8_t* out) {
    const Vec3x2 p{_mm_loadu_pd(xs + x), row.y, _mm_loadu_pd(row.z + x)};
    const Vec3x2 right = Vec3x2{_mm_loadu_pd(xs + x + 1), p.y, _mm_loadu_pd(row.z + x + 1)} - p;
    const Vec3x2 up = Vec3x2{p.x, row.y_up, _mm_loadu_pd(row.up_z + x)} - p;
    const Vec3x2 left = Vec3x2{_mm_loadu_pd(xs + x - 1), p.y, _mm_loadu_pd(row.z + x - 1)} - p;
    const Vec3x2 down = Vec3x2{p.x, row.y_down, _mm_loadu_pd(row.down_z + x)} - p;
    const Vec3x2 sum = cross(right, up) + cross(up, left) + cross(left, down) + cross(down, right);
    const __m128d length = _mm_sqrt_pd(
        _mm_add_pd(_mm_add_pd(_mm_mul_pd(sum.x, sum.x), _mm_mul_pd(sum.y, sum.y)), _mm_mul_pd(sum.z, sum.z)));
    // Where the length is not above 0 (also NaN): (0, 0, 1).
    const __m128d some = _mm_cmpgt_pd(length, _mm_setzero_pd());
    auto normal = [&](__m128d v, double otherwise) {
        return _mm_or_pd(_mm_and_pd(some, _mm_div_pd(v, length)), _mm_andnot_pd(some, _mm_set1_pd(otherwise)));
    };
    // normal_code lane by lane: maxpd and minpd clamp as std::clamp does (a NaN, from infinite
    // heights, becomes 0, what the scalar conversion of a NaN gives on x86), cvttpd2dq truncates.
    auto code = [&](__m128d n) {
        const __m128d encoded = _mm_mul_pd(_mm_add_pd(_mm_mul_pd(n, _mm_set1_pd(0.5)), _mm_set1_pd(0.5)), _mm_set1_pd(255.0));
        return _mm_cvttpd_epi32(_mm_min_pd(_mm_max_pd(encoded, _mm_setzero_pd()), _mm_set1_pd(255.0)));
    };
    const __m128i cx = code(normal(sum.x, 0.0)), cy = code(normal(sum.y, 0.0)), cz = code(normal(sum.z, 1.0));
    out[0] = static_cast<std::uint8_t>(_mm_cvtsi128_si32(cx));
    out[1] = static_cast<std::uint8_t>(_mm_cvtsi128_si32(cy));
    out[2] = static_cast<std::uint8_t>(_mm_cvtsi128_si32(cz));
    out[3] = static_cast<std::uint8_t>(_mm_cvtsi128_si32(_mm_srli_si128(cx, 4)));
    out[4] = static_cast<std::uint8_t>(_mm_cvtsi128_si32(_mm_srli_si128(cy, 4)));
    out[5] = static_cast<std::uint8_t>(_mm_cvtsi128_si32(_mm_srli_si128(cz, 4)));
}
#endif

}  // namespace

std::vector<std::uint8_t> thesis_normal_map_codes(const Texture& height_map, double texel_spacing,
                                                  double height_scale) {
    if (height_map.empty()) throw Error("thesis_normal_map: the height map is empty");
    if (!(texel_spacing > 0.0) || !std::isfinite(texel_spacing) || !std::isfinite(height_scale))
        throw Error("thesis_normal_map: texel spacing must be positive and finite and the height "
                    "scale finite");
    const int width = height_map.width();
    const int height = height_map.height();
    std::vector<std::uint8_t> codes(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3);
    // Blocks of rows in parallel, each texel on its own. A block first reads the scaled
    // heights of its rows and the row on either side once: every texel is read by itself and
    // its four neighbours.
    tessref::parallel_for(tbb::blocked_range<int>(0, height, 16), [&](const tbb::blocked_range<int>& rows) {
        const int first = std::max(rows.begin() - 1, 0), last = std::min(rows.end(), height - 1);
        // Not zeroed first: row_exact writes every value.
        const std::unique_ptr<double[]> z(new double[static_cast<std::size_t>(last - first + 1) * static_cast<std::size_t>(width)]);
        auto heights = [&](int y) {
            return z.get() + static_cast<std::size_t>(y - first) * static_cast<std::size_t>(width);
        };
        for (int y = first; y <= last; ++y) {
            const std::span<double> row(heights(y), static_cast<std::size_t>(width));
            height_map.row_exact(y, 0, row);
            for (double& v : row) v *= height_scale;
        }
#if defined(__SSE2__)
        const std::unique_ptr<double[]> xs(new double[static_cast<std::size_t>(width)]);
        for (int x = 0; x < width; ++x) xs[static_cast<std::size_t>(x)] = x * texel_spacing;
#endif
        // The position vector of pixel (x, y), neighbours clamped to the edge.
        auto P = [&](int x, int y) {
            x = std::clamp(x, 0, width - 1);
            y = std::clamp(y, 0, height - 1);
            return glm::dvec3(x * texel_spacing, y * texel_spacing, heights(y)[x]);
        };
        auto codes_of = [&](int x, int y) {
            return codes.data() + (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                                   static_cast<std::size_t>(x)) * 3;
        };
        auto texel = [&](int x, int y) {
            const glm::dvec3 p = P(x, y);
            // "the four vectors (one for each neighbour pixel)"
            const glm::dvec3 right = P(x + 1, y) - p;
            const glm::dvec3 up = P(x, y + 1) - p;
            const glm::dvec3 left = P(x - 1, y) - p;
            const glm::dvec3 down = P(x, y - 1) - p;
            // "2 by 2 vectors are crossed ... 90 degrees of each other ... four normals for
            // the current pixel, these are summed together and normalized"
            const glm::dvec3 sum = glm::cross(right, up) + glm::cross(up, left) +
                                   glm::cross(left, down) + glm::cross(down, right);
            const double length = glm::length(sum);
            // Only a degenerate height map (a single texel) leaves every product zero.
            const glm::dvec3 normal = length > 0.0 ? sum / length : glm::dvec3(0.0, 0.0, 1.0);
            std::uint8_t* out = codes_of(x, y);
            for (int c = 0; c < 3; ++c) out[c] = normal_code(normal[c]);
        };
        for (int y = rows.begin(); y < rows.end(); ++y) {
            int x = 0;
#if defined(__SSE2__)
            // Between the edge columns, whose neighbours clamp, two texels at a time.
            if (width >= 4) {
                const int y_up = std::min(y + 1, height - 1), y_down = std::max(y - 1, 0);
                const PairRow row{heights(y),
                                  heights(y_up),
                                  heights(y_down),
                                  _mm_set1_pd(y * texel_spacing),
                                  _mm_set1_pd(y_up * texel_spacing),
                                  _mm_set1_pd(y_down * texel_spacing)};
                texel(0, y);
                std::uint8_t* out = codes_of(1, y);
                for (x = 1; x + 2 < width; x += 2, out += 6) normal_codes_x2(row, xs.get(), x, out);
            }
#endif
            for (; x < width; ++x) texel(x, y);
        }
    });
    return codes;
}

Texture thesis_normal_map(const Texture& height_map, double texel_spacing, double height_scale,
                          MipmapRule rule) {
    return Texture::from_unorm8(height_map.width(), height_map.height(), 3,
                                thesis_normal_map_codes(height_map, texel_spacing, height_scale),
                                rule);
}

glm::vec3 decode_unorm_normal(glm::vec3 rgb) { return rgb * 2.0f - 1.0f; }
glm::dvec3 decode_unorm_normal(glm::dvec3 rgb) { return rgb * 2.0 - 1.0; }

}  // namespace tessref
