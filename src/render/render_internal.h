// render_internal.h — pieces shared by the rasterized and the ray-traced renderers
// (private to src/render/).
#pragma once

#include <array>
#include <cstddef>
#include <string>

#include <glm/glm.hpp>

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
// `visibility`, all but depth, triangle_id and barycentric, which the rasterizing renderer
// takes from its framebuffer when done (take_visibility: the same values, moved, not
// allocated and copied a second time); without `provenance`, not patch_id, tess_coord and
// level (RenderOptions::provenance).
void allocate(RenderResult& result, int width, int height, bool visibility = true, bool provenance = true);
void take_visibility(RenderResult& result, Framebuffer& fb);

// to_rgba8 into `out` (4 bytes a pixel), in parallel: for a caller whose buffer is not
// cleared first, so that its pages are first touched on every thread, not one.
void to_rgba8(const RenderResult& result, std::uint8_t* out);

// The camera with the image size applied (RenderOptions::size), and the size checked.
SceneCamera camera_for(const Scene& scene, const RenderOptions& options);

}  // namespace tessref::render_detail
