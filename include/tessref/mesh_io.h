// tessref/mesh_io.h — mesh files read as they are listed: IndexedMesh and read_mesh_file.
//
// tessref reads every mesh a user gives it (`tessref check`, a scene's [[mesh]]) with its
// own strict readers, one per format (src/mesh/read_*.cpp), which refuse, naming the line or
// byte offset, anything they cannot read exactly; OpenMesh's readers crash or loop on
// malformed files (src/mesh/read.cpp says how). Meshes are written by write_mesh (mesh.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/mesh.h"

namespace tessref {

// A polygon mesh as listed by a file: positions, and faces as lists of vertex ids. Face f
// is face_vertices[face_start[f] .. face_start[f+1]). Vertex and face ids are the file's
// (0-based, in file order).
struct IndexedMesh {
    std::vector<glm::dvec3> positions;
    std::vector<std::uint32_t> face_start{0};  // face_count() + 1 entries
    std::vector<std::uint32_t> face_vertices;

    // Faces the file lists that OpenMesh's kernel refuses to connect (its importer adds them
    // as separate copies instead, or drops them). Part of the face list above.
    std::vector<std::uint32_t> kernel_refused_faces;

    // What the reading could not do exactly as described above (empty normally), e.g.
    // coordinates the file holds in double precision that become equal as float.
    std::vector<std::string> reader_notes;

    // Per-vertex normals and texture coordinates, read only when MeshFileOptions asks for
    // them, each empty when the file has none (the values as float, as OpenMesh holds them).
    std::vector<glm::vec3> normals;
    std::vector<glm::vec2> uvs;
    // The provenance `tessref mesh` writes to PLY (properties patch_id, tess_u, tess_v,
    // tess_w), read when MeshFileOptions asks for it; each empty when the file has none.
    std::vector<std::uint32_t> patch_ids;
    std::vector<glm::vec3> tess_coords;

    std::string source;  // the file it was read from ("" when built in memory)
    std::string format;  // "ply", "obj", "off", "stl" ("" when built in memory)

    std::size_t vertex_count() const { return positions.size(); }
    std::size_t face_count() const { return face_start.size() - 1; }
    std::span<const std::uint32_t> face(std::size_t f) const {
        return {face_vertices.data() + face_start[f], face_start[f + 1] - face_start[f]};
    }
    void add_face(std::span<const std::uint32_t> vertex_ids);
    void add_triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c);
};

struct MeshFileOptions {
    bool vertex_attributes = false;              // also read normals and texture coordinates
    bool provenance = false;                     // also read a PLY's patch ids and tess coords
    // With provenance: keep the tess coords too. Without, a bad one is refused all the same
    // (the file is read as it would be with them) and tess_coords stays empty (the check
    // names patches, and has no use for 12 bytes a vertex more).
    bool tess_coords = true;
    std::function<void(double)> progress;        // fraction of the file read, now and then
};

// Reads a PLY (ascii, binary little or big endian), OBJ, OFF (ascii with [ST][C][N]
// prefixes, or binary as `tessref mesh --binary` writes it) or STL (ascii or binary) file,
// chosen by extension; coordinates are rounded to float as OpenMesh and admesh read them.
// Every token, index and byte count is checked: a file that is not exactly what its format
// says (a bad token, a non-finite coordinate, an index out of range, a header declaring
// more than the file holds or than memory allows, trailing data) throws tessref::Error
// naming the file and the line, or for binary data the byte offset. A file without faces
// is an error too.
IndexedMesh read_mesh_file(const std::string& path, const MeshFileOptions& options = {});

// The mesh `tessref mesh` would export: positions welded where they are bitwise equal
// (the same rule as the exporter, so a crack between patches stays a crack).
IndexedMesh indexed_mesh_from(const SurfaceMesh& surface);

}  // namespace tessref
