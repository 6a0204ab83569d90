// src/gl/gl_api.h — the OpenGL entry points the OSMesa backend uses (private).
//
// Every function is taken through OSMesaGetProcAddress (libOSMesa exports the whole GL
// API), so nothing links against libGL and no loader library is needed.
#pragma once

#include <GL/osmesa.h>  // GL types and enums (gl.h, glext.h)

#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "pipeline/stage_uniforms.h"
#include "tessref/gl_backend.h"

namespace tessref::gl {

// The GLSL layout qualifiers of a generator setting (stage_uniforms.h, shared with the CPU's
// interpreter of the twins).
using pipeline::domain_qualifier;
using pipeline::spacing_qualifier;

// X(name, return type, parameter list)
#define TESSREF_GL_FUNCTIONS(X)                                                                 \
    X(GetString, const GLubyte*, (GLenum))                                                      \
    X(GetError, GLenum, ())                                                                     \
    X(GetIntegerv, void, (GLenum, GLint*))                                                      \
    X(Enable, void, (GLenum))                                                                   \
    X(Disable, void, (GLenum))                                                                  \
    X(Finish, void, ())                                                                         \
    X(CreateShader, GLuint, (GLenum))                                                           \
    X(ShaderSource, void, (GLuint, GLsizei, const GLchar* const*, const GLint*))                \
    X(CompileShader, void, (GLuint))                                                            \
    X(GetShaderiv, void, (GLuint, GLenum, GLint*))                                              \
    X(GetShaderInfoLog, void, (GLuint, GLsizei, GLsizei*, GLchar*))                             \
    X(DeleteShader, void, (GLuint))                                                             \
    X(CreateProgram, GLuint, ())                                                                \
    X(AttachShader, void, (GLuint, GLuint))                                                     \
    X(TransformFeedbackVaryings, void, (GLuint, GLsizei, const GLchar* const*, GLenum))         \
    X(LinkProgram, void, (GLuint))                                                              \
    X(GetProgramiv, void, (GLuint, GLenum, GLint*))                                             \
    X(GetProgramInfoLog, void, (GLuint, GLsizei, GLsizei*, GLchar*))                            \
    X(DeleteProgram, void, (GLuint))                                                            \
    X(UseProgram, void, (GLuint))                                                               \
    X(GenVertexArrays, void, (GLsizei, GLuint*))                                                \
    X(BindVertexArray, void, (GLuint))                                                          \
    X(DeleteVertexArrays, void, (GLsizei, const GLuint*))                                       \
    X(GenBuffers, void, (GLsizei, GLuint*))                                                     \
    X(BindBuffer, void, (GLenum, GLuint))                                                       \
    X(BufferData, void, (GLenum, GLsizeiptr, const void*, GLenum))                              \
    X(BindBufferBase, void, (GLenum, GLuint, GLuint))                                           \
    X(MapBufferRange, void*, (GLenum, GLintptr, GLsizeiptr, GLbitfield))                        \
    X(UnmapBuffer, GLboolean, (GLenum))                                                         \
    X(DeleteBuffers, void, (GLsizei, const GLuint*))                                            \
    X(VertexAttribIPointer, void, (GLuint, GLint, GLenum, GLsizei, const void*))                \
    X(EnableVertexAttribArray, void, (GLuint))                                                  \
    X(PatchParameteri, void, (GLenum, GLint))                                                   \
    X(BeginTransformFeedback, void, (GLenum))                                                   \
    X(EndTransformFeedback, void, ())                                                           \
    X(GenQueries, void, (GLsizei, GLuint*))                                                     \
    X(DeleteQueries, void, (GLsizei, const GLuint*))                                            \
    X(BeginQuery, void, (GLenum, GLuint))                                                       \
    X(EndQuery, void, (GLenum))                                                                 \
    X(GetQueryObjectuiv, void, (GLuint, GLenum, GLuint*))                                       \
    X(DrawArrays, void, (GLenum, GLint, GLsizei))                                               \
    X(Viewport, void, (GLint, GLint, GLsizei, GLsizei))                                         \
    X(ClearColor, void, (GLfloat, GLfloat, GLfloat, GLfloat))                                   \
    X(ClearDepth, void, (GLdouble))                                                             \
    X(Clear, void, (GLbitfield))                                                                \
    X(DepthFunc, void, (GLenum))                                                                \
    X(PolygonMode, void, (GLenum, GLenum))                                                      \
    X(GetUniformLocation, GLint, (GLuint, const GLchar*))                                       \
    X(Uniform1i, void, (GLint, GLint))                                                          \
    X(Uniform1f, void, (GLint, GLfloat))                                                        \
    X(Uniform1d, void, (GLint, GLdouble))                                                       \
    X(Uniform2f, void, (GLint, GLfloat, GLfloat))                                               \
    X(Uniform3f, void, (GLint, GLfloat, GLfloat, GLfloat))                                      \
    X(Uniform4f, void, (GLint, GLfloat, GLfloat, GLfloat, GLfloat))                             \
    X(UniformMatrix3fv, void, (GLint, GLsizei, GLboolean, const GLfloat*))                      \
    X(UniformMatrix4fv, void, (GLint, GLsizei, GLboolean, const GLfloat*))                      \
    X(GenTextures, void, (GLsizei, GLuint*))                                                    \
    X(DeleteTextures, void, (GLsizei, const GLuint*))                                           \
    X(BindTexture, void, (GLenum, GLuint))                                                      \
    X(ActiveTexture, void, (GLenum))                                                            \
    X(TexImage2D, void, (GLenum, GLint, GLint, GLsizei, GLsizei, GLint, GLenum, GLenum,        \
                         const void*))                                                          \
    X(TexParameteri, void, (GLenum, GLenum, GLint))                                             \
    X(GenerateMipmap, void, (GLenum))                                                           \
    X(PixelStorei, void, (GLenum, GLint))                                                       \
    X(VertexAttribPointer, void, (GLuint, GLint, GLenum, GLboolean, GLsizei, const void*))      \
    X(DisableVertexAttribArray, void, (GLuint))                                                 \
    X(PatchParameterfv, void, (GLenum, const GLfloat*))

struct GlFunctions {
#define TESSREF_GL_MEMBER(name, ret, params) ret(GLAPIENTRY* name) params = nullptr;
    TESSREF_GL_FUNCTIONS(TESSREF_GL_MEMBER)
#undef TESSREF_GL_MEMBER
};

// A compiled capture program and its key (domain, spacing, winding, point mode).
struct CaptureProgram {
    GLuint program = 0;
};

struct Context::Impl {
    OSMesaContext osmesa = nullptr;
    std::vector<std::uint8_t> color_buffer;  // 1x1 RGBA: OSMesaMakeCurrent wants one
    GlFunctions gl;
    std::string renderer;
    std::string version;

    // Objects the capture reuses from call to call.
    GLuint vertex_array = 0;
    GLuint level_buffer = 0;     // one vertex per patch: uvec4 outer bits, uvec2 inner bits
    GLuint feedback_buffer = 0;  // transform feedback target
    GLsizeiptr feedback_capacity = 0;
    GLuint query_generated = 0;
    GLuint query_written = 0;
    std::map<std::tuple<int, int, int, bool>, CaptureProgram> programs;

    ~Impl();
    void make_current();  // makes this context current on the calling thread if it is not
    // Draws into `pixels` (RGBA float, row 0 at the BOTTOM, as OSMesa lays it out) from now
    // on; release_color_buffer() goes back to the context's own 1x1 buffer.
    void bind_color_buffer(float* pixels, int width, int height);
    void release_color_buffer();
    void check_error(const char* what);  // throws tessref::Error if glGetError reports one
};

}  // namespace tessref::gl
