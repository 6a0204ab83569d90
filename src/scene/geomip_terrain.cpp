// geomip_terrain.cpp — a geomipmapped scene's height samples and their placement
// (scene.h, geomip_terrain): the scene's own data in geomipmap.h's terms, read by the
// loader (a PVS file's check), the pipeline and `tessref pvs`.
#include "tessref/scene.h"

namespace tessref {

GeomipTerrain geomip_terrain(const Scene& scene) {
    if (!scene.grid || !scene.grid->heightmap) throw Error("a geomipmapped terrain needs a [domain] with a height map");
    const TerrainGrid& g = *scene.grid;
    const Texture& texture = g.heightmap->texture;
    GeomipTerrain terrain;
    geomip::HeightSamples& map = terrain.map;
    map.width = texture.width();
    map.height = texture.height();
    map.samples.resize(static_cast<std::size_t>(map.width) * map.height);
    for (int y = 0; y < map.height; ++y)
        for (int x = 0; x < map.width; ++x)
            map.samples[static_cast<std::size_t>(y) * map.width + x] = texture.texel_exact(0, x, y);

    // The samples span the grid's extent: sample 0 at the first corner, the last at the last.
    geomip::Settings& settings = terrain.settings;
    settings.origin = {g.u_coords.front(), g.v_coords.front()};
    settings.spacing = {(g.u_coords.back() - g.u_coords.front()) / (map.width - 1),
                        (g.v_coords.back() - g.v_coords.front()) / (map.height - 1)};
    settings.scale_z = g.scale_z;
    settings.params = scene.evaluation.geomipmap;
    return terrain;
}

}  // namespace tessref
