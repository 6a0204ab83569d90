// The scene's [shading] table (render.h) into a ShadingModel, with its textures loaded.
//
// The scene loader keeps the table as text (Scene::shading_toml). To report errors at the
// right line and column, the scene file itself is parsed again when it still exists and its
// [shading] table is read from there; otherwise the kept text is parsed (line 0).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <toml++/toml.h>

#include "render/render_internal.h"
#include "tessref/error.h"
#include "tessref/heightfield.h"
#include "tessref/render.h"

namespace tessref {

namespace {

class ShadingReader {
public:
    ShadingReader(const Scene& scene, const toml::table& table, bool positions_known)
        : scene_(scene), table_(table), positions_known_(positions_known) {}

    Where where(const toml::node* node, const std::string& key) const {
        Where w;
        w.file = scene_.file;
        w.key = "shading" + (key.empty() ? std::string() : "." + key);
        if (node && positions_known_) {
            w.line = static_cast<int>(node->source().begin.line);
            w.column = static_cast<int>(node->source().begin.column);
        }
        return w;
    }

    const toml::node* get(const std::string& key) {
        used_.push_back(key);
        return table_.get(key);
    }

    std::optional<double> number(const std::string& key) {
        const toml::node* n = get(key);
        if (!n) return std::nullopt;
        if (const auto v = n->value<double>()) {
            if (!std::isfinite(*v)) throw Error("shading." + key + " must be a finite number", where(n, key));
            return *v;
        }
        throw Error("shading." + key + " must be a number", where(n, key));
    }

    // [a, b, c] or [a, b, c, d] (when `allow_four`); `count` 3 or 4.
    std::optional<glm::vec4> vector(const std::string& key, int min_count, int max_count) {
        const toml::node* n = get(key);
        if (!n) return std::nullopt;
        return vector_of(n, key, min_count, max_count);
    }

    glm::vec4 vector_of(const toml::node* n, const std::string& key, int min_count, int max_count) const {
        const toml::array* a = n->as_array();
        const auto size = a ? static_cast<int>(a->size()) : -1;
        if (!a || size < min_count || size > max_count) {
            const std::string expected = min_count == max_count
                                             ? std::to_string(min_count) + " numbers"
                                             : std::to_string(min_count) + " or " + std::to_string(max_count) + " numbers";
            throw Error("shading." + key + " must be an array of " + expected, where(n, key));
        }
        glm::vec4 v(0.0f, 0.0f, 0.0f, 1.0f);
        for (int i = 0; i < size; ++i) {
            const auto x = (*a)[static_cast<std::size_t>(i)].value<double>();
            if (!x || !std::isfinite(*x))
                throw Error("shading." + key + "[" + std::to_string(i) + "] must be a finite number",
                            where(&(*a)[static_cast<std::size_t>(i)], key));
            v[i] = static_cast<float>(*x);
        }
        return v;
    }

    std::optional<std::string> string(const std::string& key) {
        const toml::node* n = get(key);
        if (!n) return std::nullopt;
        if (const auto s = n->value<std::string>()) return *s;
        throw Error("shading." + key + " must be a string", where(n, key));
    }

    // Every key of the table must have been read.
    void finish(const std::string& model_name) const {
        for (auto&& [k, n] : table_) {
            const std::string key(k.str());
            if (std::find(used_.begin(), used_.end(), key) == used_.end())
                throw Error("key shading." + key + " is not used by shading model " + model_name,
                            where(&n, key));
        }
    }

    const Scene& scene() const { return scene_; }

private:
    const Scene& scene_;
    const toml::table& table_;
    bool positions_known_;
    std::vector<std::string> used_;
};

std::string resolve_path(const Scene& scene, const std::string& path) {
    const std::filesystem::path p(path);
    if (p.is_absolute()) return path;
    return (std::filesystem::path(scene.file).parent_path() / p).string();
}

// A one-channel texture read as (r, r, r, 1): the same stored values in three channels, so
// that each channel filters exactly as the red one does.
Texture luminance_texture(const Texture& source, const std::string& path, const Where& where) {
    if (source.channels() != 1)
        throw Error("luminance = true needs a one-channel image, '" + path + "' has " +
                        std::to_string(source.channels()),
                    where);
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

std::shared_ptr<const Texture> read_texture(ShadingReader& reader, const toml::node& node, const std::string& key) {
    const Scene& scene = reader.scene();
    if (const auto path = node.value<std::string>()) {
        try {
            return std::make_shared<const Texture>(load_texture(resolve_path(scene, *path)));
        } catch (const Error& e) {
            throw Error("texture '" + resolve_path(scene, *path) + "': " + e.what(), reader.where(&node, key));
        }
    }
    if (node.is_array()) {
        const glm::vec4 c = reader.vector_of(&node, key, 3, 4);
        return std::make_shared<const Texture>(Texture::from_float(1, 1, 4, {c.r, c.g, c.b, c.a}));
    }
    if (const toml::table* t = node.as_table()) {
        std::string path;
        bool luminance = false;
        for (auto&& [k, n] : *t) {
            const std::string sub(k.str());
            if (sub == "path") {
                const auto s = n.value<std::string>();
                if (!s) throw Error("shading." + key + ".path must be a string", reader.where(&n, key + ".path"));
                path = *s;
            } else if (sub == "luminance") {
                const auto b = n.value<bool>();
                if (!b) throw Error("shading." + key + ".luminance must be true or false", reader.where(&n, key + ".luminance"));
                luminance = *b;
            } else {
                throw Error("unknown key shading." + key + "." + sub + " (known: path, luminance)",
                            reader.where(&n, key + "." + sub));
            }
        }
        if (path.empty()) throw Error("shading." + key + " needs a path", reader.where(&node, key));
        try {
            Texture texture = load_texture(resolve_path(scene, path));
            if (luminance) texture = luminance_texture(texture, path, reader.where(&node, key));
            return std::make_shared<const Texture>(std::move(texture));
        } catch (const Error& e) {
            throw Error("texture '" + resolve_path(scene, path) + "': " + e.what(), reader.where(&node, key));
        }
    }
    throw Error("shading." + key + " must be a path, { path = ..., luminance = true } or a colour [r, g, b, a]",
                reader.where(&node, key));
}

void read_model(ShadingReader& r, RenderShading& out) {
    ShadingModel& m = out.model;
    auto vec3_of = [](const std::optional<glm::vec4>& v, glm::vec3& target) {
        if (v) target = glm::vec3(*v);
    };
    auto float_of = [](const std::optional<double>& v, float& target) {
        if (v) target = static_cast<float>(*v);
    };
    switch (m.kind) {
        case ShadingKind::flat:
            if (const auto c = r.vector("colour", 3, 4)) m.flat.colour = *c;
            break;
        case ShadingKind::depth:
            if (const auto mapping = r.string("mapping")) {
                if (*mapping == "linear") m.depth.mapping = DepthMapping::linear;
                else if (*mapping == "window") m.depth.mapping = DepthMapping::window;
                else throw Error("unknown shading.mapping '" + *mapping + "'; expected linear or window",
                                 r.where(r.get("mapping"), "mapping"));
            }
            break;
        case ShadingKind::thesis_single:
        case ShadingKind::thesis_multi:
            vec3_of(r.vector("light_position", 3, 3), m.thesis.lightPosition);
            vec3_of(r.vector("diffuse_material", 3, 3), m.thesis.diffuseMaterial);
            if (m.kind == ShadingKind::thesis_single) vec3_of(r.vector("ambient_material", 3, 3), m.thesis.ambientMaterial);
            vec3_of(r.vector("specular_material", 3, 3), m.thesis.specularMaterial);
            float_of(r.number("shininess"), m.thesis.shininess);
            break;
        case ShadingKind::lab4:
            vec3_of(r.vector("light_direction", 3, 3), m.lab4.lightDirection);
            vec3_of(r.vector("sand_colour", 3, 3), m.lab4.sandColour);
            vec3_of(r.vector("rock_colour", 3, 3), m.lab4.rockColour);
            float_of(r.number("sand_height"), m.lab4.sandHeight);
            float_of(r.number("blend_width"), m.lab4.blendWidth);
            break;
        case ShadingKind::cosc422:
            vec3_of(r.vector("light_direction", 3, 3), m.cosc422.lightDirection);
            float_of(r.number("ambient"), m.cosc422.ambient);
            break;
        case ShadingKind::pn:
            vec3_of(r.vector("light_direction", 3, 3), m.pn.v3LightDirection);
            vec3_of(r.vector("diffuse_colour", 3, 3), m.pn.v3DiffuseColour);
            float_of(r.number("shininess"), m.pn.fShininess);
            break;
    }
}

}  // namespace

RenderShading shading_model(const Scene& scene) {
    RenderShading out;
    out.model.kind = ShadingKind::depth;
    out.model.depth.mapping = DepthMapping::linear;

    // Where the table comes from: the scene file when it is there (true positions), the kept
    // text otherwise.
    toml::table root;
    bool positions_known = false;
    const toml::table* table = nullptr;
    if (scene.shading_toml) {
        std::error_code ec;
        if (!scene.file.empty() && std::filesystem::is_regular_file(scene.file, ec)) {
            try {
                root = toml::parse_file(scene.file);
                if (const toml::node* s = root.get("shading"); s && s->is_table()) {
                    table = s->as_table();
                    positions_known = true;
                }
            } catch (const toml::parse_error&) {
                table = nullptr;  // the file changed since it was loaded: use the kept text
            }
        }
        if (!table) {
            try {
                root = toml::parse(*scene.shading_toml);
            } catch (const toml::parse_error& e) {
                Where w;
                w.file = scene.file;
                w.key = "shading";
                throw Error("the kept [shading] table does not parse: " + std::string(e.description()), w);
            }
            table = &root;
        }
    }

    if (scene.camera) {
        const glm::vec3 eye(scene.camera->eye);
        out.model.lab4.cameraPosition = eye;
        out.model.pn.v3CameraPosition = eye;
        out.model.depth.near_plane = static_cast<float>(scene.camera->near_plane);
        out.model.depth.far_plane = static_cast<float>(scene.camera->far_plane);
    }
    if (!table) return out;

    ShadingReader reader(scene, *table, positions_known);
    std::string model_name = "depth";
    if (const auto name = reader.string("model")) {
        const auto kind = shading_kind_from_string(*name);
        if (!kind)
            throw Error("unknown shading model '" + *name +
                            "'; expected flat, depth, thesis_single, thesis_multi, lab4, cosc422 or pn",
                        reader.where(table->get("model"), "model"));
        out.model.kind = *kind;
        model_name = *name;
    }
    if (const auto bg = reader.vector("background", 3, 4)) out.background = *bg;
    if (const auto wc = reader.vector("wireframe_colour", 3, 4)) out.wireframe_colour = *wc;
    read_model(reader, out);

    // Textures: only the samplers of the model's shader.
    const auto samplers = sampler_names(out.model.kind);
    if (const toml::node* t = reader.get("textures")) {
        const toml::table* textures = t->as_table();
        if (!textures) throw Error("shading.textures must be a table { sampler = texture, ... }", reader.where(t, "textures"));
        for (auto&& [k, n] : *textures) {
            const std::string name(k.str());
            const std::string key = "textures." + name;
            if (std::find(samplers.begin(), samplers.end(), name) == samplers.end()) {
                std::string known;
                for (const std::string_view s : samplers) known += (known.empty() ? "" : ", ") + std::string(s);
                throw Error("shading model " + model_name + " has no sampler '" + name + "'" +
                                (known.empty() ? std::string(" (it reads no texture)") : " (its samplers: " + known + ")"),
                            reader.where(&n, key));
            }
            *sampler_slot(out.model.textures, name) = read_texture(reader, n, key);
        }
    }
    // COSC422's fragment shader samples the terrain's own height map.
    if (out.model.kind == ShadingKind::cosc422 && !out.model.textures.heightMap && scene.grid && scene.grid->heightmap)
        out.model.textures.heightMap = std::shared_ptr<const Texture>(scene.grid->heightmap, &scene.grid->heightmap->texture);
    reader.finish(model_name);

    const auto missing = missing_textures(out.model);
    if (!missing.empty()) {
        std::string list;
        for (const std::string_view s : missing) list += (list.empty() ? "" : ", ") + std::string(s);
        throw Error("shading model " + model_name + " samples " + list +
                        ", which no texture is bound to (give them in shading.textures)",
                    reader.where(table->get("textures") ? table->get("textures") : table->get("model"), "textures"));
    }
    return out;
}

}  // namespace tessref
