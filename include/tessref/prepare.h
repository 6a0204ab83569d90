// tessref/prepare.h — the preparation pass: what a scene asks to be computed from its own
// terrain before it is run, after the load and in the flow's order.
//
// Loading (scene.h, parse_scene) only parses: it reads and checks every key and loads the
// files a scene names, and runs no stage. Two keys need a stage's result first, and the
// preparation pass computes them (Scene::preparation says which):
// - [camera] ground_clearance = d (lab 4's camera collision): the pipeline runs with the
//   camera as given (the current frame's levels), the tessellated surface's height h under
//   the eye is found (render.h, ground_height), and the eye's up coordinate becomes h + d,
//   the center moving with it (and the shading's camera uniforms with the eye). The render
//   then tessellates again from the lifted eye, so levels that depend on the eye may differ
//   a little from those the height was read on, as in an application that moves the camera
//   with the previous frame's surface.
// - [shading] model = "geomip_lightmap": the light map (geomipmap.h, LIGHT MAP) of the
//   terrain's height samples under the scene's light, one texel per sample.
// Every command runs a scene as load_scene() gives it.
#pragma once

#include <string>

#include "tessref/scene.h"

namespace tessref {

// Computes what scene.preparation asks for, once (a prepared scene is left as it is).
// Throws tessref::Error at the key that asked for it (camera.ground_clearance: the
// pipeline's error, or no triangle under the eye).
void prepare_scene(Scene& scene);

// parse_scene(path), then prepare_scene(): a scene ready to run.
Scene load_scene(const std::string& path);
// The same from TOML text (parse_scene_from_string).
Scene load_scene_from_string(const std::string& toml_text, const std::string& path);

}  // namespace tessref
