// stage_uniforms.h — what a scene's shaders read from the application, by the GLSL twins'
// names: the uniforms, the texture units, the twins' texts. The one list that both sides
// set: the GL backend through glUniform* and its texture units (src/gl/scene_render.cpp),
// the CPU through shader::Bindings when it runs a user's stages with the interpreter
// (user_program.cpp for the stages before the rasterizer, src/render/user_fragment.cpp for
// a user's fragment shader).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/scene.h"
#include "tessref/texture.h"

namespace tessref::shader {
class Bindings;
}

namespace tessref::pipeline {

// Where the values go; a name the program does not declare is ignored by both sides.
struct UniformSink {
    virtual ~UniformSink() = default;
    virtual void i(const char* name, int v) const = 0;
    virtual void f(const char* name, double v) const = 0;  // set as float
    virtual void d(const char* name, double v) const = 0;  // a double uniform (the depth model's planes)
    virtual void v2(const char* name, glm::vec2 v) const = 0;
    virtual void v3(const char* name, glm::vec3 v) const = 0;
    virtual void v4(const char* name, glm::vec4 v) const = 0;
    virtual void m3(const char* name, const glm::mat3& m) const = 0;
    virtual void m4(const char* name, const glm::mat4& m) const = 0;
};

// shader::Bindings (the interpreter's uniforms) as a UniformSink: the GL backend's list, set
// into the interpreter's state. A double uniform is set as a float (the interpreter runs no
// 64-bit types).
struct BindingsSink final : UniformSink {
    shader::Bindings& b;
    explicit BindingsSink(shader::Bindings& bindings) : b(bindings) {}
    void i(const char* name, int v) const override;
    void f(const char* name, double v) const override;
    void d(const char* name, double v) const override;
    void v2(const char* name, glm::vec2 v) const override;
    void v3(const char* name, glm::vec3 v) const override;
    void v4(const char* name, glm::vec4 v) const override;
    void m3(const char* name, const glm::mat3& m) const override;
    void m4(const char* name, const glm::mat4& m) const override;
};

// The matrices as the CPU pipeline rounds them (program.h: mat4_t<float>(camera.view_projection())).
struct StageMatrices {
    glm::mat4 view{1.0f};
    glm::mat4 view_projection{1.0f};
    glm::vec3 eye{0.0f};
};
StageMatrices stage_matrices(const Scene& scene);  // identity without a camera

// The evaluation model's and the control model's uniforms (constantLevel included).
void set_stage_uniforms(const UniformSink& u, const Scene& scene, const StageMatrices& m, glm::ivec2 viewport);

// The fragment stage's uniforms: the shading model's (shading.h), by its twin's names.
void set_shading_uniforms(const UniformSink& u, const ShadingModel& shading);

// The textures those stages sample, at the twins' layout(binding = N): 0 heightMap,
// 1 tessellationMap, 2 normalMap. `what` names the texture in errors.
using TextureBinder = std::function<void(int unit, const Texture* texture, const std::string& what)>;
void bind_stage_textures(const Scene& scene, const TextureBinder& bind);
// Every texture the scene's program samples, fragment stage included, with its unit: the
// stages' above, 4.. the shading model's samplers in the order of shading.h's
// sampler_names (heightMap at 0), geomip_terrain.frag's 4..13. A null texture (a slot the
// scene leaves empty) is passed on as null; the caller binds nothing for it.
void bind_program_textures(const Scene& scene, const RenderShading& shading, const TextureBinder& bind);

// The constant control stage for the twins whose vertex shader hands on VertexData and
// whose evaluation shader reads ControlData (thesis): GL has no constant control shader of
// its own, and without one the blocks of the two stages would not match.
extern const char* const kConstantControlShader;

// The GLSL layout qualifiers of a generator setting: `layout(quads, fractional_odd_spacing,
// ccw) in;` in an evaluation shader (the GL backend's capture and scene programs, and
// the twins the CPU interprets, write it).
inline const char* domain_qualifier(Domain d) {
    switch (d) {
        case Domain::quads: return "quads";
        case Domain::triangles: return "triangles";
        case Domain::isolines: return "isolines";
    }
    return "quads";
}

inline const char* spacing_qualifier(Spacing s) {
    switch (s) {
        case Spacing::equal: return "equal_spacing";
        case Spacing::fractional_odd: return "fractional_odd_spacing";
        case Spacing::fractional_even: return "fractional_even_spacing";
    }
    return "equal_spacing";
}

// The scene's [generator] in place of the evaluation shader's own layout(...) in; line, so
// that a twin tessellates as the CPU pipeline does (the twins' lines are the scenes'
// defaults). Throws tessref::Error naming `path` when the text has no such line.
std::string with_generator(const std::string& text, const TessSettings& g, const std::string& path);

// The scene's [shaders] with each flag's entry (--shader STAGE=FILE) in place of the one of
// its stage, ordered vertex .. fragment.
std::vector<StageShader> with_shader_flags(const std::vector<StageShader>& scene, const std::vector<StageShader>& flags);

// The text of a user's shader file (read through InputFile, at most kShaderFileBytes).
// Throws tessref::Error at the file's [shaders] key or flag when it is unreadable, and at
// its line when it holds a NUL byte (GL reads the source as a C string, up to it).
std::string read_user_shader(const StageShader& user);

// The shipped twin (a file name in data/shaders/) of the scene's model for `stage`: the text
// whose C++ model is proven to compute it bit for bit. "" where the model has none (the
// constant control stage, a geometry stage the C++ models compute alone, the flat and depth
// shading, geomipmap's tessellation stages).
std::string twin_file(const Scene& scene, ShaderStage stage);

// The text of a twin file (data/shaders/`file`).
std::string twin_text(const std::string& file);

// Whether `user` holds exactly the text of its stage's twin: the C++ model (or the built-in
// shading) is then the fast path for it, and the interpreter does not run it.
bool is_twin(const Scene& scene, const StageShader& user);

}  // namespace tessref::pipeline
