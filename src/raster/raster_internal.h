// src/raster/raster_internal.h — the rasterizer's private pieces (clipper, setup), shared by
// the files of src/raster/ and nothing else.
//
// Coordinates here are Mesa's internal ones for a window-system framebuffer: x to the right,
// y DOWN (row 0 = top row), because that is the orientation llvmpipe snaps and tests in.
// GL window y = height - raster y.
#pragma once

#include <algorithm>
#include <climits>
#include <cmath>
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
inline void make_planes(const std::int32_t* x, const std::int32_t* y, int count, Primitive& prim) {
    prim.plane_count = count;
    for (int i = 0; i < count; ++i) {
        const int j = (i + 1) % count;
        const std::int32_t dcdy = x[i] - x[j];
        const std::int32_t dcdx = y[i] - y[j];
        std::int64_t c = static_cast<std::int64_t>(dcdx) * x[i] - static_cast<std::int64_t>(dcdy) * y[i];
        if (dcdx < 0) {
            ++c;  // left edges: both fill conventions
        } else if (dcdx == 0 && dcdy < 0) {
            ++c;  // bottom-left convention for horizontal edges
        }
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

// triangle_bbox's four bounds are each a non-decreasing function of one coordinate of one
// vertex (min_x, max_x, min_y or max_y), so the box of a triangle is the min (x0, y0) and
// max (x1, y1) of its vertices' own bounds: the rasterizer computes them once per vertex
// rather than once per triangle (about two triangles a vertex). In 64 bits: the bounds of
// an out-of-range snap (INT32_MIN) stay defined.
struct VertexPixelBounds {
    std::int32_t x0, x1, y0, y1;
};
inline VertexPixelBounds vertex_pixel_bounds(std::int32_t x, std::int32_t y) {
    const std::int64_t X = x, Y = y, one = kFixedOne;
    const int adj = 1;
    return {static_cast<std::int32_t>(std::max(X >> kFixedOrder, (X + one - 1) >> kFixedOrder)),
            static_cast<std::int32_t>((X - 1) >> kFixedOrder),
            static_cast<std::int32_t>(std::max((Y + adj) >> kFixedOrder, (Y + one) >> kFixedOrder)),
            static_cast<std::int32_t>((Y - 1 + adj) >> kFixedOrder)};
}
// Whether the box of a triangle with these vertices' bounds holds a pixel of the viewport:
// a triangle whose box holds none covers no pixel (setup culls it).
inline bool bounds_have_pixels(const VertexPixelBounds& a, const VertexPixelBounds& b, const VertexPixelBounds& c,
                               const Viewport& viewport) {
    const std::int32_t x0 = std::max(std::min(std::min(a.x0, b.x0), c.x0), 0);
    const std::int32_t x1 = std::min(std::max(std::max(a.x1, b.x1), c.x1), viewport.width - 1);
    const std::int32_t y0 = std::max(std::min(std::min(a.y0, b.y0), c.y0), 0);
    const std::int32_t y1 = std::min(std::max(std::max(a.y1, b.y1), c.y1), viewport.height - 1);
    return x0 <= x1 && y0 <= y1;
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

}  // namespace tessref::raster
