// read.cpp — reading a mesh file (mesh_io.h, read_mesh_file): a strict scan of its bytes, one
// function per format (read_ply.cpp, read_obj.cpp, read_off.cpp, read_stl.cpp), picked here
// by the extension.
//
// Every mesh tessref takes from a user (`tessref check`, a scene's [[mesh]]) is read here.
// OpenMesh's readers could not be made safe against hostile files: its PLY header parser
// crashes on a `property` line before any `element`, its ASCII PLY reader reads
// uninitialised memory after a bad token (and then allocates without limit), its binary OFF
// and PLY readers trust the header's counts (gigabytes for a 4 kB file), its text readers
// turn a bad token into a vertex index, and it drops or shortens faces a checker must see.
// So each format is scanned here: the header grammar, every token, every index and the
// exact byte length are checked; counts from a header are held against the file's size and
// the memory limit before anything is allocated; every error names the file and the line
// (text) or byte offset (binary). OpenMesh keeps the part where it is the reference: which
// faces its kernel refuses, and the vertex normals of a scene's mesh, both from this scan
// through OpenMesh's importer (src/mesh/openmesh.h).
//
// Coordinates are rounded to float, as OpenMesh and admesh read them (and as the check's
// tolerances and its comparison with admesh assume); a reader note says so when the rounding
// makes coordinates equal that the file keeps apart.
#include <filesystem>
#include <string>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "common/file_name.h"
#include "mesh/read_internal.h"
#include "tessref/mesh.h"
#include "tessref/mesh_io.h"

namespace tessref {

void IndexedMesh::add_face(std::span<const std::uint32_t> vertex_ids) {
    if (face_vertices.size() + vertex_ids.size() > std::numeric_limits<std::uint32_t>::max())
        throw Error("mesh too large: more than 4294967295 face corners", Where::in_file(source));
    face_vertices.insert(face_vertices.end(), vertex_ids.begin(), vertex_ids.end());
    face_start.push_back(static_cast<std::uint32_t>(face_vertices.size()));
}

void IndexedMesh::add_triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    const std::uint32_t ids[3] = {a, b, c};
    add_face(ids);
}

namespace {

// The file's bytes, mapped rather than copied: a header is checked against the file's size
// and the memory limit before the data behind it costs memory.
class MappedFile {
public:
    explicit MappedFile(const std::string& path) {
        const Where where = Where::in_file(path);
        fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);  // a FIFO must not block
        struct stat st {};
        if (fd_ < 0 || ::fstat(fd_, &st) != 0) throw Error(std::string("cannot open mesh file: ") + std::strerror(errno), where);
        if (S_ISFIFO(st.st_mode)) throw Error("a FIFO (named pipe), not a regular file: a mesh file is read whole", where);
        if (!S_ISREG(st.st_mode)) throw Error("not a regular file (a device or socket)", where);
        size_ = static_cast<std::size_t>(st.st_size);
        if (size_ == 0) throw Error("empty mesh file", where);
        data_ = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd_, 0);
        if (data_ == MAP_FAILED) throw Error(std::string("cannot read mesh file: ") + std::strerror(errno), where);
        ::madvise(data_, size_, MADV_SEQUENTIAL);
    }
    ~MappedFile() {
        if (data_ != MAP_FAILED) ::munmap(data_, size_);
        if (fd_ >= 0) ::close(fd_);
    }
    MappedFile(const MappedFile&) = delete;
    MappedFile& operator=(const MappedFile&) = delete;
    std::string_view text() const { return {static_cast<const char*>(data_), size_}; }

private:
    int fd_ = -1;
    void* data_ = MAP_FAILED;
    std::size_t size_ = 0;
};

}  // namespace

IndexedMesh read_mesh_file(const std::string& path, const MeshFileOptions& options) {
    const Where where = Where::in_file(path);
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) throw Error("no such mesh file", where);
    if (std::filesystem::is_directory(path, ec)) throw Error("is a directory, not a mesh file", where);
    const std::string ext = lowercase_extension(path);
    if (ext != "ply" && ext != "obj" && ext != "off" && ext != "stl")
        throw Error("unsupported mesh format '" + ext + "' (expected .ply, .obj, .off or .stl)", where);
    const MappedFile file(path);
    mesh_read::Reading r(path, file.text(), options);
    r.mesh.format = ext;
    if (ext == "ply") mesh_read::read_ply(r);
    else if (ext == "off") mesh_read::read_off(r);
    else if (ext == "obj") mesh_read::read_obj(r);
    else mesh_read::read_stl(r);
    if (r.mesh.face_count() == 0) throw Error("no faces: a point cloud, not a mesh", where);
    r.note_rounding();
    if (options.progress) options.progress(1.0);
    return std::move(r.mesh);
}

IndexedMesh indexed_mesh_from(const SurfaceMesh& surface) {
    // The exporter's weld, but every triangle kept: a triangle whose corners weld together
    // is what the check should report, not lose.
    WeldedMesh welded = weld_bitwise(surface);
    IndexedMesh mesh;
    mesh.positions = std::move(welded.mesh.positions);
    mesh.face_vertices.reserve(surface.triangles.size() * 3);
    mesh.face_start.reserve(surface.triangles.size() + 1);
    for (const auto& t : surface.triangles)
        mesh.add_triangle(welded.vertex_map[t[0]], welded.vertex_map[t[1]], welded.vertex_map[t[2]]);
    return mesh;
}

}  // namespace tessref
