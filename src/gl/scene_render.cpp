// A scene through its GLSL twins on llvmpipe (gl_render.h, render_scene): `tessref gl`.
//
// Per draw: the patches' corners (terrain) or triangles (PN) -> the twins -> a float colour
// buffer with a 24-bit depth buffer, depth LESS, as `tessref render` draws. Every draw's
// GL_PRIMITIVES_GENERATED is held against the CPU pipeline's count of the same patches.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "common/input_file.h"
#include "common/isolated.h"
#include "gl/gl_api.h"
#include "gl/program.h"
#include "pipeline/stage_uniforms.h"
#include "tessref/error.h"
#include "tessref/gl_render.h"
#include "tessref/limits.h"
#include "tessref/pipeline.h"
#include "tessref/shader.h"

namespace tessref::gl {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
}

// ---- the programs: which twin for which scene ------------------------------------------

// The "no shading" modes of shading.h have no twin: flat_colour and depth_colour here.
const char* kFlatFragmentShader = R"(#version 450 core
layout(location = 0) out vec4 fragment;
uniform vec4 colour;
void main() { fragment = colour; }
)";
const char* kDepthFragmentShader = R"(#version 450 core
layout(location = 0) out vec4 fragment;
uniform int windowMapping;
uniform double nearPlane;
uniform double farPlane;
void main()
{
    if (windowMapping == 1) { fragment = vec4(vec3(gl_FragCoord.z), 1.0); return; }
    double zNdc = 2.0 * double(gl_FragCoord.z) - 1.0;
    double zEye = 2.0 * nearPlane * farPlane / (farPlane + nearPlane - zNdc * (farPlane - nearPlane));
    fragment = vec4(vec3(float((zEye - nearPlane) / (farPlane - nearPlane))), 1.0);
}
)";

// geomip_terrain.frag's sampler arrays: materials[4], alphaMaps[4].
constexpr std::size_t kGeomipMaxMaterials = 4;

struct Plan {
    std::vector<StageSource> stages;
    bool has_control_shader = false;
    bool has_geometry_shader = false;
    std::string position_expression;  // world position in the evaluation shader (capture)
    std::string normal_expression;    // the normal in the last stage before rasterization
    bool identity_mvp_for_capture = false;
    // A geomipmapped terrain: triangles the CPU built, drawn with the geomorphing vertex
    // shader and no tessellation stages; its capture wraps the vertex shader.
    bool geomipmap = false;
    // #defines for the twins' files (not a user's): TERRAIN_NORMALS, with which
    // cosc422_terrain.tese computes the height-field normal and pom.frag reads the terrain's
    // EvaluationData block.
    std::string defines;
};

StageSource file_stage(GLenum stage, const std::string& file) {
    StageSource s;
    s.stage = stage;
    s.path = shader_data_dir() + "/shaders/" + file;
    s.text = read_shader(file);
    return s;
}
// The shading model's fragment twin (the one table of twin files: pipeline::twin_file).
StageSource fragment_twin_stage(const Scene& scene) {
    return file_stage(GL_FRAGMENT_SHADER, pipeline::twin_file(scene, ShaderStage::fragment));
}
StageSource text_stage(GLenum stage, const char* text) {
    StageSource s;
    s.stage = stage;
    s.text = text;
    return s;
}


// Geomipmapping (geomipmap.h): the CPU chose the levels and built the triangles, adapting
// borders included, as the geomorphing article's application does; geomip_terrain.vert
// moves each vertex by its tween, and the normals of a [geometry] stage are the CPU's,
// handed on as a vertex attribute (the article lights the terrain with its light map
// instead). The fragment shaders that read GeometryData { gNormal, gTextureCoordinate }
// take its output: the thesis's, geomip_terrain.frag (geomip_lightmap) and the no-shading
// ones.
Plan geomip_plan(const Scene& scene, const RenderShading& shading) {
    Plan plan;
    plan.geomipmap = true;
    plan.position_expression = "gl_Position.xyz";  // mvp = identity in the capture pass
    plan.identity_mvp_for_capture = true;
    plan.normal_expression = "vertexOut.gNormal";
    plan.stages.push_back(file_stage(GL_VERTEX_SHADER, "geomip_terrain.vert"));
    switch (shading.model.kind) {
        case ShadingKind::flat: plan.stages.push_back(text_stage(GL_FRAGMENT_SHADER, kFlatFragmentShader)); break;
        case ShadingKind::depth: plan.stages.push_back(text_stage(GL_FRAGMENT_SHADER, kDepthFragmentShader)); break;
        case ShadingKind::geomip_lightmap:
            if (shading.model.geomip.materials.size() > kGeomipMaxMaterials)
                throw Error("tessref gl: geomip_terrain.frag blends at most " + std::to_string(kGeomipMaxMaterials) +
                                " materials, the scene has " + std::to_string(shading.model.geomip.materials.size()),
                            Where::at_key(scene.file, "shading.materials"));
            [[fallthrough]];
        case ShadingKind::thesis_single:
        case ShadingKind::thesis_multi: plan.stages.push_back(fragment_twin_stage(scene)); break;
        case ShadingKind::lab4:
        case ShadingKind::cosc422:
        case ShadingKind::pn:
        case ShadingKind::pom:
            throw Error(std::string("tessref gl: shading model '") + to_string(shading.model.kind) +
                            "' with evaluation model geomipmap has no GLSL twin (its fragment shader reads another "
                            "stage's outputs than geomip_terrain.vert writes)",
                        Where::at_key(scene.file, "shading.model"));
    }
    if (plan.stages.back().stage != GL_FRAGMENT_SHADER)  // a shading model added later, not listed above
        throw Error(std::string("tessref gl: shading model '") + to_string(shading.model.kind) +
                        "' with evaluation model geomipmap has no GLSL twin",
                    Where::at_key(scene.file, "shading.model"));
    return plan;
}

Plan plan_for(const Scene& scene, const RenderShading& shading) {
    Plan plan;
    const EvaluationModel em = scene.evaluation.model;
    switch (em) {
        case EvaluationModel::thesis:
            plan.position_expression = "gl_Position.xyz";  // mvp = identity in the capture pass
            plan.identity_mvp_for_capture = true;
            break;
        case EvaluationModel::cosc422:
            plan.position_expression = "evaluationOut.worldPosition";
            break;
        case EvaluationModel::lab4:
            plan.position_expression = "evaluationOut.worldPosition";
            plan.normal_expression = "evaluationOut.normal";
            break;
        case EvaluationModel::pn:
            plan.position_expression = "evaluationOut.v3PositionOut";
            plan.normal_expression = "evaluationOut.v3NormalOut";
            break;
        case EvaluationModel::geomipmap: return geomip_plan(scene, shading);
    }
    plan.stages.push_back(file_stage(GL_VERTEX_SHADER, pipeline::twin_file(scene, ShaderStage::vertex)));

    // Control: the model's twin; constant (or none, levels 1): a pass-through shader or none.
    if (scene.control && scene.control->model != ControlModel::constant) {
        plan.stages.push_back(file_stage(GL_TESS_CONTROL_SHADER, pipeline::twin_file(scene, ShaderStage::tess_control)));
        plan.has_control_shader = true;
    } else if (em == EvaluationModel::thesis) {
        plan.stages.push_back(text_stage(GL_TESS_CONTROL_SHADER, pipeline::kConstantControlShader));
        plan.has_control_shader = true;
    } else if (em != EvaluationModel::cosc422) {
        throw Error(std::string("tessref gl: a constant control stage with evaluation model '") + to_string(em) +
                        "' has no GLSL twin (its evaluation shader reads the outputs of its own control shader)",
                    Where::at_key(scene.file, "control.model"));
    }

    StageSource tese = file_stage(GL_TESS_EVALUATION_SHADER, pipeline::twin_file(scene, ShaderStage::tess_evaluation));
    tese.text = pipeline::with_generator(tese.text, scene.generator, tese.path);
    plan.stages.push_back(std::move(tese));

    if (scene.geometry) {
        const GeometryNormals n = scene.geometry->normals;
        if (em == EvaluationModel::thesis && n == GeometryNormals::normal_map) {
            plan.stages.push_back(file_stage(GL_GEOMETRY_SHADER, pipeline::twin_file(scene, ShaderStage::geometry)));
            plan.normal_expression = "geometryOut.gNormal";
        } else if (em == EvaluationModel::cosc422 && n == GeometryNormals::face) {
            plan.stages.push_back(file_stage(GL_GEOMETRY_SHADER, pipeline::twin_file(scene, ShaderStage::geometry)));
            plan.normal_expression = "geometryOut.faceNormal";
        } else if (em == EvaluationModel::cosc422 && n == GeometryNormals::height_field) {
            // No geometry stage: cosc422_terrain.tese computes the normal per vertex, as the
            // CPU's geometry stage does (pipeline/terrain.cpp, height_field_normal), and hands
            // it on in EvaluationData { worldPosition, normal, texCoord }. Only the fragment
            // shaders that read that block or nothing can follow it.
            const ShadingKind k = shading.model.kind;
            if (k != ShadingKind::pom && k != ShadingKind::flat && k != ShadingKind::depth)
                throw Error(std::string("tessref gl: [geometry] normals = \"height_field\" with evaluation model "
                                        "cosc422 has a GLSL twin for shading models pom, flat and depth only (not '") +
                                to_string(k) + "', whose fragment shader reads another stage's outputs)",
                            Where::at_key(scene.file, "geometry.normals"));
            plan.defines = "#define TERRAIN_NORMALS\n";
            plan.normal_expression = "evaluationOut.normal";
        } else if (!(em == EvaluationModel::lab4 && n == GeometryNormals::height_field)) {
            throw Error(std::string("tessref gl: [geometry] normals = \"") + to_string(n) + "\" with evaluation model '" +
                            to_string(em) + "' has no GLSL twin",
                        Where::at_key(scene.file, "geometry.normals"));
        }
        plan.has_geometry_shader = plan.stages.back().stage == GL_GEOMETRY_SHADER;
    }

    switch (shading.model.kind) {
        case ShadingKind::flat: plan.stages.push_back(text_stage(GL_FRAGMENT_SHADER, kFlatFragmentShader)); break;
        case ShadingKind::depth: plan.stages.push_back(text_stage(GL_FRAGMENT_SHADER, kDepthFragmentShader)); break;
        case ShadingKind::thesis_single:
        case ShadingKind::thesis_multi:
        case ShadingKind::lab4:
        case ShadingKind::cosc422:
        case ShadingKind::pn: plan.stages.push_back(fragment_twin_stage(scene)); break;
        case ShadingKind::geomip_lightmap:
            throw Error("tessref gl: shading model geomip_lightmap shades a geomipmapped terrain: it needs "
                        "evaluation model geomipmap",
                        Where::at_key(scene.file, "shading.model"));
        case ShadingKind::pom:
            // pom.frag reads the PN evaluation shader's EvaluationData block, or with
            // TERRAIN_NORMALS cosc422_terrain.tese's (set above for height-field normals); the
            // other terrain programs hand the fragment stage blocks without the normal it needs.
            if (em != EvaluationModel::pn && plan.defines.empty())
                throw Error("tessref gl: shading model pom has a GLSL twin for evaluation model pn, and cosc422 with "
                            "[geometry] normals = \"height_field\", only (not '" + std::string(to_string(em)) + "'" +
                                (scene.geometry ? std::string(" with normals = \"") + to_string(scene.geometry->normals) + "\""
                                                : std::string(" without [geometry]")) +
                                ")",
                            Where::at_key(scene.file, "shading.model"));
            plan.stages.push_back(fragment_twin_stage(scene));
            break;
    }
    for (StageSource& s : plan.stages) s.prefix = plan.defines + s.prefix;
    return plan;
}

// ---- user shaders: [shaders] and --shader ----------------------------------------------

GLenum gl_stage(ShaderStage stage) {
    switch (stage) {
        case ShaderStage::vertex: return GL_VERTEX_SHADER;
        case ShaderStage::tess_control: return GL_TESS_CONTROL_SHADER;
        case ShaderStage::tess_evaluation: return GL_TESS_EVALUATION_SHADER;
        case ShaderStage::geometry: return GL_GEOMETRY_SHADER;
        case ShaderStage::fragment: return GL_FRAGMENT_SHADER;
    }
    return GL_VERTEX_SHADER;
}

// The scene's [shaders], each replaced by the option of the same stage where there is one.
std::vector<StageShader> user_shaders(const Scene& scene, const SceneRenderOptions& options) {
    return pipeline::with_shader_flags(scene.shaders, options.shaders);
}

StageSource user_stage(const StageShader& user) {
    std::string text = pipeline::read_user_shader(user);
    StageSource s;
    s.stage = gl_stage(user.stage);
    s.path = user.path;
    s.origin = user.origin;
    s.text = std::move(text);
    return s;
}

// Each user file in place of its stage's twin, or added where the models have no such stage
// (GL links the stages by kind, the order only keeps the plan readable). A user's evaluation
// shader keeps its own layout(...) in; line: it is what the user wants tested, and a layout
// other than the scene's [generator] shows as draw counts other than the CPU reference's.
void apply_user_shaders(Plan& plan, const std::vector<StageShader>& shaders) {
    const auto order = [](GLenum stage) {
        const GLenum pipeline[] = {GL_VERTEX_SHADER, GL_TESS_CONTROL_SHADER, GL_TESS_EVALUATION_SHADER,
                                   GL_GEOMETRY_SHADER, GL_FRAGMENT_SHADER};
        return std::find(std::begin(pipeline), std::end(pipeline), stage) - std::begin(pipeline);
    };
    for (const StageShader& user : shaders) {
        StageSource s = user_stage(user);
        auto it = std::find_if(plan.stages.begin(), plan.stages.end(),
                               [&](const StageSource& p) { return p.stage == s.stage; });
        if (it != plan.stages.end()) {
            *it = std::move(s);
            continue;
        }
        if (s.stage == GL_TESS_CONTROL_SHADER) plan.has_control_shader = true;
        if (s.stage == GL_GEOMETRY_SHADER) {
            plan.has_geometry_shader = true;
            plan.normal_expression.clear();  // the evaluation shader's normal is not the geometry stage's
        }
        it = std::find_if(plan.stages.begin(), plan.stages.end(),
                          [&](const StageSource& p) { return order(p.stage) > order(s.stage); });
        plan.stages.insert(it, std::move(s));
    }
}

// The user's files that can change how many primitives a draw makes (all but fragment),
// for the message of a draw whose count is not the CPU reference's.
std::string count_note(const Plan& plan) {
    std::string files;
    bool evaluation = false;
    for (const StageSource& s : plan.stages) {
        if (s.origin.empty() || s.stage == GL_FRAGMENT_SHADER) continue;
        files += std::string(files.empty() ? "" : ", ") + stage_name(s.stage) + " " + s.path;
        evaluation = evaluation || s.stage == GL_TESS_EVALUATION_SHADER;
    }
    if (files.empty()) return "";
    return "; the user's shaders (" + files + ") generated a different number of primitives than the reference " +
           "models predict" +
           (evaluation ? " (a user's evaluation shader keeps its own layout(...) in; the reference tessellates "
                         "as the scene's [generator])"
                       : "");
}

// The capture program: the same stages, no fragment shader; the evaluation shader also hands
// on gl_TessCoord, gl_PrimitiveID and the world position, and the geometry shader (if any)
// passes them through with each EmitVertex (the twins' main and EmitVertex are renamed by the
// preprocessor and wrapped, the twins' text is not changed). The geometry stage's capture
// records, for the e-th vertex an invocation emits, the tess coord, patch and evaluated
// position of its input vertex e mod 3 (a pass-through shader's own corner; a shader that
// emits more vertices than it reads, its corners again), and the normal expression as the
// emitting shader computed it: a user's geometry shader in place of a twin must declare
// the twin's output block (geometryOut.gNormal / faceNormal), as the CPU reads it by
// location (src/pipeline/user_program.cpp).
std::vector<StageSource> capture_stages(const Plan& plan) {
    std::vector<StageSource> stages;
    const std::string normal = plan.normal_expression.empty() ? "vec3(0.0)" : plan.normal_expression;
    for (const StageSource& s : plan.stages) {
        if (s.stage == GL_FRAGMENT_SHADER) continue;
        StageSource c = s;
        if (plan.geomipmap && s.stage == GL_VERTEX_SHADER) {
            // No primitive generator: the tess coord, patch and levels are the CPU's, carried
            // as vertex attributes 6..9 (vertex_data) and handed on with the vertex.
            c.prefix = s.prefix + "layout(location = 6) in int tessref_patch_id;\nlayout(location = 7) in vec3 tessref_tess_coord;\n"
                       "layout(location = 8) in vec4 tessref_outer;\nlayout(location = 9) in vec2 tessref_inner;\n"
                       "out vec3 tessref_cap_tess_coord;\nflat out int tessref_cap_patch_id;\nout vec3 "
                       "tessref_cap_position;\nout vec3 tessref_cap_normal;\nout vec4 tessref_cap_outer;\nout vec2 "
                       "tessref_cap_inner;\n#define main tessref_twin_main\n";
            c.suffix = "#undef main\nvoid main()\n{\n    tessref_twin_main();\n"
                       "    tessref_cap_tess_coord = tessref_tess_coord;\n    tessref_cap_patch_id = tessref_patch_id;\n"
                       "    tessref_cap_position = " + plan.position_expression + ";\n    tessref_cap_normal = " + normal +
                       ";\n    tessref_cap_outer = tessref_outer;\n    tessref_cap_inner = tessref_inner;\n}\n";
        } else if (s.stage == GL_TESS_EVALUATION_SHADER) {
            const std::string out = plan.has_geometry_shader ? "tessref_te_" : "tessref_cap_";
            c.prefix = s.prefix + "out vec3 " + out + "tess_coord;\nout int " + out + "patch_id;\nout vec3 " + out +
                       "position;\nout vec4 " + out + "outer;\nout vec2 " + out + "inner;\n" +
                       (plan.has_geometry_shader ? "" : "out vec3 tessref_cap_normal;\n") +
                       "#define main tessref_twin_main\n";
            c.suffix = "#undef main\nvoid main()\n{\n    tessref_twin_main();\n    " + out +
                       "tess_coord = gl_TessCoord;\n    " + out + "patch_id = gl_PrimitiveID;\n    " + out +
                       "position = " + plan.position_expression + ";\n    " + out +
                       "outer = vec4(gl_TessLevelOuter[0], gl_TessLevelOuter[1], gl_TessLevelOuter[2], "
                       "gl_TessLevelOuter[3]);\n    " + out + "inner = vec2(gl_TessLevelInner[0], gl_TessLevelInner[1]);\n" +
                       (plan.has_geometry_shader ? "" : "    tessref_cap_normal = " + normal + ";\n") + "}\n";
        } else if (s.stage == GL_GEOMETRY_SHADER) {
            c.prefix = s.prefix +
                "in vec3 tessref_te_tess_coord[];\nin int tessref_te_patch_id[];\nin vec3 tessref_te_position[];\n"
                "in vec4 tessref_te_outer[];\nin vec2 tessref_te_inner[];\n"
                "out vec3 tessref_cap_tess_coord;\nout int tessref_cap_patch_id;\nout vec3 tessref_cap_position;\n"
                "out vec4 tessref_cap_outer;\nout vec2 tessref_cap_inner;\n"
                "out vec3 tessref_cap_normal;\nint tessref_emitted = 0;\nvoid tessref_emit();\n"
                "#define EmitVertex() tessref_emit()\n";
            c.suffix = "#undef EmitVertex\nvoid tessref_emit()\n{\n"
                       "    tessref_cap_tess_coord = tessref_te_tess_coord[tessref_emitted % 3];\n"
                       "    tessref_cap_patch_id = tessref_te_patch_id[tessref_emitted % 3];\n"
                       "    tessref_cap_position = tessref_te_position[tessref_emitted % 3];\n"
                       "    tessref_cap_outer = tessref_te_outer[tessref_emitted % 3];\n"
                       "    tessref_cap_inner = tessref_te_inner[tessref_emitted % 3];\n"
                       "    tessref_cap_normal = " + normal + ";\n"
                       "    EmitVertex();\n    tessref_emitted = tessref_emitted + 1;\n}\n";
        }
        stages.push_back(std::move(c));
    }
    return stages;
}

// What the capture program reads of the stages it wraps, for its errors when a user's
// shader is among them.
std::string capture_note(const Plan& plan) {
    if (std::none_of(plan.stages.begin(), plan.stages.end(), [](const StageSource& s) {
            return !s.origin.empty() && s.stage != GL_FRAGMENT_SHADER;
        }))
        return "";
    return " (it wraps the stages before rasterization and reads " + plan.position_expression +
           (plan.normal_expression.empty() ? "" : " and " + plan.normal_expression) +
           ", as the twins have them: a user's shader must declare them too)";
}

// ---- uniforms: one function per model, from the scene's settings structs ------------------

// A program may lack any of these uniforms (location -1: the call sets nothing), as a user's
// shader may; one that declares a twin's uniform with another type makes GL refuse the call.
// Without a GL (gl null) the calls only list the names they would set, in `names`: the one
// list of what tessref sets, which unset_uniform_warnings() reads.
struct Uniforms final : pipeline::UniformSink {
    GlFunctions* gl = nullptr;
    GLuint program = 0;
    const std::vector<StageSource>* stages = nullptr;  // to name the user's file that declares it
    std::set<std::string>* names = nullptr;            // with gl null: every name set
    Uniforms(GlFunctions* g, GLuint p, const std::vector<StageSource>* s = nullptr, std::set<std::string>* n = nullptr)
        : gl(g), program(p), stages(s), names(n) {}
    GLint at(const char* name) const { return gl->GetUniformLocation(program, name); }
    // True when the call is only listed.
    bool listed(const char* name) const {
        if (gl) return false;
        if (names) names->insert(name);
        return true;
    }
    void check(const char* name, const char* type) const {
        if (gl->GetError() != GL_NO_ERROR)
            throw Error(std::string("the uniform ") + name + " is declared with a type other than " + type +
                            ", the GLSL twins' (the twins' uniform names and types are the contract of a user's "
                            "shader: docs/CLI.md, `gl`)",
                        declared_at(name));
    }
    // The user's file (and line) whose text declares `uniform <type> name`, where one does.
    Where declared_at(const char* name) const {
        if (!stages) return {};
        const std::regex declaration("\\buniform\\s+\\w+\\s+" + std::string(name) + "\\b");
        for (const StageSource& s : *stages) {
            std::smatch match;
            if (s.origin.empty() || !std::regex_search(s.text, match, declaration)) continue;
            const auto line = std::count(s.text.begin(), s.text.begin() + match.position(0), '\n') + 1;
            return Where::in_file(s.path, static_cast<std::size_t>(line));
        }
        return {};
    }
    void i(const char* name, int v) const override {
        if (listed(name)) return;
        gl->Uniform1i(at(name), v);
        check(name, "int");
    }
    void f(const char* name, double v) const override {
        if (listed(name)) return;
        gl->Uniform1f(at(name), static_cast<float>(v));
        check(name, "float");
    }
    void d(const char* name, double v) const override {
        if (listed(name)) return;
        gl->Uniform1d(at(name), v);
        check(name, "double");
    }
    void v2(const char* name, glm::vec2 v) const override {
        if (listed(name)) return;
        gl->Uniform2f(at(name), v.x, v.y);
        check(name, "vec2");
    }
    void v3(const char* name, glm::vec3 v) const override {
        if (listed(name)) return;
        gl->Uniform3f(at(name), v.x, v.y, v.z);
        check(name, "vec3");
    }
    void v4(const char* name, glm::vec4 v) const override {
        if (listed(name)) return;
        gl->Uniform4f(at(name), v.x, v.y, v.z, v.w);
        check(name, "vec4");
    }
    void m3(const char* name, const glm::mat3& m) const override {
        if (listed(name)) return;
        gl->UniformMatrix3fv(at(name), 1, GL_FALSE, &m[0][0]);
        check(name, "mat3");
    }
    void m4(const char* name, const glm::mat4& m) const override {
        if (listed(name)) return;
        gl->UniformMatrix4fv(at(name), 1, GL_FALSE, &m[0][0]);
        check(name, "mat4");
    }
};

// Every uniform tessref sets for the scene, through `u` (set, or listed).
void each_uniform(const Uniforms& u, const Scene& scene, const ShadingModel& shading, const pipeline::StageMatrices& m,
                  glm::ivec2 viewport) {
    pipeline::set_stage_uniforms(u, scene, m, viewport);
    pipeline::set_shading_uniforms(u, shading);
}

}  // namespace

std::set<std::string> uniforms_set(const Scene& scene) {
    std::set<std::string> names;
    each_uniform(Uniforms{nullptr, 0, nullptr, &names}, scene, scene.shading.model, pipeline::StageMatrices{},
                 glm::ivec2(1, 1));
    // An array's elements are set one by one ("materialRepeat[2]"); the stage declares the array.
    std::set<std::string> out;
    for (const std::string& n : names) out.insert(n.substr(0, n.find('[')));
    return out;
}
std::vector<std::string> unset_uniform_warnings(const Scene& scene, const shader::Module& stage) {
    const std::set<std::string> set = uniforms_set(scene);
    std::vector<std::string> warnings;
    for (const std::string& name : stage.uniform_names())
        if (!set.count(name))
            warnings.push_back("the " + std::string(to_string(stage.stage())) + " shader " + stage.path() +
                               " declares the uniform " + name +
                               ", which tessref does not set for this scene: it reads 0 (a misspelt name? the uniforms "
                               "tessref sets are the GLSL twins')");
    // Samplers are bound by unit, not by name (the twins' layout(binding = N)): one at a unit
    // no texture is bound to samples GL's unbound texture, 0, as silently.
    std::set<int> units;
    pipeline::bind_program_textures(scene, scene.shading, [&](int unit, const Texture* t, const std::string&) {
        if (t) units.insert(unit);
    });
    for (const shader::Module::Sampler& sampler : stage.samplers())
        if (!units.count(sampler.unit))
            warnings.push_back("the " + std::string(to_string(stage.stage())) + " shader " + stage.path() +
                               " declares the sampler " + sampler.name + " at texture unit " +
                               std::to_string(sampler.unit) +
                               ", to which tessref binds no texture for this scene: it reads 0 (the units tessref "
                               "binds are the GLSL twins' layout(binding = N))");
    return warnings;
}

namespace {

void set_uniforms(GlFunctions& gl, GLuint program, const Scene& scene, const RenderShading& shading,
                  const pipeline::StageMatrices& m, glm::ivec2 viewport, const std::vector<StageSource>& stages) {
    gl.UseProgram(program);
    if (gl.GetError() != GL_NO_ERROR) throw Error("OpenGL refused to use the scene's program");
    each_uniform(Uniforms{&gl, program, &stages, nullptr}, scene, shading.model, m, viewport);
}

// ---- textures: the Texture objects the CPU samples, uploaded as they were loaded ---------

// Level 0's texels as uploaded: `stored` itself, or for a luminance texture each texel
// repeated in three channels (a copy, in `rgb`).
template <class T>
const T* uploaded_texels(const std::vector<T>& stored, bool luminance, std::vector<T>& rgb) {
    if (!luminance) return stored.data();
    rgb.resize(stored.size() * 3);
    for (std::size_t i = 0; i < stored.size(); ++i) rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = stored[i];
    return rgb.data();
}

GLuint upload(Context::Impl& c, const Texture& t, const std::string& what) {
    auto& gl = c.gl;
    static const GLenum base[4] = {GL_RED, GL_RG, GL_RGB, GL_RGBA};
    static const GLenum i8[4] = {GL_R8, GL_RG8, GL_RGB8, GL_RGBA8};
    static const GLenum i16[4] = {GL_R16, GL_RG16, GL_RGB16, GL_RGBA16};
    static const GLenum f32[4] = {GL_R32F, GL_RG32F, GL_RGB32F, GL_RGBA32F};
    if (t.empty()) throw Error("tessref gl: the texture " + what + " is empty");
    // A luminance texture goes up as three equal channels (RGB), the texture the shaders have
    // always sampled; the CPU reads its one channel and copies it (Swizzle), the same values.
    const bool luminance = t.swizzle() == Swizzle::luminance;
    const int k = luminance ? 2 : t.channels() - 1;
    const TextureLevel& level0 = t.level(0);
    GLuint name = 0;
    gl.GenTextures(1, &name);
    gl.BindTexture(GL_TEXTURE_2D, name);
    gl.PixelStorei(GL_UNPACK_ALIGNMENT, 1);
    switch (t.format()) {
        case TexelFormat::unorm8: {
            std::vector<std::uint8_t> rgb;
            gl.TexImage2D(GL_TEXTURE_2D, 0, static_cast<GLint>(i8[k]), level0.width, level0.height, 0, base[k],
                          GL_UNSIGNED_BYTE, uploaded_texels(level0.unorm8, luminance, rgb));
            break;
        }
        case TexelFormat::unorm16: {
            // Stored as code * (1/65535) in float: rounding recovers the code exactly.
            std::vector<std::uint16_t> codes(level0.texels.size()), rgb;
            for (std::size_t i = 0; i < codes.size(); ++i)
                codes[i] = static_cast<std::uint16_t>(std::lround(static_cast<double>(level0.texels[i]) * 65535.0));
            gl.TexImage2D(GL_TEXTURE_2D, 0, static_cast<GLint>(i16[k]), level0.width, level0.height, 0, base[k],
                          GL_UNSIGNED_SHORT, uploaded_texels(codes, luminance, rgb));
            break;
        }
        case TexelFormat::float32: {
            std::vector<float> rgb;
            gl.TexImage2D(GL_TEXTURE_2D, 0, static_cast<GLint>(f32[k]), level0.width, level0.height, 0, base[k],
                          GL_FLOAT, uploaded_texels(level0.texels, luminance, rgb));
            break;
        }
    }
    gl.GenerateMipmap(GL_TEXTURE_2D);  // heightfield.h: llvmpipe_blit models exactly this
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER,
                     t.min_filter() == MinFilter::linear ? GL_LINEAR : GL_LINEAR_MIPMAP_LINEAR);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    const GLint wrap = t.wrap() == Wrap::repeat ? GL_REPEAT : GL_CLAMP_TO_EDGE;  // texture.h Wrap
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, wrap);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, wrap);
    c.check_error(("uploading the texture " + what).c_str());
    return name;
}

// Texture units as the twins' layout(binding = N): 0 heightMap, 1 tessellationMap,
// 2 normalMap, 4..14 the thesis fragment shaders' samplers (shading.h), 0 cosc422's heightMap,
// 4..6 pom's.
struct BoundTextures {
    Context::Impl& c;
    std::vector<GLuint> names;
    std::vector<const Texture*> at_unit = std::vector<const Texture*>(16, nullptr);
    explicit BoundTextures(Context::Impl& context) : c(context) {}
    BoundTextures(const BoundTextures&) = delete;
    BoundTextures& operator=(const BoundTextures&) = delete;
    ~BoundTextures() {
        if (!names.empty()) c.gl.DeleteTextures(static_cast<GLsizei>(names.size()), names.data());
    }
    void bind(int unit, const Texture* t, const std::string& what) {
        if (!t) return;
        if (at_unit[static_cast<std::size_t>(unit)] == t) return;
        if (at_unit[static_cast<std::size_t>(unit)])
            throw Error("tessref gl: texture unit " + std::to_string(unit) + " is bound twice (" + what +
                        " and another texture): the twins share layout(binding = " + std::to_string(unit) + ")");
        c.gl.ActiveTexture(GL_TEXTURE0 + static_cast<GLenum>(unit));
        names.push_back(upload(c, *t, what));
        at_unit[static_cast<std::size_t>(unit)] = t;
    }
};

void bind_textures(BoundTextures& b, const Scene& scene, const RenderShading& shading) {
    pipeline::bind_program_textures(scene, shading, [&](int unit, const Texture* t, const std::string& what) { b.bind(unit, t, what); });
}

// ---- vertex data -----------------------------------------------------------------------

// Terrain: four corners per patch (control.h layout), vec4(ground, 1), with the corner
// coordinates rounded to float as the pipeline's vertex buffer holds them. PN: three
// vertices per patch, position, normal, uv.
struct VertexData {
    std::vector<float> floats;
    int patch_vertices = 4;
};

VertexData vertex_data(const Scene& scene) {
    VertexData d;
    if (scene.grid) {
        const TerrainGrid& g = *scene.grid;
        d.floats.reserve(g.patch_count() * 16);
        for (std::size_t p = 0; p < g.patch_count(); ++p) {
            const std::size_t i = p % static_cast<std::size_t>(g.patches_u);
            const std::size_t j = p / static_cast<std::size_t>(g.patches_u);
            const std::size_t a[4][2] = {{i, j}, {i, j + 1}, {i + 1, j + 1}, {i + 1, j}};
            for (const auto& c : a) {
                const float u = static_cast<float>(g.u_coords[c[0]]);
                const float v = static_cast<float>(g.v_coords[c[1]]);
                if (g.plane == GroundPlane::xy)
                    d.floats.insert(d.floats.end(), {u, v, 0.0f, 1.0f});
                else
                    d.floats.insert(d.floats.end(), {u, 0.0f, v, 1.0f});
            }
        }
    } else {
        const TriangleMeshes& m = *scene.meshes;
        d.patch_vertices = 3;
        d.floats.reserve(m.triangles.size() * 24);
        for (const auto& tri : m.triangles)
            for (std::uint32_t v : tri) {
                const glm::vec3 p(m.positions[v]), n(m.normals[v]);
                const glm::vec2 uv = m.uvs.empty() ? glm::vec2(0.0f) : glm::vec2(m.uvs[v]);
                d.floats.insert(d.floats.end(), {p.x, p.y, p.z, n.x, n.y, n.z, uv.x, uv.y});
            }
    }
    return d;
}

// A geomipmapped terrain: three vertices per triangle of the CPU's mesh (triangle order, so
// that a batch of patches is a range of vertices), kGeomipVertexWords 32-bit words each:
// groundPosition (2), sampleHeight, morphTarget, tween, normal (3), textureCoordinate (2)
// for geomip_terrain.vert (locations 0..5); then for the capture's wrapper (locations 6..9)
// the patch id (an int), the tess coord (3), the outer (4) and inner (2) levels. Every
// vertex of a triangle is written out so that a face normal ([geometry] normals = "face")
// can be each corner's normal.
constexpr std::size_t kGeomipVertexWords = 20;

VertexData geomip_vertex_data(const Scene& scene, const PipelineResult& pipe) {
    VertexData d;
    d.patch_vertices = 3;
    const SurfaceMesh& mesh = pipe.mesh;
    if (pipe.geomorph.size() != mesh.positions.size())
        throw Error("tessref gl: the geomipmapped pipeline result has no geomorph attributes", Where::at_key(scene.file, "evaluation.model"));
    const bool face = !pipe.face_normals.empty();
    d.floats.reserve(mesh.triangles.size() * 3 * kGeomipVertexWords);
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
        for (const std::uint32_t v : mesh.triangles[t]) {
            const glm::vec3 m = pipe.geomorph[v];
            const glm::vec3 n = face ? glm::vec3(pipe.face_normals[t])
                                     : mesh.normals.empty() ? glm::vec3(0.0f) : glm::vec3(mesh.normals[v]);
            const glm::vec2 uv(mesh.uvs[v]);
            const std::uint32_t patch = mesh.patch_ids[v];
            float patch_bits;
            std::memcpy(&patch_bits, &patch, sizeof patch_bits);
            const TessLevels& l = pipe.levels[patch];
            const glm::vec3 tc = mesh.tess_coords[v];
            d.floats.insert(d.floats.end(),
                            {static_cast<float>(mesh.positions[v].x), static_cast<float>(mesh.positions[v].y), m.x,
                             m.y, m.z, n.x, n.y, n.z, uv.x, uv.y, patch_bits, tc.x, tc.y, tc.z, l.outer[0],
                             l.outer[1], l.outer[2], l.outer[3], l.inner[0], l.inner[1]});
        }
    return d;
}

void geomip_attributes(GlFunctions& gl) {
    const GLsizei stride = kGeomipVertexWords * sizeof(float);
    const auto at = [](std::size_t word) { return reinterpret_cast<const void*>(word * sizeof(float)); };
    gl.VertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, stride, at(0));   // groundPosition
    gl.VertexAttribPointer(1, 1, GL_FLOAT, GL_FALSE, stride, at(2));   // sampleHeight
    gl.VertexAttribPointer(2, 1, GL_FLOAT, GL_FALSE, stride, at(3));   // morphTarget
    gl.VertexAttribPointer(3, 1, GL_FLOAT, GL_FALSE, stride, at(4));   // tween
    gl.VertexAttribPointer(4, 3, GL_FLOAT, GL_FALSE, stride, at(5));   // normal
    gl.VertexAttribPointer(5, 2, GL_FLOAT, GL_FALSE, stride, at(8));   // textureCoordinate
    gl.VertexAttribIPointer(6, 1, GL_INT, stride, at(10));             // the capture's patch id
    gl.VertexAttribPointer(7, 3, GL_FLOAT, GL_FALSE, stride, at(11));  // tess coord
    gl.VertexAttribPointer(8, 4, GL_FLOAT, GL_FALSE, stride, at(14));  // outer levels
    gl.VertexAttribPointer(9, 2, GL_FLOAT, GL_FALSE, stride, at(18));  // inner levels
    for (GLuint i = 0; i < 10; ++i) gl.EnableVertexAttribArray(i);
}

struct GlObjects {
    Context::Impl& c;
    GLuint vao = 0, vbo = 0, feedback = 0, query = 0, query_written = 0;
    std::vector<GLuint> programs;
    explicit GlObjects(Context::Impl& context) : c(context) {}
    GlObjects(const GlObjects&) = delete;
    GlObjects& operator=(const GlObjects&) = delete;
    ~GlObjects() {
        auto& gl = c.gl;
        for (GLuint p : programs) gl.DeleteProgram(p);
        const GLuint buffers[] = {vbo, feedback};
        gl.DeleteBuffers(2, buffers);
        const GLuint queries[] = {query, query_written};
        gl.DeleteQueries(2, queries);
        if (vao) gl.DeleteVertexArrays(1, &vao);
    }
};

// A draw: consecutive patches, their predicted primitive count.
struct Batch {
    std::size_t first = 0, count = 0;
    std::uint64_t predicted = 0;
};

std::vector<Batch> make_batches(const std::vector<std::uint64_t>& per_patch, std::size_t budget) {
    std::vector<Batch> batches;
    Batch b;
    for (std::size_t p = 0; p < per_patch.size(); ++p) {
        if (b.count > 0 && b.predicted + per_patch[p] > budget) {
            batches.push_back(b);
            b = Batch{p, 0, 0};
        }
        b.predicted += per_patch[p];
        ++b.count;
    }
    if (b.count > 0) batches.push_back(b);
    return batches;
}

std::string batch_name(std::size_t index, const Batch& b) {
    return "draw " + std::to_string(index) + " (patches " + std::to_string(b.first) + ".." +
           std::to_string(b.first + b.count - 1) + ")";
}

struct FeedbackRecord {
    float tess_coord[3];
    std::int32_t patch_id;
    float position[3];
    float normal[3];
    float outer[4];
    float inner[2];
};
static_assert(sizeof(FeedbackRecord) == 64);

// The patches whose levels (those the domain uses, as llvmpipe's evaluation shader read
// them, bit for bit) or triangle counts differ between the CPU pipeline and the capture. A
// patch llvmpipe emitted nothing for has no captured levels.
std::vector<PatchDifference> patch_differences(const PipelineResult& pipe, const std::vector<std::uint64_t>& per_patch,
                                               const std::vector<CapturedVertex>& capture, Domain domain) {
    std::vector<PatchDifference> gl(per_patch.size());
    for (std::size_t p = 0; p < gl.size(); ++p) {
        gl[p].patch = p;
        gl[p].cpu_triangles = per_patch[p];
        if (p < pipe.levels.size()) gl[p].cpu_levels = pipe.levels[p];
    }
    for (std::size_t v = 0; v + 2 < capture.size(); v += 3) {
        const std::size_t p = capture[v].patch_id;
        if (p >= gl.size()) continue;
        ++gl[p].gl_triangles;
        if (!gl[p].gl_levels_known) gl[p].gl_levels = capture[v].levels;
        gl[p].gl_levels_known = true;
    }
    const std::size_t outer = domain == Domain::quads ? 4 : domain == Domain::triangles ? 3 : 2;
    const std::size_t inner = domain == Domain::quads ? 2 : domain == Domain::triangles ? 1 : 0;
    const auto same_bits = [&](const TessLevels& a, const TessLevels& b) {
        return std::memcmp(a.outer.data(), b.outer.data(), sizeof(float) * outer) == 0 &&
               std::memcmp(a.inner.data(), b.inner.data(), sizeof(float) * inner) == 0;
    };
    std::vector<PatchDifference> out;
    for (const PatchDifference& d : gl)
        if (d.cpu_triangles != d.gl_triangles || (d.gl_levels_known && !same_bits(d.cpu_levels, d.gl_levels)))
            out.push_back(d);
    return out;
}

}  // namespace

SceneRender render_scene(Context& context, const Scene& scene_in, const SceneRenderOptions& options) {
    if (!scene_in.camera) throw Error("tessref gl needs a [camera] in the scene", Where::at_key(scene_in.file, "camera"));
    Scene scene = scene_in;  // the pipeline sees the image's viewport, as render_scene does
    // and runs the user's shaders through the interpreter: the prediction of each draw.
    scene.shaders = user_shaders(scene_in, options);
    if (options.size != glm::ivec2(0, 0)) scene.camera->viewport = options.size;
    const glm::ivec2 size = scene.camera->viewport;
    if (size.x < 1 || size.y < 1 || size.x > 16384 || size.y > 16384)
        throw Error("image size " + std::to_string(size.x) + "x" + std::to_string(size.y) + " is outside 1..16384",
                    Where::at_key(scene.file, "size"));

    SceneRender result;
    result.width = size.x;
    result.height = size.y;
    result.shading = scene.shading;

    // The CPU pipeline: the prediction of every draw.
    auto start = Clock::now();
    PipelineOptions pipeline_options;
    pipeline_options.math = options.math;
    result.pipeline = options.pipeline ? options.pipeline
                                       : std::make_shared<const PipelineResult>(run_pipeline(scene, pipeline_options));
    const PipelineResult& pipe = *result.pipeline;
    std::vector<std::uint64_t> per_patch(scene.patch_count(), 0);
    for (const auto& tri : pipe.mesh.triangles) ++per_patch[pipe.mesh.patch_ids[tri[0]]];
    result.stats.seconds_pipeline = seconds_since(start);

    const pipeline::StageMatrices m = pipeline::stage_matrices(scene);

    Plan plan = plan_for(scene, result.shading);
    result.user_shaders = user_shaders(scene, options);
    apply_user_shaders(plan, result.user_shaders);
    if (plan.geomipmap)  // triangles drawn as triangles: no patches for a tessellation stage
        for (const StageShader& user : result.user_shaders)
            if (user.stage == ShaderStage::tess_control || user.stage == ShaderStage::tess_evaluation)
                throw Error(std::string("tessref gl: the ") + to_string(user.stage) + " shader " + user.path + " of " +
                                user.origin + " cannot run on a geomipmapped terrain: it draws the CPU's triangles "
                                "with no tessellation stages (geomip_terrain.vert)",
                            user.where);
    const std::string user_note = count_note(plan);
    // The user's files, for the messages of a draw that fails or dies (every stage's).
    std::string user_files;
    for (const StageShader& s : result.user_shaders)
        user_files += (user_files.empty() ? "" : ", ") + std::string(to_string(s.stage)) + " shader " + s.path + " (" +
                      s.origin + ")";
    const std::string draw_what = "a scene draw" + (user_files.empty() ? std::string() : " with the user's " + user_files);
    const Where draw_where = result.user_shaders.empty() ? Where() : result.user_shaders.front().where;
    const std::vector<Batch> batches = make_batches(per_patch, options.max_primitives_per_draw);

    Context::Impl& c = context.impl();
    c.make_current();
    auto& gl = c.gl;
    const std::size_t pixels = static_cast<std::size_t>(size.x) * static_cast<std::size_t>(size.y);
    require_memory(saturating_bytes(pixels, 2 * sizeof(glm::vec4)), "a float colour buffer of " +
                   std::to_string(size.x) + "x" + std::to_string(size.y) + " pixels", Where::at_key(scene.file, "size"));
    std::vector<float> buffer(pixels * 4, 0.0f);
    c.bind_color_buffer(buffer.data(), size.x, size.y);
    struct Release {
        Context::Impl& c;
        ~Release() {
            try {
                c.release_color_buffer();
            } catch (...) {
            }
        }
    } release{c};

    GlObjects objects(c);
    BoundTextures textures(c);
    objects.programs.push_back(link(gl, plan.stages, {}, "the scene's program"));
    const GLuint program = objects.programs.back();
    bind_textures(textures, scene, result.shading);

    const VertexData vertices = plan.geomipmap ? geomip_vertex_data(scene, pipe) : vertex_data(scene);
    // A batch's first vertex and vertex count: patches of the tessellated models, the
    // patches' triangles (in patch order, three vertices each) of a geomipmapped terrain.
    std::vector<std::size_t> first_triangle(per_patch.size() + 1, 0);
    for (std::size_t p = 0; p < per_patch.size(); ++p) first_triangle[p + 1] = first_triangle[p] + per_patch[p];
    const GLenum draw_mode = plan.geomipmap ? GL_TRIANGLES : GL_PATCHES;
    const auto draw_range = [&](const Batch& b) {
        const std::size_t first = plan.geomipmap ? first_triangle[b.first] : b.first;
        const std::size_t count = plan.geomipmap ? first_triangle[b.first + b.count] - first_triangle[b.first] : b.count;
        const std::size_t n = static_cast<std::size_t>(vertices.patch_vertices);
        return std::pair{static_cast<GLint>(first * n), static_cast<GLsizei>(count * n)};
    };
    gl.GenVertexArrays(1, &objects.vao);
    gl.BindVertexArray(objects.vao);
    gl.GenBuffers(1, &objects.vbo);
    gl.BindBuffer(GL_ARRAY_BUFFER, objects.vbo);
    gl.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices.floats.size() * sizeof(float)),
                  vertices.floats.data(), GL_STATIC_DRAW);
    if (plan.geomipmap) {
        geomip_attributes(gl);
    } else if (scene.grid) {
        gl.VertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, 4 * sizeof(float), nullptr);
        gl.EnableVertexAttribArray(0);
    } else {
        const GLsizei stride = 8 * sizeof(float);
        gl.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, nullptr);
        gl.VertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(3 * sizeof(float)));
        gl.VertexAttribPointer(2, 2, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(6 * sizeof(float)));
        for (GLuint i = 0; i < 3; ++i) gl.EnableVertexAttribArray(i);
    }
    if (!plan.geomipmap) gl.PatchParameteri(GL_PATCH_VERTICES, vertices.patch_vertices);
    if (!plan.geomipmap && !plan.has_control_shader) {
        const float level = scene.control ? static_cast<float>(scene.control->constant.level) : 1.0f;
        const float outer[4] = {level, level, level, level};
        const float inner[2] = {level, level};
        gl.PatchParameterfv(GL_PATCH_DEFAULT_OUTER_LEVEL, outer);
        gl.PatchParameterfv(GL_PATCH_DEFAULT_INNER_LEVEL, inner);
    }
    gl.GenQueries(1, &objects.query);
    gl.GenQueries(1, &objects.query_written);
    c.check_error("setting up the scene's draws");

    auto predicted_of = [&](std::size_t index) {
        return batches[index].predicted + (static_cast<long long>(index) == options.corrupt_prediction_of_batch ? 1 : 0);
    };

    // ---- the picture --------------------------------------------------------------------
    start = Clock::now();
    set_uniforms(gl, program, scene, result.shading, m, size, plan.stages);
    gl.Viewport(0, 0, size.x, size.y);
    const glm::vec4 bg = result.shading.background;
    gl.ClearColor(bg.r, bg.g, bg.b, bg.a);
    gl.ClearDepth(1.0);
    gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    gl.Enable(GL_DEPTH_TEST);
    gl.DepthFunc(GL_LESS);
    gl.PolygonMode(GL_FRONT_AND_BACK, options.wireframe ? GL_LINE : GL_FILL);
    c.check_error("setting the scene's uniforms and state");
    set_isolated_phase("drawing the scene" + (user_files.empty() ? std::string() : " with the user's " + user_files),
                       draw_where);
    for (std::size_t k = 0; k < batches.size(); ++k) {
        const Batch& b = batches[k];
        gl.BeginQuery(GL_PRIMITIVES_GENERATED, objects.query);
        const auto [first, count] = draw_range(b);
        gl.DrawArrays(draw_mode, first, count);
        gl.EndQuery(GL_PRIMITIVES_GENERATED);
        GLuint generated = 0;
        gl.GetQueryObjectuiv(objects.query, GL_QUERY_RESULT, &generated);
        try {
            c.check_error(draw_what.c_str());
        } catch (const Error& e) {  // a user's point-mode or isolines layout: GL_INVALID_OPERATION
            throw Error(e.what(), draw_where);
        }
        ++result.stats.draws;
        result.stats.triangles += generated;
        if (generated != predicted_of(k)) {  // reported, not fatal: the patches are found below
            result.batch_failure += (result.batch_failure.empty() ? "" : "; ") + batch_name(k, b) +
                                    ": llvmpipe generated " + std::to_string(generated) +
                                    " primitives, the CPU primitive generator predicts " +
                                    std::to_string(predicted_of(k));
        }
    }
    if (!result.batch_failure.empty()) result.batch_failure += user_note;
    gl.Finish();
    gl.PolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    c.check_error("drawing the scene");
    result.colour.resize(pixels);
    for (int y = 0; y < size.y; ++y) {  // OSMesa's row 0 is the bottom one
        const float* row = &buffer[static_cast<std::size_t>(size.y - 1 - y) * static_cast<std::size_t>(size.x) * 4];
        for (int x = 0; x < size.x; ++x)
            result.colour[static_cast<std::size_t>(y) * static_cast<std::size_t>(size.x) + static_cast<std::size_t>(x)] =
                glm::vec4(row[4 * x], row[4 * x + 1], row[4 * x + 2], row[4 * x + 3]);
    }
    result.stats.seconds_gl = seconds_since(start);

    // ---- the capture ---------------------------------------------------------------------
    // Also run when a count differed: the capture's levels and triangles per patch are what
    // names the patches that differ (SceneRender::differences).
    const bool diagnose = !result.batch_failure.empty();
    if (!options.capture && !diagnose) return result;
    set_isolated_phase("capturing the scene by transform feedback" +
                           (user_files.empty() ? std::string() : " with the user's " + user_files),
                       draw_where);
    start = Clock::now();
    objects.programs.push_back(link(gl, capture_stages(plan),
                                    {"tessref_cap_tess_coord", "tessref_cap_patch_id", "tessref_cap_position",
                                     "tessref_cap_normal", "tessref_cap_outer", "tessref_cap_inner"},
                                    "the --capture program" + capture_note(plan)));
    const GLuint capture_program = objects.programs.back();
    set_uniforms(gl, capture_program, scene, result.shading, m, size, plan.stages);
    if (plan.identity_mvp_for_capture) Uniforms{&gl, capture_program}.m4("mvp", glm::mat4(1.0f));
    std::uint64_t largest = 0;
    for (std::size_t k = 0; k < batches.size(); ++k) largest = std::max<std::uint64_t>(largest, predicted_of(k));
    const std::uint64_t total = pipe.mesh.triangles.size();
    // Streamed to the sink, only a draw's capture is held at once.
    const bool to_sink = options.capture_sink && !diagnose;
    double sink_seconds = 0.0;  // in the sink, left out of seconds_capture
    if (!to_sink) {
        require_memory(saturating_bytes(saturating_bytes(total, 3), sizeof(CapturedVertex)),
                       "the capture of " + std::to_string(total) + " triangles", Where::at_key(scene.file, "--capture"));
        result.capture.reserve(static_cast<std::size_t>(total) * 3);
    }
    std::vector<CapturedVertex> draw_capture;
    // One primitive of slack: an overflow still shows as written < generated, and the draw
    // is then repeated into a buffer of the size llvmpipe reported.
    std::uint64_t capacity_primitives = largest + 1;
    gl.GenBuffers(1, &objects.feedback);
    const auto size_feedback = [&] {
        gl.BindBuffer(GL_TRANSFORM_FEEDBACK_BUFFER, objects.feedback);
        gl.BufferData(GL_TRANSFORM_FEEDBACK_BUFFER,
                      static_cast<GLsizeiptr>(capacity_primitives * 3 * sizeof(FeedbackRecord)), nullptr,
                      GL_STREAM_READ);
        gl.BindBufferBase(GL_TRANSFORM_FEEDBACK_BUFFER, 0, objects.feedback);
    };
    size_feedback();
    gl.Enable(GL_RASTERIZER_DISCARD);
    c.check_error("setting up the capture");
    std::vector<FeedbackRecord> records;
    bool retried = false;
    for (std::size_t k = 0; k < batches.size(); ++k) {
        const Batch& b = batches[k];
        gl.BeginQuery(GL_PRIMITIVES_GENERATED, objects.query);
        gl.BeginQuery(GL_TRANSFORM_FEEDBACK_PRIMITIVES_WRITTEN, objects.query_written);
        gl.BeginTransformFeedback(GL_TRIANGLES);
        const auto [first, count] = draw_range(b);
        gl.DrawArrays(draw_mode, first, count);
        gl.EndTransformFeedback();
        gl.EndQuery(GL_TRANSFORM_FEEDBACK_PRIMITIVES_WRITTEN);
        gl.EndQuery(GL_PRIMITIVES_GENERATED);
        GLuint generated = 0, written = 0;
        gl.GetQueryObjectuiv(objects.query, GL_QUERY_RESULT, &generated);
        gl.GetQueryObjectuiv(objects.query_written, GL_QUERY_RESULT, &written);
        c.check_error("a capture draw");
        if (written < generated && !retried) {  // more than predicted: room for all, once
            capacity_primitives = std::uint64_t{generated} + 1;
            size_feedback();
            c.check_error("growing the capture buffer");
            retried = true;
            --k;
            continue;
        }
        retried = false;
        if (written != generated || (!diagnose && generated != predicted_of(k))) {
            gl.Disable(GL_RASTERIZER_DISCARD);
            result.capture.clear();
            result.batch_failure = "capture " + batch_name(k, b) + ": llvmpipe generated " + std::to_string(generated) +
                                   " primitives and transform feedback wrote " + std::to_string(written) +
                                   ", the CPU primitive generator predicts " + std::to_string(predicted_of(k)) +
                                   user_note;
            return result;
        }
        if (written == 0) continue;
        records.resize(static_cast<std::size_t>(written) * 3);
        const void* mapped = gl.MapBufferRange(GL_TRANSFORM_FEEDBACK_BUFFER, 0,
                                               static_cast<GLsizeiptr>(records.size() * sizeof(FeedbackRecord)),
                                               GL_MAP_READ_BIT);
        if (!mapped) {
            c.check_error("mapping the transform feedback buffer");
            throw Error("cannot map the transform feedback buffer");
        }
        std::memcpy(records.data(), mapped, records.size() * sizeof(FeedbackRecord));
        gl.UnmapBuffer(GL_TRANSFORM_FEEDBACK_BUFFER);
        std::vector<CapturedVertex>& into = to_sink ? draw_capture : result.capture;
        if (to_sink) draw_capture.clear();
        for (const FeedbackRecord& r : records) {
            CapturedVertex v;
            // gl_PrimitiveID counts the draw's patches; a geomipmapped vertex carries its own.
            v.patch_id = plan.geomipmap ? static_cast<std::uint32_t>(r.patch_id)
                                        : static_cast<std::uint32_t>(b.first + static_cast<std::size_t>(r.patch_id));
            v.tess_coord = glm::vec3(r.tess_coord[0], r.tess_coord[1], r.tess_coord[2]);
            v.position = glm::vec3(r.position[0], r.position[1], r.position[2]);
            v.normal = glm::vec3(r.normal[0], r.normal[1], r.normal[2]);
            std::memcpy(v.levels.outer.data(), r.outer, sizeof r.outer);
            std::memcpy(v.levels.inner.data(), r.inner, sizeof r.inner);
            into.push_back(v);
        }
        if (to_sink) {  // not llvmpipe's time: the caller's, or waiting for it (a pipe)
            const auto handed = Clock::now();
            options.capture_sink(draw_capture);
            sink_seconds += seconds_since(handed);
        }
    }
    gl.Disable(GL_RASTERIZER_DISCARD);
    c.check_error("reading the capture back");
    result.stats.seconds_capture = seconds_since(start) - sink_seconds;
    if (diagnose) result.differences = patch_differences(pipe, per_patch, result.capture, scene.generator.domain);
    if (!options.capture) result.capture.clear();
    return result;
}

// ---- in a child process ------------------------------------------------------------------

namespace {

// The bytes of a vector of trivially copyable values, and back.
template <typename T>
void put_vector(std::string& out, const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const std::uint64_t n = v.size();
    out.append(reinterpret_cast<const char*>(&n), sizeof n);
    out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}
template <typename T>
void put_value(std::string& out, const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out.append(reinterpret_cast<const char*>(&v), sizeof v);
}
void put_string(std::string& out, const std::string& s) {
    put_value(out, static_cast<std::uint64_t>(s.size()));
    out += s;
}

struct Reader {
    const std::string& bytes;
    std::size_t at = 0;
    void take(void* to, std::size_t n) {
        if (n > bytes.size() - at) throw Error("the GL backend's child process answered with too few bytes");
        if (n == 0) return;  // an empty vector's data() may be null, which memcpy may not take
        std::memcpy(to, bytes.data() + at, n);
        at += n;
    }
    template <typename T>
    T value() {
        T v;
        take(&v, sizeof v);
        return v;
    }
    template <typename T>
    std::vector<T> vector() {
        const auto n = value<std::uint64_t>();
        if (n > (bytes.size() - at) / sizeof(T)) throw Error("the GL backend's child process answered with too few bytes");
        std::vector<T> v(static_cast<std::size_t>(n));
        take(v.data(), v.size() * sizeof(T));
        return v;
    }
    std::string string() {
        const auto n = value<std::uint64_t>();
        if (n > bytes.size() - at) throw Error("the GL backend's child process answered with too few bytes");
        std::string s = bytes.substr(at, static_cast<std::size_t>(n));
        at += static_cast<std::size_t>(n);
        return s;
    }
};

const std::string kIsolatedWhat = "the GL backend (Mesa llvmpipe, in a child process)";

}  // namespace

struct PendingRender::State {
    SceneRenderOptions options;
    RenderShading shading{};
    std::vector<StageShader> user_shaders;
    std::vector<std::string> warnings;
    IsolatedChild child;
};

PendingRender::PendingRender(std::unique_ptr<State> state) : state_(std::move(state)) {}
PendingRender::PendingRender(PendingRender&&) noexcept = default;
PendingRender& PendingRender::operator=(PendingRender&&) noexcept = default;
PendingRender::~PendingRender() = default;

PendingRender start_render_scene_isolated(const Scene& scene_in, const SceneRenderOptions& options_in) {
    if (!scene_in.camera) throw Error("tessref gl needs a [camera] in the scene", Where::at_key(scene_in.file, "camera"));
    // The CPU pipeline runs here, on every core (oneTBB is not for the child), at the
    // image's viewport as render_scene() would run it.
    Scene scene = scene_in;
    if (options_in.size != glm::ivec2(0, 0)) scene.camera->viewport = options_in.size;
    SceneRenderOptions options = options_in;
    scene.shaders = user_shaders(scene_in, options);
    if (!options.pipeline) {
        const auto start = Clock::now();
        PipelineOptions pipeline_options;
        pipeline_options.math = options.math;  // as render_scene() runs it
        options.pipeline = std::make_shared<const PipelineResult>(run_pipeline(scene, pipeline_options));
        options.pipeline_seconds = seconds_since(start);
    }
    // Every user file is read here, where the input checks apply, and handed to the child
    // as text; the child reads it again from the same path only after these checks passed.
    // A uniform a user's stage declares and tessref does not set reads 0, silently: each is
    // a warning (the stage compiled by the interpreter, which lists its uniforms; a stage it
    // cannot compile is left to GL's own errors).
    std::vector<std::string> warnings;
    for (const StageShader& s : scene.shaders) {
        const StageSource source = user_stage(s);
        try {
            const shader::Module module = shader::Module::compile({s.stage, source.path, source.text, source.prefix});
            for (std::string& w : unset_uniform_warnings(scene_in, module)) warnings.push_back(std::move(w));
        } catch (const Error&) {
        }
    }
    auto st = std::make_unique<PendingRender::State>();
    st->child = start_isolated(kIsolatedWhat, [&] {
        set_isolated_phase("creating the OSMesa context");
        // Never destroyed: the child exits when it has answered, and a driver's teardown
        // is one more place to crash after the work is done.
        Context& context = *new Context(Context::create());
        // The capture streamed: each draw's vertices go to the parent as they are read back.
        SceneRenderOptions child_options = options;
        if (options.capture_sink)
            child_options.capture_sink = [](std::span<const CapturedVertex> v) {
                send_to_parent(std::string_view(reinterpret_cast<const char*>(v.data()), v.size_bytes()));
            };
        SceneRender r = render_scene(context, scene_in, child_options);
        set_isolated_phase("sending the picture back");
        std::string out;
        put_string(out, context.renderer());
        put_value(out, r.width);
        put_value(out, r.height);
        put_vector(out, r.colour);
        put_vector(out, r.capture);
        put_string(out, r.batch_failure);
        put_vector(out, r.differences);
        put_value(out, r.stats);
        return out;
    });
    if (!options.return_pipeline) options.pipeline.reset();  // the child has its own copy
    st->shading = scene_in.shading;
    st->user_shaders = std::move(scene.shaders);
    st->warnings = std::move(warnings);
    st->options = std::move(options);
    return PendingRender(std::move(st));
}

IsolatedRender PendingRender::finish() {
    if (!state_) throw Error("PendingRender::finish() of a render that was not started or is finished");
    const std::unique_ptr<State> st = std::move(state_);
    const SceneRenderOptions& options = st->options;
    std::vector<CapturedVertex> sink_vertices;
    const std::string answer = st->child.finish(options.meanwhile, [&](std::string_view bytes) {
        // Pieces come only with a sink. The bytes are copied out of the pipe's buffer into
        // vertices of their own alignment.
        if (!options.capture_sink || bytes.size() % sizeof(CapturedVertex) != 0)
            throw Error("the GL backend's child process sent a piece of capture that is not whole vertices");
        std::vector<CapturedVertex>& v = sink_vertices;
        v.resize(bytes.size() / sizeof(CapturedVertex));
        if (!v.empty()) std::memcpy(static_cast<void*>(v.data()), bytes.data(), bytes.size());
        options.capture_sink(v);
    });

    IsolatedRender result;
    Reader in{answer};
    result.renderer = in.string();
    SceneRender& r = result.render;
    r.width = in.value<int>();
    r.height = in.value<int>();
    r.colour = in.vector<glm::vec4>();
    r.capture = in.vector<CapturedVertex>();
    r.batch_failure = in.string();
    r.differences = in.vector<PatchDifference>();
    r.stats = in.value<SceneRenderStats>();
    r.stats.seconds_pipeline += options.pipeline_seconds;
    r.shading = st->shading;
    r.pipeline = options.pipeline;
    r.user_shaders = std::move(st->user_shaders);
    r.warnings = std::move(st->warnings);
    return result;
}

IsolatedRender render_scene_isolated(const Scene& scene, const SceneRenderOptions& options) {
    return start_render_scene_isolated(scene, options).finish();
}

std::string renderer_isolated() {
    return run_isolated(kIsolatedWhat, [] {
        set_isolated_phase("creating the OSMesa context");
        return (new Context(Context::create()))->renderer();  // never destroyed, as above
    });
}

}  // namespace tessref::gl
