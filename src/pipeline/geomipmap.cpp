// geomipmap.cpp — the pipeline of a geomipmapped terrain ([evaluation] model =
// "geomipmap"): no tessellation stages. The CPU does what the application did before
// hardware tessellation (geomipmap.h): pre-processing, a level per patch from the camera,
// the patches' meshes with adapting borders and geomorphed heights. The geometry stage's
// normals follow as for every other model.
#include <array>
#include <chrono>
#include <cmath>
#include <string>

#include "pipeline/program.h"
#include "tessref/geometry.h"
#include "tessref/geomipmap.h"
#include "tessref/pipeline.h"

namespace tessref::pipeline {

namespace {

// Keeps the vertices and triangles of the patches whose `keep` is true (patch order and
// vertex order unchanged), with their face normals.
void keep_patches(SurfaceMesh& mesh, std::vector<glm::dvec3>& face_normals, std::vector<glm::vec3>& geomorph,
                  const std::vector<bool>& keep) {
    std::vector<glm::vec3> geomorph_out;
    std::vector<std::uint32_t> remap(mesh.positions.size(), 0);
    SurfaceMesh out;
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
        if (!keep[mesh.patch_ids[v]]) continue;
        remap[v] = static_cast<std::uint32_t>(out.positions.size());
        out.positions.push_back(mesh.positions[v]);
        if (!mesh.normals.empty()) out.normals.push_back(mesh.normals[v]);
        if (!mesh.uvs.empty()) out.uvs.push_back(mesh.uvs[v]);
        out.patch_ids.push_back(mesh.patch_ids[v]);
        out.tess_coords.push_back(mesh.tess_coords[v]);
        if (!geomorph.empty()) geomorph_out.push_back(geomorph[v]);
    }
    std::vector<glm::dvec3> normals_out;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const auto& tri = mesh.triangles[t];
        if (!keep[mesh.patch_ids[tri[0]]]) continue;  // a triangle's vertices are its patch's
        out.triangles.push_back({remap[tri[0]], remap[tri[1]], remap[tri[2]]});
        if (!face_normals.empty()) normals_out.push_back(face_normals[t]);
    }
    mesh = std::move(out);
    face_normals = std::move(normals_out);
    geomorph = std::move(geomorph_out);
}

}  // namespace

PipelineResult run_geomipmap(const Scene& scene, const PipelineOptions& options) {
    // PipelineTimings, only when asked for: control = pre-processing and the level
    // selection; generator 0 (no primitive generator); evaluation = the patches' meshes,
    // geomorphing and the reported levels; geometry = the normals and culling.
    using Clock = std::chrono::steady_clock;
    if (options.timings) *options.timings = PipelineTimings{};
    Clock::time_point lap = Clock::now();
    const auto time_pass = [&](double PipelineTimings::*field) {
        if (!options.timings) return;
        const Clock::time_point now = Clock::now();
        options.timings->*field = std::chrono::duration<double>(now - lap).count();
        lap = now;
    };
    const GeomipTerrain terrain = geomip_terrain(scene);
    const geomip::HeightSamples& map = terrain.map;
    const geomip::Settings& settings = terrain.settings;

    const geomip::MaxErrors max_errors = geomip::preprocess(map);
    const std::vector<double> levels = geomip::select_levels(map, max_errors, settings, scene.camera->view_projection(),
                                                             scene.camera->viewport);
    time_pass(&PipelineTimings::control);
    PipelineResult result;
    std::vector<geomip::MorphVertex> morph;
    result.mesh = geomip::build_surface(map, levels, settings, &morph);
    SurfaceMesh& mesh = result.mesh;
    // The vertex shader's attributes (geomip_terrain.vert), rounded to float as the vertex
    // buffer holds them.
    result.geomorph.resize(morph.size());
    for (std::size_t v = 0; v < morph.size(); ++v)
        result.geomorph[v] = glm::vec3(glm::dvec3(morph[v].height, morph[v].target, morph[v].tween));
    if (options.precision == Precision::gpu) {
        // The vertex buffer holds floats, and the vertex shader morphs them: the ground
        // position as uploaded, the height as geomip_terrain.vert computes it.
        const float scaleZ = static_cast<float>(settings.scale_z);
        for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
            const glm::vec3& m = result.geomorph[v];
            const glm::vec2 ground(glm::dvec2(mesh.positions[v]));
            mesh.positions[v] = glm::dvec3(ground.x, ground.y, geomip::morph_height(m.x, m.y, m.z, scaleZ));
        }
    }
    result.estimated_triangles = mesh.triangles.size();
    if (mesh.triangles.size() > scene.max_triangles)
        throw Error("the geomipmapped terrain has " + std::to_string(mesh.triangles.size()) +
                        " triangles, more than limits.max_triangles = " + std::to_string(scene.max_triangles),
                    scene.max_triangles_where);
    // The levels, as a tessellated terrain reports them: each outer level is the side's
    // dictating fractional level (geomipmap.h side_level, equal for both patches of the
    // side), the inner levels the patch's own. Outer edges 0..3 are u = 0, v = 0, u = 1,
    // v = 1 (tess coords (i / 16, j / 16)): the left, bottom, right and top sides.
    const int nx = map.patches_x(), ny = map.patches_y();
    static constexpr std::array<int, 4> side_of_edge{3, 0, 1, 2};
    result.levels.resize(levels.size());
    for (std::size_t p = 0; p < levels.size(); ++p) {
        const int px = static_cast<int>(p % nx), py = static_cast<int>(p / nx);
        TessLevels& l = result.levels[p];
        for (int e = 0; e < 4; ++e)
            l.outer[e] = static_cast<float>(
                geomip::side_level(levels, nx, ny, px, py, side_of_edge[e], settings.params.adapt));
        l.inner = {static_cast<float>(levels[p]), static_cast<float>(levels[p])};
        if (options.progress) options.progress(p + 1, levels.size());
    }
    time_pass(&PipelineTimings::evaluation);

    if (scene.geometry) {
        const auto normals_in = [&](auto zero) {
            using T = decltype(zero);
            std::vector<vec3_t<T>> positions(mesh.positions.size());
            for (std::size_t v = 0; v < positions.size(); ++v) positions[v] = vec3_t<T>(mesh.positions[v]);
            if (scene.geometry->normals == GeometryNormals::face) {
                result.face_normals.resize(mesh.triangles.size());
                for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
                    const auto& tri = mesh.triangles[t];
                    result.face_normals[t] =
                        glm::dvec3(face_normal<T>(positions[tri[0]], positions[tri[1]], positions[tri[2]]));
                }
            } else {
                const auto normals = smooth_vertex_normals<T>(
                    std::span<const vec3_t<T>>(positions),
                    std::span<const std::array<std::uint32_t, 3>>(mesh.triangles), Weld::by_position);
                mesh.normals.resize(normals.size());
                for (std::size_t v = 0; v < normals.size(); ++v) mesh.normals[v] = glm::dvec3(normals[v]);
            }
        };
        if (options.precision == Precision::gpu)
            normals_in(0.0f);
        else
            normals_in(0.0);
    }
    // Culling (geomipmap.h, CULLING): after the levels and the normals, so that what stays
    // is exactly what the unculled run draws there (smooth normals weld across patches).
    if (scene.culling) {
        std::vector<geomip::Cull> cull(levels.size(), geomip::Cull::visible);
        if (scene.culling->frustum)
            cull = geomip::cull_frustum(geomip::patch_bounds(map, settings), scene.camera->view_projection());
        if (const auto& pvs = scene.culling->pvs) {
            if (const auto cell = pvs->cell_of(scene.camera->eye, settings)) {
                result.culled.pvs_applied = true;
                for (std::size_t p = 0; p < cull.size(); ++p)
                    if (cull[p] == geomip::Cull::visible && !pvs->visible(*cell, p)) cull[p] = geomip::Cull::pvs;
            }
        }
        std::vector<bool> keep(cull.size());
        for (std::size_t p = 0; p < cull.size(); ++p) {
            keep[p] = cull[p] == geomip::Cull::visible;
            result.culled.ground_rectangle += cull[p] == geomip::Cull::ground_rectangle;
            result.culled.frustum_planes += cull[p] == geomip::Cull::frustum_planes;
            result.culled.pvs += cull[p] == geomip::Cull::pvs;
        }
        if (result.culled.total() > 0) keep_patches(mesh, result.face_normals, result.geomorph, keep);
    }
    time_pass(&PipelineTimings::geometry);
    result.distinct_patterns = 0;
    result.stages.control = true;  // the level selection
    result.stages.evaluation = true;
    result.stages.geometry = scene.geometry.has_value();
    return result;
}

}  // namespace tessref::pipeline
