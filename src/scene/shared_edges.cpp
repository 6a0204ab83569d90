// shared_edges.cpp — which patch edges a scene's domain shares (for crack checks).
#include <algorithm>
#include <utility>

#include "tessref/scene.h"

namespace tessref {

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

}  // namespace tessref
