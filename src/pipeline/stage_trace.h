// stage_trace.h — one invocation of one of a scene's stages run through the SPIR-V
// interpreter with an observer (`tessref trace`): the user's file where the scene's
// [shaders] names one, else the shipped twin, with the uniforms, textures and inputs the
// pipeline gives it (user_program.cpp).
#pragma once

#include <cstddef>
#include <string>

#include <glm/glm.hpp>

#include "tessref/control.h"
#include "tessref/scene.h"
#include "tessref/shader.h"

namespace tessref::pipeline {

struct StageTraceRequest {
    ShaderStage stage = ShaderStage::tess_evaluation;  // vertex, tess_control or tess_evaluation
    std::size_t patch = 0;
    int vertex = 0;                    // vertex: which of the patch's vertices
    glm::vec3 tess_coord{0.0f};        // tess_evaluation: gl_TessCoord (w filled in for triangles)
    MathMode math = MathMode::exact;
};

struct StageTrace {
    std::string shader;              // the file that ran (or the built-in text's name)
    shader::ShaderVertex vertex;     // vertex and evaluation: the outputs
    shader::ShaderPatch patch;       // control: the outputs and levels
    int vertices_per_patch = 0;
};

// Throws tessref::Error naming the flag (--patch, --vertex, --tess-coord, --stage) for a
// request the scene cannot answer, and the interpreter's errors.
StageTrace trace_stage(const Scene& scene, const StageTraceRequest& request, shader::Observer& observer);

}  // namespace tessref::pipeline
