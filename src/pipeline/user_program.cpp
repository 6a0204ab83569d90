// user_program.cpp — a scene with a user's vertex, control, evaluation or geometry shader
// ([shaders], `--shader STAGE=FILE`): the CPU runs those stages through the SPIR-V interpreter
// (tessref/shader.h), with the twins of data/shaders/ for the stages before the
// rasterizer that the user did not give, and the same uniforms, texture units and vertex
// buffer as the GL backend (stage_uniforms.h, src/gl/scene_render.cpp).
//
// Which stages run where:
//  - vertex, control, evaluation: the interpreter, the user's file or the twin (the twins
//    run bit for bit as their models, tests/test_shader_twins.cpp). Where the user gave
//    neither a vertex nor a control shader, the levels are the model's (the twins agree
//    with them but for the thesis normal factor's acos in exact math, where the model calls
//    the C library's acosf), so that only what the user changed changes.
//  - a user's geometry shader: the interpreter, over every triangle of a patch at once
//    (geometry() below); what it emits is the surface (pipeline.cpp holds it per patch).
//    Without one, the geometry stage's per-vertex normals (thesis normal_map, height-field
//    normals the evaluation shader does not compute) are the models', on the interpreter's
//    positions and texture coordinates. Everything after the geometry stage is the models';
//    a user's fragment shader is run by the render (src/render/user_fragment.cpp), from
//    what raster_stage_corners() gives it (`trace --stage geom` runs the geometry stage
//    here too, over one triangle of a patch).
//  - the primitive generator tessellates as the scene's [generator] says, whatever the
//    user's evaluation shader's layout(...) in; line (GL draws with the user's: a cw where
//    [generator] has ccw shows as an orientation divergence of the captures).
// Where the GL backend's capture reads the evaluated world position (gl_render.h's
// position expression) the CPU reads it too: the thesis's gl_Position with mvp the
// identity (as the capture pass sets it), the other models' EvaluationData block.
#include <algorithm>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "common/data_dir.h"
#include "common/input_file.h"
#include "common/parallel.h"
#include "pipeline/program.h"
#include "pipeline/raster_stage.h"
#include "pipeline/stage_trace.h"
#include "pipeline/stage_uniforms.h"
#include "tessref/capture.h"
#include "tessref/pipeline.h"
#include "tessref/error.h"
#include "tessref/shader.h"

namespace tessref::pipeline {

namespace {

// The twins' base name of an evaluation model (none for geomipmap: no tessellation).
const char* twin_base(EvaluationModel m) {
    switch (m) {
        case EvaluationModel::thesis: return "thesis_terrain";
        case EvaluationModel::cosc422: return "cosc422_terrain";
        case EvaluationModel::lab4: return "lab4_terrain";
        case EvaluationModel::pn: return "pn_triangles";
        case EvaluationModel::geomipmap: break;
    }
    return nullptr;
}

// The control model's twin file; "" for the constant model (and no [control]).
std::string control_twin(const Scene& scene) {
    if (!scene.control) return "";
    switch (scene.control->model) {
        case ControlModel::thesis: return "thesis_terrain.tesc";
        case ControlModel::cosc422: return "cosc422_terrain.tesc";
        case ControlModel::lab4: return "lab4_terrain.tesc";
        case ControlModel::pn: return "pn_triangles.tesc";
        case ControlModel::constant: break;
    }
    return "";
}

// The scene's geometry twin, the file the GL backend draws its [geometry] with: "" where
// the model has no geometry shader (its normals, if any, come from the evaluation shader or
// the C++ geometry stage alone).
std::string geometry_twin(const Scene& scene) {
    if (!scene.geometry) return "";
    const GeometryNormals n = scene.geometry->normals;
    if (scene.evaluation.model == EvaluationModel::thesis && n == GeometryNormals::normal_map) return "thesis_terrain.geom";
    if (scene.evaluation.model == EvaluationModel::cosc422 && n == GeometryNormals::face) return "cosc422_terrain.geom";
    return "";
}

// The shading model's fragment twin, whose text keeps the built-in shading; "" for the
// models whose fragment shader is the GL backend's own text (flat, depth).
std::string fragment_twin(ShadingKind kind) {
    switch (kind) {
        case ShadingKind::thesis_single: return "thesis_terrain_single.frag";
        case ShadingKind::thesis_multi: return "thesis_terrain.frag";
        case ShadingKind::lab4: return "lab4_terrain.frag";
        case ShadingKind::cosc422: return "cosc422_terrain.frag";
        case ShadingKind::pn: return "pn_triangles.frag";
        case ShadingKind::pom: return "pom.frag";
        case ShadingKind::geomip_lightmap: return "geomip_terrain.frag";
        case ShadingKind::flat:
        case ShadingKind::depth: break;
    }
    return "";
}

const char* layout_name(shader::GeometryOutput o) {
    switch (o) {
        case shader::GeometryOutput::points: return "points";
        case shader::GeometryOutput::line_strip: return "line_strip";
        case shader::GeometryOutput::triangle_strip: return "triangle_strip";
    }
    return "?";
}

const StageShader* given(const std::vector<StageShader>& user, ShaderStage stage) {
    for (const StageShader& s : user)
        if (s.stage == stage) return &s;
    return nullptr;
}

class UserProgram final : public PatchProgram<float> {
public:
    // capture_pass: the uniforms of the GL backend's capture pass (the thesis's mvp the
    // identity, so that gl_Position is the world position the mesh keeps); otherwise those
    // of its draw (raster_stage_corners: gl_Position in clip space).
    UserProgram(const Scene& s, std::unique_ptr<PatchProgram<float>> model_program, const std::vector<StageShader>& user,
                bool capture_pass = true)
        : scene(s), model(std::move(model_program)) {
        const EvaluationModel em = scene.evaluation.model;
        const std::string base = twin_base(em);
        // TERRAIN_NORMALS: cosc422_terrain.tese computes the height-field normal (as the GL
        // backend's plan defines it for the twins, not for a user's file).
        const bool terrain_normals = em == EvaluationModel::cosc422 && scene.geometry &&
                                     scene.geometry->normals == GeometryNormals::height_field;
        defines = terrain_normals ? "#define TERRAIN_NORMALS\n" : "";
        const auto compile = [&](ShaderStage stage, const std::string& twin, const std::string& builtin_text) {
            shader::Source src;
            src.stage = stage;
            const StageShader* u = given(user, stage);
            if (u) {
                src.path = u->path;
                src.text = read_user_shader(*u);
            } else if (!twin.empty()) {
                src.path = data_dir() + "/shaders/" + twin;
                src.text = twin_text(twin);
                src.prefix = defines;
                if (stage == ShaderStage::tess_evaluation) src.text = with_generator(src.text, scene.generator, src.path);
            } else {
                src.path = "tessref's constant control shader";
                src.text = builtin_text;
            }
            try {
                return shader::Module::compile(src);
            } catch (const Error& e) {
                if (!u) throw;
                // The user's file as they named it (flag or [shaders] key), as the GL backend's errors do.
                throw Error(std::string(e.what()) + " (" + u->origin + ")", e.where());
            }
        };
        vert.emplace(compile(ShaderStage::vertex, base + ".vert", ""));
        const std::string tesc_file = control_twin(scene);
        if (given(user, ShaderStage::tess_control) || !tesc_file.empty())
            tesc.emplace(compile(ShaderStage::tess_control, tesc_file, ""));
        else if (em == EvaluationModel::thesis)
            tesc.emplace(compile(ShaderStage::tess_control, "", kConstantControlShader));
        tese.emplace(compile(ShaderStage::tess_evaluation, base + ".tese", ""));
        model_levels = !given(user, ShaderStage::vertex) && !given(user, ShaderStage::tess_control);
        if (given(user, ShaderStage::geometry)) geom.emplace(compile(ShaderStage::geometry, "", ""));

        // The GL capture pass's uniforms: the thesis's mvp the identity (gl_Position is the
        // world position there).
        BindingsSink sink(bindings);
        set_stage_uniforms(sink, scene, stage_matrices(scene), scene.camera ? scene.camera->viewport : glm::ivec2(1280, 800));
        if (em == EvaluationModel::thesis && capture_pass) bindings.set("mvp", glm::mat4(1.0f));
        bind_stage_textures(scene, [&](int unit, const Texture* t, const std::string&) { bindings.bind_texture(unit, t); });

        // Where the evaluation shader hands on what the mesh keeps (the twins' EvaluationData).
        switch (em) {
            case EvaluationModel::thesis: uv_location = 0; break;
            case EvaluationModel::cosc422:
                position_location = 0;
                normal_location = terrain_normals ? 1 : -1;
                uv_location = terrain_normals ? 2 : 1;
                break;
            case EvaluationModel::lab4:
            case EvaluationModel::pn:
                position_location = 0;
                normal_location = 1;
                uv_location = 2;
                break;
            case EvaluationModel::geomipmap: break;
        }
        has_uvs = model->has_uvs;
        has_normals = model->has_normals;
        flip = model->flip;
        if (geom) geometry_interface(*given(user, ShaderStage::geometry));
        patches.assign(scene.patch_count(), {});
        executables();
    }

    bool geometry_shader() const override { return geom.has_value(); }

    // The patch's triangles through the evaluation and the user's geometry shader, batched
    // over the whole patch (program.h PatchProgram::geometry). The geometry stage runs in
    // world space: gl_in[i].gl_Position is vec4(the evaluated world position, 1) (the
    // thesis's own gl_Position in the capture pass, mvp the identity; the other models'
    // EvaluationData position), and an emitted vertex's gl_Position.xyz is its world
    // position, which the renderer projects with the camera as it projects every surface.
    // A geometry shader that passes gl_in[].gl_Position on, or combines it affinely (a
    // midpoint, a shrunken copy), draws what GL draws (up to rounding for the combinations);
    // one that works in clip space itself (a perspective divide, an offset in pixels) does not.
    void geometry(std::size_t p, const Pattern& pattern, SurfaceMesh& out, std::vector<glm::dvec3>& face_normals) const override {
        const shader::ShaderPatch& patch = patches[p];
        const std::span<const TessCoord> points = pattern.points();
        std::vector<glm::vec3> tess_coords(points.size());
        for (std::size_t k = 0; k < points.size(); ++k) tess_coords[k] = glm::vec3(points[k].u, points[k].v, points[k].w);
        shader::ShaderVertices evaluated;
        tese_run->evaluate(patch, tess_coords, static_cast<long long>(p), evaluated);
        for (std::size_t k = 0; k < points.size(); ++k) {
            const glm::vec4 world = position_location < 0 || static_cast<std::size_t>(position_location) >= evaluated.location_count
                                        ? evaluated.positions[k]
                                        : shader::as_vec4(evaluated.location(k, static_cast<std::size_t>(position_location)));
            evaluated.positions[k] = glm::vec4(glm::vec3(world), 1.0f);
        }
        std::vector<shader::ShaderPrimitives> primitives;
        geom_run->geometry(evaluated, pattern.indices(), static_cast<long long>(p), primitives);
        std::size_t triangles = 0;
        for (const shader::ShaderPrimitives& prims : primitives) triangles += prims.primitive_count();
        out = SurfaceMesh{};
        out.positions.reserve(3 * triangles);
        out.patch_ids.assign(3 * triangles, static_cast<std::uint32_t>(p));
        out.tess_coords.reserve(3 * triangles);
        if (has_uvs) out.uvs.reserve(3 * triangles);
        if (has_normals) out.normals.reserve(3 * triangles);
        out.triangles.reserve(triangles);
        face_normals.clear();
        const std::span<const std::uint32_t> indices = pattern.indices();
        const auto at = [](const shader::ShaderVertex& v, int location) {
            return location >= 0 && static_cast<std::size_t>(location) < v.locations.size()
                       ? shader::as_vec4(v.locations[static_cast<std::size_t>(location)])
                       : glm::vec4(0.0f);
        };
        for (std::size_t k = 0; k < primitives.size(); ++k) {
            const shader::ShaderPrimitives& prims = primitives[k];
            for (std::size_t t = 0; t < prims.primitive_count(); ++t) {
                const auto first = static_cast<std::uint32_t>(out.positions.size());
                for (std::size_t c = 0; c < 3; ++c) {
                    const std::uint32_t e = prims.indices[3 * t + c];
                    const shader::ShaderVertex& v = prims.vertices[e];
                    out.positions.emplace_back(glm::vec3(v.position));
                    // The tess coord of the input vertex the emitted one follows in order
                    // (emitted vertex e after input vertex e mod 3), as the GL capture's
                    // wrapper of EmitVertex() records it (src/gl/scene_render.cpp).
                    const TessCoord& tc = points[indices[3 * k + e % 3]];
                    out.tess_coords.emplace_back(tc.u, tc.v, tc.w);
                    if (has_uvs) out.uvs.emplace_back(glm::vec2(at(v, geometry_uv_location)));
                    if (has_normals) out.normals.emplace_back(glm::vec3(at(v, geometry_normal_location)));
                }
                if (face_normals_from_geometry)  // the provoking vertex's, the last (GL's default)
                    face_normals.emplace_back(glm::vec3(at(prims.vertices[prims.indices[3 * t + 2]], geometry_normal_location)));
                out.triangles.push_back(flip ? std::array<std::uint32_t, 3>{first, first + 2, first + 1}
                                             : std::array<std::uint32_t, 3>{first, first + 1, first + 2});
            }
        }
    }

    void use_math(MathMode math) override {
        model->use_math(math);
        options.math = math == MathMode::llvmpipe ? shader::MathMode::llvmpipe : shader::MathMode::exact;
        executables();
    }

    PatchLevels<float> control(std::size_t p) override {
        const std::vector<std::vector<shader::Slot>> attributes = vertex_attributes(p);
        std::vector<shader::ShaderVertex> shaded(attributes.size());
        for (std::size_t k = 0; k < attributes.size(); ++k)
            shaded[k] = vert_run->vertex(attributes[k], static_cast<int>(p * attributes.size() + k));
        shader::ShaderPatch& patch = patches[p];
        PatchLevels<float> levels;
        if (tesc_run) {
            patch = tesc_run->control(shaded, static_cast<long long>(p));
            for (int k = 0; k < 4; ++k) levels.outer[k] = patch.outer[k];
            for (int k = 0; k < 2; ++k) levels.inner[k] = patch.inner[k];
        } else {
            // No control shader: the evaluation reads gl_in, the levels are GL_PATCH_DEFAULT_*.
            patch.vertices = std::move(shaded);
            if (scene.control) levels = scene_constant_levels<float>(*scene.control);
        }
        // The levels the domain does not read as the models hold them (1; GL leaves them
        // undefined, the shader may not write them).
        const Domain d = scene.generator.domain;
        const int outer_used = d == Domain::quads ? 4 : d == Domain::triangles ? 3 : 2;
        const int inner_used = d == Domain::quads ? 2 : d == Domain::triangles ? 1 : 0;
        for (int k = outer_used; k < 4; ++k) levels.outer[k] = 1.0f;
        for (int k = inner_used; k < 2; ++k) levels.inner[k] = 1.0f;
        // The model's control stage runs as well: its levels where the user changed neither
        // stage that makes them, and what its geometry stage reads of the patch.
        const PatchLevels<float> model_patch_levels = model->control(p);
        if (model_levels) levels = model_patch_levels;
        // The generator's levels are what the evaluation shader reads.
        for (int k = 0; k < 4; ++k) patch.outer[k] = levels.outer[k];
        for (int k = 0; k < 2; ++k) patch.inner[k] = levels.inner[k];
        return levels;
    }

    void evaluate(std::size_t p, std::span<const DomainPoint<float>> points, SurfaceMesh& mesh, std::size_t first_vertex,
                  bool normals) const override {
        const shader::ShaderPatch& patch = patches[p];
        const bool model_normals = has_normals && normals && normal_location < 0;
        std::vector<glm::vec3> position(points.size()), normal(model_normals ? points.size() : 0);
        std::vector<glm::vec2> uv(points.size());
        std::vector<glm::vec3> tess_coords(points.size());
        for (std::size_t k = 0; k < points.size(); ++k) tess_coords[k] = glm::vec3(points[k].u, points[k].v, points[k].w);
        shader::ShaderVertices evaluated;
        tese_run->evaluate(patch, tess_coords, static_cast<long long>(p), evaluated);
        // Location j of vertex k as a vec4 (zero where the shader writes none).
        const auto at = [&](std::size_t k, int j) {
            return j >= 0 && static_cast<std::size_t>(j) < evaluated.location_count ? shader::as_vec4(evaluated.location(k, static_cast<std::size_t>(j)))
                                                                                    : glm::vec4(0.0f);
        };
        for (std::size_t k = 0; k < points.size(); ++k) {
            position[k] = position_location < 0 ? glm::vec3(evaluated.positions[k]) : glm::vec3(at(k, position_location));
            uv[k] = glm::vec2(at(k, uv_location));
            const std::size_t v = first_vertex + k;
            mesh.positions[v] = glm::dvec3(position[k]);
            if (has_uvs) mesh.uvs[v] = glm::dvec2(uv[k]);
            if (has_normals && normals && normal_location >= 0) mesh.normals[v] = glm::dvec3(glm::vec3(at(k, normal_location)));
        }
        if (model_normals) {
            model->geometry_normals(p, points, position, uv, normal);
            for (std::size_t k = 0; k < points.size(); ++k) mesh.normals[first_vertex + k] = glm::dvec3(normal[k]);
        }
    }

    // One invocation with an observer (`tessref trace`).
    StageTrace trace(const StageTraceRequest& r, shader::Observer& observer) {
        shader::RunOptions traced = options;
        traced.observer = &observer;
        StageTrace t;
        const std::vector<std::vector<shader::Slot>> attributes = vertex_attributes(r.patch);
        t.vertices_per_patch = static_cast<int>(attributes.size());
        switch (r.stage) {
            case ShaderStage::vertex: {
                if (r.vertex < 0 || static_cast<std::size_t>(r.vertex) >= attributes.size())
                    throw Error("vertex " + std::to_string(r.vertex) + " is not one of the patch's " +
                                    std::to_string(attributes.size()) + " vertices (0.." +
                                    std::to_string(attributes.size() - 1) + ")",
                                Where::in_file("--vertex"));
                t.shader = vert->path();
                const shader::Executable run(*vert, bindings, traced);
                const std::size_t k = static_cast<std::size_t>(r.vertex);
                t.vertex = run.vertex(attributes[k], static_cast<int>(r.patch * attributes.size() + k));
                return t;
            }
            case ShaderStage::tess_control: {
                if (!tesc)
                    throw Error("the scene has no control shader (a constant control stage whose evaluation shader reads "
                                "gl_in directly)",
                                Where::in_file("--stage"));
                t.shader = tesc->path();
                std::vector<shader::ShaderVertex> shaded(attributes.size());
                for (std::size_t k = 0; k < attributes.size(); ++k)
                    shaded[k] = vert_run->vertex(attributes[k], static_cast<int>(r.patch * attributes.size() + k));
                const shader::Executable run(*tesc, bindings, traced);
                t.patch = run.control(shaded, static_cast<long long>(r.patch));
                return t;
            }
            case ShaderStage::tess_evaluation: {
                t.shader = tese->path();
                control(r.patch);  // the patch as the evaluation reads it (the levels the generator used)
                t.patch = patches[r.patch];
                const shader::Executable run(*tese, bindings, traced);
                t.vertex = run.evaluate(patches[r.patch], r.tess_coord, static_cast<long long>(r.patch));
                return t;
            }
            case ShaderStage::geometry: {
                // The triangle's corners through the evaluation shader, then the geometry shader.
                const std::optional<shader::Source> src = geometry_source();
                if (!src)
                    throw Error("the scene has no geometry stage (neither a geometry shader in [shaders] nor a "
                                "[geometry] whose model has one: thesis normal_map, cosc422 face)",
                                Where::in_file("--stage"));
                const shader::Module geom = shader::Module::compile(*src);
                t.shader = geom.path();
                control(r.patch);
                const std::vector<glm::vec3> corners(r.triangle.begin(), r.triangle.end());
                t.inputs = tese_run->evaluate(patches[r.patch], corners, static_cast<long long>(r.patch));
                const shader::Executable run(geom, bindings, traced);
                t.primitives = run.geometry(t.inputs, static_cast<long long>(r.patch));
                return t;
            }
            case ShaderStage::fragment: break;
        }
        throw Error(std::string("the CPU does not run the ") + to_string(r.stage) + " stage (vert, tesc, tese or geom)",
                    Where::in_file("--stage"));
    }

    // Every triangle's corners of `mesh` (this program's pipeline result) as the last stage
    // before the rasterizer hands them on: three a triangle, in the order GL draws them (the
    // primitive generator's, before the mesh's flip), each with gl_Position and the locations
    // written by the evaluation shader, or by the geometry shader where the scene has one.
    std::vector<shader::ShaderVertex> corners(const SurfaceMesh& mesh) {
        for (std::size_t p = 0; p < patches.size(); ++p) control(p);  // the patches the evaluation reads
        // Each patch's vertices are one run of the mesh (the generator's points, in order).
        struct Run {
            std::size_t patch, first, last;
        };
        std::vector<Run> runs;
        for (std::size_t v = 0; v < mesh.patch_ids.size(); ++v) {
            if (runs.empty() || runs.back().patch != mesh.patch_ids[v]) runs.push_back({mesh.patch_ids[v], v, v});
            runs.back().last = v + 1;
        }
        std::vector<shader::ShaderVertex> evaluated(mesh.patch_ids.size());
        tessref::parallel_for(std::size_t{0}, runs.size(), [&](std::size_t r) {
            const Run& run = runs[r];
            std::vector<glm::vec3> tess_coords(run.last - run.first);
            for (std::size_t v = run.first; v < run.last; ++v) tess_coords[v - run.first] = glm::vec3(mesh.tess_coords[v]);
            shader::ShaderVertices out;
            tese_run->evaluate(patches[run.patch], tess_coords, static_cast<long long>(run.patch), out);
            for (std::size_t k = 0; k < out.size(); ++k) evaluated[run.first + k] = out.vertex(k);
        });
        std::vector<shader::ShaderVertex> corners(mesh.triangles.size() * 3);
        const std::optional<shader::Source> geometry = geometry_source();
        std::optional<shader::Executable> geom;
        if (geometry) geom.emplace(shader::Module::compile(*geometry), bindings, options);
        tessref::parallel_for(std::size_t{0}, mesh.triangles.size(), [&](std::size_t t) {
            const auto& tri = mesh.triangles[t];
            const std::array<std::uint32_t, 3> gl = flip ? std::array<std::uint32_t, 3>{tri[0], tri[2], tri[1]} : tri;
            if (!geom) {
                for (std::size_t k = 0; k < 3; ++k) corners[3 * t + k] = evaluated[gl[k]];
                return;
            }
            const std::array<shader::ShaderVertex, 3> in{evaluated[gl[0]], evaluated[gl[1]], evaluated[gl[2]]};
            const long long patch = static_cast<long long>(mesh.patch_ids[tri[0]]);
            const shader::ShaderPrimitives made = geom->geometry(in, patch);
            if (made.output != shader::GeometryOutput::triangle_strip || made.primitive_count() != 1)
                throw Error("the geometry shader made " + std::to_string(made.primitive_count()) +
                                " primitives of patch " + std::to_string(patch) +
                                "'s triangle: a user's fragment shader is run after a geometry stage that emits one "
                                "triangle per triangle only",
                            Where::in_file(geom->module().path()));
            for (std::size_t k = 0; k < 3; ++k) corners[3 * t + k] = made.vertices[made.indices[k]];
        });
        return corners;
    }

private:
    // The scene's geometry stage: a user's geometry shader, or the model's twin (thesis
    // normal_map, cosc422 face); none without either.
    std::optional<shader::Source> geometry_source() const {
        const StageShader* user_geometry = given(scene.shaders, ShaderStage::geometry);
        const std::string twin = geometry_twin(scene);
        if (!user_geometry && twin.empty()) return std::nullopt;
        shader::Source src;
        src.stage = ShaderStage::geometry;
        if (user_geometry) {
            src.path = user_geometry->path;
            src.text = read_user_shader(*user_geometry);
        } else {
            src.path = data_dir() + "/shaders/" + twin;
            src.text = twin_text(twin);
            src.prefix = defines;
        }
        return src;
    }

    // The patch's vertices as the GL backend's vertex buffer holds them: a terrain's four
    // corners vec4(ground, 1) at location 0 (control.h's corner order), a PN triangle's
    // position, normal and uv at locations 0, 1, 2.
    std::vector<std::vector<shader::Slot>> vertex_attributes(std::size_t p) const {
        std::vector<std::vector<shader::Slot>> out;
        if (scene.grid) {
            const TerrainGrid& g = *scene.grid;
            const std::size_t i = p % static_cast<std::size_t>(g.patches_u), j = p / static_cast<std::size_t>(g.patches_u);
            const std::size_t c[4][2] = {{i, j}, {i, j + 1}, {i + 1, j + 1}, {i + 1, j}};
            for (const auto& k : c) {
                const float u = static_cast<float>(g.u_coords[k[0]]), v = static_cast<float>(g.v_coords[k[1]]);
                out.push_back({shader::slot(g.plane == GroundPlane::xy ? glm::vec4(u, v, 0.0f, 1.0f)
                                                                        : glm::vec4(u, 0.0f, v, 1.0f))});
            }
            return out;
        }
        const TriangleMeshes& m = *scene.meshes;
        for (std::uint32_t v : m.triangles[p]) {
            const glm::vec2 uv = m.uvs.empty() ? glm::vec2(0.0f) : glm::vec2(m.uvs[v]);
            out.push_back({shader::slot(glm::vec4(glm::vec3(m.positions[v]), 0.0f)),
                           shader::slot(glm::vec4(glm::vec3(m.normals[v]), 0.0f)), shader::slot(glm::vec4(uv, 0.0f, 0.0f))});
        }
        return out;
    }

    void executables() {
        vert_run.emplace(*vert, bindings, options);
        if (tesc) tesc_run.emplace(*tesc, bindings, options);
        tese_run.emplace(*tese, bindings, options);
        if (geom) geom_run.emplace(*geom, bindings, options);
    }

    // Where the user's geometry shader hands on what the render and the mesh read, by
    // location, as GL links it to the fragment stage: after a model's geometry twin, its
    // GeometryData block (location 0 the normal, 1 the texture coordinate: the fragment
    // twins read gNormal / faceNormal and the coordinate there); elsewhere the evaluation
    // shader's locations, which the fragment twins read and a geometry shader in between
    // must hand on. Refuses a layout or outputs the pipeline cannot take.
    void geometry_interface(const StageShader& user) {
        const shader::GeometryLayout layout = geom->geometry_layout();
        const std::string who = "the geometry shader " + user.path + " (" + user.origin + ")";
        if (layout.input_vertices != 3)
            throw Error(who + " takes primitives of " + std::to_string(layout.input_vertices) +
                            " vertices; the primitive generator hands it triangles: layout(triangles) in;",
                        Where::in_file(user.path));
        if (layout.output != shader::GeometryOutput::triangle_strip)
            throw Error(who + " emits layout(" + layout_name(layout.output) + ") out; the pipeline (render, mesh, capture) "
                            "takes triangles only: layout(triangle_strip, max_vertices = N) out;",
                        Where::in_file(user.path));
        if (scene.generator.domain == Domain::isolines || scene.generator.point_mode)
            throw Error(who + " needs triangles, but the scene's [generator] makes " +
                            (scene.generator.point_mode ? std::string("points") : std::string("isolines")),
                        Where::at_key(scene.file, "generator"));
        if (scene.geometry && scene.geometry->normals == GeometryNormals::smooth)
            throw Error(who + " replaces the geometry stage, but [geometry] normals = \"smooth\" is the C++ stage's "
                            "sum over the whole surface, which has no shader to replace",
                        Where::at_key(scene.file, "geometry.normals"));
        const bool twin = !geometry_twin(scene).empty();
        geometry_normal_location = twin ? 0 : normal_location;
        geometry_uv_location = twin ? 1 : uv_location;
        face_normals_from_geometry = scene.geometry && scene.geometry->normals == GeometryNormals::face;
        if (has_normals && !face_normals_from_geometry && geometry_normal_location < 0)
            throw Error(who + " replaces the geometry stage, but the scene's per-vertex normals ([geometry] normals = \"" +
                            to_string(scene.geometry->normals) + "\") come from the C++ geometry stage, "
                            "which reads the evaluation's domain points",
                        Where::at_key(scene.file, "geometry.normals"));
        const std::vector<shader::Module::Output> outputs = geom->outputs();
        const auto require = [&](bool needed, int location, int components, const char* what) {
            if (!needed) return;
            const bool written = std::any_of(outputs.begin(), outputs.end(), [&](const shader::Module::Output& o) {
                return o.location == location && o.components >= components;
            });
            if (!written)
                throw Error(who + " has no output at location " + std::to_string(location) + " of " +
                                std::to_string(components) + " components, where the fragment stage reads " + what +
                                " (layout(location = " + std::to_string(location) + ") out ...)",
                            Where::in_file(user.path));
        };
        require(has_normals || face_normals_from_geometry, geometry_normal_location, 3, "the normal");
        require(has_uvs && geometry_uv_location >= 0, geometry_uv_location, 2, "the texture coordinate");
    }

    const Scene& scene;
    std::string defines;  // the GL backend's #defines for the twins
    std::unique_ptr<PatchProgram<float>> model;  // levels (when the user gave no vertex or control shader), normals
    bool model_levels = false;
    std::optional<shader::Module> vert, tesc, tese, geom;
    shader::Bindings bindings;
    shader::RunOptions options;
    std::optional<shader::Executable> vert_run, tesc_run, tese_run, geom_run;
    int geometry_normal_location = -1;  // a user's geometry shader: where its outputs are read
    int geometry_uv_location = -1;
    bool face_normals_from_geometry = false;  // [geometry] normals = "face": the provoking vertex's normal
    int position_location = -1;  // -1: gl_Position.xyz
    int normal_location = -1;    // -1: the model's geometry stage
    int uv_location = -1;
    std::vector<shader::ShaderPatch> patches;  // per patch: the control stage's output
};

}  // namespace

std::vector<StageShader> interpreted_stages(const Scene& scene) {
    std::vector<StageShader> out;
    const char* base = twin_base(scene.evaluation.model);
    if (!base) return out;  // geomipmap: no tessellation stages to run
    for (const StageShader& s : scene.shaders) {
        if (s.stage == ShaderStage::fragment) continue;  // not in the pipeline (a fragment shader: the render's)
        // A file whose text is exactly the shipped twin's is the twin: the C++ model, which
        // the twin is proven to compute bit for bit, is the fast path for it. Any other text
        // (a changed constant, a comment) runs through the interpreter.
        if (is_twin(scene, s)) continue;
        out.push_back(s);
    }
    return out;
}

std::string twin_file(const Scene& scene, ShaderStage stage) {
    const char* base = twin_base(scene.evaluation.model);
    switch (stage) {
        case ShaderStage::vertex: return base ? std::string(base) + ".vert" : "";
        case ShaderStage::tess_control: return control_twin(scene);
        case ShaderStage::tess_evaluation: return base ? std::string(base) + ".tese" : "";
        case ShaderStage::geometry: return geometry_twin(scene);
        case ShaderStage::fragment: return fragment_twin(scene.shading.model.kind);
    }
    return "";
}

std::string twin_text(const std::string& file) {
    return read_input_file(data_dir() + "/shaders/" + file, "shader file", kShaderFileBytes);
}

bool is_twin(const Scene& scene, const StageShader& user) {
    const std::string twin = twin_file(scene, user.stage);
    return !twin.empty() && read_user_shader(user) == twin_text(twin);
}

StageTrace trace_stage(const Scene& scene, const StageTraceRequest& request, shader::Observer& observer) {
    if (!twin_base(scene.evaluation.model))
        throw Error("a geomipmapped terrain has no tessellation stages to trace (its vertex shader is the CPU's "
                    "geomorph)",
                    Where::at_key(scene.file, "evaluation.model"));
    if (request.patch >= scene.patch_count())
        throw Error("patch " + std::to_string(request.patch) + " is not one of the scene's " +
                        std::to_string(scene.patch_count()) + " patches (0.." + std::to_string(scene.patch_count() - 1) + ")",
                    Where::in_file("--patch"));
    StageTraceRequest r = request;
    if (r.stage == ShaderStage::tess_evaluation) {
        const glm::vec3 tc = r.tess_coord;
        const bool triangles = scene.generator.domain == Domain::triangles;
        if (!(tc.x >= 0.0f && tc.x <= 1.0f && tc.y >= 0.0f && tc.y <= 1.0f) || (triangles && tc.x + tc.y > 1.0f))
            throw Error(std::string("the tess coord must lie in the ") + (triangles ? "triangle u, v >= 0, u + v <= 1"
                                                                                    : "square [0, 1] x [0, 1]"),
                        Where::in_file("--tess-coord"));
        r.tess_coord.z = triangles ? (1.0f - tc.x) - tc.y : 0.0f;  // gl_TessCoord's w, as the generator computes it
    }
    if (r.stage == ShaderStage::geometry) {
        // The primitive's corners as the pipeline emits them for GL (capture.h: the
        // generator's order, each triangle's corners as emitted), with the scene's shaders.
        PipelineOptions options;
        options.math = request.math;
        const std::vector<CapturedVertex> capture = capture_from_pipeline(scene, run_pipeline(scene, options));
        std::vector<std::size_t> corners;
        for (std::size_t k = 0; k < capture.size(); ++k)
            if (capture[k].patch_id == request.patch) corners.push_back(k);
        const std::size_t triangles = corners.size() / 3;
        if (request.primitive >= triangles)
            throw Error("primitive " + std::to_string(request.primitive) + " is not one of patch " +
                            std::to_string(request.patch) + "'s " + std::to_string(triangles) + " triangles" +
                            (triangles ? " (0.." + std::to_string(triangles - 1) + ")" : ""),
                        Where::in_file("--primitive"));
        for (std::size_t i = 0; i < 3; ++i) r.triangle[i] = capture[corners[3 * request.primitive + i]].tess_coord;
    }
    std::unique_ptr<PatchProgram<float>> model = make_model_program<float>(scene, glm::dvec3(0.0));
    UserProgram program(scene, std::move(model), interpreted_stages(scene));
    program.use_math(request.math);
    return program.trace(r, observer);
}

RasterStageCorners raster_stage_corners(const Scene& scene, const SurfaceMesh& mesh, MathMode math) {
    if (!twin_base(scene.evaluation.model))
        throw Error("a user's fragment shader after a geomipmapped terrain is not run on the CPU (it has no "
                    "tessellation stages for the interpreter to run)",
                    Where::at_key(scene.file, "evaluation.model"));
    if (const StageShader* g = given(scene.shaders, ShaderStage::geometry))
        throw Error("a user's fragment shader after a user's geometry shader is not run by render yet (the surface is "
                    "the geometry shader's triangles, whose corners the fragment stage would need as emitted)",
                    g->where);
    UserProgram program(scene, make_model_program<float>(scene, glm::dvec3(0.0)), interpreted_stages(scene), false);
    program.use_math(math);
    RasterStageCorners out;
    out.corners = program.corners(mesh);
    out.flipped = program.flip;
    return out;
}

std::unique_ptr<PatchProgram<float>> make_user_program(const Scene& scene, std::unique_ptr<PatchProgram<float>> model,
                                                       const std::vector<StageShader>& user) {
    return std::make_unique<UserProgram>(scene, std::move(model), user);
}

}  // namespace tessref::pipeline
