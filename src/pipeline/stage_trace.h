// stage_trace.h — one invocation of one of a scene's stages run through the SPIR-V
// interpreter with an observer (`tessref trace`): the user's file where the scene's
// [shaders] names one, else the shipped twin, with the uniforms, textures and inputs the
// pipeline gives it (user_program.cpp).
#pragma once

#include <array>
#include <cstddef>
#include <string>

#include <glm/glm.hpp>

#include "tessref/control.h"
#include "tessref/scene.h"
#include "tessref/shader.h"

namespace tessref::pipeline {

struct StageTraceRequest {
    ShaderStage stage = ShaderStage::tess_evaluation;  // vertex, tess_control, tess_evaluation or geometry
    std::size_t patch = 0;
    std::size_t primitive = 0;         // geometry: the patch's triangle, in the generator's order (as gl --capture)
    int vertex = 0;                    // vertex: which of the patch's vertices
    glm::vec3 tess_coord{0.0f};        // tess_evaluation: gl_TessCoord (w filled in for triangles)
    std::array<glm::vec3, 3> triangle{};  // geometry: the primitive's corners' tess coords (filled in)
    MathMode math = MathMode::exact;
};

struct StageTrace {
    std::string shader;              // the file that ran (or the built-in text's name)
    shader::ShaderVertex vertex;     // vertex and evaluation: the outputs
    shader::ShaderPatch patch;       // control: the outputs and levels
    // geometry: the triangle's vertices as the evaluation shader handed them on, and what
    // the geometry shader emitted of them
    std::vector<shader::ShaderVertex> inputs;
    shader::ShaderPrimitives primitives;
    int vertices_per_patch = 0;
};

// Throws tessref::Error naming the flag (--patch, --vertex, --tess-coord, --primitive, --stage) for a
// request the scene cannot answer, and the interpreter's errors.
StageTrace trace_stage(const Scene& scene, const StageTraceRequest& request, shader::Observer& observer);

}  // namespace tessref::pipeline
