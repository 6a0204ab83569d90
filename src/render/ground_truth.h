// src/render/ground_truth.h — the full-resolution surface that is the ground truth of the
// speed/accuracy study, in one place for its two users: raytrace_scene() (render.h), which
// ray-traces it, and the sweep's geometric error (src/sweep/geometric_error.h), which
// measures a tessellation's distance to it.
//
// The surface (render.h, raytrace_scene): vertex lines along each ground axis at the grid
// extent's two borders and at every texel centre strictly inside the extent; at each
// crossing the height map sampled at mip 0 in double (texel values exactly, bilinear
// between them, clamp to edge) times scale_z; two triangles per quad, split along the
// diagonal from its (low u, low v) corner to its (high u, high v) corner.
#pragma once

#include <vector>

#include "tessref/scene.h"

namespace tessref::ground_truth {

// Texture coordinate along one ground axis: st = a * world + b (the evaluation model's map).
struct AxisMap {
    double a = 1.0;
    double b = 0.0;
    double st(double world) const { return a * world + b; }
    double world(double st) const { return (st - b) / a; }
};

struct GroundMap {
    AxisMap u, v;  // world x -> s; world y (plane xy) or z (plane xz) -> t
};

// The evaluation model's map from ground coordinates to texture coordinates (terrain
// scenes: thesis xy / scale_xy, COSC422 the extent, lab 4 xz / scale_xy + offset).
GroundMap ground_map(const Scene& scene);

// The vertex lines along one axis, sorted, distinct: lo, hi and every texel centre inside.
std::vector<double> vertex_lines(double lo, double hi, const AxisMap& map, int texels);

// The surface's height at its vertex (u, v) (ground coordinates): mip 0 in double at the
// mapped texture coordinate, times scale_z.
double vertex_height(const TerrainGrid& grid, const GroundMap& map, double u, double v);

}  // namespace tessref::ground_truth
