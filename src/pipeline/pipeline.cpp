// pipeline.cpp — run_pipeline(): the passes over the patches, in the order GL runs them.
//
// Four passes, each parallel over patches with oneTBB and each writing only its own
// patch's pre-sized slot, so the result does not depend on the thread count:
//  1. control: the vertex and control shaders of every patch (its levels);
//  2. budget: an upper bound of the triangle count from the levels, before tessellating;
//  3. generator: one pattern per distinct level set (PatternCache), and every patch's
//     vertex and triangle ranges in the output by prefix sums;
//  4. evaluation and per-vertex / per-face geometry into those ranges.
// Smooth normals, which need the whole surface, follow serially (geometry.h sums in
// triangle order, deterministic). Everything model-specific is the program's
// (program.h); this file reads the same for every model.
#include "tessref/pipeline.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <mutex>
#include <span>
#include <string>
#include <type_traits>

#include "common/parallel.h"
#include "pipeline/program.h"
#include "tessref/geometry.h"
#include "tessref/limits.h"

namespace tessref {
namespace {

// Tess coords in the run's precision.
template <typename T>
std::span<const DomainPoint<T>> domain_points(const Pattern& pattern) {
    if constexpr (std::is_same_v<T, float>)
        return pattern.points();
    else
        return pattern.points_exact();
}

// A vertex at infinity or NaN (a height texel that scale_z carries past the float range,
// say) would reach the mesh file or the rasterizer silently; the run stops instead,
// naming the first such vertex (lowest index, so the same whatever the thread count),
// its patch and tess coord, and for a terrain the largest texel its height was read from.
// (A post-evaluation check rather than one at load: whether a texel overflows depends
// on the model, the precision and the interpolation, which only evaluation knows.)
void require_finite_positions(const Scene& scene, const SurfaceMesh& mesh, Precision precision) {
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
    Where where = Where::at_patch(scene.file, mesh.patch_ids[v]);
    if (scene.grid && !mesh.uvs.empty()) {
        // The level-0 texels of the bilinear footprint at the vertex's texture coordinate
        // (clamped to the edge); the one of largest magnitude is the likely culprit.
        const Texture& t = scene.grid->heightmap->texture;
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


// The patches grouped by their level sets: each distinct set is tessellated once, even
// when many threads would ask the cache for it at the same moment.
std::vector<std::shared_ptr<const Pattern>> patterns_of(const Scene& scene, const std::vector<TessLevels>& levels,
                                                       Precision precision, PatternCache& cache,
                                                       std::size_t& distinct_count) {
    const std::size_t n = levels.size();
    std::vector<LevelBits> keys(n);
    for (std::size_t p = 0; p < n; ++p) keys[p] = level_bits(levels[p]);
    std::vector<std::size_t> order(n);
    for (std::size_t p = 0; p < n; ++p) order[p] = p;
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return keys[a] < keys[b]; });
    std::vector<std::size_t> representatives;  // first patch of each distinct level set
    std::vector<std::size_t> group(n);          // patch -> index into representatives
    for (std::size_t k = 0; k < n; ++k) {
        if (k == 0 || keys[order[k]] != keys[order[k - 1]]) representatives.push_back(order[k]);
        group[order[k]] = representatives.size() - 1;
    }
    std::vector<std::shared_ptr<const Pattern>> distinct(representatives.size());
    tessref::parallel_for(tbb::blocked_range<std::size_t>(0, representatives.size(), 1),
                          [&](const tbb::blocked_range<std::size_t>& r) {
                              for (std::size_t k = r.begin(); k != r.end(); ++k)
                                  distinct[k] = cache.get(scene.generator, levels[representatives[k]], precision);
                          });
    distinct_count = distinct.size();
    std::vector<std::shared_ptr<const Pattern>> patterns(n);
    for (std::size_t p = 0; p < n; ++p) patterns[p] = distinct[group[p]];
    return patterns;
}

using Clock = std::chrono::steady_clock;

// What a geometry shader's emitted vertex takes in SurfaceMesh: position, normal and uv in
// double, tess coord, patch id, and its share of a triangle.
constexpr std::uint64_t kEmittedVertexBytes = 3 * 8 + 3 * 8 + 2 * 8 + 3 * 4 + 4 + 4;

// Pass timings (PipelineTimings), only when asked for; they change nothing else.
struct PassTimer {
    PipelineTimings* timings;
    Clock::time_point lap = Clock::now();
    void operator()(double PipelineTimings::*field) {
        if (!timings) return;
        const Clock::time_point now = Clock::now();
        timings->*field = std::chrono::duration<double>(now - lap).count();
        lap = now;
    }
};

}  // namespace

struct PatchStream::Impl {
    virtual ~Impl() = default;
    virtual void emit(std::size_t patch, SurfaceMesh& mesh, std::size_t first_vertex, std::size_t first_triangle,
                      std::vector<glm::dvec3>* face_normals, bool vertex_normals, bool provenance,
                      bool triangles, PatchStream::Projection* projection) const = 0;
    virtual void evaluate_points(std::size_t patch, std::span<const std::uint32_t> points, SurfaceMesh& mesh,
                                 std::size_t first) const = 0;
    virtual void later_normals(std::size_t patch, std::span<const std::uint32_t> points, SurfaceMesh& mesh,
                               std::size_t first) const = 0;
    virtual std::array<std::uint32_t, 3> triangle(std::size_t triangle, SurfaceMesh& out,
                                                  glm::dvec3* face_normal) const = 0;

    Precision precision = Precision::gpu;
    bool flip = false;  // the program reverses the pattern's triangles (1 <-> 2)
    glm::dvec3 origin{0.0};
    std::vector<TessLevels> levels;
    std::uint64_t estimated_triangles = 0;
    std::size_t distinct_patterns = 0;
    std::vector<std::shared_ptr<const Pattern>> patterns;
    std::vector<std::size_t> vertex_base, triangle_base;
    bool has_uvs = false, has_normals = false, face_normals = false, smooth_normals = false;
    // A user's geometry shader: per patch, what it emitted (PatchProgram::geometry).
    bool geometry_shader = false;
    std::vector<SurfaceMesh> emitted;
    std::vector<std::vector<glm::dvec3>> emitted_face_normals;
};

namespace {

template <typename T>
struct StreamImpl final : PatchStream::Impl {
    std::unique_ptr<pipeline::PatchProgram<T>> program;

    StreamImpl(const Scene& scene, const PipelineOptions& options, PassTimer& time_pass) {
        precision = options.precision;
        const std::size_t n = scene.patch_count();
        // Camera-relative evaluation: gpu precision only (exact precision would gain nothing).
        if (options.camera_relative && std::is_same_v<T, float>) origin = camera_relative_origin(scene);
        program = pipeline::make_program<T>(scene, origin);
        program->use_math(options.math);
        flip = program->flip;
        has_uvs = program->has_uvs;
        has_normals = program->has_normals;
        face_normals = scene.geometry && scene.geometry->normals == GeometryNormals::face;
        smooth_normals = scene.geometry && scene.geometry->normals == GeometryNormals::smooth;

        // Pass 1: the vertex and control shaders.
        levels.resize(n);
        tessref::parallel_for(tbb::blocked_range<std::size_t>(0, n, 64), [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t p = r.begin(); p != r.end(); ++p) levels[p] = to_tess_levels(program->control(p));
        });

        // Pass 2: the budget, from the levels, before any tessellation.
        std::uint64_t estimate = 0;
        for (std::size_t p = 0; p < n; ++p) estimate += estimate_triangles(scene.generator, levels[p]);
        estimated_triangles = estimate;
        if (estimate > scene.max_triangles)
            throw Error("the scene asks for up to " + std::to_string(estimate) +
                            " triangles (estimated from its tessellation levels), more than limits.max_triangles = " +
                            std::to_string(scene.max_triangles),
                        scene.max_triangles_where);
        time_pass(&PipelineTimings::control);

        // Pass 3: the primitive generator, and every patch's place in the output.
        PatternCache local_cache;
        patterns = patterns_of(scene, levels, precision, options.cache ? *options.cache : local_cache,
                               distinct_patterns);
        vertex_base.assign(n + 1, 0);
        triangle_base.assign(n + 1, 0);
        for (std::size_t p = 0; p < n; ++p) {
            vertex_base[p + 1] = vertex_base[p] + patterns[p]->points().size();
            triangle_base[p + 1] = triangle_base[p] + patterns[p]->primitive_count();
        }
        time_pass(&PipelineTimings::generator);
        if (program->geometry_shader()) {
            // The geometry shader decides how many triangles each patch makes: its output
            // is computed now, patch by patch in parallel, and emit() copies it.
            geometry_shader = true;
            emitted.resize(n);
            emitted_face_normals.resize(n);
            // The budget again, as the output grows: a geometry shader may emit more
            // triangles than it is given (up to max_vertices - 2 for each).
            std::atomic<std::uint64_t> total{0};
            const auto over_budget = [&] {
                return Error("the scene's geometry shader emits more triangles than limits.max_triangles = " +
                                 std::to_string(scene.max_triangles),
                             scene.max_triangles_where);
            };
            tessref::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1), [&](const tbb::blocked_range<std::size_t>& r) {
                for (std::size_t p = r.begin(); p != r.end(); ++p) {
                    program->geometry(p, *patterns[p], emitted[p], emitted_face_normals[p]);
                    const std::uint64_t so_far = total += emitted[p].triangles.size();
                    if (so_far > scene.max_triangles) throw over_budget();
                    // Held until the stream closes: three vertices of their own a triangle.
                    require_memory(saturating_bytes(so_far, 3 * kEmittedVertexBytes),
                                   "the output of the scene's geometry shader (" + std::to_string(so_far) +
                                       " triangles so far)",
                                   scene.max_triangles_where);
                }
            });
            for (std::size_t p = 0; p < n; ++p) {
                vertex_base[p + 1] = vertex_base[p] + emitted[p].positions.size();
                triangle_base[p + 1] = triangle_base[p] + emitted[p].triangles.size();
            }
            time_pass(&PipelineTimings::geometry);
        }
        if (vertex_base[n] > 0xffffffffu)
            throw Error("the scene emits " + std::to_string(vertex_base[n]) +
                            " vertices, more than 32-bit indices address",
                        scene.max_triangles_where);
    }

    void write_coords(std::size_t p, std::span<const TessCoord> coords, SurfaceMesh& mesh, std::size_t first) const {
        for (std::size_t k = 0; k < coords.size(); ++k) {
            mesh.patch_ids[first + k] = static_cast<std::uint32_t>(p);
            mesh.tess_coords[first + k] = glm::vec3(coords[k].u, coords[k].v, coords[k].w);
        }
    }

    // A geometry shader's output of patch p (held since the stream opened): its vertices
    // `vertices`, in that order, at mesh index first on.
    void copy_emitted(std::size_t p, std::span<const std::uint32_t> vertices, SurfaceMesh& mesh, std::size_t first) const {
        const SurfaceMesh& e = emitted[p];
        for (std::size_t k = 0; k < vertices.size(); ++k) {
            const std::size_t v = vertices[k];
            mesh.positions[first + k] = e.positions[v];
            mesh.patch_ids[first + k] = e.patch_ids[v];
            mesh.tess_coords[first + k] = e.tess_coords[v];
            if (has_uvs) mesh.uvs[first + k] = e.uvs[v];
            if (has_normals) mesh.normals[first + k] = e.normals[v];
        }
    }

    void emit(std::size_t p, SurfaceMesh& mesh, std::size_t first_vertex, std::size_t first_triangle,
              std::vector<glm::dvec3>* normals_out, bool vertex_normals, bool provenance,
              bool write_triangles, PatchStream::Projection* projection) const override {
        if (geometry_shader) {
            const SurfaceMesh& e = emitted[p];
            std::vector<std::uint32_t> all(e.positions.size());
            for (std::size_t v = 0; v < all.size(); ++v) all[v] = static_cast<std::uint32_t>(v);
            copy_emitted(p, all, mesh, first_vertex);
            if (projection)
                projection->finite &= pipeline::project_vertices(mesh.positions.data() + first_vertex, all.size(),
                                                                 projection->mvp, projection->clip + first_vertex);
            const auto base = static_cast<std::uint32_t>(first_vertex);
            for (std::size_t t = 0; t < e.triangles.size(); ++t)
                mesh.triangles[first_triangle + t] = {base + e.triangles[t][0], base + e.triangles[t][1], base + e.triangles[t][2]};
            if (face_normals && normals_out)
                std::copy(emitted_face_normals[p].begin(), emitted_face_normals[p].end(),
                          normals_out->begin() + static_cast<std::ptrdiff_t>(first_triangle));
            return;
        }
        const Pattern& pattern = *patterns[p];
        if (projection) {
            // The face normals below are computed from the positions: written whatever the
            // caller asked.
            const bool asked = projection->positions;
            projection->positions = asked || (face_normals && normals_out);
            program->evaluate_projected(p, domain_points<T>(pattern), mesh, first_vertex, vertex_normals, *projection);
            projection->positions = asked;
        } else {
            program->evaluate(p, domain_points<T>(pattern), mesh, first_vertex, vertex_normals);
        }
        if (provenance) write_coords(p, pattern.points(), mesh, first_vertex);
        // The pattern's triangles (a scene's domain makes triangles: three indices each) moved
        // to the patch's vertices, reversed (1 <-> 2) where the program flips them: a loop per
        // orientation, with nothing else in it.
        const std::uint32_t* indices = pattern.indices().data();
        const std::size_t count = pattern.primitive_count();
        const auto base = static_cast<std::uint32_t>(first_vertex);
        const auto placed = [&](std::size_t t, bool flip) -> std::array<std::uint32_t, 3> {
            const std::uint32_t* prim = indices + 3 * t;
            return {base + prim[0], base + prim[flip ? 2 : 1], base + prim[flip ? 1 : 2]};
        };
        const auto move = [&]<bool flip>() {
            for (std::size_t t = 0; t < count; ++t) mesh.triangles[first_triangle + t] = placed(t, flip);
        };
        if (write_triangles) {
            if (program->flip) move.template operator()<true>();
            else move.template operator()<false>();
        }
        if (face_normals && normals_out) {
            for (std::size_t t = 0; t < count; ++t) {
                // The geometry shader's face normal, from the vertices as the evaluation wrote them.
                const std::array<std::uint32_t, 3> tri = placed(t, program->flip);
                const vec3_t<T> p0(mesh.positions[tri[0]]), p1(mesh.positions[tri[1]]), p2(mesh.positions[tri[2]]);
                (*normals_out)[first_triangle + t] = glm::dvec3(face_normal<T>(p0, p1, p2));
            }
        }
    }

    // `out` sized for one triangle (0, 1, 2) and the attributes the surface has.
    void one_triangle(SurfaceMesh& out) const {
        out.positions.resize(3);
        out.patch_ids.resize(3);
        out.tess_coords.resize(3);
        out.uvs.resize(has_uvs ? 3 : 0);
        out.normals.resize(has_normals ? 3 : 0);
        out.triangles.assign(1, {0, 1, 2});
    }

    std::array<std::uint32_t, 3> triangle(std::size_t triangle, SurfaceMesh& out,
                                          glm::dvec3* normal_out) const override {
        const std::size_t p = static_cast<std::size_t>(
            std::upper_bound(triangle_base.begin(), triangle_base.end(), triangle) - triangle_base.begin() - 1);
        if (geometry_shader) {
            const std::array<std::uint32_t, 3> tri = emitted[p].triangles[triangle - triangle_base[p]];
            one_triangle(out);
            copy_emitted(p, tri, out, 0);
            if (face_normals && normal_out) *normal_out = emitted_face_normals[p][triangle - triangle_base[p]];
            for (glm::dvec3& position : out.positions) position += origin;
            const auto first = static_cast<std::uint32_t>(vertex_base[p]);
            return {first + tri[0], first + tri[1], first + tri[2]};
        }
        const auto prim = patterns[p]->primitive(triangle - triangle_base[p]);
        std::array<std::uint32_t, 3> points{prim[0], prim[1], prim[2]};
        if (program->flip) std::swap(points[1], points[2]);
        one_triangle(out);
        evaluate_points(p, points, out, 0);
        if (face_normals && normal_out) {
            const vec3_t<T> p0(out.positions[0]), p1(out.positions[1]), p2(out.positions[2]);
            *normal_out = glm::dvec3(face_normal<T>(p0, p1, p2));
        }
        for (glm::dvec3& position : out.positions) position += origin;
        const auto first = static_cast<std::uint32_t>(vertex_base[p]);
        return {first + points[0], first + points[1], first + points[2]};
    }

    void evaluate_points(std::size_t p, std::span<const std::uint32_t> indices, SurfaceMesh& mesh,
                         std::size_t first) const override {
        if (geometry_shader) return copy_emitted(p, indices, mesh, first);
        const Pattern& pattern = *patterns[p];
        const auto all = domain_points<T>(pattern);
        const auto coords = pattern.points();
        // The evaluation is a function of each point alone: a few at a time give the same bits.
        std::array<DomainPoint<T>, 16> points;
        std::array<TessCoord, 16> tess;
        for (std::size_t k0 = 0; k0 < indices.size(); k0 += points.size()) {
            const std::size_t count = std::min(points.size(), indices.size() - k0);
            for (std::size_t k = 0; k < count; ++k) {
                points[k] = all[indices[k0 + k]];
                tess[k] = coords[indices[k0 + k]];
            }
            program->evaluate(p, std::span<const DomainPoint<T>>(points.data(), count), mesh, first + k0, true);
            write_coords(p, std::span<const TessCoord>(tess.data(), count), mesh, first + k0);
        }
    }
    void later_normals(std::size_t p, std::span<const std::uint32_t> indices, SurfaceMesh& mesh,
                       std::size_t first) const override {
        if (!has_normals) return;
        if (geometry_shader) {
            // emit() copied the geometry shader's normals already (it has no later).
            const SurfaceMesh& e = emitted[p];
            for (const std::uint32_t i : indices) mesh.normals[first + i] = e.normals[i];
            return;
        }
        const auto all = domain_points<T>(*patterns[p]);
        std::array<DomainPoint<T>, 64> points;
        std::array<std::uint32_t, 64> vertices;
        for (std::size_t k0 = 0; k0 < indices.size(); k0 += points.size()) {
            const std::size_t count = std::min(points.size(), indices.size() - k0);
            for (std::size_t k = 0; k < count; ++k) {
                points[k] = all[indices[k0 + k]];
                vertices[k] = static_cast<std::uint32_t>(first + indices[k0 + k]);
            }
            program->later_normals(p, std::span<const DomainPoint<T>>(points.data(), count),
                                   std::span<const std::uint32_t>(vertices.data(), count), mesh);
        }
    }
};

template <typename T>
std::unique_ptr<PatchStream::Impl> make_stream(const Scene& scene, const PipelineOptions& options, PassTimer& timer) {
    return std::make_unique<StreamImpl<T>>(scene, options, timer);
}

std::unique_ptr<PatchStream::Impl> open_stream(const Scene& scene, const PipelineOptions& options, PassTimer& timer) {
    if (scene.patch_count() == 0) throw Error("the scene has no patches", Where::in_file(scene.file));
    if (!PatchStream::streams(scene))
        throw Error("a geomipmapped terrain has no tessellation stages to stream", Where::at_key(scene.file, "evaluation.model"));
    if (options.precision == Precision::gpu) return make_stream<float>(scene, options, timer);
    return make_stream<double>(scene, options, timer);
}

PipelineResult run(const Scene& scene, const PipelineOptions& options) {
    PassTimer time_pass{options.timings};
    if (options.timings) *options.timings = PipelineTimings{};
    PatchStream stream(scene, options);
    const std::size_t n = stream.patch_count();
    const std::size_t vertices = stream.vertex_base(n), triangles = stream.triangle_base(n);
    time_pass.lap = Clock::now();
    PipelineResult result;
    result.origin = stream.origin();
    const bool relative = result.origin != glm::dvec3(0.0);

    // Pass 4: evaluation and geometry, every patch into its slot.
    SurfaceMesh& mesh = result.mesh;
    stream.size(mesh, result.face_normals, vertices, triangles);

    std::atomic<std::size_t> done{0};
    std::mutex progress_mutex;
    tessref::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t p = r.begin(); p != r.end(); ++p) {
            stream.emit(p, mesh, stream.vertex_base(p), stream.triangle_base(p), &result.face_normals);
            const std::size_t d = ++done;
            if (options.progress) {
                std::lock_guard<std::mutex> lock(progress_mutex);
                options.progress(std::max(d, done.load()), n);
            }
        }
    });

    // Camera-relative: the evaluation wrote origin-relative floats; the mesh holds world
    // positions (origin added in double), the renderer the floats themselves.
    if (relative) {
        result.relative_positions.resize(vertices);
        for (std::size_t v = 0; v < vertices; ++v) {
            result.relative_positions[v] = glm::vec3(mesh.positions[v]);
            mesh.positions[v] += result.origin;
        }
    }

    require_finite_positions(scene, mesh, options.precision);
    time_pass(&PipelineTimings::evaluation);

    if (stream.smooth_normals()) {
        // From the positions as the evaluation wrote them (origin-relative when camera-relative).
        const auto smooth = [&](auto zero) {
            using T = decltype(zero);
            std::vector<vec3_t<T>> positions(vertices);
            for (std::size_t v = 0; v < vertices; ++v)
                positions[v] = relative ? vec3_t<T>(result.relative_positions[v]) : vec3_t<T>(mesh.positions[v]);
            const auto normals = smooth_vertex_normals<T>(std::span<const vec3_t<T>>(positions),
                                                          std::span<const std::array<std::uint32_t, 3>>(mesh.triangles),
                                                          Weld::by_position);
            mesh.normals.resize(vertices);
            for (std::size_t v = 0; v < vertices; ++v) mesh.normals[v] = glm::dvec3(normals[v]);
        };
        if (options.precision == Precision::gpu) smooth(0.0f);
        else smooth(0.0);
        time_pass(&PipelineTimings::geometry);
    }

    result.levels = stream.levels();
    result.geometry_shader = stream.geometry_shader();
    result.reversed = stream.reversed();
    result.estimated_triangles = stream.estimated_triangles();
    result.distinct_patterns = stream.distinct_patterns();
    result.stages.control = scene.control.has_value();
    result.stages.evaluation = true;
    result.stages.geometry = scene.geometry.has_value();
    return result;
}

}  // namespace

namespace {

// Pieces of about kPieceTriangles triangles (whole patches), evaluated kPiecesAtOnce at a
// time: small enough (about 80 bytes a vertex, half a vertex a triangle) that the weld
// finds a batch still in the caches, large enough to keep the threads busy.
constexpr std::size_t kPieceTriangles = std::size_t{1} << 13;
constexpr std::size_t kPiecesAtOnce = 4;

struct Piece {
    std::size_t first_patch = 0, last_patch = 0;
    SurfaceMesh mesh;  // no face normals: a mesh file has none
};

struct Batch {
    std::vector<Piece> pieces{kPiecesAtOnce};
    std::size_t used = 0;
    std::exception_ptr failure;  // of its evaluation, thrown when the batch's turn to be welded comes
};

// The next pieces of whole patches from next_patch on (none when it is past the last).
void plan_batch(const PatchStream& stream, std::size_t& next_patch, Batch& batch) {
    batch.used = 0;
    batch.failure = nullptr;
    for (; batch.used < batch.pieces.size() && next_patch < stream.patch_count(); ++batch.used) {
        Piece& piece = batch.pieces[batch.used];
        piece.first_patch = next_patch;
        next_patch = piece.last_patch = stream.run_end(next_patch, kPieceTriangles);
    }
}

// Pass 4 for the batch's patches, each piece what run_pipeline()'s mesh holds for its patches.
void evaluate_batch(const PatchStream& stream, Batch& batch) {
    const glm::dvec3 origin = stream.origin();
    try {
        tessref::parallel_for(std::size_t{0}, batch.used, [&](std::size_t k) {
            Piece& piece = batch.pieces[k];
            stream.emit_run(piece.first_patch, piece.last_patch, piece.mesh, nullptr);
            // World positions, as run() adds the origin back (in double).
            if (origin != glm::dvec3(0.0))
                for (glm::dvec3& position : piece.mesh.positions) position += origin;
        });
    } catch (...) {
        batch.failure = std::current_exception();
    }
}

}  // namespace

bool surface_streams(const Scene& scene) {
    return PatchStream::streams(scene) && !(scene.geometry && scene.geometry->normals == GeometryNormals::smooth);
}

WeldedMesh run_pipeline_welded(const Scene& scene, const PipelineOptions& options) {
    if (scene.patch_count() == 0) throw Error("the scene has no patches", Where::in_file(scene.file));
    if (!surface_streams(scene)) {
        WeldedMesh welded = weld_bitwise(run_pipeline(scene, options).mesh);
        welded.vertex_map = {};
        return welded;
    }
    PipelineOptions stream_options = options;
    stream_options.timings = nullptr;
    stream_options.progress = nullptr;
    const PatchStream stream(scene, stream_options);
    const std::size_t n = stream.patch_count();
    SurfaceWelder welder(stream.vertex_base(n), stream.triangle_base(n));
    const auto weld_batch = [&](const Batch& batch) {
        if (batch.failure) std::rethrow_exception(batch.failure);
        for (std::size_t k = 0; k < batch.used; ++k) {
            // In patch order: the first non-finite vertex of the surface is the first one met.
            require_finite_positions(scene, batch.pieces[k].mesh, options.precision);
            welder.add(batch.pieces[k].mesh);
        }
    };

    // The weld is serial: while one thread welds a batch, the others evaluate the next.
    std::size_t next_patch = 0;
    Batch current, next;
    plan_batch(stream, next_patch, current);
    evaluate_batch(stream, current);
    while (current.used > 0) {
        plan_batch(stream, next_patch, next);
        tessref::parallel_for(0, 2, [&](int task) {
            if (task == 0) weld_batch(current);
            else evaluate_batch(stream, next);
        });
        if (options.progress) options.progress(current.pieces[current.used - 1].last_patch, n);
        std::swap(current, next);
    }
    return welder.take();
}

std::optional<MeshWriteReport> write_pipeline_ply(const Scene& scene, const PipelineOptions& options,
                                                  const MeshWriteOptions& write_options, std::ostream& out) {
    if (scene.patch_count() == 0) throw Error("the scene has no patches", Where::in_file(scene.file));
    // Positions that are not float values (exact precision, world positions of a
    // camera-relative run) would have StreamedPlyWriter refuse the first piece.
    if (!surface_streams(scene) || options.precision != Precision::gpu || options.camera_relative ||
        write_options.format != MeshFormat::ply || !write_options.weld)
        return std::nullopt;
    PipelineOptions stream_options = options;
    stream_options.timings = nullptr;
    stream_options.progress = nullptr;
    const PatchStream stream(scene, stream_options);
    const std::size_t n = stream.patch_count();
    StreamedPlyWriter writer(out, write_options, stream.vertex_base(n), stream.triangle_base(n));
    bool streaming = true;
    const auto write_batch = [&](const Batch& batch) {
        if (batch.failure) std::rethrow_exception(batch.failure);
        for (std::size_t k = 0; k < batch.used && streaming; ++k) {
            // In patch order: the first non-finite vertex of the surface is the first one met.
            require_finite_positions(scene, batch.pieces[k].mesh, options.precision);
            streaming = writer.add(batch.pieces[k].mesh);
        }
    };

    // As run_pipeline_welded(): one thread welds and writes a batch while the others
    // evaluate the next.
    std::size_t next_patch = 0;
    Batch current, next;
    plan_batch(stream, next_patch, current);
    evaluate_batch(stream, current);
    while (current.used > 0 && streaming) {
        plan_batch(stream, next_patch, next);
        tessref::parallel_for(0, 2, [&](int task) {
            if (task == 0) write_batch(current);
            else evaluate_batch(stream, next);
        });
        if (options.progress) options.progress(current.pieces[current.used - 1].last_patch, n);
        std::swap(current, next);
    }
    if (!streaming) return std::nullopt;
    return writer.finish([&stream](std::size_t first, std::span<std::array<std::uint32_t, 3>> triangles) {
        stream.triangles(first, triangles);
    });
}

glm::dvec3 camera_relative_origin(const Scene& scene) {
    if (!scene.camera) return glm::dvec3(0.0);
    glm::dvec3 origin = scene.camera->eye;
    // A terrain's evaluation writes the height itself (from the height map, absolute): only
    // the ground axes can be shifted.
    if (scene.grid) (scene.grid->plane == GroundPlane::xy ? origin.z : origin.y) = 0.0;
    return origin;
}

SceneCamera camera_moved_by(SceneCamera camera, const glm::dvec3& origin) {
    camera.eye -= origin;
    camera.center -= origin;
    return camera;
}

PipelineResult run_pipeline(const Scene& scene, const PipelineOptions& options) {
    if (scene.patch_count() == 0) throw Error("the scene has no patches", Where::in_file(scene.file));
    if (scene.evaluation.model == EvaluationModel::geomipmap) return pipeline::run_geomipmap(scene, options);
    return run(scene, options);
}

PatchStream::PatchStream(const Scene& scene, const PipelineOptions& options) {
    PassTimer timer{options.timings};
    impl_ = open_stream(scene, options, timer);
}
PatchStream::~PatchStream() = default;
PatchStream::PatchStream(PatchStream&&) noexcept = default;
PatchStream& PatchStream::operator=(PatchStream&&) noexcept = default;

bool PatchStream::streams(const Scene& scene) { return scene.evaluation.model != EvaluationModel::geomipmap; }
std::size_t PatchStream::patch_count() const { return impl_->levels.size(); }
const std::vector<TessLevels>& PatchStream::levels() const { return impl_->levels; }
std::uint64_t PatchStream::estimated_triangles() const { return impl_->estimated_triangles; }
std::size_t PatchStream::distinct_patterns() const { return impl_->distinct_patterns; }
const Pattern& PatchStream::pattern(std::size_t patch) const { return *impl_->patterns.at(patch); }
std::size_t PatchStream::vertex_base(std::size_t patch) const { return impl_->vertex_base.at(patch); }
std::size_t PatchStream::triangle_base(std::size_t patch) const { return impl_->triangle_base.at(patch); }
std::size_t PatchStream::patch_of_triangle(std::size_t triangle) const {
    const auto& base = impl_->triangle_base;
    // The last patch whose first triangle is <= triangle (patches without triangles skipped).
    const auto it = std::upper_bound(base.begin(), base.end(), triangle);
    return static_cast<std::size_t>(it - base.begin()) - 1;
}
std::size_t PatchStream::run_end(std::size_t first, std::size_t triangles) const {
    const auto& base = impl_->triangle_base;
    std::size_t last = first + 1;
    while (last < patch_count() && base.at(last + 1) - base.at(first) <= triangles) ++last;
    return last;
}
bool PatchStream::has_uvs() const { return impl_->has_uvs; }
bool PatchStream::has_normals() const { return impl_->has_normals; }
bool PatchStream::face_normals() const { return impl_->face_normals; }
bool PatchStream::smooth_normals() const { return impl_->smooth_normals; }
glm::dvec3 PatchStream::origin() const { return impl_->origin; }
bool PatchStream::geometry_shader() const { return impl_->geometry_shader; }
bool PatchStream::reversed() const { return impl_->flip; }
void PatchStream::size(SurfaceMesh& mesh, std::vector<glm::dvec3>& face_normals, std::size_t vertices,
                       std::size_t triangles) const {
    mesh.positions.resize(vertices);
    mesh.patch_ids.resize(vertices);
    mesh.tess_coords.resize(vertices);
    if (impl_->has_uvs) mesh.uvs.resize(vertices);
    if (impl_->has_normals) mesh.normals.resize(vertices);
    mesh.triangles.resize(triangles);
    if (impl_->face_normals) face_normals.resize(triangles);
}
void PatchStream::emit(std::size_t patch, SurfaceMesh& mesh, std::size_t first_vertex, std::size_t first_triangle,
                       std::vector<glm::dvec3>* face_normals, VertexNormals normals, Provenance provenance,
                       Triangles triangles, Projection* projection) const {
    if (triangles == Triangles::shared && shared_triangles(patch).empty())
        throw Error("patch " + std::to_string(patch) + "'s triangles are not its pattern's to share",
                    Where::at_key("triangles"));
    impl_->emit(patch, mesh, first_vertex, first_triangle, face_normals, normals == VertexNormals::now,
                provenance == Provenance::now, triangles == Triangles::write, projection);
}
void PatchStream::emit_run(std::size_t first, std::size_t last, SurfaceMesh& mesh,
                           std::vector<glm::dvec3>* face_normals, VertexNormals normals, Provenance provenance,
                           Triangles triangles, Projection* projection) const {
    const std::size_t v0 = vertex_base(first), t0 = triangle_base(first);
    std::vector<glm::dvec3> none;
    const bool shared = triangles == Triangles::shared;
    size(mesh, face_normals ? *face_normals : none, vertex_base(last) - v0, shared ? 0 : triangle_base(last) - t0);
    if (shared && face_normals && impl_->face_normals) face_normals->resize(triangle_base(last) - t0);
    for (std::size_t p = first; p < last; ++p)
        emit(p, mesh, vertex_base(p) - v0, triangle_base(p) - t0, face_normals, normals, provenance, triangles,
             projection);
}
std::span<const std::array<std::uint32_t, 3>> PatchStream::shared_triangles(std::size_t patch) const {
    if (impl_->flip || impl_->geometry_shader) return {};
    const Pattern& pattern = *impl_->patterns.at(patch);
    if (pattern.vertices_per_primitive() != 3) return {};
    // Three indices a triangle, contiguous: the layout of std::array<std::uint32_t, 3>.
    static_assert(sizeof(std::array<std::uint32_t, 3>) == 3 * sizeof(std::uint32_t));
    return {reinterpret_cast<const std::array<std::uint32_t, 3>*>(pattern.indices().data()), pattern.primitive_count()};
}
void PatchStream::triangles(std::size_t first, std::span<std::array<std::uint32_t, 3>> out) const {
    if (out.empty()) return;
    const auto& base = impl_->triangle_base;
    if (first + out.size() > base.back())
        throw Error("triangles " + std::to_string(first) + " to " + std::to_string(first + out.size()) +
                        " are not all in the surface",
                    Where::at_key("triangle"));
    std::size_t p = patch_of_triangle(first);
    for (std::size_t k = 0; k < out.size(); ++k) {
        const std::size_t t = first + k;
        while (t >= base[p + 1]) ++p;
        const auto vertex0 = static_cast<std::uint32_t>(impl_->vertex_base[p]);
        if (impl_->geometry_shader) {
            const auto& tri = impl_->emitted[p].triangles[t - base[p]];
            out[k] = {vertex0 + tri[0], vertex0 + tri[1], vertex0 + tri[2]};
            continue;
        }
        const auto prim = impl_->patterns[p]->primitive(t - base[p]);
        const auto vertex = static_cast<std::uint32_t>(impl_->vertex_base[p]);
        out[k] = {vertex + prim[0], vertex + prim[impl_->flip ? 2 : 1], vertex + prim[impl_->flip ? 1 : 2]};
    }
}
std::array<std::uint32_t, 3> PatchStream::triangle(std::size_t triangle, SurfaceMesh& out,
                                                  glm::dvec3* face_normal) const {
    if (triangle >= impl_->triangle_base.back())
        throw Error("triangle " + std::to_string(triangle) + " is not in the surface", Where::at_key("triangle"));
    return impl_->triangle(triangle, out, face_normal);
}
void PatchStream::later_normals(std::size_t patch, std::span<const std::uint32_t> points, SurfaceMesh& mesh,
                                std::size_t first) const {
    impl_->later_normals(patch, points, mesh, first);
}

}  // namespace tessref
