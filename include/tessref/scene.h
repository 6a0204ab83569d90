// tessref/scene.h — scenes: the TOML file that names the stages of one pipeline run.
//
// A scene names only the stages it uses; a stage it does not name is not run and costs
// nothing. parse_scene() parses and validates it, loads every image and mesh it names, and
// throws tessref::Error naming the file, line, column and key of the first problem; it runs
// no stage. What a scene asks to be computed from its own terrain (the camera's ground
// clearance, a light map) is done after it by the preparation pass, prepare.h, whose
// load_scene() is the two together. pipeline.h runs a scene.
//
// The file format (every table and key, defaults and ranges, with examples) is documented
// in one place: data/scenes/README.md. The structs below are what the loader makes of it.
// Each stage's parameters are the stage's own structs (control.h, evaluation.h), held in
// double; a stage of the pipeline converts them to its precision once.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/control.h"
#include "tessref/geomipmap.h"
#include "tessref/error.h"
#include "tessref/evaluation.h"
#include "tessref/heightfield.h"
#include "tessref/shading.h"
#include "tessref/tessellator.h"

namespace tessref {

// ---------------------------------------------------------------------------------------
// The parsed scene
// ---------------------------------------------------------------------------------------

enum class GroundPlane : std::uint8_t { xy, xz };
enum class ControlModel : std::uint8_t { constant, thesis, cosc422, lab4, pn };
// geomipmap: not a tessellation shader; geomipmapping with geomorphing (geomipmap.h) builds
// the terrain's meshes on the CPU, as the applications before hardware tessellation did.
enum class EvaluationModel : std::uint8_t { thesis, cosc422, lab4, pn, geomipmap };
enum class GeometryNormals : std::uint8_t { face, normal_map, height_field, smooth };

const char* to_string(ControlModel model);
const char* to_string(EvaluationModel model);
const char* to_string(GeometryNormals normals);

struct SceneCamera {
    glm::dvec3 eye{0.0, 0.0, 1.0};
    glm::dvec3 center{0.0};
    glm::dvec3 up{0.0, 0.0, 1.0};
    double fov_y_degrees = 30.0;
    glm::ivec2 viewport{1280, 800};
    double near_plane = 1.0;
    double far_plane = 10000.0;

    glm::dmat4 view() const;        // lookAt(eye, center, up)
    glm::dmat4 projection() const;  // perspective(fov_y, width / height, near, far), GL clip
    glm::dmat4 view_projection() const { return projection() * view(); }
};

// A terrain grid of nu x nv quad patches.
struct TerrainGrid {
    GroundPlane plane = GroundPlane::xy;
    int patches_u = 1;
    int patches_v = 1;
    // Corner coordinates along the two axes (nu + 1 and nv + 1 values), as the application
    // would put them in its vertex buffer (computed in double, used rounded to float on the
    // gpu path: both patches of an edge read the same entry).
    std::vector<double> u_coords;  // x
    std::vector<double> v_coords;  // y (plane xy) or z (plane xz)
    // Texture-coordinate extent of COSC422's mapping (the extent keys as given).
    glm::dvec2 extent_u{0.0, 1.0};
    glm::dvec2 extent_v{0.0, 1.0};
    bool follow_camera = false;
    double patch_size = 0.0;

    double scale_xy = 1.0;
    double scale_z = 1.0;
    glm::dvec2 texcoord_offset{0.0};
    std::string heightmap_path;
    std::shared_ptr<const HeightField> heightmap;
    std::shared_ptr<const Texture> normal_map;  // null unless a stage needs it

    std::size_t patch_count() const {
        return static_cast<std::size_t>(patches_u) * static_cast<std::size_t>(patches_v);
    }
    // The four corners of patch p on the ground plane (height 0), control.h layout.
    std::array<glm::dvec3, 4> corners(std::size_t patch) const;
};

// Triangle meshes for PN triangles: all meshes of the scene concatenated.
struct TriangleMeshes {
    std::vector<glm::dvec3> positions;  // translated and scaled
    std::vector<glm::dvec3> normals;    // per vertex, as in the file (or averaged)
    std::vector<glm::dvec2> uvs;        // per vertex; empty when a mesh has none
    std::vector<std::array<std::uint32_t, 3>> triangles;  // one patch each, ccw outside
    std::vector<std::string> paths;     // the files, in order
    std::size_t patch_count() const { return triangles.size(); }
};

// [control]: the model, and that model's own parameters (control.h); only the chosen
// model's member is meaningful.
struct ControlStage {
    ControlModel model = ControlModel::constant;
    ConstantControl<double> constant{};
    ThesisControlParams<double> thesis{};
    std::string tessellation_map_path;  // thesis: empty when none (the texture factor reads 0)
    std::shared_ptr<const Texture> tessellation_map;
    Cosc422Space cosc422 = Cosc422Space::world;
    Lab4ControlParams<double> lab4{};
    PnControlParams<double> pn{};
};

// [evaluation]: the model; the terrain models take their parameters from [domain].
struct EvaluationStage {
    EvaluationModel model = EvaluationModel::thesis;
    PnEvaluationParams<double> pn{};
    geomip::Params geomipmap{};
};

struct GeometryStage {
    GeometryNormals normals = GeometryNormals::smooth;
};

// [culling]: a geomipmapped terrain's patch culling (geomipmap.h, CULLING and PVS). Absent:
// every patch is drawn.
struct CullingStage {
    bool frustum = true;                   // the ground rectangle and the six planes
    std::string pvs_path;                  // empty: no PVS
    std::shared_ptr<const geomip::Pvs> pvs;
};

// [shaders]: one entry per stage named, in the order vertex .. fragment.
enum class ShaderStage : std::uint8_t { vertex, tess_control, tess_evaluation, geometry, fragment };
const char* to_string(ShaderStage stage);  // "vertex", "tess_control", ... ([shaders] keys)
// The long names and the short ones (vert, tesc, tese, geom, frag); nullopt for others.
std::optional<ShaderStage> shader_stage_from_string(const std::string& name);
struct StageShader {
    ShaderStage stage = ShaderStage::vertex;
    std::string path;    // the file; [shaders]: resolved against the scene file's directory
    std::string origin;  // how the user named it, as typed: [shaders] tess_evaluation = "x.tese"
    Where where;         // for errors: the scene key's place, or the flag
};

// What the preparation pass (prepare.h) computes from the scene's own terrain after the
// load: the loader reads the keys and checks them, and runs no stage.
struct ScenePreparation {
    // [camera] ground_clearance = d (lab 4's camera collision): the eye is lifted to the
    // tessellated surface under it plus d.
    std::optional<double> ground_clearance;
    Where ground_clearance_where;
    // [shading] model = "geomip_lightmap": the light its light map is computed from
    // (shading.geomip.lightMap, lightMapScale, lightMapOffset).
    std::optional<geomip::LightMapParams> light_map;
    bool done = false;  // prepare_scene() has run
};

struct Scene {
    std::string file;  // the scene file as given (used in error messages)
    std::string name;
    std::string description;

    std::optional<TerrainGrid> grid;       // exactly one of grid / meshes
    std::optional<TriangleMeshes> meshes;

    std::optional<SceneCamera> camera;
    TessSettings generator{};
    std::optional<ControlStage> control;   // absent: every level 1
    EvaluationStage evaluation{};
    std::optional<GeometryStage> geometry; // absent: evaluation normals or none
    std::optional<CullingStage> culling;   // [culling] (geomipmap only)
    RenderShading shading{};                   // [shading] (default: depth), textures loaded
    std::vector<StageShader> shaders;          // [shaders] (`tessref gl` only)
    std::uint64_t max_triangles = 50'000'000;
    Where max_triangles_where;  // where the budget was set (or the scene file): for errors
    ScenePreparation preparation;

    std::size_t patch_count() const;
};

// Parses, validates and loads a scene file (images and meshes included), running no stage:
// a scene that asks for preparation (ScenePreparation) needs prepare_scene() (prepare.h)
// before it is run; load_scene() there does both. Throws tessref::Error with Where{file,
// line, column, key} on any problem; errors from an image or mesh loader are re-thrown with
// the scene's place (the key that named the file) and the loader's message (which names the
// image) in what().
Scene parse_scene(const std::string& path);
// The same from TOML text; `path` names the text in errors and is the base of relative
// paths (it need not exist).
Scene parse_scene_from_string(const std::string& toml_text, const std::string& path);

// The shading uniforms that read the camera (lab 4 cameraPosition, PN and POM
// v3CameraPosition, depth near/far) set from scene.camera: the loader sets them, and the
// preparation pass again when it moves the camera. No camera: nothing changes.
void set_camera_uniforms(Scene& scene);

// A geomipmapped scene's height samples (mip 0, exactly) and their world placement, as
// run_pipeline() builds its terrain from them (and `tessref pvs` its PVS, the loader checks
// a PVS file against). Throws tessref::Error for a scene without a terrain grid.
struct GeomipTerrain {
    geomip::HeightSamples map;
    geomip::Settings settings;
};
GeomipTerrain geomip_terrain(const Scene& scene);

// ---------------------------------------------------------------------------------------
// Patch adjacency (for crack checks)
// ---------------------------------------------------------------------------------------

// One edge shared by two patches: outer level `edge_a` of patch_a and `edge_b` of patch_b
// (gl_TessLevelOuter indices, control.h's kQuadEdges / kTriangleEdges).
struct SharedEdge {
    std::uint32_t patch_a = 0;
    int edge_a = 0;
    std::uint32_t patch_b = 0;
    int edge_b = 0;
};
std::vector<SharedEdge> shared_edges(const Scene& scene);

}  // namespace tessref
