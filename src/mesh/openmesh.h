// src/mesh/openmesh.h — where a mesh read by tessref's own readers (read_mesh_file,
// tessref/mesh_io.h) enters OpenMesh (private to the library).
//
// OpenMesh's readers are not used on user files (src/mesh/read.cpp says why), but its
// half-edge kernel stays the reference for what a mesh file means to OpenMesh: which faces
// it refuses (the check's refused_face class) and the vertex normals it computes (a
// scene's [mesh] without normals). Both are asked of one import, done here as OpenMesh's
// readers do it.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <vector>

#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include "tessref/mesh.h"
#include "tessref/mesh_io.h"

namespace tessref::mesh_detail {

using HalfEdgeMesh = OpenMesh::PolyMesh_ArrayKernelT<>;

struct HalfEdgeImport {
    HalfEdgeMesh mesh;
    // Faces of the file the kernel did not take as listed (IndexedMesh::kernel_refused_faces).
    std::vector<std::uint32_t> refused_faces;
};

// Builds OpenMesh's half-edge mesh from `file` through OpenMesh's importer, as its readers
// build it: the file's vertices in order, positions rounded to float, with the file's
// vertex normals and uvs when it has them, then its faces in order. The importer drops a
// face with a repeated vertex or fewer than three, and adds a face making a complex edge or
// vertex on copies of its vertices (appended after the file's); both are refused_faces, and
// OpenMesh explains each on omerr() (silence it with QuietStream). With
// compute_missing_normals, a file without normals gets OpenMesh's vertex normals: the
// normalized sum of the incident face normals, from faces in its circulation order.
HalfEdgeImport import_half_edge_mesh(const IndexedMesh& file, bool compute_missing_normals);

// write_mesh() with a PLY file written by OpenMesh's PLY writer, the reference that
// tessref's own PLY writer (write_mesh's) reproduces byte for byte; the other formats go
// through OpenMesh's writers in write_mesh() too, so for them the two are the same.
MeshWriteReport write_mesh_through_openmesh(const SurfaceMesh& mesh, std::ostream& out,
                                            const MeshWriteOptions& options);

// Silences one of OpenMesh's log streams (omlog(), omerr()) for a scope, restoring its
// previous state afterwards.
class QuietStream {
public:
    explicit QuietStream(OpenMesh::mostream& stream) : stream_(stream), was_enabled_(stream.is_enabled()) {
        stream_.disable();
    }
    ~QuietStream() {
        if (was_enabled_) stream_.enable();
    }
    QuietStream(const QuietStream&) = delete;
    QuietStream& operator=(const QuietStream&) = delete;

private:
    OpenMesh::mostream& stream_;
    bool was_enabled_;
};

}  // namespace tessref::mesh_detail
