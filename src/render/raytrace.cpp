// The ground truth: the full-resolution height field ray-traced with Embree (render.h,
// raytrace_scene), shaded by the same fragment stage as the rasterized image.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "common/parallel.h"
#include "pipeline/terrain.h"
#include "render/ground_truth.h"

#include "render/render_internal.h"
#include "tessref/error.h"
#include "tessref/geometry.h"
#include "tessref/heightfield.h"
#include "tessref/raycast.h"
#include "tessref/render.h"

namespace tessref {

using render_detail::pixel_ndc;
using render_detail::quad_of;

namespace {

using ground_truth::GroundMap;
using ground_truth::ground_map;
using ground_truth::vertex_lines;

struct GroundTruthSurface {
    std::vector<glm::dvec3> positions;
    std::vector<std::array<std::uint32_t, 3>> triangles;
    std::vector<glm::dvec3> smooth_normals;  // only for [geometry] normals = "smooth"
    int columns = 0, rows = 0;
};

GroundTruthSurface build_surface(const Scene& scene, const GroundMap& map) {
    const TerrainGrid& g = *scene.grid;
    const Texture& height = g.heightmap->texture;
    const auto [u_lo, u_hi] = std::minmax(g.u_coords.front(), g.u_coords.back());
    const auto [v_lo, v_hi] = std::minmax(g.v_coords.front(), g.v_coords.back());
    const std::vector<double> us = vertex_lines(u_lo, u_hi, map.u, height.width());
    const std::vector<double> vs = vertex_lines(v_lo, v_hi, map.v, height.height());
    GroundTruthSurface s;
    s.columns = static_cast<int>(us.size());
    s.rows = static_cast<int>(vs.size());
    s.positions.resize(us.size() * vs.size());
    const bool xy = g.plane == GroundPlane::xy;
    tessref::parallel_for(std::size_t{0}, vs.size(), [&](std::size_t j) {
        for (std::size_t i = 0; i < us.size(); ++i) {
            const double h = ground_truth::vertex_height(g, map, us[i], vs[j]);
            s.positions[j * us.size() + i] = xy ? glm::dvec3(us[i], vs[j], h) : glm::dvec3(us[i], h, vs[j]);
        }
    });
    // Two triangles per quad, split from (low u, low v) to (high u, high v), facing up.
    const auto cols = static_cast<std::uint32_t>(us.size());
    s.triangles.reserve(2 * (us.size() - 1) * (vs.size() - 1));
    for (std::uint32_t j = 0; j + 1 < vs.size(); ++j) {
        for (std::uint32_t i = 0; i + 1 < cols; ++i) {
            const std::uint32_t a = j * cols + i, b = a + 1, c = a + cols + 1, d = a + cols;
            // Plane xy (z up): (a, b, c) is counter-clockwise from above. Plane xz (y up): x
            // cross z points down, so the order is reversed.
            if (xy) {
                s.triangles.push_back({a, b, c});
                s.triangles.push_back({a, c, d});
            } else {
                s.triangles.push_back({a, c, b});
                s.triangles.push_back({a, d, c});
            }
        }
    }
    if (scene.geometry && scene.geometry->normals == GeometryNormals::smooth)
        s.smooth_normals = smooth_vertex_normals<double>(s.positions, s.triangles, Weld::by_index);
    return s;
}

// The ray through the centre of pixel (x, row): from the near plane (t = 0) to the far plane
// (t = 1), as clipping against -w <= z <= w keeps it.
struct Ray {
    glm::dvec3 origin, direction;
};
Ray pixel_ray(const glm::dmat4& inverse_vp, double x, double row, int width, int height) {
    const glm::dvec2 ndc = pixel_ndc(x, row, width, height);
    glm::dvec4 n = inverse_vp * glm::dvec4(ndc, -1.0, 1.0);
    glm::dvec4 f = inverse_vp * glm::dvec4(ndc, 1.0, 1.0);
    const glm::dvec3 near_point = glm::dvec3(n) / n.w, far_point = glm::dvec3(f) / f.w;
    return {near_point, far_point - near_point};
}

// Where a ray meets the plane of a triangle (may be outside the triangle); nullopt when
// parallel.
std::optional<glm::dvec3> plane_hit(const Ray& ray, const glm::dvec3& p0, const glm::dvec3& normal) {
    const double denominator = glm::dot(normal, ray.direction);
    if (denominator == 0.0 || !std::isfinite(denominator)) return std::nullopt;
    const double t = glm::dot(normal, p0 - ray.origin) / denominator;
    return ray.origin + t * ray.direction;
}

}  // namespace

RenderResult raytrace_scene(const Scene& scene, const RenderOptions& options, RaytraceStats* stats_out) {
    if (!scene.grid) {
        throw Error("--raytrace needs a terrain scene ([domain] with a height map): the ground truth is the "
                    "full-resolution height field",
                    Where::at_key(scene.file, "mesh"));
    }
    RenderResult result;
    result.camera = render_detail::camera_for(scene, options);
    result.shading = scene.shading;
    const int width = result.camera.viewport.x, height = result.camera.viewport.y;
    const glm::dmat4 vp = result.camera.view_projection();
    result.mvp = glm::mat4(vp);
    const glm::dmat4 inverse_vp = glm::inverse(vp);
    auto progress = [&](std::string_view stage, double fraction) {
        if (options.progress) options.progress(stage, fraction);
    };

    const auto start = std::chrono::steady_clock::now();
    progress("building the height field", 0.0);
    const TerrainGrid& grid = *scene.grid;
    const GroundMap map = ground_map(scene);
    const GroundTruthSurface surface = build_surface(scene, map);
    const RayScene rays(surface.positions, surface.triangles);
    RaytraceStats stats;
    stats.triangles = surface.triangles.size();
    stats.vertices = surface.positions.size();
    stats.grid_columns = surface.columns;
    stats.grid_rows = surface.rows;
    result.stats.triangles = stats.triangles;
    result.stats.vertices = stats.vertices;
    result.stats.seconds_pipeline = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    const bool xy = grid.plane == GroundPlane::xy;
    const std::optional<GeometryNormals> normals =
        scene.geometry ? std::optional<GeometryNormals>(scene.geometry->normals)
                       : (scene.evaluation.model == EvaluationModel::lab4 ? std::optional<GeometryNormals>(GeometryNormals::height_field)
                                                                          : std::nullopt);
    const glm::mat3 normalMatrix(1.0f);  // the model matrix is the identity (as in the pipeline)

    // A geomipmapped terrain's texture coordinate is not the height map's: uv = sample /
    // (size - 1) over the extent (geomipmap.h OUTPUT), the article's one light map.
    const bool geomipmap = scene.evaluation.model == EvaluationModel::geomipmap;
    const glm::dvec2 extent_lo(grid.u_coords.front(), grid.v_coords.front());
    const glm::dvec2 extent(grid.u_coords.back() - grid.u_coords.front(), grid.v_coords.back() - grid.v_coords.front());
    auto tex_coord = [&](const glm::dvec3& p) {
        if (geomipmap) return (glm::dvec2(p.x, p.y) - extent_lo) / extent;
        return glm::dvec2(map.u.st(p.x), map.v.st(xy ? p.y : p.z));
    };
    // The scene's geometry stage at a point of the surface instead of at a vertex.
    auto surface_normal = [&](const glm::dvec3& p, const glm::vec2& st, std::uint32_t tri,
                              const glm::dvec3& b) -> glm::vec3 {
        if (!normals) return glm::vec3(0.0f, 0.0f, 1.0f);  // FragmentInputs' default, as the raster path
        switch (*normals) {
            case GeometryNormals::normal_map:
                // thesis_terrain.geom: NormalFromTexture(texture(normalMap, textureCoordinate).rgb)
                return thesis_normal_from_texture<float>(glm::vec3(grid.normal_map->texture(st)), normalMatrix);
            case GeometryNormals::face: {
                const auto& t = surface.triangles[tri];
                return glm::vec3(face_normal<double>(surface.positions[t[0]], surface.positions[t[1]],
                                                     surface.positions[t[2]]));
            }
            case GeometryNormals::smooth: {
                const auto& t = surface.triangles[tri];
                return glm::vec3(b[0] * surface.smooth_normals[t[0]] + b[1] * surface.smooth_normals[t[1]] +
                                 b[2] * surface.smooth_normals[t[2]]);
            }
            case GeometryNormals::height_field: break;
        }
        // height_field at mip 0, as the pipeline computes it at a vertex.
        return pipeline::height_field_normal<float>(scene, glm::vec3(p), 0.0f);
    };

    const auto shade_start = std::chrono::steady_clock::now();
    progress("ray tracing", 0.0);
    render_detail::allocate(result, width, height);
    result.domain = scene.generator.domain;
    const FragmentNeeds needs = fragment_needs(result.shading.model.kind);
    const auto covered = tessref::parallel_reduce(
        tbb::blocked_range<int>(0, height), std::uint64_t{0},
        [&](const tbb::blocked_range<int>& rows, std::uint64_t count) {
            for (int row = rows.begin(); row < rows.end(); ++row) {
                for (int x = 0; x < width; ++x) {
                    const Ray ray = pixel_ray(inverse_vp, x, row, width, height);
                    const RayHit hit = rays.intersect(ray.origin, ray.direction, 0.0, 1.0);
                    if (!hit.hit) continue;
                    // The hit again in double, on the plane of the triangle Embree found (its
                    // float t is only a first answer).
                    const auto& t = surface.triangles[hit.triangle];
                    const glm::dvec3 p0 = surface.positions[t[0]], p1 = surface.positions[t[1]],
                                     p2 = surface.positions[t[2]];
                    const glm::dvec3 plane_normal = glm::cross(p1 - p0, p2 - p0);
                    const glm::dvec3 p = plane_hit(ray, p0, plane_normal).value_or(ray.origin + hit.t * ray.direction);
                    // Barycentric weights of p in the triangle (areas of the sub-triangles).
                    const double area = glm::dot(plane_normal, plane_normal);
                    const glm::dvec3 b(glm::dot(glm::cross(p1 - p, p2 - p), plane_normal) / area,
                                       glm::dot(glm::cross(p2 - p, p0 - p), plane_normal) / area,
                                       glm::dot(glm::cross(p0 - p, p1 - p), plane_normal) / area);
                    const glm::dvec4 clip = vp * glm::dvec4(p, 1.0);
                    const float depth = static_cast<float>(render_detail::window_depth(clip));
                    const std::size_t i = result.index(x, row);
                    ++count;
                    result.triangle_id[i] = hit.triangle;
                    result.barycentric[i] = glm::vec3(b);
                    result.depth[i] = depth;

                    FragmentInputs f;
                    f.depth = depth;
                    f.worldPosition = glm::vec3(p);
                    const glm::vec2 st(tex_coord(p));
                    f.texCoord = st;
                    if (needs.texCoord_derivatives) {
                        const auto q = quad_of(x, row);
                        auto st_at = [&](int px, int prow) {
                            const auto h = plane_hit(pixel_ray(inverse_vp, px, prow, width, height), p0, plane_normal);
                            return h ? glm::vec2(tex_coord(*h))
                                     : glm::vec2(std::numeric_limits<float>::quiet_NaN());
                        };
                        const glm::vec2 top_left = st_at(q.x0, q.row0);
                        f.texCoord_dx = st_at(q.x0 + 1, q.row0) - top_left;
                        f.texCoord_dy = top_left - st_at(q.x0, q.row0 + 1);
                    }
                    if (needs.normal) f.normal = surface_normal(p, st, hit.triangle, b);
                    result.colour[i] = shade(result.shading.model, f);
                }
            }
            return count;
        },
        std::plus<>());
    result.stats.covered_pixels = covered;
    stats.covered_pixels = covered;
    result.stats.seconds_shade =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - shade_start).count();
    progress("ray tracing", 1.0);
    if (options.colour8) render_detail::keep_colour8(result);
    if (stats_out) *stats_out = stats;
    return result;
}

}  // namespace tessref
