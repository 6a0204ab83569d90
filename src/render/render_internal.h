// render_internal.h — pieces shared by the rasterized and the ray-traced renderers
// (private to src/render/).
#pragma once

#include <array>
#include <cstddef>
#include <string>

#include <glm/glm.hpp>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include "tessref/error.h"
#include "tessref/raster.h"
#include "tessref/render.h"

namespace tessref::render_detail {

// Normalized device coordinates of the centre of image pixel (x, row) (row 0 on top): the
// inverse of the viewport transform win = (ndc + 1) * size / 2 at window (x + 0.5,
// height - 1 - row + 0.5).
inline glm::dvec2 pixel_ndc(double x, double row, int width, int height) {
    const double wy = static_cast<double>(height) - 1.0 - row;
    return {(x + 0.5) * 2.0 / width - 1.0, (wy + 0.5) * 2.0 / height - 1.0};
}

// The perspective-correct weights, at NDC point p, of the triangle with clip-space corners
// c[0..2]: the affine weights beta (sum 1) of the clip-space point sum(beta_i c_i) whose
// projection is p. With h_i = (x_i, y_i, w_i), sum(beta_i h_i) is proportional to
// (p.x, p.y, 1), so by Cramer's rule beta_i is proportional to det(p, h_j, h_k) for (i, j, k)
// cyclic. No division by w_i: corners behind the eye are fine. Evaluates the triangle's
// plane outside the triangle too (helper pixels). NaN or inf where the plane is seen
// edge-on (the weights' sum vanishes).
// The three cross products depend on the triangle alone: PerspectiveWeights computes them
// once for any number of points (the same operations, so the same values).
struct PerspectiveWeights {
    glm::dvec3 c12, c20, c01;
    explicit PerspectiveWeights(const std::array<glm::dvec4, 3>& c) {
        const glm::dvec3 h0(c[0].x, c[0].y, c[0].w), h1(c[1].x, c[1].y, c[1].w), h2(c[2].x, c[2].y, c[2].w);
        c12 = glm::cross(h1, h2);
        c20 = glm::cross(h2, h0);
        c01 = glm::cross(h0, h1);
    }
    glm::dvec3 operator()(glm::dvec2 p) const {
        const glm::dvec3 q(p, 1.0);
        const glm::dvec3 b(glm::dot(q, c12), glm::dot(q, c20), glm::dot(q, c01));
        return b / (b.x + b.y + b.z);
    }
};
inline glm::dvec3 perspective_weights(const std::array<glm::dvec4, 3>& c, glm::dvec2 p) {
    return PerspectiveWeights(c)(p);
}

// llvmpipe's per-quad derivatives of the visible primitive's texture coordinate (render.h):
// the triangle's interpolation at the quad's top-left, top-right and bottom-left pixel
// centres, inside the triangle or not (helper pixels). What they read of the triangle:
// its clip-space corners and its texture coordinates as the float varying.
struct QuadTriangle {
    std::array<glm::vec4, 3> clip;
    std::array<glm::vec2, 3> uv;
};
// The NDC of the quad's pixel centres: `first` of its left column and top row, `second` of
// its right column and bottom row (pixel_ndc of its top-left and bottom-right pixels).
struct QuadNdc {
    glm::dvec2 first, second;
};
struct Derivatives {
    glm::vec2 dx{0.0f}, dy{0.0f};
};

inline Derivatives quad_derivatives(const QuadTriangle& t, const QuadNdc& ndc) {
    const PerspectiveWeights weights(
        {glm::dvec4(t.clip[0]), glm::dvec4(t.clip[1]), glm::dvec4(t.clip[2])});
    // perspective_weights at each of the three pixels, with the products shared: a weight is
    // dot((ndc.x, ndc.y, 1), c) = (ndc.x c.x + ndc.y c.y) + c.z in glm's order, and the
    // three pixels take their ndc.x from the quad's two columns and ndc.y from its two rows.
    const glm::dvec3 cx(weights.c12.x, weights.c20.x, weights.c01.x), cy(weights.c12.y, weights.c20.y, weights.c01.y),
        cz(weights.c12.z, weights.c20.z, weights.c01.z);
    const glm::dvec3 left = ndc.first.x * cx, right = ndc.second.x * cx, top = ndc.first.y * cy,
                     bottom = ndc.second.y * cy;
    auto uv = [&](const glm::dvec3& column, const glm::dvec3& row) {
        const glm::dvec3 b = column + row + cz;
        const glm::vec3 w(b / (b.x + b.y + b.z));
        return w[0] * t.uv[0] + w[1] * t.uv[1] + w[2] * t.uv[2];  // SurfaceView::uv_at
    };
    const glm::vec2 top_left = uv(left, top);
    return {uv(right, top) - top_left, top_left - uv(left, bottom)};
}

#if defined(__SSE2__)
// quad_derivatives of two triangles at once, a and b in the two lanes of every double
// (and in the halves of every float register): each lane's operations are the scalar
// one's, in its order, so each lane's values are its bits.
inline void quad_derivatives_x2(const QuadTriangle& a, const QuadTriangle& b, const QuadNdc& ndc, Derivatives out[2]) {
    // h_i = (x_i, y_i, w_i) of both triangles: (a's, b's) per coordinate.
    struct H {
        __m128d x, y, w;
    };
    auto corner = [&](int i) {
        const __m128 pa = _mm_loadu_ps(&a.clip[static_cast<std::size_t>(i)].x);
        const __m128 pb = _mm_loadu_ps(&b.clip[static_cast<std::size_t>(i)].x);
        const __m128 xy = _mm_unpacklo_ps(pa, pb), zw = _mm_unpackhi_ps(pa, pb);  // (ax, bx, ay, by), (az, bz, aw, bw)
        return H{_mm_cvtps_pd(xy), _mm_cvtps_pd(_mm_movehl_ps(xy, xy)), _mm_cvtps_pd(_mm_movehl_ps(zw, zw))};
    };
    const H h0 = corner(0), h1 = corner(1), h2 = corner(2);
    // glm::cross(p, q): (p.y q.z - q.y p.z, p.z q.x - q.z p.x, p.x q.y - q.x p.y), z being w.
    auto cross = [](const H& p, const H& q) {
        return H{_mm_sub_pd(_mm_mul_pd(p.y, q.w), _mm_mul_pd(q.y, p.w)),
                 _mm_sub_pd(_mm_mul_pd(p.w, q.x), _mm_mul_pd(q.w, p.x)),
                 _mm_sub_pd(_mm_mul_pd(p.x, q.y), _mm_mul_pd(q.x, p.y))};
    };
    const H c12 = cross(h1, h2), c20 = cross(h2, h0), c01 = cross(h0, h1);
    // cx = (c12.x, c20.x, c01.x) and so on: H's x, y, w here stand for the weights 0, 1, 2.
    const H cx{c12.x, c20.x, c01.x}, cy{c12.y, c20.y, c01.y}, cz{c12.w, c20.w, c01.w};
    auto times = [](double k, const H& c) {
        const __m128d kk = _mm_set1_pd(k);
        return H{_mm_mul_pd(kk, c.x), _mm_mul_pd(kk, c.y), _mm_mul_pd(kk, c.w)};
    };
    const H left = times(ndc.first.x, cx), right = times(ndc.second.x, cx), top = times(ndc.first.y, cy),
            bottom = times(ndc.second.y, cy);
    // The texture coordinates (a's u, v, b's u, v) per corner.
    auto uvs = [&](int i) {
        const glm::vec2 p = a.uv[static_cast<std::size_t>(i)], q = b.uv[static_cast<std::size_t>(i)];
        return _mm_setr_ps(p.x, p.y, q.x, q.y);
    };
    const __m128 uv0 = uvs(0), uv1 = uvs(1), uv2 = uvs(2);
    auto uv = [&](const H& column, const H& row) {
        const __m128d b0 = _mm_add_pd(_mm_add_pd(column.x, row.x), cz.x);
        const __m128d b1 = _mm_add_pd(_mm_add_pd(column.y, row.y), cz.y);
        const __m128d b2 = _mm_add_pd(_mm_add_pd(column.w, row.w), cz.w);
        const __m128d sum = _mm_add_pd(_mm_add_pd(b0, b1), b2);
        // Each weight in float, spread over its triangle's two lanes: (a, a, b, b).
        auto weight = [&](__m128d bi) {
            const __m128 w = _mm_cvtpd_ps(_mm_div_pd(bi, sum));
            return _mm_unpacklo_ps(w, w);
        };
        return _mm_add_ps(_mm_add_ps(_mm_mul_ps(weight(b0), uv0), _mm_mul_ps(weight(b1), uv1)),
                          _mm_mul_ps(weight(b2), uv2));
    };
    const __m128 top_left = uv(left, top);
    alignas(16) float dx[4], dy[4];
    _mm_store_ps(dx, _mm_sub_ps(uv(right, top), top_left));
    _mm_store_ps(dy, _mm_sub_ps(top_left, uv(left, bottom)));
    out[0] = {{dx[0], dx[1]}, {dy[0], dy[1]}};
    out[1] = {{dx[2], dx[3]}, {dy[2], dy[3]}};
}
#endif

// The quad derivatives of count triangles: two at a time where SSE2 allows.
inline void quad_derivatives(const QuadTriangle* triangles, int count, const QuadNdc& ndc, Derivatives* out) {
    int k = 0;
#if defined(__SSE2__)
    for (; k + 2 <= count; k += 2) quad_derivatives_x2(triangles[k], triangles[k + 1], ndc, out + k);
#endif
    for (; k < count; ++k) out[k] = quad_derivatives(triangles[k], ndc);
}

// Window z (depth range [0, 1]) of a clip-space point.
inline double window_depth(const glm::dvec4& clip) { return 0.5 * (clip.z / clip.w) + 0.5; }

// The pixels of the 2x2 quad of (x, row) that llvmpipe's derivatives read: its top-left,
// top-right and bottom-left pixels (image rows; the framebuffer of a window is stored top
// row first, so the quads are aligned on even image rows). A quad cut by the image border
// still has its pixel positions: helper pixels outside the image are evaluated too.
struct QuadPixels {
    int x0, row0;
};
inline QuadPixels quad_of(int x, int row) { return {x & ~1, row & ~1}; }

// Resizes and clears the per-pixel buffers of `result` for a width x height image; without
// `visibility`, all but depth and triangle_id, which the rasterizing renderer takes from its
// framebuffer when done (take_visibility: the same values, moved, not allocated and copied a
// second time); without `provenance`, not patch_id, tess_coord, barycentric and level
// (RenderOptions::provenance); with `colour8`, rgba8 (the background's codes) instead of
// colour (RenderOptions::colour8: the resolve converts each pixel it shades).
void allocate(RenderResult& result, int width, int height, bool visibility = true, bool provenance = true,
              bool colour8 = false);
// RenderOptions::colour8 for a renderer that shaded into the float colour: its codes into
// rgba8, and colour freed.
void keep_colour8(RenderResult& result);
void take_visibility(RenderResult& result, Framebuffer& fb);

// to_rgba8 into `out` (4 bytes a pixel), in parallel: for a caller whose buffer is not
// cleared first, so that its pages are first touched on every thread, not one. A colour8
// render's codes are copied.
void to_rgba8(const RenderResult& result, std::uint8_t* out);

// The camera with the image size applied (RenderOptions::size), and the size checked.
SceneCamera camera_for(const Scene& scene, const RenderOptions& options);

}  // namespace tessref::render_detail
