// The geometric steps of check_mesh() (topology.cpp has the ones on the face list alone):
// areas, the signed volume, degenerate faces, the up axis of a terrain, unwelded coincident
// vertices and T-junctions. Neighbour searches use hashed uniform grids (cells a few
// tolerances wide), so they stay linear in the mesh size.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numeric>
#include <span>
#include <string>
#include <unordered_map>

#include "common/parallel.h"

#include "check/check_internal.h"

namespace tessref::check_detail {

namespace {

constexpr std::size_t kFaceChunk = 1 << 14;
constexpr std::size_t kVertexChunk = 1 << 14;

// Spreads the low 21 bits of x to every third bit.
std::uint64_t spread_bits(std::uint64_t x) {
    x &= 0x1fffff;
    x = (x | x << 32) & 0x1f00000000ffffull;
    x = (x | x << 16) & 0x1f0000ff0000ffull;
    x = (x | x << 8) & 0x100f00f00f00f00full;
    x = (x | x << 4) & 0x10c30c30c30c30c3ull;
    x = (x | x << 2) & 0x1249249249249249ull;
    return x;
}

// The Morton (Z-order) code of a cell: nearby cells get nearby codes, so points sorted by
// it are visited in space order (and their positions read nearly in memory order). Cells
// 2^21 apart share a code; they only cost a distance test.
std::uint64_t cell_key(std::int64_t x, std::int64_t y, std::int64_t z) {
    return spread_bits(static_cast<std::uint64_t>(x)) | spread_bits(static_cast<std::uint64_t>(y)) << 1 |
           spread_bits(static_cast<std::uint64_t>(z)) << 2;
}

// A uniform grid over a set of points: their entries sorted by cell, so a cell's points
// are adjacent and a cell is found by binary search.
class PointGrid {
public:
    struct Entry {
        std::uint64_t key;  // the cell's code
        std::uint32_t id;   // the point's index
        auto operator<=>(const Entry&) const = default;
    };

    // The points i of `points` for which include(i). Each entry is written once, by the
    // thread that computes its cell (a std::vector would first clear them all on one
    // thread: 19 MB for 1.2 M points, after the kernel cleared the fresh pages); a point
    // left out takes a code no cell has, which sorts after every cell's, and is cut off.
    template <class Include>
    PointGrid(std::span<const glm::dvec3> points, Include&& include, glm::dvec3 origin, double cell)
        : origin_(origin), cell_(cell) {
        entries_.allocate(points.size());
        tessref::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 1 << 14), [&](const auto& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                const auto id = static_cast<std::uint32_t>(i);
                if (!include(id)) {
                    entries_[i] = {kLeftOut, id};
                    continue;
                }
                const glm::i64vec3 c = cell_of(points[i]);
                entries_[i] = {cell_key(c.x, c.y, c.z), id};
            }
        });
        tessref::parallel_sort(entries_.begin(), entries_.end());
        size_ = static_cast<std::size_t>(std::lower_bound(entries_.begin(), entries_.end(), Entry{kLeftOut, 0}) -
                                         entries_.begin());
    }

    glm::i64vec3 cell_of(const glm::dvec3& p) const {
        return glm::i64vec3(glm::floor((p - origin_) / cell_));
    }

    // Calls fn(id) for every point filed under cell c (and, rarely, a cell sharing its code).
    template <class Fn>
    void visit(const glm::i64vec3& c, Fn&& fn) const {
        const std::uint64_t key = cell_key(c.x, c.y, c.z);
        const Entry* end = entries_.begin() + size_;
        for (auto it = std::lower_bound(entries_.begin(), end, Entry{key, 0}); it != end && it->key == key; ++it) fn(it->id);
    }

    double cell() const { return cell_; }
    // The points in cell order: entry(i) = (cell key, id); a cell's points are adjacent.
    std::size_t size() const { return size_; }
    const Entry& entry(std::size_t i) const { return entries_[i]; }

private:
    // Above every cell code (cell_key() sets the low 63 bits at most).
    static constexpr std::uint64_t kLeftOut = std::numeric_limits<std::uint64_t>::max();
    glm::dvec3 origin_;
    double cell_;
    Table<Entry> entries_;
    std::size_t size_ = 0;
};

// Point-to-segment: the parameter along a->b of the closest point, and the distance.
struct SegmentDistance {
    double t;
    double distance;
};
SegmentDistance segment_distance(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b) {
    const glm::dvec3 ab = b - a;
    const double len2 = glm::dot(ab, ab);
    const double t = len2 > 0.0 ? glm::dot(p - a, ab) / len2 : 0.0;
    return {t, glm::distance(p, a + glm::clamp(t, 0.0, 1.0) * ab)};
}

}  // namespace

glm::dvec3 face_vector_area(const IndexedMesh& mesh, std::size_t f) {
    const auto face = mesh.face(f);
    if (face.size() < 3) return glm::dvec3(0.0);
    const glm::dvec3 o = mesh.positions[face[0]];
    glm::dvec3 sum(0.0);
    for (std::size_t k = 1; k + 1 < face.size(); ++k)
        sum += glm::cross(mesh.positions[face[k]] - o, mesh.positions[face[k + 1]] - o);
    return 0.5 * sum;
}

std::string format_number(double x) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.6g", x);
    return buffer;
}

std::string format_point(const glm::dvec3& p) {
    return "(" + format_number(p.x) + ", " + format_number(p.y) + ", " + format_number(p.z) + ")";
}

void analyse_face_geometry(CheckState& state) {
    const IndexedMesh& mesh = state.mesh;
    CheckReport& report = state.report;
    const glm::dvec3 reference = 0.5 * (state.bbox_min + state.bbox_max);
    const bool have_flips = !state.face_flipped.empty();
    struct ComponentSums {
        double volume = 0.0;  // with flipped faces turned back
        std::size_t faces = 0;
        std::uint32_t first_face = kNoIndex;
    };
    struct ChunkResult {
        double area = 0.0, volume_as_listed = 0.0;
        glm::dvec3 vector_area{0.0};
        std::size_t triangles = 0;
        std::map<std::uint32_t, ComponentSums> components;
        std::vector<Defect> degenerate;
        std::size_t degenerate_count = 0;
        // Per axis: whether some face turns away from +axis / from -axis (the terrain test
        // below, for whichever axis turns out to be up).
        bool turned_from_plus[3] = {false, false, false}, turned_from_minus[3] = {false, false, false};
    };
    const std::size_t cap = state.options.max_locations;
    const double tolerance = state.tolerance;
    auto results = map_chunks<ChunkResult>(mesh.face_count(), kFaceChunk, [&](std::size_t f0, std::size_t f1, ChunkResult& out) {
        // Faces of one component come in runs: look its sums up once a run.
        std::uint32_t component = kNoIndex;
        ComponentSums* sums = nullptr;
        for (std::size_t f = f0; f < f1; ++f) {
            const auto face = mesh.face(f);
            if (face.size() >= 3) out.triangles += face.size() - 2;
            if (state.face_status[f] != face_kept) continue;
            const glm::dvec3 a = face_vector_area(mesh, f);
            const double area = glm::length(a);
            double volume = 0.0;
            const glm::dvec3 o = mesh.positions[face[0]] - reference;
            for (std::size_t k = 1; k + 1 < face.size(); ++k)
                volume += glm::dot(o, glm::cross(mesh.positions[face[k]] - reference, mesh.positions[face[k + 1]] - reference));
            volume /= 6.0;
            const double sign = have_flips && state.face_flipped[f] ? -1.0 : 1.0;
            out.area += area;
            out.volume_as_listed += volume;
            const glm::dvec3 oriented = sign * a;
            out.vector_area += oriented;
            for (int k = 0; k < 3; ++k) {
                out.turned_from_plus[k] = out.turned_from_plus[k] || oriented[k] < -1e-6 * area;
                out.turned_from_minus[k] = out.turned_from_minus[k] || -oriented[k] < -1e-6 * area;
            }
            if (state.vertex_component[face[0]] != component || !sums) {
                component = state.vertex_component[face[0]];
                sums = &out.components[component];  // std::map: the address stays valid
            }
            sums->volume += sign * volume;
            ++sums->faces;
            sums->first_face = std::min(sums->first_face, static_cast<std::uint32_t>(f));

            // Degenerate: the face is thinner than the tolerance across its longest edge.
            double longest = 0.0;
            for (std::size_t k = 0; k < face.size(); ++k)
                longest = std::max(longest, glm::distance(mesh.positions[face[k]], mesh.positions[face[(k + 1) % face.size()]]));
            const double height = longest > 0.0 ? 2.0 * area / longest : 0.0;
            if (height <= tolerance) {
                ++out.degenerate_count;
                if (out.degenerate.size() < cap) {
                    Defect d;
                    glm::dvec3 centre(0.0);
                    for (std::uint32_t v : face) centre += mesh.positions[v];
                    d.position = centre / double(face.size());
                    d.faces = {static_cast<std::uint32_t>(f)};
                    d.vertices.assign(face.begin(), face.end());
                    d.measure = height;
                    d.detail = "face " + std::to_string(f) + " has zero area (height " + format_number(height) +
                               " across its longest edge " + format_number(longest) + ")";
                    out.degenerate.push_back(std::move(d));
                }
            }
        }
    });

    std::vector<ComponentSums> components(report.component_count);
    glm::dvec3 vector_area(0.0);
    bool turned_from_plus[3] = {false, false, false}, turned_from_minus[3] = {false, false, false};
    auto& degenerate = report.defects[int(DefectClass::degenerate_face)];
    for (ChunkResult& r : results) {
        report.surface_area += r.area;
        report.signed_volume += r.volume_as_listed;
        report.triangle_count += r.triangles;
        vector_area += r.vector_area;
        for (const auto& [id, sums] : r.components) {
            ComponentSums& c = components[id];
            c.volume += sums.volume;
            c.faces += sums.faces;
            c.first_face = std::min(c.first_face, sums.first_face);
        }
        for (int k = 0; k < 3; ++k) {
            turned_from_plus[k] = turned_from_plus[k] || r.turned_from_plus[k];
            turned_from_minus[k] = turned_from_minus[k] || r.turned_from_minus[k];
        }
        degenerate.count += r.degenerate_count;
        for (Defect& d : r.degenerate)
            if (degenerate.locations.size() < cap) degenerate.locations.push_back(std::move(d));
    }
    // Faces with a repeated vertex are degenerate too (reported before the zero-area ones).
    state.report.triangle_count = report.triangle_count;

    // Up: the axis the surface faces along most.
    const glm::dvec3 magnitude = glm::abs(vector_area);
    state.up_axis = magnitude.x >= magnitude.y && magnitude.x >= magnitude.z ? 0 : (magnitude.y >= magnitude.z ? 1 : 2);
    state.up_sign = vector_area[state.up_axis] < 0.0 ? -1.0 : 1.0;
    report.up_axis = state.up_axis;

    // A terrain: open, and no face turned away from up (vertical walls allowed): for no
    // face up_sign * a[up] < -1e-6 |a|, a its oriented vector area (negating is exact, so
    // the flags above, taken for both signs, decide it exactly).
    if (!report.closed && magnitude[state.up_axis] > 0.0)
        report.terrain_like = !(state.up_sign > 0.0 ? turned_from_plus : turned_from_minus)[state.up_axis];

    // Closed components must enclose a positive volume (faces pointing outward).
    for (std::uint32_t c = 0; c < components.size(); ++c) {
        if (state.component_has_boundary[c] || components[c].faces == 0) continue;
        if (components[c].volume >= 0.0) continue;
        Defect d;
        const std::uint32_t f = components[c].first_face;
        const auto face = mesh.face(f);
        glm::dvec3 centre(0.0);
        for (std::uint32_t v : face) centre += mesh.positions[v];
        d.position = centre / double(face.size());
        d.faces = {f};
        d.measure = components[c].volume;
        d.detail = "closed component " + std::to_string(c) + " (" + std::to_string(components[c].faces) +
                   " faces, starting at face " + std::to_string(f) + ") encloses a negative volume " +
                   format_number(components[c].volume) + ": its faces point inward";
        state.add_defect(DefectClass::inverted_volume, std::move(d));
    }
}

void find_coincident_vertices(CheckState& state) {
    const IndexedMesh& mesh = state.mesh;
    // The vertices a face uses, at finite positions.
    const auto searched = [&](std::uint32_t v) {
        const glm::dvec3& p = mesh.positions[v];
        return state.vertex_referenced[v] && std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
    };
    const double tolerance = state.tolerance;
    auto equal_position = [&](std::uint32_t a, std::uint32_t b) { return mesh.positions[a] == mesh.positions[b]; };

    // Pairs (v, u), v < u, closer than the tolerance (or equal when the tolerance is 0).
    std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
    if (tolerance > 0.0) {
        // Cells much wider than the tolerance: a point looks into a neighbour cell only when
        // it lies within the tolerance of the face between them (a few percent of points),
        // and into its own cell by walking its run of the grid's sorted entries.
        const double cell = std::max(32.0 * tolerance, 1e-12 * std::max(1.0, state.diagonal));
        const PointGrid grid(mesh.positions, searched, state.bbox_min, cell);
        auto parts = map_chunks<std::vector<std::pair<std::uint32_t, std::uint32_t>>>(
            grid.size(), kVertexChunk, [&](std::size_t i0, std::size_t i1, auto& out) {
                for (std::size_t i = i0; i < i1; ++i) {
                    // Not a structured binding: the lambda below captures v, which clang 15
                    // (the fuzz build's compiler) cannot do for a binding.
                    const auto key = grid.entry(i).key;
                    const std::uint32_t v = grid.entry(i).id;
                    const glm::dvec3 p = mesh.positions[v];
                    for (std::size_t j = i + 1; j < grid.size() && grid.entry(j).key == key; ++j) {
                        const std::uint32_t u = grid.entry(j).id;
                        if (glm::distance(p, mesh.positions[u]) <= tolerance) out.emplace_back(std::min(u, v), std::max(u, v));
                    }
                    const glm::i64vec3 c = grid.cell_of(p);
                    const glm::dvec3 local = (p - state.bbox_min) / cell - glm::dvec3(c);
                    int lo[3], hi[3];
                    bool near_face = false;
                    for (int k = 0; k < 3; ++k) {
                        lo[k] = local[k] * cell <= tolerance ? -1 : 0;
                        hi[k] = (1.0 - local[k]) * cell <= tolerance ? 1 : 0;
                        near_face = near_face || lo[k] != 0 || hi[k] != 0;
                    }
                    if (!near_face) continue;
                    for (int dx = lo[0]; dx <= hi[0]; ++dx)
                        for (int dy = lo[1]; dy <= hi[1]; ++dy)
                            for (int dz = lo[2]; dz <= hi[2]; ++dz) {
                                if (dx == 0 && dy == 0 && dz == 0) continue;
                                grid.visit(c + glm::i64vec3(dx, dy, dz), [&](std::uint32_t u) {
                                    if (u > v && glm::distance(p, mesh.positions[u]) <= tolerance) out.emplace_back(v, u);
                                });
                            }
                }
            });
        pairs = concatenate(std::move(parts));
        tessref::parallel_sort(pairs.begin(), pairs.end());
        pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    } else {
        std::vector<std::uint32_t> sorted;
        for (std::uint32_t v = 0; v < mesh.vertex_count(); ++v)
            if (searched(v)) sorted.push_back(v);
        auto less = [&](std::uint32_t a, std::uint32_t b) {
            const glm::dvec3 &p = mesh.positions[a], &q = mesh.positions[b];
            if (p.x != q.x) return p.x < q.x;
            if (p.y != q.y) return p.y < q.y;
            if (p.z != q.z) return p.z < q.z;
            return a < b;
        };
        tessref::parallel_sort(sorted.begin(), sorted.end(), less);
        for (std::size_t i = 0; i < sorted.size();) {
            std::size_t j = i + 1;
            while (j < sorted.size() && equal_position(sorted[i], sorted[j])) ++j;
            for (std::size_t k = i + 1; k < j; ++k) pairs.emplace_back(sorted[i], sorted[k]);
            i = j;
        }
        std::sort(pairs.begin(), pairs.end());
    }
    if (pairs.empty()) return;

    // Group: equal positions into one class, chains of near pairs into the other.
    std::unordered_map<std::uint32_t, std::uint32_t> exact_parent, near_parent;
    auto find = [](std::unordered_map<std::uint32_t, std::uint32_t>& parent, std::uint32_t x) {
        auto it = parent.try_emplace(x, x).first;
        while (it->second != x) {
            x = it->second;
            it = parent.find(x);
        }
        return x;
    };
    auto unite = [&](std::unordered_map<std::uint32_t, std::uint32_t>& parent, std::uint32_t a, std::uint32_t b) {
        a = find(parent, a);
        b = find(parent, b);
        if (a != b) parent[std::max(a, b)] = std::min(a, b);
    };
    // Two vertices joined by an edge are a short edge, not a weld that was missed (a face
    // too thin to matter is reported as degenerate instead).
    VertexStar star;
    auto joined = [&](std::uint32_t v, std::uint32_t u) {
        const std::uint32_t lo = std::min(v, u), hi = std::max(v, u);
        star.make(state, lo);
        return std::any_of(star.half_edges.begin(), star.half_edges.end(), [&](const HalfEdgeEntry& h) {
            return h.other == hi && state.face_status[h.face()] == face_kept;
        });
    };
    for (const auto& [v, u] : pairs) {
        if (equal_position(v, u)) unite(exact_parent, v, u);
        else if (!joined(v, u)) unite(near_parent, v, u);
    }
    auto emit = [&](std::unordered_map<std::uint32_t, std::uint32_t>& parent, DefectClass kind) {
        std::map<std::uint32_t, std::vector<std::uint32_t>> groups;  // by smallest vertex
        for (const auto& [v, p] : parent) groups[find(parent, v)].push_back(v);
        for (auto& [root, members] : groups) {
            std::sort(members.begin(), members.end());
            Defect d;
            d.position = mesh.positions[root];
            double spread = 0.0;
            for (std::uint32_t m : members) spread = std::max(spread, glm::distance(mesh.positions[root], mesh.positions[m]));
            d.measure = spread;
            d.detail = std::to_string(members.size()) + " vertices " +
                       (kind == DefectClass::coincident_vertices ? std::string("at the same position")
                                                                 : "within " + format_number(spread) + " of each other") +
                       ", not welded";
            if (members.size() > 32) members.resize(32);
            d.vertices = std::move(members);
            state.add_defect(kind, std::move(d));
        }
    };
    emit(exact_parent, DefectClass::coincident_vertices);
    emit(near_parent, DefectClass::near_coincident_vertices);
}

void find_t_junctions(CheckState& state) {
    const IndexedMesh& mesh = state.mesh;
    const auto& boundary = state.boundary;
    if (boundary.empty()) return;
    const double tolerance = state.tolerance;
    // On a terrain, look from above: a patch edge whose midpoint was displaced differently
    // on its two sides opens a crack that is vertical, far wider than the tolerance in 3D
    // but nothing seen from above.
    const bool from_above = state.report.terrain_like;
    const int up = state.up_axis;
    auto flat = [&](glm::dvec3 p) {
        if (from_above) p[up] = 0.0;
        return p;
    };

    std::vector<std::uint32_t> vertices;
    vertices.reserve(2 * boundary.size());
    double total_length = 0.0;
    for (const BoundaryHalfEdge& h : boundary) {
        vertices.push_back(h.from);
        vertices.push_back(h.to);
        total_length += glm::distance(flat(mesh.positions[h.from]), flat(mesh.positions[h.to]));
    }
    std::sort(vertices.begin(), vertices.end());
    vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
    // The boundary vertices' flat positions, by their rank in `vertices` (ascending ids, so
    // the grid's cells list them in the order of their ids): a table over every vertex of
    // the mesh would be fresh pages for a few thousand entries, on one thread.
    std::vector<glm::dvec3> flat_positions(vertices.size());
    for (std::size_t i = 0; i < vertices.size(); ++i) flat_positions[i] = flat(mesh.positions[vertices[i]]);

    const double mean_length = total_length / double(boundary.size());
    const double cell = std::max({mean_length, 4.0 * tolerance, 1e-12 * std::max(1.0, state.diagonal)});
    glm::dvec3 origin = flat(state.bbox_min);
    // (Seen from above, the up coordinate is zero everywhere, so the grid is one cell thick.)
    const PointGrid grid(flat_positions, [](std::uint32_t) { return true; }, origin, cell);

    struct Found {
        std::uint32_t vertex, edge;
        double distance_3d, distance_flat;
    };
    auto parts = map_chunks<std::vector<Found>>(boundary.size(), 1 << 12, [&](std::size_t e0, std::size_t e1, std::vector<Found>& out) {
        for (std::size_t e = e0; e < e1; ++e) {
            const BoundaryHalfEdge& h = boundary[e];
            const glm::dvec3 a = flat(mesh.positions[h.from]), b = flat(mesh.positions[h.to]);
            const double length = glm::distance(a, b);
            if (length <= 2.0 * tolerance) continue;
            const glm::i64vec3 c0 = grid.cell_of(glm::min(a, b) - glm::dvec3(tolerance));
            const glm::i64vec3 c1 = grid.cell_of(glm::max(a, b) + glm::dvec3(tolerance));
            const std::int64_t cells = (c1.x - c0.x + 1) * (c1.y - c0.y + 1) * (c1.z - c0.z + 1);
            const auto own = mesh.face(h.face);
            auto test = [&](std::uint32_t rank) {
                const std::uint32_t v = vertices[rank];
                if (std::find(own.begin(), own.end(), v) != own.end()) return;  // another face's edge only
                const glm::dvec3 p = flat_positions[rank];
                const SegmentDistance s = segment_distance(p, a, b);
                if (s.distance > tolerance) return;
                // Strictly inside the edge: farther than the tolerance from both ends.
                if (glm::distance(p, a) <= tolerance || glm::distance(p, b) <= tolerance) return;
                const double d3 = segment_distance(mesh.positions[v], mesh.positions[h.from], mesh.positions[h.to]).distance;
                out.push_back({v, static_cast<std::uint32_t>(e), d3, s.distance});
            };
            if (cells > 4096) {
                // A very long edge against a fine grid: test every boundary vertex instead.
                for (std::uint32_t rank = 0; rank < vertices.size(); ++rank) test(rank);
                continue;
            }
            for (std::int64_t x = c0.x; x <= c1.x; ++x)
                for (std::int64_t y = c0.y; y <= c1.y; ++y)
                    for (std::int64_t z = c0.z; z <= c1.z; ++z) grid.visit(glm::i64vec3(x, y, z), test);
        }
    });
    std::vector<Found> found = concatenate(std::move(parts));
    std::sort(found.begin(), found.end(), [](const Found& x, const Found& y) {
        return x.edge != y.edge ? x.edge < y.edge : x.vertex < y.vertex;
    });
    found.erase(std::unique(found.begin(), found.end(), [](const Found& x, const Found& y) {
                    return x.edge == y.edge && x.vertex == y.vertex;
                }),
                found.end());
    for (const Found& t : found) {
        const BoundaryHalfEdge& h = boundary[t.edge];
        Defect d;
        d.position = mesh.positions[t.vertex];
        d.vertices = {t.vertex, h.from, h.to};
        d.faces = {h.face};
        d.measure = t.distance_3d;
        d.detail = "vertex " + std::to_string(t.vertex) + " lies on edge " + std::to_string(h.from) + "-" +
                   std::to_string(h.to) + " of face " + std::to_string(h.face);
        if (t.distance_3d > tolerance)
            d.detail += " seen from above; the surfaces there are " + format_number(t.distance_3d) + " apart (a crack)";
        else
            d.detail += " (distance " + format_number(t.distance_3d) + ")";
        state.add_defect(DefectClass::t_junction, std::move(d));
    }
}

// On a terrain, the faces whose oriented normal points down its up axis (the axis's positive
// direction is up: GL's terrains lie in the xy plane with z up, or the xz plane with y up).
// A terrain's faces all turn one way (analyse_face_geometry), so either none faces down or
// every face does: the whole surface wound the other way, as a cw evaluation shader makes it.
void find_faces_facing_down(CheckState& state) {
    if (!state.report.terrain_like || state.up_sign > 0.0) return;
    const IndexedMesh& mesh = state.mesh;
    for (std::uint32_t f = 0; f < mesh.face_count(); ++f) {
        if (state.face_status[f] != face_kept) continue;
        if (!state.face_flipped.empty() && state.face_flipped[f]) continue;  // reported as a flip
        const auto face = mesh.face(f);
        glm::dvec3 normal(0.0), centre(0.0);
        for (std::size_t i = 0; i < face.size(); ++i) {
            const glm::dvec3& a = mesh.positions[face[i]];
            const glm::dvec3& b = mesh.positions[face[(i + 1) % face.size()]];
            normal += glm::cross(a, b);
            centre += a;
        }
        if (!(normal[state.up_axis] < 0.0)) continue;
        Defect d;
        d.position = centre / double(face.size());
        d.faces = {f};
        d.vertices.assign(face.begin(), face.end());
        d.detail = std::string("face ") + std::to_string(f) + " faces down " + "xyz"[state.up_axis] +
                   " (the terrain is wound the other way)";
        state.add_defect(DefectClass::facing_down, std::move(d));
    }
}

}  // namespace tessref::check_detail
