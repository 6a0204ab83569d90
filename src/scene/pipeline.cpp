// pipeline.cpp — runs a scene: control -> primitive generator -> evaluation -> geometry.
//
// Four passes, each parallel over patches with oneTBB and each writing only its own
// patch's pre-sized slot, so the result does not depend on the thread count:
//  1. control: the patch's corners (the vertex shader's output) and levels;
//  2. budget: an upper bound of the triangle count from the levels, before tessellating;
//  3. generator: one pattern per patch from the PatternCache (level sets shared by
//     several patches tessellate once); prefix sums give every patch its vertex and
//     triangle ranges in the output;
//  4. evaluation and per-vertex / per-face geometry into those ranges.
// Smooth normals, which need the whole surface, follow serially (geometry.h sums in
// triangle order, deterministic).
#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <string>
#include <span>
#include <type_traits>

#include "common/parallel.h"

#include "tessref/evaluation.h"
#include "tessref/geometry.h"
#include "tessref/scene.h"

namespace tessref {

// ---------------------------------------------------------------------------------------
// Adjacency and estimates
// ---------------------------------------------------------------------------------------

std::vector<SharedEdge> shared_edges(const Scene& scene) {
    std::vector<SharedEdge> out;
    if (scene.grid) {
        const TerrainGrid& g = *scene.grid;
        const std::uint32_t nu = static_cast<std::uint32_t>(g.patches_u);
        const std::uint32_t nv = static_cast<std::uint32_t>(g.patches_v);
        for (std::uint32_t j = 0; j < nv; ++j)
            for (std::uint32_t i = 0; i < nu; ++i) {
                const std::uint32_t p = j * nu + i;
                // Edge 2 (u = 1: c3-c2) of (i, j) is edge 0 (u = 0: c0-c1) of (i+1, j);
                // edge 3 (v = 1: c1-c2) of (i, j) is edge 1 (v = 0: c0-c3) of (i, j+1).
                if (i + 1 < nu) out.push_back({p, 2, p + 1, 0});
                if (j + 1 < nv) out.push_back({p, 3, p + nu, 1});
            }
    } else if (scene.meshes) {
        const auto& tris = scene.meshes->triangles;
        struct Side {
            std::uint32_t patch;
            int edge;
        };
        std::vector<std::pair<std::pair<std::uint32_t, std::uint32_t>, Side>> sides;
        for (std::uint32_t p = 0; p < tris.size(); ++p)
            for (int e = 0; e < 3; ++e) {
                const std::uint32_t a = tris[p][kTriangleEdges[e][0]];
                const std::uint32_t b = tris[p][kTriangleEdges[e][1]];
                sides.push_back({{std::min(a, b), std::max(a, b)}, Side{p, e}});
            }
        std::stable_sort(sides.begin(), sides.end(),
                         [](const auto& x, const auto& y) { return x.first < y.first; });
        for (std::size_t k = 0; k + 1 < sides.size(); ++k)
            if (sides[k].first == sides[k + 1].first) {
                out.push_back({sides[k].second.patch, sides[k].second.edge, sides[k + 1].second.patch,
                               sides[k + 1].second.edge});
                ++k;  // a manifold edge has two sides; a third would pair with nothing here
            }
    }
    return out;
}

bool on_outer_edge(Domain domain, const glm::vec3& c, int edge) {
    if (domain == Domain::quads) {
        switch (edge) {
            case 0: return c.x == 0.0f;
            case 1: return c.y == 0.0f;
            case 2: return c.x == 1.0f;
            case 3: return c.y == 1.0f;
        }
        return false;
    }
    switch (edge) {
        case 0: return c.x == 0.0f;
        case 1: return c.y == 0.0f;
        case 2: return c.z == 0.0f;
    }
    return false;
}

namespace {

// Segments an edge of level f is cut into (after the generator's clamping and rounding to
// its spacing's parity); an upper bound for fractional levels (their two short segments
// are counted).
std::uint64_t segments(float f, Spacing spacing) {
    float lo = 1.0f, hi = 64.0f;
    if (spacing == Spacing::fractional_odd) hi = 63.0f;
    if (spacing == Spacing::fractional_even) lo = 2.0f;
    const float clamped = std::isnan(f) ? lo : std::min(hi, std::max(lo, f));
    std::uint64_t n = static_cast<std::uint64_t>(std::ceil(clamped));
    if (spacing == Spacing::fractional_odd && n % 2 == 0) ++n;
    if (spacing == Spacing::fractional_even && n % 2 == 1) ++n;
    return n;
}

}  // namespace

std::uint64_t estimate_triangles(const TessSettings& settings, const TessLevels& levels) {
    const int used_outer = settings.domain == Domain::quads ? 4 : settings.domain == Domain::triangles ? 3 : 2;
    for (int i = 0; i < used_outer; ++i)
        if (!(levels.outer[i] > 0.0f)) return 0;  // culled
    std::uint64_t outer_sum = 0;
    for (int i = 0; i < used_outer; ++i) outer_sum += segments(levels.outer[i], settings.spacing);
    if (settings.domain == Domain::quads) {
        // Inner rings (at least 3 segments per axis once any ring exists) plus the stitching
        // of each outer edge to the first ring.
        const std::uint64_t a = std::max<std::uint64_t>(3, segments(levels.inner[0], settings.spacing));
        const std::uint64_t b = std::max<std::uint64_t>(3, segments(levels.inner[1], settings.spacing));
        return 2 * a * b + 2 * outer_sum;
    }
    if (settings.domain == Domain::triangles) {
        // About 1.5 n^2 for the rings; 2 n^2 bounds it with the stitching.
        const std::uint64_t n = std::max<std::uint64_t>(3, segments(levels.inner[0], settings.spacing));
        return 2 * n * n + 2 * outer_sum;
    }
    return 0;  // isolines make no triangles
}

namespace {

template <typename T>
Sampler2D<T> sampler(const std::shared_ptr<const Texture>& texture) {
    if (!texture) return [](vec2_t<T>) { return vec4_t<T>(T(0)); };  // an unbound sampler reads 0
    return [texture](vec2_t<T> st) { return texture->texture(st); };
}
template <typename T>
Sampler2DLod<T> sampler_lod(const std::shared_ptr<const Texture>& texture) {
    return [texture](vec2_t<T> st, T lod) { return texture->textureLod(st, lod); };
}

// Tess coords in the run's precision.
template <typename T>
std::span<const DomainPoint<T>> domain_points(const Pattern& pattern) {
    if constexpr (std::is_same_v<T, float>)
        return pattern.points();
    else
        return pattern.points_exact();
}

template <typename T>
struct Run {
    const Scene& scene;
    const PipelineOptions& options;
    Precision precision;
    std::size_t patch_count = 0;

    // Uniforms in the run's precision.
    mat4_t<T> view{T(1)}, viewProjection{T(1)};
    mat3_t<T> normalMatrix{T(1)};  // the thesis's normalMatrix: model is the identity
    vec3_t<T> cameraPosition{T(0)};
    std::shared_ptr<const Texture> height_texture;
    Sampler2D<T> heightMap;
    Sampler2DLod<T> heightMapLod;
    Sampler2D<T> normalMap;
    ThesisControl<T> thesisControl{};
    Lab4Control<T> lab4Control{};
    PnControl<T> pnControl{};
    ThesisEvaluation<T> thesisEvaluation{};
    Cosc422Evaluation<T> cosc422Evaluation{};
    Lab4Evaluation<T> lab4Evaluation{};
    PnEvaluation<T> pnEvaluation{};
    std::vector<T> u_coords, v_coords;  // grid corner coordinates as the vertex buffer holds them
    bool flip = false;                  // reverse each triangle to face up / out

    // Per patch, from pass 1.
    std::vector<TessLevels> levels;
    std::vector<std::array<vec4_t<T>, 4>> tcPosition;  // terrain: the control stage's output corners
    std::vector<Lab4Lod<T>> lab4Lod;
    std::vector<PnPatch<T>> pnPatches;

    Run(const Scene& s, const PipelineOptions& o) : scene(s), options(o), precision(o.precision) {}

    void setup() {
        patch_count = scene.patch_count();
        if (scene.camera) {
            view = mat4_t<T>(scene.camera->view());
            viewProjection = mat4_t<T>(scene.camera->view_projection());
            cameraPosition = vec3_t<T>(scene.camera->eye);
        }
        const EvaluationModel em = scene.evaluation.model;
        if (scene.grid) {
            const TerrainGrid& g = *scene.grid;
            height_texture = std::shared_ptr<const Texture>(g.heightmap, &g.heightmap->texture);
            heightMap = sampler<T>(height_texture);
            heightMapLod = sampler_lod<T>(height_texture);
            if (g.normal_map) normalMap = sampler<T>(g.normal_map);
            for (double u : g.u_coords) u_coords.push_back(static_cast<T>(u));
            for (double v : g.v_coords) v_coords.push_back(static_cast<T>(v));
            // The grid's facing: cross(c3 - c0, c1 - c0) against the plane's up axis.
            const auto c = g.corners(0);
            const glm::dvec3 up = g.plane == GroundPlane::xy ? glm::dvec3(0, 0, 1) : glm::dvec3(0, 1, 0);
            const bool ccw_faces_up = glm::dot(glm::cross(c[3] - c[0], c[1] - c[0]), up) > 0.0;
            flip = ccw_faces_up != (scene.generator.winding == Winding::ccw);

            thesisEvaluation.heightMap = heightMap;
            thesisEvaluation.mvp = viewProjection;
            thesisEvaluation.scaleXY = static_cast<T>(g.scale_xy);
            thesisEvaluation.scaleZ = static_cast<T>(g.scale_z);

            cosc422Evaluation.heightMap = heightMap;
            cosc422Evaluation.mvpMatrix = viewProjection;
            cosc422Evaluation.xMin = static_cast<T>(g.extent_u.x);
            cosc422Evaluation.xMax = static_cast<T>(g.extent_u.y);
            cosc422Evaluation.zMin = static_cast<T>(g.extent_v.x);
            cosc422Evaluation.zMax = static_cast<T>(g.extent_v.y);
            cosc422Evaluation.heightScale = static_cast<T>(g.scale_z);

            lab4Evaluation.heightMap = heightMapLod;
            lab4Evaluation.mvp = viewProjection;
            lab4Evaluation.horizontalScale = static_cast<T>(g.scale_xy);
            lab4Evaluation.verticalScale = static_cast<T>(g.scale_z);
            lab4Evaluation.texCoordOffset = vec2_t<T>(g.texcoord_offset);
        } else {
            flip = scene.generator.winding == Winding::cw;
        }
        if (em == EvaluationModel::pn) {
            pnEvaluation.m4ViewProjection = viewProjection;
            pnEvaluation.fInfluence = static_cast<T>(scene.evaluation.pn_influence);
            pnEvaluation.normal = scene.evaluation.pn_normal;
            pnEvaluation.watertightEdges = scene.evaluation.pn_watertight_edges;
        }
        if (scene.control) {
            const ControlStage& c = *scene.control;
            if (c.model == ControlModel::thesis) {
                thesisControl.factor = c.thesis.factor;
                thesisControl.tessellationLevel = static_cast<T>(c.thesis.level);
                thesisControl.scaleXY = static_cast<T>(scene.grid->scale_xy);
                thesisControl.cameraPosition = cameraPosition;
                thesisControl.tessellationMap = sampler<T>(c.thesis.tessellation_map);
                thesisControl.normalMap = normalMap;
                thesisControl.distance.limit = static_cast<T>(c.thesis.distance.limit);
                thesisControl.distance.divisor = static_cast<T>(c.thesis.distance.divisor);
                thesisControl.weights.constant = static_cast<T>(c.thesis.weights.constant);
                thesisControl.weights.normal = static_cast<T>(c.thesis.weights.normal);
                thesisControl.weights.texture = static_cast<T>(c.thesis.weights.texture);
                thesisControl.weights.distance = static_cast<T>(c.thesis.weights.distance);
                thesisControl.normalAngleThreshold = static_cast<T>(c.thesis.normal_threshold);
            } else if (c.model == ControlModel::lab4) {
                lab4Control.cameraPosition = cameraPosition;
                lab4Control.firstZoneEnd = static_cast<T>(c.lab4.first_zone_end);
                lab4Control.zoneGrowth = static_cast<T>(c.lab4.zone_growth);
                lab4Control.maxLevel = static_cast<T>(c.lab4.max_level);
                lab4Control.minLevel = static_cast<T>(c.lab4.min_level);
                lab4Control.edgeRule = c.lab4.edge_rule;
            } else if (c.model == ControlModel::pn) {
                const glm::ivec2 vp = scene.camera ? scene.camera->viewport : glm::ivec2(1280, 800);
                pnControl.v2Resolution = vec2_t<T>(static_cast<T>(vp.x), static_cast<T>(vp.y));
                pnControl.fPixelsPerEdge = static_cast<T>(c.pn.pixels_per_edge);
                pnControl.minLevel = static_cast<T>(c.pn.min_level);
                pnControl.maxLevel = static_cast<T>(c.pn.max_level);
                pnControl.flatEdgesAtLevel1 = c.pn.flat_edges_at_level_1;
            }
        }
    }

    // ---- pass 1: vertex shader and control stage ------------------------------------
    void control_patch(std::size_t p) {
        const std::optional<ControlStage>& control = scene.control;
        PatchLevels<T> patch_levels;  // GL's default patch levels (1) without a control stage
        if (scene.grid) {
            const TerrainGrid& g = *scene.grid;
            const std::size_t i = p % static_cast<std::size_t>(g.patches_u);
            const std::size_t j = p / static_cast<std::size_t>(g.patches_u);
            auto ground = [&](std::size_t a, std::size_t b) {
                return g.plane == GroundPlane::xy ? vec3_t<T>(u_coords[a], v_coords[b], T(0))
                                                  : vec3_t<T>(u_coords[a], T(0), v_coords[b]);
            };
            const std::array<vec3_t<T>, 4> flat{ground(i, j), ground(i, j + 1), ground(i + 1, j + 1), ground(i + 1, j)};
            std::array<vec4_t<T>, 4>& corners = tcPosition[p];
            const bool thesis_vs = scene.evaluation.model == EvaluationModel::thesis ||
                                   (control && control->model == ControlModel::thesis);
            for (int k = 0; k < 4; ++k)
                corners[k] = thesis_vs ? thesis_vertex<T>(vec2_t<T>(flat[k]), heightMap, thesisEvaluation.scaleXY,
                                                          thesisEvaluation.scaleZ)  // thesis_terrain.vert
                                       : vec4_t<T>(flat[k], T(1));                  // pass-through vertex shader
            const QuadCorners<T> vPosition{vec3_t<T>(corners[0]), vec3_t<T>(corners[1]), vec3_t<T>(corners[2]),
                                           vec3_t<T>(corners[3])};
            if (control) {
                switch (control->model) {
                    case ControlModel::constant:
                        patch_levels = constant_levels<T>(static_cast<T>(control->constant_level));
                        break;
                    case ControlModel::thesis: patch_levels = thesis_levels<T>(vPosition, thesisControl); break;
                    case ControlModel::cosc422:
                        patch_levels = cosc422_levels<T>(vPosition, control->cosc422_space, view);
                        break;
                    case ControlModel::lab4: {
                        const Lab4ControlOutput<T> out = lab4_control<T>(vPosition, lab4Control);
                        patch_levels = out.levels;
                        lab4Lod[p] = out.lod;
                        break;
                    }
                    case ControlModel::pn: break;  // rejected at load for a terrain
                }
            }
        } else {
            const TriangleMeshes& m = *scene.meshes;
            const auto& tri = m.triangles[p];
            TriangleCorners<T> pos, nrm;
            std::array<vec2_t<T>, 3> uv{};
            std::array<vec4_t<T>, 3> glPosition{};
            for (int k = 0; k < 3; ++k) {
                pos[k] = vec3_t<T>(m.positions[tri[k]]);
                nrm[k] = vec3_t<T>(m.normals[tri[k]]);
                if (!m.uvs.empty()) uv[k] = vec2_t<T>(m.uvs[tri[k]]);
                glPosition[k] = viewProjection * vec4_t<T>(pos[k], T(1));  // the tutorial's vertex shader
            }
            pnPatches[p] = pn_patch<T>(pos, nrm, uv);
            if (control) {
                if (control->model == ControlModel::constant)
                    patch_levels = constant_levels<T>(static_cast<T>(control->constant_level));
                else if (control->model == ControlModel::pn)
                    patch_levels = pn_levels<T>(glPosition, nrm, pnControl);
            }
        }
        levels[p] = to_tess_levels(patch_levels);
    }

    // ---- pass 4: evaluation and geometry of one patch ---------------------------------
    void evaluate_patch(std::size_t p, const Pattern& pattern, std::size_t vertex_base, std::size_t triangle_base,
                        PipelineResult& result, bool geometry_vertex_normals, bool eval_normals) {
        SurfaceMesh& mesh = result.mesh;
        const auto points = domain_points<T>(pattern);
        const auto float_points = pattern.points();
        const EvaluationModel em = scene.evaluation.model;
        const std::optional<GeometryStage>& geometry = scene.geometry;
        const bool want_uv = scene.grid || (scene.meshes && !scene.meshes->uvs.empty());
        for (std::size_t k = 0; k < points.size(); ++k) {
            const DomainPoint<T>& tc = points[k];
            EvaluatedVertex<T> ev;
            T lod = T(0);
            switch (em) {
                case EvaluationModel::thesis: ev = thesis_evaluate<T>(tcPosition[p], tc, thesisEvaluation); break;
                case EvaluationModel::cosc422: ev = cosc422_evaluate<T>(tcPosition[p], tc, cosc422Evaluation); break;
                case EvaluationModel::lab4:
                    ev = lab4_evaluate<T>(tcPosition[p], tc, lab4Lod[p], lab4Evaluation);
                    lod = lab4Lod[p].maxLogTessellationLevel - lab4_vertex_log_level<T>(tc, lab4Lod[p]);
                    break;
                case EvaluationModel::pn: ev = pn_evaluate<T>(pnPatches[p], tc, pnEvaluation); break;
            }
            const std::size_t v = vertex_base + k;
            mesh.positions[v] = glm::dvec3(ev.position);
            if (want_uv) mesh.uvs[v] = glm::dvec2(ev.textureCoordinate);
            mesh.patch_ids[v] = static_cast<std::uint32_t>(p);
            mesh.tess_coords[v] = glm::vec3(float_points[k].u, float_points[k].v, float_points[k].w);
            if (eval_normals) mesh.normals[v] = glm::dvec3(ev.normal);
            if (geometry_vertex_normals) mesh.normals[v] = glm::dvec3(vertex_normal(ev, lod));
        }
        const std::size_t n_tri = pattern.primitive_count();
        for (std::size_t t = 0; t < n_tri; ++t) {
            const auto prim = pattern.primitive(t);
            std::array<std::uint32_t, 3> tri{static_cast<std::uint32_t>(vertex_base + prim[0]),
                                             static_cast<std::uint32_t>(vertex_base + prim[1]),
                                             static_cast<std::uint32_t>(vertex_base + prim[2])};
            if (flip) std::swap(tri[1], tri[2]);
            mesh.triangles[triangle_base + t] = tri;
            if (geometry && geometry->normals == GeometryNormals::face) {
                // The geometry shader's face normal, from the vertices as the pipeline holds them.
                const vec3_t<T> p0(mesh.positions[tri[0]]), p1(mesh.positions[tri[1]]), p2(mesh.positions[tri[2]]);
                result.face_normals[triangle_base + t] = glm::dvec3(face_normal<T>(p0, p1, p2));
            }
        }
    }

    vec3_t<T> vertex_normal(const EvaluatedVertex<T>& ev, T lod) const {
        const TerrainGrid& g = *scene.grid;
        if (scene.geometry->normals == GeometryNormals::normal_map) {
            // thesis_terrain.geom: gNormal = NormalFromTexture(texture(normalMap, textureCoordinate).rgb)
            return thesis_normal_from_texture<T>(vec3_t<T>(normalMap(ev.textureCoordinate)), normalMatrix);
        }
        // height_field
        if (scene.evaluation.model == EvaluationModel::lab4) {
            // lab4_terrain.tese: lab4_vertex_normal(position.x, position.z, lod)
            Lab4NormalSampling<T> sampling;
            sampling.heightMap = heightMapLod;
            sampling.horizontalScale = lab4Evaluation.horizontalScale;
            sampling.verticalScale = lab4Evaluation.verticalScale;
            sampling.texCoordOffset = lab4Evaluation.texCoordOffset;
            sampling.h = static_cast<T>(g.scale_xy / height_texture->width());  // gridStep: one texel
            sampling.lod = lod;
            return lab4_vertex_normal<T>(ev.position.x, ev.position.z, sampling);
        }
        // Appendix A at level 0 for the other terrains, from the vertex's texture coordinate.
        if (g.plane == GroundPlane::xy) {
            // Thesis mapping st = xy / scaleXY; appendix A's frame (x, up, z') with z' = world y:
            // the returned (nx, n_up, nz') is the world normal (nx, nz', n_up).
            const T h = static_cast<T>(g.scale_xy / height_texture->width());
            const T step = static_cast<T>(1.0 / height_texture->width());
            const auto n = lab4_height_normal(*height_texture, ev.textureCoordinate, vec2_t<T>(step, step), h,
                                              static_cast<T>(g.scale_z), T(0));
            return vec3_t<T>(n.x, n.z, n.y);
        }
        // COSC422 mapping s = (x - x0)/(x1 - x0), t = (z - z0)/(z1 - z0), y up.
        const double h = std::abs(g.extent_u.y - g.extent_u.x) / height_texture->width();
        const vec2_t<T> st_step(static_cast<T>(h / (g.extent_u.y - g.extent_u.x)),
                                static_cast<T>(h / (g.extent_v.y - g.extent_v.x)));
        return vec3_t<T>(lab4_height_normal(*height_texture, ev.textureCoordinate, st_step, static_cast<T>(h),
                                            static_cast<T>(g.scale_z), T(0)));
    }

    // A vertex at infinity or NaN (a height texel that scale_z carries past the float range,
    // say) would reach the mesh file or the rasterizer silently; the run stops instead,
    // naming the first such vertex (lowest index, so the same whatever the thread count),
    // its patch and tess coord, and for a terrain the largest texel its height was read from.
    // (A post-evaluation check rather than one at load: whether a texel overflows depends
    // on the model, the precision and the interpolation, which only evaluation knows.)
    void require_finite_positions(const SurfaceMesh& mesh) const {
        const auto finite = [](const glm::dvec3& p) {
            return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
        };
        const auto bad = std::find_if_not(mesh.positions.begin(), mesh.positions.end(), finite);
        if (bad == mesh.positions.end()) return;
        const std::size_t v = static_cast<std::size_t>(bad - mesh.positions.begin());
        const auto number = [](double x) {
            char buffer[32];
            std::snprintf(buffer, sizeof buffer, "%.9g", x);
            return std::string(buffer);
        };
        const glm::vec3 tc = mesh.tess_coords[v];
        std::string what = "patch " + std::to_string(mesh.patch_ids[v]) + " evaluates to a non-finite vertex (" +
                           number(bad->x) + ", " + number(bad->y) + ", " + number(bad->z) + ") at tess coord (" +
                           number(tc.x) + ", " + number(tc.y) + ", " + number(tc.z) + ") in " +
                           (precision == Precision::gpu ? "gpu (float)" : "exact (double)") + " precision";
        Where where{scene.file, 0, 0, "", static_cast<long long>(mesh.patch_ids[v])};
        if (scene.grid && !mesh.uvs.empty()) {
            // The level-0 texels of the bilinear footprint at the vertex's texture coordinate
            // (clamped to the edge); the one of largest magnitude is the likely culprit.
            const Texture& t = *height_texture;
            const glm::dvec2 st = mesh.uvs[v];
            const auto footprint = [](double s, int size) {
                const double u = std::isfinite(s) ? std::clamp(s * size - 0.5, -1.0, double(size)) : 0.0;
                const int i = static_cast<int>(std::floor(u));
                return std::array<int, 2>{std::clamp(i, 0, size - 1), std::clamp(i + 1, 0, size - 1)};
            };
            const auto xs = footprint(st.x, t.width());
            const auto ys = footprint(st.y, t.height());
            int tx = xs[0], ty = ys[0];
            for (int x : xs)
                for (int y : ys)
                    if (std::abs(t.texel_exact(0, x, y)) > std::abs(t.texel_exact(0, tx, ty))) tx = x, ty = y;
            what += ": its height is read at texture coordinate (" + number(st.x) + ", " + number(st.y) +
                    ") from texels up to (" + std::to_string(tx) + ", " + std::to_string(ty) + ") = " +
                    number(t.texel_exact(0, tx, ty)) + " of " + scene.grid->heightmap_path +
                    ", times domain.scale_z = " + number(scene.grid->scale_z);
            where.key = "domain.heightmap";
        }
        throw Error(what, where);
    }

    PipelineResult run() {
        setup();
        PipelineResult result;
        const std::size_t n = patch_count;
        levels.assign(n, TessLevels{});
        if (scene.grid) tcPosition.assign(n, {});
        if (scene.control && scene.control->model == ControlModel::lab4) lab4Lod.assign(n, {});
        if (scene.meshes) pnPatches.assign(n, {});

        // Pass 1: control.
        tessref::parallel_for(tbb::blocked_range<std::size_t>(0, n, 64), [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t p = r.begin(); p != r.end(); ++p) control_patch(p);
        });

        // Pass 2: the budget, from the levels, before any tessellation.
        std::uint64_t estimate = 0;
        for (std::size_t p = 0; p < n; ++p) estimate += estimate_triangles(scene.generator, levels[p]);
        result.estimated_triangles = estimate;
        if (estimate > scene.max_triangles)
            throw Error("the scene asks for up to " + std::to_string(estimate) +
                            " triangles (estimated from its tessellation levels), more than limits.max_triangles = " +
                            std::to_string(scene.max_triangles),
                        scene.max_triangles_where);

        // Pass 3: patterns, and every patch's place in the output. Patches are grouped by
        // the bits of their levels first, so each distinct level set is tessellated once
        // even when many threads would ask the cache for it at the same moment.
        PatternCache local_cache;
        PatternCache& cache = options.cache ? *options.cache : local_cache;
        using Key = std::array<std::uint32_t, 6>;
        auto key_of = [&](std::size_t p) {
            Key k{};
            for (int i = 0; i < 4; ++i) k[i] = std::bit_cast<std::uint32_t>(levels[p].outer[i]);
            for (int i = 0; i < 2; ++i) k[4 + i] = std::bit_cast<std::uint32_t>(levels[p].inner[i]);
            return k;
        };
        std::vector<std::size_t> order(n);
        for (std::size_t p = 0; p < n; ++p) order[p] = p;
        std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return key_of(a) < key_of(b); });
        std::vector<std::size_t> representatives;  // first patch of each distinct level set
        std::vector<std::size_t> group(n);          // patch -> index into representatives
        for (std::size_t k = 0; k < n; ++k) {
            if (k == 0 || key_of(order[k]) != key_of(order[k - 1])) representatives.push_back(order[k]);
            group[order[k]] = representatives.size() - 1;
        }
        std::vector<std::shared_ptr<const Pattern>> distinct(representatives.size());
        tessref::parallel_for(tbb::blocked_range<std::size_t>(0, representatives.size(), 1),
                          [&](const tbb::blocked_range<std::size_t>& r) {
                              for (std::size_t k = r.begin(); k != r.end(); ++k)
                                  distinct[k] = cache.get(scene.generator, levels[representatives[k]], precision);
                          });
        result.distinct_patterns = distinct.size();
        std::vector<std::shared_ptr<const Pattern>> patterns(n);
        for (std::size_t p = 0; p < n; ++p) patterns[p] = distinct[group[p]];
        std::vector<std::size_t> vertex_base(n + 1, 0), triangle_base(n + 1, 0);
        for (std::size_t p = 0; p < n; ++p) {
            vertex_base[p + 1] = vertex_base[p] + patterns[p]->points().size();
            triangle_base[p + 1] = triangle_base[p] + patterns[p]->primitive_count();
        }
        const std::size_t vertices = vertex_base[n], triangles = triangle_base[n];
        if (vertices > 0xffffffffu)
            throw Error("the scene emits " + std::to_string(vertices) + " vertices, more than 32-bit indices address",
                        scene.max_triangles_where);

        // Pass 4: evaluation and geometry.
        SurfaceMesh& mesh = result.mesh;
        const bool geometry_vertex_normals =
            scene.geometry && (scene.geometry->normals == GeometryNormals::normal_map ||
                               scene.geometry->normals == GeometryNormals::height_field);
        const bool eval_normals = !scene.geometry && scene.evaluation.model == EvaluationModel::pn;
        mesh.positions.resize(vertices);
        mesh.patch_ids.resize(vertices);
        mesh.tess_coords.resize(vertices);
        if (scene.grid || !scene.meshes->uvs.empty()) mesh.uvs.resize(vertices);
        if (geometry_vertex_normals || eval_normals) mesh.normals.resize(vertices);
        mesh.triangles.resize(triangles);
        if (scene.geometry && scene.geometry->normals == GeometryNormals::face) result.face_normals.resize(triangles);

        std::atomic<std::size_t> done{0};
        std::mutex progress_mutex;
        tessref::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4), [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t p = r.begin(); p != r.end(); ++p) {
                evaluate_patch(p, *patterns[p], vertex_base[p], triangle_base[p], result, geometry_vertex_normals,
                               eval_normals);
                const std::size_t d = ++done;
                if (options.progress) {
                    std::lock_guard<std::mutex> lock(progress_mutex);
                    options.progress(std::max(d, done.load()), n);
                }
            }
        });

        require_finite_positions(mesh);

        if (scene.geometry && scene.geometry->normals == GeometryNormals::smooth) {
            std::vector<vec3_t<T>> positions(vertices);
            for (std::size_t v = 0; v < vertices; ++v) positions[v] = vec3_t<T>(mesh.positions[v]);
            const auto normals = smooth_vertex_normals<T>(std::span<const vec3_t<T>>(positions),
                                                          std::span<const std::array<std::uint32_t, 3>>(mesh.triangles),
                                                          Weld::by_position);
            mesh.normals.resize(vertices);
            for (std::size_t v = 0; v < vertices; ++v) mesh.normals[v] = glm::dvec3(normals[v]);
        }

        result.levels = std::move(levels);
        result.stages.control = scene.control.has_value();
        result.stages.evaluation = true;
        result.stages.geometry = scene.geometry.has_value();
        return result;
    }
};

}  // namespace

PipelineResult run_pipeline(const Scene& scene, const PipelineOptions& options) {
    if (scene.patch_count() == 0) throw Error("the scene has no patches", Where{scene.file, 0, 0, "", -1});
    if (options.precision == Precision::gpu) return Run<float>(scene, options).run();
    return Run<double>(scene, options).run();
}

}  // namespace tessref
