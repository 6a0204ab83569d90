// shading_load.cpp — the [shading] table (schema: data/scenes/README.md) into
// Scene::shading, its textures loaded.
#include "scene/shading_load.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "scene/toml_reader.h"
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
    "ambient",                                                                      // cosc422
    "diffuse_colour",                                                               // pn
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
    }
}

// A one-channel texture read as (r, r, r, 1): the same stored values in three channels, so
// that each channel filters exactly as the red one does.
Texture luminance_texture(const Texture& source) {
    const TextureLevel& level0 = source.level(0);
    const std::size_t n = static_cast<std::size_t>(level0.width) * static_cast<std::size_t>(level0.height);
    switch (source.format()) {
        case TexelFormat::unorm8: {
            std::vector<std::uint8_t> codes(n * 3);
            for (std::size_t i = 0; i < n; ++i) codes[3 * i] = codes[3 * i + 1] = codes[3 * i + 2] = level0.unorm8[i];
            return Texture::from_unorm8(level0.width, level0.height, 3, std::move(codes), source.mipmap_rule());
        }
        case TexelFormat::unorm16: {
            std::vector<std::uint16_t> codes(n * 3);
            for (std::size_t i = 0; i < n; ++i) {
                // Stored as code * (1/65535) in float: rounding recovers the code exactly.
                const auto code = static_cast<std::uint16_t>(std::lround(static_cast<double>(level0.texels[i]) * 65535.0));
                codes[3 * i] = codes[3 * i + 1] = codes[3 * i + 2] = code;
            }
            return Texture::from_unorm16(level0.width, level0.height, 3, std::move(codes), source.mipmap_rule());
        }
        case TexelFormat::float32: {
            std::vector<float> texels(n * 3);
            for (std::size_t i = 0; i < n; ++i) texels[3 * i] = texels[3 * i + 1] = texels[3 * i + 2] = level0.texels[i];
            return Texture::from_float(level0.width, level0.height, 3, std::move(texels), source.mipmap_rule());
        }
    }
    return source;
}

// One entry of shading.textures: "path", { path = "...", luminance = true } or a colour.
std::shared_ptr<const Texture> read_texture(TableReader& textures, const std::string& sampler, const Resolve& resolve) {
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
        texture = load_texture(file);
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
        texture = luminance_texture(texture);
    }
    return std::make_shared<const Texture>(std::move(texture));
}

std::string joined(const std::vector<std::string>& names) {
    std::string list;
    for (const std::string& s : names) list += (list.empty() ? "" : ", ") + s;
    return list;
}

}  // namespace

RenderShading read_shading(const std::string& file, const toml::table* table, const Scene& scene,
                           const Resolve& resolve) {
    RenderShading out;
    ShadingModel& m = out.model;
    if (scene.camera) {
        const glm::vec3 eye(scene.camera->eye);
        m.lab4.cameraPosition = eye;
        m.pn.v3CameraPosition = eye;
        m.depth.near_plane = static_cast<float>(scene.camera->near_plane);
        m.depth.far_plane = static_cast<float>(scene.camera->far_plane);
    }
    if (!table) return out;

    TableReader t(file, *table, "shading", kShadingKeys);
    std::string model = to_string(m.kind);
    if (const auto name = t.string_opt("model")) {
        const auto kind = shading_kind_from_string(*name);
        if (!kind)
            t.fail("model", "unknown shading model '" + *name +
                                "'; expected flat, depth, thesis_single, thesis_multi, lab4, cosc422 or pn");
        m.kind = *kind;
        model = *name;
    }
    set(out.background, t.colour_opt("background"));
    set(out.wireframe_colour, t.colour_opt("wireframe_colour"));
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
            if (textures.has(name)) *sampler_slot(m.textures, name) = read_texture(textures, name, resolve);
        textures.finish();
    }
    // COSC422's fragment shader samples the terrain's own height map.
    if (m.kind == ShadingKind::cosc422 && !m.textures.heightMap && scene.grid && scene.grid->heightmap)
        m.textures.heightMap = std::shared_ptr<const Texture>(scene.grid->heightmap, &scene.grid->heightmap->texture);
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
