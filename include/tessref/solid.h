// tessref/solid.h — closing a terrain into a watertight solid (`tessref mesh --solid`).
#pragma once

#include "tessref/mesh.h"

namespace tessref {

// Closes a terrain (a surface seen from +up, triangles counter-clockwise from above; up is
// the axis up_axis: 2 for a terrain on plane xy, 1 for plane xz) into a solid for 3D
// printing or volume meshing: the vertices are welded where their positions are bitwise
// equal (as the mesh export does), a vertical skirt runs from the outer outline down to the
// plane where coordinate up_axis equals `base`, and the base closes it from below. Every face
// points outward, so the solid has a positive volume and `tessref check --expect closed`
// passes it — provided the terrain itself has no crack: boundary loops inside the outline
// (a hole, a T-junction crack between patches) are left open, for the check to report.
//
// New vertices copy the attributes of the outline vertex above them (patch id, tess coord,
// uv); their normals point straight down. Throws tessref::Error when the terrain has no
// triangles or no closed outline, faces down, or when `base` is not below every vertex.
SurfaceMesh close_terrain_into_solid(const SurfaceMesh& terrain, double base, int up_axis = 2);

}  // namespace tessref
