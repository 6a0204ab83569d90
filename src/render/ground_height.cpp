// ground_height.cpp — the height map and the tessellated surface under a ground point
// (render.h, ground_height).
#include <algorithm>
#include <cmath>
#include <string>

#include "render/ground_truth.h"
#include "tessref/error.h"
#include "tessref/render.h"

namespace tessref {

GroundHeight ground_height(const Scene& scene, const PipelineResult& pipeline, glm::dvec2 ground) {
    if (!scene.grid)
        throw Error("the ground under a point needs a terrain scene ([domain] with a height map)",
                    Where::at_key(scene.file, "mesh"));
    if (!std::isfinite(ground.x) || !std::isfinite(ground.y))
        throw Error("the ground point must be finite", Where::in_file("--ground"));
    const TerrainGrid& g = *scene.grid;
    const auto inside = [](double x, double a, double b) { return x >= std::min(a, b) && x <= std::max(a, b); };
    if (!inside(ground.x, g.u_coords.front(), g.u_coords.back()) ||
        !inside(ground.y, g.v_coords.front(), g.v_coords.back()))
        throw Error("the ground point (" + std::to_string(ground.x) + ", " + std::to_string(ground.y) +
                        ") is outside the terrain's extent",
                    Where::in_file("--ground"));

    GroundHeight result;
    result.ground = ground;
    result.height_map = ground_truth::vertex_height(g, ground_truth::ground_map(scene), ground.x, ground.y);

    // The tessellated surface: the ground projection of each triangle, the point's
    // barycentric weights there, the up coordinate interpolated with them.
    const bool xy = g.plane == GroundPlane::xy;
    const auto on_ground = [xy](const glm::dvec3& p) { return xy ? glm::dvec2(p.x, p.y) : glm::dvec2(p.x, p.z); };
    const auto up = [xy](const glm::dvec3& p) { return xy ? p.z : p.y; };
    const SurfaceMesh& mesh = pipeline.mesh;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const auto& tri = mesh.triangles[t];
        const glm::dvec2 a = on_ground(mesh.positions[tri[0]]), b = on_ground(mesh.positions[tri[1]]),
                         c = on_ground(mesh.positions[tri[2]]);
        const double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        if (area == 0.0) continue;
        const double wa = ((b.x - ground.x) * (c.y - ground.y) - (b.y - ground.y) * (c.x - ground.x)) / area;
        const double wb = ((c.x - ground.x) * (a.y - ground.y) - (c.y - ground.y) * (a.x - ground.x)) / area;
        const double wc = 1.0 - wa - wb;
        // A point on a shared edge belongs to the first triangle; rounding of the weights
        // must not let it fall between two.
        constexpr double slack = -1e-12;
        if (wa < slack || wb < slack || wc < slack) continue;
        result.on_surface = true;
        result.tessellated =
            wa * up(mesh.positions[tri[0]]) + wb * up(mesh.positions[tri[1]]) + wc * up(mesh.positions[tri[2]]);
        result.triangle_id = static_cast<std::uint32_t>(t);
        result.patch_id = mesh.patch_ids[tri[0]];
        if (result.patch_id < pipeline.levels.size()) result.patch_levels = pipeline.levels[result.patch_id];
        break;
    }
    return result;
}

}  // namespace tessref
