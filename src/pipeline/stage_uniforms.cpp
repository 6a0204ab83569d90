// stage_uniforms.cpp — the uniforms, texture units and twin texts of a scene's stages, one
// list for the GL backend and the CPU interpreter (stage_uniforms.h).
#include "pipeline/stage_uniforms.h"

#include <algorithm>
#include <cmath>
#include <regex>

#include "common/input_file.h"
#include "tessref/error.h"
#include "tessref/shader.h"

namespace tessref::pipeline {

namespace {

// ---- one function per model, from the scene's settings structs --------------------------

void thesis_uniforms(const UniformSink& u, const Scene& scene, const StageMatrices& m) {
    const TerrainGrid& g = *scene.grid;
    u.f("scaleXY", g.scale_xy);
    u.f("scaleZ", g.scale_z);
    u.m4("mvp", m.view_projection);
    u.m3("normalMatrix", glm::mat3(1.0f));  // the model matrix is the identity
}

void thesis_control_uniforms(const UniformSink& u, const Scene& scene, const ThesisControlParams<double>& c,
                             const StageMatrices& m) {
    u.f("tessellationLevel", c.tessellationLevel);
    u.f("scaleXY", scene.grid->scale_xy);
    u.v3("cameraPosition", m.eye);
    u.i("thesisFactor", static_cast<int>(c.factor));  // distance 0, map 1, normal 2, all 3
    u.f("distanceLimit", c.distance.limit);
    u.f("distanceDivisor", c.distance.divisor);
    u.f("normalAngleThreshold", c.normalAngleThreshold);
    u.f("normalTessellationWeight", c.weights.normal);
    u.f("textureTessellationWeight", c.weights.texture);
    u.f("distanceTessellationWeight", c.weights.distance);
    u.f("constantTessellationWeight", c.weights.constant);
}

void cosc422_uniforms(const UniformSink& u, const Scene& scene, const StageMatrices& m) {
    const TerrainGrid& g = *scene.grid;
    u.m4("mvpMatrix", m.view_projection);
    u.m4("mvMatrix", m.view);
    u.f("xMin", g.extent_u.x);
    u.f("xMax", g.extent_u.y);
    u.f("zMin", g.extent_v.x);
    u.f("zMax", g.extent_v.y);
    u.f("heightScale", g.scale_z);
    // TERRAIN_NORMALS: one texel, as the CPU's height_field_normal (pipeline/terrain.cpp)
    u.f("gridStep", std::abs(g.extent_u.y - g.extent_u.x) / g.heightmap->texture.width());
    if (scene.control && scene.control->model == ControlModel::cosc422)
        u.i("levelSpace", scene.control->cosc422 == Cosc422Space::eye ? 1 : 0);
}

void lab4_uniforms(const UniformSink& u, const Scene& scene, const StageMatrices& m) {
    const TerrainGrid& g = *scene.grid;
    u.m4("mvp", m.view_projection);
    u.f("horizontalScale", g.scale_xy);
    u.f("verticalScale", g.scale_z);
    u.v2("texCoordOffset", glm::vec2(g.texcoord_offset));
    u.f("gridStep", g.scale_xy / g.heightmap->texture.width());  // as the CPU program: one texel
}

void lab4_control_uniforms(const UniformSink& u, const Lab4ControlParams<double>& c, const StageMatrices& m) {
    u.v3("cameraPosition", m.eye);
    u.f("firstZoneEnd", c.firstZoneEnd);
    u.f("zoneGrowth", c.zoneGrowth);
    u.f("maxLevel", c.maxLevel);
    u.f("minLevel", c.minLevel);
    u.i("edgeRule", c.edgeRule == Lab4EdgeRule::lower ? 0 : 1);
}

void pn_uniforms(const UniformSink& u, const Scene& scene, const StageMatrices& m, glm::ivec2 viewport) {
    u.m4("m4Transform", glm::mat4(1.0f));  // the meshes are translated and scaled at load
    u.m4("m4ViewProjection", m.view_projection);
    u.f("fInfluence", scene.evaluation.pn.fInfluence);
    u.i("normalMode", scene.evaluation.pn.normal == PnNormal::linear ? 0 : 1);
    u.i("watertightEdges", scene.evaluation.pn.watertightEdges ? 1 : 0);
    u.v2("v2Resolution", glm::vec2(viewport));
    if (scene.control && scene.control->model == ControlModel::pn)
        u.i("flatEdgesAtLevel1", scene.control->pn.flatEdgesAtLevel1 ? 1 : 0);
}

void geomip_uniforms(const UniformSink& u, const Scene& scene, const StageMatrices& m) {
    u.m4("mvp", m.view_projection);
    u.f("scaleZ", scene.grid->scale_z);  // the pipeline's float(settings.scale_z)
}

void geomip_shading_uniforms(const UniformSink& u, const GeomipLightmapShading& g) {
    u.i("materialCount", static_cast<int>(g.materials.size()));
    for (std::size_t i = 0; i < g.materials.size(); ++i)
        u.f(("materialRepeat[" + std::to_string(i) + "]").c_str(), g.materials[i].repeat);
    u.v2("lightMapScale", g.lightMapScale);
    u.v2("lightMapOffset", g.lightMapOffset);
    u.i("cloudsEnabled", g.clouds ? 1 : 0);
    u.f("cloudRepeat", g.cloudRepeat);
    u.v2("cloudOffset", g.cloudOffset);
}

}  // namespace

void set_shading_uniforms(const UniformSink& u, const ShadingModel& s) {
    switch (s.kind) {
        case ShadingKind::flat: u.v4("colour", s.flat.colour); break;
        case ShadingKind::depth:
            u.i("windowMapping", s.depth.mapping == DepthMapping::window ? 1 : 0);
            // The fragment shader's double uniforms hold the floats of shading.h exactly widened.
            u.d("nearPlane", s.depth.near_plane);
            u.d("farPlane", s.depth.far_plane);
            break;
        case ShadingKind::thesis_single:
        case ShadingKind::thesis_multi:
            u.v3("lightPosition", s.thesis.lightPosition);
            u.v3("diffuseMaterial", s.thesis.diffuseMaterial);
            u.v3("ambientMaterial", s.thesis.ambientMaterial);
            u.v3("specularMaterial", s.thesis.specularMaterial);
            u.f("shininess", s.thesis.shininess);
            u.m4("rotationMatrix", s.rotationMatrix);
            break;
        case ShadingKind::lab4:
            u.v3("cameraPosition", s.lab4.cameraPosition);
            u.v3("lightDirection", s.lab4.lightDirection);
            u.v3("sandColour", s.lab4.sandColour);
            u.v3("rockColour", s.lab4.rockColour);
            u.f("sandHeight", s.lab4.sandHeight);
            u.f("blendWidth", s.lab4.blendWidth);
            break;
        case ShadingKind::cosc422:
            u.v3("lightDirection", s.cosc422.lightDirection);
            u.f("ambient", s.cosc422.ambient);
            break;
        case ShadingKind::pn:
            u.v3("v3CameraPosition", s.pn.v3CameraPosition);
            u.v3("v3LightDirection", s.pn.v3LightDirection);
            u.v3("v3DiffuseColour", s.pn.v3DiffuseColour);
            u.f("fShininess", s.pn.fShininess);
            break;
        case ShadingKind::pom:
            u.v3("v3CameraPosition", s.pom.v3CameraPosition);
            u.v3("v3LightDirection", s.pom.v3LightDirection);
            u.v3("v3DiffuseColour", s.pom.v3DiffuseColour);
            u.f("fShininess", s.pom.fShininess);
            u.i("iParallaxMode", static_cast<int>(s.pom.parallax.mode));
            u.f("fBumpScale", s.pom.parallax.fBumpScale);
            u.f("fMinLayers", s.pom.parallax.fMinLayers);
            u.f("fMaxLayers", s.pom.parallax.fMaxLayers);
            u.f("fShadowLayers", s.pom.parallax.fShadowLayers);
            u.i("bSelfShadow", s.pom.bSelfShadow ? 1 : 0);
            u.f("fUvRepeat", s.pom.fUvRepeat);
            break;
        case ShadingKind::geomip_lightmap: geomip_shading_uniforms(u, s.geomip); break;
    }
}

void BindingsSink::i(const char* name, int v) const { b.set(name, v); }
void BindingsSink::f(const char* name, double v) const { b.set(name, static_cast<float>(v)); }
void BindingsSink::d(const char* name, double v) const { b.set(name, static_cast<float>(v)); }
void BindingsSink::v2(const char* name, glm::vec2 v) const { b.set(name, v); }
void BindingsSink::v3(const char* name, glm::vec3 v) const { b.set(name, v); }
void BindingsSink::v4(const char* name, glm::vec4 v) const { b.set(name, v); }
void BindingsSink::m3(const char* name, const glm::mat3& m) const { b.set(name, m); }
void BindingsSink::m4(const char* name, const glm::mat4& m) const { b.set(name, m); }

StageMatrices stage_matrices(const Scene& scene) {
    StageMatrices m;
    if (!scene.camera) return m;
    m.view = glm::mat4(scene.camera->view());
    m.view_projection = glm::mat4(scene.camera->view_projection());
    m.eye = glm::vec3(scene.camera->eye);
    return m;
}

void set_stage_uniforms(const UniformSink& u, const Scene& scene, const StageMatrices& m, glm::ivec2 viewport) {
    switch (scene.evaluation.model) {
        case EvaluationModel::thesis: thesis_uniforms(u, scene, m); break;
        case EvaluationModel::cosc422: cosc422_uniforms(u, scene, m); break;
        case EvaluationModel::lab4: lab4_uniforms(u, scene, m); break;
        case EvaluationModel::pn: pn_uniforms(u, scene, m, viewport); break;
        case EvaluationModel::geomipmap: geomip_uniforms(u, scene, m); break;
    }
    if (scene.control) {
        const ControlStage& c = *scene.control;
        if (c.model == ControlModel::thesis) thesis_control_uniforms(u, scene, c.thesis, m);
        if (c.model == ControlModel::lab4) lab4_control_uniforms(u, c.lab4, m);
        if (c.model == ControlModel::constant) u.f("constantLevel", c.constant.level);
    } else {
        u.f("constantLevel", 1.0);  // GL's default patch levels
    }
}

void bind_stage_textures(const Scene& scene, const TextureBinder& bind) {
    if (scene.grid) {
        bind(0, &scene.grid->heightmap->texture, "heightMap (" + scene.grid->heightmap_path + ")");
        if (scene.grid->normal_map) bind(2, scene.grid->normal_map.get(), "normalMap");
    }
    if (scene.control && scene.control->model == ControlModel::thesis && scene.control->tessellation_map)
        bind(1, scene.control->tessellation_map.get(), "tessellationMap");
}

void bind_program_textures(const Scene& scene, const RenderShading& shading, const TextureBinder& bind) {
    bind_stage_textures(scene, bind);
    if (shading.model.kind == ShadingKind::geomip_lightmap) {  // geomip_terrain.frag's bindings
        const GeomipLightmapShading& g = shading.model.geomip;
        bind(4, g.lightMap.get(), "lightMap");
        for (std::size_t i = 0; i < g.materials.size(); ++i) {
            bind(5 + static_cast<int>(i), g.materials[i].texture.get(), "materials[" + std::to_string(i) + "]");
            bind(9 + static_cast<int>(i), g.materials[i].alpha.get(), "alphaMaps[" + std::to_string(i) + "]");
        }
        bind(13, g.clouds.get(), "clouds");
    }
    const auto names = sampler_names(shading.model.kind);
    for (std::size_t i = 0; i < names.size(); ++i) {
        const auto* slot = sampler_slot(shading.model.textures, names[i]);
        if (!slot || !*slot) continue;
        const int unit = names[i] == "heightMap" ? 0 : 4 + static_cast<int>(i);
        bind(unit, slot->get(), std::string(names[i]));
    }
}

const char* const kConstantControlShader = R"(#version 450 core
layout(vertices = 4) out;
layout(location = 0) in VertexData { vec4 vPosition; } vertexIn[];
layout(location = 0) out ControlData { vec4 tcPosition; } controlOut[];
uniform float constantLevel;
void main()
{
    controlOut[gl_InvocationID].tcPosition = vertexIn[gl_InvocationID].vPosition;
    gl_TessLevelOuter[0] = constantLevel;
    gl_TessLevelOuter[1] = constantLevel;
    gl_TessLevelOuter[2] = constantLevel;
    gl_TessLevelOuter[3] = constantLevel;
    gl_TessLevelInner[0] = constantLevel;
    gl_TessLevelInner[1] = constantLevel;
}
)";


std::string with_generator(const std::string& text, const TessSettings& g, const std::string& path) {
    static const std::regex layout(R"(layout\s*\(\s*(quads|triangles|isolines)[^)]*\)\s*in\s*;)");
    std::string replacement = std::string("layout(") + domain_qualifier(g.domain) + ", " +
                              spacing_qualifier(g.spacing) + ", " + (g.winding == Winding::cw ? "cw" : "ccw") +
                              (g.point_mode ? ", point_mode" : "") + ") in;";
    std::smatch m;
    if (!std::regex_search(text, m, layout))
        throw Error("the evaluation shader has no layout(quads|triangles|isolines, ...) in; line", Where::in_file(path));
    return m.prefix().str() + replacement + m.suffix().str();
}

std::vector<StageShader> with_shader_flags(const std::vector<StageShader>& scene, const std::vector<StageShader>& flags) {
    std::vector<StageShader> shaders = flags;
    for (const StageShader& s : scene)
        if (std::none_of(shaders.begin(), shaders.end(), [&](const StageShader& o) { return o.stage == s.stage; }))
            shaders.push_back(s);
    std::sort(shaders.begin(), shaders.end(),
              [](const StageShader& a, const StageShader& b) { return a.stage < b.stage; });
    return shaders;
}

std::string read_user_shader(const StageShader& user) {
    const std::string what = std::string("the ") + to_string(user.stage) + " shader " + user.path + " of " + user.origin;
    std::string text;
    try {
        text = read_input_file(user.path, "shader file", kShaderFileBytes);
    } catch (const Error& e) {
        throw Error("cannot read " + what + ": " + e.message(), user.where);
    }
    // GL takes the source as C strings: a NUL byte would end the shader there, silently.
    if (const std::size_t nul = text.find('\0'); nul != std::string::npos)
        throw Error(what + " holds a NUL byte (GL would read the shader only up to it)",
                    Where::in_file(user.path, static_cast<std::size_t>(std::count(text.begin(), text.begin() +
                                                                                 static_cast<std::ptrdiff_t>(nul), '\n')) + 1));
    return text;
}

}  // namespace tessref::pipeline
