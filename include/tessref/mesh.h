// tessref/mesh.h — the tessellated surface as plain data, and its export.
//
// SurfaceMesh is what the pipeline (scene -> control -> generator -> evaluation ->
// geometry) produces and what `tessref mesh` writes through OpenMesh. Every vertex
// remembers where it came from: the patch that emitted it and its gl_TessCoord, so a
// defect found later (a crack, a wrong normal) can be traced back to a patch.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace tessref {

struct SurfaceMesh {
    // One entry per emitted vertex (not welded: patches that share an edge each emit
    // their own copies; export welds only bitwise-equal positions).
    std::vector<glm::dvec3> positions;   // world space; float-exact values in gpu precision
    std::vector<glm::dvec3> normals;     // empty when no stage produced normals
    std::vector<glm::dvec2> uvs;         // texture coordinates; empty when none
    std::vector<std::uint32_t> patch_ids;
    std::vector<glm::vec3> tess_coords;  // gl_TessCoord of the vertex in its patch
    std::vector<std::array<std::uint32_t, 3>> triangles;  // counter-clockwise seen from outside/above
};

}  // namespace tessref
