// shading_load.h — the [shading] table of a scene (private to src/scene/).
#pragma once

#include <functional>
#include <string>

#include <toml++/toml.h>

#include "tessref/scene.h"

namespace tessref::scene_detail {

// load_texture(file), or the texture of the scene's height map where `file` is that map and
// texture_of_height_field gives it: a file the scene names twice is decoded once.
Texture load_scene_texture(const std::string& file, const Scene& scene);

// [shading] (null `table`: the scene has none, depth shading) as Scene::shading, its textures
// loaded, the camera's uniforms not yet set (set_camera_uniforms, scene.h). `scene` has its
// grid read: its height map is COSC422's heightMap unless the table binds another, and
// geomip_lightmap's light goes into scene.preparation. `resolve` makes a path of the scene
// file openable. Errors as TableReader's (toml_reader.h).
RenderShading read_shading(const std::string& file, const toml::table* table, Scene& scene,
                           const std::function<std::string(const std::string&)>& resolve);

}  // namespace tessref::scene_detail
