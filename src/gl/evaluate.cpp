// A GLSL float expression evaluated on llvmpipe (gl_backend.h, evaluate): one point per
// input, the operands as raw bits in one vertex attribute, the result back by transform
// feedback with the rasterizer discarded.
#include <cstring>

#include "gl/gl_api.h"
#include "gl/program.h"
#include "tessref/error.h"

namespace tessref::gl {

std::string evaluate_shader(const std::string& expression, const std::string& functions) {
    // uintBitsToFloat hands every operand over untouched (NaN payloads, denormals); the
    // compiler cannot fold the expression, since its operands are only known at draw time.
    return "#version 450 core\n"
           "layout(location = 0) in uvec2 operands;\n"
           "out float result;\n" +
           functions +
           "void main() {\n"
           "    float x = uintBitsToFloat(operands.x);\n"
           "    float y = uintBitsToFloat(operands.y);\n"
           "    result = " + expression + ";\n"
           "    gl_Position = vec4(0.0);\n"
           "}\n";
}

std::vector<float> evaluate(Context& context, const std::string& expression,
                            std::span<const float> x, std::span<const float> y, const std::string& functions) {
    if (!y.empty() && y.size() != x.size())
        throw Error("evaluate: " + std::to_string(x.size()) + " x operands but " +
                    std::to_string(y.size()) + " y operands");
    std::vector<float> result(x.size());
    if (x.empty()) return result;

    Context::Impl& c = context.impl();
    c.make_current();
    auto& gl = c.gl;

    StageSource vs;
    vs.stage = GL_VERTEX_SHADER;
    vs.text = evaluate_shader(expression, functions);
    const GLuint program = link(gl, {vs}, {"result"}, "the expression program");

    std::vector<std::uint32_t> operands(2 * x.size(), 0u);
    for (std::size_t i = 0; i < x.size(); ++i) {
        std::memcpy(&operands[2 * i], &x[i], sizeof(float));
        if (!y.empty()) std::memcpy(&operands[2 * i + 1], &y[i], sizeof(float));
    }
    GLuint vertex_array = 0, buffers[2] = {0, 0};
    gl.GenVertexArrays(1, &vertex_array);
    gl.GenBuffers(2, buffers);
    gl.BindVertexArray(vertex_array);
    gl.BindBuffer(GL_ARRAY_BUFFER, buffers[0]);
    gl.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(operands.size() * sizeof(std::uint32_t)),
                  operands.data(), GL_STATIC_DRAW);
    gl.VertexAttribIPointer(0, 2, GL_UNSIGNED_INT, 0, nullptr);
    gl.EnableVertexAttribArray(0);
    gl.BindBuffer(GL_TRANSFORM_FEEDBACK_BUFFER, buffers[1]);
    gl.BufferData(GL_TRANSFORM_FEEDBACK_BUFFER, static_cast<GLsizeiptr>(x.size() * sizeof(float)),
                  nullptr, GL_STREAM_READ);
    gl.BindBufferBase(GL_TRANSFORM_FEEDBACK_BUFFER, 0, buffers[1]);
    gl.UseProgram(program);
    gl.Enable(GL_RASTERIZER_DISCARD);
    gl.BeginTransformFeedback(GL_POINTS);
    gl.DrawArrays(GL_POINTS, 0, static_cast<GLsizei>(x.size()));
    gl.EndTransformFeedback();
    gl.Disable(GL_RASTERIZER_DISCARD);
    const void* mapped = gl.MapBufferRange(GL_TRANSFORM_FEEDBACK_BUFFER, 0,
                                           static_cast<GLsizeiptr>(x.size() * sizeof(float)), GL_MAP_READ_BIT);
    if (mapped) {
        std::memcpy(result.data(), mapped, result.size() * sizeof(float));
        gl.UnmapBuffer(GL_TRANSFORM_FEEDBACK_BUFFER);
    }
    gl.UseProgram(0);
    gl.DeleteProgram(program);
    gl.BindVertexArray(0);
    gl.DeleteVertexArrays(1, &vertex_array);
    gl.DeleteBuffers(2, buffers);
    if (!mapped) throw Error("evaluate: cannot map the transform feedback buffer");
    c.check_error("evaluating an expression");
    return result;
}

}  // namespace tessref::gl
