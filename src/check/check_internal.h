// src/check/check_internal.h — the state shared by the steps of check_mesh() (private).
//
// check_mesh() runs its steps in a fixed order over one CheckState: each step reads what
// earlier steps left in it and adds its defects to the report. Parallel steps split their
// input into fixed chunks and merge the chunks' results in chunk order, so the report does
// not depend on the thread count.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <string_view>
#include <type_traits>
#include <unordered_map>
#include <vector>

#include "common/parallel.h"

#include "tessref/check.h"
#include "tessref/error.h"

namespace tessref::check_detail {

inline constexpr std::uint32_t kNoIndex = std::numeric_limits<std::uint32_t>::max();

// Why a face is left out of the topology.
enum FaceStatus : std::uint8_t {
    face_kept = 0,
    face_too_few_vertices = 1,
    face_repeated_vertex = 2,
    face_duplicate = 3,
    face_non_finite = 4,
};

// A half-edge filed under its smaller vertex: the other vertex, and face << 1 | forward,
// where forward means the face traverses the edge from the smaller vertex to the larger
// (VertexStar).
struct HalfEdgeEntry {
    std::uint32_t other;
    std::uint32_t face_and_direction;
    std::uint32_t face() const { return face_and_direction >> 1; }
    bool forward() const { return face_and_direction & 1u; }
};

// A table the step that makes it writes whole: allocated without being cleared first (a
// std::vector clears it on one thread: for the half-edges of a 2.4 M triangle mesh, 57 MB,
// that was 1.7 % of the check's profile, before the parallel pass wrote it all again).
template <class T>
class Table {
    static_assert(std::is_trivially_copyable_v<T>);

public:
    void allocate(std::size_t n) {
        data_ = std::make_unique_for_overwrite<T[]>(n);
        size_ = n;
    }
    void release() {
        data_.reset();
        size_ = 0;
    }
    std::size_t size() const { return size_; }
    bool empty() const { return size_ == 0; }
    T& operator[](std::size_t i) { return data_[i]; }
    const T& operator[](std::size_t i) const { return data_[i]; }
    T* begin() { return data_.get(); }
    T* end() { return data_.get() + size_; }
    const T* begin() const { return data_.get(); }
    const T* end() const { return data_.get() + size_; }

private:
    std::unique_ptr<T[]> data_;
    std::size_t size_ = 0;
};

struct BoundaryHalfEdge {
    std::uint32_t from, to, face;
    auto operator<=>(const BoundaryHalfEdge&) const = default;
};

struct CheckState {
    CheckState(const IndexedMesh& m, const CheckOptions& o, CheckReport& r) : mesh(m), options(o), report(r) {}
    const IndexedMesh& mesh;
    const CheckOptions& options;
    CheckReport& report;
    double tolerance = 0.0;
    glm::dvec3 bbox_min{0.0}, bbox_max{0.0};
    double diagonal = 0.0;

    std::vector<std::uint8_t> face_status;      // FaceStatus per face
    std::vector<std::uint8_t> vertex_referenced; // by any face

    // The faces at each vertex that classify_faces kept, in face order (corner_faces[
    // corner_start[v] .. corner_start[v + 1]]): made by build_corner_table, read by the
    // topology steps and, through VertexStar, by every step that asks for an edge.
    Table<std::uint32_t> corner_start;  // vertex_count + 1
    Table<std::uint32_t> corner_faces;

    std::vector<BoundaryHalfEdge> boundary;        // sorted
    std::size_t inconsistent_edges = 0;
    std::size_t non_manifold_edges = 0;

    // At vertices with more than one fan: (vertex << 32 | face) -> the face's fan there.
    std::unordered_map<std::uint64_t, std::uint32_t> fan_at_pinch;

    std::vector<std::uint32_t> vertex_component;  // per vertex, none if in no kept face
    std::vector<std::uint8_t> component_has_boundary;  // or a non-manifold edge
    std::vector<std::uint8_t> face_flipped;       // empty when every piece is consistent

    // Boundary loops in trace order (before sorting for the report), and for each boundary
    // half-edge (index into `boundary`) the loop it belongs to.
    std::vector<BoundaryLoop> loops;
    std::vector<std::uint32_t> loop_of_boundary;
    int allowed_loop = -1;  // index into loops (a terrain's outline)
    // Expect::automatic on a mesh that is neither closed nor a terrain: per component, 1 for
    // an open sheet (a boundary, every face seen from one side along its own up axis, as a
    // terrain is), whose outer outline is allowed and whose faces the closed probe leaves out.
    std::vector<std::uint8_t> component_is_sheet;

    int up_axis = 2;
    double up_sign = 1.0;

    void add_defect(DefectClass kind, Defect defect) {
        DefectReport& r = report.defects[static_cast<int>(kind)];
        ++r.count;
        if (r.locations.size() < options.max_locations) r.locations.push_back(std::move(defect));
    }
    void progress(std::string_view stage, double fraction) const {
        if (options.progress) options.progress(stage, fraction);
    }
    glm::dvec3 position(std::uint32_t v) const { return mesh.positions[v]; }
};

// Runs fn(chunk_begin, chunk_end, result&) over [0, n) in fixed chunks, in parallel, and
// returns the per-chunk results in chunk order.
template <class Result, class Fn>
std::vector<Result> map_chunks(std::size_t n, std::size_t chunk, Fn&& fn) {
    const std::size_t chunks = (n + chunk - 1) / chunk;
    std::vector<Result> results(chunks);
    tessref::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t c = r.begin(); c != r.end(); ++c)
            fn(c * chunk, std::min(n, (c + 1) * chunk), results[c]);
    });
    return results;
}

template <class T>
std::vector<T> concatenate(std::vector<std::vector<T>>&& parts) {
    std::size_t total = 0;
    for (const auto& p : parts) total += p.size();
    std::vector<T> out;
    out.reserve(total);
    for (auto& p : parts) out.insert(out.end(), std::make_move_iterator(p.begin()), std::make_move_iterator(p.end()));
    return out;
}

// Lock-free union-find: roots link under smaller roots, so every set ends with its
// smallest element as root, whatever the order of the unions. Each element starts as its own
// root, written in parallel chunks (a table of atomics would first be cleared on one thread).
class ConcurrentDisjointSets {
public:
    explicit ConcurrentDisjointSets(std::size_t n) {
        parent_.allocate(n);
        tessref::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1 << 16), [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) parent_[i] = static_cast<std::uint32_t>(i);
        });
    }
    std::uint32_t find(std::uint32_t v) {
        while (true) {
            std::uint32_t p = parent(v).load(std::memory_order_relaxed);
            if (p == v) return v;
            const std::uint32_t gp = parent(p).load(std::memory_order_relaxed);
            if (gp != p) parent(v).compare_exchange_weak(p, gp, std::memory_order_relaxed);
            v = gp;
        }
    }
    void unite(std::uint32_t a, std::uint32_t b) {
        while (true) {
            a = find(a);
            b = find(b);
            if (a == b) return;
            if (a < b) std::swap(a, b);  // link the larger root under the smaller
            std::uint32_t expected = a;
            if (parent(a).compare_exchange_strong(expected, b, std::memory_order_relaxed)) return;
        }
    }

private:
    std::atomic_ref<std::uint32_t> parent(std::uint32_t v) { return std::atomic_ref<std::uint32_t>(parent_[v]); }
    Table<std::uint32_t> parent_;
};

// A vertex's star: the faces at it (the corner table's, in face order), each with its two
// neighbours of the vertex, and from those the half-edges filed under the vertex (its
// smaller one): its edges to larger vertices, each with the faces on it. Made from the
// corner table when a step asks for it (a table of every half-edge was 57 MB of fresh
// pages on a 2.4 M-triangle mesh, filled and sorted to be read once); reused as scratch
// from vertex to vertex.
struct VertexStar {
    std::uint32_t vertex = 0;
    std::span<const std::uint32_t> faces;  // at the vertex, in face order
    // neighbour << 32 | i << 1 | 1 where faces[i] runs from the vertex to the neighbour,
    // | 0 where it runs from the neighbour to the vertex; sorted.
    std::vector<std::uint64_t> neighbours;
    // The half-edges filed under the vertex, sorted by (other, face << 1 | forward).
    std::vector<HalfEdgeEntry> half_edges;

    void make(const CheckState& state, std::uint32_t v);  // of the corner table's faces at v
    void make(const CheckState& state, std::uint32_t v, std::span<const std::uint32_t> faces);  // of these
    static std::uint32_t face_index(std::uint64_t neighbour) { return static_cast<std::uint32_t>(neighbour) >> 1; }

    // Calls fn(vertex, other, half-edges) for each edge filed under the vertex.
    template <class Fn>
    void for_each_edge(Fn&& fn) const {
        for (std::size_t i = 0; i < half_edges.size();) {
            std::size_t j = i + 1;
            while (j < half_edges.size() && half_edges[j].other == half_edges[i].other) ++j;
            fn(vertex, half_edges[i].other, std::span<const HalfEdgeEntry>(half_edges.data() + i, j - i));
            i = j;
        }
    }
};

// Steps of check_mesh(), in the order they run.
void build_corner_table(CheckState& state);
// The duplicate faces, the edges' classes and the vertices where the surface is pinched.
void classify_edges_and_vertices(CheckState& state);
void find_components(CheckState& state);
void check_orientation(CheckState& state);
void analyse_face_geometry(CheckState& state);
void trace_boundary_loops(CheckState& state);
void judge_boundary(CheckState& state);
void find_coincident_vertices(CheckState& state);
void find_t_junctions(CheckState& state);
void find_faces_facing_down(CheckState& state);
void run_ray_probe(CheckState& state);

// The faces of `mesh` OpenMesh's kernel refuses (IndexedMesh::kernel_refused_faces), by
// importing it (src/mesh/openmesh.h).
std::vector<std::uint32_t> kernel_refused_faces(const IndexedMesh& mesh);

// Shared geometry helpers.
glm::dvec3 face_vector_area(const IndexedMesh& mesh, std::size_t f);  // Newell, half the normal sum
std::string format_point(const glm::dvec3& p);
std::string format_number(double x);

}  // namespace tessref::check_detail
