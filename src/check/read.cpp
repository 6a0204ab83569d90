// Reading a mesh for checking: OpenMesh parses the file; we keep every face it hands over.
//
// OpenMesh's ImporterT adds each face to a half-edge kernel, which refuses faces that would
// make a complex edge or vertex (the importer then re-adds them on private vertex copies)
// and rejects faces with a repeated vertex outright. Its STL reader also skips facets whose
// corners coincide before the importer sees them. A checker must see all of these, so the
// importer below records every vertex and face first and lets OpenMesh do its part after;
// STL facets the reader skipped are recovered from the file.
#include <algorithm>
#include <bit>
#include <charconv>
#include <climits>
#include <iostream>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <unordered_map>

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/importer/ImporterT.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include "check/check_internal.h"
#include "tessref/check.h"
#include "tessref/error.h"

namespace tessref {

void IndexedMesh::add_face(std::span<const std::uint32_t> vertex_ids) {
    if (face_vertices.size() + vertex_ids.size() > std::numeric_limits<std::uint32_t>::max())
        throw Error("mesh too large: more than 4294967295 face corners", check_detail::where_in(source));
    face_vertices.insert(face_vertices.end(), vertex_ids.begin(), vertex_ids.end());
    face_start.push_back(static_cast<std::uint32_t>(face_vertices.size()));
}

void IndexedMesh::add_triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    const std::uint32_t ids[3] = {a, b, c};
    add_face(ids);
}

namespace {

using OmMesh = OpenMesh::PolyMesh_ArrayKernelT<>;

// Records positions and faces as the reader produces them, then forwards to ImporterT.
class RecordingImporter : public OpenMesh::IO::ImporterT<OmMesh> {
public:
    using Base = OpenMesh::IO::ImporterT<OmMesh>;
    RecordingImporter(OmMesh& om, IndexedMesh& out) : Base(om), om_(om), out_(out) {}

    // Progress: elements (vertices + faces) expected, and whom to tell.
    void set_progress(std::uint64_t expected, const std::function<void(double)>* progress) {
        expected_ = expected;
        progress_ = progress;
    }

    OpenMesh::VertexHandle add_vertex(const OpenMesh::Vec3f& p) override {
        record_vertex({p[0], p[1], p[2]});
        return Base::add_vertex(p);
    }
    OpenMesh::VertexHandle add_vertex(const OpenMesh::Vec3d& p) override {
        record_vertex({p[0], p[1], p[2]});
        return Base::add_vertex(p);
    }
    OpenMesh::VertexHandle add_vertex() override {
        record_vertex(glm::dvec3(0.0));
        return Base::add_vertex();
    }
    void set_point(OpenMesh::VertexHandle vh, const OpenMesh::Vec3f& p) override {
        const int index = vertex_index_of(vh);
        if (index >= 0) out_.positions[index] = glm::dvec3(p[0], p[1], p[2]);
        Base::set_point(vh, p);
    }

    OpenMesh::FaceHandle add_face(const VHandles& handles) override {
        const auto face_id = static_cast<std::uint32_t>(out_.face_count());
        tick();
        // A reader that misparsed a header can run on, adding empty faces, far beyond
        // anything the file could hold: stop it.
        if (face_id >= face_limit_) throw FaceLimit{};
        ids_.clear();
        bool valid = true;
        for (const OpenMesh::VertexHandle& vh : handles) {
            const int index = vertex_index_of(vh);
            if (index < 0) {
                valid = false;
                if (!bad_face_) bad_face_ = BadFace{face_id, vh.idx()};
                continue;
            }
            ids_.push_back(static_cast<std::uint32_t>(index));
        }
        if (!valid) return OpenMesh::FaceHandle();  // reported as an error after reading
        out_.add_face(ids_);

        // ImporterT re-adds a face the kernel refuses on copies of its vertices, and returns
        // an invalid handle for a face with a repeated vertex: either way, refused.
        const std::size_t vertices_before = om_.n_vertices();
        const OpenMesh::FaceHandle fh = Base::add_face(handles);
        if (!fh.is_valid() || om_.n_vertices() != vertices_before)
            out_.kernel_refused_faces.push_back(face_id);
        return fh;
    }

    struct BadFace {
        std::uint32_t face_id;
        int vertex;
    };
    struct FaceLimit {};
    void set_face_limit(std::size_t limit) { face_limit_ = limit; }
    const std::optional<BadFace>& bad_face() const { return bad_face_; }
    std::size_t recorded_vertices() const { return recorded_; }

private:
    void tick() {
        if (progress_ && expected_ > 0 && ++elements_ % 65536 == 0)
            (*progress_)(std::min(1.0, double(elements_) / double(expected_)));
    }
    void record_vertex(const glm::dvec3& p) {
        tick();
        // OpenMesh handles are the kernel's vertex indices; the kernel also grows when the
        // importer copies vertices of a refused face, so keep our own mapping.
        kernel_to_file_.resize(om_.n_vertices() + 1, -1);
        kernel_to_file_[om_.n_vertices()] = static_cast<int>(out_.positions.size());
        out_.positions.push_back(p);
        ++recorded_;
    }
    int vertex_index_of(OpenMesh::VertexHandle vh) const {
        const int k = vh.idx();
        if (k < 0 || k >= static_cast<int>(kernel_to_file_.size())) return -1;
        return kernel_to_file_[k];
    }

    OmMesh& om_;
    IndexedMesh& out_;
    std::vector<int> kernel_to_file_;
    std::vector<std::uint32_t> ids_;
    std::optional<BadFace> bad_face_;
    std::size_t recorded_ = 0;
    std::size_t face_limit_ = std::numeric_limits<std::size_t>::max();
    std::uint64_t expected_ = 0, elements_ = 0;
    const std::function<void(double)>* progress_ = nullptr;
};

// Sends OpenMesh's diagnostics (its omerr/omlog streams, and the readers that write to
// std::cerr directly) to a string while a file is read, so the terminal stays clean and an
// error message can quote the reader. Reading happens on one thread, before any parallel
// work, so swapping the standard streams' buffers is safe here.
class CapturedOpenMeshLog {
public:
    CapturedOpenMeshLog()
        : old_cerr_(std::cerr.rdbuf(text_.rdbuf())), old_clog_(std::clog.rdbuf(text_.rdbuf())),
          old_cout_(std::cout.rdbuf(text_.rdbuf())) {}
    ~CapturedOpenMeshLog() {
        ::omerr() << std::flush;
        ::omlog() << std::flush;
        std::cerr.rdbuf(old_cerr_);
        std::clog.rdbuf(old_clog_);
        std::cout.rdbuf(old_cout_);
    }
    std::string first_line() {
        ::omerr() << std::flush;
        std::string s = text_.str();
        const auto end = s.find('\n');
        if (end != std::string::npos) s.resize(end);
        while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
        if (s.size() > 200) s.resize(200);
        return s;
    }

private:
    std::ostringstream text_;
    std::streambuf* old_cerr_;
    std::streambuf* old_clog_;
    std::streambuf* old_cout_;
};

std::string lowercase_extension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    if (!ext.empty() && ext[0] == '.') ext.erase(0, 1);
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

std::uint32_t read_u32_le(const unsigned char* p) {
    return std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 |
           std::uint32_t(p[3]) << 24;
}

// What an STL file is, decided as OpenMesh decides it (binary when its size is exactly
// 84 + 50 * the facet count in its header), plus the checks OpenMesh leaves out: a file
// that is not binary must be text that starts with "solid" and ends with "endsolid" — a
// truncated binary STL would otherwise be read as an empty ASCII one.
struct StlKind {
    bool binary = false;
    std::uint64_t facets = 0;  // binary only
};

StlKind classify_stl(const std::string& path) {
    const Where where = check_detail::where_in(path);
    std::ifstream in(path, std::ios::binary);
    const auto size = std::filesystem::file_size(path);
    unsigned char header[84] = {};
    in.read(reinterpret_cast<char*>(header), 84);
    const auto got = static_cast<std::uint64_t>(in.gcount());
    if (got == 84) {
        const std::uint64_t facets = read_u32_le(header + 80);
        if (84 + 50 * facets == size) return {true, facets};
    }
    // Not binary by size: it must be ASCII.
    in.clear();
    in.seekg(0);
    std::string head(std::min<std::uint64_t>(size, 65536), '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    const bool text = std::all_of(head.begin(), head.end(), [](char ch) {
        const auto c = static_cast<unsigned char>(ch);
        return c >= 32 || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v';
    });
    std::size_t first = head.find_first_not_of(" \t\r\n");
    const bool starts_solid =
        first != std::string::npos && head.size() - first >= 5 &&
        std::equal(head.begin() + static_cast<long>(first), head.begin() + static_cast<long>(first) + 5,
                   "solid", [](char a, char b) { return std::tolower(static_cast<unsigned char>(a)) == b; });
    if (!text || !starts_solid) {
        if (got == 84) {
            const std::uint64_t facets = read_u32_le(header + 80);
            throw Error("truncated or corrupt binary STL: header announces " + std::to_string(facets) +
                            " facets (" + std::to_string(84 + 50 * facets) + " bytes), the file has " +
                            std::to_string(size) + " bytes",
                        where);
        }
        throw Error("not an STL file: too short for binary STL (" + std::to_string(size) +
                        " bytes) and not ASCII STL",
                    where);
    }
    // ASCII: it must end with "endsolid" (possibly followed by a name).
    const std::uint64_t tail_size = std::min<std::uint64_t>(size, 4096);
    std::string tail(tail_size, '\0');
    in.clear();
    in.seekg(static_cast<std::streamoff>(size - tail_size));
    in.read(tail.data(), static_cast<std::streamsize>(tail_size));
    std::string lower = tail;
    for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    const auto pos = lower.rfind("endsolid");
    const bool ends_properly = pos != std::string::npos && lower.find("endfacet", pos) == std::string::npos;
    if (!ends_properly) throw Error("truncated ASCII STL: no 'endsolid' at the end", where);
    return {false, 0};
}

// The facets of an STL file as corner positions, in file order. Used only to recover the
// facets OpenMesh's reader skipped (those whose corners coincide), which it never reports;
// the reading itself is OpenMesh's. Mirrors its parser: binary records of 12 floats + 2
// bytes; ASCII "outer" lines followed by three "vertex x y z" lines.
std::vector<std::array<glm::vec3, 3>> stl_facet_corners(const std::string& path, const StlKind& kind) {
    std::vector<std::array<glm::vec3, 3>> facets;
    std::ifstream in(path, std::ios::binary);
    if (kind.binary) {
        facets.reserve(kind.facets);
        in.seekg(84);
        unsigned char record[50];
        for (std::uint64_t i = 0; i < kind.facets && in.read(reinterpret_cast<char*>(record), 50); ++i) {
            std::array<glm::vec3, 3> corners;
            for (int c = 0; c < 3; ++c)
                for (int k = 0; k < 3; ++k)
                    corners[c][k] = std::bit_cast<float>(read_u32_le(record + 12 + 12 * c + 4 * k));
            facets.push_back(corners);
        }
        return facets;
    }
    std::string line;
    while (std::getline(in, line)) {
        if (line.find("outer") == std::string::npos && line.find("OUTER") == std::string::npos) continue;
        std::array<glm::vec3, 3> corners{};
        for (int c = 0; c < 3 && std::getline(in, line); ++c) {
            std::istringstream fields(line);
            std::string keyword;
            fields >> keyword >> corners[c].x >> corners[c].y >> corners[c].z;
        }
        facets.push_back(corners);
    }
    return facets;
}

// OpenMesh's STL reader merges corners that compare equal as floats (so -0 and +0 too).
struct FloatPointKey {
    std::uint32_t x, y, z;
    static std::uint32_t bits(float f) { return f == 0.0f ? 0u : std::bit_cast<std::uint32_t>(f); }
    explicit FloatPointKey(const glm::vec3& p) : x(bits(p.x)), y(bits(p.y)), z(bits(p.z)) {}
    bool operator==(const FloatPointKey&) const = default;
};
struct FloatPointHash {
    std::size_t operator()(const FloatPointKey& k) const {
        std::uint64_t h = k.x * 0x9E3779B97F4A7C15ull;
        h ^= (h >> 29) + k.y * 0xBF58476D1CE4E5B9ull;
        h ^= (h >> 31) + k.z * 0x94D049BB133111EBull;
        return static_cast<std::size_t>(h ^ (h >> 32));
    }
};

// Puts the facets OpenMesh skipped back into the face list, at their place in the file.
void recover_skipped_stl_facets(const std::string& path, const StlKind& kind, IndexedMesh& mesh) {
    const auto facets = stl_facet_corners(path, kind);
    if (facets.size() <= mesh.face_count()) return;

    std::unordered_map<FloatPointKey, std::uint32_t, FloatPointHash> vertex_of;
    vertex_of.reserve(mesh.positions.size());
    for (std::uint32_t v = 0; v < mesh.positions.size(); ++v)
        vertex_of.emplace(FloatPointKey(glm::vec3(mesh.positions[v])), v);

    // Where our view of the file and OpenMesh's part, OpenMesh's reading stands, with a note.
    const auto give_up = [&] {
        mesh.reader_notes.push_back("the STL reader skipped " + std::to_string(facets.size() - mesh.face_count()) +
                                    " facets that could not be recovered");
    };
    IndexedMesh rebuilt;
    std::vector<std::uint32_t> refused_by_old_id(mesh.face_count(), 0);
    for (std::uint32_t f : mesh.kernel_refused_faces) refused_by_old_id[f] = 1;
    std::size_t next_read = 0;
    for (const auto& corners : facets) {
        const FloatPointKey a(corners[0]), b(corners[1]), c(corners[2]);
        const bool skipped = a == b || b == c || a == c;
        const auto new_id = static_cast<std::uint32_t>(rebuilt.face_count());
        if (skipped) {
            std::uint32_t ids[3];
            for (int i = 0; i < 3; ++i) {
                const auto it = vertex_of.find(FloatPointKey(corners[i]));
                // Every corner is added as a vertex before the reader skips the facet.
                if (it == vertex_of.end()) return give_up();
                ids[i] = it->second;
            }
            rebuilt.add_face(ids);
            rebuilt.reader_skipped_faces.push_back(new_id);
        } else {
            if (next_read >= mesh.face_count()) break;
            rebuilt.add_face(mesh.face(next_read));
            if (refused_by_old_id[next_read]) rebuilt.kernel_refused_faces.push_back(new_id);
            ++next_read;
        }
    }
    if (next_read != mesh.face_count()) return give_up();
    rebuilt.positions = std::move(mesh.positions);
    rebuilt.source = mesh.source;
    rebuilt.format = mesh.format;
    rebuilt.reader_notes = std::move(mesh.reader_notes);
    mesh = std::move(rebuilt);
}

// ---------------------------------------------------------------------------------------
// What the file declares, checked against what the reader delivered. OpenMesh's ASCII PLY
// and OFF readers stop quietly at the end of a truncated file, and its PLY header parser
// never returns on a header without "end_header"; these checks turn both into errors.

struct DeclaredCounts {
    std::optional<std::uint64_t> vertices, faces;
};

std::string trim(std::string s) {
    const auto b = s.find_first_not_of(" \t\r\n");
    if (b == std::string::npos) return {};
    const auto e = s.find_last_not_of(" \t\r\n");
    return s.substr(b, e - b + 1);
}

DeclaredCounts ply_declared_counts(const std::string& path) {
    const Where where = check_detail::where_in(path);
    std::ifstream in(path, std::ios::binary);
    std::string line;
    if (!std::getline(in, line) || trim(line) != "ply") throw Error("not a PLY file: it does not start with 'ply'", where);
    DeclaredCounts counts;
    std::size_t header_bytes = line.size() + 1;
    while (std::getline(in, line)) {
        header_bytes += line.size() + 1;
        if (header_bytes > (1u << 20)) break;
        std::istringstream fields(trim(line));
        std::string keyword;
        fields >> keyword;
        if (keyword == "end_header") return counts;
        if (keyword == "element") {
            std::string name;
            std::uint64_t count = 0;
            if (!(fields >> name >> count)) throw Error("PLY header: bad element line '" + trim(line) + "'", where);
            if (name == "vertex") counts.vertices = count;
            if (name == "face") counts.faces = count;
        }
    }
    throw Error("PLY header has no 'end_header'", where);
}

DeclaredCounts off_declared_counts(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::vector<std::string> tokens;
    std::string line;
    for (int lines = 0; tokens.size() < 4 && lines < 1000 && std::getline(in, line); ++lines) {
        if (const auto hash = line.find('#'); hash != std::string::npos) {
            if (!tokens.empty() && tokens.size() < 3 && trim(line.substr(0, hash)).empty())
                throw Error("OFF header: comment lines before the counts are not supported (OpenMesh's reader misreads them)",
                            check_detail::where_in(path, lines + 1));
            line.resize(hash);
        }
        std::istringstream fields(line);
        for (std::string token; tokens.size() < 4 && fields >> token;) tokens.push_back(token);
    }
    DeclaredCounts counts;
    if (tokens.size() < 3 || tokens[0].size() < 3 || tokens[0].substr(tokens[0].size() - 3) != "OFF") return counts;
    if (tokens[1] == "BINARY") return counts;
    std::uint64_t v = 0, f = 0;
    if (std::from_chars(tokens[1].data(), tokens[1].data() + tokens[1].size(), v).ec == std::errc() &&
        std::from_chars(tokens[2].data(), tokens[2].data() + tokens[2].size(), f).ec == std::errc()) {
        counts.vertices = v;
        counts.faces = f;
    }
    return counts;
}

void check_declared_counts(const DeclaredCounts& declared, const IndexedMesh& mesh, const std::string& what) {
    const Where where = check_detail::where_in(mesh.source);
    if (declared.vertices && *declared.vertices != mesh.positions.size())
        throw Error("truncated or corrupt " + what + ": the header declares " + std::to_string(*declared.vertices) +
                        " vertices, " + std::to_string(mesh.positions.size()) + " were read",
                    where);
    if (declared.faces && *declared.faces != mesh.face_count())
        throw Error("truncated or corrupt " + what + ": the header declares " + std::to_string(*declared.faces) +
                        " faces, " + std::to_string(mesh.face_count()) + " were read",
                    where);
}

// ---------------------------------------------------------------------------------------
// OBJ: OpenMesh's reader removes repeated vertices from a face before handing it over, and
// drops the face when fewer than three remain. To report such faces as the file lists
// them, the face lines are scanned for their vertex ids (the first number of each
// v/vt/vn group, negative ids counting back from the last vertex so far) and set beside
// what OpenMesh delivered. Everything else about the file is OpenMesh's reading.

void merge_obj_faces_as_listed(const std::string& path, IndexedMesh& mesh) {
    const Where where = check_detail::where_in(path);
    std::ifstream in(path, std::ios::binary);
    IndexedMesh listed;
    std::vector<std::uint32_t> ids;
    std::int64_t vertices_so_far = 0;
    std::size_t line_number = 0;
    std::string line;
    while (std::getline(in, line)) {
        ++line_number;
        std::size_t i = line.find_first_not_of(" \t");
        if (i == std::string::npos || i + 1 >= line.size()) continue;
        const bool blank_after = line[i + 1] == ' ' || line[i + 1] == '\t';
        if (line[i] == 'v' && blank_after) {
            ++vertices_so_far;
            continue;
        }
        if (line[i] != 'f' || !blank_after) continue;
        ids.clear();
        std::istringstream tokens(line.substr(i + 2));
        for (std::string token; tokens >> token;) {
            const std::string first = token.substr(0, token.find('/'));
            std::int64_t value = 0;
            if (first.empty() ||
                std::from_chars(first.data(), first.data() + first.size(), value).ec != std::errc())
                continue;  // OpenMesh skips what is not a number
            const std::int64_t index = value < 0 ? vertices_so_far + value : value - 1;
            if (index < 0 || index >= static_cast<std::int64_t>(mesh.positions.size()))
                throw Error("face " + std::to_string(listed.face_count()) + " refers to vertex " +
                                std::to_string(value) + ", but the file has " +
                                std::to_string(mesh.positions.size()) + " vertices",
                            check_detail::where_in(path, static_cast<int>(std::min<std::size_t>(line_number, INT32_MAX))));
            ids.push_back(static_cast<std::uint32_t>(index));
        }
        listed.add_face(ids);
    }

    // Set the listed faces beside the delivered ones: equal where the listed face has no
    // repeated vertex, missing or shortened where it has.
    IndexedMesh merged;
    merged.source = mesh.source;
    merged.format = mesh.format;
    std::vector<char> refused(mesh.face_count(), 0);
    for (std::uint32_t f : mesh.kernel_refused_faces) refused[f] = 1;
    // Where our view of the file and OpenMesh's part (a construct the scan does not know),
    // OpenMesh's reading stands, with a note.
    const auto give_up = [&](std::size_t f) {
        mesh.reader_notes.push_back("OBJ face " + std::to_string(f) +
                                    ": the face lines could not be matched with OpenMesh's reading; faces its reader "
                                    "dropped or shortened (repeated vertices) are not recovered");
    };
    std::size_t next = 0;
    std::vector<std::uint32_t> sorted;
    for (std::size_t f = 0; f < listed.face_count(); ++f) {
        const auto face = listed.face(f);
        sorted.assign(face.begin(), face.end());
        std::sort(sorted.begin(), sorted.end());
        const auto unique = static_cast<std::size_t>(std::unique(sorted.begin(), sorted.end()) - sorted.begin());
        const auto id = static_cast<std::uint32_t>(merged.face_count());
        if (unique == face.size() && face.size() >= 3) {
            if (next >= mesh.face_count() || !std::ranges::equal(mesh.face(next), face)) return give_up(f);
            if (refused[next]) merged.kernel_refused_faces.push_back(id);
            ++next;
        } else {
            if (unique >= 3) ++next;  // OpenMesh delivered a shortened copy
            merged.reader_skipped_faces.push_back(id);
        }
        merged.add_face(face);
    }
    if (next != mesh.face_count()) return give_up(listed.face_count());
    merged.positions = std::move(mesh.positions);
    merged.reader_notes = std::move(mesh.reader_notes);
    mesh = std::move(merged);
}

}  // namespace

IndexedMesh read_mesh_for_check(const std::string& path) { return read_mesh_for_check(path, {}); }

IndexedMesh read_mesh_for_check(const std::string& path, const std::function<void(double)>& progress) {
    const Where where = check_detail::where_in(path);
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) throw Error("no such mesh file", where);
    if (std::filesystem::is_directory(path, ec)) throw Error("is a directory, not a mesh file", where);
    {
        std::ifstream probe(path, std::ios::binary);
        if (!probe) throw Error("cannot open mesh file", where);
    }
    const std::string ext = lowercase_extension(path);
    if (ext != "ply" && ext != "obj" && ext != "off" && ext != "stl")
        throw Error("unsupported mesh format '" + ext + "' (expected .ply, .obj, .off or .stl)", where);
    if (std::filesystem::file_size(path, ec) == 0) throw Error("empty mesh file", where);

    StlKind stl_kind;
    if (ext == "stl") stl_kind = classify_stl(path);
    DeclaredCounts ply_counts, off_counts;
    if (ext == "ply") ply_counts = ply_declared_counts(path);
    if (ext == "off") off_counts = off_declared_counts(path);

    IndexedMesh mesh;
    mesh.source = path;
    mesh.format = ext;
    OmMesh om;
    RecordingImporter importer(om, mesh);
    std::uint64_t expected = 0;
    // Binary STL: its facets, and about half as many distinct corners (a closed surface).
    if (ext == "stl" && stl_kind.binary) expected = stl_kind.facets + stl_kind.facets / 2;
    for (const DeclaredCounts* counts : {&ply_counts, &off_counts})
        if (counts->vertices && counts->faces) expected = *counts->vertices + *counts->faces;
    if (progress) importer.set_progress(expected, &progress);
    OpenMesh::IO::Options options;
    bool ok = false;
    std::string reader_message;
    {
        CapturedOpenMeshLog log;
        importer.set_face_limit(std::filesystem::file_size(path) + 16);
        try {
            ok = OpenMesh::IO::IOManager().read(path, importer, options);
        } catch (const RecordingImporter::FaceLimit&) {
            throw Error("the " + ext + " reader ran past the end of the data (a corrupt or unsupported header?)", where);
        }
        reader_message = log.first_line();
    }
    if (!ok) {
        std::string what = "cannot read mesh file as " + ext;
        if (!reader_message.empty()) what += ": OpenMesh says '" + reader_message + "'";
        throw Error(what, where);
    }
    if (importer.bad_face()) {
        const auto& bad = *importer.bad_face();
        throw Error("face " + std::to_string(bad.face_id) + " refers to vertex " +
                        std::to_string(bad.vertex) + ", but the file has " +
                        std::to_string(importer.recorded_vertices()) + " vertices",
                    where);
    }
    if (mesh.face_count() == 0 && mesh.positions.empty())
        throw Error("no vertices and no faces could be read" +
                        (reader_message.empty() ? std::string() : " (OpenMesh says '" + reader_message + "')"),
                    where);
    if (ext == "ply") check_declared_counts(ply_counts, mesh, "PLY file");
    if (ext == "off") check_declared_counts(off_counts, mesh, "OFF file");
    if (ext == "stl") recover_skipped_stl_facets(path, stl_kind, mesh);
    if (ext == "obj") merge_obj_faces_as_listed(path, mesh);
    if (mesh.face_count() == 0) throw Error("no faces: a point cloud, not a mesh", where);
    return mesh;
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
