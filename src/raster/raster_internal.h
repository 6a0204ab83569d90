// src/raster/raster_internal.h — the rasterizer's private pieces (clipper, setup), shared by
// the files of src/raster/ and nothing else.
//
// Coordinates here are Mesa's internal ones for a window-system framebuffer: x to the right,
// y DOWN (row 0 = top row), because that is the orientation llvmpipe snaps and tests in.
// GL window y = height - raster y.
#pragma once

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstddef>
#include <cstdint>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include <glm/glm.hpp>

namespace tessref::raster {

// Viewport transform as Mesa's state tracker hands it to draw for a window-system buffer
// (_mesa_get_viewport_xform, then the Y_0_TOP flip of st_update_viewport).
struct Viewport {
    int width = 0;
    int height = 0;
    float scale[3] = {};
    float translate[3] = {};
};
Viewport make_viewport(int width, int height);

// A vertex as draw's clipper sees it.
struct ClipVertex {
    glm::vec4 clip{0.0f};   // clip-space position (draw's clip_pos)
    glm::vec4 win{0.0f};    // window x, y (y down), z, and 1/w
    glm::vec3 bary{0.0f};   // weights of the source triangle's three vertices
    unsigned clipmask = 0;  // bit i: outside draw's plane i
    bool edgeflag = true;
};

// Window position as draw computes it: (p * (1/w)) * scale + translate, 1/w in .w; fused:
// the last multiply-add as one fma (llvmpipe's vertex-shader JIT), else C's two roundings
// (draw's post-shader path behind tessellation/geometry shaders, and the clipper).
// Inline, as the next two and cvt_rne: the rasterizer runs them on every vertex.
inline glm::vec4 window_position(const glm::vec4& clip, const Viewport& vp, bool fused) {
    const float oow = 1.0f / clip.w;
    glm::vec4 win;
    if (fused) {
        // draw_llvm.c generate_viewport: out * (1/w), then lp_build_fmuladd(out, scale, trans),
        // which LLVM fuses on a host with FMA.
        for (int k = 0; k < 3; ++k) win[k] = std::fma(clip[k] * oow, vp.scale[k], vp.translate[k]);
    } else {
        // draw_cliptest_tmp.h / draw_pipe_clip.c interp(), C compiled without FMA:
        // w = 1.0f / pos[3]; pos * w * scale + trans.
        win.x = clip.x * oow * vp.scale[0] + vp.translate[0];
        win.y = clip.y * oow * vp.scale[1] + vp.translate[1];
        win.z = clip.z * oow * vp.scale[2] + vp.translate[2];
    }
    win.w = oow;
    return win;
}
// draw's cliptest bits: 0 x>w, 1 x<-w, 2 y>w, 3 y<-w, 4 z<-w, 5 z>w.
inline unsigned compute_clipmask(const glm::vec4& p) {
    // draw_cliptest_tmp.h with DO_CLIP_XY | DO_CLIP_FULL_Z (GL's -1..1 depth).
    unsigned mask = 0;
    if (-p.x + p.w < 0) mask |= 1u << 0;
    if (p.x + p.w < 0) mask |= 1u << 1;
    if (-p.y + p.w < 0) mask |= 1u << 2;
    if (p.y + p.w < 0) mask |= 1u << 3;
    if (p.z + p.w < 0) mask |= 1u << 4;
    if (-p.z + p.w < 0) mask |= 1u << 5;
    return mask;
}


// Largest polygon the clipper can produce (Mesa's MAX_CLIPPED_VERTICES with no user planes
// is larger; 3 + 6 planes is what a convex clip of a triangle can reach, plus slack for
// vertices lying exactly on a plane).
inline constexpr int kMaxClipVertices = 32;

// Clips one triangle (clipmask = OR of its vertices' masks, nonzero, AND zero) against the
// view volume, as draw_pipe_clip.c's do_clip_tri does. Writes the polygon to out (edges[i]:
// polygon edge i -> i+1 is an original edge) and returns its vertex count, 0 when nothing is
// left or a clip distance was infinite/NaN (draw discards those).
int clip_polygon(const ClipVertex (&in)[3], unsigned clipmask, const Viewport& viewport,
                 ClipVertex (&out)[kMaxClipVertices], bool (&edges)[kMaxClipVertices]);

// One primitive ready for rasterization: a set-up triangle (3 planes) or line (4 planes).
struct Primitive {
    // Inclusive pixel bounding box in raster coordinates, clamped to the framebuffer.
    int x0, y0, x1, y1;
    int plane_count;
    // Edge functions: E(px, py) = c + dcdy * py - dcdx * px (dcdx, dcdy already scaled by
    // 256, c with the fill-rule bias); pixel (px, py) is covered iff E > 0 for every plane.
    std::int64_t c[4];
    std::int64_t dcdx[4];
    std::int64_t dcdy[4];
    // Float attribute planes a(px, py) = a[0] + a[1] * (px - ox) + a[2] * (py - oy), at pixel
    // centres (px, py integer): depth, 1/w and the three barycentric weights times 1/w.
    float ox, oy;
    float z[3];
    float oow[3];
    float bw[3][3];
    std::uint32_t source;  // index of the input triangle
    bool front;
    // A triangle whose box holds at most four pixels: bit (py - y0) * (x1 - x0 + 1) + (px - x0)
    // set for each pixel (px, py) that passes the edge functions; kLargeBox for a larger box
    // (or a line), which the tiles test pixel by pixel.
    int small_coverage;
};
inline constexpr int kLargeBox = -1;

// Whether pixel (px, py) passes every edge function of the primitive (llvmpipe's coverage
// test, exact in 64-bit integers). All of them evaluated, without a branch: whether a tiny
// triangle covers a pixel centre is a coin toss a branch would mispredict.
inline bool covered(const Primitive& p, int px, int py) {
    bool inside = true;
    for (int k = 0; k < p.plane_count; ++k) inside &= p.c[k] + p.dcdy[k] * py - p.dcdx[k] * px > 0;
    return inside;
}

// llvmpipe's triangle setup (calc_fixed_position + do_triangle_ccw): culled (zero area,
// culled face, or empty bounding box, as llvmpipe culls), empty (set up, but a box of at most
// four pixels none of whose centres passes the edge functions: it would draw nothing, so its
// attribute planes are not computed and prim holds only its box and edges), or drawn (with
// small_coverage: which pixels of a box of at most four it covers).
enum class Face { both, front_only, back_only };
enum class Setup { culled, empty, drawn };
// A corner as setup reads it: its window position, its weights of the source triangle's
// vertices, and the window position snapped (snap_fixed of win.x and win.y). Pointers: an
// unclipped triangle's corners are its prepared vertices, snapped once per vertex rather
// than once per triangle, and their weights the unit vectors (no ClipVertex copies).
struct SetupCorner {
    const glm::vec4* win;
    const glm::vec3* bary;
    std::int32_t x, y;
};
inline Setup setup_triangle(const SetupCorner& v0, const SetupCorner& v1, const SetupCorner& v2, Face face,
                            const Viewport& viewport, Primitive& prim);

// llvmpipe's one-pixel-wide line setup (try_setup_line, diamond-exit rule, non-rectangular).
bool setup_line(const ClipVertex& v1, const ClipVertex& v2, const Viewport& viewport,
                Primitive& prim);

inline constexpr int kFixedOrder = 8;  // FIXED_ORDER: 8 sub-pixel bits
inline constexpr int kFixedOne = 1 << kFixedOrder;

// do_triangle_ccw's bounding box of three snapped vertices; bottom_edge_rule = 1 gives
// adj = 1. Its x0 and y0 may name a column/row whose centre lies left of / above the
// snapped triangle, or is its topmost vertex, which the fill rule leaves out (llvmpipe lets
// the edge functions reject them); tightening them changes no coverage and drops most
// sub-pixel triangles before any plane is set up. Inline: the rasterizer runs it on every
// triangle of a tessellated surface.
[[gnu::always_inline]] inline void triangle_bbox(const std::int32_t* x, const std::int32_t* y, Primitive& prim) {
    const int adj = 1;
    const std::int32_t min_x = std::min(std::min(x[0], x[1]), x[2]), max_x = std::max(std::max(x[0], x[1]), x[2]);
    const std::int32_t min_y = std::min(std::min(y[0], y[1]), y[2]), max_y = std::max(std::max(y[0], y[1]), y[2]);
    prim.x0 = std::max(min_x >> kFixedOrder, (min_x + kFixedOne - 1) >> kFixedOrder);
    prim.x1 = (max_x - 1) >> kFixedOrder;
    prim.y0 = std::max((min_y + adj) >> kFixedOrder, (min_y + kFixedOne) >> kFixedOrder);
    prim.y1 = (max_y - 1 + adj) >> kFixedOrder;
}

// The box clamped to the viewport; false when nothing is left.
inline bool clamp_bbox(Primitive& prim, const Viewport& vp) {
    prim.x0 = std::max(prim.x0, 0);
    prim.y0 = std::max(prim.y0, 0);
    prim.x1 = std::min(prim.x1, vp.width - 1);
    prim.y1 = std::min(prim.y1, vp.height - 1);
    return prim.x0 <= prim.x1 && prim.y0 <= prim.y1;
}

// Edge planes of a convex ccw polygon (in llvmpipe's sense: positive fixed-point area) with
// the bottom-left fill convention that Mesa selects for a window-system framebuffer
// (bottom_edge_rule = 1: in raster coordinates, y down, bottom edges are included; in GL
// window coordinates, y up, that is the bottom-left rule).
// The fill-rule bias of an edge: 1 for left edges (both fill conventions) and, by the
// bottom-left convention, for horizontal edges with dcdy < 0.
inline int edge_bias(std::int64_t dcdx, std::int64_t dcdy) { return (dcdx < 0) | ((dcdx == 0) & (dcdy < 0)); }
inline void make_planes(const std::int32_t* x, const std::int32_t* y, int count, Primitive& prim) {
    prim.plane_count = count;
    for (int i = 0; i < count; ++i) {
        const int j = (i + 1) % count;
        const std::int32_t dcdy = x[i] - x[j];
        const std::int32_t dcdx = y[i] - y[j];
        const std::int64_t c = static_cast<std::int64_t>(dcdx) * x[i] - static_cast<std::int64_t>(dcdy) * y[i] +
                               edge_bias(dcdx, dcdy);
        prim.c[i] = c;
        prim.dcdx[i] = static_cast<std::int64_t>(dcdx) * kFixedOne;
        prim.dcdy[i] = static_cast<std::int64_t>(dcdy) * kFixedOne;
    }
}


// Which pixel centres of the primitive's box pass all its edge functions, for boxes of at
// most four pixels (bit (py - y0) * width + (px - x0)); kLargeBox for larger ones, which
// the tiles decide. The test is the tiles' own, E = c + dcdy * py - dcdx * px > 0 in 64-bit
// integers (covered()), so it agrees with them pixel for pixel. Most triangles of a finely
// tessellated surface that survive the box test are slivers between pixel centres: this
// spares them the float planes and the binning, and the rasterizer writes the pixels of the
// others without testing them again.
inline int small_box_coverage(const Primitive& p) {
    const int width = p.x1 - p.x0 + 1;
    if (width * (p.y1 - p.y0 + 1) > 4) return kLargeBox;
    int mask = 0;
    for (int py = p.y0, bit = 0; py <= p.y1; ++py)
        for (int px = p.x0; px <= p.x1; ++px, ++bit) mask |= covered(p, px, py) << bit;
    return mask;
}

// setup_triangle in two halves. The integer one, inline (the rasterizer runs it on every
// triangle that passes the box test, and half of them end here): orientation, culling,
// box and edge functions, which pixels of a small box are covered; v in setup's vertex
// order on return (the first two swapped for a clockwise triangle).
[[gnu::always_inline]] inline Setup setup_coverage(const SetupCorner* (&v)[3], Face face, const Viewport& vp,
                                                   Primitive& prim) {
    std::int32_t x[3] = {v[0]->x, v[1]->x, v[2]->x}, y[3] = {v[0]->y, v[1]->y, v[2]->y};
    const std::int32_t dx01 = x[0] - x[1], dy01 = y[0] - y[1];
    const std::int32_t dx20 = x[2] - x[0], dy20 = y[2] - y[0];
    const std::int64_t area = static_cast<std::int64_t>(dx01) * dy20 - static_cast<std::int64_t>(dx20) * dy01;
    if (area == 0) return Setup::culled;
    // Positive area is counter-clockwise in GL window coordinates: front-facing.
    const bool front = area > 0;
    if ((face == Face::front_only && !front) || (face == Face::back_only && front)) return Setup::culled;
    if (area < 0) {  // rotate_fixed_position_01 (provoking vertex last)
        std::swap(v[0], v[1]);
        std::swap(x[0], x[1]);
        std::swap(y[0], y[1]);
    }
    prim.front = front;

    triangle_bbox(x, y, prim);
    if (!clamp_bbox(prim, vp)) return Setup::culled;
    make_planes(x, y, 3, prim);
    prim.small_coverage = small_box_coverage(prim);
    return prim.small_coverage == 0 ? Setup::empty : Setup::drawn;
}
// The float one, for a drawn triangle: the attribute planes (depth, 1/w, weights).
void setup_attributes(const SetupCorner* const (&v)[3], Primitive& prim);

inline Setup setup_triangle(const SetupCorner& v0, const SetupCorner& v1, const SetupCorner& v2, Face face,
                            const Viewport& viewport, Primitive& prim) {
    const SetupCorner* v[3] = {&v0, &v1, &v2};
    const Setup result = setup_coverage(v, face, viewport, prim);
    if (result == Setup::drawn) setup_attributes(v, prim);
    return result;
}

// Round-to-nearest-even as SSE's cvtps2dq (out of range: INT32_MIN), and Mesa's util_iround
// on x86-64 ((int)(f + 0.5f), in float).
inline std::int32_t cvt_rne(float v) {
#if defined(__SSE2__)
    // The instruction itself (round to nearest even under the default MXCSR; out of range
    // and NaN give INT32_MIN), without a libm call per vertex.
    return _mm_cvtss_si32(_mm_set_ss(v));
#else
    if (!(std::fabs(v) < 2147483648.0f)) return INT32_MIN;  // SSE "integer indefinite"
    return static_cast<std::int32_t>(std::nearbyint(v));
#endif
}
std::int32_t util_iround(float f);

// A window coordinate in llvmpipe's 8-bit sub-pixel fixed point (calc_fixed_position:
// (v - 0.5) * 256 rounded to nearest even, as cvtps2dq).
inline std::int32_t snap_fixed(float window_coordinate) {
    return cvt_rne((window_coordinate - 0.5f) * static_cast<float>(kFixedOne));
}


inline bool finite4(const glm::vec4& v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z) && std::isfinite(v.w);
}

// A window position snapped as setup snaps it (snap_fixed of x and y).
struct FixedXY {
    std::int32_t x, y;
};

// A vertex's share of the box test, 8 bytes. triangle_bbox's four bounds are each a
// non-decreasing function of one coordinate of one vertex (min_x, max_x, min_y or max_y), and
// so is clamp_bbox's clamp: the clamped box of a triangle is the min (x0, y0) and max (x1, y1)
// of its vertices' clamped bounds, computed once per vertex rather than once per triangle
// (about two triangles a vertex). Kept as (x0, y0, -x1, -y1) in 16 bits, x0 and y0 at least 0,
// x1 at most width - 1 and y1 at most height - 1: a triangle's box is then the lane-wise min
// of its three vertices' (triangle_box), and holds a pixel iff x0 + (-x1) <= 0 and
// y0 + (-y1) <= 0 (box_has_pixels). The snapped position of an inside vertex lies within a
// pixel of the viewport (|x|, |y| <= w), so its bounds and their sums fit 16 bits.
struct BoxBounds {
    std::int16_t x0, y0, neg_x1, neg_y1;
};
// The bounds of a vertex that is not inside (outside a clip plane, or without a finite clip
// or window position): a triangle with it always passes the box test (x0 + (-x1) <= -2), to
// the clipper's path, and its box's x0 < 0 says so: a triangle's box has x0 >= 0 iff its
// three vertices are inside.
inline constexpr BoxBounds kAnywhereBox = {-1, -1, -1, -1};

// An inside vertex's bounds (triangle_bbox of one vertex, adj = 1, clamped): in 32 bits, each
// max of triangle_bbox is its second term; -((x - 1) >> 8) is (256 - x) >> 8, and
// -(y >> 8) is (255 - y) >> 8.
inline BoxBounds box_bounds(std::int32_t x, std::int32_t y, const Viewport& vp) {
    return {static_cast<std::int16_t>(std::max((x + kFixedOne - 1) >> kFixedOrder, 0)),
            static_cast<std::int16_t>(std::max((y + kFixedOne) >> kFixedOrder, 0)),
            static_cast<std::int16_t>(std::max((kFixedOne - x) >> kFixedOrder, 1 - vp.width)),
            static_cast<std::int16_t>(std::max((kFixedOne - 1 - y) >> kFixedOrder, 1 - vp.height))};
}
inline BoxBounds triangle_box(const BoxBounds& a, const BoxBounds& b, const BoxBounds& c) {
    auto min3 = [](std::int16_t p, std::int16_t q, std::int16_t r) { return std::min(std::min(p, q), r); };
    return {min3(a.x0, b.x0, c.x0), min3(a.y0, b.y0, c.y0), min3(a.neg_x1, b.neg_x1, c.neg_x1),
            min3(a.neg_y1, b.neg_y1, c.neg_y1)};
}
// Whether a triangle's box holds a pixel of the viewport: one whose box holds none covers no
// pixel (setup culls it).
inline bool box_has_pixels(const BoxBounds& box) { return box.x0 + box.neg_x1 <= 0 && box.y0 + box.neg_y1 <= 0; }
// Whether the box is the one pixel (x0, y0) and every vertex inside. Without a branch per
// condition: setup_chunk asks it of every candidate.
inline bool one_pixel_box(const BoxBounds& box) {
    return (box.x0 >= 0) & (box.x0 + box.neg_x1 == 0) & (box.y0 + box.neg_y1 == 0);
}

// A vertex as setup and the box test read it, from its clip position: the window position,
// the snap, and the bounds, kAnywhereBox unless the vertex is inside: finite clip and window
// positions inside every clip plane (draw's cliptest), where setup needs no clipper.
[[gnu::always_inline]] inline void prepare_vertex(const glm::vec4& clip, const Viewport& vp, bool fused,
                                                  glm::vec4& win, FixedXY& fixed, BoxBounds& bounds) {
    win = window_position(clip, vp, fused);
    fixed = {snap_fixed(win.x), snap_fixed(win.y)};
    const bool inside = finite4(clip) && compute_clipmask(clip) == 0 && finite4(win);
    bounds = inside ? box_bounds(fixed.x, fixed.y, vp) : kAnywhereBox;
}
// prepare_vertex of positions[first, last) into win[], fixed[] and bounds[] (same indices):
// the unfused window transform four vertices at a time with SSE2 where there is SSE2, the
// same bits as prepare_vertex (the same IEEE operations lane by lane).
void prepare_vertices(const glm::vec4* positions, std::size_t first, std::size_t last, const Viewport& vp,
                      bool fused, glm::vec4* win, FixedXY* fixed, BoxBounds* bounds);

// Plane through three (x, y, a) points, evaluated at pixel centres relative to vertex 0
// (setup_attributes; zero gradients where they are not finite).
inline void triangle_plane(const float a[3], float ooa, float dx01, float dy01, float dx20, float dy20,
                           float out[3]) {
    const float da01 = a[0] - a[1];
    const float da20 = a[2] - a[0];
    float dadx = (da01 * dy20 - dy01 * da20) * ooa;
    float dady = (dx01 * da20 - da01 * dx20) * ooa;
    if (!std::isfinite(dadx) || !std::isfinite(dady)) dadx = dady = 0.0f;
    out[0] = a[0];
    out[1] = dadx;
    out[2] = dady;
}
// An attribute plane at (fx, fy) relative to its origin.
inline float eval_plane(const float plane[3], float fx, float fy) { return plane[0] + plane[1] * fx + plane[2] * fy; }
// An interpolated depth, clamped to the depth range.
inline float depth_value(float z) { return std::isnan(z) ? 1.0f : std::clamp(z, 0.0f, 1.0f); }

// The fragment of a drawn triangle whose box is one pixel.
struct OnePixelFragment {
    float z;
    float weights[3];
    bool front;
};
// setup_triangle of an unclipped triangle (three `inside` vertices, unit weights) whose box is
// the one pixel (px, py), then the fragment the tiles would compute from its planes
// (fragment_depth, fragment_weights): the same integers and the same float operations in the
// same order, so the same outcome, depth and weights bit for bit, without the planes kept.
//
// Coverage: with the positions taken relative to the pixel (x - 256 px, y - 256 py), the edge
// function of make_planes at the pixel, c + dcdy * py - dcdx * px, is the same integer as
// x_j * y_i - x_i * y_j + bias (bias 0 or 1), and do_triangle_ccw's area the sum of the three
// x_j * y_i - x_i * y_j. A clockwise triangle is set up as (v1, v0, v2), which reverses each
// edge and the sign of its product. So where no product is 0 (the centre on no edge line),
// the pixel is covered iff the three have one sign; where one is 0, its bias decides, as
// setup computes it.
//
// The attribute planes: depth in float; 1/w and the three weights times 1/w as the lanes of
// one SSE2 vector (a weight is 1/w at its own vertex's lane, +0 at the others: 1/w of an
// inside vertex is positive and finite).
// Whether the pixel centre passes the three edge functions with their bias, in setup's vertex
// order (rotate_fixed_position_01: (v1, v0, v2) for a clockwise triangle); setup_one_pixel's
// case of a centre on an edge line. Apart: it is rare, and its values would crowd the
// registers of the common case.
[[gnu::noinline]] inline bool one_pixel_covered_on_edge(const FixedXY& v0, const FixedXY& v1, const FixedXY& v2,
                                                        int px, int py, bool cw) {
    const std::int64_t ox = px * kFixedOne, oy = py * kFixedOne;
    const FixedXY& a = cw ? v1 : v0;
    const FixedXY& b = cw ? v0 : v1;
    const std::int64_t ax = a.x - ox, ay = a.y - oy;
    const std::int64_t bx = b.x - ox, by = b.y - oy;
    const std::int64_t cx = v2.x - ox, cy = v2.y - oy;
    auto edge = [](std::int64_t xi, std::int64_t yi, std::int64_t xj, std::int64_t yj) {
        return xj * yi - xi * yj + edge_bias(yi - yj, xi - xj) > 0;
    };
    return edge(ax, ay, bx, by) & edge(bx, by, cx, cy) & edge(cx, cy, ax, ay);
}

// setup_one_pixel in two halves: the outcome (and the winding and facing of a triangle not
// culled), then the fragment of a drawn one. The outcome has no branch but on a centre on an
// edge line (rare): at about a triangle a pixel, whether a one-pixel triangle covers its pixel
// is a coin toss, which a branch mispredicts every other time. So setup_chunk decides every
// candidate first and computes the drawn ones' fragments after, in a loop whose divisions
// overlap from one triangle to the next.
struct OnePixelCoverage {
    Setup setup;
    bool cw;     // set up as (v1, v0, v2)
    bool front;  // front-facing
};
// culled, else drawn or empty, without a branch: setup_chunk keeps or drops the triangle on it.
inline Setup one_pixel_outcome(bool culled, bool covered) {
    static_assert(static_cast<int>(Setup::culled) == 0 && static_cast<int>(Setup::empty) == 1 &&
                  static_cast<int>(Setup::drawn) == 2);
    return static_cast<Setup>((1 + static_cast<int>(covered)) * static_cast<int>(!culled));
}
[[gnu::always_inline]] inline OnePixelCoverage one_pixel_coverage(const FixedXY& v0, const FixedXY& v1,
                                                                  const FixedXY& v2, int px, int py, Face face) {
    const std::int64_t ox = px * kFixedOne, oy = py * kFixedOne;
    const std::int64_t x0 = v0.x - ox, x1 = v1.x - ox, x2 = v2.x - ox;
    const std::int64_t y0 = v0.y - oy, y1 = v1.y - oy, y2 = v2.y - oy;
    const std::int64_t e01 = x1 * y0 - x0 * y1, e12 = x2 * y1 - x1 * y2, e20 = x0 * y2 - x2 * y0;
    const std::int64_t area = e01 + e12 + e20;
    const bool front = area > 0, cw = area < 0;
    const bool culled = (area == 0) | ((face == Face::front_only) & !front) | ((face == Face::back_only) & front);
    bool covered = ((e01 ^ e12) | (e12 ^ e20)) >= 0;  // one sign, where no product is 0
    if (((e01 == 0) | (e12 == 0) | (e20 == 0)) & !culled) [[unlikely]]
        covered = one_pixel_covered_on_edge(v0, v1, v2, px, py, cw);
    return {one_pixel_outcome(culled, covered), cw, front};
}

#if defined(__SSE2__)
// one_pixel_coverage of four triangles at once: lane l is triangle tris[t[l]] with the box
// box[l], and bit l of each mask is its outcome. Only the lanes whose box is one pixel mean
// anything (the others compute values nobody reads). Relative to its pixel, a vertex of a
// one-pixel box lies within 256 (a pixel in fixed point) in x and y: box_bounds' rounding
// puts x in [256 px - 255, 256 px + 256] and y in [256 py - 256, 256 py + 255]. So every
// coordinate fits 16 bits and each edge function x_j y_i - x_i y_j, whose products are at
// most 2^16, is one pmaddwd of the pairs (x_j, -x_i) and (y_i, y_j), exact in 32 bits like
// the 64-bit scalar. A lane with a centre on an edge line (a product 0) is left to lane(),
// which asks one_pixel_covered_on_edge as the scalar does.
struct OnePixelCoverage4 {
    int culled, drawn, on_edge, cw, front;  // lane masks

    OnePixelCoverage lane(int l, const FixedXY& v0, const FixedXY& v1, const FixedXY& v2, int px, int py) const {
        const bool is_cw = (cw >> l) & 1;
        bool is_drawn = (drawn >> l) & 1;
        if ((on_edge >> l) & 1) [[unlikely]]
            is_drawn = one_pixel_covered_on_edge(v0, v1, v2, px, py, is_cw);
        return {one_pixel_outcome((culled >> l) & 1, is_drawn), is_cw, static_cast<bool>((front >> l) & 1)};
    }
};

[[gnu::always_inline]] inline OnePixelCoverage4 one_pixel_coverage4(const FixedXY* fixed,
                                                                    const std::array<std::uint32_t, 3>* tris,
                                                                    const std::uint32_t t[4], const BoxBounds box[4],
                                                                    Face face) {
    // The vertices' x and y, lane by lane: vertex k of the four triangles.
    __m128i x[3], y[3];
    for (int k = 0; k < 3; ++k) {
        auto xy = [&](int l) { return _mm_loadl_epi64(reinterpret_cast<const __m128i*>(&fixed[tris[t[l]][k]])); };
        const __m128 lo = _mm_castsi128_ps(_mm_unpacklo_epi64(xy(0), xy(1)));
        const __m128 hi = _mm_castsi128_ps(_mm_unpacklo_epi64(xy(2), xy(3)));
        x[k] = _mm_castps_si128(_mm_shuffle_ps(lo, hi, _MM_SHUFFLE(2, 0, 2, 0)));
        y[k] = _mm_castps_si128(_mm_shuffle_ps(lo, hi, _MM_SHUFFLE(3, 1, 3, 1)));
    }
    const __m128i ox = _mm_slli_epi32(_mm_set_epi32(box[3].x0, box[2].x0, box[1].x0, box[0].x0), kFixedOrder);
    const __m128i oy = _mm_slli_epi32(_mm_set_epi32(box[3].y0, box[2].y0, box[1].y0, box[0].y0), kFixedOrder);
    __m128i px16[3], nx16[3], py16[3];  // x, -x and y relative to the pixel, in 16 bits
    for (int k = 0; k < 3; ++k) {
        const __m128i dx = _mm_sub_epi32(x[k], ox);
        px16[k] = _mm_packs_epi32(dx, dx);
        const __m128i neg = _mm_sub_epi32(_mm_setzero_si128(), dx);
        nx16[k] = _mm_packs_epi32(neg, neg);
        const __m128i dy = _mm_sub_epi32(y[k], oy);
        py16[k] = _mm_packs_epi32(dy, dy);
    }
    // e_ij = x_j y_i - x_i y_j (one_pixel_coverage's e01, e12, e20)
    auto edge = [&](int i, int j) {
        return _mm_madd_epi16(_mm_unpacklo_epi16(px16[j], nx16[i]), _mm_unpacklo_epi16(py16[i], py16[j]));
    };
    const __m128i e01 = edge(0, 1), e12 = edge(1, 2), e20 = edge(2, 0);
    const __m128i zero = _mm_setzero_si128();
    const __m128i area = _mm_add_epi32(_mm_add_epi32(e01, e12), e20);
    const __m128i front = _mm_cmpgt_epi32(area, zero), cw = _mm_cmplt_epi32(area, zero);
    const __m128i cull_front = _mm_set1_epi32(face == Face::back_only ? -1 : 0);
    const __m128i cull_back = _mm_set1_epi32(face == Face::front_only ? -1 : 0);
    const __m128i culled = _mm_or_si128(_mm_cmpeq_epi32(area, zero),
                                        _mm_or_si128(_mm_and_si128(front, cull_front), _mm_and_si128(cw, cull_back)));
    const __m128i any_zero = _mm_or_si128(_mm_or_si128(_mm_cmpeq_epi32(e01, zero), _mm_cmpeq_epi32(e12, zero)),
                                          _mm_cmpeq_epi32(e20, zero));
    const __m128i mixed = _mm_srai_epi32(_mm_or_si128(_mm_xor_si128(e01, e12), _mm_xor_si128(e12, e20)), 31);
    auto mask = [](__m128i m) { return _mm_movemask_ps(_mm_castsi128_ps(m)); };
    return {mask(culled), ~mask(_mm_or_si128(culled, _mm_or_si128(any_zero, mixed))) & 0xF,
            mask(_mm_andnot_si128(culled, any_zero)), mask(cw), mask(front)};
}
#endif

// The fragment of a triangle that one_pixel_coverage drew.
[[gnu::always_inline]] inline void one_pixel_fragment(const glm::vec4& win0, const glm::vec4& win1,
                                                      const glm::vec4& win2, bool cw, bool front, int px, int py,
                                                      OnePixelFragment& out) {
    // setup_attributes' vertex order, selected without a branch (the winding is a coin toss).
    const glm::vec4* const first_two[2] = {&win0, &win1};
    const glm::vec4& a = *first_two[cw];
    const glm::vec4& b = *first_two[!cw];
    const glm::vec4& c = win2;
    const float fdx01 = a.x - b.x, fdy01 = a.y - b.y;
    const float fdx20 = c.x - a.x, fdy20 = c.y - a.y;
    const float ooa = 1.0f / (fdx01 * fdy20 - fdx20 * fdy01);
    const float fx = static_cast<float>(px) - (a.x - 0.5f);
    const float fy = static_cast<float>(py) - (a.y - 0.5f);
    const float z[3] = {a.z, b.z, c.z};
    float zp[3];
    triangle_plane(z, ooa, fdx01, fdy01, fdx20, fdy20, zp);
    out.z = depth_value(eval_plane(zp, fx, fy));
    out.front = front;
#if defined(__SSE2__)
    // Lanes 0-2: weight k times 1/w; lane 3: 1/w.
    alignas(16) static constexpr std::uint32_t kLanes[3][4] = {
        {~0u, 0u, 0u, ~0u}, {0u, ~0u, 0u, ~0u}, {0u, 0u, ~0u, ~0u}};
    auto attributes = [](const glm::vec4& v, int k) {
        return _mm_and_ps(_mm_set1_ps(v.w), _mm_load_ps(reinterpret_cast<const float*>(kLanes[k])));
    };
    const __m128 a0 = attributes(a, cw), a1 = attributes(b, !cw), a2 = attributes(c, 2);
    const __m128 da01 = _mm_sub_ps(a0, a1), da20 = _mm_sub_ps(a2, a0);
    const __m128 vooa = _mm_set1_ps(ooa);
    __m128 dadx = _mm_mul_ps(_mm_sub_ps(_mm_mul_ps(da01, _mm_set1_ps(fdy20)), _mm_mul_ps(_mm_set1_ps(fdy01), da20)), vooa);
    __m128 dady = _mm_mul_ps(_mm_sub_ps(_mm_mul_ps(_mm_set1_ps(fdx01), da20), _mm_mul_ps(da01, _mm_set1_ps(fdx20))), vooa);
    const __m128 magnitude = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
    const __m128 infinity = _mm_set1_ps(INFINITY);
    const __m128 finite = _mm_and_ps(_mm_cmplt_ps(_mm_and_ps(dadx, magnitude), infinity),
                                     _mm_cmplt_ps(_mm_and_ps(dady, magnitude), infinity));
    dadx = _mm_and_ps(dadx, finite);
    dady = _mm_and_ps(dady, finite);
    const __m128 e = _mm_add_ps(_mm_add_ps(a0, _mm_mul_ps(dadx, _mm_set1_ps(fx))), _mm_mul_ps(dady, _mm_set1_ps(fy)));
    alignas(16) float w[4];
    _mm_store_ps(w, _mm_div_ps(e, _mm_shuffle_ps(e, e, _MM_SHUFFLE(3, 3, 3, 3))));
    for (int k = 0; k < 3; ++k) out.weights[k] = w[k];
#else
    const float oow[3] = {a.w, b.w, c.w};
    float plane[3];
    triangle_plane(oow, ooa, fdx01, fdy01, fdx20, fdy20, plane);
    const float oow_at = eval_plane(plane, fx, fy);
    const int slot[3] = {cw ? 1 : 0, cw ? 0 : 1, 2};
    for (int k = 0; k < 3; ++k) {
        const float bw[3] = {slot[0] == k ? oow[0] : 0.0f, slot[1] == k ? oow[1] : 0.0f, slot[2] == k ? oow[2] : 0.0f};
        triangle_plane(bw, ooa, fdx01, fdy01, fdx20, fdy20, plane);
        out.weights[k] = eval_plane(plane, fx, fy) / oow_at;
    }
#endif
}

[[gnu::always_inline]] inline Setup setup_one_pixel(const FixedXY& v0, const FixedXY& v1, const FixedXY& v2,
                                                    const glm::vec4& win0, const glm::vec4& win1,
                                                    const glm::vec4& win2, int px, int py, Face face,
                                                    OnePixelFragment& out) {
    const OnePixelCoverage c = one_pixel_coverage(v0, v1, v2, px, py, face);
    if (c.setup == Setup::drawn) one_pixel_fragment(win0, win1, win2, c.cw, c.front, px, py, out);
    return c.setup;
}

}  // namespace tessref::raster
