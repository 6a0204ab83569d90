// src/raster/clip.cpp — homogeneous clipping and the window transform, as Mesa's draw module
// (draw_pipe_clip.c, draw_cliptest_tmp.h / draw_llvm.c generate_viewport) computes them.
//
// Every float operation is written in the order Mesa writes it, so that the window
// coordinates, and therefore the snapped fixed-point positions, come out bit-identical.
#include <bit>
#include <cmath>

#include "raster/raster_internal.h"

namespace tessref::raster {

// A crossing edge is handled as in Mesa 22.3's draw module: the sides are compared against 0
// only, and t is measured from the vertex nearer to the plane. (Older Mesa tested
// DIFFERENT_SIGNS(dp, dp_prev), which adds a near-duplicate vertex when a distance is exactly
// 0, and always interpolated from the outside vertex: the same filled pixels, but not the
// same wireframe when a vertex lies exactly on a clip plane, which the llvmpipe differential
// test WireframeWithBackFaceCullingIsIdentical tells apart: 962 pixels differed.)

Viewport make_viewport(int width, int height) {
    // _mesa_get_viewport_xform with X = Y = 0, near = 0, far = 1, then st_update_viewport's
    // flip for a Y_0_TOP (window-system) framebuffer.
    Viewport vp;
    vp.width = width;
    vp.height = height;
    const float half_width = 0.5f * static_cast<float>(width);
    const float half_height = 0.5f * static_cast<float>(height);
    vp.scale[0] = half_width;
    vp.translate[0] = half_width + 0.0f;
    vp.scale[1] = half_height;
    vp.translate[1] = half_height + 0.0f;
    const double n = 0.0, f = 1.0;
    vp.scale[2] = static_cast<float>(0.5 * (f - n));
    vp.translate[2] = static_cast<float>(0.5 * (n + f));
    vp.scale[1] *= -1.0f;
    vp.translate[1] = static_cast<float>(height) - vp.translate[1];
    return vp;
}



namespace {

// draw->plane[0..5] as draw_init() sets them ("mesa's a bit wonky").
constexpr float kPlanes[6][4] = {
    {-1, 0, 0, 1}, {1, 0, 0, 1}, {0, -1, 0, 1}, {0, 1, 0, 1}, {0, 0, 1, 1}, {0, 0, -1, 1},
};

inline float dot4(const glm::vec4& a, const float* b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
}

inline bool is_inf_or_nan(float x) { return !std::isfinite(x); }

// draw_pipe_clip.c interp(): LINTERP(t, out, in) = out + t * (in - out) on the clip position
// (and on every perspective attribute, here the barycentric weights), then the projective
// divide and viewport transform of the new vertex.
void interp(ClipVertex& dst, float t, const ClipVertex& out, const ClipVertex& in,
            const Viewport& vp) {
    dst.clipmask = 0;
    dst.edgeflag = false;
    for (int k = 0; k < 4; ++k) dst.clip[k] = out.clip[k] + t * (in.clip[k] - out.clip[k]);
    dst.win = window_position(dst.clip, vp, /*fused=*/false);
    for (int k = 0; k < 3; ++k) dst.bary[k] = out.bary[k] + t * (in.bary[k] - out.bary[k]);
}

}  // namespace

int clip_polygon(const ClipVertex (&in)[3], unsigned clipmask, const Viewport& vp,
                 ClipVertex (&out)[kMaxClipVertices], bool (&edges)[kMaxClipVertices]) {
    ClipVertex pool[kMaxClipVertices + 1];
    int tmpnr = 0;
    const ClipVertex* a[kMaxClipVertices + 1];
    const ClipVertex* b[kMaxClipVertices + 1];
    bool a_edges[kMaxClipVertices + 1];
    bool b_edges[kMaxClipVertices + 1];
    const ClipVertex** inlist = a;
    const ClipVertex** outlist = b;
    bool* in_edges = a_edges;
    bool* out_edges = b_edges;
    int n = 3;
    for (int i = 0; i < 3; ++i) {
        inlist[i] = &in[i];
        in_edges[i] = true;  // a triangle of a list: DRAW_PIPE_EDGE_FLAG_ALL
    }

    while (clipmask && n >= 3) {
        const int plane_idx = std::countr_zero(clipmask);
        const float* plane = kPlanes[plane_idx];
        const ClipVertex* vert_prev = inlist[0];
        bool edge_prev = in_edges[0];
        float dp_prev = dot4(vert_prev->clip, plane);
        clipmask &= ~(1u << plane_idx);
        if (is_inf_or_nan(dp_prev)) return 0;  // "discard nan"
        if (n >= kMaxClipVertices) return 0;
        inlist[n] = inlist[0];  // prevent rotation of vertices
        in_edges[n] = in_edges[0];
        int outcount = 0;

        for (int i = 1; i <= n; ++i) {
            const ClipVertex* vert = inlist[i];
            const bool edge = in_edges[i];
            const float dp = dot4(vert->clip, plane);
            if (is_inf_or_nan(dp)) return 0;

            bool different_sign;
            if (dp_prev >= 0.0f) {
                if (outcount >= kMaxClipVertices) return 0;
                out_edges[outcount] = edge_prev;
                outlist[outcount++] = vert_prev;
                different_sign = dp < 0.0f;
            } else {
                different_sign = !(dp < 0.0f);
            }
            if (different_sign) {
                if (tmpnr >= kMaxClipVertices + 1 || outcount >= kMaxClipVertices) return 0;
                ClipVertex* new_vert = &pool[tmpnr++];
                bool& new_edge = out_edges[outcount];
                outlist[outcount++] = new_vert;
                const float denom = dp - dp_prev;
                if (dp < 0.0f) {  // going out
                    if (-dp < dp_prev) {
                        interp(*new_vert, dp / denom, *vert, *vert_prev, vp);
                    } else {
                        interp(*new_vert, -dp_prev / denom, *vert_prev, *vert, vp);
                    }
                    new_edge = edge_prev;  // no edge along a frustum plane
                    new_vert->edgeflag = false;
                } else {  // coming back in
                    if (-dp_prev < dp) {
                        interp(*new_vert, -dp_prev / denom, *vert_prev, *vert, vp);
                    } else {
                        interp(*new_vert, dp / denom, *vert, *vert_prev, vp);
                    }
                    new_vert->edgeflag = vert_prev->edgeflag;
                    new_edge = edge_prev;
                }
            }
            vert_prev = vert;
            edge_prev = edge;
            dp_prev = dp;
        }
        std::swap(inlist, outlist);
        std::swap(in_edges, out_edges);
        n = outcount;
    }
    if (n < 3) return 0;
    for (int i = 0; i < n; ++i) {
        out[i] = *inlist[i];
        edges[i] = in_edges[i];
    }
    return n;
}

}  // namespace tessref::raster
