// The ray-cast crack probe (Embree): an independent, geometric second opinion on what the
// topology says. It does not look at edges or vertex ids at all, only at whether rays get
// through the surface:
//  - terrain: vertical rays on a dense grid over the footprint; a ray inside the outline
//    that hits nothing went through a hole or a crack;
//  - closed mesh: lines along the three axes through the bounding box cross a closed
//    surface an even number of times, so an odd count means a leak; and rays cast from
//    points found inside in every direction must hit the surface, so a miss escaped
//    through a gap.
// Neither verdict may rest on a grazing hit. Where a ray passes within single-precision
// rounding of an edge or a vertex, Embree may report the triangles on both sides, one, or
// (at a ridge) none, so such a hit says nothing about whether the ray crossed the surface
// there: the ray is cast again beside itself, off the edge, and the clean cast decides. And
// where the topology rules a leak out (every edge has exactly two faces, but for a
// terrain's outline), the surface is a closed cycle that every line crosses an even number
// of times, whatever it is made of: failures there are rounding, dismissed, not reported.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <string>

#include "check/check_internal.h"
#include "tessref/raycast.h"

namespace tessref::check_detail {

namespace {

// A ray that grazed an edge or a vertex is cast again beside itself, across its direction:
// 16 to 128 scene resolutions away (far enough to leave the edge's rounding behind, close
// enough to stay in a crack it went through), turning by the golden angle so that the
// tries leave a vertex between different pairs of its edges.
constexpr int kRecasts = 8;

glm::dvec3 beside(const glm::dvec3& origin, const glm::dvec3& across_u, const glm::dvec3& across_w, int attempt,
                  double resolution) {
    const double radius = 16.0 * attempt * resolution;
    const double angle = 2.399963229728653 * attempt;  // the golden angle
    return origin + radius * (std::cos(angle) * across_u + std::sin(angle) * across_w);
}

bool grazes(const RayHit& hit, const RayScene& scene) {
    return hit.side == 0 || hit.edge_distance <= scene.resolution();
}

// Whether a ray could get through the surface at all: only where some edge lacks its second
// face (a boundary edge other than the outline loop the terrain probe allows) or has more
// than two.
bool topology_allows_leaks(const CheckState& state, int outline) {
    if (state.non_manifold_edges > 0) return true;
    for (std::size_t i = 0; i < state.boundary.size(); ++i) {
        const std::uint32_t loop = state.loop_of_boundary[i];
        if (static_cast<int>(loop) != outline && !(loop < state.loops.size() && state.loops[loop].allowed)) return true;
    }
    return false;
}

struct GridFailure {
    int axis;
    int i, j;
    auto operator<=>(const GridFailure&) const = default;
};

// 4-connected clusters of failed grid cells (per axis), each as the list of its cells.
std::vector<std::vector<GridFailure>> cluster(std::vector<GridFailure> failures) {
    std::sort(failures.begin(), failures.end());
    std::vector<std::uint32_t> parent(failures.size());
    std::iota(parent.begin(), parent.end(), 0u);
    auto find = [&](std::uint32_t x) {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
    };
    auto index_of = [&](const GridFailure& g) -> std::int64_t {
        auto it = std::lower_bound(failures.begin(), failures.end(), g);
        return it != failures.end() && *it == g ? it - failures.begin() : -1;
    };
    for (std::size_t n = 0; n < failures.size(); ++n) {
        const GridFailure& g = failures[n];
        for (const GridFailure& h : {GridFailure{g.axis, g.i + 1, g.j}, GridFailure{g.axis, g.i, g.j + 1}}) {
            const std::int64_t m = index_of(h);
            if (m < 0) continue;
            const std::uint32_t a = find(static_cast<std::uint32_t>(n)), b = find(static_cast<std::uint32_t>(m));
            if (a != b) parent[std::max(a, b)] = std::min(a, b);
        }
    }
    std::map<std::uint32_t, std::vector<GridFailure>> groups;
    for (std::size_t n = 0; n < failures.size(); ++n) groups[find(static_cast<std::uint32_t>(n))].push_back(failures[n]);
    std::vector<std::vector<GridFailure>> out;
    for (auto& [root, cells] : groups) out.push_back(std::move(cells));
    return out;
}

double distance_2d_to_segment(glm::dvec2 p, glm::dvec2 a, glm::dvec2 b) {
    const glm::dvec2 ab = b - a;
    const double len2 = glm::dot(ab, ab);
    const double t = len2 > 0.0 ? glm::clamp(glm::dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
    return glm::distance(p, a + t * ab);
}

// The boundary vertices that are not on the allowed outline, and the faces at each.
struct OpenBoundary {
    std::vector<std::uint32_t> vertices;
    std::map<std::uint32_t, std::uint32_t> loop_of;
    std::map<std::uint32_t, std::vector<std::uint32_t>> faces_of;
};

OpenBoundary open_boundary(const CheckState& state) {
    OpenBoundary out;
    for (std::size_t i = 0; i < state.boundary.size(); ++i) {
        const std::uint32_t loop = state.loop_of_boundary[i];
        if (static_cast<int>(loop) == state.allowed_loop) continue;
        const BoundaryHalfEdge& h = state.boundary[i];
        for (std::uint32_t v : {h.from, h.to}) {
            out.loop_of.emplace(v, loop);
            auto& faces = out.faces_of[v];
            if (std::find(faces.begin(), faces.end(), h.face) == faces.end()) faces.push_back(h.face);
        }
    }
    for (const auto& [v, loop] : out.loop_of) out.vertices.push_back(v);
    return out;
}

constexpr double kAssociationBudget = 2e7;  // point-to-vertex distance evaluations

// The terrain probe's vertical rays: one per cell of a resolution x resolution grid over the
// bounding box of the outline (the largest closed boundary loop unless one is allowed),
// placed `probe_offset` into its cell; only those inside the outline are cast.
struct VerticalRays {
    int outline = -1;
    std::vector<glm::dvec2> polygon;  // the outline, in ground coordinates (iu, iw)
    glm::dvec2 lo{0.0}, hi{0.0}, step{0.0}, offset{0.0};  // the outline's box; a cell
    int resolution = 1;
};

// nullopt: the terrain has no closed outline to probe inside.
std::optional<VerticalRays> vertical_rays(const CheckState& state) {
    const int k = state.up_axis, iu = (k + 1) % 3, iw = (k + 2) % 3;
    VerticalRays rays;
    rays.outline = state.allowed_loop;
    if (rays.outline < 0) {
        double best = -1.0;
        for (std::size_t i = 0; i < state.loops.size(); ++i)
            if (state.loops[i].closed && state.loops[i].area > best) {
                best = state.loops[i].area;
                rays.outline = static_cast<int>(i);
            }
    }
    if (rays.outline < 0) return std::nullopt;
    for (std::uint32_t v : state.loops[rays.outline].vertices)
        rays.polygon.emplace_back(state.mesh.positions[v][iu], state.mesh.positions[v][iw]);
    rays.lo = rays.hi = rays.polygon[0];
    for (const glm::dvec2& p : rays.polygon) {
        rays.lo = glm::min(rays.lo, p);
        rays.hi = glm::max(rays.hi, p);
    }
    rays.resolution = std::max(1, state.options.probe_resolution);
    rays.step = (rays.hi - rays.lo) / double(rays.resolution);
    rays.offset = state.options.probe_offset;
    return rays;
}

// Whether any ray of the grid, or a ray recast beside it, can meet the triangle whose ground
// shadow has the corners t. A vertical ray meets a triangle only where its ground point lies
// in the triangle's shadow, up to Embree's single-precision rounding (a few resolutions);
// the recast moves a ray 16 resolutions across. So a triangle farther than `reach` (more
// than both) from every grid point can be hit by no ray. First the cheap test, the grid
// points in the shadow's box widened by `reach`; then, for the few there, their distance to
// the shadow itself (which leaves out about half of what the box lets in: a triangle fills
// half its box). Non-finite or degenerate input, or a large triangle: reachable.
bool reachable(const VerticalRays& rays, const std::array<glm::dvec2, 3>& t, double reach) {
    const glm::dvec2 lo = glm::min(glm::min(t[0], t[1]), t[2]), hi = glm::max(glm::max(t[0], t[1]), t[2]);
    double first[2], last[2];
    for (int a = 0; a < 2; ++a) {
        const double step = rays.step[a];
        if (!(step > 0.0)) return true;
        first[a] = std::ceil((lo[a] - reach - rays.lo[a]) / step - rays.offset[a]);
        last[a] = std::floor((hi[a] + reach - rays.lo[a]) / step - rays.offset[a]);
        if (!(first[a] <= last[a])) return !(std::isfinite(first[a]) && std::isfinite(last[a]));
        if (last[a] < 0.0 || first[a] > double(rays.resolution - 1)) return false;
        first[a] = std::max(first[a], 0.0);
        last[a] = std::min(last[a], double(rays.resolution - 1));
    }
    if ((last[0] - first[0] + 1) * (last[1] - first[1] + 1) > 64) return true;
    const auto cross = [](glm::dvec2 a, glm::dvec2 b) { return a.x * b.y - a.y * b.x; };
    for (double j = first[1]; j <= last[1]; ++j)
        for (double i = first[0]; i <= last[0]; ++i) {
            // The ray's ground point, as terrain_probe() places it.
            const glm::dvec2 g(rays.lo.x + (i + rays.offset.x) * rays.step.x, rays.lo.y + (j + rays.offset.y) * rays.step.y);
            const double d0 = cross(t[1] - t[0], g - t[0]), d1 = cross(t[2] - t[1], g - t[1]), d2 = cross(t[0] - t[2], g - t[2]);
            if ((d0 >= 0.0 && d1 >= 0.0 && d2 >= 0.0) || (d0 <= 0.0 && d1 <= 0.0 && d2 <= 0.0)) return true;  // inside
            for (int k = 0; k < 3; ++k)
                if (distance_2d_to_segment(g, t[k], t[(k + 1) % 3]) <= reach) return true;
        }
    return false;
}

void terrain_probe(CheckState& state, const RayScene& scene, const VerticalRays& rays) {
    const IndexedMesh& mesh = state.mesh;
    CheckReport& report = state.report;
    const int k = state.up_axis, iu = (k + 1) % 3, iw = (k + 2) % 3;
    const int outline = rays.outline;
    report.probe.mode = "terrain";
    const std::vector<glm::dvec2>& polygon = rays.polygon;
    const glm::dvec2 lo = rays.lo, hi = rays.hi, step = rays.step;
    const int resolution = rays.resolution;
    const double margin = state.tolerance + 1e-5 * std::max(hi.x - lo.x, hi.y - lo.y);
    const double height = state.bbox_max[k] - state.bbox_min[k];
    glm::dvec3 direction(0.0);
    direction[k] = -state.up_sign;
    const double start = state.up_sign > 0 ? state.bbox_max[k] + 0.01 * height + margin : state.bbox_min[k] - 0.01 * height - margin;

    const glm::dvec2 offset = rays.offset;
    glm::dvec3 across_u(0.0), across_w(0.0);
    across_u[iu] = 1.0;
    across_w[iw] = 1.0;

    struct RowResult {
        std::size_t rays = 0, recast = 0;
        std::vector<GridFailure> failures;
    };
    std::vector<RowResult> rows(resolution);
    const int batch = 16;
    for (int j0 = 0; j0 < resolution; j0 += batch) {
        const int j1 = std::min(resolution, j0 + batch);
        tessref::parallel_for(tbb::blocked_range<int>(j0, j1, 1), [&](const tbb::blocked_range<int>& r) {
            std::vector<double> crossings;
            for (int j = r.begin(); j != r.end(); ++j) {
                const double w = lo.y + (j + offset.y) * step.y;
                crossings.clear();
                for (std::size_t e = 0; e < polygon.size(); ++e) {
                    const glm::dvec2 p = polygon[e], q = polygon[(e + 1) % polygon.size()];
                    if ((p.y > w) != (q.y > w)) crossings.push_back(p.x + (w - p.y) * (q.x - p.x) / (q.y - p.y));
                }
                std::sort(crossings.begin(), crossings.end());
                std::size_t passed = 0;
                for (int i = 0; i < resolution; ++i) {
                    const double u = lo.x + (i + offset.x) * step.x;
                    while (passed < crossings.size() && crossings[passed] < u) ++passed;
                    if (passed % 2 == 0) continue;  // outside the outline
                    ++rows[j].rays;
                    glm::dvec3 origin(0.0);
                    origin[k] = start;
                    origin[iu] = u;
                    origin[iw] = w;
                    // Whether the ray hits, not where: Embree's occlusion query tests each
                    // triangle as the nearest-hit query does (the same watertight test, from
                    // an unbounded ray), so it answers the same, and stops at the first hit.
                    if (scene.occluded(origin, direction)) continue;
                    // Rays grazing the outline may slip past its edge in single precision.
                    double near_outline = std::numeric_limits<double>::infinity();
                    for (std::size_t e = 0; e < polygon.size(); ++e)
                        near_outline = std::min(near_outline, distance_2d_to_segment({u, w}, polygon[e], polygon[(e + 1) % polygon.size()]));
                    if (near_outline <= margin) continue;
                    // A miss is a hole only if a ray beside it, off any edge this one may have
                    // slipped past, misses too (as it does in any crack wider than that step).
                    ++rows[j].recast;
                    if (scene.occluded(beside(origin, across_u, across_w, 1, scene.resolution()), direction)) continue;
                    rows[j].failures.push_back({k, i, j});
                }
            }
        });
        state.progress("ray probe", 0.8 + 0.2 * double(j1) / resolution);
    }
    std::vector<GridFailure> failures;
    for (RowResult& r : rows) {
        report.probe.rays += r.rays;
        report.probe.recast_rays += r.recast;
        failures.insert(failures.end(), r.failures.begin(), r.failures.end());
    }
    if (failures.empty()) return;
    if (!topology_allows_leaks(state, outline)) {
        report.probe.dismissed_rays = failures.size();
        return;
    }
    report.probe.failed_rays = failures.size();

    const OpenBoundary open = open_boundary(state);
    const auto clusters = cluster(failures);
    const bool associate = double(clusters.size()) * double(open.vertices.size()) <= kAssociationBudget;
    const double mid_height = 0.5 * (state.bbox_min[k] + state.bbox_max[k]);
    for (const auto& cells : clusters) {
        glm::dvec2 centre(0.0);
        for (const GridFailure& g : cells)
            centre += glm::dvec2(lo.x + (g.i + offset.x) * step.x, lo.y + (g.j + offset.y) * step.y);
        centre /= double(cells.size());
        Defect d;
        d.position[iu] = centre.x;
        d.position[iw] = centre.y;
        d.position[k] = mid_height;
        d.measure = double(cells.size());
        d.detail = std::to_string(cells.size()) + " vertical ray" + (cells.size() == 1 ? "" : "s") +
                   " inside the outline hit nothing";
        if (associate && !open.vertices.empty()) {
            std::uint32_t best = open.vertices[0];
            double best_distance = std::numeric_limits<double>::infinity();
            for (std::uint32_t v : open.vertices) {
                const double dist = glm::distance(centre, glm::dvec2(mesh.positions[v][iu], mesh.positions[v][iw]));
                if (dist < best_distance) {
                    best_distance = dist;
                    best = v;
                }
            }
            d.position[k] = mesh.positions[best][k];
            d.vertices = {best};
            d.faces = open.faces_of.at(best);
            d.detail += "; nearest open boundary vertex " + std::to_string(best) + " at " +
                        format_point(mesh.positions[best]);
        }
        state.add_defect(DefectClass::probe_miss, std::move(d));
    }
}

// The lines of the closed probe: a grid of resolution x resolution lines along each axis,
// from a margin outside the bounding box, each shifted by `probe_offset` cells.
struct ProbeGrid {
    struct Line {
        glm::dvec3 origin, direction;
    };
    glm::dvec3 bbox_min, extent;
    double margin;
    glm::dvec2 offset;
    int resolution;

    explicit ProbeGrid(const CheckState& state)
        : bbox_min(state.bbox_min),
          extent(state.bbox_max - state.bbox_min),
          margin(0.01 * state.diagonal + state.tolerance + 1e-12),
          offset(state.options.probe_offset),
          resolution(std::max(1, state.options.probe_resolution)) {}

    Line line(int axis, int i, int j) const {
        const int iu = (axis + 1) % 3, iw = (axis + 2) % 3;
        Line l{glm::dvec3(0.0), glm::dvec3(0.0)};
        l.origin[axis] = bbox_min[axis] - margin;
        l.origin[iu] = bbox_min[iu] + (i + offset.x) * extent[iu] / resolution;
        l.origin[iw] = bbox_min[iw] + (j + offset.y) * extent[iw] / resolution;
        l.direction[axis] = 1.0;
        return l;
    }
};

// What the grid's lines found: those that crossed the surface an odd number of times, and a
// point inside the solid from each line along x that crossed it twice or more.
struct GridCrossings {
    std::vector<GridFailure> odd;
    std::vector<glm::dvec3> inside;
};

// Casts every line of the grid and counts its crossings; a line that grazes an edge is recast
// beside itself, up to `kRecasts` times, and left undecided after that.
GridCrossings cast_grid(CheckState& state, const RayScene& scene, const ProbeGrid& grid) {
    CheckReport& report = state.report;
    const int resolution = grid.resolution;
    struct LineResult {
        std::size_t rays = 0, recast = 0, undecided = 0;
        std::vector<GridFailure> odd;
        std::vector<glm::dvec3> inside;  // a point between the first two crossings
    };
    // Every hit of a line that grazes nothing is a crossing of the surface from one side to
    // the other; a line with a grazing hit has no count.
    struct Crossings {
        std::size_t count = 0;
        double first = 0.0, second = 0.0;
    };
    auto crossings_along = [&](const glm::dvec3& origin, const glm::dvec3& direction) -> std::optional<Crossings> {
        Crossings c;
        for (const RayHit& hit : scene.all_hits(origin, direction)) {
            if (grazes(hit, scene)) return std::nullopt;
            if (c.count == 0) c.first = hit.t;
            if (c.count == 1) c.second = hit.t;
            ++c.count;
        }
        return c;
    };
    std::vector<LineResult> rows(3 * static_cast<std::size_t>(resolution));
    const int batch = 16;
    for (int r0 = 0; r0 < 3 * resolution; r0 += batch) {
        const int r1 = std::min(3 * resolution, r0 + batch);
        tessref::parallel_for(tbb::blocked_range<int>(r0, r1, 1), [&](const tbb::blocked_range<int>& range) {
            for (int row = range.begin(); row != range.end(); ++row) {
                const int axis = row / resolution, j = row % resolution;
                glm::dvec3 across_u(0.0), across_w(0.0);
                across_u[(axis + 1) % 3] = 1.0;
                across_w[(axis + 2) % 3] = 1.0;
                LineResult& result = rows[row];
                for (int i = 0; i < resolution; ++i) {
                    ProbeGrid::Line l = grid.line(axis, i, j);
                    ++result.rays;
                    std::optional<Crossings> crossings = crossings_along(l.origin, l.direction);
                    if (!crossings) ++result.recast;
                    const glm::dvec3 origin = l.origin;
                    for (int attempt = 1; !crossings && attempt <= kRecasts; ++attempt) {
                        l.origin = beside(origin, across_u, across_w, attempt, scene.resolution());
                        crossings = crossings_along(l.origin, l.direction);
                    }
                    if (!crossings) {
                        ++result.undecided;
                        continue;
                    }
                    if (crossings->count % 2 == 1) result.odd.push_back({axis, i, j});
                    else if (crossings->count >= 2 && axis == 0)
                        result.inside.push_back(l.origin + 0.5 * (crossings->first + crossings->second) * l.direction);
                }
            }
        });
        state.progress("ray probe", 0.8 + 0.15 * double(r1) / (3 * resolution));
    }
    GridCrossings found;
    for (LineResult& r : rows) {
        report.probe.rays += r.rays;
        report.probe.recast_rays += r.recast;
        report.probe.undecided_rays += r.undecided;
        found.odd.insert(found.odd.end(), r.odd.begin(), r.odd.end());
        found.inside.insert(found.inside.end(), r.inside.begin(), r.inside.end());
    }
    return found;
}

// The escape rays: the n-th inside point looks along the n-th (mod 4096) direction of a
// spiral over the sphere, golden angle apart.
constexpr std::size_t kEscapeDirections = 4096;
glm::dvec3 escape_direction(std::size_t n) {
    const double index = double(n % kEscapeDirections) + 0.5;
    const double z = 1.0 - 2.0 * index / double(kEscapeDirections);
    const double phi = index * 2.399963229728653;  // golden angle
    const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
    return {s * std::cos(phi), s * std::sin(phi), z};
}

// The inside points whose escape ray hits nothing: a closed surface would have stopped it.
std::vector<std::size_t> escaping(const RayScene& scene, const std::vector<glm::dvec3>& inside) {
    std::vector<std::uint8_t> escaped(inside.size(), 0);
    tessref::parallel_for(tbb::blocked_range<std::size_t>(0, inside.size(), 256), [&](const auto& r) {
        for (std::size_t n = r.begin(); n != r.end(); ++n) escaped[n] = !scene.occluded(inside[n], escape_direction(n));
    });
    std::vector<std::size_t> escapes;
    for (std::size_t n = 0; n < inside.size(); ++n)
        if (escaped[n]) escapes.push_back(n);
    return escapes;
}

// The failed rays as defects, located: when few enough, each at the open boundary vertex
// nearest its ray, grouped by that vertex's loop; otherwise the odd lines clustered by
// cell and every escape ray on its own.
void report_closed_failures(CheckState& state, const ProbeGrid& grid, const GridCrossings& found,
                            const std::vector<std::size_t>& escapes) {
    const std::vector<GridFailure>& odd = found.odd;
    const OpenBoundary open = open_boundary(state);
    const std::size_t failures = odd.size() + escapes.size();
    const bool associate = !open.vertices.empty() && double(failures) * double(open.vertices.size()) <= kAssociationBudget;
    auto nearest = [&](const glm::dvec3& origin, const glm::dvec3& direction, bool whole_line) {
        std::uint32_t best = open.vertices[0];
        double best_distance = std::numeric_limits<double>::infinity();
        for (std::uint32_t v : open.vertices) {
            const glm::dvec3 p = state.mesh.positions[v] - origin;
            double t = glm::dot(p, direction);
            if (!whole_line) t = std::max(t, 0.0);
            const double dist = glm::length(p - t * direction);
            if (dist < best_distance) {
                best_distance = dist;
                best = v;
            }
        }
        return best;
    };
    struct Group {
        std::size_t rays = 0;
        std::uint32_t vertex = 0;
        glm::dvec3 first_origin{0.0};
    };
    auto emit = [&](DefectClass kind, std::vector<std::pair<glm::dvec3, glm::dvec3>> rays, bool whole_line,
                    const std::string& what) {
        if (rays.empty()) return;
        if (associate) {
            std::map<std::uint32_t, Group> by_loop;
            for (const auto& [o, d] : rays) {
                const std::uint32_t v = nearest(o, d, whole_line);
                Group& g = by_loop[open.loop_of.at(v)];
                if (g.rays++ == 0) {
                    g.vertex = v;
                    g.first_origin = o;
                }
            }
            for (const auto& [loop, g] : by_loop) {
                Defect d;
                d.position = state.mesh.positions[g.vertex];
                d.vertices = {g.vertex};
                d.faces = open.faces_of.at(g.vertex);
                d.measure = double(g.rays);
                d.detail = std::to_string(g.rays) + " " + what + "; nearest open boundary vertex " +
                           std::to_string(g.vertex) + " at " + format_point(d.position);
                state.add_defect(kind, std::move(d));
            }
            return;
        }
        for (const auto& [o, d] : rays) {
            Defect defect;
            defect.position = o;
            defect.measure = 1.0;
            defect.detail = "1 " + what + " from " + format_point(o) + " towards " + format_point(d);
            state.add_defect(kind, std::move(defect));
        }
    };
    if (associate) {
        std::vector<std::pair<glm::dvec3, glm::dvec3>> rays;
        for (const GridFailure& g : odd) {
            const ProbeGrid::Line l = grid.line(g.axis, g.i, g.j);
            rays.emplace_back(l.origin, l.direction);
        }
        emit(DefectClass::probe_odd_parity, std::move(rays), true, "lines crossed the surface an odd number of times");
    } else {
        for (const auto& cells : cluster(odd)) {
            const ProbeGrid::Line l = grid.line(cells[0].axis, cells[0].i, cells[0].j);
            Defect d;
            d.position = l.origin;
            d.measure = double(cells.size());
            d.detail = std::to_string(cells.size()) + " line(s) along axis " + std::to_string(cells[0].axis) +
                       " crossed the surface an odd number of times, the first from " + format_point(l.origin);
            state.add_defect(DefectClass::probe_odd_parity, std::move(d));
        }
    }
    std::vector<std::pair<glm::dvec3, glm::dvec3>> escape_rays;
    for (std::size_t n : escapes) escape_rays.emplace_back(found.inside[n], escape_direction(n));
    emit(DefectClass::probe_escape, std::move(escape_rays), false, "rays from inside escaped without a hit");
}

// The probe of a closed solid: every grid line must cross the surface an even number of
// times, and no ray from a point inside may escape.
void closed_probe(CheckState& state, const RayScene& scene) {
    CheckReport& report = state.report;
    report.probe.mode = "closed";
    const ProbeGrid grid(state);
    const GridCrossings found = cast_grid(state, scene, grid);
    const std::vector<std::size_t> escapes = escaping(scene, found.inside);
    state.progress("ray probe", 1.0);
    report.probe.rays += found.inside.size();
    if (found.odd.empty() && escapes.empty()) return;
    if (!topology_allows_leaks(state, -1)) {
        report.probe.dismissed_rays = found.odd.size() + escapes.size();
        return;
    }
    report.probe.failed_rays = found.odd.size() + escapes.size();
    report_closed_failures(state, grid, found, escapes);
}

}  // namespace

void run_ray_probe(CheckState& state) {
    CheckReport& report = state.report;
    if (!state.options.ray_probe) {
        report.probe.skipped_because = "disabled";
        return;
    }
    const bool terrain = report.terrain_like;
    const bool closed = !terrain && report.judged_as == "closed";
    if (!terrain && !closed) {
        report.probe.skipped_because = "an open mesh that is not a terrain has no inside to probe";
        return;
    }
    // The BVH's build is most of the probe's time, and a terrain's rays are vertical: they
    // can meet only the triangles over whose ground they pass, a fraction of a fine mesh. So
    // the terrain's scene holds only those (every triangle a ray or its recast can hit, up
    // to rounding with room to spare: reachable()), and the first triangle, so that it is
    // never empty. Whether a ray hits is then what it is in the whole mesh's scene, and
    // whether is all the terrain probe asks (not which triangle, nor where): the report is
    // the same. The scene is built on every position, so its shift and resolution() are
    // the whole mesh's.
    const IndexedMesh& mesh = state.mesh;
    const std::optional<VerticalRays> rays = terrain ? vertical_rays(state) : std::nullopt;
    const int iu = (state.up_axis + 1) % 3, iw = (state.up_axis + 2) % 3;
    const double reach = rays ? 64.0 * RayScene::resolution_of(mesh.positions) : 0.0;  // the recast's 16, and rounding
    const bool cull = rays && std::isfinite(reach) && reach > 0.0;
    // Fan-triangulate the analysed faces, in fixed chunks in parallel, joined in face order.
    // The first triangle is kept whether a ray reaches it or not.
    const auto probed = [&](std::size_t f) {
        // An open sheet beside closed components has no inside: the closed probe leaves it out.
        return state.face_status[f] == face_kept &&
               (state.component_is_sheet.empty() || !state.component_is_sheet[state.vertex_component[mesh.face(f)[0]]]);
    };
    std::size_t first_face = 0;
    while (first_face < mesh.face_count() && !probed(first_face)) ++first_face;
    using Triangle = std::array<std::uint32_t, 3>;
    auto parts = map_chunks<std::vector<Triangle>>(mesh.face_count(), 1 << 15, [&](std::size_t f0, std::size_t f1, auto& out) {
        for (std::size_t f = f0; f < f1; ++f) {
            if (!probed(f)) continue;
            const auto face = mesh.face(f);
            for (std::size_t k = 1; k + 1 < face.size(); ++k) {
                const Triangle t{face[0], face[k], face[k + 1]};
                if (cull && !(f == first_face && k == 1)) {
                    std::array<glm::dvec2, 3> shadow;
                    for (int c = 0; c < 3; ++c) shadow[c] = {mesh.positions[t[c]][iu], mesh.positions[t[c]][iw]};
                    if (!reachable(*rays, shadow, reach)) continue;
                }
                out.push_back(t);
            }
        }
    });
    std::vector<Triangle> triangles = concatenate(std::move(parts));
    if (triangles.empty()) {
        report.probe.skipped_because = "no faces to probe";
        return;
    }
    if (terrain && !rays) {
        report.probe.mode = "none";
        report.probe.skipped_because = "the terrain has no closed outline";
        return;
    }
    // The probe casts one pass of rays: Embree's quick build (RayScene::Build::quick) costs
    // less than it adds to the rays (on the 2.4 M-triangle grid, 0.04 s of CPU for the
    // build and 0.08 s for the rays, against 0.08 s and 0.06 s). The tree decides only which
    // triangles a ray through an edge or a vertex meets there, and the probe never asks
    // which: the terrain probe asks whether a ray hits, and a ray through a welded edge or
    // vertex hits on any tree (the watertight test); the closed probe recasts a line with
    // any grazing hit, and it has one on any tree.
    state.progress("ray probe: building the BVH", 0.8);
    const RayScene scene(mesh.positions, triangles, RayScene::Build::quick);
    triangles.clear();
    triangles.shrink_to_fit();
    if (terrain) terrain_probe(state, scene, *rays);
    else closed_probe(state, scene);
}

}  // namespace tessref::check_detail
