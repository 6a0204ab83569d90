// shading_load.h — the [shading] table of a scene (private to src/scene/).
#pragma once

#include <functional>
#include <string>

#include <toml++/toml.h>

#include "tessref/scene.h"

namespace tessref::scene_detail {

// [shading] (null `table`: the scene has none, depth shading) as Scene::shading, its textures
// loaded. `scene` has its camera and grid read: the camera gives the camera-dependent
// uniforms (lab 4 cameraPosition, PN v3CameraPosition, depth near/far), the grid's height
// map is COSC422's heightMap unless the table binds another. `resolve` makes a path of the
// scene file openable. Errors as TableReader's (toml_reader.h).
RenderShading read_shading(const std::string& file, const toml::table* table, const Scene& scene,
                           const std::function<std::string(const std::string&)>& resolve);

}  // namespace tessref::scene_detail
