// prepare.cpp — the preparation pass (prepare.h): camera clearance and the light map,
// computed after the load from the scene's own terrain. It sits above render because the
// clearance reads the tessellated surface's height (render.h, ground_height).
#include "tessref/prepare.h"

#include <memory>
#include <utility>
#include <vector>

#include "tessref/geomipmap.h"
#include "tessref/pipeline.h"
#include "tessref/render.h"

namespace tessref {

namespace {

// [camera] ground_clearance: the eye's up coordinate becomes the tessellated surface's
// height under it plus the clearance, the center moving with it.
void lift_camera_above_ground(Scene& scene, double clearance, const Where& w) {
    SceneCamera& cam = *scene.camera;
    const bool xy = scene.grid->plane == GroundPlane::xy;
    const glm::dvec2 ground = xy ? glm::dvec2(cam.eye.x, cam.eye.y) : glm::dvec2(cam.eye.x, cam.eye.z);
    GroundHeight h;
    try {
        h = ground_height(scene, run_pipeline(scene), ground);
    } catch (const Error& e) {
        throw Error("camera.ground_clearance: " + e.message(), w);
    }
    if (!h.on_surface) throw Error("camera.ground_clearance: no triangle of the surface lies under the eye", w);
    const double up = h.tessellated + clearance;
    double& eye_up = xy ? cam.eye.z : cam.eye.y;
    double& center_up = xy ? cam.center.z : cam.center.y;
    center_up += up - eye_up;
    eye_up = up;
    set_camera_uniforms(scene);
}

// geomip_lightmap: one light value per height sample, a one-channel float texture sampled
// with texel centres on the samples (shading.h, GeomipLightmapShading).
void compute_light_map(Scene& scene, const geomip::LightMapParams& light) {
    const GeomipTerrain terrain = geomip_terrain(scene);
    const int w = terrain.map.width, h = terrain.map.height;
    const std::vector<double> values =
        geomip::light_map(terrain.map, terrain.settings.spacing, terrain.settings.scale_z, light);
    GeomipLightmapShading& g = scene.shading.model.geomip;
    g.lightMap = std::make_shared<const Texture>(Texture::from_float(w, h, 1, std::vector<float>(values.begin(), values.end())));
    g.lightMapScale = glm::vec2(glm::dvec2(w - 1, h - 1) / glm::dvec2(w, h));
    g.lightMapOffset = glm::vec2(glm::dvec2(0.5) / glm::dvec2(w, h));
}

}  // namespace

void prepare_scene(Scene& scene) {
    ScenePreparation& p = scene.preparation;
    if (p.done) return;
    if (p.ground_clearance && scene.camera) lift_camera_above_ground(scene, *p.ground_clearance, p.ground_clearance_where);
    if (p.light_map) compute_light_map(scene, *p.light_map);
    p.done = true;
}

Scene load_scene(const std::string& path) {
    Scene scene = parse_scene(path);
    prepare_scene(scene);
    return scene;
}

Scene load_scene_from_string(const std::string& toml_text, const std::string& path) {
    Scene scene = parse_scene_from_string(toml_text, path);
    prepare_scene(scene);
    return scene;
}

}  // namespace tessref
