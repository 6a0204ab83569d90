// stage_uniforms.h — what a scene's shaders before the rasterizer read from the
// application, by the GLSL twins' names: the uniforms, the texture units, the twins'
// texts. The one list that both sides set: the GL backend through glUniform* and its
// texture units (src/gl/scene_render.cpp), the CPU through shader::Bindings when it runs a
// user's stages with the interpreter (user_program.cpp). The fragment stage's uniforms
// stay with the GL backend: the CPU runs no fragment shader.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/scene.h"
#include "tessref/texture.h"

namespace tessref::pipeline {

// Where the values go; a name the program does not declare is ignored by both sides.
struct UniformSink {
    virtual ~UniformSink() = default;
    virtual void i(const char* name, int v) const = 0;
    virtual void f(const char* name, double v) const = 0;  // set as float
    virtual void v2(const char* name, glm::vec2 v) const = 0;
    virtual void v3(const char* name, glm::vec3 v) const = 0;
    virtual void v4(const char* name, glm::vec4 v) const = 0;
    virtual void m3(const char* name, const glm::mat3& m) const = 0;
    virtual void m4(const char* name, const glm::mat4& m) const = 0;
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

// The textures those stages sample, at the twins' layout(binding = N): 0 heightMap,
// 1 tessellationMap, 2 normalMap. `what` names the texture in errors.
using TextureBinder = std::function<void(int unit, const Texture* texture, const std::string& what)>;
void bind_stage_textures(const Scene& scene, const TextureBinder& bind);

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

}  // namespace tessref::pipeline
