// shading_load.cpp — the [shading] table (schema: data/scenes/README.md) into
// Scene::shading, its textures loaded.
#include "scene/shading_load.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <vector>

#include "scene/toml_reader.h"
#include "tessref/geomipmap.h"
#include "tessref/heightfield.h"

namespace tessref::scene_detail {

namespace {

using Resolve = std::function<std::string(const std::string&)>;

// Every key of [shading] under any model; finish() reports one the chosen model does not read.
const std::vector<std::string> kShadingKeys = {
    "model", "background", "wireframe_colour",                                      // every model
    "colour",                                                                       // flat
    "mapping",                                                                      // depth
    "light_position", "diffuse_material", "ambient_material", "specular_material",  // thesis_*
    "shininess",                                                                    // thesis_*, pn
    "light_direction",                                                              // lab4, cosc422, pn
    "sand_colour", "rock_colour", "sand_height", "blend_width",                     // lab4
    "ambient",                                                                      // cosc422, geomip_lightmap
    "materials", "clouds", "time",                                                  // geomip_lightmap
    "diffuse_colour",                                                               // pn, pom
    "bump_scale", "parallax", "min_layers", "max_layers", "self_shadow", "shadow_layers",  // pom
    "uv_repeat",                                                                    // pom
    "textures"};                                                                    // the models with samplers

void set(float& target, const std::optional<double>& v) {
    if (v) target = static_cast<float>(*v);
}
void set(glm::vec3& target, const std::optional<glm::dvec3>& v) {
    if (v) target = glm::vec3(*v);
}
void set(glm::vec4& target, const std::optional<glm::dvec4>& v) {
    if (v) target = glm::vec4(*v);
}

std::string text(const glm::vec3& v) {
    return "[" + format_number(v.x) + ", " + format_number(v.y) + ", " + format_number(v.z) + "]";
}

// GLSL leaves normalize(0) undefined; in float a squared length that underflows to 0 or
// overflows gives no direction either. Such a uniform has no reference image.
bool normalizable(const glm::vec3& v) {
    const float d = glm::dot(v, v);
    return d > 0.0f && std::isfinite(d);
}

// A direction the shader normalizes.
void read_direction(TableReader& t, const std::string& k, glm::vec3& target) {
    set(target, t.vec3_opt(k));
    if (t.has(k) && !normalizable(target))
        t.fail(k, t.key(k) + " = " + text(target) + " cannot be normalized (GLSL leaves normalize(0) undefined)");
}

// Exponents of pow(x, shininess) with x = 0 reachable: GLSL leaves pow(0, y <= 0) undefined.
void read_shininess(TableReader& t, float& target) { set(target, t.real_opt("shininess", 0.0, HUGE_VAL, true)); }

void read_model(TableReader& t, ShadingModel& m) {
    switch (m.kind) {
        case ShadingKind::flat: set(m.flat.colour, t.colour_opt("colour")); break;
        case ShadingKind::depth:
            if (const auto mapping = t.choice_opt("mapping", {"linear", "window"}))
                m.depth.mapping = *mapping == "linear" ? DepthMapping::linear : DepthMapping::window;
            break;
        case ShadingKind::thesis_single:
        case ShadingKind::thesis_multi:
            set(m.thesis.lightPosition, t.vec3_opt("light_position"));
            // The specular term normalizes lightPosition + (0, 0, 1) (thesis_light, quirk kept).
            if (t.has("light_position") && !normalizable(m.thesis.lightPosition + glm::vec3(0.0f, 0.0f, 1.0f)))
                t.fail("light_position", t.key("light_position") + " = " + text(m.thesis.lightPosition) +
                                             ": the shader normalizes light_position + (0, 0, 1), which cannot be "
                                             "normalized (GLSL leaves normalize(0) undefined)");
            set(m.thesis.diffuseMaterial, t.vec3_opt("diffuse_material"));
            if (m.kind == ShadingKind::thesis_single) set(m.thesis.ambientMaterial, t.vec3_opt("ambient_material"));
            set(m.thesis.specularMaterial, t.vec3_opt("specular_material"));
            read_shininess(t, m.thesis.shininess);
            break;
        case ShadingKind::lab4: {
            read_direction(t, "light_direction", m.lab4.lightDirection);
            set(m.lab4.sandColour, t.vec3_opt("sand_colour"));
            set(m.lab4.rockColour, t.vec3_opt("rock_colour"));
            set(m.lab4.sandHeight, t.real_opt("sand_height"));
            set(m.lab4.blendWidth, t.real_opt("blend_width", 0.0, HUGE_VAL, true));
            // smoothstep(sandHeight - blendWidth, sandHeight + blendWidth, y), in float: GLSL
            // leaves it undefined when edge0 >= edge1.
            const float edge0 = m.lab4.sandHeight - m.lab4.blendWidth, edge1 = m.lab4.sandHeight + m.lab4.blendWidth;
            if (!(edge0 < edge1))
                t.fail(t.has("blend_width") ? "blend_width" : "sand_height",
                       t.key("blend_width") + " = " + format_number(m.lab4.blendWidth) + " is lost next to " +
                           t.key("sand_height") + " = " + format_number(m.lab4.sandHeight) +
                           " in float: the edges of smoothstep(sand_height - blend_width, sand_height + "
                           "blend_width, y) are equal (GLSL leaves smoothstep undefined when edge0 >= edge1)");
            break;
        }
        case ShadingKind::cosc422:
            read_direction(t, "light_direction", m.cosc422.lightDirection);
            set(m.cosc422.ambient, t.real_opt("ambient"));
            break;
        case ShadingKind::pn:
            read_direction(t, "light_direction", m.pn.v3LightDirection);
            set(m.pn.v3DiffuseColour, t.vec3_opt("diffuse_colour"));
            read_shininess(t, m.pn.fShininess);
            break;
        case ShadingKind::geomip_lightmap: break;  // read_geomip_lightmap
        case ShadingKind::pom: {
            read_direction(t, "light_direction", m.pom.v3LightDirection);
            set(m.pom.v3DiffuseColour, t.vec3_opt("diffuse_colour"));
            read_shininess(t, m.pom.fShininess);
            ParallaxParams& p = m.pom.parallax;
            if (const auto mode = t.choice_opt("parallax", {"none", "parallax", "steep", "occlusion"}))
                p.mode = *parallax_mode_from_string(*mode);
            set(p.fBumpScale, t.real_opt("bump_scale", 0.0, 16.0));
            // The layer counts are loop bounds in the shader: whole numbers from 1 to 256.
            if (const auto v = t.integer_opt("min_layers", 1, 256)) p.fMinLayers = static_cast<float>(*v);
            if (const auto v = t.integer_opt("max_layers", 1, 256)) p.fMaxLayers = static_cast<float>(*v);
            if (const auto v = t.integer_opt("shadow_layers", 1, 256)) p.fShadowLayers = static_cast<float>(*v);
            if (p.fMinLayers > p.fMaxLayers)
                t.fail(t.has("min_layers") ? "min_layers" : "max_layers",
                       t.key("min_layers") + " = " + format_number(p.fMinLayers) + " is above " + t.key("max_layers") +
                           " = " + format_number(p.fMaxLayers));
            if (const auto v = t.boolean_opt("self_shadow")) m.pom.bSelfShadow = *v;
            set(m.pom.fUvRepeat, t.real_opt("uv_repeat", 0.0, 65536.0, true));
            break;
        }
    }
}

// One entry of shading.textures: "path", { path = "...", luminance = true } or a colour.
std::shared_ptr<const Texture> read_texture(TableReader& textures, const std::string& sampler, const Scene& scene,
                                            const Resolve& resolve) {
    const toml::node& n = *textures.node(sampler);
    if (n.is_array()) {
        const glm::vec4 c(*textures.colour_opt(sampler));
        return std::make_shared<const Texture>(Texture::from_float(1, 1, 4, {c.r, c.g, c.b, c.a}));
    }
    std::string path;
    Where where = textures.where(sampler);
    std::optional<Where> luminance;  // where luminance = true was asked
    if (n.is_string()) {
        path = *textures.string_opt(sampler);
        if (path.empty()) textures.fail(sampler, textures.key(sampler) + " must name an image");
    } else if (const toml::table* spec = n.as_table()) {
        TableReader t(textures.file(), *spec, textures.key(sampler), {"path", "luminance"});
        path = t.string("path", "the image");
        if (path.empty()) t.fail("path", t.key("path") + " must name an image");
        where = t.where("path");
        if (t.boolean_opt("luminance").value_or(false)) luminance = t.where("luminance");
        t.finish();
    } else {
        textures.wrong_type(sampler, n, "a path, { path = \"...\", luminance = true } or a colour [r, g, b, a]");
    }
    const std::string file = resolve(path);
    Texture texture;
    try {
        texture = load_scene_texture(file, scene);
    } catch (const Error& e) {
        throw Error("cannot load texture: " + e.message(), where);
    } catch (const std::exception& e) {
        throw Error("cannot load texture: " + std::string(e.what()), where);
    }
    if (luminance) {
        if (texture.channels() != 1)
            throw Error(luminance->key + " = true needs a one-channel image; " + file + " has " +
                            std::to_string(texture.channels()),
                        *luminance);
        texture.set_swizzle(Swizzle::luminance);
    }
    return std::make_shared<const Texture>(std::move(texture));
}

// An image named by key `k` of table `t`, loaded (an error names the key and the file).
std::shared_ptr<const Texture> read_image(TableReader& t, const std::string& k, const Scene& scene, const Resolve& resolve,
                                          Wrap wrap) {
    const std::string path = t.string(k, "an image");
    if (path.empty()) t.fail(k, t.key(k) + " must name an image");
    const std::string file = resolve(path);
    Texture texture;
    try {
        texture = load_scene_texture(file, scene);
    } catch (const Error& e) {
        throw Error("cannot load texture " + file + ": " + e.message(), t.where(k));
    } catch (const std::exception& e) {
        throw Error("cannot load texture " + file + ": " + std::string(e.what()), t.where(k));
    }
    texture.set_wrap(wrap);
    return std::make_shared<const Texture>(std::move(texture));
}

// geomip_lightmap: the light the light map is computed from (by the preparation pass,
// prepare.h: the light map is geomipmap.h's LIGHT MAP over the terrain), the materials, the
// clouds.
void read_geomip_lightmap(TableReader& t, Scene& scene, GeomipLightmapShading& g, const Resolve& resolve) {
    if (scene.evaluation.model != EvaluationModel::geomipmap || !scene.grid || !scene.grid->heightmap)
        t.fail("model", "shading model geomip_lightmap lights a geomipmapped terrain from its height map: it needs "
                        "evaluation model geomipmap");
    // One light and alpha texel per height sample (geomip_terrain() reads mip 0 of the map).
    const int w = scene.grid->heightmap->texture.width(), h = scene.grid->heightmap->texture.height();

    geomip::LightMapParams light;
    if (const auto d = t.vec3_opt("light_direction")) {
        light.light_direction = *d;
        const double dd = glm::dot(*d, *d);
        if (!(dd > 0.0) || !std::isfinite(dd))
            t.fail("light_direction", t.key("light_direction") + " cannot be normalized");
    }
    light.ambient = t.real_or("ambient", light.ambient, 0.0, 1.0);
    scene.preparation.light_map = light;

    // The materials: an array of { texture, repeat, alpha }; the first is the base pass.
    const toml::node* n = t.node("materials");
    if (!n) t.missing("materials", "the material passes, the first without an alpha map");
    const toml::array* list = n->as_array();
    if (!list) t.wrong_type("materials", *n, "an array of tables { texture = \"...\", repeat = r, alpha = \"...\" }");
    if (list->empty()) t.fail("materials", t.key("materials") + " must name at least one material (the base pass)");
    for (std::size_t i = 0; i < list->size(); ++i) {
        const toml::node& e = *list->get(i);
        const std::string name = t.key("materials") + "[" + std::to_string(i) + "]";
        const toml::table* tbl = e.as_table();
        if (!tbl)
            throw Error(name + " must be a table { texture = \"...\", repeat = r, alpha = \"...\" }, not " +
                            type_name(e),
                        where_at(t.file(), e.source(), name));
        TableReader m(t.file(), *tbl, name, {"texture", "repeat", "alpha"});
        GeomipMaterial material;
        material.texture = read_image(m, "texture", scene, resolve, Wrap::repeat);
        material.repeat = static_cast<float>(m.real_or("repeat", 1.0, 0.0, 1e6, true));
        if (i == 0) {
            if (m.has("alpha"))
                m.fail("alpha", m.key("alpha") + ": the base pass has no alpha map (nothing is drawn before it)");
        } else {
            material.alpha = read_image(m, "alpha", scene, resolve, Wrap::clamp_to_edge);
            if (material.alpha->width() != w || material.alpha->height() != h)
                m.fail("alpha", m.key("alpha") + ": the alpha map is " + std::to_string(material.alpha->width()) + "x" +
                                    std::to_string(material.alpha->height()) + ", the height map " + std::to_string(w) +
                                    "x" + std::to_string(h) + " (one alpha texel per height sample)");
        }
        m.finish();
        g.materials.push_back(std::move(material));
    }

    // The clouds: { texture, repeat, velocity }, scrolled to velocity * time.
    if (const toml::table* c = t.table_opt("clouds")) {
        TableReader ct(t.file(), *c, t.key("clouds"), {"texture", "repeat", "velocity"});
        g.clouds = read_image(ct, "texture", scene, resolve, Wrap::repeat);
        g.cloudRepeat = static_cast<float>(ct.real_or("repeat", 1.0, 0.0, 1e6, true));
        const glm::dvec2 velocity = ct.vec2_opt("velocity").value_or(glm::dvec2(0.0));
        const double time = t.real_or("time", 0.0, -1e12, 1e12);
        // The translation in double, reduced to [0, 1) before float sees it: a texture that
        // repeats is the same there, and a large time keeps its precision.
        const glm::dvec2 offset = velocity * time;
        g.cloudOffset = glm::vec2(offset - glm::floor(offset));
        ct.finish();
    } else if (t.has("time")) {
        t.fail("time", t.key("time") + " moves the cloud shadows: it is not used without shading.clouds");
    }
}

std::string joined(const std::vector<std::string>& names) {
    std::string list;
    for (const std::string& s : names) list += (list.empty() ? "" : ", ") + s;
    return list;
}

}  // namespace

Texture load_scene_texture(const std::string& file, const Scene& scene) {
    if (scene.grid && scene.grid->heightmap && file == scene.grid->heightmap_path)
        if (std::optional<Texture> same = texture_of_height_field(*scene.grid->heightmap)) return std::move(*same);
    return load_texture(file);
}

RenderShading read_shading(const std::string& file, const toml::table* table, Scene& scene,
                           const Resolve& resolve) {
    RenderShading out;
    ShadingModel& m = out.model;
    if (!table) return out;

    TableReader t(file, *table, "shading", kShadingKeys);
    std::string model = to_string(m.kind);
    if (const auto name = t.string_opt("model")) {
        const auto kind = shading_kind_from_string(*name);
        if (!kind)
            t.fail("model", "unknown shading model '" + *name +
                                "'; expected flat, depth, thesis_single, thesis_multi, lab4, cosc422, pn, "
                                "geomip_lightmap or pom");
        m.kind = *kind;
        model = *name;
    }
    set(out.background, t.colour_opt("background"));
    set(out.wireframe_colour, t.colour_opt("wireframe_colour"));
    if (m.kind == ShadingKind::geomip_lightmap)
        read_geomip_lightmap(t, scene, m.geomip, resolve);
    else
        read_model(t, m);

    // Textures: only the samplers of the model's shader, by their GLSL names.
    const std::vector<std::string> samplers(sampler_names(m.kind).begin(), sampler_names(m.kind).end());
    if (const toml::node* n = t.node("textures")) {
        if (!n->is_table()) t.wrong_type("textures", *n, "a table { sampler = texture, ... }");
        for (auto&& [k, v] : *n->as_table()) {
            const std::string name(k.str());
            if (std::find(samplers.begin(), samplers.end(), name) == samplers.end())
                throw Error("shading model " + model + " has no sampler '" + name + "'" +
                                (samplers.empty() ? " (it reads no texture)" : " (its samplers: " + joined(samplers) + ")"),
                            where_at(file, v.source(), "shading.textures." + name));
        }
        TableReader textures(file, *n->as_table(), "shading.textures", samplers);
        for (const std::string& name : samplers)
            if (textures.has(name)) *sampler_slot(m.textures, name) = read_texture(textures, name, scene, resolve);
        textures.finish();
    }
    // COSC422's fragment shader samples the terrain's own height map.
    if (m.kind == ShadingKind::cosc422 && !m.textures.heightMap && scene.grid && scene.grid->heightmap)
        m.textures.heightMap = std::shared_ptr<const Texture>(scene.grid->heightmap, &scene.grid->heightmap->texture);
    // pom.frag's samplers wrap (GL's default), so that uv_repeat tiles them.
    if (m.kind == ShadingKind::pom)
        for (const std::string& name : samplers) {
            auto& slot = *sampler_slot(m.textures, name);
            if (slot && slot->wrap() != Wrap::repeat) {
                auto copy = std::make_shared<Texture>(*slot);
                copy->set_wrap(Wrap::repeat);
                slot = std::move(copy);
            }
        }
    t.finish("by shading model " + model);

    // GL would read (0, 0, 0, 1) from a sampler with no texture: surely not what was meant.
    const auto missing = missing_textures(m);
    if (!missing.empty()) {
        Where w = t.where(t.has("textures") ? "textures" : "model");
        w.key = t.key("textures");
        throw Error("shading model " + model + " samples " +
                        joined(std::vector<std::string>(missing.begin(), missing.end())) +
                        ", which no texture is bound to (give them in shading.textures)",
                    w);
    }
    return out;
}

}  // namespace tessref::scene_detail

namespace tessref {

void set_camera_uniforms(Scene& scene) {
    if (!scene.camera) return;
    ShadingModel& m = scene.shading.model;
    const glm::vec3 eye(scene.camera->eye);
    m.lab4.cameraPosition = eye;
    m.pn.v3CameraPosition = eye;
    m.pom.v3CameraPosition = eye;
    m.depth.near_plane = static_cast<float>(scene.camera->near_plane);
    m.depth.far_plane = static_cast<float>(scene.camera->far_plane);
}

}  // namespace tessref
