// Topology of the face list as the file gives it: edges, fans, components, orientation and
// boundary loops, computed on our own corner table (the faces at each vertex) and the
// half-edges made from it, so that non-manifold input is seen exactly (a half-edge data
// structure cannot even hold it).
#include <algorithm>
#include <atomic>
#include <limits>
#include <numeric>
#include <queue>
#include <span>
#include <string>
#include <utility>

#include "check/check_internal.h"
#include "tessref/error.h"

namespace tessref::check_detail {

namespace {

constexpr std::size_t kVertexChunk = 1 << 14;
constexpr std::size_t kFaceChunk = 1 << 14;
// At most this many runs of faces fill the corner table (build_corner_table).
constexpr std::size_t kMaxTableParts = 4;

bool same_vertex_set(const IndexedMesh& mesh, std::uint32_t f, std::uint32_t g) {
    const auto a = mesh.face(f);
    const auto b = mesh.face(g);
    if (a.size() != b.size()) return false;
    if (a.size() == 3) {
        std::uint32_t x[3] = {a[0], a[1], a[2]}, y[3] = {b[0], b[1], b[2]};
        std::sort(x, x + 3);
        std::sort(y, y + 3);
        return x[0] == y[0] && x[1] == y[1] && x[2] == y[2];
    }
    std::vector<std::uint32_t> x(a.begin(), a.end()), y(b.begin(), b.end());
    std::sort(x.begin(), x.end());
    std::sort(y.begin(), y.end());
    return x == y;
}

// Calls fn(lo, hi, half_edges) for every undirected edge with lo in [v0, v1): the
// half-edges filed under lo (VertexStar) that go to hi.
template <class Fn>
void for_each_edge_in(const CheckState& state, std::size_t v0, std::size_t v1, Fn&& fn) {
    VertexStar star;
    for (std::size_t v = v0; v < v1; ++v) {
        star.make(state, static_cast<std::uint32_t>(v));
        star.for_each_edge(fn);
    }
}

}  // namespace

void VertexStar::make(const CheckState& state, std::uint32_t v, std::span<const std::uint32_t> faces) {
    vertex = v;
    this->faces = faces;
    neighbours.clear();
    half_edges.clear();
    const IndexedMesh& mesh = state.mesh;
    for (std::uint32_t i = 0; i < faces.size(); ++i) {
        const auto face = mesh.face(faces[i]);
        const std::size_t n = face.size();
        std::size_t k = 0;
        while (face[k] != v) ++k;  // once: a kept face repeats no vertex
        const std::uint32_t prev = face[k == 0 ? n - 1 : k - 1], next = face[k + 1 == n ? 0 : k + 1];
        neighbours.push_back(std::uint64_t(prev) << 32 | i << 1);
        neighbours.push_back(std::uint64_t(next) << 32 | i << 1 | 1u);
    }
    // A vertex has a few neighbours, sorted by insertion; the apex of a large fan has many.
    if (neighbours.size() > 32) {
        std::sort(neighbours.begin(), neighbours.end());
    } else {
        for (std::size_t i = 1; i < neighbours.size(); ++i) {
            const std::uint64_t x = neighbours[i];
            std::size_t j = i;
            for (; j > 0 && neighbours[j - 1] > x; --j) neighbours[j] = neighbours[j - 1];
            neighbours[j] = x;
        }
    }
    // The face runs prev -> v -> next: v -> next is forward when next is the larger, prev ->
    // v backward when prev is; each is filed here when v is the smaller. The faces are in
    // face order, so (neighbour, i, 1 for next) sorts as (other, face << 1 | forward).
    for (const std::uint64_t x : neighbours)
        if (x >> 32 > v)
            half_edges.push_back({static_cast<std::uint32_t>(x >> 32), faces[face_index(x)] << 1 | static_cast<std::uint32_t>(x & 1u)});
}

void VertexStar::make(const CheckState& state, std::uint32_t v) {
    make(state, v,
         std::span<const std::uint32_t>(state.corner_faces.begin() + state.corner_start[v],
                                        state.corner_faces.begin() + state.corner_start[v + 1]));
}

void build_corner_table(CheckState& state) {
    const IndexedMesh& mesh = state.mesh;
    const std::size_t vertex_count = mesh.vertex_count();
    const std::size_t face_count = mesh.face_count();
    if (face_count >= (std::size_t(1) << 31))
        throw Error("mesh too large to check: more than 2^31 faces", Where::in_file(mesh.source));

    // A counting sort of the kept faces' corners by vertex. The faces are cut into `parts`
    // runs, each counted and filed by one task with counters of its own, so no counter is
    // shared between threads (an atomic increment costs several plain ones). Part p files
    // its entries after those of parts 0 .. p-1 at every vertex, so a vertex's entries come
    // out in face order whatever the number of parts: the table a serial pass makes. The
    // counters take 4 bytes a vertex for each part, so the parts are few.
    const std::size_t parts = std::clamp<std::size_t>(
        std::min<std::size_t>(static_cast<std::size_t>(tessref::worker_threads()), kMaxTableParts), 1,
        face_count / kFaceChunk + 1);
    const std::size_t part_faces = (face_count + parts - 1) / parts;
    // Per part and vertex: the part's corners there, then where the part files its next
    // one (corners[p * vertex_count + v]).
    Table<std::uint32_t> corners;
    corners.allocate(parts * vertex_count);
    const auto for_each_part = [&](auto&& fn) {
        tessref::parallel_for(tbb::blocked_range<std::size_t>(0, parts, 1), [&](const auto& r) {
            for (std::size_t p = r.begin(); p != r.end(); ++p)
                fn(corners.begin() + p * vertex_count, p * part_faces, std::min(face_count, (p + 1) * part_faces));
        });
    };
    for_each_part([&](std::uint32_t* corner, std::size_t f0, std::size_t f1) {
        std::fill(corner, corner + vertex_count, 0u);
        for (std::size_t f = f0; f < f1; ++f) {
            if (state.face_status[f] != face_kept) continue;
            for (const std::uint32_t a : mesh.face(f)) ++corner[a];
        }
    });

    // Each vertex's start, and each part's first slot there; chunks of vertices in
    // parallel once their totals are known.
    const auto totals = map_chunks<std::uint64_t>(vertex_count, kVertexChunk, [&](std::size_t v0, std::size_t v1, std::uint64_t& total) {
        for (std::size_t p = 0; p < parts; ++p)
            for (std::size_t v = v0; v < v1; ++v) total += corners[p * vertex_count + v];
    });
    std::vector<std::uint64_t> chunk_start(totals.size() + 1, 0);
    for (std::size_t c = 0; c < totals.size(); ++c) chunk_start[c + 1] = chunk_start[c] + totals[c];
    state.corner_start.allocate(vertex_count + 1);
    tessref::parallel_for(tbb::blocked_range<std::size_t>(0, totals.size(), 1), [&](const auto& r) {
        for (std::size_t c = r.begin(); c != r.end(); ++c) {
            auto next_corner = static_cast<std::uint32_t>(chunk_start[c]);
            for (std::size_t v = c * kVertexChunk; v < std::min(vertex_count, (c + 1) * kVertexChunk); ++v) {
                state.corner_start[v] = next_corner;
                for (std::size_t p = 0; p < parts; ++p) next_corner += std::exchange(corners[p * vertex_count + v], next_corner);
            }
        }
    });
    state.corner_start[vertex_count] = static_cast<std::uint32_t>(chunk_start.back());

    // Every slot is written below: the table is not cleared first.
    state.corner_faces.allocate(chunk_start.back());
    for_each_part([&](std::uint32_t* corner, std::size_t f0, std::size_t f1) {
        for (std::size_t f = f0; f < f1; ++f) {
            if (state.face_status[f] != face_kept) continue;
            for (const std::uint32_t a : mesh.face(f)) state.corner_faces[corner[a]++] = static_cast<std::uint32_t>(f);
        }
    });
}

namespace {

// Whether faces f and g, both on one edge, are two faces over the same vertex set.
bool same_faces_on_edge(const IndexedMesh& mesh, std::uint32_t f, std::uint32_t g) {
    if (f == g) return false;
    const auto x = mesh.face(f), y = mesh.face(g);
    // Two triangles on an edge hold both its vertices (a kept face repeats none), so their
    // third vertices decide, and so do the xors of all three.
    return x.size() == 3 && y.size() == 3 ? (x[0] ^ x[1] ^ x[2]) == (y[0] ^ y[1] ^ y[2]) : same_vertex_set(mesh, f, g);
}

// Finds the faces repeating others on the edge whose half-edges are `edge`: a face there
// over the same vertex set as an earlier one has its half-edge marked in `repeats`, and
// (the face, the earliest face there it repeats) is added to `duplicates`: at most one pair
// a half-edge, however many copies of a face there are.
void find_duplicates_on_edge(const CheckState& state, std::span<const HalfEdgeEntry> edge,
                             std::vector<std::pair<std::uint32_t, std::uint32_t>>& duplicates,
                             std::vector<std::uint8_t>& repeats, std::vector<std::uint32_t>& earliest) {
    const IndexedMesh& mesh = state.mesh;
    repeats.assign(edge.size(), 0);
    earliest.assign(edge.size(), kNoIndex);
    for (std::size_t i = 0; i < edge.size(); ++i)
        for (std::size_t j = i + 1; j < edge.size(); ++j) {
            std::uint32_t f = edge[i].face(), g = edge[j].face();
            if (!same_faces_on_edge(mesh, f, g)) continue;
            const std::size_t later = f > g ? i : j;
            repeats[later] = 1;
            earliest[later] = std::min({earliest[later], f, g});
        }
    for (std::size_t i = 0; i < edge.size(); ++i)
        if (repeats[i]) duplicates.emplace_back(edge[i].face(), earliest[i]);
}

// The vertices of a run where the surface is pinched.
struct PinchedVertices {
    std::vector<Defect> defects;  // the run's first max_locations
    std::size_t count = 0;
    std::vector<std::pair<std::uint64_t, std::uint32_t>> fans;  // (vertex << 32 | face, fan)
};

// Whether the star's faces make more than one fan (faces around the vertex connected
// through edges at it) and so pinch the surface there (two cones touching at their tips, a
// bow tie); if so, the vertex and each face's fan into `out`. parent: scratch.
void find_fans(const CheckState& state, const VertexStar& star, std::vector<std::uint32_t>& parent, PinchedVertices& out) {
    const auto count = static_cast<std::uint32_t>(star.faces.size());
    if (count < 2) return;
    parent.resize(count);
    std::iota(parent.begin(), parent.end(), 0u);
    auto find = [&](std::uint32_t x) {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
    };
    // Faces sharing a neighbour share the edge to it: one fan.
    std::uint32_t fans = count;
    const std::vector<std::uint64_t>& neighbours = star.neighbours;
    for (std::size_t i = 1; i < neighbours.size(); ++i) {
        if (neighbours[i] >> 32 != neighbours[i - 1] >> 32) continue;
        const std::uint32_t x = find(VertexStar::face_index(neighbours[i])), y = find(VertexStar::face_index(neighbours[i - 1]));
        if (x != y) {
            parent[std::max(x, y)] = std::min(x, y);
            --fans;
        }
    }
    if (fans <= 1) return;
    const std::uint32_t v = star.vertex;
    for (std::uint32_t i = 0; i < count; ++i) out.fans.emplace_back(std::uint64_t(v) << 32 | star.faces[i], find(i));
    ++out.count;
    if (out.defects.size() >= state.options.max_locations) return;
    Defect d;
    d.position = state.mesh.positions[v];
    d.vertices = {v};
    for (std::uint32_t i = 0; i < count && d.faces.size() < 32; ++i) d.faces.push_back(star.faces[i]);
    d.measure = fans;
    d.detail = "vertex " + std::to_string(v) + " joins " + std::to_string(fans) + " separate fans of faces";
    out.defects.push_back(std::move(d));
}

// The runs' pinched vertices into the report, in vertex order (counts exact, the first
// max_locations located).
void add_pinched_vertices(CheckState& state, std::vector<PinchedVertices>& runs) {
    auto& report = state.report.defects[int(DefectClass::non_manifold_vertex)];
    for (PinchedVertices& r : runs) {
        report.count += r.count;
        for (Defect& d : r.defects)
            if (report.locations.size() < state.options.max_locations) report.locations.push_back(std::move(d));
        state.fan_at_pinch.insert(r.fans.begin(), r.fans.end());
    }
}

}  // namespace

// Duplicate faces, each edge as boundary, manifold, inconsistent or non-manifold, and the
// vertices with more than one fan, in one pass over the vertices' stars (each made once
// from the corner table, read for both). Two faces over the same vertex set share every
// edge, so comparing the faces met on each edge finds every duplicate; the earliest face of
// a set is the original. And since a face's duplicates are on every edge of it, an edge's
// kept faces (those that repeat no other) are known from the edge's own half-edges, before
// the faces are marked. The fans, though, are of the faces the corner table holds, which
// include the duplicates: where there are any, the fans are found again without them.
void classify_edges_and_vertices(CheckState& state) {
    const IndexedMesh& mesh = state.mesh;
    struct ChunkResult {
        std::vector<std::pair<std::uint32_t, std::uint32_t>> duplicates;  // (face, a face it repeats)
        std::size_t edges = 0;
        std::vector<BoundaryHalfEdge> boundary;
        std::vector<Defect> non_manifold;
        std::vector<Defect> inconsistent;
        std::size_t non_manifold_count = 0, inconsistent_count = 0;
        PinchedVertices pinched;
    };
    const std::size_t cap = state.options.max_locations;
    auto results = map_chunks<ChunkResult>(mesh.vertex_count(), kVertexChunk, [&](std::size_t v0, std::size_t v1, ChunkResult& out) {
        VertexStar star;
        std::vector<HalfEdgeEntry> kept;
        std::vector<std::uint8_t> repeats;
        std::vector<std::uint32_t> earliest, parent;
        for (std::size_t v = v0; v < v1; ++v) {
            star.make(state, static_cast<std::uint32_t>(v));
            star.for_each_edge([&](std::uint32_t lo, std::uint32_t hi, std::span<const HalfEdgeEntry> edge) {
                kept.clear();
                if (edge.size() == 1 || (edge.size() == 2 && !same_faces_on_edge(mesh, edge[0].face(), edge[1].face()))) {
                    kept.assign(edge.begin(), edge.end());  // most edges: no face there repeats another
                } else {
                    find_duplicates_on_edge(state, edge, out.duplicates, repeats, earliest);
                    for (std::size_t i = 0; i < edge.size(); ++i)
                        if (!repeats[i]) kept.push_back(edge[i]);
                }
                if (kept.empty()) return;
                ++out.edges;
                // Only a defect's location reads the positions (a boundary edge is located by
                // its loop): an edge's second vertex is far from its first in the list.
                const auto mid = [&] { return 0.5 * (mesh.positions[lo] + mesh.positions[hi]); };
                if (kept.size() == 1) {
                    const HalfEdgeEntry& h = kept[0];
                    out.boundary.push_back(h.forward() ? BoundaryHalfEdge{lo, hi, h.face()} : BoundaryHalfEdge{hi, lo, h.face()});
                } else if (kept.size() == 2) {
                    const HalfEdgeEntry& h0 = kept[0];
                    const HalfEdgeEntry& h1 = kept[1];
                    if (h0.forward() == h1.forward()) {
                        ++out.inconsistent_count;
                        if (out.inconsistent.size() < cap) {
                            Defect d;
                            d.position = mid();
                            d.faces = {h0.face(), h1.face()};
                            d.vertices = h0.forward() ? std::vector<std::uint32_t>{lo, hi} : std::vector<std::uint32_t>{hi, lo};
                            d.detail = "faces " + std::to_string(h0.face()) + " and " + std::to_string(h1.face()) +
                                       " both run from vertex " + std::to_string(d.vertices[0]) + " to " +
                                       std::to_string(d.vertices[1]);
                            out.inconsistent.push_back(std::move(d));
                        }
                    }
                } else {
                    ++out.non_manifold_count;
                    if (out.non_manifold.size() < cap) {
                        Defect d;
                        d.position = mid();
                        d.vertices = {lo, hi};
                        for (const HalfEdgeEntry& h : kept) d.faces.push_back(h.face());
                        d.measure = double(kept.size());
                        d.detail = "edge " + std::to_string(lo) + "-" + std::to_string(hi) + " is shared by " +
                                   std::to_string(kept.size()) + " faces";
                        out.non_manifold.push_back(std::move(d));
                    }
                }
            });
            find_fans(state, star, parent, out.pinched);
        }
    });
    // Each repeat was found on each of its edges, perhaps in several chunks: sorted, a face's
    // first pair names the earliest face it repeats, and the faces come in face order. (No
    // table over every face: a clean mesh has no pair at all.)
    std::vector<std::pair<std::uint32_t, std::uint32_t>> duplicates;
    for (ChunkResult& r : results) duplicates.insert(duplicates.end(), r.duplicates.begin(), r.duplicates.end());
    std::sort(duplicates.begin(), duplicates.end());
    for (std::size_t k = 0; k < duplicates.size(); ++k) {
        if (k > 0 && duplicates[k].first == duplicates[k - 1].first) continue;
        const auto [g, original] = duplicates[k];
        state.face_status[g] = face_duplicate;
        Defect d;
        const auto face = mesh.face(g);
        glm::dvec3 centre(0.0);
        for (std::uint32_t v : face) centre += mesh.positions[v];
        d.position = centre / double(face.size());
        d.faces = {original, g};
        d.vertices.assign(face.begin(), face.end());
        d.detail = "face " + std::to_string(g) + " repeats face " + std::to_string(original) +
                   (std::ranges::equal(mesh.face(original), face) ? "" : " (same vertices, other order)");
        state.add_defect(DefectClass::duplicate_face, std::move(d));
    }

    std::size_t edges = 0;
    for (ChunkResult& r : results) {
        edges += r.edges;
        state.boundary.insert(state.boundary.end(), r.boundary.begin(), r.boundary.end());
        state.inconsistent_edges += r.inconsistent_count;
        state.non_manifold_edges += r.non_manifold_count;
        // Counts are exact; only the first `cap` locations are kept, in vertex order.
        auto& inc = state.report.defects[int(DefectClass::inconsistent_orientation)];
        auto& nm = state.report.defects[int(DefectClass::non_manifold_edge)];
        inc.count += r.inconsistent_count;
        nm.count += r.non_manifold_count;
        for (Defect& d : r.inconsistent)
            if (inc.locations.size() < cap) inc.locations.push_back(std::move(d));
        for (Defect& d : r.non_manifold)
            if (nm.locations.size() < cap) nm.locations.push_back(std::move(d));
    }
    std::sort(state.boundary.begin(), state.boundary.end());
    state.report.edge_count = edges;
    state.report.boundary_edge_count = state.boundary.size();

    std::vector<PinchedVertices> pinched;
    if (duplicates.empty()) {
        for (ChunkResult& r : results) pinched.push_back(std::move(r.pinched));
    } else {
        // Without the duplicates just marked (the face each repeats stays, so every vertex
        // keeps a kept face).
        pinched = map_chunks<PinchedVertices>(mesh.vertex_count(), kVertexChunk, [&](std::size_t v0, std::size_t v1, PinchedVertices& out) {
            VertexStar star;
            std::vector<std::uint32_t> kept, parent;
            for (std::size_t v = v0; v < v1; ++v) {
                kept.clear();
                for (std::uint32_t c = state.corner_start[v]; c < state.corner_start[v + 1]; ++c)
                    if (state.face_status[state.corner_faces[c]] == face_kept) kept.push_back(state.corner_faces[c]);
                star.make(state, static_cast<std::uint32_t>(v), kept);
                find_fans(state, star, parent, out);
            }
        });
    }
    add_pinched_vertices(state, pinched);
}

void find_components(CheckState& state) {
    const IndexedMesh& mesh = state.mesh;
    ConcurrentDisjointSets sets(mesh.vertex_count());
    tessref::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.face_count(), kFaceChunk), [&](const auto& r) {
        for (std::size_t f = r.begin(); f != r.end(); ++f) {
            if (state.face_status[f] != face_kept) continue;
            const auto face = mesh.face(f);
            for (std::size_t k = 1; k < face.size(); ++k) sets.unite(face[0], face[k]);
        }
    });
    // A vertex is in a kept face where the corner table files a face under it.
    const auto in_kept_face = [&](std::uint32_t v) { return state.corner_start[v + 1] != state.corner_start[v]; };
    // Roots are the smallest vertex of their set, so numbering roots in vertex order numbers
    // components by their smallest vertex: each chunk of vertices counts its roots, numbers
    // them from the chunk's first number, then every vertex takes its root's number.
    const std::size_t vertex_count = mesh.vertex_count();
    Table<std::uint32_t> root;  // written whole below
    root.allocate(vertex_count);
    const auto roots = map_chunks<std::uint32_t>(vertex_count, kVertexChunk, [&](std::size_t v0, std::size_t v1, std::uint32_t& count) {
        for (std::size_t v = v0; v < v1; ++v) {
            root[v] = in_kept_face(static_cast<std::uint32_t>(v)) ? sets.find(static_cast<std::uint32_t>(v)) : kNoIndex;
            count += root[v] == v;
        }
    });
    std::vector<std::uint32_t> first_number(roots.size() + 1, 0);
    for (std::size_t c = 0; c < roots.size(); ++c) first_number[c + 1] = first_number[c] + roots[c];
    state.vertex_component.resize(vertex_count);
    const auto for_each_chunk = [&](auto&& fn) {
        tessref::parallel_for(tbb::blocked_range<std::size_t>(0, roots.size(), 1), [&](const auto& r) {
            for (std::size_t c = r.begin(); c != r.end(); ++c) fn(c, c * kVertexChunk, std::min(vertex_count, (c + 1) * kVertexChunk));
        });
    };
    for_each_chunk([&](std::size_t c, std::size_t v0, std::size_t v1) {
        std::uint32_t number = first_number[c];
        for (std::size_t v = v0; v < v1; ++v)
            if (root[v] == v) state.vertex_component[v] = number++;
    });
    for_each_chunk([&](std::size_t, std::size_t v0, std::size_t v1) {
        for (std::size_t v = v0; v < v1; ++v)
            if (root[v] != v) state.vertex_component[v] = root[v] == kNoIndex ? kNoIndex : state.vertex_component[root[v]];
    });
    const std::uint32_t components = first_number.back();
    state.report.component_count = components;
    state.component_has_boundary.assign(components, 0);
    for (const BoundaryHalfEdge& h : state.boundary) state.component_has_boundary[state.vertex_component[h.from]] = 1;
    for (const Defect& d : state.report.of(DefectClass::non_manifold_edge).locations)
        state.component_has_boundary[state.vertex_component[d.vertices[0]]] = 1;
    if (state.report.count(DefectClass::non_manifold_edge) > state.report.of(DefectClass::non_manifold_edge).locations.size()) {
        // Not every non-manifold edge is listed: mark their components from the table.
        for_each_edge_in(state, 0, mesh.vertex_count(), [&](std::uint32_t lo, std::uint32_t, std::span<const HalfEdgeEntry> edge) {
            std::uint32_t kept = 0;
            for (const HalfEdgeEntry& h : edge) kept += state.face_status[h.face()] == face_kept;
            if (kept > 2) state.component_has_boundary[state.vertex_component[lo]] = 1;
        });
    }
}

void check_orientation(CheckState& state) {
    if (state.inconsistent_edges == 0) return;
    const IndexedMesh& mesh = state.mesh;
    const std::size_t face_count = mesh.face_count();
    // Faces joined by manifold edges, with whether they disagree across that edge.
    std::vector<std::uint32_t> degree(face_count + 1, 0);
    struct Link {
        std::uint32_t f, g;
        bool disagree;
    };
    std::vector<Link> links;
    for_each_edge_in(state, 0, mesh.vertex_count(), [&](std::uint32_t, std::uint32_t, std::span<const HalfEdgeEntry> edge) {
        HalfEdgeEntry kept[2];
        std::uint32_t n = 0;
        for (const HalfEdgeEntry& h : edge)
            if (state.face_status[h.face()] == face_kept) {
                if (n < 2) kept[n] = h;
                ++n;
            }
        if (n != 2) return;
        const HalfEdgeEntry& h0 = kept[0];
        const HalfEdgeEntry& h1 = kept[1];
        links.push_back({h0.face(), h1.face(), h0.forward() == h1.forward()});
    });
    for (const Link& l : links) {
        ++degree[l.f + 1];
        ++degree[l.g + 1];
    }
    std::partial_sum(degree.begin(), degree.end(), degree.begin());
    std::vector<std::pair<std::uint32_t, bool>> adjacent(degree.back());
    {
        std::vector<std::uint32_t> cursor(degree.begin(), degree.end() - 1);
        for (const Link& l : links) {
            adjacent[cursor[l.f]++] = {l.g, l.disagree};
            adjacent[cursor[l.g]++] = {l.f, l.disagree};
        }
    }
    links.clear();
    links.shrink_to_fit();

    // Two-colour each piece by relative orientation; the smaller colour class is flipped
    // (on a tie, the class of the piece's first face is taken as right).
    std::vector<std::int8_t> side(face_count, -1);
    state.face_flipped.assign(face_count, 0);
    std::vector<std::uint32_t> piece;
    std::queue<std::uint32_t> queue;
    for (std::uint32_t seed = 0; seed < face_count; ++seed) {
        if (state.face_status[seed] != face_kept || side[seed] >= 0) continue;
        piece.clear();
        side[seed] = 0;
        queue.push(seed);
        std::size_t ones = 0;
        while (!queue.empty()) {
            const std::uint32_t f = queue.front();
            queue.pop();
            piece.push_back(f);
            ones += side[f];
            for (std::uint32_t i = degree[f]; i < degree[f + 1]; ++i) {
                const auto [g, disagree] = adjacent[i];
                if (side[g] >= 0) continue;  // a conflict here means a non-orientable piece
                side[g] = static_cast<std::int8_t>(side[f] ^ (disagree ? 1 : 0));
                queue.push(g);
            }
        }
        const std::int8_t flipped_side = ones * 2 > piece.size() ? 0 : 1;
        for (std::uint32_t f : piece)
            if (side[f] == flipped_side) state.face_flipped[f] = 1;
    }
    for (std::uint32_t f = 0; f < face_count; ++f)
        if (state.face_flipped[f]) state.report.flipped_faces.push_back(f);
}

void trace_boundary_loops(CheckState& state) {
    const IndexedMesh& mesh = state.mesh;
    const auto& boundary = state.boundary;  // sorted by (from, to, face)
    state.loop_of_boundary.assign(boundary.size(), kNoIndex);
    auto first_out = [&](std::uint32_t v) {
        return static_cast<std::size_t>(
            std::lower_bound(boundary.begin(), boundary.end(), BoundaryHalfEdge{v, 0, 0}) - boundary.begin());
    };
    for (std::size_t start = 0; start < boundary.size(); ++start) {
        if (state.loop_of_boundary[start] != kNoIndex) continue;
        const auto loop_id = static_cast<std::uint32_t>(state.loops.size());
        BoundaryLoop loop;
        std::size_t current = start;
        while (true) {
            const BoundaryHalfEdge& h = boundary[current];
            state.loop_of_boundary[current] = loop_id;
            loop.vertices.push_back(h.from);
            loop.length += glm::distance(mesh.positions[h.from], mesh.positions[h.to]);
            ++loop.edge_count;
            if (h.to == boundary[start].from) break;
            // Continue with an unused boundary half-edge leaving h.to; where the surface is
            // pinched there (several fans), with one of the same fan as h's face, so that
            // each loop follows one sheet of faces.
            std::size_t next = boundary.size();
            const auto fan_of = [&](std::uint32_t face) {
                const auto it = state.fan_at_pinch.find(std::uint64_t(h.to) << 32 | face);
                return it == state.fan_at_pinch.end() ? kNoIndex : it->second;
            };
            const std::uint32_t fan_in = state.fan_at_pinch.empty() ? kNoIndex : fan_of(h.face);
            for (std::size_t c = first_out(h.to); c < boundary.size() && boundary[c].from == h.to; ++c) {
                if (state.loop_of_boundary[c] != kNoIndex) continue;
                if (next == boundary.size()) next = c;
                if (fan_in != kNoIndex && fan_of(boundary[c].face) == fan_in) {
                    next = c;
                    break;
                }
            }
            if (next >= boundary.size()) {
                loop.closed = false;
                loop.vertices.push_back(h.to);
                break;
            }
            current = next;
        }
        // Vector area (Newell) about the first vertex, and the centroid.
        glm::dvec3 area(0.0), centroid(0.0);
        const glm::dvec3 origin = mesh.positions[loop.vertices[0]];
        for (std::size_t i = 0; i < loop.vertices.size(); ++i) {
            const glm::dvec3 p = mesh.positions[loop.vertices[i]] - origin;
            const glm::dvec3 q = mesh.positions[loop.vertices[(i + 1) % loop.vertices.size()]] - origin;
            area += 0.5 * glm::cross(p, q);
            centroid += p;
        }
        loop.area = glm::length(area);
        loop.centroid = origin + centroid / double(loop.vertices.size());
        state.loops.push_back(std::move(loop));
    }
}

namespace {

double point_segment_distance(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b) {
    const glm::dvec3 ab = b - a;
    const double length2 = glm::dot(ab, ab);
    const double t = length2 > 0.0 ? std::clamp(glm::dot(p - a, ab) / length2, 0.0, 1.0) : 0.0;
    return glm::distance(p, a + t * ab);
}

// BoundaryLoop::gap. Quadratic in the loop's vertices: a loop of more than kGapVertices is
// measured on every k-th vertex (its sides' segments joining those).
double loop_gap(const IndexedMesh& mesh, const BoundaryLoop& loop) {
    constexpr std::size_t kGapVertices = 2048;
    const std::size_t stride = loop.vertices.size() / kGapVertices + 1;
    std::vector<glm::dvec3> p;
    for (std::size_t i = 0; i < loop.vertices.size(); i += stride) p.push_back(mesh.positions[loop.vertices[i]]);
    const std::size_t n = p.size();
    if (n < 3) return n == 2 ? glm::distance(p[0], p[1]) : 0.0;
    std::size_t a = 0, b = 0;
    double farthest = -1.0;
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i + 1; j < n; ++j)
            if (const double d = glm::distance(p[i], p[j]); d > farthest) {
                farthest = d;
                a = i;
                b = j;
            }
    // Side one: a .. b; side two: b .. a around the loop (the two share their ends).
    const auto distance_to_side = [&](const glm::dvec3& q, std::size_t from, std::size_t to) {
        double best = std::numeric_limits<double>::infinity();
        for (std::size_t k = from; k != to; k = (k + 1) % n) best = std::min(best, point_segment_distance(q, p[k], p[(k + 1) % n]));
        return best;
    };
    double gap = 0.0;
    for (std::size_t k = a; k != b; k = (k + 1) % n) gap = std::max(gap, distance_to_side(p[k], b, a));
    for (std::size_t k = b; k != a; k = (k + 1) % n) gap = std::max(gap, distance_to_side(p[k], a, b));
    return gap;
}

}  // namespace

// A mesh with closed parts and open ones (a model standing on a plate, as the PN triangles
// scene is) is judged per component: a component with a boundary whose every face is seen
// from one side along the component's own up axis (the terrain rule of
// analyse_face_geometry, per component) is an open sheet, and its outer outline, the closed
// loop of the largest area, is allowed; every other boundary is a defect, as under the closed
// rules the rest of the mesh is held to.
void judge_sheets(CheckState& state) {
    const IndexedMesh& mesh = state.mesh;
    const std::size_t components = state.component_has_boundary.size();
    std::vector<glm::dvec3> area(components, glm::dvec3(0.0));
    for (std::size_t f = 0; f < mesh.face_count(); ++f)
        if (state.face_status[f] == face_kept) area[state.vertex_component[mesh.face(f)[0]]] += face_vector_area(mesh, f);
    std::vector<int> up_axis(components, 2);
    std::vector<double> up_sign(components, 1.0);
    state.component_is_sheet.assign(components, 0);
    for (std::size_t c = 0; c < components; ++c) {
        const glm::dvec3 m = glm::abs(area[c]);
        up_axis[c] = m.x >= m.y && m.x >= m.z ? 0 : (m.y >= m.z ? 1 : 2);
        up_sign[c] = area[c][up_axis[c]] < 0.0 ? -1.0 : 1.0;
        state.component_is_sheet[c] = state.component_has_boundary[c] && m[up_axis[c]] > 0.0;
    }
    for (std::size_t f = 0; f < mesh.face_count(); ++f) {
        if (state.face_status[f] != face_kept) continue;
        const std::uint32_t c = state.vertex_component[mesh.face(f)[0]];
        if (!state.component_is_sheet[c]) continue;
        const glm::dvec3 a = face_vector_area(mesh, f);
        if (up_sign[c] * a[up_axis[c]] < -1e-6 * glm::length(a)) state.component_is_sheet[c] = 0;
    }
    std::vector<int> outline(components, -1);
    for (std::size_t i = 0; i < state.loops.size(); ++i) {
        const BoundaryLoop& loop = state.loops[i];
        if (!loop.closed || loop.vertices.empty()) continue;
        const std::uint32_t c = state.vertex_component[loop.vertices.front()];
        if (c >= components || !state.component_is_sheet[c]) continue;
        if (outline[c] < 0 || loop.area > state.loops[static_cast<std::size_t>(outline[c])].area) outline[c] = static_cast<int>(i);
    }
    for (std::size_t c = 0; c < components; ++c) {
        if (outline[c] < 0) continue;
        state.loops[static_cast<std::size_t>(outline[c])].allowed = true;
        ++state.report.open_sheets;
    }
}

void judge_boundary(CheckState& state) {
    CheckReport& report = state.report;
    const bool open_rules = report.expect == Expect::open ||
                            (report.expect == Expect::automatic && !report.closed && report.terrain_like);
    report.judged_as = open_rules ? "open" : "closed";
    if (open_rules) {
        // The outer outline: the closed loop that bounds the most area.
        double best = -1.0;
        for (std::size_t i = 0; i < state.loops.size(); ++i)
            if (state.loops[i].closed && state.loops[i].area > best) {
                best = state.loops[i].area;
                state.allowed_loop = static_cast<int>(i);
            }
        if (state.allowed_loop >= 0) state.loops[state.allowed_loop].allowed = true;
    } else if (report.expect == Expect::automatic && !report.closed) {
        judge_sheets(state);
    }

    // Faces of each loop's edges, for locating.
    std::vector<std::vector<std::uint32_t>> loop_faces(std::min(state.loops.size(), state.options.max_locations + 1));
    for (std::size_t i = 0; i < state.boundary.size(); ++i) {
        const std::uint32_t loop = state.loop_of_boundary[i];
        if (loop < loop_faces.size() && loop_faces[loop].size() < 64) loop_faces[loop].push_back(state.boundary[i].face);
    }
    for (std::size_t i = 0; i < state.loops.size(); ++i) {
        BoundaryLoop& loop = state.loops[i];
        if (loop.allowed) continue;
        loop.gap = loop_gap(state.mesh, loop);
        Defect d;
        d.position = loop.centroid;
        d.vertices.assign(loop.vertices.begin(), loop.vertices.begin() + std::min<std::size_t>(loop.vertices.size(), 64));
        if (i < loop_faces.size()) {
            d.faces = loop_faces[i];
            std::sort(d.faces.begin(), d.faces.end());
            d.faces.erase(std::unique(d.faces.begin(), d.faces.end()), d.faces.end());
        }
        d.measure = loop.length;
        d.detail = std::string(loop.closed ? "boundary loop" : "open boundary chain") + " of " +
                   std::to_string(loop.edge_count) + " edges, length " + format_number(loop.length) +
                   ", largest gap " + format_number(loop.gap) + (open_rules ? ", not the outer outline" : "");
        state.add_defect(DefectClass::boundary_loop, std::move(d));
    }

    report.boundary_loop_count = state.loops.size();
    // Loops for the report: the allowed one, then the largest.
    std::vector<std::size_t> order(state.loops.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        if (state.loops[a].allowed != state.loops[b].allowed) return state.loops[a].allowed;
        return state.loops[a].area > state.loops[b].area;
    });
    for (std::size_t i = 0; i < order.size() && i < state.options.max_locations; ++i)
        report.boundary_loops.push_back(state.loops[order[i]]);
}

}  // namespace tessref::check_detail
