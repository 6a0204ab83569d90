// geomipmap.cpp — see tessref/geomipmap.h.
#include "tessref/geomipmap.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>

#include "tessref/error.h"
#include "tessref/mesh.h"

namespace tessref::geomip {

namespace {

constexpr int N = kPatchCells;

int step_of(int level) { return 1 << level; }

// The counter-clockwise perimeter parameter of a point on the square [lo, hi]^2's border:
// side index (0 bottom, 1 right, 2 top, 3 left) plus the fraction along it; corners land
// on whole numbers, so the patch border and the inner loop meet corner to corner.
double perimeter_parameter(glm::ivec2 p, int lo, int hi) {
    const double len = hi - lo;
    if (p.y == lo && p.x < hi) return (p.x - lo) / len;
    if (p.x == hi && p.y < hi) return 1.0 + (p.y - lo) / len;
    if (p.y == hi && p.x > lo) return 2.0 + (hi - p.x) / len;
    return 3.0 + (hi - p.y) / len;
}

// The closed loop around [lo, hi]^2, counter-clockwise from (lo, lo), each side with its
// own step.
std::vector<glm::ivec2> square_loop(int lo, int hi, const SideSteps& steps) {
    std::vector<glm::ivec2> loop;
    for (int x = lo; x < hi; x += steps[0]) loop.push_back({x, lo});
    for (int y = lo; y < hi; y += steps[1]) loop.push_back({hi, y});
    for (int x = hi; x > lo; x -= steps[2]) loop.push_back({x, hi});
    for (int y = hi; y > lo; y -= steps[3]) loop.push_back({lo, y});
    return loop;
}

bool is_power_of_two_step(int step) { return step >= 1 && step <= N && (step & (step - 1)) == 0; }

// The side (0..3) a border sample lies on, or -1 for an interior sample or a corner.
int border_side(glm::ivec2 v) {
    const bool corner = (v.x == 0 || v.x == N) && (v.y == 0 || v.y == N);
    if (corner) return -1;
    if (v.y == 0) return 0;
    if (v.x == N) return 1;
    if (v.y == N) return 2;
    if (v.x == 0) return 3;
    return -1;
}

// What a vertex moves toward as its patch tweens to the next coarser level: a weighted
// sum of at most three local samples' true heights, and which tween drives it.
struct Stencil {
    std::array<glm::ivec2, 3> sample{};
    std::array<double, 3> weight{};
    int count = 0;
    int side = -1;  // -1: the patch's own tween (interior and corners), else the side's
};

struct Topology {
    PatchMesh mesh;
    std::vector<Stencil> stencils;  // per vertex of mesh
};

// The barycentric weights of local point p in the mesh's triangle that holds it (the first
// one, in triangle order, for a point on a shared edge: both give the same height).
Stencil locate(const PatchMesh& mesh, glm::ivec2 p) {
    for (const auto& t : mesh.triangles) {
        const glm::dvec2 a(mesh.vertices[t[0]]), b(mesh.vertices[t[1]]), c(mesh.vertices[t[2]]);
        const glm::dvec2 q(p);
        const double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        const double wa = ((b.x - q.x) * (c.y - q.y) - (b.y - q.y) * (c.x - q.x)) / area;
        const double wb = ((c.x - q.x) * (a.y - q.y) - (c.y - q.y) * (a.x - q.x)) / area;
        const double wc = 1.0 - wa - wb;
        if (wa >= -1e-12 && wb >= -1e-12 && wc >= -1e-12) {
            Stencil st;
            st.sample = {mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]};
            st.weight = {wa, wb, wc};
            st.count = 3;
            return st;
        }
    }
    throw Error("geomipmap: a point lies outside its patch mesh (internal error)");
}

// Per level, every local sample's place on the level's own surface (no adaptation): what
// the pre-processing measures the error against. Built once.
const std::array<std::vector<Stencil>, kLevels>& level_stencils() {
    static const std::array<std::vector<Stencil>, kLevels> stencils = [] {
        std::array<std::vector<Stencil>, kLevels> all;
        for (int k = 0; k < kLevels; ++k) {
            const int s = step_of(k);
            const PatchMesh mesh = patch_mesh(k, {s, s, s, s});
            for (int j = 0; j <= N; ++j)
                for (int i = 0; i <= N; ++i) all[k].push_back(locate(mesh, {i, j}));
        }
        return all;
    }();
    return stencils;
}

double apply(const Stencil& st, const HeightSamples& map, glm::ivec2 origin) {
    double h = 0.0;
    for (int c = 0; c < st.count; ++c) h += st.weight[c] * map.at(origin.x + st.sample[c].x, origin.y + st.sample[c].y);
    return h;
}

// The level-k mesh of a patch with these side steps, and for each vertex its target on
// the next coarser level's surface (the patch's level k + 1 mesh, whose side steps are the
// larger of 2s and this side's step: what the same neighbours give one level up).
Topology make_topology(int level, const SideSteps& sides) {
    Topology topo;
    topo.mesh = patch_mesh(level, sides);
    topo.stencils.resize(topo.mesh.vertices.size());
    if (level == kLevels - 1) {
        for (std::size_t v = 0; v < topo.mesh.vertices.size(); ++v)
            topo.stencils[v] = Stencil{{topo.mesh.vertices[v]}, {1.0}, 1, -1};
        return topo;
    }
    const int s = step_of(level);
    SideSteps up{};
    for (int q = 0; q < 4; ++q) up[q] = std::max(2 * s, sides[q]);
    const PatchMesh coarse = patch_mesh(level + 1, up);
    for (std::size_t v = 0; v < topo.mesh.vertices.size(); ++v) {
        const glm::ivec2 p = topo.mesh.vertices[v];
        Stencil st;
        const int side = border_side(p);
        if (side >= 0) {
            // Along the border: the side's next coarser step drops every other vertex of
            // this side's step; a dropped one moves to the middle of its two neighbours on
            // the border, exactly as the patch across the side computes it.
            const int S = sides[side];
            const int along = (side == 0 || side == 2) ? p.x : p.y;
            st.side = side;
            if (S < N && (along / S) % 2 == 1) {
                const glm::ivec2 dir = (side == 0 || side == 2) ? glm::ivec2(1, 0) : glm::ivec2(0, 1);
                st.sample = {p - S * dir, p + S * dir, p};
                st.weight = {0.5, 0.5, 0.0};
                st.count = 2;
            } else {
                st.sample = {p, p, p};
                st.weight = {1.0, 0.0, 0.0};
                st.count = 1;
            }
        } else if (p.x % N == 0 && p.y % N == 0) {
            st = Stencil{{p, p, p}, {1.0, 0.0, 0.0}, 1, -1};  // corners never move
        } else {
            // Interior: the point's barycentric weights in the coarse triangle holding it.
            st = locate(coarse, p);
            st.side = -1;
        }
        topo.stencils[v] = st;
    }
    return topo;
}

}  // namespace

void validate(const HeightSamples& map) {
    const auto ok = [](int n) { return n >= N + 1 && (n - 1) % N == 0; };
    if (!ok(map.width) || !ok(map.height))
        throw Error("a geomipmapped height map must have 16a + 1 x 16b + 1 samples (17, 33, 65, ...), not " +
                    std::to_string(map.width) + " x " + std::to_string(map.height));
    if (map.samples.size() != static_cast<std::size_t>(map.width) * static_cast<std::size_t>(map.height))
        throw Error("geomipmap: the sample count does not match the map's size");
    for (std::size_t k = 0; k < map.samples.size(); ++k)
        if (!std::isfinite(map.samples[k]))
            throw Error("geomipmap: sample (" + std::to_string(k % map.width) + ", " + std::to_string(k / map.width) +
                        ") is not finite");
}

MaxErrors preprocess(const HeightSamples& map) {
    validate(map);
    MaxErrors result(static_cast<std::size_t>(map.patches_x()) * map.patches_y());
    for (int py = 0; py < map.patches_y(); ++py)
        for (int px = 0; px < map.patches_x(); ++px) {
            const glm::ivec2 origin(px * N, py * N);
            auto& levels = result[static_cast<std::size_t>(py) * map.patches_x() + px];
            for (int k = 0; k < kLevels; ++k) {
                MaxErrorVertex best;
                best.sample = {0, 0};
                best.true_height = best.level_height = map.at(origin.x, origin.y);
                for (int j = 0; j <= N; ++j)
                    for (int i = 0; i <= N; ++i) {
                        MaxErrorVertex m;
                        m.sample = {i, j};
                        m.true_height = map.at(origin.x + i, origin.y + j);
                        m.level_height = apply(level_stencils()[k][static_cast<std::size_t>(j) * (N + 1) + i], map, origin);
                        if (m.error() > best.error()) best = m;  // first in row order on ties
                    }
                levels[k] = best;
            }
        }
    return result;
}

PatchMesh patch_mesh(int level, const SideSteps& sides) {
    if (level < 0 || level >= kLevels) throw Error("geomipmap: level " + std::to_string(level) + " is outside 0..4");
    const int s = step_of(level);
    for (int q = 0; q < 4; ++q)
        if (!is_power_of_two_step(sides[q]) || sides[q] < s)
            throw Error("geomipmap: side step " + std::to_string(sides[q]) + " is not a power of two from " +
                        std::to_string(s) + " to 16");
    std::vector<glm::ivec2> vertices;
    std::vector<std::array<glm::ivec2, 3>> triangles;
    const auto cell = [&](int x, int y, int step) {
        const glm::ivec2 a(x, y), b(x + step, y), c(x + step, y + step), d(x, y + step);
        triangles.push_back({a, b, c});
        triangles.push_back({a, c, d});
    };
    if (s == N) {
        cell(0, 0, N);  // level 4: one quad; no neighbour can be coarser
    } else {
        // The inner grid: every cell of step s that does not touch the border.
        for (int y = s; y + s <= N - s; y += s)
            for (int x = s; x + s <= N - s; x += s) cell(x, y, s);
        // The ring between the border (each side at its own step) and the inner grid's
        // boundary (step s, or the single centre sample at level 3): a zipper that walks
        // both loops counter-clockwise by perimeter parameter, always advancing the loop
        // whose next vertex comes first (the border on ties).
        const std::vector<glm::ivec2> outer = square_loop(0, N, sides);
        const std::vector<glm::ivec2> inner =
            s == N / 2 ? std::vector<glm::ivec2>{{N / 2, N / 2}} : square_loop(s, N - s, {s, s, s, s});
        const std::size_t no = outer.size(), ni = inner.size();
        const bool point = ni == 1;
        std::size_t i = 0, j = 0;
        while (i < no || (!point && j < ni)) {
            const double po = i < no ? (i + 1 < no ? perimeter_parameter(outer[i + 1], 0, N) : 4.0)
                                     : std::numeric_limits<double>::infinity();
            const double pi = (!point && j < ni) ? (j + 1 < ni ? perimeter_parameter(inner[j + 1], s, N - s) : 4.0)
                                                 : std::numeric_limits<double>::infinity();
            const glm::ivec2 in = inner[point ? 0 : j % ni];
            if (po <= pi) {
                triangles.push_back({outer[i], outer[(i + 1) % no], in});
                ++i;
            } else {
                triangles.push_back({outer[i % no], inner[(j + 1) % ni], in});
                ++j;
            }
        }
    }
    // Vertices: the samples used, row by row.
    for (const auto& t : triangles) vertices.insert(vertices.end(), t.begin(), t.end());
    std::sort(vertices.begin(), vertices.end(),
              [](glm::ivec2 a, glm::ivec2 b) { return a.y != b.y ? a.y < b.y : a.x < b.x; });
    vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
    PatchMesh mesh;
    mesh.vertices = vertices;
    const auto index = [&](glm::ivec2 p) {
        const auto it = std::lower_bound(vertices.begin(), vertices.end(), p, [](glm::ivec2 a, glm::ivec2 b) {
            return a.y != b.y ? a.y < b.y : a.x < b.x;
        });
        return static_cast<std::uint32_t>(it - vertices.begin());
    };
    for (const auto& t : triangles) mesh.triangles.push_back({index(t[0]), index(t[1]), index(t[2])});
    return mesh;
}

std::vector<double> select_levels(const HeightSamples& map, const MaxErrors& max_errors, const Settings& settings,
                                  const glm::dmat4& view_projection, glm::ivec2 viewport) {
    validate(map);
    if (!(settings.params.error_bound_px >= 0.0) || !std::isfinite(settings.params.error_bound_px))
        throw Error("geomipmap: the error bound must be a finite number of pixels >= 0");
    if (settings.params.tween && !(*settings.params.tween >= 0.0 && *settings.params.tween <= 1.0))
        throw Error("geomipmap: the tween must lie in [0, 1]");
    const std::size_t patches = static_cast<std::size_t>(map.patches_x()) * map.patches_y();
    if (max_errors.size() != patches) throw Error("geomipmap: the pre-processing is of another map");
    if (const std::optional<int> forced = settings.params.level) {
        if (*forced < 0 || *forced >= kLevels) throw Error("geomipmap: a forced level must lie in 0..4");
        const double t = *forced + 1 < kLevels ? settings.params.tween.value_or(0.0) : 0.0;
        return std::vector<double>(patches, *forced + t);
    }
    const auto to_pixels = [&](glm::dvec3 p, bool& visible) {
        const glm::dvec4 c = view_projection * glm::dvec4(p, 1.0);
        visible = c.w > 0.0 && c.z >= -c.w;  // in front of the near plane
        return glm::dvec2((c.x / c.w + 1.0) * 0.5 * viewport.x, (c.y / c.w + 1.0) * 0.5 * viewport.y);
    };
    std::vector<double> levels(patches, 0.0);
    for (std::size_t p = 0; p < patches; ++p) {
        const glm::ivec2 origin(static_cast<int>(p % map.patches_x()) * N, static_cast<int>(p / map.patches_x()) * N);
        std::array<double, kLevels> error{};
        for (int k = 0; k < kLevels; ++k) {
            const MaxErrorVertex& m = max_errors[p][k];
            if (m.error() == 0.0) continue;  // the level is exact: no error on any screen
            const double x = settings.origin.x + (origin.x + m.sample.x) * settings.spacing.x;
            const double y = settings.origin.y + (origin.y + m.sample.y) * settings.spacing.y;
            bool seen_true = false, seen_level = false;
            const glm::dvec2 a = to_pixels({x, y, m.true_height * settings.scale_z}, seen_true);
            const glm::dvec2 b = to_pixels({x, y, m.level_height * settings.scale_z}, seen_level);
            error[k] = seen_true && seen_level ? glm::length(a - b) : std::numeric_limits<double>::infinity();
        }
        int k = 0;
        while (k + 1 < kLevels && error[k + 1] <= settings.params.error_bound_px) ++k;
        double t = 0.0;
        if (k + 1 < kLevels) {
            t = settings.params.tween ? *settings.params.tween
                               : (std::isinf(error[k + 1]) ? 0.0
                                                            : (settings.params.error_bound_px - error[k]) / (error[k + 1] - error[k]));
            t = std::clamp(t, 0.0, 1.0);
            if (!settings.params.tween) t = std::min(t, std::nextafter(1.0, 0.0));
        }
        levels[p] = k + t;
    }
    return levels;
}

double side_level(const std::vector<double>& levels, int patches_x, int patches_y, int px, int py, int side,
                  bool adapt) {
    static constexpr std::array<glm::ivec2, 4> offsets{glm::ivec2(0, -1), glm::ivec2(1, 0), glm::ivec2(0, 1),
                                                       glm::ivec2(-1, 0)};
    const double own = levels[static_cast<std::size_t>(py) * patches_x + px];
    const int qx = px + offsets[side].x, qy = py + offsets[side].y;
    if (!adapt || qx < 0 || qy < 0 || qx >= patches_x || qy >= patches_y) return own;
    return std::max(own, levels[static_cast<std::size_t>(qy) * patches_x + qx]);
}

SurfaceBounds surface_bounds(const HeightSamples& map) {
    validate(map);
    // Every topology a patch can take: level k, each side's step 2^k .. 16.
    struct Tri {
        std::array<std::uint32_t, 3> v;
        glm::ivec2 lo, hi;  // the squares its box meets
    };
    struct Topo {
        std::vector<std::vector<glm::ivec2>> samples;  // per vertex: it and its target's samples
        std::vector<Tri> triangles;
    };
    std::vector<Topo> topos;
    for (int k = 0; k < kLevels; ++k) {
        const int n = kLevels - k;  // step choices per side
        for (int c = 0; c < n * n * n * n; ++c) {
            SideSteps sides{};
            for (int q = 0, r = c; q < 4; ++q, r /= n) sides[q] = 1 << (k + r % n);
            const Topology t = make_topology(k, sides);
            Topo topo;
            for (std::size_t v = 0; v < t.mesh.vertices.size(); ++v) {
                std::vector<glm::ivec2> list{t.mesh.vertices[v]};
                for (int i = 0; i < t.stencils[v].count; ++i) list.push_back(t.stencils[v].sample[i]);
                topo.samples.push_back(std::move(list));
            }
            for (const auto& tri : t.mesh.triangles) {
                const glm::ivec2 a = t.mesh.vertices[tri[0]], b = t.mesh.vertices[tri[1]], d = t.mesh.vertices[tri[2]];
                const glm::ivec2 lo = glm::min(glm::min(a, b), d), hi = glm::max(glm::max(a, b), d);
                // Squares meeting the box [lo, hi]: lo - 1 .. hi (within the patch's 0..15).
                topo.triangles.push_back({tri, glm::max(lo - 1, glm::ivec2(0)), glm::min(hi, glm::ivec2(N - 1))});
            }
            topos.push_back(std::move(topo));
        }
    }
    const int w = map.width - 1, h = map.height - 1;
    SurfaceBounds out;
    out.lo.assign(static_cast<std::size_t>(w) * h, std::numeric_limits<double>::infinity());
    out.hi.assign(static_cast<std::size_t>(w) * h, -std::numeric_limits<double>::infinity());
    std::vector<double> vlo, vhi;
    for (int py = 0; py < map.patches_y(); ++py)
        for (int px = 0; px < map.patches_x(); ++px) {
            const glm::ivec2 origin(px * N, py * N);
            for (const Topo& topo : topos) {
                vlo.assign(topo.samples.size(), 0.0);
                vhi.assign(topo.samples.size(), 0.0);
                for (std::size_t v = 0; v < topo.samples.size(); ++v) {
                    double a = std::numeric_limits<double>::infinity(), b = -a;
                    for (const glm::ivec2 s : topo.samples[v]) {
                        const double z = map.at(origin.x + s.x, origin.y + s.y);
                        a = std::min(a, z);
                        b = std::max(b, z);
                    }
                    vlo[v] = a;
                    vhi[v] = b;
                }
                for (const Tri& t : topo.triangles) {
                    const double a = std::min({vlo[t.v[0]], vlo[t.v[1]], vlo[t.v[2]]});
                    const double b = std::max({vhi[t.v[0]], vhi[t.v[1]], vhi[t.v[2]]});
                    for (int j = t.lo.y; j <= t.hi.y; ++j)
                        for (int i = t.lo.x; i <= t.hi.x; ++i) {
                            const std::size_t q = static_cast<std::size_t>(origin.y + j) * w + origin.x + i;
                            out.lo[q] = std::min(out.lo[q], a);
                            out.hi[q] = std::max(out.hi[q], b);
                        }
                }
            }
        }
    return out;
}

float morph_height(float sampleHeight, float morphTarget, float tween, float scaleZ) {
    // GLSL: geomip_terrain.vert:33 float height = mix(sampleHeight, morphTarget, tween);
    const float height = sampleHeight + tween * (morphTarget - sampleHeight);
    // GLSL: geomip_terrain.vert:35 vec4 position = vec4(groundPosition, height * scaleZ, 1.0);
    return height * scaleZ;
}

SurfaceMesh build_surface(const HeightSamples& map, const std::vector<double>& levels, const Settings& settings,
                          std::vector<MorphVertex>* morph) {
    validate(map);
    const int nx = map.patches_x(), ny = map.patches_y();
    if (levels.size() != static_cast<std::size_t>(nx) * ny)
        throw Error("geomipmap: " + std::to_string(levels.size()) + " levels for " + std::to_string(nx * ny) + " patches");
    for (std::size_t p = 0; p < levels.size(); ++p)
        if (!(levels[p] >= 0.0 && levels[p] <= kLevels - 1))
            throw Error("geomipmap: the level of patch " + std::to_string(p) + " is outside [0, 4]", Where::at_patch(p));
    const auto split = [](double f, int& k, double& t) {
        k = std::min(static_cast<int>(std::floor(f)), kLevels - 1);
        t = k == kLevels - 1 ? 0.0 : f - k;
    };
    std::map<std::array<int, 5>, Topology> topologies;
    SurfaceMesh mesh;
    if (morph) morph->clear();
    for (int py = 0; py < ny; ++py)
        for (int px = 0; px < nx; ++px) {
            const std::size_t p = static_cast<std::size_t>(py) * nx + px;
            int k;
            double t;
            split(levels[p], k, t);
            // Each side's step and tween: the dictating patch's (the larger fractional
            // level of the two), or the patch's own without adaptation or at the map's edge.
            SideSteps sides{};
            std::array<double, 4> side_tween{};
            for (int q = 0; q < 4; ++q) {
                int kq;
                split(side_level(levels, nx, ny, px, py, q, settings.params.adapt), kq, side_tween[q]);
                sides[q] = 1 << kq;
            }
            const std::array<int, 5> key{k, sides[0], sides[1], sides[2], sides[3]};
            auto it = topologies.find(key);
            if (it == topologies.end()) it = topologies.emplace(key, make_topology(k, sides)).first;
            const Topology& topo = it->second;

            const glm::ivec2 origin(px * N, py * N);
            const std::uint32_t base = static_cast<std::uint32_t>(mesh.positions.size());
            for (std::size_t v = 0; v < topo.mesh.vertices.size(); ++v) {
                const glm::ivec2 s = topo.mesh.vertices[v];
                const Stencil& st = topo.stencils[v];
                const double h = map.at(origin.x + s.x, origin.y + s.y);
                double target = 0.0;
                if (st.count == 2) {
                    // Summed in map order, so the patch across the side gets the same bits.
                    const glm::ivec2 a = origin + st.sample[0], b = origin + st.sample[1];
                    target = 0.5 * map.at(a.x, a.y) + 0.5 * map.at(b.x, b.y);
                } else {
                    target = apply(st, map, origin);
                }
                const double tween = st.side < 0 ? t : side_tween[st.side];
                const double z = tween == 0.0 ? h : h + tween * (target - h);
                if (morph) morph->push_back({h, target, tween});
                const glm::ivec2 g = origin + s;
                mesh.positions.push_back({settings.origin.x + g.x * settings.spacing.x,
                                          settings.origin.y + g.y * settings.spacing.y, z * settings.scale_z});
                mesh.uvs.push_back({static_cast<double>(g.x) / (map.width - 1), static_cast<double>(g.y) / (map.height - 1)});
                mesh.patch_ids.push_back(static_cast<std::uint32_t>(p));
                mesh.tess_coords.push_back({static_cast<float>(s.x) / N, static_cast<float>(s.y) / N, 0.0f});
            }
            for (const auto& tri : topo.mesh.triangles) mesh.triangles.push_back({base + tri[0], base + tri[1], base + tri[2]});
        }
    return mesh;
}

}  // namespace tessref::geomip

namespace tessref::geomip {

// ---- the light map (the article, "Building the Mesh": two vectors from the sample to its
// neighbours, their cross product the normal, the normal's diffuse light the texel) ---------

glm::dvec3 sample_normal(const HeightSamples& map, glm::dvec2 spacing, double scale_z, int x, int y) {
    // The vector along +x: to the right neighbour, or from the left one at the last column.
    const int x0 = x + 1 < map.width ? x : x - 1, y0 = y + 1 < map.height ? y : y - 1;
    const double ha = (map.at(x0 + 1, y) - map.at(x0, y)) * scale_z;
    const double hb = (map.at(x, y0 + 1) - map.at(x, y0)) * scale_z;
    const glm::dvec3 a(spacing.x, 0.0, ha), b(0.0, spacing.y, hb);
    return glm::normalize(glm::cross(a, b));
}

std::vector<double> light_map(const HeightSamples& map, glm::dvec2 spacing, double scale_z,
                              const LightMapParams& params) {
    validate(map);
    const double d = glm::dot(params.light_direction, params.light_direction);
    if (!(d > 0.0) || !std::isfinite(d)) throw Error("geomipmap: the light direction cannot be normalized");
    if (!(params.ambient >= 0.0 && params.ambient <= 1.0)) throw Error("geomipmap: the ambient light must lie in [0, 1]");
    const glm::dvec3 l = glm::normalize(params.light_direction);
    std::vector<double> light(map.samples.size());
    for (int y = 0; y < map.height; ++y)
        for (int x = 0; x < map.width; ++x) {
            const glm::dvec3 n = sample_normal(map, spacing, scale_z, x, y);
            light[static_cast<std::size_t>(y) * map.width + x] =
                params.ambient + (1.0 - params.ambient) * std::max(glm::dot(n, l), 0.0);
        }
    return light;
}

// ---- culling (the article, "Optimizations": the frustum's ground rectangle, then the
// patches' boxes against the frustum's six sides) ---------------------------------------

std::vector<Box> patch_bounds(const HeightSamples& map, const Settings& settings) {
    validate(map);
    const int nx = map.patches_x(), ny = map.patches_y();
    std::vector<Box> boxes(static_cast<std::size_t>(nx) * ny);
    for (int py = 0; py < ny; ++py)
        for (int px = 0; px < nx; ++px) {
            double lo = map.at(px * N, py * N), hi = lo;
            for (int j = 0; j <= N; ++j)
                for (int i = 0; i <= N; ++i) {
                    const double h = map.at(px * N + i, py * N + j);
                    lo = std::min(lo, h);
                    hi = std::max(hi, h);
                }
            const glm::dvec2 a = settings.origin + glm::dvec2(px * N, py * N) * settings.spacing;
            const glm::dvec2 b = settings.origin + glm::dvec2((px + 1) * N, (py + 1) * N) * settings.spacing;
            Box& box = boxes[static_cast<std::size_t>(py) * nx + px];
            box.lo = {std::min(a.x, b.x), std::min(a.y, b.y), std::min(lo * settings.scale_z, hi * settings.scale_z)};
            box.hi = {std::max(a.x, b.x), std::max(a.y, b.y), std::max(lo * settings.scale_z, hi * settings.scale_z)};
        }
    return boxes;
}

std::vector<Cull> cull_frustum(const std::vector<Box>& boxes, const glm::dmat4& view_projection) {
    // The six planes of GL clip space, -w <= x, y, z <= w, as rows of the matrix
    // (Gribb and Hartmann): plane k holds dot(plane, (p, 1)) >= 0 inside.
    const glm::dmat4 m = glm::transpose(view_projection);  // m[r] is row r
    const std::array<glm::dvec4, 6> planes{m[3] + m[0], m[3] - m[0], m[3] + m[1],
                                           m[3] - m[1], m[3] + m[2], m[3] - m[2]};
    // (1) The ground rectangle: the frustum's eight corners (NDC cube corners through the
    // inverse) projected onto the ground plane.
    const glm::dmat4 inverse = glm::inverse(view_projection);
    glm::dvec2 rect_lo(std::numeric_limits<double>::infinity()), rect_hi(-std::numeric_limits<double>::infinity());
    bool rectangle = true;
    for (int c = 0; c < 8; ++c) {
        const glm::dvec4 q = inverse * glm::dvec4(c & 1 ? 1.0 : -1.0, c & 2 ? 1.0 : -1.0, c & 4 ? 1.0 : -1.0, 1.0);
        if (!(q.w > 0.0) || !std::isfinite(q.x / q.w) || !std::isfinite(q.y / q.w)) rectangle = false;
        const glm::dvec2 g(q.x / q.w, q.y / q.w);
        rect_lo = glm::min(rect_lo, g);
        rect_hi = glm::max(rect_hi, g);
    }
    constexpr double kMargin = 1e-6;
    const glm::dvec2 pad = (rect_hi - rect_lo) * kMargin;
    std::vector<Cull> out(boxes.size(), Cull::visible);
    for (std::size_t p = 0; p < boxes.size(); ++p) {
        const Box& b = boxes[p];
        if (rectangle && (b.hi.x < rect_lo.x - pad.x || b.lo.x > rect_hi.x + pad.x || b.hi.y < rect_lo.y - pad.y ||
                          b.lo.y > rect_hi.y + pad.y)) {
            out[p] = Cull::ground_rectangle;
            continue;
        }
        // (2) A box is outside a plane when even its corner farthest along the plane's
        // normal is outside; the margin is relative to the terms' size.
        for (const glm::dvec4& pl : planes) {
            const glm::dvec3 far(pl.x >= 0.0 ? b.hi.x : b.lo.x, pl.y >= 0.0 ? b.hi.y : b.lo.y,
                                 pl.z >= 0.0 ? b.hi.z : b.lo.z);
            const double d = pl.x * far.x + pl.y * far.y + pl.z * far.z + pl.w;
            const double size = std::abs(pl.x * far.x) + std::abs(pl.y * far.y) + std::abs(pl.z * far.z) + std::abs(pl.w);
            if (d < -kMargin * size) {
                out[p] = Cull::frustum_planes;
                break;
            }
        }
    }
    return out;
}

}  // namespace tessref::geomip
