// src/raster/raster_internal.h — the rasterizer's private pieces (clipper, setup), shared by
// the files of src/raster/ and nothing else.
//
// Coordinates here are Mesa's internal ones for a window-system framebuffer: x to the right,
// y DOWN (row 0 = top row), because that is the orientation llvmpipe snaps and tests in.
// GL window y = height - raster y.
#pragma once

#include <cstdint>

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
glm::vec4 window_position(const glm::vec4& clip, const Viewport& viewport, bool fused);
// draw's cliptest bits: 0 x>w, 1 x<-w, 2 y>w, 3 y<-w, 4 z<-w, 5 z>w.
unsigned compute_clipmask(const glm::vec4& clip);

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
};

// llvmpipe's triangle setup (calc_fixed_position + do_triangle_ccw). Returns false when the
// triangle is culled (zero area, culled face, or empty bounding box).
enum class Face { both, front_only, back_only };
bool setup_triangle(const ClipVertex& v0, const ClipVertex& v1, const ClipVertex& v2, Face face,
                    const Viewport& viewport, Primitive& prim);

// llvmpipe's one-pixel-wide line setup (try_setup_line, diamond-exit rule, non-rectangular).
bool setup_line(const ClipVertex& v1, const ClipVertex& v2, const Viewport& viewport,
                Primitive& prim);

// A window coordinate in llvmpipe's 8-bit sub-pixel fixed point (calc_fixed_position:
// (v - 0.5) * 256 rounded to nearest even, as cvtps2dq).
std::int32_t snap_fixed(float window_coordinate);
// Whether the pixel box do_triangle_ccw derives from three snapped vertices holds a pixel
// of the viewport: a triangle whose box holds none covers no pixel (setup culls it).
bool fixed_bbox_has_pixels(const std::int32_t (&x)[3], const std::int32_t (&y)[3], const Viewport& viewport);

// Round-to-nearest-even as SSE's cvtps2dq (out of range: INT32_MIN), and Mesa's util_iround
// on x86-64 ((int)(f + 0.5f), in float).
std::int32_t cvt_rne(float v);
std::int32_t util_iround(float f);

}  // namespace tessref::raster
