// Closing a terrain into a solid: skirt from the outer outline down to a base plane, and
// the base. See include/tessref/solid.h.
#include "tessref/solid.h"

#include <algorithm>
#include <array>
#include <limits>
#include <cmath>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

#include "tessref/error.h"

namespace tessref {

namespace {

double cross_z(glm::dvec2 o, glm::dvec2 a, glm::dvec2 b) { return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x); }

// Ear clipping of a counter-clockwise polygon; returns triangles (as polygon indices) in
// counter-clockwise order. Empty when it gets stuck (no ear left).
std::vector<std::array<std::size_t, 3>> clip_ears(const std::vector<glm::dvec2>& polygon) {
    std::vector<std::size_t> remaining(polygon.size());
    std::iota(remaining.begin(), remaining.end(), 0);
    std::vector<std::array<std::size_t, 3>> triangles;
    while (remaining.size() > 3) {
        bool clipped = false;
        for (std::size_t i = 0; i < remaining.size(); ++i) {
            const std::size_t p = remaining[(i + remaining.size() - 1) % remaining.size()];
            const std::size_t c = remaining[i];
            const std::size_t n = remaining[(i + 1) % remaining.size()];
            if (cross_z(polygon[p], polygon[c], polygon[n]) <= 0.0) continue;  // reflex or flat
            bool empty = true;
            for (std::size_t q : remaining) {
                if (q == p || q == c || q == n) continue;
                if (cross_z(polygon[p], polygon[c], polygon[q]) >= 0.0 && cross_z(polygon[c], polygon[n], polygon[q]) >= 0.0 &&
                    cross_z(polygon[n], polygon[p], polygon[q]) >= 0.0) {
                    empty = false;
                    break;
                }
            }
            if (!empty) continue;
            triangles.push_back({p, c, n});
            remaining.erase(remaining.begin() + static_cast<long>(i));
            clipped = true;
            break;
        }
        if (!clipped) return {};
    }
    if (cross_z(polygon[remaining[0]], polygon[remaining[1]], polygon[remaining[2]]) <= 0.0) return {};
    triangles.push_back({remaining[0], remaining[1], remaining[2]});
    return triangles;
}

// A position seen from above: its two coordinates across the up axis, (u, w, up) a
// right-handed frame.
struct TopView {
    int iu, iw;
    glm::dvec2 operator()(const glm::dvec3& p) const { return {p[iu], p[iw]}; }
};

// The boundary half-edges of a welded mesh: directed edges (from, to) whose edge no other
// triangle uses, sorted. Edges are filed by their smaller vertex and counted there.
std::vector<std::pair<std::uint32_t, std::uint32_t>> boundary_half_edges(const SurfaceMesh& mesh) {
    const std::size_t vertex_count = mesh.positions.size();
    std::vector<std::uint32_t> start(vertex_count + 1, 0);
    for (const auto& t : mesh.triangles)
        for (int k = 0; k < 3; ++k) ++start[std::min(t[k], t[(k + 1) % 3]) + 1];
    std::partial_sum(start.begin(), start.end(), start.begin());
    struct Entry {
        std::uint32_t other, from;
    };
    std::vector<Entry> entries(start.back());
    {
        std::vector<std::uint32_t> cursor(start.begin(), start.end() - 1);
        for (const auto& t : mesh.triangles)
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t a = t[k], b = t[(k + 1) % 3];
                entries[cursor[std::min(a, b)]++] = {std::max(a, b), a};
            }
    }
    std::vector<std::pair<std::uint32_t, std::uint32_t>> boundary;  // (from, to), sorted
    for (std::uint32_t v = 0; v < vertex_count; ++v) {
        auto first = entries.begin() + start[v], last = entries.begin() + start[v + 1];
        std::sort(first, last, [](const Entry& x, const Entry& y) { return x.other < y.other; });
        for (auto it = first; it != last;) {
            auto end = it + 1;
            while (end != last && end->other == it->other) ++end;
            if (end - it == 1) boundary.emplace_back(it->from, it->from == v ? it->other : v);
            it = end;
        }
    }
    std::sort(boundary.begin(), boundary.end());
    return boundary;
}

// The outer outline: of the closed loops the boundary half-edges form, the one enclosing the
// largest area seen from above, with its signed area (positive: counter-clockwise). Empty
// when no loop closes.
std::pair<std::vector<std::uint32_t>, double> outer_outline(
    const std::vector<std::pair<std::uint32_t, std::uint32_t>>& boundary, const std::vector<glm::dvec3>& positions,
    TopView flat) {
    std::vector<char> used(boundary.size(), 0);
    std::vector<std::uint32_t> outline;
    double outline_area = 0.0;
    for (std::size_t s = 0; s < boundary.size(); ++s) {
        if (used[s]) continue;
        std::vector<std::uint32_t> loop;
        std::size_t current = s;
        bool closed = false;
        while (true) {
            used[current] = 1;
            loop.push_back(boundary[current].first);
            const std::uint32_t to = boundary[current].second;
            if (to == boundary[s].first) {
                closed = true;
                break;
            }
            // Where several boundary edges leave `to` (patches that touch only there, a
            // crack reaching the outline), take the sharpest right turn: it keeps to the
            // outside, so the outline stays a simple polygon and the crack its own loop.
            const glm::dvec2 here = flat(positions[to]);
            const glm::dvec2 heading = here - flat(positions[boundary[current].first]);
            auto next = boundary.end();
            double best_turn = std::numeric_limits<double>::infinity();
            for (auto c = std::lower_bound(boundary.begin(), boundary.end(), std::make_pair(to, std::uint32_t{0}));
                 c != boundary.end() && c->first == to; ++c) {
                if (used[c - boundary.begin()]) continue;
                const glm::dvec2 out = flat(positions[c->second]) - here;
                const double turn = std::atan2(heading.x * out.y - heading.y * out.x, glm::dot(heading, out));
                if (turn < best_turn) {
                    best_turn = turn;
                    next = c;
                }
            }
            if (next == boundary.end()) break;
            current = static_cast<std::size_t>(next - boundary.begin());
        }
        if (!closed) continue;
        double area = 0.0;
        for (std::size_t i = 0; i < loop.size(); ++i) {
            const glm::dvec2 p = flat(positions[loop[i]]);
            const glm::dvec2 q = flat(positions[loop[(i + 1) % loop.size()]]);
            area += 0.5 * (p.x * q.y - q.x * p.y);
        }
        if (std::abs(area) > std::abs(outline_area)) {
            outline_area = area;
            outline = std::move(loop);
        }
    }
    return {std::move(outline), outline_area};
}

}  // namespace

SurfaceMesh close_terrain_into_solid(const SurfaceMesh& terrain, double base_z, int up_axis) {
    if (terrain.triangles.empty()) throw Error("cannot close a terrain without triangles into a solid");
    if (!std::isfinite(base_z)) throw Error("the base of the solid must be a finite height", Where::at_key("base_z"));
    if (up_axis < 0 || up_axis > 2) throw Error("the up axis must be 0, 1 or 2 (x, y or z)", Where::at_key("base_z"));
    // Seen from above: (u, w, up) is a right-handed frame.
    const int up = up_axis, iu = (up + 1) % 3, iw = (up + 2) % 3;
    const TopView flat{iu, iw};
    const auto on_base = [&](const glm::dvec3& p) {
        glm::dvec3 q = p;
        q[up] = base_z;
        return q;
    };
    glm::dvec3 down(0.0);
    down[up] = -1.0;

    // Weld as the mesh export does (bitwise-equal positions; attributes of the copy with
    // the lowest patch id). Triangles whose corners weld together are dropped there too.
    const WeldedMesh welded = weld_bitwise(terrain);
    SurfaceMesh solid = welded.mesh;
    const bool has_normals = !solid.normals.empty(), has_uvs = !solid.uvs.empty();
    const bool has_patches = !solid.patch_ids.empty(), has_coords = !solid.tess_coords.empty();
    auto copy_vertex = [&](std::uint32_t from, const glm::dvec3& position) {
        // (Copies first: push_back of an element of the same vector may reallocate under it.)
        solid.positions.push_back(position);
        if (has_normals) solid.normals.push_back(down);
        if (has_uvs) {
            const glm::dvec2 uv = solid.uvs[from];
            solid.uvs.push_back(uv);
        }
        if (has_patches) {
            const std::uint32_t patch = solid.patch_ids[from];
            solid.patch_ids.push_back(patch);
        }
        if (has_coords) {
            const glm::vec3 coord = solid.tess_coords[from];
            solid.tess_coords.push_back(coord);
        }
        return static_cast<std::uint32_t>(solid.positions.size() - 1);
    };
    double lowest = std::numeric_limits<double>::infinity();
    for (const glm::dvec3& p : solid.positions) lowest = std::min(lowest, p[up]);
    if (!(base_z < lowest))
        throw Error("the base of the solid (" + std::string(1, "xyz"[up]) + " = " + std::to_string(base_z) +
                        ") must lie below the terrain's lowest point (" + std::to_string(lowest) + ")",
                    Where::at_key("base_z"));

    // The outer outline, from the boundary half-edges (the other loops are holes and cracks).
    const auto [outline, outline_area] =
        outer_outline(boundary_half_edges(solid), solid.positions, flat);
    if (outline.empty()) throw Error("the terrain has no closed outline to close into a solid");
    if (outline_area < 0.0)
        throw Error("the terrain's triangles face downward (its outline runs clockwise seen from above)");

    // Skirt: below each outline vertex a base vertex; each outline edge a -> b becomes the
    // wall (b, a, a'), (b, a', b'), which runs along a -> b the other way, as a neighbour must.
    const std::size_t m = outline.size();
    std::vector<std::uint32_t> below(m);
    for (std::size_t i = 0; i < m; ++i) {
        below[i] = copy_vertex(outline[i], on_base(solid.positions[outline[i]]));
    }
    for (std::size_t i = 0; i < m; ++i) {
        const std::size_t j = (i + 1) % m;
        solid.triangles.push_back({outline[j], outline[i], below[i]});
        solid.triangles.push_back({outline[j], below[i], below[j]});
    }

    // Base, facing down: a fan from the outline's centroid when every fan triangle turns
    // the right way (a convex or star-shaped footprint), ear clipping otherwise.
    std::vector<glm::dvec2> polygon(m);
    glm::dvec2 centroid(0.0);
    for (std::size_t i = 0; i < m; ++i) {
        polygon[i] = flat(solid.positions[outline[i]]);
        centroid += polygon[i];
    }
    centroid /= double(m);
    bool star = true;
    double scale = 0.0;
    for (const glm::dvec2& p : polygon) scale = std::max(scale, glm::distance(p, centroid));
    for (std::size_t i = 0; i < m && star; ++i)
        star = cross_z(centroid, polygon[i], polygon[(i + 1) % m]) > 1e-12 * scale * scale;
    if (star) {
        glm::dvec3 centre_position(0.0);
        centre_position[iu] = centroid.x;
        centre_position[iw] = centroid.y;
        centre_position[up] = base_z;
        const std::uint32_t centre = copy_vertex(outline[0], centre_position);
        for (std::size_t i = 0; i < m; ++i) solid.triangles.push_back({centre, below[(i + 1) % m], below[i]});
    } else {
        const auto ears = clip_ears(polygon);
        if (ears.empty()) throw Error("cannot triangulate the base under this terrain's outline");
        for (const auto& e : ears) solid.triangles.push_back({below[e[2]], below[e[1]], below[e[0]]});
    }
    return solid;
}

}  // namespace tessref
