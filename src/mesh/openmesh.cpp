#include "mesh/openmesh.h"

#include <OpenMesh/Core/IO/importer/ImporterT.hh>

namespace tessref::mesh_detail {

HalfEdgeImport import_half_edge_mesh(const IndexedMesh& file, bool compute_missing_normals) {
    HalfEdgeImport out;
    HalfEdgeMesh& mesh = out.mesh;
    const bool normals = !file.normals.empty();
    const bool uvs = !file.uvs.empty();
    if (normals || compute_missing_normals) mesh.request_vertex_normals();
    if (uvs) mesh.request_vertex_texcoords2D();
    mesh.reserve(file.vertex_count(), 0, file.face_count());
    {
        OpenMesh::IO::ImporterT<HalfEdgeMesh> importer(mesh);
        for (std::size_t v = 0; v < file.vertex_count(); ++v) {
            const glm::dvec3& p = file.positions[v];
            const auto vh = importer.add_vertex(OpenMesh::Vec3f(float(p.x), float(p.y), float(p.z)));
            if (normals) importer.set_normal(vh, OpenMesh::Vec3f(file.normals[v].x, file.normals[v].y, file.normals[v].z));
            if (uvs) importer.set_texcoord(vh, OpenMesh::Vec2f(file.uvs[v].x, file.uvs[v].y));
        }
        OpenMesh::IO::BaseImporter::VHandles handles;
        for (std::size_t f = 0; f < file.face_count(); ++f) {
            handles.clear();
            for (std::uint32_t v : file.face(f)) handles.emplace_back(static_cast<int>(v));
            const std::size_t vertices_before = mesh.n_vertices();
            const OpenMesh::FaceHandle fh = importer.add_face(handles);
            if (!fh.is_valid() || mesh.n_vertices() != vertices_before)
                out.refused_faces.push_back(static_cast<std::uint32_t>(f));
        }
    }
    if (!normals && compute_missing_normals) {
        mesh.request_face_normals();
        mesh.update_normals();
    }
    return out;
}

}  // namespace tessref::mesh_detail
