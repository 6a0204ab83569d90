// Export of a SurfaceMesh: validation, bitwise welding, and the OpenMesh writers.
// See include/tessref/mesh.h for the contract (what is welded, what each format carries).
#include "tessref/mesh.h"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <filesystem>
#include <limits>
#include <mutex>
#include <ostream>
#include <thread>
#include <utility>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include "common/huge_pages.h"
#include "common/parallel.h"
#include "common/stream_failure.h"
#include "mesh/openmesh.h"
#include "tessref/error.h"

namespace tessref {

namespace {

}  // namespace

// ---------------------------------------------------------------------------------------
// Formats

std::string_view to_string(MeshFormat format) {
    switch (format) {
        case MeshFormat::ply: return "ply";
        case MeshFormat::obj: return "obj";
        case MeshFormat::off: return "off";
        case MeshFormat::stl: return "stl";
    }
    return "?";
}

std::optional<MeshFormat> parse_mesh_format(std::string_view name) {
    std::string lower(name);
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    for (MeshFormat format : {MeshFormat::ply, MeshFormat::obj, MeshFormat::off, MeshFormat::stl}) {
        if (lower == to_string(format)) return format;
    }
    return std::nullopt;
}

MeshFormat mesh_format_from_path(const std::string& path) {
    std::string extension = std::filesystem::path(path).extension().string();
    if (!extension.empty() && extension.front() == '.') extension.erase(0, 1);
    if (const std::optional<MeshFormat> format = parse_mesh_format(extension)) return *format;
    const std::string what =
        extension.empty() ? "output file has no extension; expected .ply, .obj, .off or .stl"
                          : "unknown mesh format '." + extension +
                                "'; expected .ply, .obj, .off or .stl";
    throw Error(what, Where::in_file(path));
}

bool mesh_format_has_binary(MeshFormat format) { return format != MeshFormat::obj; }

// ---------------------------------------------------------------------------------------
// Checks

void validate(const SurfaceMesh& mesh) {
    const std::size_t n = mesh.positions.size();
    const auto check_size = [n](std::size_t size, const char* name) {
        if (size != 0 && size != n) {
            throw Error("surface mesh has " + std::to_string(size) + " " + name + " for " +
                            std::to_string(n) + " vertices",
                        Where::at_key(name));
        }
    };
    check_size(mesh.normals.size(), "normals");
    check_size(mesh.uvs.size(), "uvs");
    check_size(mesh.patch_ids.size(), "patch_ids");
    check_size(mesh.tess_coords.size(), "tess_coords");
    if (n > std::numeric_limits<std::uint32_t>::max()) {
        throw Error("surface mesh has more vertices than 32-bit indices can name");
    }
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        for (const std::uint32_t index : mesh.triangles[t]) {
            if (index >= n) {
                Where where = Where::at_key("triangles[" + std::to_string(t) + "]");
                const std::uint32_t first = mesh.triangles[t][0];
                if (first < mesh.patch_ids.size()) where.patch_id = mesh.patch_ids[first];
                throw Error("triangle names vertex " + std::to_string(index) + " of " +
                                std::to_string(n),
                            where);
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Welding

namespace {

// The bit pattern of a position, the sign of a zero dropped (+0.0 + 0.0 == +0.0, and
// -0.0 + 0.0 == +0.0, every other value is unchanged, NaN payloads included).
struct PositionKey {
    std::uint64_t x, y, z;
    bool operator==(const PositionKey&) const = default;
};

std::uint64_t coordinate_bits(double c) {
    if (c == 0.0) c = 0.0;  // -0.0 -> +0.0
    return std::bit_cast<std::uint64_t>(c);
}

PositionKey position_key(const glm::dvec3& p) {
    return {coordinate_bits(p.x), coordinate_bits(p.y), coordinate_bits(p.z)};
}

// splitmix64's finalizer: every input bit reaches every output bit, so grid-like
// coordinates (which differ only in a few mantissa bits) spread over the buckets.
std::uint64_t mix64(std::uint64_t h) {
    h ^= h >> 30;
    h *= 0xbf58476d1ce4e5b9ULL;
    h ^= h >> 27;
    h *= 0x94d049bb133111ebULL;
    h ^= h >> 31;
    return h;
}

struct PositionKeyHash {
    std::size_t operator()(const PositionKey& k) const {
        return static_cast<std::size_t>(mix64(k.x ^ mix64(k.y ^ mix64(k.z))));
    }
};

}  // namespace

namespace {

// Welded vertex ids by position. Open addressing, linear probing, at most half full: a slot
// holds a welded vertex id in its low 32 bits and the high 32 bits of its key's hash above
// them (all ones: empty; no id is 2^32 - 1), so that a probe passing another vertex's slot
// rarely reads that vertex's position. Several times faster than std::unordered_map here,
// which allocates a node per vertex; callers prefetch the slot of a vertex a few ahead, the
// table being far larger than the caches. The positions themselves stay with the caller:
// `position_of(id)` gives a stored vertex's.
class PositionTable {
public:
    // Sized for `expected` vertices; it doubles (rehashing) whenever it would be more than
    // half full.
    explicit PositionTable(std::size_t expected) {
        std::size_t capacity = 16;
        while (capacity < 2 * expected) capacity *= 2;
        slots_.reserve(capacity);
        advise_huge_pages(slots_);
        slots_.assign(capacity, kEmpty);
    }

    // Emptied, and sized for `expected` vertices (never shrunk).
    void clear(std::size_t expected) {
        std::size_t capacity = slots_.size();
        while (capacity < 2 * expected) capacity *= 2;
        slots_.assign(capacity, kEmpty);
        size_ = 0;
    }

    static constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

    // The id stored for position `p` (whose hash is `hash`), or kNone.
    template <typename PositionOf>
    std::uint32_t find(const glm::dvec3& p, std::uint64_t hash, const PositionOf& position_of) const {
        const PositionKey key = position_key(p);
        const std::uint64_t tag = hash >> 32;
        for (std::size_t slot = hash & mask(); slots_[slot] != kEmpty; slot = (slot + 1) & mask()) {
            const std::uint64_t s = slots_[slot];
            if ((s >> 32) == tag && position_key(position_of(static_cast<std::uint32_t>(s))) == key)
                return static_cast<std::uint32_t>(s);
        }
        return kNone;
    }

    static std::uint64_t hash(const glm::dvec3& p) {
        return static_cast<std::uint64_t>(PositionKeyHash{}(position_key(p)));
    }
    void prefetch(std::uint64_t hash) const { __builtin_prefetch(&slots_[hash & mask()]); }

    // The id stored for position `p` (whose hash is `hash`); when there is none, `id` is
    // stored for it and returned. `position_of` maps a stored id to its position.
    template <typename PositionOf>
    std::uint32_t find_or_insert(const glm::dvec3& p, std::uint64_t hash, std::uint32_t id,
                                 const PositionOf& position_of) {
        // Grown first, so that `position_of` need only know the ids stored so far.
        if (2 * (size_ + 1) > slots_.size()) grow(position_of);
        const PositionKey key = position_key(p);
        const std::uint64_t tag = hash >> 32;
        std::size_t slot = hash & mask();
        while (slots_[slot] != kEmpty) {
            const std::uint64_t s = slots_[slot];
            if ((s >> 32) == tag && position_key(position_of(static_cast<std::uint32_t>(s))) == key)
                return static_cast<std::uint32_t>(s);
            slot = (slot + 1) & mask();
        }
        slots_[slot] = tag << 32 | id;
        ++size_;
        return id;
    }

private:
    static constexpr std::uint64_t kEmpty = std::numeric_limits<std::uint64_t>::max();
    std::size_t mask() const { return slots_.size() - 1; }

    template <typename PositionOf>
    void grow(const PositionOf& position_of) {
        std::vector<std::uint64_t> old;
        old.reserve(2 * slots_.size());
        advise_huge_pages(old);
        old.assign(2 * slots_.size(), kEmpty);
        old.swap(slots_);
        for (const std::uint64_t s : old) {
            if (s == kEmpty) continue;
            std::size_t slot = hash(position_of(static_cast<std::uint32_t>(s))) & mask();
            while (slots_[slot] != kEmpty) slot = (slot + 1) & mask();
            slots_[slot] = s;
        }
    }

    std::vector<std::uint64_t> slots_;
    std::size_t size_ = 0;
};

// How far ahead of the vertex being welded its table slot is prefetched.
constexpr std::size_t kPrefetchAhead = 8;

// Appends `triangles` (corners mapped by `vertex_map`) to `out`, leaving out those whose
// corners weld into fewer than three vertices; returns how many it left out.
std::size_t append_welded_triangles(const std::vector<std::array<std::uint32_t, 3>>& triangles,
                                    const std::vector<std::uint32_t>& vertex_map,
                                    std::vector<std::array<std::uint32_t, 3>>& out) {
    std::size_t degenerate = 0;
    for (const auto& triangle : triangles) {
        const std::array<std::uint32_t, 3> welded{vertex_map[triangle[0]], vertex_map[triangle[1]],
                                                  vertex_map[triangle[2]]};
        if (welded[0] == welded[1] || welded[1] == welded[2] || welded[2] == welded[0]) {
            ++degenerate;
            continue;
        }
        out.push_back(welded);
    }
    return degenerate;
}

}  // namespace

struct SurfaceWelder::Impl {
    explicit Impl(std::size_t expected_vertices) : table(expected_vertices) {}
    PositionTable table;
    WeldedMesh welded;
    std::vector<std::uint32_t> piece_map;  // the current piece's vertex -> welded vertex
    std::vector<std::uint64_t> hashes;     // the current piece's positions' hashes
    // The current piece's welded vertices' source copies: source[k] for the piece's k-th new
    // welded vertex, replaced for older ones that a copy of this piece takes over.
    std::vector<std::uint32_t> source;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> replaced;  // (welded vertex, copy)
    bool shaped = false;                   // a piece with vertices has set which attributes there are
};

SurfaceWelder::SurfaceWelder(std::size_t expected_vertices, std::size_t expected_triangles)
    : impl_(std::make_unique<Impl>(expected_vertices)) {
    // Reserved, not touched: only the pages the welded mesh fills are ever resident, and
    // no append copies what is already there.
    SurfaceMesh& out = impl_->welded.mesh;
    out.positions.reserve(expected_vertices);
    out.triangles.reserve(expected_triangles);
    advise_huge_pages(out.positions);
    advise_huge_pages(out.triangles);
}
SurfaceWelder::~SurfaceWelder() = default;
SurfaceWelder::SurfaceWelder(SurfaceWelder&&) noexcept = default;
SurfaceWelder& SurfaceWelder::operator=(SurfaceWelder&&) noexcept = default;

void SurfaceWelder::add(const SurfaceMesh& piece, std::vector<std::uint32_t>* vertex_map) {
    validate(piece);
    const std::size_t n = piece.positions.size();
    if (n == 0) return;  // then it has no triangles either (validated)
    Impl& s = *impl_;
    SurfaceMesh& out = s.welded.mesh;
    if (!s.shaped) {
        // The first piece with vertices decides which attributes the welded mesh has.
        const std::size_t capacity = out.positions.capacity();
        const auto reserve = [capacity](auto& attribute, bool present) {
            if (!present) return;
            attribute.reserve(capacity);
            advise_huge_pages(attribute);
        };
        reserve(out.normals, !piece.normals.empty());
        reserve(out.uvs, !piece.uvs.empty());
        reserve(out.patch_ids, !piece.patch_ids.empty());
        reserve(out.tess_coords, !piece.tess_coords.empty());
        s.shaped = true;
    } else {
        const auto check = [&](bool piece_has, bool welded_has, const char* name) {
            if (piece_has != welded_has)
                throw Error(std::string("surface piece ") + (piece_has ? "has " : "lacks ") + name +
                                " unlike the pieces before it",
                            Where::at_key(name));
        };
        check(!piece.normals.empty(), !out.normals.empty(), "normals");
        check(!piece.uvs.empty(), !out.uvs.empty(), "uvs");
        check(!piece.patch_ids.empty(), !out.patch_ids.empty(), "patch_ids");
        check(!piece.tess_coords.empty(), !out.tess_coords.empty(), "tess_coords");
    }
    if (s.welded.emitted_vertices + n > std::numeric_limits<std::uint32_t>::max())
        throw Error("surface mesh has more vertices than 32-bit indices can name");

    const bool normals = !piece.normals.empty(), uvs = !piece.uvs.empty();
    const bool patch_ids = !piece.patch_ids.empty(), tess_coords = !piece.tess_coords.empty();
    const auto position_of = [&out](std::uint32_t welded) -> const glm::dvec3& { return out.positions[welded]; };
    const std::size_t base = out.positions.size();  // the welded vertices of the pieces before
    s.piece_map.resize(n);
    // Every hash first, in one pass over the positions: each is computed once, and the
    // slots can be prefetched as far ahead as wanted.
    s.hashes.resize(n);
    for (std::size_t i = 0; i < n; ++i) s.hashes[i] = PositionTable::hash(piece.positions[i]);
    // The decisions, in emission order: which welded vertex each copy is, and which copy each
    // welded vertex takes ALL its attributes from, the one with the lowest patch id, then the
    // earliest (an earlier piece's copy is an earlier one). Only what the decisions read is
    // written here: the positions (the table's keys; any copy's will do, they compare equal)
    // and the patch ids. The other attributes are copied afterwards, in parallel.
    s.source.clear();
    s.replaced.clear();
    for (std::size_t i = 0; i < n; ++i) {
        if (i + kPrefetchAhead < n) s.table.prefetch(s.hashes[i + kPrefetchAhead]);
        const auto next = static_cast<std::uint32_t>(out.positions.size());
        const std::uint32_t welded = s.table.find_or_insert(piece.positions[i], s.hashes[i], next, position_of);
        const auto copy = static_cast<std::uint32_t>(i);
        if (welded == next) {
            out.positions.push_back(piece.positions[i]);
            if (patch_ids) out.patch_ids.push_back(piece.patch_ids[i]);
            s.source.push_back(copy);
        } else if (patch_ids && piece.patch_ids[i] < out.patch_ids[welded]) {
            out.patch_ids[welded] = piece.patch_ids[i];
            if (welded >= base) s.source[welded - base] = copy;
            else s.replaced.emplace_back(welded, copy);
        }
        s.piece_map[i] = welded;
    }
    // Every attribute from the chosen copy (the position too: the sign of its zeros).
    const auto take_copy = [&](std::size_t welded, std::size_t i) {
        out.positions[welded] = piece.positions[i];
        if (normals) out.normals[welded] = piece.normals[i];
        if (uvs) out.uvs[welded] = piece.uvs[i];
        if (tess_coords) out.tess_coords[welded] = piece.tess_coords[i];
    };
    const std::size_t welded_count = out.positions.size();
    if (normals) out.normals.resize(welded_count);
    if (uvs) out.uvs.resize(welded_count);
    if (tess_coords) out.tess_coords.resize(welded_count);
    tessref::parallel_for(tbb::blocked_range<std::size_t>(base, welded_count, 4096), [&](const auto& r) {
        for (std::size_t v = r.begin(); v < r.end(); ++v) take_copy(v, s.source[v - base]);
    });
    // In order: a later entry for the same vertex has a lower patch id.
    for (const auto& [welded, i] : s.replaced) take_copy(welded, i);
    s.welded.emitted_vertices += n;
    s.welded.degenerate_triangles += append_welded_triangles(piece.triangles, s.piece_map, out.triangles);
    if (vertex_map) vertex_map->swap(s.piece_map);  // the next piece resizes its own
}

WeldedMesh SurfaceWelder::take() {
    WeldedMesh result = std::move(impl_->welded);
    impl_->welded = {};
    return result;
}

WeldedMesh weld_bitwise(const SurfaceMesh& mesh) {
    SurfaceWelder welder(mesh.positions.size(), mesh.triangles.size());
    std::vector<std::uint32_t> vertex_map;
    welder.add(mesh, &vertex_map);
    WeldedMesh result = welder.take();
    result.vertex_map = std::move(vertex_map);
    return result;
}

// ---------------------------------------------------------------------------------------
// Writing

namespace {

// Every OpenMesh writer stores 32-bit floats (see mesh.h), so the kernel holds floats:
// converting here or inside the writer gives the same (round-to-nearest) values.
using ExportMesh = OpenMesh::TriMesh_ArrayKernelT<OpenMesh::DefaultTraits>;

// OpenMesh's writers read a mesh through its exporter interface (IO::BaseExporter). This
// exporter serves the vertices (and their properties) from an OpenMesh kernel that holds
// vertices only, and the triangles straight from our list, so the half-edge structure is
// never built: a triangle list that a half-edge mesh cannot hold (a non-manifold edge or
// vertex) is written as it is, and the export skips the costliest step (connecting faces).
class TriangleListExporter : public OpenMesh::IO::ExporterT<ExportMesh> {
public:
    TriangleListExporter(const ExportMesh& vertices, const std::vector<std::array<std::uint32_t, 3>>& triangles)
        : OpenMesh::IO::ExporterT<ExportMesh>(vertices), triangles_(triangles) {}

    unsigned int get_vhandles(OpenMesh::FaceHandle face,
                              std::vector<OpenMesh::VertexHandle>& corners) const override {
        const auto& triangle = triangles_[static_cast<std::size_t>(face.idx())];
        corners.assign({OpenMesh::VertexHandle(static_cast<int>(triangle[0])),
                        OpenMesh::VertexHandle(static_cast<int>(triangle[1])),
                        OpenMesh::VertexHandle(static_cast<int>(triangle[2]))});
        return 3;
    }
    std::size_t n_faces() const override { return triangles_.size(); }
    std::size_t n_edges() const override { return 0; }  // no writer of ours reads it
    bool is_triangle_mesh() const override { return true; }
    // Per-corner texture coordinates live on half-edges, which do not exist here; only
    // vertex texture coordinates are written (Options::FaceTexCoord is never set).
    unsigned int get_face_texcoords(std::vector<OpenMesh::Vec2f>& texcoords) const override {
        texcoords.clear();
        return 0;
    }
    OpenMesh::HalfedgeHandle getHeh(OpenMesh::FaceHandle, OpenMesh::VertexHandle) const override {
        return OpenMesh::HalfedgeHandle();
    }

private:
    const std::vector<std::array<std::uint32_t, 3>>& triangles_;
};

OpenMesh::Vec3f to_float(const glm::dvec3& v) {
    return {static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z)};
}

std::string number(double x) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.9g", x);
    return buffer;
}


// The file stores floats: a position beyond the float range would be written as inf, and
// a non-finite one as inf or nan. Neither is geometry; the export stops, naming the vertex.
void require_finite_floats(const SurfaceMesh& mesh) {
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
        const glm::dvec3& p = mesh.positions[v];
        const OpenMesh::Vec3f f = to_float(p);
        if (std::isfinite(f[0]) && std::isfinite(f[1]) && std::isfinite(f[2])) continue;
        const bool finite = std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
        std::string what = "vertex (" + number(p.x) + ", " + number(p.y) + ", " + number(p.z) + ")";
        if (!mesh.tess_coords.empty()) {
            const glm::vec3 tc = mesh.tess_coords[v];
            what += " at tess coord (" + number(tc.x) + ", " + number(tc.y) + ", " + number(tc.z) + ")";
        }
        what += finite ? " is beyond the 32-bit float range (largest " +
                             number(std::numeric_limits<float>::max()) + ") that mesh files store"
                       : " is not finite";
        throw Error(what, mesh.patch_ids.empty() ? Where{} : Where::at_patch(mesh.patch_ids[v]));
    }
}

// What storing positions as float loses of a double computation: distinct vertices that
// round to one float point, and triangles with area whose float corners have none.
// Nothing when every position is already a float (gpu precision).
void measure_float_storage(const SurfaceMesh& mesh, MeshWriteReport& report) {
    const std::size_t n = mesh.positions.size();
    double largest = 0.0;
    bool all_floats = true;
    for (std::size_t v = 0; v < n; ++v) {
        const glm::dvec3& p = mesh.positions[v];
        for (int c = 0; c < 3; ++c) {
            largest = std::max(largest, std::abs(p[c]));
            all_floats = all_floats && static_cast<double>(static_cast<float>(p[c])) == p[c];
        }
    }
    const float largest_f = static_cast<float>(largest);
    report.largest_coordinate = largest;
    report.float_spacing = static_cast<double>(std::nextafter(largest_f, std::numeric_limits<float>::infinity())) -
                           static_cast<double>(largest_f);
    report.float_distinct_vertices = n;
    if (all_floats) return;

    const auto stored = [&mesh](std::uint32_t v) { return glm::dvec3(glm::vec3(mesh.positions[v])); };
    std::vector<std::array<std::uint32_t, 3>> keys(n);
    for (std::uint32_t v = 0; v < keys.size(); ++v) {
        const glm::vec3 f(mesh.positions[v]);
        for (int c = 0; c < 3; ++c) keys[v][c] = std::bit_cast<std::uint32_t>(f[c] == 0.0f ? 0.0f : f[c]);
    }
    std::sort(keys.begin(), keys.end());
    report.float_distinct_vertices =
        static_cast<std::size_t>(std::unique(keys.begin(), keys.end()) - keys.begin());

    // A zero area is seen exactly: differences of floats are exact in double (short of a
    // 2^29 spread in magnitude), and products that are equal round alike.
    const auto zero_area = [](const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
        return glm::cross(b - a, c - a) == glm::dvec3(0.0);
    };
    for (const auto& t : mesh.triangles) {
        if (zero_area(stored(t[0]), stored(t[1]), stored(t[2])) &&
            !zero_area(mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]))
            ++report.float_degenerate_triangles;
    }
}

// What a file carries of the mesh (see mesh.h).
struct WrittenAttributes {
    bool normals = false, uvs = false, patch_ids = false, tess_coords = false;
};

using Progress = std::function<void(std::string_view, double)>;

// Through OpenMesh's writer (every format; PLY's reference): the vertices copied into an
// OpenMesh kernel, the triangles served from the list.
void write_through_openmesh(const SurfaceMesh& mesh, const WrittenAttributes& written, const MeshWriteOptions& options,
                            std::ostream& out, const Progress& progress) {
    const MeshFormat format = options.format;
    const std::size_t n = mesh.positions.size();
    ExportMesh om;
    om.reserve(n, 0, 0);
    if (written.normals) om.request_vertex_normals();
    if (written.uvs) om.request_vertex_texcoords2D();
    // PLY extra properties: OpenMesh's PLY writer emits every persistent vertex property
    // of a supported scalar type under its own name, in the order they were added.
    OpenMesh::VPropHandleT<int> patch_id_property;
    OpenMesh::VPropHandleT<float> tess_u_property, tess_v_property, tess_w_property;
    if (written.patch_ids) {
        om.add_property(patch_id_property, "patch_id");
        om.property(patch_id_property).set_persistent(true);
    }
    if (written.tess_coords) {
        om.add_property(tess_u_property, "tess_u");
        om.add_property(tess_v_property, "tess_v");
        om.add_property(tess_w_property, "tess_w");
        om.property(tess_u_property).set_persistent(true);
        om.property(tess_v_property).set_persistent(true);
        om.property(tess_w_property).set_persistent(true);
    }

    constexpr std::size_t progress_step = std::size_t{1} << 16;
    for (std::size_t v = 0; v < n; ++v) {
        if (v % progress_step == 0) progress("collecting", static_cast<double>(v) / static_cast<double>(n));
        const ExportMesh::VertexHandle vh = om.add_vertex(to_float(mesh.positions[v]));
        if (written.normals) om.set_normal(vh, to_float(mesh.normals[v]));
        if (written.uvs) {
            om.set_texcoord2D(vh, ExportMesh::TexCoord2D(static_cast<float>(mesh.uvs[v].x),
                                                         static_cast<float>(mesh.uvs[v].y)));
        }
        if (written.patch_ids) {
            // PLY's `int`: patch ids beyond 2^31 - 1 would need more patches than any
            // triangle budget allows.
            om.property(patch_id_property, vh) = static_cast<int>(mesh.patch_ids[v]);
        }
        if (written.tess_coords) {
            om.property(tess_u_property, vh) = mesh.tess_coords[v].x;
            om.property(tess_v_property, vh) = mesh.tess_coords[v].y;
            om.property(tess_w_property, vh) = mesh.tess_coords[v].z;
        }
    }
    progress("collecting", 1.0);

    OpenMesh::IO::Options io_options;
    if (options.binary) {
        io_options += OpenMesh::IO::Options::Binary;
        if (format == MeshFormat::ply) io_options += OpenMesh::IO::Options::LSB;
    }
    if (written.normals) io_options += OpenMesh::IO::Options::VertexNormal;
    if (written.uvs) io_options += OpenMesh::IO::Options::VertexTexCoord;
    if (written.patch_ids || written.tess_coords) io_options += OpenMesh::IO::Options::Custom;

    bool ok = false;
    progress("writing", 0.0);
    {
        // OpenMesh's writers chat about every file they write.
        const mesh_detail::QuietStream quiet_log(::omlog());
        const mesh_detail::QuietStream quiet_out(::omout());
        TriangleListExporter exporter(om, mesh.triangles);
        ok = OpenMesh::IO::IOManager().write(out, "." + std::string(to_string(format)), exporter, io_options,
                                             options.ascii_digits);
    }
    out.flush();
    if (!ok) throw Error("OpenMesh could not write the mesh as " + std::string(to_string(format)));
}

// Little-endian 32-bit values (PLY's binary_little_endian), whatever the machine's order.
char* store_le32(char* p, std::uint32_t bits) {
    if constexpr (std::endian::native == std::endian::big) {
        bits = (bits >> 24) | ((bits >> 8) & 0xff00u) | ((bits << 8) & 0xff0000u) | (bits << 24);
    }
    std::memcpy(p, &bits, 4);
    return p + 4;
}
char* store_le(char* p, float value) { return store_le32(p, std::bit_cast<std::uint32_t>(value)); }
char* store_le(char* p, std::int32_t value) { return store_le32(p, static_cast<std::uint32_t>(value)); }

// ASCII numbers as OpenMesh's PLY writer prints them (operator<< of a float at the
// stream's precision, i.e. printf's %.<digits>g of the float's value; std::to_chars in
// general format with a precision is specified to print exactly that).
char* print(char* p, float value, int digits) {
    return std::to_chars(p, p + 64, static_cast<double>(value), std::chars_format::general, digits).ptr;
}
char* print(char* p, std::int64_t value) { return std::to_chars(p, p + 32, value).ptr; }

// write_ply's records: at most kRecordLimit bytes each (13 numbers of at most 25 characters),
// formatted kBlockRecords to a task, kBlocksAtOnce tasks at a time (a few MiB held).
constexpr std::size_t kRecordLimit = 1024;
constexpr std::size_t kBlockRecords = std::size_t{1} << 13;
constexpr std::size_t kBlocksAtOnce = 8;

// PLY's header and records, byte for byte what OpenMesh 9's PLY writer writes for the same
// mesh, options and properties (tests/test_mesh.cpp compares the two on every attribute
// combination, ascii and binary): write_ply() writes a welded mesh with them, and
// StreamedPlyWriter a surface as it arrives.
struct PlyRecords {
    WrittenAttributes written;
    bool binary = false;
    int digits = 9;

    std::string header(std::size_t vertices, std::size_t triangles) const {
        std::string header = "ply\n";
        header += binary ? "format binary_little_endian 1.0\n" : "format ascii 1.0\n";
        header += "element vertex " + std::to_string(vertices) + "\n";
        header += "property float x\nproperty float y\nproperty float z\n";
        if (written.normals) header += "property float nx\nproperty float ny\nproperty float nz\n";
        if (written.uvs) header += "property float u\nproperty float v\n";
        if (written.patch_ids) header += "property int patch_id\n";
        if (written.tess_coords) header += "property float tess_u\nproperty float tess_v\nproperty float tess_w\n";
        header += "element face " + std::to_string(triangles) + "\n";
        header += "property list uchar int vertex_indices\n";
        header += "end_header\n";
        return header;
    }

    // Vertex v of `mesh` at q; returns the record's end. At most kRecordLimit bytes.
    char* vertex(const SurfaceMesh& mesh, std::size_t v, char* q) const {
        float values[8];
        int count = 0;
        const glm::dvec3& p = mesh.positions[v];
        values[count++] = static_cast<float>(p.x);
        values[count++] = static_cast<float>(p.y);
        values[count++] = static_cast<float>(p.z);
        if (written.normals) {
            const glm::dvec3& normal = mesh.normals[v];
            values[count++] = static_cast<float>(normal.x);
            values[count++] = static_cast<float>(normal.y);
            values[count++] = static_cast<float>(normal.z);
        }
        if (written.uvs) {
            values[count++] = static_cast<float>(mesh.uvs[v].x);
            values[count++] = static_cast<float>(mesh.uvs[v].y);
        }
        // PLY's `int` (see write_through_openmesh).
        const std::int32_t patch_id = written.patch_ids ? static_cast<std::int32_t>(mesh.patch_ids[v]) : 0;
        const glm::vec3 tess = written.tess_coords ? mesh.tess_coords[v] : glm::vec3(0.0f);
        if (binary) {
            for (int i = 0; i < count; ++i) q = store_le(q, values[i]);
            if (written.patch_ids) q = store_le(q, patch_id);
            if (written.tess_coords) {
                q = store_le(q, tess.x);
                q = store_le(q, tess.y);
                q = store_le(q, tess.z);
            }
        } else {
            for (int i = 0; i < count; ++i) {
                if (i > 0) *q++ = ' ';
                q = print(q, values[i], digits);
            }
            if (written.patch_ids) {
                *q++ = ' ';
                q = print(q, patch_id);
            }
            if (written.tess_coords) {
                for (const float t : {tess.x, tess.y, tess.z}) {
                    *q++ = ' ';
                    q = print(q, t, digits);
                }
            }
            *q++ = '\n';
        }
        return q;
    }

    char* triangle(const std::array<std::uint32_t, 3>& triangle, char* q) const {
        if (binary) {
            *q++ = 3;
            for (const std::uint32_t index : triangle) q = store_le(q, static_cast<std::int32_t>(index));
        } else {
            *q++ = '3';
            for (const std::uint32_t index : triangle) {
                *q++ = ' ';
                q = print(q, static_cast<std::int64_t>(index));
            }
            *q++ = '\n';
        }
        return q;
    }
};

// A buffer of formatted records, grown so that a record always fits.
struct RecordBlock {
    std::vector<char> bytes;
    std::size_t used = 0;
    char* reserve_record() {
        if (bytes.size() - used < kRecordLimit) bytes.resize(std::max(2 * bytes.size(), std::size_t{1} << 16));
        return bytes.data() + used;
    }
    void end_record(char* end) { used = static_cast<std::size_t>(end - bytes.data()); }
};

// Writes rounds of record blocks to a stream, in order, on a thread of its own, so that
// the kernel's copying of a large file into its pages (a third of a streamed export's CPU
// time, on the thread that also welds) runs beside the welding and formatting of what
// comes next. At most two rounds wait (a few MiB); a round's blocks come back, their
// capacity kept, for a later round. Only this thread touches the stream between the
// first write() and drain().
class BackgroundWriter {
public:
    explicit BackgroundWriter(std::ostream& out) : out_(out), thread_([this] { run(); }) {}
    ~BackgroundWriter() {  // what is still queued is dropped (an error on the way out)
        {
            const std::lock_guard<std::mutex> lock(mutex_);
            stop_ = true;
        }
        changed_.notify_all();
        thread_.join();
    }
    BackgroundWriter(const BackgroundWriter&) = delete;
    BackgroundWriter& operator=(const BackgroundWriter&) = delete;

    // Queues the first `count` blocks of `blocks` and hands back blocks to fill next (at
    // least `count` of them); throws the Error of a write that failed before.
    std::vector<RecordBlock> write(std::vector<RecordBlock> blocks, std::size_t count) {
        std::unique_lock<std::mutex> lock(mutex_);
        changed_.wait(lock, [&] { return queue_.size() < 2 || !error_.empty(); });
        if (!error_.empty()) throw Error("cannot write the mesh: " + error_);
        queue_.push_back({std::move(blocks), count});
        std::vector<RecordBlock> next;
        if (!spare_.empty()) {
            next = std::move(spare_.back());
            spare_.pop_back();
        }
        lock.unlock();
        changed_.notify_all();
        if (next.size() < count) next.resize(count);
        return next;
    }

    // Waits until every queued block is written; throws the Error of a write that failed.
    void drain() {
        std::unique_lock<std::mutex> lock(mutex_);
        changed_.wait(lock, [&] { return (queue_.empty() && !writing_) || !error_.empty(); });
        if (!error_.empty()) throw Error("cannot write the mesh: " + error_);
    }

private:
    struct Round {
        std::vector<RecordBlock> blocks;
        std::size_t count = 0;
    };

    void run() {
        std::unique_lock<std::mutex> lock(mutex_);
        for (;;) {
            changed_.wait(lock, [&] { return stop_ || !queue_.empty(); });
            if (stop_) return;
            Round round = std::move(queue_.front());
            queue_.pop_front();
            writing_ = true;
            lock.unlock();
            std::string failure;
            for (std::size_t k = 0; k < round.count && failure.empty(); ++k) {
                out_.write(round.blocks[k].bytes.data(), static_cast<std::streamsize>(round.blocks[k].used));
                if (!out_) failure = stream_failure();
            }
            lock.lock();
            writing_ = false;
            if (!failure.empty()) error_ = failure;
            spare_.push_back(std::move(round.blocks));
            changed_.notify_all();
            if (!error_.empty()) return;
        }
    }

    std::ostream& out_;
    std::mutex mutex_;
    std::condition_variable changed_;
    std::deque<Round> queue_;
    std::vector<std::vector<RecordBlock>> spare_;
    bool writing_ = false, stop_ = false;
    std::string error_;
    std::thread thread_;  // last: started once the members above exist
};

void write_ply(const SurfaceMesh& mesh, const WrittenAttributes& written, const MeshWriteOptions& options,
               std::ostream& out, const Progress& progress) {
    const std::size_t n = mesh.positions.size();
    const std::vector<std::array<std::uint32_t, 3>>& triangles = mesh.triangles;
    const PlyRecords records_of{written, options.binary, options.ascii_digits};
    const std::string header = records_of.header(n, triangles.size());
    progress("writing", 0.0);
    out.write(header.data(), static_cast<std::streamsize>(header.size()));

    // Records n + t are triangle t. Blocks of them are formatted in parallel, a round of
    // blocks at a time, and written in order: the bytes a serial loop would write, in a
    // fraction of the time for ASCII, whose number printing is most of the export.
    const std::size_t records = n + triangles.size();
    std::vector<RecordBlock> blocks(kBlocksAtOnce);
    const std::size_t progress_step = std::max<std::size_t>(1, records / 128);  // a few hundred calls at most (mesh.h)
    std::size_t next_progress = 0;
    for (std::size_t first = 0; first < records; first += kBlocksAtOnce * kBlockRecords) {
        if (first >= next_progress) {
            progress("writing", static_cast<double>(first) / static_cast<double>(records));
            next_progress = first + progress_step;
        }
        const std::size_t round = std::min(kBlocksAtOnce, (records - first + kBlockRecords - 1) / kBlockRecords);
        tessref::parallel_for(std::size_t{0}, round, [&](std::size_t k) {
            RecordBlock& block = blocks[k];
            block.used = 0;
            const std::size_t begin = first + k * kBlockRecords, end = std::min(records, begin + kBlockRecords);
            for (std::size_t r = begin; r < end; ++r) {
                char* q = block.reserve_record();
                block.end_record(r < n ? records_of.vertex(mesh, r, q) : records_of.triangle(triangles[r - n], q));
            }
        });
        for (std::size_t k = 0; k < round && out; ++k)
            out.write(blocks[k].bytes.data(), static_cast<std::streamsize>(blocks[k].used));
    }
    out.flush();
}

}  // namespace

std::string MeshWriteReport::precision_warning() const {
    if (float_distinct_vertices == vertices && float_degenerate_triangles == 0) return {};
    return "stored as 32-bit floats, the " + std::to_string(vertices) + " distinct vertices fall on " +
           std::to_string(float_distinct_vertices) + " points and " + std::to_string(float_degenerate_triangles) +
           " of " + std::to_string(triangles) + " triangles lose all their area (largest coordinate " +
           number(largest_coordinate) + ", float spacing there " + number(float_spacing) +
           "): the file does not hold what the double computation had; move the scene nearer the origin";
}

namespace {

void check_write_options(const MeshWriteOptions& options) {
    if (options.binary && !mesh_format_has_binary(options.format)) {
        throw Error(std::string(to_string(options.format)) + " has no binary form; drop --binary or "
                                                             "write .ply, .off or .stl",
                    Where::in_file("--binary"));
    }
    if (options.ascii_digits < 1 || options.ascii_digits > 17) {
        throw Error("ASCII digits must be within [1, 17], got " + std::to_string(options.ascii_digits));
    }
}

// Writes `mesh` as it is (welded, or an unwelded export); `emitted` and `degenerate` are the
// weld's counts for the report.
MeshWriteReport write_view(const SurfaceMesh& mesh, std::size_t emitted, std::size_t degenerate, std::ostream& out,
                           const MeshWriteOptions& options, bool openmesh_ply_writer) {
    const MeshFormat format = options.format;
    const auto progress = [&options](std::string_view stage, double fraction) {
        if (options.progress) options.progress(stage, fraction);
    };
    if (mesh.positions.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()) ||
        mesh.triangles.size() > static_cast<std::size_t>(std::numeric_limits<int>::max())) {
        throw Error("mesh too large for OpenMesh's 32-bit handles: " + std::to_string(mesh.positions.size()) +
                    " vertices, " + std::to_string(mesh.triangles.size()) + " triangles");
    }
    MeshWriteReport report;
    report.emitted_vertices = emitted;
    report.vertices = mesh.positions.size();
    report.triangles = mesh.triangles.size();
    report.degenerate_triangles = degenerate;
    require_finite_floats(mesh);
    measure_float_storage(mesh, report);

    // What the format can carry, and what the mesh has.
    WrittenAttributes written;
    written.normals = format != MeshFormat::stl && !mesh.normals.empty();
    written.uvs = format != MeshFormat::stl && !mesh.uvs.empty();
    written.patch_ids = format == MeshFormat::ply && !mesh.patch_ids.empty();
    written.tess_coords = format == MeshFormat::ply && !mesh.tess_coords.empty();

    if (format == MeshFormat::ply && !openmesh_ply_writer) write_ply(mesh, written, options, out, progress);
    else write_through_openmesh(mesh, written, options, out, progress);
    if (!out) throw Error("cannot write the mesh: " + stream_failure());
    progress("writing", 1.0);
    return report;
}

MeshWriteReport write_mesh(const SurfaceMesh& mesh, std::ostream& out, const MeshWriteOptions& options,
                           bool openmesh_ply_writer) {
    check_write_options(options);
    errno = 0;  // stream_failure() reports only what this write's calls set
    const auto progress = [&options](std::string_view stage, double fraction) {
        if (options.progress) options.progress(stage, fraction);
    };
    if (!options.weld) {
        validate(mesh);
        return write_view(mesh, mesh.positions.size(), 0, out, options,
                          openmesh_ply_writer);
    }
    progress("welding", 0.0);
    const WeldedMesh welded = weld_bitwise(mesh);
    progress("welding", 1.0);
    return write_view(welded.mesh, mesh.positions.size(),
                      welded.degenerate_triangles, out, options, openmesh_ply_writer);
}

}  // namespace

MeshWriteReport write_mesh(const SurfaceMesh& mesh, std::ostream& out, const MeshWriteOptions& options) {
    return write_mesh(mesh, out, options, false);
}

MeshWriteReport write_mesh(const WeldedMesh& welded, std::ostream& out, const MeshWriteOptions& options) {
    check_write_options(options);
    errno = 0;  // stream_failure() reports only what this write's calls set
    if (!options.weld) throw Error("a welded mesh cannot be written unwelded");
    validate(welded.mesh);
    return write_view(welded.mesh, welded.emitted_vertices, welded.degenerate_triangles, out, options, false);
}

MeshWriteReport mesh_detail::write_mesh_through_openmesh(const SurfaceMesh& mesh, std::ostream& out,
                                                         const MeshWriteOptions& options) {
    return write_mesh(mesh, out, options, true);
}


// ---------------------------------------------------------------------------------------
// Streamed PLY

namespace {

struct Box {
    glm::dvec3 lo{std::numeric_limits<double>::infinity()}, hi{-std::numeric_limits<double>::infinity()};
    bool empty() const { return lo.x > hi.x; }
    void add(const glm::dvec3& p) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    bool meets(const Box& o) const {
        return lo.x <= o.hi.x && o.lo.x <= hi.x && lo.y <= o.hi.y && o.lo.y <= hi.y && lo.z <= o.hi.z && o.lo.z <= hi.z;
    }
};

// Whether no patch's interior box meets the whole box of a patch of another piece (closed
// boxes: a shared coordinate meets), proven within a budget of box tests; false when it is not, or
// not within the budget. The interiors are binned into a grid over the two axes along
// which the surface spreads most, cells at least as wide as every patch (so that each box
// lies in at most 2 x 2 cells), at most 4096 a side.
bool interiors_apart(const std::vector<Box>& interiors, const std::vector<Box>& wholes,
                     const std::vector<std::uint32_t>& piece_of) {
    Box all;
    for (const Box& b : wholes) {
        all.add(b.lo);
        all.add(b.hi);
    }
    if (all.empty()) return true;
    const glm::dvec3 extent = all.hi - all.lo;
    int axes[3] = {0, 1, 2};
    std::sort(axes, axes + 3, [&](int a, int b) { return extent[a] > extent[b]; });
    const int a = axes[0], b = axes[1];
    double width_a = 0.0, width_b = 0.0;
    for (const Box& w : wholes) {
        width_a = std::max(width_a, w.hi[a] - w.lo[a]);
        width_b = std::max(width_b, w.hi[b] - w.lo[b]);
    }
    const double cell_a = std::max(width_a, extent[a] / 4096.0), cell_b = std::max(width_b, extent[b] / 4096.0);
    const auto cell = [&](double x, int axis, double size) -> std::int64_t {
        if (!(size > 0.0)) return 0;
        return std::clamp<std::int64_t>(static_cast<std::int64_t>(std::floor((x - all.lo[axis]) / size)), 0, 1 << 13);
    };
    const auto key = [](std::int64_t i, std::int64_t j) { return static_cast<std::uint64_t>(i) << 32 | static_cast<std::uint64_t>(j); };
    std::vector<std::pair<std::uint64_t, std::uint32_t>> cells;
    for (std::size_t p = 0; p < interiors.size(); ++p) {
        const Box& e = interiors[p];
        if (e.empty()) continue;
        for (std::int64_t i = cell(e.lo[a], a, cell_a); i <= cell(e.hi[a], a, cell_a); ++i)
            for (std::int64_t j = cell(e.lo[b], b, cell_b); j <= cell(e.hi[b], b, cell_b); ++j)
                cells.emplace_back(key(i, j), static_cast<std::uint32_t>(p));
    }
    std::sort(cells.begin(), cells.end());
    std::size_t budget = 64 * wholes.size() + (std::size_t{1} << 20);
    for (std::size_t q = 0; q < wholes.size(); ++q) {
        const Box& w = wholes[q];
        const std::int64_t i0 = cell(w.lo[a], a, cell_a), i1 = cell(w.hi[a], a, cell_a);
        const std::int64_t j0 = cell(w.lo[b], b, cell_b), j1 = cell(w.hi[b], b, cell_b);
        for (std::int64_t i = i0; i <= i1; ++i) {
            for (std::int64_t j = j0; j <= j1; ++j) {
                if (budget-- == 0) return false;
                const auto first = std::lower_bound(cells.begin(), cells.end(), std::pair{key(i, j), std::uint32_t{0}});
                for (auto it = first; it != cells.end() && it->first == key(i, j); ++it) {
                    if (budget-- == 0) return false;
                    if (piece_of[it->second] != piece_of[q] && interiors[it->second].meets(w)) return false;
                }
            }
        }
    }
    return true;
}

// Whether every coordinate is a finite float value (compared before the conversion, which
// is undefined beyond float's range).
bool is_float_point(const glm::dvec3& p) {
    constexpr double largest = std::numeric_limits<float>::max();
    for (int c = 0; c < 3; ++c)
        if (!(std::abs(p[c]) <= largest) || static_cast<double>(static_cast<float>(p[c])) != p[c]) return false;
    return true;
}

}  // namespace

struct StreamedPlyWriter::Impl {
    Impl(std::ostream& o, const MeshWriteOptions& opts, std::size_t vertices, std::size_t triangles)
        : out(o), options(opts), vertex_bound(vertices), triangle_bound(triangles) {}

    std::ostream& out;
    MeshWriteOptions options;
    std::size_t vertex_bound, triangle_bound;
    PlyRecords records;
    bool started = false, failed = false;
    std::size_t header_length = 0;
    // Vertices on their patch box's surface, from every piece so far: index -> position, welded id.
    PositionTable shared{0};
    std::vector<glm::dvec3> shared_positions;
    std::vector<std::uint32_t> shared_ids;
    PositionTable local{0};               // the current piece's vertices, by piece index
    std::vector<std::uint32_t> welded_of;  // emitted vertex -> welded vertex
    std::vector<std::uint64_t> hashes;
    std::vector<std::uint8_t> on_box;      // the piece's vertex lies on its patch box's surface
    std::vector<std::uint32_t> fresh;      // the piece's vertices that are new welded vertices
    std::vector<Box> interiors, wholes;    // per patch, in order
    std::vector<std::uint32_t> piece_of;   // per patch: the piece it came in
    std::uint32_t pieces = 0;
    bool has_patch = false;
    std::uint32_t last_patch = 0;
    std::size_t welded = 0, emitted = 0, emitted_triangles = 0, degenerate = 0;
    double largest = 0.0;
    std::vector<RecordBlock> blocks;
    std::optional<BackgroundWriter> writer;  // the records after the header, until finish()

    void write(const char* data, std::size_t size) {
        out.write(data, static_cast<std::streamsize>(size));
        if (!out) throw Error("cannot write the mesh: " + stream_failure());
    }

    // The patches' boxes, and which vertices lie on their surfaces; false when the piece's
    // patch ids go back.
    bool measure_patches(const SurfaceMesh& piece) {
        const std::size_t n = piece.positions.size();
        on_box.resize(n);
        for (std::size_t g0 = 0; g0 < n;) {
            std::size_t g1 = n;
            if (!piece.patch_ids.empty()) {
                const std::uint32_t patch = piece.patch_ids[g0];
                if (has_patch && patch < last_patch) return false;
                has_patch = true;
                last_patch = patch;
                for (g1 = g0 + 1; g1 < n && piece.patch_ids[g1] == patch; ++g1) {}
            }
            Box whole, interior;
            for (std::size_t i = g0; i < g1; ++i) whole.add(piece.positions[i]);
            for (std::size_t i = g0; i < g1; ++i) {
                const glm::dvec3& p = piece.positions[i];
                const bool on = p.x == whole.lo.x || p.x == whole.hi.x || p.y == whole.lo.y || p.y == whole.hi.y ||
                                p.z == whole.lo.z || p.z == whole.hi.z;
                on_box[i] = on;
                if (!on) interior.add(p);
            }
            wholes.push_back(whole);
            interiors.push_back(interior);
            piece_of.push_back(pieces);
            g0 = g1;
        }
        return true;
    }

    bool add(const SurfaceMesh& piece) {
        if (failed) return false;
        validate(piece);
        const std::size_t n = piece.positions.size();
        if (n == 0) return true;  // then it has no triangles either (validated)
        WrittenAttributes present;
        present.normals = !piece.normals.empty();
        present.uvs = !piece.uvs.empty();
        present.patch_ids = !piece.patch_ids.empty();
        present.tess_coords = !piece.tess_coords.empty();
        if (started) {
            const auto check = [](bool piece_has, bool welded_has, const char* name) {
                if (piece_has != welded_has)
                    throw Error(std::string("surface piece ") + (piece_has ? "has " : "lacks ") + name +
                                    " unlike the pieces before it",
                                Where::at_key(name));
            };
            check(present.normals, records.written.normals, "normals");
            check(present.uvs, records.written.uvs, "uvs");
            check(present.patch_ids, records.written.patch_ids, "patch_ids");
            check(present.tess_coords, records.written.tess_coords, "tess_coords");
        }
        for (const glm::dvec3& p : piece.positions)
            if (!is_float_point(p)) return fail();
        if (emitted + n > std::numeric_limits<std::uint32_t>::max()) return fail();
        if (!measure_patches(piece)) return fail();
        ++pieces;
        if (!started) {
            records = PlyRecords{present, options.binary, options.ascii_digits};
            const std::string header = records.header(vertex_bound, triangle_bound);
            header_length = header.size();
            write(header.data(), header.size());
            out.flush();  // before the writer's thread takes the stream
            writer.emplace(out);
            started = true;
        }

        // The decisions, in emission order: an earlier piece's shared vertex, an earlier
        // vertex of this piece, or a new welded vertex (whose record this copy writes).
        hashes.resize(n);
        for (std::size_t i = 0; i < n; ++i) hashes[i] = PositionTable::hash(piece.positions[i]);
        welded_of.resize(emitted + n);
        std::uint32_t* const map = welded_of.data() + emitted;
        local.clear(n);
        fresh.clear();
        const auto shared_position = [this](std::uint32_t g) -> const glm::dvec3& { return shared_positions[g]; };
        const auto piece_position = [&piece](std::uint32_t k) -> const glm::dvec3& { return piece.positions[k]; };
        for (std::size_t i = 0; i < n; ++i) {
            if (i + kPrefetchAhead < n && on_box[i + kPrefetchAhead]) shared.prefetch(hashes[i + kPrefetchAhead]);
            const glm::dvec3& p = piece.positions[i];
            // An interior point meets no other piece's patch (finish() proves it).
            const std::uint32_t g = on_box[i] ? shared.find(p, hashes[i], shared_position) : PositionTable::kNone;
            if (g != PositionTable::kNone) {
                map[i] = shared_ids[g];
                continue;
            }
            const auto copy = static_cast<std::uint32_t>(i);
            const std::uint32_t first = local.find_or_insert(p, hashes[i], copy, piece_position);
            if (first != copy) {
                map[i] = map[first];
                continue;
            }
            map[i] = static_cast<std::uint32_t>(welded++);
            fresh.push_back(copy);
            if (on_box[i]) {
                shared.find_or_insert(p, hashes[i], static_cast<std::uint32_t>(shared_positions.size()), shared_position);
                shared_positions.push_back(p);
                shared_ids.push_back(map[i]);
            }
        }
        for (const auto& triangle : piece.triangles) {
            const std::uint32_t a = map[triangle[0]], b = map[triangle[1]], c = map[triangle[2]];
            if (a == b || b == c || c == a) ++degenerate;
        }
        emitted += n;
        emitted_triangles += piece.triangles.size();
        for (const std::uint32_t i : fresh) {
            const glm::dvec3& p = piece.positions[i];
            largest = std::max({largest, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
        }

        // The new vertices' records, blocks of them formatted in parallel (a piece has a few
        // thousand: ASCII's number printing is most of its time), written in order.
        constexpr std::size_t block_records = 512;
        const std::size_t block_count = (fresh.size() + block_records - 1) / block_records;
        if (blocks.size() < block_count) blocks.resize(block_count);
        tessref::parallel_for(std::size_t{0}, block_count, [&](std::size_t k) {
            RecordBlock& block = blocks[k];
            block.used = 0;
            const std::size_t end = std::min(fresh.size(), (k + 1) * block_records);
            for (std::size_t r = k * block_records; r < end; ++r)
                block.end_record(records.vertex(piece, fresh[r], block.reserve_record()));
        });
        blocks = writer->write(std::move(blocks), block_count);
        return true;
    }

    // The caller writes the file otherwise once this gives up: the writer's thread lets go
    // of the stream first.
    bool fail() {
        failed = true;
        stop_writing();
        return false;
    }
    void stop_writing() {
        if (!writer) return;
        writer->drain();
        writer.reset();
    }

    std::optional<MeshWriteReport> finish(const TriangleSource& source) {
        if (failed || !started) return std::nullopt;
        const std::size_t triangles = emitted_triangles - degenerate;
        constexpr auto handles = static_cast<std::size_t>(std::numeric_limits<int>::max());
        const std::string header = records.header(welded, triangles);
        if (!interiors_apart(interiors, wholes, piece_of) || welded > handles || triangles > handles ||  // write_mesh's error
            header.size() != header_length) {
            fail();
            return std::nullopt;
        }

        const auto progress = [this](double fraction) {
            if (options.progress) options.progress("writing", fraction);
        };
        progress(0.0);
        std::vector<std::vector<std::array<std::uint32_t, 3>>> emitted_blocks(kBlocksAtOnce);
        if (blocks.size() < kBlocksAtOnce) blocks.resize(kBlocksAtOnce);
        const std::size_t step = kBlocksAtOnce * kBlockRecords;
        const std::size_t progress_step = std::max<std::size_t>(step, emitted_triangles / 128);
        std::size_t next_progress = progress_step;
        for (std::size_t first = 0; first < emitted_triangles; first += step) {
            if (first >= next_progress) {
                progress(static_cast<double>(first) / static_cast<double>(emitted_triangles));
                next_progress = first + progress_step;
            }
            const std::size_t round = std::min(kBlocksAtOnce, (emitted_triangles - first + kBlockRecords - 1) / kBlockRecords);
            tessref::parallel_for(std::size_t{0}, round, [&](std::size_t k) {
                const std::size_t begin = first + k * kBlockRecords;
                std::vector<std::array<std::uint32_t, 3>>& list = emitted_blocks[k];
                list.resize(std::min(emitted_triangles, begin + kBlockRecords) - begin);
                source(begin, list);
                RecordBlock& block = blocks[k];
                block.used = 0;
                for (const auto& triangle : list) {
                    for (const std::uint32_t index : triangle)
                        if (index >= emitted) throw Error("the streamed triangles name vertex " + std::to_string(index) +
                                                          " of " + std::to_string(emitted));
                    const std::array<std::uint32_t, 3> w{welded_of[triangle[0]], welded_of[triangle[1]],
                                                         welded_of[triangle[2]]};
                    if (w[0] == w[1] || w[1] == w[2] || w[2] == w[0]) continue;
                    block.end_record(records.triangle(w, block.reserve_record()));
                }
            });
            blocks = writer->write(std::move(blocks), round);
            if (blocks.size() < kBlocksAtOnce) blocks.resize(kBlocksAtOnce);
        }
        stop_writing();
        out.seekp(0);
        write(header.data(), header.size());
        out.flush();
        if (!out) throw Error("cannot write the mesh: " + stream_failure());
        progress(1.0);

        MeshWriteReport report;
        report.emitted_vertices = emitted;
        report.vertices = welded;
        report.triangles = triangles;
        report.degenerate_triangles = degenerate;
        report.float_distinct_vertices = welded;  // every position is a float (add())
        report.largest_coordinate = largest;
        const auto largest_f = static_cast<float>(largest);
        report.float_spacing = static_cast<double>(std::nextafter(largest_f, std::numeric_limits<float>::infinity())) -
                               static_cast<double>(largest_f);
        return report;
    }
};

StreamedPlyWriter::StreamedPlyWriter(std::ostream& out, const MeshWriteOptions& options, std::size_t emitted_vertices,
                                     std::size_t emitted_triangles)
    : impl_(std::make_unique<Impl>(out, options, emitted_vertices, emitted_triangles)) {
    check_write_options(options);
    if (options.format != MeshFormat::ply || !options.weld)
        throw Error("the streamed writer writes welded PLY files only");
    errno = 0;  // stream_failure() reports only what this write's calls set
    // Reserved, not touched: only the pages the emitted vertices fill are resident.
    impl_->welded_of.reserve(emitted_vertices);
}
StreamedPlyWriter::~StreamedPlyWriter() = default;

bool StreamedPlyWriter::add(const SurfaceMesh& piece) { return impl_->add(piece); }

std::optional<MeshWriteReport> StreamedPlyWriter::finish(const TriangleSource& triangles) {
    return impl_->finish(triangles);
}

}  // namespace tessref
