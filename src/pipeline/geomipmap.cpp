// geomipmap.cpp — the pipeline of a geomipmapped terrain ([evaluation] model =
// "geomipmap"): no tessellation stages. The CPU does what the application did before
// hardware tessellation (geomipmap.h): pre-processing, a level per patch from the camera,
// the patches' meshes with adapting borders and geomorphed heights. The geometry stage's
// normals follow as for every other model.
#include <array>
#include <cmath>
#include <string>

#include "pipeline/program.h"
#include "tessref/geometry.h"
#include "tessref/geomipmap.h"
#include "tessref/pipeline.h"

namespace tessref::pipeline {

PipelineResult run_geomipmap(const Scene& scene, const PipelineOptions& options) {
    const TerrainGrid& g = *scene.grid;
    const Texture& texture = g.heightmap->texture;
    geomip::HeightSamples map;
    map.width = texture.width();
    map.height = texture.height();
    map.samples.resize(static_cast<std::size_t>(map.width) * map.height);
    for (int y = 0; y < map.height; ++y)
        for (int x = 0; x < map.width; ++x)
            map.samples[static_cast<std::size_t>(y) * map.width + x] = texture.texel_exact(0, x, y);

    // The samples span the grid's extent: sample 0 at the first corner, the last at the last.
    geomip::Settings settings;
    settings.origin = {g.u_coords.front(), g.v_coords.front()};
    settings.spacing = {(g.u_coords.back() - g.u_coords.front()) / (map.width - 1),
                        (g.v_coords.back() - g.v_coords.front()) / (map.height - 1)};
    settings.scale_z = g.scale_z;
    settings.params = scene.evaluation.geomipmap;

    const geomip::MaxErrors max_errors = geomip::preprocess(map);
    const std::vector<double> levels = geomip::select_levels(map, max_errors, settings, scene.camera->view_projection(),
                                                             scene.camera->viewport);
    PipelineResult result;
    result.mesh = geomip::build_surface(map, levels, settings);
    SurfaceMesh& mesh = result.mesh;
    if (options.precision == Precision::gpu)  // the vertex buffer holds floats
        for (glm::dvec3& p : mesh.positions) p = glm::dvec3(glm::vec3(p));
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
    result.distinct_patterns = 0;
    result.stages.control = true;  // the level selection
    result.stages.evaluation = true;
    result.stages.geometry = scene.geometry.has_value();
    return result;
}

}  // namespace tessref::pipeline
