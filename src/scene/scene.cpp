// scene.cpp — parsing, validating and loading a scene file (the format: data/scenes/README.md).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <utility>

#include <glm/gtc/matrix_transform.hpp>
#include <toml++/toml.h>

#include "mesh/openmesh.h"
#include "scene/shading_load.h"
#include "scene/toml_reader.h"
#include "tessref/mesh_io.h"
#include "tessref/scene.h"

namespace tessref {

using scene_detail::TableReader;
using scene_detail::where_at;

const char* to_string(ControlModel model) {
    switch (model) {
        case ControlModel::constant: return "constant";
        case ControlModel::thesis: return "thesis";
        case ControlModel::cosc422: return "cosc422";
        case ControlModel::lab4: return "lab4";
        case ControlModel::pn: return "pn";
    }
    return "?";
}
const char* to_string(EvaluationModel model) {
    switch (model) {
        case EvaluationModel::thesis: return "thesis";
        case EvaluationModel::cosc422: return "cosc422";
        case EvaluationModel::lab4: return "lab4";
        case EvaluationModel::pn: return "pn";
        case EvaluationModel::geomipmap: return "geomipmap";
    }
    return "?";
}
const char* to_string(GeometryNormals normals) {
    switch (normals) {
        case GeometryNormals::face: return "face";
        case GeometryNormals::normal_map: return "normal_map";
        case GeometryNormals::height_field: return "height_field";
        case GeometryNormals::smooth: return "smooth";
    }
    return "?";
}

const char* to_string(ShaderStage stage) {
    switch (stage) {
        case ShaderStage::vertex: return "vertex";
        case ShaderStage::tess_control: return "tess_control";
        case ShaderStage::tess_evaluation: return "tess_evaluation";
        case ShaderStage::geometry: return "geometry";
        case ShaderStage::fragment: return "fragment";
    }
    return "?";
}
std::optional<ShaderStage> shader_stage_from_string(const std::string& name) {
    static const std::pair<const char*, ShaderStage> names[] = {
        {"vertex", ShaderStage::vertex},     {"vert", ShaderStage::vertex},
        {"tess_control", ShaderStage::tess_control},     {"tesc", ShaderStage::tess_control},
        {"tess_evaluation", ShaderStage::tess_evaluation}, {"tese", ShaderStage::tess_evaluation},
        {"geometry", ShaderStage::geometry}, {"geom", ShaderStage::geometry},
        {"fragment", ShaderStage::fragment}, {"frag", ShaderStage::fragment}};
    for (const auto& [n, stage] : names)
        if (name == n) return stage;
    return std::nullopt;
}

glm::dmat4 SceneCamera::view() const { return glm::lookAt(eye, center, up); }
glm::dmat4 SceneCamera::projection() const {
    return glm::perspective(glm::radians(fov_y_degrees),
                            static_cast<double>(viewport.x) / static_cast<double>(viewport.y),
                            near_plane, far_plane);
}

std::array<glm::dvec3, 4> TerrainGrid::corners(std::size_t patch) const {
    const std::size_t i = patch % static_cast<std::size_t>(patches_u);
    const std::size_t j = patch / static_cast<std::size_t>(patches_u);
    auto point = [&](std::size_t a, std::size_t b) {
        return plane == GroundPlane::xy ? glm::dvec3(u_coords[a], v_coords[b], 0.0)
                                        : glm::dvec3(u_coords[a], 0.0, v_coords[b]);
    };
    // control.h layout: c0 = (u,v) (0,0), c1 = (0,1), c2 = (1,1), c3 = (1,0).
    return {point(i, j), point(i, j + 1), point(i + 1, j + 1), point(i + 1, j)};
}

std::size_t Scene::patch_count() const {
    if (grid) return grid->patch_count();
    if (meshes) return meshes->patch_count();
    return 0;
}

namespace {

namespace fs = std::filesystem;

// The tables a scene may have.
const std::vector<std::string> kTopLevel = {"scene",      "domain",   "mesh",     "camera",  "generator", "control",
                                            "evaluation", "geometry", "shading", "shaders", "limits",
                                            "culling"};

struct Loader {
    std::string file;     // as given, for messages
    fs::path base_dir;    // relative paths start here
    Scene scene;

    std::string resolve(const std::string& relative) const {
        fs::path p(relative);
        if (p.is_absolute()) return p.string();
        return (base_dir / p).lexically_normal().string();
    }

    // Runs a loader and re-throws its tessref::Error with the scene's place.
    template <typename F>
    auto load_file(const TableReader& table, const std::string& key, const std::string& what, F&& f) {
        try {
            return f();
        } catch (const Error& e) {
            throw Error(what + ": " + e.message(), table.where(key));
        } catch (const std::exception& e) {
            throw Error(what + ": " + e.what(), table.where(key));
        }
    }

    // ---- [scene] ------------------------------------------------------------------
    void read_scene(const toml::table& root) {
        const toml::node* n = root.get("scene");
        if (!n) throw Error("missing table [scene]", Where::at_key(file, "scene"));
        if (!n->is_table()) throw Error("scene must be a table", where_at(file, n->source(), "scene"));
        TableReader t(file, *n->as_table(), "scene", {"name", "description"});
        scene.name = t.string("name");
        if (scene.name.empty()) t.fail("name", "scene.name must not be empty");
        scene.description = t.string_opt("description").value_or("");
        t.finish();
    }

    // ---- [camera] -----------------------------------------------------------------
    void read_camera(const toml::table& table, const glm::dvec3& default_up) {
        TableReader t(file, table, "camera",
                      {"position", "theta", "phi", "eye", "center", "up", "fov_y", "viewport", "near", "far",
                       "ground_clearance"});
        SceneCamera cam;
        const bool thesis_style = t.has("position") || t.has("theta") || t.has("phi");
        const bool lookat_style = t.has("eye") || t.has("center");
        if (thesis_style && lookat_style)
            t.fail(t.has("eye") ? "eye" : "center",
                   "camera: give either position/theta/phi (thesis) or eye/center/up, not both");
        if (thesis_style) {
            auto position = t.vec3_opt("position");
            if (!position) t.missing("position", "the thesis camera needs position, theta and phi");
            const double theta = t.real("theta", -1e6, 1e6, false, false, "the thesis camera needs theta");
            const double phi = t.real("phi", -89.9, 89.9, false, false, "the thesis camera needs phi");
            // Listing 2: the thesis's 3.14 (not pi) is kept; it turns the view by a few
            // hundredths of a degree, as the program that made the figures did.
            glm::dvec3 target(std::sin(theta * 3.14 / 180.0), std::cos(theta * 3.14 / 180.0),
                              std::tan(phi * 3.14 / 180.0));
            target = glm::normalize(target);
            cam.eye = *position;
            cam.center = *position + target;
            cam.up = glm::dvec3(0.0, 0.0, 1.0);
            if (t.has("up")) t.fail("up", "camera.up is fixed to (0, 0, 1) by the thesis camera (position/theta/phi)");
        } else {
            auto eye = t.vec3_opt("eye");
            if (!eye) t.missing("eye", "give eye/center/up or position/theta/phi");
            auto center = t.vec3_opt("center");
            if (!center) t.missing("center");
            cam.eye = *eye;
            cam.center = *center;
            cam.up = t.vec3_opt("up").value_or(default_up);
            if (glm::length(cam.center - cam.eye) == 0.0) t.fail("center", "camera.center must differ from camera.eye");
            if (glm::length(glm::cross(cam.center - cam.eye, cam.up)) == 0.0)
                t.fail(t.has("up") ? "up" : "center", "camera.up must not be parallel to the view direction");
        }
        cam.fov_y_degrees = t.real_or("fov_y", 30.0, 0.0, 180.0, true, true);
        if (auto vp = t.integers_opt("viewport", 2, 1, 65536)) cam.viewport = glm::ivec2((*vp)[0], (*vp)[1]);
        cam.near_plane = t.real_or("near", 1.0, 0.0, HUGE_VAL, true);
        cam.far_plane = t.real_or("far", 10000.0, 0.0, HUGE_VAL, true);
        if (!(cam.far_plane > cam.near_plane)) t.fail("far", "camera.far must be greater than camera.near");
        // Lifted by the preparation pass (prepare.h), which runs the pipeline.
        ScenePreparation& p = scene.preparation;
        p.ground_clearance = t.real_opt("ground_clearance", 0.0, 1e12);
        if (p.ground_clearance) p.ground_clearance_where = t.where("ground_clearance");
        t.finish();
        scene.camera = cam;
    }

    // ---- [domain] -----------------------------------------------------------------
    const std::vector<std::string> kDomainKeys = {
        "plane", "patches", "x", "y", "z", "follow_camera", "patch_size", "heightmap", "nodata",
        "nodata_policy", "fill_value", "scale_xy", "scale_z", "texcoord_offset", "normal_map",
        "normal_map_spacing", "normal_map_height_scale"};

    // First pass: the grid's shape (the camera may be needed for follow_camera, so the
    // coordinates are filled in later by place_grid).
    void read_domain_shape(TableReader& t) {
        TerrainGrid g;
        g.plane = t.choice("plane", {"xy", "xz"}) == "xy" ? GroundPlane::xy : GroundPlane::xz;
        auto patches = t.integers_opt("patches", 2, 1, 1 << 20);
        if (!patches) t.missing("patches");
        g.patches_u = static_cast<int>((*patches)[0]);
        g.patches_v = static_cast<int>((*patches)[1]);
        // Per-patch state is allocated before the budget can be estimated from the levels.
        if (static_cast<std::uint64_t>(g.patches_u) * static_cast<std::uint64_t>(g.patches_v) > (1u << 26))
            t.fail("patches", "domain.patches asks for " +
                                  std::to_string(static_cast<std::uint64_t>(g.patches_u) * g.patches_v) +
                                  " patches; at most 67108864 (2^26) are supported");
        g.follow_camera = t.boolean_opt("follow_camera").value_or(false);
        const std::string second = g.plane == GroundPlane::xy ? "y" : "z";
        const std::string wrong_axis = g.plane == GroundPlane::xy ? "z" : "y";
        if (t.has(wrong_axis))
            t.fail(wrong_axis, "domain." + wrong_axis + " is not an axis of plane " +
                                   (g.plane == GroundPlane::xy ? "xy" : "xz") + " (use domain." + second + ")");
        if (g.follow_camera) {
            g.patch_size = t.real("patch_size", 0.0, HUGE_VAL, true, false, "follow_camera needs patch_size");
            if (t.has("x")) t.fail("x", "domain.x is not used with follow_camera (the grid follows the camera)");
            if (t.has(second)) t.fail(second, "domain." + second + " is not used with follow_camera");
        } else {
            auto x = t.vec2_opt("x");
            if (!x) t.missing("x", "the grid's extent along x");
            auto v = t.vec2_opt(second);
            if (!v) t.missing(second, "the grid's extent along " + second);
            if ((*x)[0] == (*x)[1]) t.fail("x", "domain.x must span a non-empty range");
            if ((*v)[0] == (*v)[1]) t.fail(second, "domain." + second + " must span a non-empty range");
            g.extent_u = *x;
            g.extent_v = *v;
            if (t.has("patch_size")) t.fail("patch_size", "domain.patch_size is only used with follow_camera = true");
        }
        scene.grid = g;
    }

    void place_grid(TableReader& t) {
        TerrainGrid& g = *scene.grid;
        g.u_coords.resize(static_cast<std::size_t>(g.patches_u) + 1);
        g.v_coords.resize(static_cast<std::size_t>(g.patches_v) + 1);
        if (g.follow_camera) {
            if (!scene.camera) t.fail("follow_camera", "domain.follow_camera needs a [camera]");
            // Lab 4: the grid is centred on the camera and moves only by whole patches, so
            // its vertices always sit on multiples of patch_size.
            const double s = g.patch_size;
            const glm::dvec3 eye = scene.camera->eye;
            const double cam_v = g.plane == GroundPlane::xy ? eye.y : eye.z;
            const double ku = std::floor(eye.x / s + 0.5) - std::floor(g.patches_u / 2.0);
            for (int i = 0; i <= g.patches_u; ++i) g.u_coords[i] = (ku + i) * s;
            if (g.plane == GroundPlane::xy) {
                const double kv = std::floor(cam_v / s + 0.5) - std::floor(g.patches_v / 2.0);
                for (int j = 0; j <= g.patches_v; ++j) g.v_coords[j] = (kv + j) * s;
            } else {
                // z descending, so that u = +x, v = -z and ccw triangles face +y.
                const double kv = std::floor(cam_v / s + 0.5) + std::floor(g.patches_v / 2.0);
                for (int j = 0; j <= g.patches_v; ++j) g.v_coords[j] = (kv - j) * s;
            }
            g.extent_u = {g.u_coords.front(), g.u_coords.back()};
            g.extent_v = {g.v_coords.front(), g.v_coords.back()};
        } else {
            for (int i = 0; i <= g.patches_u; ++i)
                g.u_coords[i] = i == g.patches_u ? g.extent_u.y
                                                 : g.extent_u.x + (g.extent_u.y - g.extent_u.x) * i / g.patches_u;
            for (int j = 0; j <= g.patches_v; ++j)
                g.v_coords[j] = j == g.patches_v ? g.extent_v.y
                                                 : g.extent_v.x + (g.extent_v.y - g.extent_v.x) * j / g.patches_v;
        }
    }

    // Second pass: the height map and scales, once the models are known.
    void read_domain_data(TableReader& t) {
        TerrainGrid& g = *scene.grid;
        const EvaluationModel em = scene.evaluation.model;
        const bool thesis_control = scene.control && scene.control->model == ControlModel::thesis;
        const bool uses_scale_xy = em == EvaluationModel::thesis || em == EvaluationModel::lab4 || thesis_control;
        if (uses_scale_xy)
            g.scale_xy = t.real("scale_xy", 0.0, HUGE_VAL, true, false,
                                std::string("evaluation model ") + to_string(em) + " maps world to texture by it");
        else if (t.has("scale_xy"))
            t.fail("scale_xy", em == EvaluationModel::geomipmap
                                   ? "domain.scale_xy is not used by evaluation model geomipmap (the height map's samples "
                                     "span the extent domain.x and domain.y)"
                                   : "domain.scale_xy is not used by evaluation model cosc422 (its texture coordinates "
                                     "come from the extent domain.x and domain.z)");
        g.scale_z = t.real("scale_z", -HUGE_VAL, HUGE_VAL, false, false, "the height scale");
        if (auto off = t.vec2_opt("texcoord_offset")) {
            if (em != EvaluationModel::lab4) t.fail("texcoord_offset", "domain.texcoord_offset is used by evaluation model lab4 only");
            g.texcoord_offset = *off;
        }

        HeightFieldOptions options;
        if (auto policy = t.choice_opt("nodata_policy", {"error", "fill_neighbour_mean", "fill_constant"}))
            options.nodata_policy = *policy == "error"                 ? NodataPolicy::error
                                    : *policy == "fill_neighbour_mean" ? NodataPolicy::fill_neighbour_mean
                                                                       : NodataPolicy::fill_constant;
        options.nodata_value = t.real_opt("nodata");
        if (auto fill = t.real_opt("fill_value")) {
            if (options.nodata_policy != NodataPolicy::fill_constant)
                t.fail("fill_value", "domain.fill_value is used with nodata_policy = \"fill_constant\" only");
            options.fill_value = *fill;
        }
        g.heightmap_path = resolve(t.string("heightmap", "the terrain's height map"));
        g.heightmap = load_file(t, "heightmap", "cannot load height map", [&] {
            return std::make_shared<const HeightField>(load_height_field(g.heightmap_path, options));
        });

        if (em == EvaluationModel::geomipmap) {
            // 17 x 17 samples a patch, borders shared: the map has 16 nu + 1 x 16 nv + 1.
            const Texture& h = g.heightmap->texture;
            if (h.width() != 16 * g.patches_u + 1 || h.height() != 16 * g.patches_v + 1)
                t.fail("patches", "evaluation model geomipmap cuts the height map into patches of 17 x 17 samples "
                                  "sharing their borders: " + std::to_string(g.patches_u) + " x " +
                                  std::to_string(g.patches_v) + " patches need " + std::to_string(16 * g.patches_u + 1) +
                                  " x " + std::to_string(16 * g.patches_v + 1) + " samples, and " + g.heightmap_path +
                                  " has " + std::to_string(h.width()) + " x " + std::to_string(h.height()));
        }

        const bool needs_normal_map =
            (thesis_control && (scene.control->thesis.factor == ThesisFactor::normal ||
                                scene.control->thesis.factor == ThesisFactor::all)) ||
            (scene.geometry && scene.geometry->normals == GeometryNormals::normal_map);
        const auto normal_map_file = t.string_opt("normal_map");
        const auto spacing = t.real_opt("normal_map_spacing", 0.0, HUGE_VAL, true);
        const auto height_scale = t.real_opt("normal_map_height_scale");
        if (!needs_normal_map) {
            for (const char* k : {"normal_map", "normal_map_spacing", "normal_map_height_scale"})
                if (t.has(k))
                    t.fail(k, std::string("domain.") + k +
                                  " is not used: no stage reads a normal map (thesis normal/all factor, "
                                  "geometry normals = \"normal_map\")");
        } else if (normal_map_file) {
            if (spacing || height_scale)
                t.fail(spacing ? "normal_map_spacing" : "normal_map_height_scale",
                       "normal_map_spacing / normal_map_height_scale generate a normal map; not used with domain.normal_map");
            const std::string path = resolve(*normal_map_file);
            auto texture = load_file(t, "normal_map", "cannot load normal map", [&] {
                return std::make_shared<const Texture>(scene_detail::load_scene_texture(path, scene));
            });
            if (texture->channels() < 3)
                t.fail("normal_map", "normal map " + path + " has " + std::to_string(texture->channels()) +
                                         " channel(s); it needs RGB");
            g.normal_map = texture;
        } else {
            const Texture& h = g.heightmap->texture;
            const double d = spacing.value_or(g.scale_xy / h.width());
            const double hs = height_scale.value_or(g.scale_z);
            g.normal_map = std::make_shared<const Texture>(thesis_normal_map(h, d, hs));
        }
    }

    // ---- [mesh] / [[mesh]] --------------------------------------------------------
    void read_meshes(const toml::node& node) {
        std::vector<std::pair<const toml::table*, std::string>> tables;
        if (node.is_table()) {
            tables.push_back({node.as_table(), "mesh"});
        } else if (const toml::array* a = node.as_array()) {
            if (a->empty()) throw Error("mesh must name at least one mesh", where_at(file, node.source(), "mesh"));
            for (std::size_t i = 0; i < a->size(); ++i) {
                const toml::node& e = *a->get(i);
                const std::string key = "mesh[" + std::to_string(i) + "]";
                if (!e.is_table()) throw Error(key + " must be a table, not " + std::string(scene_detail::type_name(e)),
                                               where_at(file, e.source(), key));
                tables.push_back({e.as_table(), key});
            }
        } else {
            throw Error("mesh must be a table or an array of tables, not " + std::string(scene_detail::type_name(node)),
                        where_at(file, node.source(), "mesh"));
        }
        TriangleMeshes meshes;
        bool any_without_uv = false, any_with_uv = false;
        for (auto& [table, name] : tables) {
            TableReader t(file, *table, name, {"path", "translate", "scale"});
            const std::string path = resolve(t.string("path", "the mesh file"));
            const glm::dvec3 translate = t.vec3_opt("translate").value_or(glm::dvec3(0.0));
            const double scale = t.real_or("scale", 1.0, 0.0, HUGE_VAL, true);
            t.finish();
            const bool has_uv = read_one_mesh(t, path, translate, scale, meshes);
            (has_uv ? any_with_uv : any_without_uv) = true;
        }
        if (!any_with_uv || any_without_uv) meshes.uvs.clear();  // uv only when every mesh has it
        scene.meshes = std::move(meshes);
    }

    bool read_one_mesh(const TableReader& t, const std::string& path, const glm::dvec3& translate, double scale,
                       TriangleMeshes& out) {
        std::error_code ec;
        // Anything else that is not a mesh file (a directory, a FIFO) the reader names.
        if (!fs::exists(path, ec)) throw Error("cannot read mesh " + path + ": no such file", t.where("path"));
        // The reader `tessref check` uses (it refuses hostile files, naming line or byte).
        IndexedMesh file;
        try {
            MeshFileOptions read_options;
            read_options.vertex_attributes = true;
            file = read_mesh_file(path, read_options);
        } catch (const Error& e) {
            throw Error("cannot read mesh: " + e.message(), t.where("path"));
        }
        for (std::size_t f = 0; f < file.face_count(); ++f) {
            const auto face = file.face(f);
            if (face.size() != 3)
                throw Error("mesh " + path + " is not a triangle mesh: face " + std::to_string(f) + " has " +
                                std::to_string(face.size()) + " vertices (PN triangles need triangles)",
                            t.where("path"));
            if (face[0] == face[1] || face[1] == face[2] || face[0] == face[2])
                throw Error("mesh " + path + ": face " + std::to_string(f) + " repeats a vertex (PN triangles need three)",
                            t.where("path"));
        }
        // OpenMesh's half-edge mesh: it computes the vertex normals a file lacks.
        const mesh_detail::HalfEdgeImport imported = mesh_detail::import_half_edge_mesh(file, true);
        const mesh_detail::HalfEdgeMesh& mesh = imported.mesh;
        const bool has_uv = !file.uvs.empty();
        const std::uint32_t base = static_cast<std::uint32_t>(out.positions.size());
        for (auto vh : mesh.vertices()) {
            const auto p = mesh.point(vh);
            const auto n = mesh.normal(vh);
            out.positions.push_back(glm::dvec3(p[0], p[1], p[2]) * scale + translate);
            out.normals.push_back(glm::dvec3(n[0], n[1], n[2]));
            if (has_uv) {
                const auto uv = mesh.texcoord2D(vh);
                out.uvs.push_back(glm::dvec2(uv[0], uv[1]));
            } else {
                out.uvs.push_back(glm::dvec2(0.0));
            }
        }
        for (auto fh : mesh.faces()) {
            std::array<std::uint32_t, 3> tri{};
            int k = 0;
            for (auto vh : mesh.fv_range(fh)) tri[k++] = base + static_cast<std::uint32_t>(vh.idx());
            out.triangles.push_back(tri);
        }
        out.paths.push_back(path);
        return has_uv;
    }

    // ---- [generator] --------------------------------------------------------------
    void read_generator(const toml::table* table) {
        // Defaults: the layout of the evaluation shader of the model.
        TessSettings s;
        switch (scene.evaluation.model) {
            case EvaluationModel::thesis: s = {Domain::quads, Spacing::fractional_odd, Winding::ccw, false}; break;
            case EvaluationModel::cosc422: s = {Domain::quads, Spacing::equal, Winding::ccw, false}; break;
            case EvaluationModel::lab4: s = {Domain::quads, Spacing::equal, Winding::ccw, false}; break;
            case EvaluationModel::pn: s = {Domain::triangles, Spacing::fractional_odd, Winding::ccw, false}; break;
            case EvaluationModel::geomipmap: s = {Domain::quads, Spacing::equal, Winding::ccw, false}; break;
        }
        if (table && scene.evaluation.model == EvaluationModel::geomipmap)
            throw Error("a geomipmapped terrain has no primitive generator to configure: remove [generator]",
                        Where::at_key(file, "generator"));
        if (table) {
            TableReader t(file, *table, "generator", {"domain", "spacing", "winding"});
            if (auto d = t.choice_opt("domain", {"quads", "triangles", "isolines"})) {
                if (*d == "isolines") t.fail("domain", "generator.domain = \"isolines\" makes lines, not a surface");
                s.domain = *parse_domain(*d);
                const Domain needed = scene.meshes ? Domain::triangles : Domain::quads;
                if (s.domain != needed)
                    t.fail("domain", std::string("generator.domain must be \"") + std::string(to_string(needed)) +
                                         "\" for " + (scene.meshes ? "triangle meshes" : "a terrain grid of quad patches"));
            }
            if (auto sp = t.choice_opt("spacing", {"equal", "fractional_odd", "fractional_even"})) s.spacing = *parse_spacing(*sp);
            if (auto w = t.choice_opt("winding", {"ccw", "cw"})) s.winding = *parse_winding(*w);
            t.finish();
        }
        scene.generator = s;
    }

    // ---- [control] ----------------------------------------------------------------
    void read_control(const toml::table& table) {
        TableReader t(file, table, "control",
                      {"model", "level", "factor", "tessellation_map", "weights", "distance_limit", "distance_divisor",
                       "normal_threshold", "space", "first_zone_end", "zone_growth", "max_level", "min_level",
                       "edge_rule", "pixels_per_edge", "flat_edges_at_level_1"});
        ControlStage c;
        const std::string model = t.choice("model", {"constant", "thesis", "cosc422", "lab4", "pn"}, "the control model");
        if (model == "constant") {
            c.model = ControlModel::constant;
            c.constant.level = t.real("level", -1e6, 1e6, false, false, "the constant level");
        } else if (model == "thesis") {
            c.model = ControlModel::thesis;
            const std::string factor = t.choice("factor", {"distance", "tessellation_map", "normal", "all"},
                                                "which factor drives the levels");
            c.thesis.factor = factor == "distance"           ? ThesisFactor::distance
                              : factor == "tessellation_map" ? ThesisFactor::tessellation_map
                              : factor == "normal"           ? ThesisFactor::normal
                                                             : ThesisFactor::all;
            c.thesis.tessellationLevel = t.real("level", -1e6, 1e6, false, false, "tessellationLevel, the thesis's userDecidedLevel");
            c.thesis.distance.limit = t.real_or("distance_limit", 50.0, 0.0, HUGE_VAL, true);
            c.thesis.distance.divisor = t.real_or("distance_divisor", 10.0, 0.0, HUGE_VAL, true);
            c.thesis.normalAngleThreshold = t.real_or("normal_threshold", 0.90, 0.0, 4.0 * M_PI);
            if (c.thesis.factor == ThesisFactor::all) {
                if (const toml::table* w = t.table_opt("weights")) {
                    TableReader wt(file, *w, "control.weights", {"constant", "normal", "texture", "distance"});
                    c.thesis.weights.constant = wt.real_or("constant", 1.0, 0.0, 1e6);
                    c.thesis.weights.normal = wt.real_or("normal", 5.0, 0.0, 1e6);
                    c.thesis.weights.texture = wt.real_or("texture", 5.0, 0.0, 1e6);
                    c.thesis.weights.distance = wt.real_or("distance", 5.0, 0.0, 1e6);
                    wt.finish();
                    const auto& ww = c.thesis.weights;
                    if (!(ww.constant + ww.normal + ww.texture + ww.distance > 0.0))
                        t.fail("weights", "control.weights must not all be 0 (formula (2) divides by their sum)");
                }
            }
            const bool map_needed = c.thesis.factor == ThesisFactor::tessellation_map ||
                                    (c.thesis.factor == ThesisFactor::all && c.thesis.weights.texture != 0.0);
            const bool map_allowed = c.thesis.factor == ThesisFactor::tessellation_map || c.thesis.factor == ThesisFactor::all;
            if (map_allowed && t.has("tessellation_map")) {
                c.tessellation_map_path = resolve(t.string("tessellation_map"));
                const std::string path = c.tessellation_map_path;
                c.tessellation_map = load_file(t, "tessellation_map", "cannot load tessellation map", [&] {
                    return std::make_shared<const Texture>(scene_detail::load_scene_texture(path, scene));
                });
            } else if (map_needed) {
                t.missing("tessellation_map", c.thesis.factor == ThesisFactor::all
                                                  ? "formula (2) reads it unless weights.texture = 0"
                                                  : "the tessellation-map factor reads it");
            }
            t.finish(std::string("by thesis factor ") + factor);
        } else if (model == "cosc422") {
            c.model = ControlModel::cosc422;
            c.cosc422 = t.choice("space", {"world", "eye"}, "world or eye space z") == "world" ? Cosc422Space::world
                                                                                                      : Cosc422Space::eye;
        } else if (model == "lab4") {
            c.model = ControlModel::lab4;
            auto power_of_two = [&](const char* k, double fallback) {
                const double v = t.real_or(k, fallback, 1.0, 64.0);
                int e = 0;
                if (std::frexp(v, &e) != 0.5) t.fail(k, std::string("control.") + k + " must be a power of two in [1, 64]");
                return v;
            };
            c.lab4.firstZoneEnd = t.real_or("first_zone_end", 50.0, 0.0, HUGE_VAL, true);
            c.lab4.zoneGrowth = t.real_or("zone_growth", 2.0, 1.0, HUGE_VAL, true);
            c.lab4.maxLevel = power_of_two("max_level", 64.0);
            c.lab4.minLevel = power_of_two("min_level", 1.0);
            if (c.lab4.minLevel > c.lab4.maxLevel) t.fail("min_level", "control.min_level must not exceed control.max_level");
            if (auto rule = t.choice_opt("edge_rule", {"lower", "higher"}))
                c.lab4.edgeRule = *rule == "lower" ? Lab4EdgeRule::lower : Lab4EdgeRule::higher;
        } else {
            c.model = ControlModel::pn;
            c.pn.fPixelsPerEdge = t.real_or("pixels_per_edge", 4.0, 0.0, HUGE_VAL, true);
            c.pn.minLevel = t.real_or("min_level", 1.0, 0.0, 64.0);
            c.pn.maxLevel = t.real_or("max_level", 32.0, 0.0, 64.0);
            if (c.pn.minLevel > c.pn.maxLevel) t.fail("min_level", "control.min_level must not exceed control.max_level");
            c.pn.flatEdgesAtLevel1 = t.boolean_opt("flat_edges_at_level_1").value_or(true);
        }
        t.finish("by control model " + model);
        scene.control = c;
    }

    // ---- [evaluation] -------------------------------------------------------------
    void read_evaluation(const toml::table& table) {
        TableReader t(file, table, "evaluation",
                      {"model", "influence", "normal", "watertight_edges", "error_bound_px", "adapt", "tween", "level"});
        const std::string model =
            t.choice("model", {"thesis", "cosc422", "lab4", "pn", "geomipmap"}, "the evaluation model");
        EvaluationStage e;
        e.model = model == "thesis"      ? EvaluationModel::thesis
                  : model == "cosc422"   ? EvaluationModel::cosc422
                  : model == "lab4"      ? EvaluationModel::lab4
                  : model == "geomipmap" ? EvaluationModel::geomipmap
                                         : EvaluationModel::pn;
        if (e.model == EvaluationModel::geomipmap) {
            e.geomipmap.error_bound_px = t.real_or("error_bound_px", 1.0, 0.0, 1e6);
            e.geomipmap.adapt = t.boolean_opt("adapt").value_or(true);
            e.geomipmap.tween = t.real_opt("tween", 0.0, 1.0);
            if (auto level = t.integer_opt("level", 0, geomip::kLevels - 1)) {
                if (t.has("error_bound_px"))
                    t.fail("level", "evaluation.level forces every patch's level: error_bound_px does not apply with it");
                e.geomipmap.level = static_cast<int>(*level);
            }
        }
        if (e.model == EvaluationModel::pn) {
            e.pn.fInfluence = t.real_or("influence", 0.75, -1e6, 1e6);
            if (auto n = t.choice_opt("normal", {"quadratic", "linear"}))
                e.pn.normal = *n == "quadratic" ? PnNormal::quadratic : PnNormal::linear;
            e.pn.watertightEdges = t.boolean_opt("watertight_edges").value_or(true);
        }
        t.finish("by evaluation model " + model);
        scene.evaluation = e;
    }

    // ---- [geometry] ---------------------------------------------------------------
    void read_geometry(const toml::table& table) {
        TableReader t(file, table, "geometry", {"normals"});
        const std::string n = t.choice("normals", {"face", "normal_map", "height_field", "smooth"}, "which normals");
        GeometryStage g;
        g.normals = n == "face"           ? GeometryNormals::face
                    : n == "normal_map"   ? GeometryNormals::normal_map
                    : n == "height_field" ? GeometryNormals::height_field
                                          : GeometryNormals::smooth;
        t.finish();
        scene.geometry = g;
    }

    // ---- [shaders] ----------------------------------------------------------------
    // Only names and paths: `tessref gl` reads the files, the CPU commands never need them.
    void read_shaders(const toml::table& table) {
        static const std::vector<std::string> keys = {"vertex", "tess_control", "tess_evaluation", "geometry",
                                                      "fragment"};
        TableReader t(file, table, "shaders", keys);
        for (const std::string& k : keys) {
            const auto path = t.string_opt(k);
            if (!path) continue;
            if (path->empty()) t.fail(k, "shaders." + k + " must name a GLSL file");
            scene.shaders.push_back(
                StageShader{*shader_stage_from_string(k), resolve(*path), "[shaders] " + k + " = \"" + *path + "\"",
                            t.where(k)});
        }
        t.finish();
    }

    // ---- [culling] ----------------------------------------------------------------
    // After the domain's data: a PVS is checked against the terrain it was built for.
    void read_culling(const toml::table& table) {
        TableReader t(file, table, "culling", {"frustum", "pvs"});
        if (scene.evaluation.model != EvaluationModel::geomipmap)
            throw Error("[culling] culls the patches of a geomipmapped terrain (evaluation model geomipmap); a "
                        "tessellated scene has no patch culling",
                        t.where_table());
        CullingStage c;
        c.frustum = t.boolean_opt("frustum").value_or(true);
        if (const auto path = t.string_opt("pvs")) {
            if (path->empty()) t.fail("pvs", "culling.pvs must name a PVS file (made by tessref pvs SCENE -o FILE)");
            c.pvs_path = resolve(*path);
            geomip::Pvs pvs = load_file(t, "pvs", "cannot load the PVS file " + c.pvs_path,
                                        [&] { return geomip::read_pvs(c.pvs_path); });
            const GeomipTerrain terrain = geomip_terrain(scene);
            if (pvs.patches_x != terrain.map.patches_x() || pvs.patches_y != terrain.map.patches_y() ||
                pvs.terrain_id != geomip::terrain_identity(terrain.map, terrain.settings))
                t.fail("pvs", "the PVS file " + c.pvs_path +
                                  " was built for another terrain (its height map, extent or scale_z differ): "
                                  "rebuild it with tessref pvs");
            c.pvs = std::make_shared<const geomip::Pvs>(std::move(pvs));
        }
        t.finish();
        scene.culling = std::move(c);
    }

    // ---- [limits] -----------------------------------------------------------------
    void read_limits(const toml::table& table) {
        TableReader t(file, table, "limits", {"max_triangles"});
        if (auto m = t.integer_opt("max_triangles", 1, std::int64_t(1) << 40)) {
            scene.max_triangles = static_cast<std::uint64_t>(*m);
            scene.max_triangles_where = t.where("max_triangles");
        }
        t.finish();
    }

    // ---- the whole file -----------------------------------------------------------
    void load(const std::string& text) {
        toml::table root;
        try {
            root = toml::parse(text, file);
        } catch (const toml::parse_error& e) {
            Where w;
            w.file = file;
            w.line = static_cast<int>(e.source().begin.line);
            w.column = static_cast<int>(e.source().begin.column);
            throw Error("malformed TOML: " + std::string(e.description()), w);
        }
        scene.file = file;
        scene.max_triangles_where = Where::at_key(file, "limits.max_triangles");

        for (auto&& [k, n] : root) {
            const std::string ks(k.str());
            if (std::find(kTopLevel.begin(), kTopLevel.end(), ks) == kTopLevel.end()) {
                const bool looks_like_stage = n.is_table() || n.is_array();
                throw Error((looks_like_stage ? "unknown stage or table [" + ks + "]" : "unknown top-level key " + ks) +
                                " (known: scene, domain, mesh, camera, generator, control, evaluation, geometry, "
                                "shading, shaders, limits, culling)",
                            where_at(file, k.source(), ks));
            }
            if (ks != "mesh" && !n.is_table())
                throw Error(ks + " must be a table, not " + std::string(scene_detail::type_name(n)),
                            where_at(file, n.source(), ks));
        }
        read_scene(root);
        if (const toml::node* l = root.get("limits")) read_limits(*l->as_table());
        if (const toml::node* sh = root.get("shaders")) read_shaders(*sh->as_table());

        const toml::node* domain = root.get("domain");
        const toml::node* mesh = root.get("mesh");
        if (domain && mesh)
            throw Error("a scene has either [domain] (terrain) or [mesh] (triangle meshes), not both",
                        where_at(file, mesh->source(), "mesh"));
        if (!domain && !mesh) throw Error("missing [domain] (a terrain grid) or [mesh] (triangle meshes)", Where::at_key(file, "domain"));

        const toml::node* eval = root.get("evaluation");
        if (!eval)
            throw Error("missing [evaluation]: without an evaluation stage GL does not tessellate",
                        Where::at_key(file, "evaluation"));
        read_evaluation(*eval->as_table());
        if (const toml::node* c = root.get("control")) read_control(*c->as_table());
        if (const toml::node* g = root.get("geometry")) read_geometry(*g->as_table());

        std::optional<TableReader> domain_reader;
        if (domain) {
            domain_reader.emplace(file, *domain->as_table(), "domain", kDomainKeys);
            read_domain_shape(*domain_reader);
        } else {
            read_meshes(*mesh);
        }
        const glm::dvec3 default_up = scene.grid && scene.grid->plane == GroundPlane::xy ? glm::dvec3(0, 0, 1)
                                                                                          : glm::dvec3(0, 1, 0);
        if (const toml::node* c = root.get("camera")) read_camera(*c->as_table(), default_up);
        read_generator(root.get("generator") ? root.get("generator")->as_table() : nullptr);
        check_combination(root);
        if (domain) {
            place_grid(*domain_reader);
            read_domain_data(*domain_reader);
            domain_reader->finish();
        }
        if (const toml::node* c = root.get("culling")) read_culling(*c->as_table());
        // A grid alone beyond the budget is refused before anything is computed (each
        // patch emits at least one triangle unless culled).
        const std::uint64_t min_triangles = static_cast<std::uint64_t>(scene.patch_count()) *
                                            (scene.generator.domain == Domain::quads ? 2u : 1u);
        if (min_triangles > scene.max_triangles) {
            Where w = domain ? domain_reader->where("patches") : scene.max_triangles_where;
            throw Error("the scene has " + std::to_string(scene.patch_count()) + " patches, at least " +
                            std::to_string(min_triangles) + " triangles, more than limits.max_triangles = " +
                            std::to_string(scene.max_triangles),
                        w);
        }
        if (scene.preparation.ground_clearance && !(scene.grid && scene.grid->heightmap))
            throw Error("camera.ground_clearance keeps the eye above a terrain: the scene needs a [domain] with a "
                        "height map",
                        scene.preparation.ground_clearance_where);
        // Last: the scene's other errors come first, its textures are the slowest to load,
        // and COSC422's default heightMap is the grid's.
        const toml::node* shading = root.get("shading");
        scene.shading = scene_detail::read_shading(file, shading ? shading->as_table() : nullptr, scene,
                                                   [this](const std::string& p) { return resolve(p); });
        set_camera_uniforms(scene);
    }

    // Models, domain and camera must fit together.
    void check_combination(const toml::table& root) {
        auto where_of = [&](const char* table, const char* key) {
            const toml::node* t = root.get(table);
            if (t && t->is_table())
                if (const toml::node* n = t->as_table()->get(key)) return where_at(file, n->source(), std::string(table) + "." + key);
            return Where::at_key(file, std::string(table) + "." + key);
        };
        const EvaluationModel em = scene.evaluation.model;
        const bool terrain = scene.grid.has_value();
        const auto plane = terrain ? scene.grid->plane : GroundPlane::xy;
        auto need_plane = [&](GroundPlane p, const char* table, const char* what) {
            if (!terrain)
                throw Error(std::string(what) + " needs a terrain [domain], not [mesh]", where_of(table, "model"));
            if (plane != p)
                throw Error(std::string(what) + " needs domain.plane = \"" + (p == GroundPlane::xy ? "xy" : "xz") + "\"",
                            where_of(table, "model"));
        };
        switch (em) {
            case EvaluationModel::thesis: need_plane(GroundPlane::xy, "evaluation", "evaluation model thesis (z up)"); break;
            case EvaluationModel::cosc422: need_plane(GroundPlane::xz, "evaluation", "evaluation model cosc422 (y up)"); break;
            case EvaluationModel::lab4: need_plane(GroundPlane::xz, "evaluation", "evaluation model lab4 (y up)"); break;
            case EvaluationModel::pn:
                if (terrain) throw Error("evaluation model pn needs triangle meshes ([mesh]), not a terrain [domain]",
                                         where_of("evaluation", "model"));
                break;
            case EvaluationModel::geomipmap:
                need_plane(GroundPlane::xy, "evaluation", "evaluation model geomipmap (z up)");
                if (scene.control)
                    throw Error("evaluation model geomipmap chooses its levels itself (evaluation.error_bound_px, "
                                "evaluation.tween): remove [control]",
                                where_of("control", "model"));
                if (!scene.camera)
                    throw Error("evaluation model geomipmap measures each level's screen error with the camera: "
                                "add a [camera]",
                                where_of("evaluation", "model"));
                if (scene.geometry && scene.geometry->normals != GeometryNormals::face &&
                    scene.geometry->normals != GeometryNormals::smooth)
                    throw Error("evaluation model geomipmap takes geometry normals = \"face\" or \"smooth\"",
                                where_of("geometry", "normals"));
                break;
        }
        if (scene.control) {
            const ControlStage& c = *scene.control;
            switch (c.model) {
                case ControlModel::constant: break;
                case ControlModel::thesis: need_plane(GroundPlane::xy, "control", "control model thesis (z up)"); break;
                case ControlModel::cosc422: need_plane(GroundPlane::xz, "control", "control model cosc422 (y up)"); break;
                case ControlModel::lab4: need_plane(GroundPlane::xz, "control", "control model lab4 (y up)"); break;
                case ControlModel::pn:
                    if (terrain) throw Error("control model pn needs triangle meshes ([mesh])", where_of("control", "model"));
                    break;
            }
            const bool needs_camera = (c.model == ControlModel::thesis && (c.thesis.factor == ThesisFactor::distance ||
                                                                          c.thesis.factor == ThesisFactor::all)) ||
                                      (c.model == ControlModel::cosc422 && c.cosc422 == Cosc422Space::eye) ||
                                      c.model == ControlModel::lab4 || c.model == ControlModel::pn;
            if (needs_camera && !scene.camera)
                throw Error(std::string("control model ") + to_string(c.model) + " reads the camera: add a [camera]",
                            where_of("control", "model"));
        }
        if (em == EvaluationModel::lab4 && (!scene.control || scene.control->model != ControlModel::lab4))
            throw Error("evaluation model lab4 needs control model lab4 (it reads the mip levels the control stage "
                        "passes on)",
                        where_of("evaluation", "model"));
        if (scene.geometry) {
            const GeometryNormals n = scene.geometry->normals;
            if (n == GeometryNormals::normal_map && !(terrain && plane == GroundPlane::xy))
                throw Error("geometry normals = \"normal_map\" needs a terrain on plane xy (the thesis's z-up normal map)",
                            where_of("geometry", "normals"));
            if (n == GeometryNormals::height_field && !terrain)
                throw Error("geometry normals = \"height_field\" needs a terrain [domain] with a height map",
                            where_of("geometry", "normals"));
        }
    }
};

std::string read_text_file(const std::string& path) {
    std::error_code ec;
    if (!fs::exists(path, ec)) throw Error("scene file not found", Where::in_file(path));
    if (fs::is_directory(path, ec)) throw Error("scene path is a directory", Where::in_file(path));
    std::ifstream in(path, std::ios::binary);
    if (!in) throw Error("cannot open scene file", Where::in_file(path));
    std::ostringstream os;
    os << in.rdbuf();
    if (in.bad()) throw Error("cannot read scene file", Where::in_file(path));
    return os.str();
}

}  // namespace

Scene parse_scene_from_string(const std::string& toml_text, const std::string& path) {
    Loader loader;
    loader.file = path;
    loader.base_dir = fs::path(path).parent_path();
    loader.load(toml_text);
    return std::move(loader.scene);
}

Scene parse_scene(const std::string& path) { return parse_scene_from_string(read_text_file(path), path); }

}  // namespace tessref
