// The geometric error of a tessellated terrain against the full-resolution height field:
// see geometric_error.h for what is measured and why it is exact.
#include "sweep/geometric_error.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "common/parallel.h"
#include "render/ground_truth.h"
#include "tessref/error.h"

namespace tessref::sweep {

TruthSurface truth_surface(const Scene& scene) {
    if (!scene.grid)
        throw Error("the geometric error needs a terrain scene (a height map): a mesh scene has no full-resolution "
                    "height field",
                    Where::at_key(scene.file, "mesh"));
    const TerrainGrid& g = *scene.grid;
    const ground_truth::GroundMap map = ground_truth::ground_map(scene);
    const Texture& height = g.heightmap->texture;
    // As raytrace.cpp's build_surface: the same lines, the same heights.
    const auto [u_lo, u_hi] = std::minmax(g.u_coords.front(), g.u_coords.back());
    const auto [v_lo, v_hi] = std::minmax(g.v_coords.front(), g.v_coords.back());
    TruthSurface s;
    s.plane_xy = g.plane == GroundPlane::xy;
    s.us = ground_truth::vertex_lines(u_lo, u_hi, map.u, height.width());
    s.vs = ground_truth::vertex_lines(v_lo, v_hi, map.v, height.height());
    s.heights.resize(s.us.size() * s.vs.size());
    tessref::parallel_for(std::size_t{0}, s.vs.size(), [&](std::size_t j) {
        for (std::size_t i = 0; i < s.us.size(); ++i)
            s.heights[j * s.us.size() + i] = ground_truth::vertex_height(g, map, s.us[i], s.vs[j]);
    });
    return s;
}

namespace {

// A corner of a clipped piece: ground point and the tessellation's height there.
struct Corner {
    double u, v, h;
};
// A convex polygon: a triangle clipped by six half-planes has at most nine corners (more only if rounding made it non-convex; add() drops those beyond the room).
struct Polygon {
    // Room for rounding-made extra corners. Not zeroed: only the first n are ever read, and
    // zeroing 768 bytes for every clip was most of the geometric error's time.
    std::array<Corner, 32> c;
    int n = 0;
};

// Keeps the part where a * u + b * v + k >= 0 (Sutherland-Hodgman, one edge), into `out`;
// returns the result: `in` itself where no corner is cut off (most clips: a small triangle
// inside its texel), which the loop would copy corner by corner. Heights are interpolated
// linearly along the cut edge: T is linear on the triangle, so they are exact.
const Polygon& clip(const Polygon& in, double a, double b, double k, Polygon& out) {
    std::array<double, 32> f;  // each corner's a u + b v + k, once (the first in.n)
    bool inside = true;
    for (int i = 0; i < in.n; ++i) {
        const Corner& p = in.c[static_cast<std::size_t>(i)];
        f[static_cast<std::size_t>(i)] = a * p.u + b * p.v + k;
        inside = inside && f[static_cast<std::size_t>(i)] >= 0.0;
    }
    if (inside) return in;
    out.n = 0;
    const auto add = [&out](const Corner& c) {
        if (out.n < static_cast<int>(out.c.size())) out.c[static_cast<std::size_t>(out.n++)] = c;
    };
    for (int i = 0; i < in.n; ++i) {
        const int j = i + 1 == in.n ? 0 : i + 1;
        const Corner& p = in.c[static_cast<std::size_t>(i)];
        const Corner& q = in.c[static_cast<std::size_t>(j)];
        const double fp = f[static_cast<std::size_t>(i)], fq = f[static_cast<std::size_t>(j)];
        if (fp >= 0.0) add(p);
        if ((fp >= 0.0) != (fq >= 0.0)) {
            const double t = fp / (fp - fq);
            add({p.u + t * (q.u - p.u), p.v + t * (q.v - p.v), p.h + t * (q.h - p.h)});
        }
    }
    return out;
}

// What one patch contributes.
struct PatchError {
    double max = -1.0;     // -1: no area measured
    double sum_sq = 0.0;   // integral of e^2
    double area = 0.0;
    Corner at{};           // where |e| is largest (h = T)
    double truth_at = 0.0; // G there
};

// One piece: the polygon (T heights) inside one truth triangle, whose height is
// g(u, v) = h0 + su * (u - u0) + sv * (v - v0).
void measure_piece(const Polygon& piece, double u0, double v0, double h0, double su, double sv, PatchError& out) {
    if (piece.n < 3) return;
    std::array<double, 32> e;  // the first piece.n are written
    for (int i = 0; i < piece.n; ++i) {
        const Corner& p = piece.c[static_cast<std::size_t>(i)];
        const double g = h0 + (p.u - u0) * su + (p.v - v0) * sv;
        e[static_cast<std::size_t>(i)] = p.h - g;
        if (std::abs(e[static_cast<std::size_t>(i)]) > out.max) {
            out.max = std::abs(e[static_cast<std::size_t>(i)]);
            out.at = p;
            out.truth_at = g;
        }
    }
    const Corner& p0 = piece.c[0];
    for (int i = 1; i + 1 < piece.n; ++i) {
        const Corner& p1 = piece.c[static_cast<std::size_t>(i)];
        const Corner& p2 = piece.c[static_cast<std::size_t>(i + 1)];
        const double area = 0.5 * std::abs((p1.u - p0.u) * (p2.v - p0.v) - (p2.u - p0.u) * (p1.v - p0.v));
        const double a = e[0], b = e[static_cast<std::size_t>(i)], c = e[static_cast<std::size_t>(i + 1)];
        out.sum_sq += area * (a * a + b * b + c * c + a * b + b * c + c * a) / 6.0;
        out.area += area;
    }
}

// The cells between a truth axis's vertex lines: index i is [lines[i], lines[i + 1]].
// The lines are the texel centres, evenly spaced, and the extent's two borders, so a cell is
// found by arithmetic from the inner lines' spacing, then moved to the exact answer by
// comparing with the lines themselves (a step at most, but for rounding): the index a
// binary search gives, without its dozen dependent loads per look-up.
class Cells {
public:
    explicit Cells(const std::vector<double>& lines) : lines_(lines), last_(lines.size() - 2) {
        if (lines.size() >= 4) {
            first_inner_ = lines[1];
            per_unit_ = double(lines.size() - 3) / (lines[lines.size() - 2] - lines[1]);
        }
    }
    // The cell holding x, clamped to the cells (x below the first line: 0; at or beyond
    // the last: the last cell); for x on a line, the cell that begins there.
    std::size_t of(double x) const {
        std::size_t i = last_;
        const double guess = 1.0 + std::floor((x - first_inner_) * per_unit_);
        if (guess <= 0.0) i = 0;  // (NaN: the last cell, as a search finds no line above it)
        else if (guess < double(last_)) i = static_cast<std::size_t>(guess);
        while (i < last_ && lines_[i + 1] <= x) ++i;
        while (i > 0 && lines_[i] > x) --i;
        return i;
    }

private:
    const std::vector<double>& lines_;
    std::size_t last_;
    double first_inner_ = 0.0, per_unit_ = 0.0;
};

// The truth's cells along both ground axes.
struct TruthCells {
    explicit TruthCells(const TruthSurface& truth) : u(truth.us), v(truth.vs) {}
    Cells u, v;
};

// One tessellated triangle against every truth triangle under it.
void measure_triangle(const TruthSurface& truth, const TruthCells& cells, const std::array<Corner, 3>& t, PatchError& out) {
    const double umin = std::min({t[0].u, t[1].u, t[2].u}), umax = std::max({t[0].u, t[1].u, t[2].u});
    const double vmin = std::min({t[0].v, t[1].v, t[2].v}), vmax = std::max({t[0].v, t[1].v, t[2].v});
    if (!(umax > umin) || !(vmax > vmin)) return;  // no ground area (or NaN)
    const double cross = (t[1].u - t[0].u) * (t[2].v - t[0].v) - (t[2].u - t[0].u) * (t[1].v - t[0].v);
    if (cross == 0.0) return;
    const std::size_t i0 = cells.u.of(umin), i1 = cells.u.of(umax);
    const std::size_t j0 = cells.v.of(vmin), j1 = cells.v.of(vmax);
    Polygon tri, row_low, row_high, cell_low, cell_high, piece;  // the clips' results, reused
    tri.n = 3;
    for (std::size_t k = 0; k < 3; ++k) tri.c[k] = t[k];
    // A triangle inside one row (column) of cells: the row's (cell's) clips would keep every
    // corner (v - v0 rounds to >= 0 exactly when v >= v0), so they are skipped. (Only for the
    // triangle itself: a clipped corner may lie a rounding step outside the triangle's box.)
    const bool one_row = j0 == j1 && vmin >= truth.vs[j0] && vmax <= truth.vs[j0 + 1] && std::isfinite(umin) &&
                         std::isfinite(umax);  // (0 * u is NaN for an infinite u)
    const bool one_cell = one_row && i0 == i1 && umin >= truth.us[i0] && umax <= truth.us[i0 + 1];
    for (std::size_t j = j0; j <= j1; ++j) {
        const double v0 = truth.vs[j], v1 = truth.vs[j + 1], dv = v1 - v0;
        const Polygon& row = one_row ? tri : clip(clip(tri, 0.0, 1.0, -v0, row_low), 0.0, -1.0, v1, row_high);
        if (row.n < 3) continue;
        for (std::size_t i = i0; i <= i1; ++i) {
            const double u0 = truth.us[i], u1 = truth.us[i + 1], du = u1 - u0;
            const Polygon& cell = one_cell ? row : clip(clip(row, 1.0, 0.0, -u0, cell_low), -1.0, 0.0, u1, cell_high);
            if (cell.n < 3) continue;
            const double ha = truth.height(i, j), hb = truth.height(i + 1, j);
            const double hc = truth.height(i + 1, j + 1), hd = truth.height(i, j + 1);
            // The diagonal from a = (u0, v0) to c = (u1, v1): f = (u - u0) dv - (v - v0) du.
            // f >= 0: triangle (a, b, c), below the diagonal; f <= 0: triangle (a, c, d).
            const double a = dv, b = -du, k = -u0 * dv + v0 * du;
            const double su_below = (hb - ha) / du, sv_below = (hc - hb) / dv;
            const double su_above = (hc - hd) / du, sv_above = (hd - ha) / dv;
            // A cell piece wholly on one side (most, where triangles are smaller than texels)
            // is measured as it is: the other side's clip, whose f is this one's negated
            // (exactly: negation commutes with rounding; at most the sign of a zero
            // differs), would keep no corner.
            bool below = true, above = true;
            for (int n = 0; n < cell.n; ++n) {
                const Corner& p = cell.c[static_cast<std::size_t>(n)];
                const double f = a * p.u + b * p.v + k;
                below = below && f > 0.0;
                above = above && f < 0.0;
            }
            if (below) measure_piece(cell, u0, v0, ha, su_below, sv_below, out);
            else if (above) measure_piece(cell, u0, v0, ha, su_above, sv_above, out);
            else {
                measure_piece(clip(cell, a, b, k, piece), u0, v0, ha, su_below, sv_below, out);
                measure_piece(clip(cell, -a, -b, u0 * dv - v0 * du, piece), u0, v0, ha, su_above, sv_above, out);
            }
        }
    }
}

}  // namespace

GeometricError geometric_error(const TruthSurface& truth, const SurfaceMesh& mesh, const SceneCamera* camera) {
    GeometricError result;
    if (truth.us.size() < 2 || truth.vs.size() < 2 || mesh.triangles.empty()) return result;
    // The triangles of each patch: they come patch after patch (pipeline.h OUTPUT).
    std::vector<std::size_t> starts;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
        if (t == 0 || mesh.patch_ids[mesh.triangles[t][0]] != mesh.patch_ids[mesh.triangles[t - 1][0]]) starts.push_back(t);
    starts.push_back(mesh.triangles.size());
    const std::size_t groups = starts.size() - 1;
    std::vector<PatchError> slots(groups);
    const bool xy = truth.plane_xy;
    const auto corner = [&](std::uint32_t v) {
        const glm::dvec3& p = mesh.positions[v];
        return xy ? Corner{p.x, p.y, p.z} : Corner{p.x, p.z, p.y};
    };
    const TruthCells cells(truth);
    tessref::parallel_for(std::size_t{0}, groups, [&](std::size_t g) {
        for (std::size_t t = starts[g]; t < starts[g + 1]; ++t) {
            const auto& tri = mesh.triangles[t];
            measure_triangle(truth, cells, {corner(tri[0]), corner(tri[1]), corner(tri[2])}, slots[g]);
        }
    });

    // The visible part of the segment from (u, v, g) to (u, v, t) (visible_pixels).
    const glm::dmat4 vp = camera ? camera->view_projection() : glm::dmat4(1.0);
    const auto visible_pixels = [&](double u, double v, double g, double t) {
        const auto at = [&](double h) { return xy ? glm::dvec3(u, v, h) : glm::dvec3(u, h, v); };
        return sweep::visible_pixels(vp, camera->viewport, at(g), at(t));
    };
    double sum_sq = 0.0, area = 0.0;
    result.max = 0.0;
    for (const PatchError& s : slots) {  // serially, in patch order: deterministic
        if (s.max < 0.0) continue;
        sum_sq += s.sum_sq;
        area += s.area;
        if (s.max > result.max) {
            result.max = s.max;
            result.max_at = {s.at.u, s.at.v};
        }
        if (camera) result.max_px = std::max(result.max_px, visible_pixels(s.at.u, s.at.v, s.truth_at, s.at.h));
    }
    result.area = area;
    result.rms = area > 0.0 ? std::sqrt(std::max(0.0, sum_sq) / area) : 0.0;
    return result;
}

namespace {

// visible_pixels() from the segment's ends in clip space.
double visible_clip_pixels(const glm::dvec4& a, const glm::dvec4& b, glm::ivec2 viewport) {
    double t0 = 0.0, t1 = 1.0;
    for (int axis = 0; axis < 3; ++axis) {
        for (const double sign : {1.0, -1.0}) {
            // f(s) = w + sign * coordinate >= 0, linear along the segment.
            const double fa = a.w + sign * a[axis], fb = b.w + sign * b[axis];
            if (fa < 0.0 && fb < 0.0) return 0.0;
            if (fa < 0.0) t0 = std::max(t0, fa / (fa - fb));
            if (fb < 0.0) t1 = std::min(t1, fa / (fa - fb));
        }
    }
    if (!(t1 > t0)) return 0.0;
    const auto window = [&](double s) {
        const glm::dvec4 c = a + s * (b - a);
        return (glm::dvec2(c) / c.w * 0.5 + 0.5) * glm::dvec2(viewport);
    };
    return glm::length(window(t1) - window(t0));
}

glm::dvec4 clip_point(const glm::dmat4& view_projection, const glm::dvec3& p) {
    return view_projection * glm::dvec4(p, 1.0);
}

}  // namespace

double visible_pixels(const glm::dmat4& view_projection, glm::ivec2 viewport, const glm::dvec3& from,
                      const glm::dvec3& to) {
    return visible_clip_pixels(clip_point(view_projection, from), clip_point(view_projection, to), viewport);
}

double mean_edge_pixels(const SurfaceMesh& mesh, const glm::dmat4& view_projection, glm::ivec2 viewport) {
    // The edges' lengths chunk by chunk, in parallel into a buffer, then added serially in
    // triangle order: the same sum on any thread count, and the same as one loop over the
    // edges (an edge with no visible part adds 0, which leaves the sum as it is). The
    // serial part is one addition per edge. Each triangle's corners are taken to clip space
    // once for its three edges, by the expression visible_pixels() uses. (Once per vertex
    // for the whole mesh was slower: a fresh array of 32 bytes a vertex costs more in page
    // faults than the transforms it saves.)
    constexpr std::size_t kChunk = std::size_t{1} << 15;  // triangles
    std::vector<double> px(3 * std::min(kChunk, mesh.triangles.size()));
    double sum = 0.0;
    std::size_t edges = 0;
    for (std::size_t first = 0; first < mesh.triangles.size(); first += kChunk) {
        const std::size_t count = std::min(kChunk, mesh.triangles.size() - first);
        tessref::parallel_for(tbb::blocked_range<std::size_t>(0, count, 1 << 10),
                              [&](const tbb::blocked_range<std::size_t>& r) {
                                  for (std::size_t t = r.begin(); t < r.end(); ++t) {
                                      const auto& tri = mesh.triangles[first + t];
                                      const glm::dvec4 c[3] = {clip_point(view_projection, mesh.positions[tri[0]]),
                                                               clip_point(view_projection, mesh.positions[tri[1]]),
                                                               clip_point(view_projection, mesh.positions[tri[2]])};
                                      for (std::size_t k = 0; k < 3; ++k)
                                          px[3 * t + k] = visible_clip_pixels(c[k], c[(k + 1) % 3], viewport);
                                  }
                              });
        for (std::size_t e = 0; e < 3 * count; ++e) {
            sum += px[e];
            edges += px[e] > 0.0;
        }
    }
    return edges ? sum / static_cast<double>(edges) : 0.0;
}

}  // namespace tessref::sweep
