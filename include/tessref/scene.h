// tessref/scene.h — scenes (TOML) and the pipeline that runs them into a SurfaceMesh.
//
// A scene is a TOML file that names only the stages it uses; a stage it does not name is
// not run and costs nothing. load_scene() parses and validates it, loads every image and
// mesh it names, and throws tessref::Error naming the file, line, column and key of the
// first problem. run_pipeline() runs control -> primitive generator -> evaluation ->
// geometry over every patch and returns the tessellated surface.
//
// ======================================================================================
// SCHEMA (data/scenes/README.md has the same with examples). Paths are relative to the
// scene file. Numbers may be written as integers where a real is expected. Unknown keys,
// unknown tables and wrong types are errors; so is a key that the chosen models do not use.
//
// [scene]                       required
//   name = "thesis-all-10"      required string
//   description = "..."         optional string
//
// ---- the domain: exactly one of [domain] (a terrain grid of quad patches) or [mesh] /
// ---- [[mesh]] (triangle meshes, one patch per triangle, for PN triangles)
// [domain]
//   plane = "xy" | "xz"         "xy": ground plane z = 0, z up (thesis); "xz": y = 0, y up
//                               (COSC422, lab 4)
//   patches = [nu, nv]          patch count along the plane's first axis (x) and second
//                               axis (y or z); each >= 1, at most 2^26 patches in all
//   x = [x0, x1]                extent: the grid's corner columns run from x0 to x1 and its
//   y = [y0, y1]  (plane xy)    rows from y0 (or z0) to y1 (z1), equally spaced. Patch
//   z = [z0, z1]  (plane xz)    (i, j) has corners c0 = (x_i, y_j), c1 = (x_i, y_j+1),
//                               c2 = (x_i+1, y_j+1), c3 = (x_i+1, y_j) (control.h layout)
//   follow_camera = true        instead of x/y/z: lab 4's sliding window, nu x nv patches
//   patch_size = s              of side s centred on the camera, the centre snapped to a
//                               multiple of s (x ascending; z descending on plane xz, y
//                               ascending on plane xy, so ccw faces up)
//   heightmap = "path"          required: the height map (8/16-bit PGM/PNG, float TIFF,
//                               PFM, EXR; see heightfield.h)
//   nodata = -32768             optional raw value meaning "no data"; with
//   nodata_policy = "error"     "error" (default) | "fill_neighbour_mean" | "fill_constant"
//   fill_value = 0.0            for fill_constant
//   scale_xy = s                thesis: textureCoordinate = position.xy / scaleXY;
//                               lab 4: horizontalScale (texCoord = xz / s + offset).
//                               Not used by COSC422 (its texture coordinates come from the
//                               extent: s = (x - x0)/(x1 - x0), t = (z - z0)/(z1 - z0)).
//   scale_z = s                 height = sample * s (thesis scaleZ, COSC422's 10, lab 4's
//                               verticalScale); required
//   texcoord_offset = [s, t]    lab 4 only (default [0, 0])
//   normal_map = "path"         optional RGB normal map (thesis encoding); when absent and
//                               a stage needs one (thesis normal factor, geometry
//                               normal_map) it is generated from the height map by
//                               thesis_normal_map() with
//   normal_map_spacing = d      world distance between texels (default scale_xy / width)
//   normal_map_height_scale = h (default scale_z), i.e. the normals of the world surface
//
// [mesh] or [[mesh]]            one table or an array of tables, one per mesh file
//   path = "path"               OBJ, OFF, PLY, STL read through OpenMesh; every face must be
//                               a triangle; vertex normals from the file, or when it has
//                               none the normalized sum of the incident face normals
//   translate = [x, y, z]       optional, default [0, 0, 0]
//   scale = s                   optional uniform scale (> 0), default 1
//
// [camera]                      optional; required by the models that read it (thesis
//                               distance/all, COSC422 eye space, lab 4, PN)
//   either the thesis's listing 2 (z up):
//     position = [x, y, z]      cameraPosition
//     theta = deg, phi = deg    targetVector = normalize(sin(theta*3.14/180),
//                               cos(theta*3.14/180), tan(phi*3.14/180)) — the thesis's
//                               3.14, kept; center = position + targetVector; up = (0,0,1)
//   or a plain look-at:
//     eye = [x, y, z]
//     center = [x, y, z]
//     up = [x, y, z]            default: the plane's up axis ((0,0,1) for xy, (0,1,0) else)
//   fov_y = 30.0                vertical field of view in degrees (OSG's default 30)
//   viewport = [1280, 800]      pixels (the thesis's screen)
//   near = 1.0, far = 10000.0   clip planes
//
// [generator]                   optional; defaults are the evaluation model's layout
//   domain = "quads" | "triangles"        (quads for [domain], triangles for meshes)
//   spacing = "equal" | "fractional_odd" | "fractional_even"
//   winding = "ccw" | "cw"
//
// [control]                     optional; without it every level is 1 (GL's default patch
//                               levels, GL_PATCH_DEFAULT_OUTER/INNER_LEVEL)
//   model = "constant"          level = L (all six levels)
//   model = "thesis"            factor = "distance" | "tessellation_map" | "normal" | "all"
//                               level = L (tessellationLevel, the text's userDecidedLevel)
//                               tessellation_map = "path"  (factors tessellation_map, all;
//                                   for all it may be left out when weights.texture = 0)
//                               weights = { constant = 1, normal = 5, texture = 5,
//                                           distance = 5 }      (formula (2), all only)
//                               distance_limit = 50, distance_divisor = 10
//                               normal_threshold = 0.9 (radians)
//   model = "cosc422"           space = "world" | "eye"
//   model = "lab4"              first_zone_end = 50, zone_growth = 2, max_level = 64,
//                               min_level = 1 (powers of two), edge_rule = "lower"|"higher"
//   model = "pn"                pixels_per_edge = 4, min_level = 1, max_level = 32,
//                               flat_edges_at_level_1 = true; resolution = camera viewport
//
// [evaluation]                  required (without an evaluation shader GL does not
//                               tessellate)
//   model = "thesis" | "cosc422" | "lab4" | "pn"
//   pn only: influence = 0.75, normal = "quadratic" | "linear", watertight_edges = true
//   (terrain models take their parameters from [domain]; lab4 needs control model lab4,
//   whose mip levels it reads)
//
// [geometry]                    optional; without it the mesh has the evaluation's normals
//                               (PN) or none (terrain)
//   normals = "face"            one normal per triangle (PipelineResult::face_normals)
//           | "normal_map"      thesis GS: per vertex from the normal map (plane xy)
//           | "height_field"    lab 4 appendix A, per vertex from the height map (lab 4:
//                               at the vertex's mip level; other terrain: level 0)
//           | "smooth"          area-weighted vertex normals of the tessellated surface
//
// [shading]                     the fragment stage: kept here as text (Scene::shading_toml)
//                               and parsed, with its own errors, by include/tessref/render.h
//
// [shaders]                     optional; `tessref gl` only (gl_backend.h): a user's GLSL
//                               file in place of the GLSL twin of one stage. The CPU
//                               commands ignore it (they keep the reference models) and the
//                               loader does not open the files (`tessref gl` does)
//   vertex = "path"             any of the five stages; a stage the models do not have
//   tess_control = "path"       (e.g. geometry without [geometry]) is added
//   tess_evaluation = "path"
//   geometry = "path"
//   fragment = "path"
//
// [limits]
//   max_triangles = 50000000    the run is refused (before tessellating) when an upper
//                               bound of the triangle count, estimated from the levels,
//                               exceeds it
// ======================================================================================
//
// OUTPUT. The SurfaceMesh holds, patch after patch in patch order, every domain point of
// the patch's pattern (generator order) evaluated, and the pattern's triangles re-indexed.
// Triangles are counter-clockwise seen from above (terrain: +z for plane xy, +y for plane
// xz) or from outside (meshes, whose faces are counter-clockwise seen from outside, as OBJ
// and OFF files have them): the generator's winding is applied, and the index order is
// reversed when the winding and the grid's orientation together would give the other side.
// Patch ids: terrain patch (i, j) is j * nu + i; mesh patches are the faces, mesh after
// mesh, in file order. The output is byte-identical whatever the thread count: each patch
// fills a pre-sized slot.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/control.h"
#include "tessref/error.h"
#include "tessref/evaluation.h"
#include "tessref/heightfield.h"
#include "tessref/mesh.h"
#include "tessref/tessellator.h"

namespace tessref {

// ---------------------------------------------------------------------------------------
// The parsed scene
// ---------------------------------------------------------------------------------------

enum class GroundPlane : std::uint8_t { xy, xz };
enum class ControlModel : std::uint8_t { constant, thesis, cosc422, lab4, pn };
enum class EvaluationModel : std::uint8_t { thesis, cosc422, lab4, pn };
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

struct ThesisControlSettings {
    ThesisFactor factor = ThesisFactor::all;
    double level = 1.0;
    ThesisWeights<double> weights{};
    ThesisDistance<double> distance{};
    double normal_threshold = 0.90;
    std::string tessellation_map_path;  // empty: none (texture factor reads 0)
    std::shared_ptr<const Texture> tessellation_map;
};

struct Lab4ControlSettings {
    double first_zone_end = 50.0;
    double zone_growth = 2.0;
    double max_level = 64.0;
    double min_level = 1.0;
    Lab4EdgeRule edge_rule = Lab4EdgeRule::lower;
};

struct PnControlSettings {
    double pixels_per_edge = 4.0;
    double min_level = 1.0;
    double max_level = 32.0;
    bool flat_edges_at_level_1 = true;
};

struct ControlStage {
    ControlModel model = ControlModel::constant;
    double constant_level = 1.0;
    ThesisControlSettings thesis{};
    Cosc422Space cosc422_space = Cosc422Space::world;
    Lab4ControlSettings lab4{};
    PnControlSettings pn{};
};

struct EvaluationStage {
    EvaluationModel model = EvaluationModel::thesis;
    double pn_influence = 0.75;
    PnNormal pn_normal = PnNormal::quadratic;
    bool pn_watertight_edges = true;
};

struct GeometryStage {
    GeometryNormals normals = GeometryNormals::smooth;
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
    std::optional<std::string> shading_toml;  // [shading] table as TOML text (render.h parses it)
    std::vector<StageShader> shaders;          // [shaders] (`tessref gl` only)
    std::uint64_t max_triangles = 50'000'000;
    Where max_triangles_where;  // where the budget was set (or the scene file): for errors

    std::size_t patch_count() const;
};

// Parses, validates and loads a scene file (images and meshes included). Throws
// tessref::Error with Where{file, line, column, key} on any problem; errors from an image
// or mesh loader are re-thrown with the scene's place (the key that named the file) and
// the loader's message (which names the image) in what().
Scene load_scene(const std::string& path);
// The same from TOML text; `path` names the text in errors and is the base of relative
// paths (it need not exist).
Scene load_scene_from_string(const std::string& toml_text, const std::string& path);

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

// Whether a tess coord lies on outer edge `edge` of its patch (quads: u == 0, v == 0,
// u == 1, v == 1; triangles: u == 0, v == 0, w == 0).
bool on_outer_edge(Domain domain, const glm::vec3& tess_coord, int edge);

// An upper bound on the triangles the primitive generator emits for these levels (0 for a
// culled patch), without tessellating: used to refuse a run beyond the budget.
std::uint64_t estimate_triangles(const TessSettings& settings, const TessLevels& levels);

// ---------------------------------------------------------------------------------------
// The pipeline
// ---------------------------------------------------------------------------------------

struct PipelineOptions {
    Precision precision = Precision::gpu;  // gpu: float stages, exact: double stages
    // Called with (patches done, patch count) as patches finish, from worker threads
    // (serialized by the pipeline); may be empty.
    std::function<void(std::size_t done, std::size_t total)> progress;
    PatternCache* cache = nullptr;         // shared cache; a private one when null
};

// Which stages ran (a stage the scene does not name does not run).
struct StagesRun {
    bool control = false;
    bool evaluation = false;
    bool geometry = false;
};

struct PipelineResult {
    SurfaceMesh mesh;
    std::vector<glm::dvec3> face_normals;  // one per triangle with [geometry] normals = "face"
    std::vector<TessLevels> levels;        // per patch: what the control stage wrote
    std::uint64_t estimated_triangles = 0;
    std::size_t distinct_patterns = 0;     // distinct level sets (patterns) of this run
    StagesRun stages{};
};

// Runs the scene's pipeline. Throws tessref::Error (key "limits.max_triangles") when the
// estimate exceeds the scene's budget, before any tessellation.
PipelineResult run_pipeline(const Scene& scene, const PipelineOptions& options = {});

}  // namespace tessref
