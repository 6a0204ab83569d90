// The ground-truth surface's pieces shared by the ray tracer and the sweep: see
// ground_truth.h.
#include "render/ground_truth.h"

#include <algorithm>

namespace tessref::ground_truth {

GroundMap ground_map(const Scene& scene) {
    const TerrainGrid& g = *scene.grid;
    GroundMap m;
    switch (scene.evaluation.model) {
        case EvaluationModel::thesis:  // thesis_terrain.tese:31 position.xy / scaleXY
            m.u = {1.0 / g.scale_xy, 0.0};
            m.v = {1.0 / g.scale_xy, 0.0};
            break;
        case EvaluationModel::cosc422: {  // cosc422_terrain.tese:58 (posn.x - xMin) / (xMax - xMin)
            const double au = 1.0 / (g.extent_u.y - g.extent_u.x), av = 1.0 / (g.extent_v.y - g.extent_v.x);
            m.u = {au, -g.extent_u.x * au};
            m.v = {av, -g.extent_v.x * av};
            break;
        }
        case EvaluationModel::lab4:  // lab4_terrain.tese: xz / horizontalScale + texCoordOffset
            m.u = {1.0 / g.scale_xy, g.texcoord_offset.x};
            m.v = {1.0 / g.scale_xy, g.texcoord_offset.y};
            break;
        case EvaluationModel::pn: break;  // not a terrain
        case EvaluationModel::geomipmap: {
            // Sample k stands at origin + k * spacing (geomipmap.h): the texel centre
            // (k + 0.5) / W, so the vertex lines are the samples themselves and the truth is
            // the level-0 mesh (the same diagonal), heights exact at the samples.
            const double w = g.heightmap->texture.width(), h = g.heightmap->texture.height();
            const double du = (g.u_coords.back() - g.u_coords.front()) / (w - 1);
            const double dv = (g.v_coords.back() - g.v_coords.front()) / (h - 1);
            m.u = {1.0 / (du * w), 0.5 / w - g.u_coords.front() / (du * w)};
            m.v = {1.0 / (dv * h), 0.5 / h - g.v_coords.front() / (dv * h)};
            break;
        }
    }
    return m;
}

std::vector<double> vertex_lines(double lo, double hi, const AxisMap& map, int texels) {
    std::vector<double> lines{lo, hi};
    for (int k = 0; k < texels; ++k) {
        const double w = map.world((k + 0.5) / texels);
        if (w > lo && w < hi) lines.push_back(w);
    }
    std::sort(lines.begin(), lines.end());
    lines.erase(std::unique(lines.begin(), lines.end()), lines.end());
    return lines;
}

double vertex_height(const TerrainGrid& grid, const GroundMap& map, double u, double v) {
    // Mip level 0 in double: the texel values exactly, bilinear between them.
    const glm::dvec2 st(map.u.st(u), map.v.st(v));
    return grid.heightmap->texture.textureLod(st, 0.0).r * grid.scale_z;
}

}  // namespace tessref::ground_truth
