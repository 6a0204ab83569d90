// Every GLSL twin proven against its hand-written C++ model: the twins of data/shaders/ run
// through the SPIR-V interpreter (tessref/shader.h) with the uniforms and textures the GL
// backend sets (src/gl/scene_render.cpp), patch by patch, and compared bit for bit with the
// CPU pipeline's levels and evaluated positions in gpu precision.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <functional>
#include <optional>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tessref/pipeline.h"
#include "tessref/prepare.h"
#include "tessref/scene.h"
#include "tessref/shader.h"

namespace tessref::shader {
namespace {

std::string scene_path(const std::string& name) { return std::string(TESSREF_DATA_DIR) + "/scenes/" + name + ".toml"; }

Module twin(ShaderStage stage, const std::string& file) {
    const std::string path = std::string(TESSREF_DATA_DIR) + "/shaders/" + file;
    std::ifstream in(path);
    std::ostringstream text;
    text << in.rdbuf();
    Source s;
    s.stage = stage;
    s.path = path;
    s.text = text.str();
    return Module::compile(s);
}

// thesis_uniforms and thesis_control_uniforms of the GL backend, with mvp the identity (as
// its capture pass sets it, so that gl_Position.xyz is the world position).
Bindings thesis_bindings(const Scene& scene) {
    const TerrainGrid& g = *scene.grid;
    Bindings b;
    b.set("scaleXY", static_cast<float>(g.scale_xy));
    b.set("scaleZ", static_cast<float>(g.scale_z));
    b.set("mvp", glm::mat4(1.0f));
    b.bind_texture(0, &g.heightmap->texture);
    if (g.normal_map) b.bind_texture(2, g.normal_map.get());
    if (scene.control && scene.control->model == ControlModel::thesis) {
        const ThesisControlParams<double>& c = scene.control->thesis;
        b.set("tessellationLevel", static_cast<float>(c.tessellationLevel));
        b.set("cameraPosition", glm::vec3(scene.camera->eye));
        b.set("thesisFactor", static_cast<int>(c.factor));
        b.set("distanceLimit", static_cast<float>(c.distance.limit));
        b.set("distanceDivisor", static_cast<float>(c.distance.divisor));
        b.set("normalAngleThreshold", static_cast<float>(c.normalAngleThreshold));
        b.set("normalTessellationWeight", static_cast<float>(c.weights.normal));
        b.set("textureTessellationWeight", static_cast<float>(c.weights.texture));
        b.set("distanceTessellationWeight", static_cast<float>(c.weights.distance));
        b.set("constantTessellationWeight", static_cast<float>(c.weights.constant));
        if (scene.control->tessellation_map) b.bind_texture(1, scene.control->tessellation_map.get());
    }
    return b;
}

// A terrain patch's four corners as the GL backend's vertex buffer holds them.
std::vector<Slot> corners(const TerrainGrid& g, std::size_t p) {
    const std::size_t i = p % static_cast<std::size_t>(g.patches_u), j = p / static_cast<std::size_t>(g.patches_u);
    const std::size_t c[4][2] = {{i, j}, {i, j + 1}, {i + 1, j + 1}, {i + 1, j}};
    std::vector<Slot> out;
    for (const auto& k : c) {
        const float u = static_cast<float>(g.u_coords[k[0]]), v = static_cast<float>(g.v_coords[k[1]]);
        out.push_back(slot(g.plane == GroundPlane::xy ? glm::vec4(u, v, 0.0f, 1.0f) : glm::vec4(u, 0.0f, v, 1.0f)));
    }
    return out;
}

std::string levels_text(const std::array<float, 4>& outer, const std::array<float, 2>& inner) {
    char text[200];
    std::snprintf(text, sizeof text, "(%.9g %.9g %.9g %.9g; %.9g %.9g)", outer[0], outer[1], outer[2], outer[3], inner[0],
                  inner[1]);
    return text;
}

struct Counts {
    std::size_t patches = 0, level_mismatches = 0, vertices = 0, position_mismatches = 0;
    std::string first;
};

// A terrain's twins against its program: every patch's levels (when the scene has a
// control twin), and the evaluated position (gl_Position.xyz, mvp the identity, or the
// vec3 at `position_location`) at every vertex of every `stride`-th patch.
// A patch's vertex attributes as the GL backend's vertex buffer holds them.
using PatchInputs = std::function<std::vector<std::vector<Slot>>(const Scene&, std::size_t patch)>;

std::vector<std::vector<Slot>> terrain_inputs(const Scene& scene, std::size_t p) {
    std::vector<std::vector<Slot>> out;
    for (const Slot& c : corners(*scene.grid, p)) out.push_back({c});
    return out;
}

// PN: the triangle's three vertices, position, normal and uv (locations 0, 1, 2).
std::vector<std::vector<Slot>> pn_inputs(const Scene& scene, std::size_t p) {
    const TriangleMeshes& m = *scene.meshes;
    std::vector<std::vector<Slot>> out;
    for (std::uint32_t v : m.triangles[p]) {
        const glm::vec2 uv = m.uvs.empty() ? glm::vec2(0.0f) : glm::vec2(m.uvs[v]);
        out.push_back({slot(glm::vec4(glm::vec3(m.positions[v]), 0.0f)), slot(glm::vec4(glm::vec3(m.normals[v]), 0.0f)),
                       slot(glm::vec4(uv, 0.0f, 0.0f))});
    }
    return out;
}

Counts terrain_against_model(const std::string& name, const std::string& base, const Bindings& b,
                             int position_location, std::size_t stride, const PatchInputs& inputs = terrain_inputs,
                             MathMode math = MathMode::exact) {
    RunOptions options;
    options.math = math;
    const Scene scene = load_scene(scene_path(name));
    PipelineOptions pipeline_options;  // the model in the same math mode
    pipeline_options.math = math == MathMode::llvmpipe ? tessref::MathMode::llvmpipe : tessref::MathMode::exact;
    const PipelineResult result = run_pipeline(scene, pipeline_options);
    const Executable vert(twin(ShaderStage::vertex, base + ".vert"), b, options);
    const Executable tese(twin(ShaderStage::tess_evaluation, base + ".tese"), b, options);
    const bool control = scene.control && scene.control->model != ControlModel::constant;
    std::optional<Executable> tesc;
    if (control) tesc.emplace(twin(ShaderStage::tess_control, base + ".tesc"), b, options);
    const SurfaceMesh& mesh = result.mesh;
    std::vector<std::vector<std::uint32_t>> vertices_of(scene.patch_count());
    for (std::uint32_t v = 0; v < mesh.patch_ids.size(); ++v) vertices_of[mesh.patch_ids[v]].push_back(v);
    Counts n;
    for (std::size_t p = 0; p < scene.patch_count(); ++p) {
        const std::vector<std::vector<Slot>> attributes = inputs(scene, p);
        std::vector<ShaderVertex> shaded;
        for (std::size_t k = 0; k < attributes.size(); ++k) shaded.push_back(vert.vertex(attributes[k], static_cast<int>(k)));
        ShaderPatch patch;
        if (tesc) {
            patch = tesc->control(shaded, static_cast<long long>(p));
            ++n.patches;
            const TessLevels& l = result.levels[p];
            // The levels the domain reads (GL leaves the others undefined: the model holds 1,
            // the interpreter what the shader wrote, or 0).
            const Domain d = scene.generator.domain;
            const int outer = d == Domain::quads ? 4 : d == Domain::triangles ? 3 : 2;
            const int inner = d == Domain::quads ? 2 : d == Domain::triangles ? 1 : 0;
            bool same = true;
            for (int k = 0; k < outer; ++k) same = same && std::bit_cast<std::uint32_t>(patch.outer[k]) == std::bit_cast<std::uint32_t>(l.outer[k]);
            for (int k = 0; k < inner; ++k) same = same && std::bit_cast<std::uint32_t>(patch.inner[k]) == std::bit_cast<std::uint32_t>(l.inner[k]);
            if (!same) {
                ++n.level_mismatches;
                if (n.first.empty())
                    n.first = "patch " + std::to_string(p) + " levels interpreter " + levels_text(patch.outer, patch.inner) +
                              " model " + levels_text(l.outer, l.inner);
            }
        } else {
            patch.vertices = shaded;  // the constant control shader passes the vertices through
        }
        if (p % stride != 0) continue;
        for (std::uint32_t v : vertices_of[p]) {
            const ShaderVertex out = tese.evaluate(patch, mesh.tess_coords[v], static_cast<long long>(p));
            ++n.vertices;
            const glm::vec3 model(mesh.positions[v]);
            const glm::vec3 shader = position_location < 0 ? glm::vec3(out.position)
                                                           : glm::vec3(as_vec4(out.locations.at(static_cast<std::size_t>(position_location))));
            if (std::bit_cast<std::array<std::uint32_t, 3>>(shader) != std::bit_cast<std::array<std::uint32_t, 3>>(model)) {
                ++n.position_mismatches;
                if (n.first.empty())
                    n.first = "patch " + std::to_string(p) + " vertex " + std::to_string(v) + " interpreter (" +
                              std::to_string(shader.x) + ", " + std::to_string(shader.y) + ", " + std::to_string(shader.z) +
                              ") model (" + std::to_string(model.x) + ", " + std::to_string(model.y) + ", " +
                              std::to_string(model.z) + ")";
            }
        }
    }
    return n;
}

Counts thesis_against_model(const std::string& name, std::size_t stride) {
    return terrain_against_model(name, "thesis_terrain", thesis_bindings(load_scene(scene_path(name))), -1, stride);
}

// cosc422_uniforms of the GL backend.
Bindings cosc422_bindings(const Scene& scene) {
    const TerrainGrid& g = *scene.grid;
    Bindings b;
    b.set("mvpMatrix", glm::mat4(scene.camera->view_projection()));
    b.set("mvMatrix", glm::mat4(scene.camera->view()));
    b.set("xMin", static_cast<float>(g.extent_u.x));
    b.set("xMax", static_cast<float>(g.extent_u.y));
    b.set("zMin", static_cast<float>(g.extent_v.x));
    b.set("zMax", static_cast<float>(g.extent_v.y));
    b.set("heightScale", static_cast<float>(g.scale_z));
    b.set("gridStep", static_cast<float>(std::abs(g.extent_u.y - g.extent_u.x) / g.heightmap->texture.width()));
    if (scene.control && scene.control->model == ControlModel::cosc422)
        b.set("levelSpace", scene.control->cosc422 == Cosc422Space::eye ? 1 : 0);
    b.bind_texture(0, &g.heightmap->texture);
    return b;
}

// lab4_uniforms and lab4_control_uniforms of the GL backend.
Bindings lab4_bindings(const Scene& scene) {
    const TerrainGrid& g = *scene.grid;
    Bindings b;
    b.set("mvp", glm::mat4(scene.camera->view_projection()));
    b.set("horizontalScale", static_cast<float>(g.scale_xy));
    b.set("verticalScale", static_cast<float>(g.scale_z));
    b.set("texCoordOffset", glm::vec2(g.texcoord_offset));
    b.set("gridStep", static_cast<float>(g.scale_xy / g.heightmap->texture.width()));
    const Lab4ControlParams<double>& c = scene.control->lab4;
    b.set("cameraPosition", glm::vec3(scene.camera->eye));
    b.set("firstZoneEnd", static_cast<float>(c.firstZoneEnd));
    b.set("zoneGrowth", static_cast<float>(c.zoneGrowth));
    b.set("maxLevel", static_cast<float>(c.maxLevel));
    b.set("minLevel", static_cast<float>(c.minLevel));
    b.set("edgeRule", c.edgeRule == Lab4EdgeRule::lower ? 0 : 1);
    b.bind_texture(0, &g.heightmap->texture);
    return b;
}

// Levels: the thesis control shader against thesis_levels on every patch, for the factors
// that call no GLSL.std.450 function whose exact result the model rounds otherwise
// (distance: sqrt; map: texture). Evaluation: every vertex of every 7th patch.
TEST(ThesisTwins, DistanceFactorLevelsAndEvaluationAreTheModels) {
    const Counts n = thesis_against_model("thesis-distance-4", 7);
    EXPECT_EQ(n.patches, 256u);
    EXPECT_GT(n.vertices, 300u);
    EXPECT_EQ(n.level_mismatches, 0u) << n.first;
    EXPECT_EQ(n.position_mismatches, 0u) << n.first;
}

TEST(ThesisTwins, MapFactorLevelsAndEvaluationAreTheModels) {
    for (const char* name : {"thesis-map-4", "thesis-map-18"}) {
        const Counts n = thesis_against_model(name, 7);
        EXPECT_EQ(n.patches, 256u) << name;
        EXPECT_GT(n.vertices, 150u) << name;
        EXPECT_EQ(n.level_mismatches, 0u) << name << ": " << n.first;
        EXPECT_EQ(n.position_mismatches, 0u) << name << ": " << n.first;
    }
}

TEST(ThesisTwins, ConstantLevelEvaluationIsTheModels) {
    const Counts n = thesis_against_model("thesis-constant-64", 17);
    EXPECT_GT(n.vertices, 10000u);
    EXPECT_EQ(n.position_mismatches, 0u) << n.first;
}

// The real height maps, whose extents are not multiples of the patch size: there the form
// of mix() shows (x * (1 - a) + y * a instead of x + a * (y - x) moves 1379 of these
// jacksboro vertices). Their control stage uses the normal factor, whose acos and
// normalize the model computes with the C library's acosf and 1 / sqrt (two roundings),
// not correctly rounded as the exact mode does: the levels are compared in the llvmpipe
// mode, not here.
TEST(ThesisTwins, RealHeightMapEvaluationIsTheModels) {
    for (const char* name : {"jacksboro", "olinda"}) {
        const Counts n = thesis_against_model(name, 5);
        EXPECT_GT(n.vertices, 500u) << name;
        EXPECT_EQ(n.position_mismatches, 0u) << name << ": " << n.first;
    }
}

// COSC422: the level in world and in eye space (mvMatrix * position), the evaluation's
// worldPosition (location 0).
TEST(Cosc422Twins, LevelsAndEvaluationAreTheModels) {
    for (const char* name : {"cosc422", "cosc422-eye"}) {
        const Counts n = terrain_against_model(name, "cosc422_terrain", cosc422_bindings(load_scene(scene_path(name))), 0, 5);
        EXPECT_EQ(n.patches, 81u) << name;
        EXPECT_GT(n.vertices, 2000u) << name;
        EXPECT_EQ(n.level_mismatches, 0u) << name << ": " << n.first;
        EXPECT_EQ(n.position_mismatches, 0u) << name << ": " << n.first;
    }
}

// Lab 4: the zones' levels, the per-patch outputs the evaluation reads (patch out/in at
// locations 1..4), the evaluation's worldPosition.
TEST(Lab4Twins, LevelsAndEvaluationAreTheModels) {
    const Counts n = terrain_against_model("lab4-canyon", "lab4_terrain", lab4_bindings(load_scene(scene_path("lab4-canyon"))), 0, 5);
    EXPECT_EQ(n.patches, 1024u);
    EXPECT_GT(n.vertices, 10000u);
    EXPECT_EQ(n.level_mismatches, 0u) << n.first;
    EXPECT_EQ(n.position_mismatches, 0u) << n.first;
}

// pn_uniforms of the GL backend, at the camera's viewport.
Bindings pn_bindings(const Scene& scene) {
    Bindings b;
    b.set("m4Transform", glm::mat4(1.0f));
    b.set("m4ViewProjection", glm::mat4(scene.camera->view_projection()));
    b.set("fInfluence", static_cast<float>(scene.evaluation.pn.fInfluence));
    b.set("normalMode", scene.evaluation.pn.normal == PnNormal::linear ? 0 : 1);
    b.set("watertightEdges", scene.evaluation.pn.watertightEdges ? 1 : 0);
    b.set("v2Resolution", glm::vec2(scene.camera->viewport));
    if (scene.control && scene.control->model == ControlModel::pn)
        b.set("flatEdgesAtLevel1", scene.control->pn.flatEdgesAtLevel1 ? 1 : 0);
    return b;
}

// PN triangles: levels from the projected corners (m4ViewProjection * position, whose
// column sums glm and the interpreter both take pairwise: (c0 x + c1 y) + (c2 z + c3 w);
// summed from the first column on, 14 of these 104 patches got other levels), every patch.
// The positions are the model's only with inversesqrt rounded twice (1 / sqrt, as the
// model's glm::normalize and llvmpipe's rsqrt): in exact mode the correctly rounded
// inversesqrt of normalize() moves 7107 of the 18407 compared vertices by a few ulps, so
// they are compared in the llvmpipe mode, not here.
TEST(PnTwins, LevelsAreTheModels) {
    const Counts n = terrain_against_model("pn-triangles", "pn_triangles", pn_bindings(load_scene(scene_path("pn-triangles"))), 0,
                                           3, pn_inputs);
    EXPECT_EQ(n.patches, 104u);
    EXPECT_GT(n.vertices, 10000u);
    EXPECT_EQ(n.level_mismatches, 0u) << n.first;
}

// In the llvmpipe mode inversesqrt is llvmpipe's 1 / sqrt, as the model's normalize: the
// PN positions are then the model's on every compared vertex.
TEST(PnTwins, PositionsAreTheModelsInTheLlvmpipeMode) {
    const Counts n = terrain_against_model("pn-triangles", "pn_triangles", pn_bindings(load_scene(scene_path("pn-triangles"))), 0,
                                           3, pn_inputs, MathMode::llvmpipe);
    EXPECT_GT(n.vertices, 10000u);
    EXPECT_EQ(n.level_mismatches, 0u) << n.first;
    EXPECT_EQ(n.position_mismatches, 0u) << n.first;
}

// ---- the geometry twins ---------------------------------------------------------------

// normalize(v) as each side rounds it: the models call glm's, v * (1 / sqrt(dot)) with the
// dot product summed from the first component; the interpreter's exact mode rounds
// inversesqrt once (correctly), its llvmpipe mode sums the dot product from the last
// component, as llvmpipe does (tessref/shader.h).
enum class NormalizeForm : std::uint8_t { glm, exact, llvmpipe };
glm::vec3 normalize_as(glm::vec3 v, NormalizeForm form) {
    const float x2 = v.x * v.x, y2 = v.y * v.y, z2 = v.z * v.z;
    float d = 0.0f;
    if (form == NormalizeForm::llvmpipe) {
        const float zy = z2 + y2;
        d = zy + x2;
    } else {
        const float xy = x2 + y2;
        d = xy + z2;
    }
    const float r = form == NormalizeForm::exact ? static_cast<float>(1.0 / std::sqrt(static_cast<double>(d))) : 1.0f / std::sqrt(d);
    return glm::vec3(v.x * r, v.y * r, v.z * r);
}

bool same_bits(glm::vec3 a, glm::vec3 b) {
    return std::bit_cast<std::array<std::uint32_t, 3>>(a) == std::bit_cast<std::array<std::uint32_t, 3>>(b);
}

struct GeometryCounts {
    std::size_t triangles = 0, vertices = 0;
    std::size_t model_unexplained = 0, twin_unexplained = 0;  // not normalize_as(...) of the vector before it
    std::size_t differing = 0;                                 // twin and model (normalize's rounding)
    std::string first;
};

// A geometry twin against the model's geometry stage: every `stride`-th triangle of the
// pipeline's mesh handed to the twin as the evaluation stage hands it on (gl_Position the
// position, the EvaluationData block from `block`), in the triangle's vertex order. The
// twin must emit one triangle of three vertices; the normal at location 0 of each must be
// `normalized` (what the shader normalizes, then the identity normalMatrix where the twin
// applies one) through normalize_as in the math mode's form, and the model's normal the same
// through glm's form: so that where twin and model differ, normalize's rounding is all of it.
using GeometryBlock = std::function<std::vector<Slot>(const SurfaceMesh&, std::uint32_t vertex)>;
using ModelNormal = std::function<glm::vec3(const PipelineResult&, std::size_t triangle, std::uint32_t vertex)>;
using Normalized = std::function<glm::vec3(const SurfaceMesh&, std::size_t triangle, std::uint32_t vertex, NormalizeForm)>;

GeometryCounts geometry_against_model(const std::string& name, const std::string& file, const Bindings& b,
                                      const GeometryBlock& block, const ModelNormal& model, const Normalized& normalized,
                                      std::size_t stride, MathMode math) {
    RunOptions options;
    options.math = math;
    const Scene scene = load_scene(scene_path(name));
    PipelineOptions pipeline_options;
    pipeline_options.math = math == MathMode::llvmpipe ? tessref::MathMode::llvmpipe : tessref::MathMode::exact;
    const PipelineResult result = run_pipeline(scene, pipeline_options);
    const Executable geom(twin(ShaderStage::geometry, file), b, options);
    const SurfaceMesh& mesh = result.mesh;
    const NormalizeForm form = math == MathMode::llvmpipe ? NormalizeForm::llvmpipe : NormalizeForm::exact;
    GeometryCounts n;
    for (std::size_t t = 0; t < mesh.triangles.size(); t += stride) {
        std::vector<ShaderVertex> in(3);
        for (int i = 0; i < 3; ++i) {
            const std::uint32_t v = mesh.triangles[t][static_cast<std::size_t>(i)];
            in[static_cast<std::size_t>(i)].position = glm::vec4(glm::vec3(mesh.positions[v]), 1.0f);
            in[static_cast<std::size_t>(i)].locations = block(mesh, v);
        }
        const ShaderPrimitives out = geom.geometry(in, static_cast<long long>(t));
        ++n.triangles;
        EXPECT_EQ(out.indices, (std::vector<std::uint32_t>{0, 1, 2})) << name << " triangle " << t;
        if (out.vertices.size() != 3) continue;
        for (int i = 0; i < 3; ++i) {
            const std::uint32_t v = mesh.triangles[t][static_cast<std::size_t>(i)];
            const glm::vec3 shader(as_vec4(out.vertices[static_cast<std::size_t>(i)].locations.at(0)));
            const glm::vec3 expected = model(result, t, v);
            ++n.vertices;
            n.differing += !same_bits(shader, expected);
            const bool twin_ok = same_bits(shader, normalized(mesh, t, v, form));
            const bool model_ok = same_bits(expected, normalized(mesh, t, v, NormalizeForm::glm));
            n.twin_unexplained += !twin_ok;
            n.model_unexplained += !model_ok;
            if ((!twin_ok || !model_ok) && n.first.empty()) {
                char text[300];
                std::snprintf(text, sizeof text, "triangle %zu vertex %u interpreter (%.9g %.9g %.9g) model (%.9g %.9g %.9g)",
                              t, v, shader.x, shader.y, shader.z, expected.x, expected.y, expected.z);
                n.first = text;
            }
        }
    }
    return n;
}

// thesis_terrain.geom: EvaluationData's textureCoordinate at location 0; normalMatrix the
// identity and the normal map at unit 2, as the GL backend sets them (stage_uniforms.cpp).
// It normalizes texture(normalMap, uv).rgb - 0.5.
GeometryCounts thesis_geometry_against_model(const std::string& name, std::size_t stride, MathMode math) {
    const Scene scene = load_scene(scene_path(name));
    const Texture* normal_map = scene.grid->normal_map.get();
    Bindings b;
    b.set("normalMatrix", glm::mat3(1.0f));
    b.bind_texture(2, normal_map);
    return geometry_against_model(
        name, "thesis_terrain.geom", b,
        [](const SurfaceMesh& mesh, std::uint32_t v) { return std::vector<Slot>{slot(glm::vec4(glm::vec2(mesh.uvs[v]), 0.0f, 0.0f))}; },
        [](const PipelineResult& r, std::size_t, std::uint32_t v) { return glm::vec3(r.mesh.normals[v]); },
        [normal_map](const SurfaceMesh& mesh, std::size_t, std::uint32_t v, NormalizeForm form) {
            const glm::vec3 texel(normal_map->texture(glm::vec2(mesh.uvs[v])));
            return glm::mat3(1.0f) * normalize_as(texel - glm::vec3(0.5f), form);
        },
        stride, math);
}

// cosc422_terrain.geom: EvaluationData's worldPosition and texCoord at locations 0 and 1; the
// model's face normal of the triangle at each of its vertices. It normalizes
// cross(p1 - p0, p2 - p0).
GeometryCounts cosc422_geometry_against_model(const std::string& name, std::size_t stride, MathMode math) {
    return geometry_against_model(
        name, "cosc422_terrain.geom", Bindings{},
        [](const SurfaceMesh& mesh, std::uint32_t v) {
            return std::vector<Slot>{slot(glm::vec4(glm::vec3(mesh.positions[v]), 0.0f)),
                                     slot(glm::vec4(glm::vec2(mesh.uvs[v]), 0.0f, 0.0f))};
        },
        [](const PipelineResult& r, std::size_t t, std::uint32_t) { return glm::vec3(r.face_normals[t]); },
        [](const SurfaceMesh& mesh, std::size_t t, std::uint32_t, NormalizeForm form) {
            const auto p = [&](int i) { return glm::vec3(mesh.positions[mesh.triangles[t][static_cast<std::size_t>(i)]]); };
            return normalize_as(glm::cross(p(1) - p(0), p(2) - p(0)), form);
        },
        stride, math);
}

// The geometry twins are their models but for normalize's rounding, at every vertex: the
// twin's normal is what the math mode's normalize makes of the very vector the model
// normalizes with glm's. That rounding differs on a share of the vertices in both modes:
// exact mode's correctly rounded inversesqrt against the model's 1 / sqrt, llvmpipe's dot
// product from the last component against glm's from the first. The model is the odd one
// against llvmpipe (GeometryTwinsGiveLlvmpipesNormals in test_user_shaders.cpp: the twins in
// the llvmpipe mode give llvmpipe's normals bit for bit, the model up to 3 ulps off).
TEST(ThesisTwins, GeometryNormalsAreTheModelsButForNormalize) {
    for (const MathMode math : {MathMode::exact, MathMode::llvmpipe})
        for (const char* name : {"thesis-normal-2", "jacksboro"}) {
            const GeometryCounts n = thesis_geometry_against_model(name, 3, math);
            EXPECT_GT(n.vertices, 1000u) << name;
            EXPECT_EQ(n.twin_unexplained, 0u) << name << " " << to_string(math) << ": " << n.first;
            EXPECT_EQ(n.model_unexplained, 0u) << name << " " << to_string(math) << ": " << n.first;
            EXPECT_GT(n.differing, 0u) << name << " " << to_string(math);  // the forms do differ here
            std::printf("%s %s: twin and model differ at %zu of %zu vertices, each by normalize's rounding alone\n", name,
                        to_string(math), n.differing, n.vertices);
        }
}

TEST(Cosc422Twins, GeometryFaceNormalsAreTheModelsButForNormalize) {
    for (const MathMode math : {MathMode::exact, MathMode::llvmpipe})
        for (const char* name : {"cosc422", "cosc422-eye"}) {
            const GeometryCounts n = cosc422_geometry_against_model(name, 3, math);
            EXPECT_GT(n.vertices, 1000u) << name;
            EXPECT_EQ(n.twin_unexplained, 0u) << name << " " << to_string(math) << ": " << n.first;
            EXPECT_EQ(n.model_unexplained, 0u) << name << " " << to_string(math) << ": " << n.first;
            std::printf("%s %s: twin and model differ at %zu of %zu vertices, each by normalize's rounding alone\n", name,
                        to_string(math), n.differing, n.vertices);
        }
}

}  // namespace
}  // namespace tessref::shader
