// src/raster/setup.cpp — llvmpipe's primitive setup: fixed-point positions, edge functions with
// the fill-rule bias, bounding boxes (lp_setup_tri.c, lp_setup_line.c), plus the float
// attribute planes this rasterizer interpolates depth and barycentric weights with.
#include <algorithm>
#include <climits>
#include <cmath>
#include <utility>

#include "raster/raster_internal.h"

namespace tessref::raster {

namespace {

constexpr float kPixelOffset = 0.5f;  // half_pixel_center

}  // namespace


std::int32_t util_iround(float f) {
    if (f >= 0.0f) {
        const float g = f + 0.5f;
        if (!(g < 2147483648.0f)) return INT32_MIN;
        return static_cast<std::int32_t>(g);
    }
    const float g = f - 0.5f;
    if (!(g > -2147483648.0f)) return INT32_MIN;
    return static_cast<std::int32_t>(g);
}

void setup_attributes(const SetupCorner* const (&v)[3], Primitive& prim) {
    // Attribute planes from the unsnapped window positions (like lp_setup's coefficients).
    const float fdx01 = v[0]->win->x - v[1]->win->x, fdy01 = v[0]->win->y - v[1]->win->y;
    const float fdx20 = v[2]->win->x - v[0]->win->x, fdy20 = v[2]->win->y - v[0]->win->y;
    const float ooa = 1.0f / (fdx01 * fdy20 - fdx20 * fdy01);
    prim.ox = v[0]->win->x - kPixelOffset;
    prim.oy = v[0]->win->y - kPixelOffset;
    const float z[3] = {v[0]->win->z, v[1]->win->z, v[2]->win->z};
    const float oow[3] = {v[0]->win->w, v[1]->win->w, v[2]->win->w};
    triangle_plane(z, ooa, fdx01, fdy01, fdx20, fdy20, prim.z);
    triangle_plane(oow, ooa, fdx01, fdy01, fdx20, fdy20, prim.oow);
    for (int k = 0; k < 3; ++k) {
        const float bw[3] = {(*v[0]->bary)[k] * oow[0], (*v[1]->bary)[k] * oow[1], (*v[2]->bary)[k] * oow[2]};
        triangle_plane(bw, ooa, fdx01, fdy01, fdx20, fdy20, prim.bw[k]);
    }
}

namespace {

inline bool sign(float x) { return x >= 0; }
inline float fracf(float f) { return f - std::floor(f); }

inline std::int32_t subpixel_snap(float a) { return util_iround(static_cast<float>(kFixedOne) * a); }

}  // namespace

bool setup_line(const ClipVertex& in1, const ClipVertex& in2, const Viewport& vp, Primitive& prim) {
    const ClipVertex* v1 = &in1;
    const ClipVertex* v2 = &in2;
    const float dx = v1->win.x - v2->win.x;
    const float dy = v1->win.y - v2->win.y;
    const float area = dx * dx + dy * dy;
    if (area == 0) return false;

    float x_offset = 0, y_offset = 0;
    float x_offset_end = 0, y_offset_end = 0;
    const float x1diff = v1->win.x - std::floor(v1->win.x) - 0.5f;
    const float y1diff = v1->win.y - std::floor(v1->win.y) - 0.5f;
    float x2diff = v2->win.x - std::floor(v2->win.x) - 0.5f;
    float y2diff = v2->win.y - std::floor(v2->win.y) - 0.5f;
    const int fixed_width = util_iround(1.0f) * kFixedOne;
    bool draw_start, draw_end, will_draw_start, will_draw_end;
    std::int32_t x[4], y[4];

    if (std::fabs(dx) >= std::fabs(dy)) {
        const float dydx = dy / dx;
        // X-major line.
        if (y2diff == -0.5f && dy < 0.0f) y2diff = 0.5f;
        // Diamond exit rule test for the starting point.
        if (std::fabs(x1diff) + std::fabs(y1diff) < 0.5f) {
            draw_start = true;
        } else if (sign(x1diff) == sign(-dx)) {
            draw_start = false;
        } else if (sign(-y1diff) != sign(dy)) {
            draw_start = true;
        } else {
            const float yintersect = fracf(v1->win.y) + x1diff * dydx;
            draw_start = (yintersect < 1.0f && yintersect > 0.0f);
        }
        // ... and for the ending point.
        if (std::fabs(x2diff) + std::fabs(y2diff) < 0.5f) {
            draw_end = false;
        } else if (sign(x2diff) != sign(-dx)) {
            draw_end = false;
        } else if (sign(-y2diff) == sign(dy)) {
            draw_end = true;
        } else {
            const float yintersect = fracf(v2->win.y) + x2diff * dydx;
            draw_end = (yintersect < 1.0f && yintersect > 0.0f);
        }
        // Are we already drawing start/end? (Mesa 22.3's form: an end exactly on a pixel
        // centre column counts as drawn; later Mesa changed that for dx < 0, which moves the
        // end of such lines by a rounding step: the differential test has such a case.)
        will_draw_start = sign(-x1diff) != sign(dx);
        will_draw_end = (sign(x2diff) == sign(-dx)) || x2diff == 0;
        if (dx < 0.0f) {
            std::swap(v1, v2);  // v2 is to the right of v1
            if (will_draw_start != draw_start) {
                x_offset_end = -x1diff - 0.5f;
                y_offset_end = x_offset_end * dydx;
            }
            if (will_draw_end != draw_end) {
                x_offset = -x2diff - 0.5f;
                y_offset = x_offset * dydx;
            }
        } else {
            if (will_draw_start != draw_start) {
                x_offset = -x1diff + 0.5f;
                y_offset = x_offset * dydx;
            }
            if (will_draw_end != draw_end) {
                x_offset_end = -x2diff + 0.5f;
                y_offset_end = x_offset_end * dydx;
            }
        }
        x[0] = subpixel_snap(v1->win.x + x_offset - kPixelOffset);
        x[1] = subpixel_snap(v2->win.x + x_offset_end - kPixelOffset);
        x[2] = subpixel_snap(v2->win.x + x_offset_end - kPixelOffset);
        x[3] = subpixel_snap(v1->win.x + x_offset - kPixelOffset);
        y[0] = subpixel_snap(v1->win.y + y_offset - kPixelOffset) - fixed_width / 2;
        y[1] = subpixel_snap(v2->win.y + y_offset_end - kPixelOffset) - fixed_width / 2;
        y[2] = subpixel_snap(v2->win.y + y_offset_end - kPixelOffset) + fixed_width / 2;
        y[3] = subpixel_snap(v1->win.y + y_offset - kPixelOffset) + fixed_width / 2;
    } else {
        const float dxdy = dx / dy;
        // Y-major line.
        if (x2diff == -0.5f && dx < 0.0f) x2diff = 0.5f;
        if (std::fabs(x1diff) + std::fabs(y1diff) < 0.5f) {
            draw_start = true;
        } else if (sign(-y1diff) == sign(dy)) {
            draw_start = false;
        } else if (sign(x1diff) != sign(-dx)) {
            draw_start = true;
        } else {
            const float xintersect = fracf(v1->win.x) + y1diff * dxdy;
            draw_start = (xintersect < 1.0f && xintersect > 0.0f);
        }
        if (std::fabs(x2diff) + std::fabs(y2diff) < 0.5f) {
            draw_end = false;
        } else if (sign(-y2diff) != sign(dy)) {
            draw_end = false;
        } else if (sign(x2diff) == sign(-dx)) {
            draw_end = true;
        } else {
            const float xintersect = fracf(v2->win.x) + y2diff * dxdy;
            draw_end = (xintersect < 1.0f && xintersect >= 0.0f);
        }
        will_draw_start = sign(y1diff) == sign(dy);
        will_draw_end = (sign(-y2diff) == sign(dy)) || y2diff == 0;
        if (dy > 0.0f) {
            std::swap(v1, v2);  // v2 is on top of v1
            if (will_draw_start != draw_start) {
                y_offset_end = -y1diff + 0.5f;
                x_offset_end = y_offset_end * dxdy;
            }
            if (will_draw_end != draw_end) {
                y_offset = -y2diff + 0.5f;
                x_offset = y_offset * dxdy;
            }
        } else {
            if (will_draw_start != draw_start) {
                y_offset = -y1diff - 0.5f;
                x_offset = y_offset * dxdy;
            }
            if (will_draw_end != draw_end) {
                y_offset_end = -y2diff - 0.5f;
                x_offset_end = y_offset_end * dxdy;
            }
        }
        x[0] = subpixel_snap(v1->win.x + x_offset - kPixelOffset) - fixed_width / 2;
        x[1] = subpixel_snap(v2->win.x + x_offset_end - kPixelOffset) - fixed_width / 2;
        x[2] = subpixel_snap(v2->win.x + x_offset_end - kPixelOffset) + fixed_width / 2;
        x[3] = subpixel_snap(v1->win.x + x_offset - kPixelOffset) + fixed_width / 2;
        y[0] = subpixel_snap(v1->win.y + y_offset - kPixelOffset);
        y[1] = subpixel_snap(v2->win.y + y_offset_end - kPixelOffset);
        y[2] = subpixel_snap(v2->win.y + y_offset_end - kPixelOffset);
        y[3] = subpixel_snap(v1->win.y + y_offset - kPixelOffset);
    }

    // Bounding box, inclusive, bottom-left convention (adj = 1).
    const int adj = 1;
    prim.x0 = (std::min({x[0], x[1], x[2], x[3]}) + (kFixedOne - 1)) >> kFixedOrder;
    prim.x1 = ((std::max({x[0], x[1], x[2], x[3]}) + (kFixedOne - 1)) >> kFixedOrder) - 1;
    prim.y0 = (std::min({y[0], y[1], y[2], y[3]}) + (kFixedOne - 1) + adj) >> kFixedOrder;
    prim.y1 = ((std::max({y[0], y[1], y[2], y[3]}) + (kFixedOne - 1) + adj) >> kFixedOrder) - 1;
    if (!clamp_bbox(prim, vp)) return false;
    make_planes(x, y, 4, prim);
    prim.small_coverage = kLargeBox;

    // Attributes along the major axis from the ORIGINAL first vertex, like llvmpipe's
    // linear_coef with its "wide-lines formula" (dadx = (a1 - a2) / dx for x-major lines).
    const ClipVertex& a = in1;
    const ClipVertex& b = in2;
    prim.ox = a.win.x - kPixelOffset;
    prim.oy = a.win.y - kPixelOffset;
    const bool x_major = std::fabs(dx) >= std::fabs(dy);
    auto line_plane = [&](float a1, float a2, float out[3]) {
        const float da21 = a1 - a2;
        out[0] = a1;
        out[1] = x_major ? da21 / dx : 0.0f;
        out[2] = x_major ? 0.0f : da21 / dy;
    };
    line_plane(a.win.z, b.win.z, prim.z);
    line_plane(a.win.w, b.win.w, prim.oow);
    for (int k = 0; k < 3; ++k) line_plane(a.bary[k] * a.win.w, b.bary[k] * b.win.w, prim.bw[k]);
    return true;
}

}  // namespace tessref::raster
