// src/sweep/geometric_error.h — how far a tessellated terrain lies from the full-resolution
// height field: the geometric error columns of `tessref sweep` (docs/SWEEP.md).
//
// THE TRUTH. The same surface raytrace_scene() ray-traces (render.h; built from
// src/render/ground_truth.h, so the image error and the geometric error judge against one
// truth): vertex lines at the grid extent's borders and at every texel centre inside it,
// heights mip 0 in double, two triangles per texel quad split from its (low u, low v) to its
// (high u, high v) corner. Call it G; it is piecewise linear over the ground plane.
//
// THE TESSELLATION. T: the pipeline's triangles, each a plane through its three vertices
// (mesh positions, in the run's precision). Both are height fields over the ground plane
// (plane xy: ground (x, y), height z; plane xz: ground (x, z), height y).
//
// THE ERROR. e = T - G, the vertical distance in world units. Over each piece of the
// overlay of the two triangulations (a tessellated triangle clipped to one truth triangle:
// a convex polygon), T and G are both linear, so e is linear: its extreme values are at the
// pieces' corners, which are exactly the tessellation's vertices, the truth's vertices (the
// texel grid vertices) and the crossings of the tessellation's edges with the truth's edges
// (texel grid lines and the quads' diagonals). The computation clips every tessellated
// triangle against every truth triangle under it, so:
//   max  = the largest |e| over all those corners: the exact maximum of |T - G| over the
//          tessellated area (up to double rounding), not a sample of it;
//   rms  = sqrt( integral of e^2 dA / integral of dA ), AREA-WEIGHTED over the ground area
//          the tessellation covers, integrated exactly (e is linear on each piece: a
//          triangle of area A with corner values a, b, c has integral of e^2 =
//          A (a^2 + b^2 + c^2 + ab + bc + ca) / 6);
//   max_px = the screen size of the error: for each patch, the point of its largest |e|,
//          the vertical segment from G to T there, clipped to the camera's view volume
//          (-w <= x, y, z <= w in clip space: what lies off screen, behind the eye or
//          beyond the far plane is not seen), projected into window coordinates; its length
//          in pixels (0 when none of it is in view); the maximum over patches.
// Ground outside the truth's extent (a float vertex a rounding step outside) and patches
// culled by a level <= 0 (no triangles) cover no area and count nowhere. Triangles whose
// ground projection has zero area count only through their neighbours.
//
// DETERMINISM. Patches are measured in parallel, each into its own slot; the slots are
// combined serially in patch order, so the result is the same for any thread count.
#pragma once

#include <cstddef>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/mesh.h"
#include "tessref/scene.h"

namespace tessref::sweep {

// G of one terrain scene: vertex lines and the heights at their crossings.
struct TruthSurface {
    bool plane_xy = true;          // ground (x, y), height z; else ground (x, z), height y
    std::vector<double> us, vs;    // vertex lines along the ground axes, ascending
    std::vector<double> heights;   // heights[j * us.size() + i] at (us[i], vs[j])
    double height(std::size_t i, std::size_t j) const { return heights[j * us.size() + i]; }
};

// Builds G for a terrain scene. Throws tessref::Error for a mesh (PN) scene.
TruthSurface truth_surface(const Scene& scene);

struct GeometricError {
    double max = 0.0;     // world units
    double rms = 0.0;     // world units, area-weighted
    double max_px = 0.0;  // pixels (0 without a camera)
    double area = 0.0;    // ground area the tessellation covers (the RMS's total weight)
    glm::dvec2 max_at{0.0};  // ground point of `max`
};

// The error of `mesh` (a pipeline result of a terrain scene whose truth is `truth`);
// `camera` (its viewport the image size) gives max_px, null: max_px = 0.
GeometricError geometric_error(const TruthSurface& truth, const SurfaceMesh& mesh, const SceneCamera* camera);

// The length in pixels of the part of the segment from `from` to `to` that the camera sees:
// the segment clipped to the view volume (-w <= x, y, z <= w in clip space, where it stays a
// segment), projected into window coordinates of `viewport`; 0 when none of it is in view.
double visible_pixels(const glm::dmat4& view_projection, glm::ivec2 viewport, const glm::dvec3& from,
                      const glm::dvec3& to);

// The mean projected edge length: visible_pixels() of every edge of every triangle (an edge
// two triangles share counts twice), averaged over the edges with a visible part; 0 when
// none has one. The sweep's mean_edge_px column (docs/SWEEP.md), to hold against the 3-6
// pixels per triangle edge that hardware-tessellated terrains aim at. The edges are measured
// in parallel and summed serially in triangle order: the same number on any thread count.
double mean_edge_pixels(const SurfaceMesh& mesh, const glm::dmat4& view_projection, glm::ivec2 viewport);

}  // namespace tessref::sweep
