// Differential test of the rasterizer against Mesa's llvmpipe (OSMesa), the arbiter of
// "coverage exactly as llvmpipe": the same clip-space triangles are drawn by OpenGL into
// OSMesa's own (window-system) buffer and by tessref::rasterize, and the coverage is compared
// pixel for pixel, for every triangle on its own; 100% agreement is required.
//
// How llvmpipe's coverage of many triangles is read back in few draws: a float RGBA buffer,
// additive blending, and triangle i of a pass adding 16^(i % 6) to channel i / 6, so each
// pixel ends up holding, in 4-bit digits, how many fragments each of the pass's 24 triangles
// generated there (exact in float). Fill covers a pixel at most once per triangle; a
// wireframe triangle's edges can cover it two or three times, and the counts must agree too. Each triangle is its own draw call with its id in a uniform (a flat vertex output
// is not reliable for the lines of glPolygonMode(GL_LINE) on llvmpipe: some line fragments
// came out with the next triangle's id). The vertex shader passes clip coordinates through
// unchanged; no transform is involved. OSMesa's buffer has row 0 at the bottom (GL window y), tessref's at the top.
//
// Cases (fixed seeds): small, large and sliver triangles, triangles on a quarter-pixel grid
// (pixel-centre aligned edges and vertices, rounding ties), many sub-pixel positions, shared
// edges (quads, fans), perspective w, huge coordinates (up to 1e7, w up to 1e18), triangles
// crossing the near plane
// and every other clip plane, vertices exactly on a clip plane; the same in
// glPolygonMode(GL_LINE); back-face culling; the same through pass-through tessellation
// shaders (draw's other window transform); overlapping triangles with depth LESS; and the
// shipped scenes' tessellated surfaces drawn whole (per-pixel fragment counts).
#include <gtest/gtest.h>

#include <GL/osmesa.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "tessref/prepare.h"
#include "tessref/raster.h"
#include "tessref/pipeline.h"

namespace {

using Tri = std::array<glm::vec4, 3>;

// ---------------------------------------------------------------------------------------
// A minimal OSMesa GL 4.5 core context with the few entry points the test needs.

#define RASTER_TEST_GL(X)                                                        \
    X(GetString, const GLubyte*, (GLenum))                                       \
    X(GetError, GLenum, ())                                                      \
    X(Enable, void, (GLenum))                                                    \
    X(Disable, void, (GLenum))                                                   \
    X(Finish, void, ())                                                          \
    X(Viewport, void, (GLint, GLint, GLsizei, GLsizei))                          \
    X(ClearColor, void, (GLfloat, GLfloat, GLfloat, GLfloat))                    \
    X(ClearDepth, void, (GLdouble))                                              \
    X(Clear, void, (GLbitfield))                                                 \
    X(BlendFunc, void, (GLenum, GLenum))                                         \
    X(BlendEquation, void, (GLenum))                                             \
    X(DepthFunc, void, (GLenum))                                                 \
    X(PolygonMode, void, (GLenum, GLenum))                                       \
    X(CullFace, void, (GLenum))                                                  \
    X(FrontFace, void, (GLenum))                                                 \
    X(CreateShader, GLuint, (GLenum))                                            \
    X(ShaderSource, void, (GLuint, GLsizei, const GLchar* const*, const GLint*)) \
    X(CompileShader, void, (GLuint))                                             \
    X(GetShaderiv, void, (GLuint, GLenum, GLint*))                               \
    X(GetShaderInfoLog, void, (GLuint, GLsizei, GLsizei*, GLchar*))              \
    X(CreateProgram, GLuint, ())                                                 \
    X(AttachShader, void, (GLuint, GLuint))                                      \
    X(LinkProgram, void, (GLuint))                                               \
    X(GetProgramiv, void, (GLuint, GLenum, GLint*))                              \
    X(GetProgramInfoLog, void, (GLuint, GLsizei, GLsizei*, GLchar*))             \
    X(UseProgram, void, (GLuint))                                                \
    X(GetUniformLocation, GLint, (GLuint, const GLchar*))                        \
    X(Uniform1i, void, (GLint, GLint))                                           \
    X(GenVertexArrays, void, (GLsizei, GLuint*))                                 \
    X(BindVertexArray, void, (GLuint))                                           \
    X(GenBuffers, void, (GLsizei, GLuint*))                                      \
    X(BindBuffer, void, (GLenum, GLuint))                                        \
    X(BufferData, void, (GLenum, GLsizeiptr, const void*, GLenum))               \
    X(VertexAttribPointer, void, (GLuint, GLint, GLenum, GLboolean, GLsizei, const void*)) \
    X(EnableVertexAttribArray, void, (GLuint))                                   \
    X(DrawArrays, void, (GLenum, GLint, GLsizei))                                \
    X(PatchParameteri, void, (GLenum, GLint))

struct Gl {
#define RASTER_TEST_GL_MEMBER(name, ret, params) ret(*name) params = nullptr;
    RASTER_TEST_GL(RASTER_TEST_GL_MEMBER)
#undef RASTER_TEST_GL_MEMBER
};

const char* kVertexShader = R"(#version 450 core
layout(location = 0) in vec4 position;
void main() { gl_Position = position; }
)";

// A pass-through tessellation (one patch = the triangle, every level 1: the generator emits
// exactly its three corners, tess coords 0 and 1, so gl_Position is copied exactly). Drawn
// this way, llvmpipe computes window coordinates in draw's C post-shader path, as for every
// tessellated draw, instead of the vertex-shader JIT.
const char* kTessControlShader = R"(#version 450 core
layout(vertices = 3) out;
void main() {
    gl_out[gl_InvocationID].gl_Position = gl_in[gl_InvocationID].gl_Position;
    gl_TessLevelOuter[0] = 1.0;
    gl_TessLevelOuter[1] = 1.0;
    gl_TessLevelOuter[2] = 1.0;
    gl_TessLevelInner[0] = 1.0;
}
)";
const char* kTessEvaluationShader = R"(#version 450 core
layout(triangles, equal_spacing, ccw) in;
void main() {
    gl_Position = gl_TessCoord.x * gl_in[0].gl_Position + gl_TessCoord.y * gl_in[1].gl_Position +
                  gl_TessCoord.z * gl_in[2].gl_Position;
}
)";

// mode 0: add 16^(id % 6) to channel id / 6 (fragment counts); mode 1: write id + 1 in red.
const char* kFragmentShader = R"(#version 450 core
uniform int mode;
uniform int id;
out vec4 colour;
void main() {
    if (mode == 0) {
        vec4 c = vec4(0.0);
        c[id / 6] = float(1 << (4 * (id % 6)));
        colour = c;
    } else {
        colour = vec4(float(id + 1), 0.0, 0.0, 1.0);
    }
}
)";

class Llvmpipe {
public:
    Llvmpipe() {
        const int attributes[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 24,
                                  OSMESA_STENCIL_BITS, 0, OSMESA_ACCUM_BITS, 0,
                                  OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                                  OSMESA_CONTEXT_MAJOR_VERSION, 4,
                                  OSMESA_CONTEXT_MINOR_VERSION, 5, 0};
        ctx_ = OSMesaCreateContextAttribs(attributes, nullptr);
        if (!ctx_) return;
        resize(1, 1);
        if (!ok_) return;
#define RASTER_TEST_GL_LOAD(name, ret, params)                                                \
    gl_.name = reinterpret_cast<ret(*) params>(OSMesaGetProcAddress("gl" #name));               \
    if (!gl_.name) { error_ = "missing gl" #name; ok_ = false; return; }
        RASTER_TEST_GL(RASTER_TEST_GL_LOAD)
#undef RASTER_TEST_GL_LOAD
        renderer_ = reinterpret_cast<const char*>(gl_.GetString(GL_RENDERER));
        version_ = reinterpret_cast<const char*>(gl_.GetString(GL_VERSION));
        program_ = link(false);
        tess_program_ = link(true);
        if (!program_ || !tess_program_) { ok_ = false; return; }
        GLuint vao = 0;
        gl_.GenVertexArrays(1, &vao);
        gl_.BindVertexArray(vao);
        gl_.GenBuffers(1, &position_buffer_);
        gl_.BindBuffer(GL_ARRAY_BUFFER, position_buffer_);
        gl_.VertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, 0, nullptr);
        gl_.EnableVertexAttribArray(0);
        ok_ = gl_.GetError() == GL_NO_ERROR;
        if (!ok_) error_ = "GL error during setup";
    }
    ~Llvmpipe() {
        if (ctx_) OSMesaDestroyContext(ctx_);
    }
    Llvmpipe(const Llvmpipe&) = delete;
    Llvmpipe& operator=(const Llvmpipe&) = delete;

    bool ok() const { return ok_; }
    const std::string& error() const { return error_; }
    std::string description() const { return renderer_ + ", " + version_; }

    void resize(int width, int height) {
        width_ = width;
        height_ = height;
        buffer_.assign(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 4, 0.0f);
        ok_ = OSMesaMakeCurrent(ctx_, buffer_.data(), GL_FLOAT, width, height);
        if (!ok_) error_ = "OSMesaMakeCurrent(GL_FLOAT) failed";
        if (ok_ && gl_.Viewport) gl_.Viewport(0, 0, width, height);
    }

    struct DrawState {
        bool lines = false;
        bool cull_back = false;
        bool depth_less = false;
        bool tessellation = false;  // through the pass-through tessellation shaders
        bool one_id = false;        // all triangles with id 0, in large draw calls
    };

    // Draws the triangles (vertex i*3+k), triangle i with id i; returns the RGBA float buffer,
    // row 0 = bottom.
    const std::vector<float>& draw(const std::vector<Tri>& tris, int mode, const DrawState& state) {
        std::vector<glm::vec4> positions;
        for (const Tri& t : tris) positions.insert(positions.end(), t.begin(), t.end());
        gl_.BindBuffer(GL_ARRAY_BUFFER, position_buffer_);
        gl_.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(positions.size() * sizeof(glm::vec4)),
                       positions.data(), GL_STREAM_DRAW);
        const GLuint program = state.tessellation ? tess_program_ : program_;
        gl_.UseProgram(program);
        gl_.Uniform1i(gl_.GetUniformLocation(program, "mode"), mode);
        const GLint id_location = gl_.GetUniformLocation(program, "id");
        if (state.tessellation) gl_.PatchParameteri(GL_PATCH_VERTICES, 3);
        gl_.ClearColor(0, 0, 0, 0);
        gl_.ClearDepth(1.0);
        gl_.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
        if (mode == 0) {
            gl_.Enable(GL_BLEND);
            gl_.BlendEquation(GL_FUNC_ADD);
            gl_.BlendFunc(GL_ONE, GL_ONE);
        } else {
            gl_.Disable(GL_BLEND);
        }
        if (state.depth_less) {
            gl_.Enable(GL_DEPTH_TEST);
            gl_.DepthFunc(GL_LESS);
        } else {
            gl_.Disable(GL_DEPTH_TEST);
        }
        if (state.cull_back) {
            gl_.Enable(GL_CULL_FACE);
            gl_.CullFace(GL_BACK);
            gl_.FrontFace(GL_CCW);
        } else {
            gl_.Disable(GL_CULL_FACE);
        }
        gl_.PolygonMode(GL_FRONT_AND_BACK, state.lines ? GL_LINE : GL_FILL);
        if (state.one_id) {
            gl_.Uniform1i(id_location, 0);
            constexpr std::size_t kPerDraw = 50000;  // well below llvmpipe's trouble zone
            for (std::size_t first = 0; first < tris.size(); first += kPerDraw) {
                const std::size_t count = std::min(kPerDraw, tris.size() - first);
                gl_.DrawArrays(state.tessellation ? GL_PATCHES : GL_TRIANGLES, static_cast<GLint>(3 * first),
                               static_cast<GLsizei>(3 * count));
            }
        } else {
            for (std::size_t i = 0; i < tris.size(); ++i) {
                gl_.Uniform1i(id_location, static_cast<GLint>(i));
                gl_.DrawArrays(state.tessellation ? GL_PATCHES : GL_TRIANGLES, static_cast<GLint>(3 * i), 3);
            }
        }
        gl_.Finish();
        gl_.Finish();
        last_error_ = gl_.GetError();
        return buffer_;
    }
    GLenum last_error() const { return last_error_; }

private:
    GLuint compile(GLenum type, const char* source) {
        const GLuint shader = gl_.CreateShader(type);
        gl_.ShaderSource(shader, 1, &source, nullptr);
        gl_.CompileShader(shader);
        GLint status = 0;
        gl_.GetShaderiv(shader, GL_COMPILE_STATUS, &status);
        if (!status) {
            char log[2048] = {};
            gl_.GetShaderInfoLog(shader, sizeof log, nullptr, log);
            error_ = std::string("shader: ") + log;
            return 0;
        }
        return shader;
    }
    GLuint link(bool tessellation) {
        const GLuint vs = compile(GL_VERTEX_SHADER, kVertexShader);
        const GLuint fs = compile(GL_FRAGMENT_SHADER, kFragmentShader);
        if (!vs || !fs) return 0;
        const GLuint program = gl_.CreateProgram();
        gl_.AttachShader(program, vs);
        gl_.AttachShader(program, fs);
        if (tessellation) {
            const GLuint tcs = compile(GL_TESS_CONTROL_SHADER, kTessControlShader);
            const GLuint tes = compile(GL_TESS_EVALUATION_SHADER, kTessEvaluationShader);
            if (!tcs || !tes) return 0;
            gl_.AttachShader(program, tcs);
            gl_.AttachShader(program, tes);
        }
        gl_.LinkProgram(program);
        GLint status = 0;
        gl_.GetProgramiv(program, GL_LINK_STATUS, &status);
        if (!status) {
            char log[2048] = {};
            gl_.GetProgramInfoLog(program, sizeof log, nullptr, log);
            error_ = std::string("link: ") + log;
            return 0;
        }
        return program;
    }

    OSMesaContext ctx_ = nullptr;
    Gl gl_;
    bool ok_ = false;
    std::string error_ = "OSMesaCreateContextAttribs failed";
    std::string renderer_, version_;
    GLuint program_ = 0, tess_program_ = 0, position_buffer_ = 0;
    int width_ = 0, height_ = 0;
    std::vector<float> buffer_;
    GLenum last_error_ = GL_NO_ERROR;
};

Llvmpipe& llvmpipe() {
    static Llvmpipe instance;
    return instance;
}

// ---------------------------------------------------------------------------------------
// Comparison.

struct Mismatch {
    std::size_t triangle;
    int x, y;  // GL window coordinates
    std::uint32_t llvmpipe_count, tessref_count;  // fragments of the triangle at the pixel
};

struct Result {
    std::size_t triangles = 0;
    std::size_t covered_pixels = 0;  // (pixel, triangle) pairs llvmpipe covered
    std::size_t pixels_compared = 0; // (pixel, triangle) pairs compared
    std::vector<Mismatch> mismatches;
};

std::string describe(const Tri& t) {
    char buf[512];
    std::snprintf(buf, sizeof buf, "(%a, %a, %a, %a) (%a, %a, %a, %a) (%a, %a, %a, %a)",
                  t[0].x, t[0].y, t[0].z, t[0].w, t[1].x, t[1].y, t[1].z, t[1].w, t[2].x, t[2].y,
                  t[2].z, t[2].w);
    return buf;
}

// Per-triangle coverage by both, compared pixel for pixel.
// tessellation: draw through the pass-through tessellation shaders and rasterize with
// WindowTransform::tessellation (else a plain vertex-shader draw and ::vertex_shader);
// wrong_transform: rasterize with the other transform (to show that the test tells them apart).
Result compare_coverage(const std::vector<Tri>& tris, int width, int height, bool lines,
                        bool cull_back, bool tessellation = false, bool wrong_transform = false) {
    Llvmpipe& gl = llvmpipe();
    gl.resize(width, height);
    Result result;
    tessref::Framebuffer fb = tessref::Framebuffer::create(width, height);
    tessref::RasterSettings settings;
    settings.polygon_mode = lines ? tessref::PolygonMode::line : tessref::PolygonMode::fill;
    settings.cull = cull_back ? tessref::CullMode::back : tessref::CullMode::none;
    settings.depth_func = tessref::DepthFunc::always;
    settings.window_transform = tessellation != wrong_transform ? tessref::WindowTransform::tessellation
                                                                : tessref::WindowTransform::vertex_shader;

    constexpr std::size_t kPerPass = 24;
    for (std::size_t first = 0; first < tris.size(); first += kPerPass) {
        const std::size_t count = std::min(kPerPass, tris.size() - first);
        const std::vector<Tri> pass(tris.begin() + static_cast<std::ptrdiff_t>(first),
                                    tris.begin() + static_cast<std::ptrdiff_t>(first + count));
        Llvmpipe::DrawState state;
        state.lines = lines;
        state.cull_back = cull_back;
        state.tessellation = tessellation;
        const std::vector<float>& buffer = gl.draw(pass, 0, state);
        EXPECT_EQ(gl.last_error(), static_cast<GLenum>(GL_NO_ERROR));
        for (std::size_t i = 0; i < count; ++i) {
            fb.clear();
            const std::array<std::uint32_t, 3> tri{0, 1, 2};
            tessref::RasterInput input;
            input.positions = pass[i];
            input.triangles = {&tri, 1};
            tessref::rasterize(fb, input, settings);
            const int channel = static_cast<int>(i / 6);
            const int shift = 4 * static_cast<int>(i % 6);
            ++result.triangles;
            for (int y = 0; y < height; ++y) {
                for (int x = 0; x < width; ++x) {
                    const float v = buffer[(static_cast<std::size_t>(y) * width + x) * 4 + channel];
                    const std::uint32_t theirs = (static_cast<std::uint32_t>(v) >> shift) & 15u;
                    const std::uint32_t ours = fb.fragment_count[fb.index(x, y)];
                    if (!lines) EXPECT_LE(ours, 1u);
                    ++result.pixels_compared;
                    result.covered_pixels += theirs != 0 ? 1 : 0;
                    if (theirs != ours) result.mismatches.push_back({first + i, x, y, theirs, ours});
                }
            }
        }
    }
    return result;
}

void report(const char* name, const std::vector<Tri>& tris, const Result& r) {
    std::printf("[llvmpipe] %-28s %6zu triangles, %9zu pixels compared, %8zu covered, %zu mismatches\n",
                name, r.triangles, r.pixels_compared, r.covered_pixels, r.mismatches.size());
    std::size_t shown = 0;
    std::size_t last_tri = static_cast<std::size_t>(-1);
    for (const Mismatch& m : r.mismatches) {
        if (m.triangle != last_tri) {
            if (++shown > 8) break;
            std::printf("  triangle %zu: %s\n", m.triangle, describe(tris[m.triangle]).c_str());
            last_tri = m.triangle;
        }
        std::printf("    pixel (%d, %d): llvmpipe %u, tessref %u fragments\n", m.x, m.y, m.llvmpipe_count,
                    m.tessref_count);
    }
}

// ---------------------------------------------------------------------------------------
// Triangle generators (clip space). Window x = (ndc + 1) * W / 2.

struct Gen {
    std::mt19937 rng;
    int width, height;
    explicit Gen(unsigned seed, int w, int h) : rng(seed), width(w), height(h) {}
    float uniform(float a, float b) { return std::uniform_real_distribution<float>(a, b)(rng); }
    int integer(int a, int b) { return std::uniform_int_distribution<int>(a, b)(rng); }
    // Clip-space vertex (w = 1) at window position (wx, wy), GL window coordinates.
    glm::vec4 at_window(float wx, float wy, float z = 0.0f) const {
        return {wx * 2.0f / static_cast<float>(width) - 1.0f, wy * 2.0f / static_cast<float>(height) - 1.0f, z,
                1.0f};
    }
    glm::vec4 random_window_point(float margin = 0.0f) {
        return at_window(uniform(-margin, static_cast<float>(width) + margin),
                         uniform(-margin, static_cast<float>(height) + margin), uniform(-0.9f, 0.9f));
    }
};

std::vector<Tri> small_triangles(Gen& g, int n) {
    std::vector<Tri> out;
    for (int i = 0; i < n; ++i) {
        const float cx = g.uniform(2, static_cast<float>(g.width) - 2);
        const float cy = g.uniform(2, static_cast<float>(g.height) - 2);
        const float size = g.uniform(0.05f, 6.0f);
        Tri t;
        for (auto& v : t) v = g.at_window(cx + g.uniform(-size, size), cy + g.uniform(-size, size), g.uniform(-0.5f, 0.5f));
        out.push_back(t);
    }
    return out;
}

std::vector<Tri> large_triangles(Gen& g, int n) {
    std::vector<Tri> out;
    for (int i = 0; i < n; ++i) {
        Tri t;
        for (auto& v : t) v = g.random_window_point(static_cast<float>(g.width) * 0.5f);
        out.push_back(t);
    }
    return out;
}

std::vector<Tri> slivers(Gen& g, int n) {
    std::vector<Tri> out;
    for (int i = 0; i < n; ++i) {
        const glm::vec4 a = g.random_window_point(4.0f), b = g.random_window_point(4.0f);
        const float s = g.uniform(0.0f, 1.0f);
        glm::vec4 c = a + s * (b - a);
        const float off = g.uniform(-0.02f, 0.02f);
        c.x += off * 2.0f / static_cast<float>(g.width);
        c.y -= off * 2.0f / static_cast<float>(g.height);
        out.push_back({a, b, c});
    }
    return out;
}

// Vertices on a quarter-pixel (or 1/512-pixel) grid: edges and vertices through pixel centres,
// horizontal and vertical edges, snapping ties.
std::vector<Tri> grid_triangles(Gen& g, int n, float step, int span) {
    std::vector<Tri> out;
    for (int i = 0; i < n; ++i) {
        const int cx = g.integer(span, static_cast<int>(static_cast<float>(g.width) / step) - span);
        const int cy = g.integer(span, static_cast<int>(static_cast<float>(g.height) / step) - span);
        Tri t;
        for (auto& v : t) {
            v = g.at_window(static_cast<float>(cx + g.integer(-span, span)) * step,
                            static_cast<float>(cy + g.integer(-span, span)) * step);
        }
        if (i % 3 == 0) t[2].x = t[1].x;  // a vertical edge
        if (i % 3 == 1) t[2].y = t[0].y;  // a horizontal edge
        out.push_back(t);
    }
    return out;
}

std::vector<Tri> shared_edges(Gen& g, int quads) {
    std::vector<Tri> out;
    for (int i = 0; i < quads; ++i) {
        glm::vec4 p[4];
        const float cx = g.uniform(0, static_cast<float>(g.width)), cy = g.uniform(0, static_cast<float>(g.height));
        const float r = g.uniform(0.5f, 20.0f);
        for (int k = 0; k < 4; ++k) {
            const float a = (static_cast<float>(k) + g.uniform(0.1f, 0.9f)) * 1.5707964f;
            p[k] = g.at_window(cx + r * std::cos(a), cy + r * std::sin(a));
        }
        out.push_back({p[0], p[1], p[2]});
        out.push_back({p[0], p[2], p[3]});
    }
    // A fan around a vertex at a pixel centre and one at a random point.
    for (int f = 0; f < 2; ++f) {
        const float cx = f == 0 ? 20.5f : g.uniform(10, 30), cy = f == 0 ? 20.5f : g.uniform(10, 30);
        const int spokes = 11;
        for (int k = 0; k < spokes; ++k) {
            const float a0 = 6.2831853f * static_cast<float>(k) / spokes;
            const float a1 = 6.2831853f * static_cast<float>(k + 1) / spokes;
            out.push_back({g.at_window(cx, cy), g.at_window(cx + 15 * std::cos(a0), cy + 15 * std::sin(a0)),
                           g.at_window(cx + 15 * std::cos(a1), cy + 15 * std::sin(a1))});
        }
    }
    return out;
}

// Perspective: the same window-space triangles with w != 1 (and huge w), plus coordinates far
// outside the view volume.
std::vector<Tri> perspective(Gen& g, int n) {
    std::vector<Tri> out;
    for (int i = 0; i < n; ++i) {
        Tri t;
        for (auto& v : t) {
            v = g.random_window_point(static_cast<float>(g.width) * 0.25f);
            const float w = i % 4 == 0 ? g.uniform(1000.0f, 1.0e6f) : g.uniform(0.1f, 10.0f);
            v *= w;
        }
        out.push_back(t);
    }
    for (int i = 0; i < n / 4; ++i) {  // far outside, big magnitudes
        Tri t;
        for (auto& v : t) v = {g.uniform(-3e4f, 3e4f), g.uniform(-3e4f, 3e4f), g.uniform(-0.5f, 0.5f), 1.0f};
        out.push_back(t);
    }
    return out;
}

// Huge coordinates: far outside the view volume, clip coordinates up to 1e7 and w up to 1e18,
// where float clipping moves the clipped corners by whole pixels.
std::vector<Tri> huge(Gen& g, int n) {
    std::vector<Tri> out;
    for (int i = 0; i < n; ++i) {
        const float size = std::pow(10.0f, g.uniform(2.0f, 7.0f));
        const float w = std::pow(10.0f, g.uniform(-3.0f, 18.0f));
        Tri t;
        for (auto& v : t) v = glm::vec4(g.uniform(-size, size), g.uniform(-size, size), g.uniform(-0.9f, 0.9f), 1.0f) * w;
        out.push_back(t);
    }
    return out;
}

// One or two vertices behind the eye (w < 0), crossing the near (z = -w) plane.
std::vector<Tri> near_plane(Gen& g, int n) {
    std::vector<Tri> out;
    for (int i = 0; i < n; ++i) {
        Tri t;
        const int behind = 1 + (i % 2);
        for (int k = 0; k < 3; ++k) {
            // View-space point, then a GL perspective projection (fovy 90, near 0.1, far 100).
            const float vx = g.uniform(-4, 4), vy = g.uniform(-4, 4);
            const float vz = k < behind ? g.uniform(-0.5f, 1.0f) : -g.uniform(0.5f, 8.0f);
            const float n_ = 0.1f, f_ = 100.0f;
            const float aspect = static_cast<float>(g.width) / static_cast<float>(g.height);
            t[static_cast<std::size_t>(k)] = {vx / aspect, vy, (f_ + n_) / (n_ - f_) * vz + 2 * f_ * n_ / (n_ - f_), -vz};
        }
        out.push_back(t);
    }
    return out;
}

// Vertices exactly on a clip plane (x = w, y = -w, z = -w ...) with others outside it.
std::vector<Tri> on_planes(Gen& g, int n) {
    std::vector<Tri> out;
    for (int i = 0; i < n; ++i) {
        Tri t;
        for (auto& v : t) v = g.random_window_point(static_cast<float>(g.width) * 0.3f);
        const int k = i % 3;
        const float w = g.uniform(0.5f, 3.0f);
        t[static_cast<std::size_t>(k)] *= w;
        switch (i % 6) {
            case 0: t[static_cast<std::size_t>(k)].x = w; break;
            case 1: t[static_cast<std::size_t>(k)].x = -w; break;
            case 2: t[static_cast<std::size_t>(k)].y = w; break;
            case 3: t[static_cast<std::size_t>(k)].y = -w; break;
            case 4: t[static_cast<std::size_t>(k)].z = -w; t[static_cast<std::size_t>((k + 1) % 3)].z = -2.0f; break;
            default: t[static_cast<std::size_t>(k)].z = w; t[static_cast<std::size_t>((k + 1) % 3)].z = 2.0f; break;
        }
        out.push_back(t);
    }
    return out;
}

std::vector<Tri> all_cases(unsigned seed, int width, int height) {
    Gen g(seed, width, height);
    std::vector<Tri> all;
    auto add = [&](std::vector<Tri> v) { all.insert(all.end(), v.begin(), v.end()); };
    add(small_triangles(g, 1500));
    add(large_triangles(g, 300));
    add(slivers(g, 400));
    add(grid_triangles(g, 800, 0.25f, 12));
    add(grid_triangles(g, 800, 1.0f / 512.0f, 1500));
    add(shared_edges(g, 200));
    add(perspective(g, 300));
    add(huge(g, 300));
    add(near_plane(g, 400));
    add(on_planes(g, 300));
    return all;
}

class RasterLlvmpipe : public ::testing::Test {
protected:
    void SetUp() override {
        // The differential check is the contract: no llvmpipe is a failure, not a skip.
        ASSERT_TRUE(llvmpipe().ok()) << "no OSMesa GL 4.5 core context: " << llvmpipe().error();
    }
};

TEST_F(RasterLlvmpipe, ReadbackSeesOneTriangleWhereExpected) {
    // A hand check of the harness: a triangle covering the bottom-left half of the
    // viewport covers GL window pixel (0, 0) and not (W-1, H-1), in both.
    Llvmpipe& gl = llvmpipe();
    gl.resize(16, 8);
    const std::vector<Tri> tris = {{glm::vec4(-1, -1, 0, 1), glm::vec4(1, -1, 0, 1), glm::vec4(-1, 1, 0, 1)}};
    const std::vector<float>& buf = gl.draw(tris, 0, {});
    EXPECT_EQ(buf[0], 1.0f);                       // GL (0, 0), the bottom-left pixel
    EXPECT_EQ(buf[(7 * 16 + 15) * 4], 0.0f);       // GL (15, 7), the top-right one
    const Result r = compare_coverage(tris, 16, 8, false, false);
    EXPECT_TRUE(r.mismatches.empty());
    std::printf("[llvmpipe] %s\n", gl.description().c_str());
}

TEST_F(RasterLlvmpipe, FillCoverageIsIdentical) {
    for (auto [w, h] : {std::pair{128, 96}, std::pair{61, 47}}) {
        const std::vector<Tri> tris = all_cases(20240601u + static_cast<unsigned>(w), w, h);
        const Result r = compare_coverage(tris, w, h, false, false);
        report(("fill " + std::to_string(w) + "x" + std::to_string(h)).c_str(), tris, r);
        EXPECT_TRUE(r.mismatches.empty()) << r.mismatches.size() << " pixels differ";
    }
}

TEST_F(RasterLlvmpipe, BackFaceCullingIsIdentical) {
    const std::vector<Tri> tris = all_cases(777u, 96, 64);
    const Result r = compare_coverage(tris, 96, 64, false, true);
    report("fill, cull back 96x64", tris, r);
    EXPECT_TRUE(r.mismatches.empty()) << r.mismatches.size() << " pixels differ";
}

TEST_F(RasterLlvmpipe, WireframeCoverageIsIdentical) {
    const std::vector<Tri> tris = all_cases(9090u, 128, 96);
    const Result r = compare_coverage(tris, 128, 96, true, false);
    report("polygon mode line 128x96", tris, r);
    EXPECT_TRUE(r.mismatches.empty()) << r.mismatches.size() << " pixels differ";
}

TEST_F(RasterLlvmpipe, WireframeWithBackFaceCullingIsIdentical) {
    const std::vector<Tri> tris = all_cases(31337u, 96, 64);
    const Result r = compare_coverage(tris, 96, 64, true, true);
    report("polygon mode line, cull back", tris, r);
    EXPECT_TRUE(r.mismatches.empty()) << r.mismatches.size() << " pixels differ";
}

TEST_F(RasterLlvmpipe, FillThroughTessellationShadersIsIdentical) {
    const std::vector<Tri> tris = all_cases(8080u, 128, 96);
    const Result r = compare_coverage(tris, 128, 96, false, false, true);
    report("fill, tessellation path", tris, r);
    EXPECT_TRUE(r.mismatches.empty()) << r.mismatches.size() << " pixels differ";
}

TEST_F(RasterLlvmpipe, WireframeThroughTessellationShadersIsIdentical) {
    const std::vector<Tri> tris = all_cases(4242u, 128, 96);
    const Result r = compare_coverage(tris, 128, 96, true, false, true);
    report("line, tessellation path", tris, r);
    EXPECT_TRUE(r.mismatches.empty()) << r.mismatches.size() << " pixels differ";
    // The same with the vertex-shader window transform (fma) must NOT agree everywhere:
    // otherwise this test could not tell the two paths apart.
    const Result wrong = compare_coverage(tris, 128, 96, true, false, true, true);
    std::printf("[llvmpipe] (with the vertex-shader transform instead: %zu mismatches)\n",
                wrong.mismatches.size());
    EXPECT_GT(wrong.mismatches.size(), 0u);
}

// A shipped scene's tessellated surface (run_pipeline, gpu precision) projected with its
// camera, as the vertex shader would (gl_Position = mvp * vec4(position, 1) in float), drawn
// whole at the scene's 1280 x 800 with depth test off: the number of fragments at every
// pixel must be identical (shared edges of real tessellations: no pixel lost or doubled).
void compare_scene(const char* name, bool lines) {
    const tessref::Scene scene =
        tessref::load_scene(std::string(TESSREF_DATA_DIR) + "/scenes/" + name + ".toml");
    const tessref::PipelineResult result = tessref::run_pipeline(scene);
    const tessref::SceneCamera camera = scene.camera.value_or(tessref::SceneCamera{});
    const int W = camera.viewport.x, H = camera.viewport.y;
    const glm::mat4 mvp(camera.view_projection());
    std::vector<glm::vec4> positions;
    for (const glm::dvec3& p : result.mesh.positions) positions.push_back(mvp * glm::vec4(glm::vec3(p), 1.0f));
    std::vector<Tri> tris;
    for (const auto& t : result.mesh.triangles) tris.push_back({positions[t[0]], positions[t[1]], positions[t[2]]});

    Llvmpipe& gl = llvmpipe();
    gl.resize(W, H);
    Llvmpipe::DrawState state;
    state.one_id = true;
    state.lines = lines;
    const std::vector<float>& buffer = gl.draw(tris, 0, state);
    ASSERT_EQ(gl.last_error(), static_cast<GLenum>(GL_NO_ERROR));

    tessref::Framebuffer fb = tessref::Framebuffer::create(W, H);
    tessref::RasterSettings settings;
    settings.depth_func = tessref::DepthFunc::always;
    settings.window_transform = tessref::WindowTransform::vertex_shader;
    settings.polygon_mode = lines ? tessref::PolygonMode::line : tessref::PolygonMode::fill;
    tessref::RasterInput input;
    input.positions = positions;
    input.triangles = result.mesh.triangles;
    const tessref::RasterStats stats = tessref::rasterize(fb, input, settings);
    std::size_t mismatches = 0;
    std::uint64_t theirs_total = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const auto theirs = static_cast<std::uint32_t>(buffer[(static_cast<std::size_t>(y) * W + x) * 4]);
            theirs_total += theirs;
            if (theirs != fb.fragment_count[fb.index(x, y)] && ++mismatches <= 8)
                std::printf("    pixel (%d, %d): llvmpipe %u, tessref %u fragments\n", x, y, theirs,
                            fb.fragment_count[fb.index(x, y)]);
        }
    std::printf("[llvmpipe] scene %-14s %-5s %8zu triangles (%llu clipped), %7d pixels, %9llu fragments, %zu mismatches\n",
                name, lines ? "line" : "fill", tris.size(), static_cast<unsigned long long>(stats.triangles_clipped),
                W * H, static_cast<unsigned long long>(theirs_total), mismatches);
    EXPECT_EQ(theirs_total, stats.fragments);
    EXPECT_EQ(mismatches, 0u);
}

TEST_F(RasterLlvmpipe, ShippedScenesGiveTheSameFragmentCounts) {
    for (const char* name : {"thesis-all-10", "jacksboro", "lab4-canyon"}) {
        compare_scene(name, false);
        compare_scene(name, true);
    }
}

TEST_F(RasterLlvmpipe, DepthLessPicksTheSameTriangle) {
    // Overlapping triangles at different (and intersecting) depths, drawn in one pass with
    // depth LESS: the visible triangle must agree wherever the two nearest candidates' depths
    // are not within 1e-4 of each other (llvmpipe's depth buffer is 24-bit unorm here).
    constexpr int W = 128, H = 96;
    Llvmpipe& gl = llvmpipe();
    gl.resize(W, H);
    Gen g(99u, W, H);
    std::size_t compared = 0, skipped_ties = 0, mismatches = 0, draws = 0;
    for (int round = 0; round < 40; ++round) {
        std::vector<Tri> tris = large_triangles(g, 20);
        const std::vector<Tri> more = small_triangles(g, 40);
        tris.insert(tris.end(), more.begin(), more.end());
        Llvmpipe::DrawState state;
        state.depth_less = true;
        const std::vector<float>& buf = gl.draw(tris, 1, state);
        ++draws;
        tessref::Framebuffer fb = tessref::Framebuffer::create(W, H);
        std::vector<glm::vec4> positions;
        std::vector<std::array<std::uint32_t, 3>> indices;
        for (const Tri& t : tris) {
            const auto base = static_cast<std::uint32_t>(positions.size());
            positions.insert(positions.end(), t.begin(), t.end());
            indices.push_back({base, base + 1, base + 2});
        }
        tessref::RasterInput input;
        input.positions = positions;
        input.triangles = indices;
        tessref::RasterSettings less;
        less.window_transform = tessref::WindowTransform::vertex_shader;
        tessref::rasterize(fb, input, less);
        // Per pixel, the analytic window depth of every covering triangle (single-triangle
        // coverage from tessref, which the tests above hold equal to llvmpipe's).
        std::vector<std::vector<std::pair<double, std::uint32_t>>> cands(static_cast<std::size_t>(W * H));
        tessref::Framebuffer one = tessref::Framebuffer::create(W, H);
        tessref::RasterSettings always;
        always.depth_func = tessref::DepthFunc::always;
        always.window_transform = tessref::WindowTransform::vertex_shader;
        for (std::size_t i = 0; i < tris.size(); ++i) {
            one.clear();
            tessref::RasterInput in1;
            in1.positions = positions;
            in1.triangles = {&indices[i], 1};
            tessref::rasterize(one, in1, always);
            const Tri& t = tris[i];
            for (int y = 0; y < H; ++y)
                for (int x = 0; x < W; ++x) {
                    if (!one.fragment_count[one.index(x, y)]) continue;
                    // Depth plane through the three NDC vertices (w = 1 here).
                    const double px = (x + 0.5) * 2.0 / W - 1.0, py = (y + 0.5) * 2.0 / H - 1.0;
                    const glm::dvec3 a(t[0]), b(t[1]), c(t[2]);
                    const glm::dvec3 nrm = glm::cross(b - a, c - a);
                    const double z = a.z - (nrm.x * (px - a.x) + nrm.y * (py - a.y)) / nrm.z;
                    cands[static_cast<std::size_t>(y * W + x)].push_back({0.5 * z + 0.5, static_cast<std::uint32_t>(i)});
                }
        }
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                auto& c = cands[static_cast<std::size_t>(y * W + x)];
                const float theirs = buf[(static_cast<std::size_t>(y) * W + x) * 4];
                const std::uint32_t ours = fb.triangle_id[fb.index(x, y)];
                std::stable_sort(c.begin(), c.end(), [](auto& l, auto& r) { return l.first < r.first; });
                std::erase_if(c, [](auto& e) { return e.first >= 1.0 || e.first < 0.0; });
                if (c.size() >= 2 && c[1].first - c[0].first < 1e-4) {
                    ++skipped_ties;
                    continue;
                }
                ++compared;
                const std::uint32_t expected_theirs = ours == tessref::kNoTriangle ? 0u : ours + 1u;
                if (static_cast<std::uint32_t>(theirs) != expected_theirs) {
                    if (++mismatches <= 10)
                        std::printf("  depth: round %d pixel (%d,%d) llvmpipe %u tessref %u\n", round, x, y,
                                    static_cast<std::uint32_t>(theirs), expected_theirs);
                }
            }
    }
    std::printf("[llvmpipe] depth LESS: %zu draws, %zu pixels compared, %zu near-ties skipped, %zu mismatches\n",
                draws, compared, skipped_ties, mismatches);
    EXPECT_EQ(mismatches, 0u);
}

}  // namespace
