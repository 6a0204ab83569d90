// tessref/gl_backend.h — the real OpenGL primitive generator, through OSMesa (Mesa llvmpipe).
//
// The independent peer of tessellator.h: the same six levels go through GLSL 4.50
// tessellation shaders (data/shaders/capture_tess_coord.{vert,tesc,tese}) on an offscreen
// OpenGL 4.5 core context, and transform feedback returns the gl_TessCoord of every
// vertex of every primitive the fixed-function generator emitted, as raw float bits.
//
//   auto ctx = tessref::gl::Context::create();          // throws tessref::Error if unavailable
//   auto got = tessref::gl::capture_patterns(ctx, settings, level_sets);
//
// Levels reach gl_TessLevelOuter/Inner as raw bits (the control shader applies
// uintBitsToFloat), so NaN, infinities, denormals and negatives are passed untouched.
// Many patches are drawn per call, in batches small enough that llvmpipe stays correct
// (large tessellated draws come out corrupted: see TESSELLATION.md); every batch is
// checked with GL_PRIMITIVES_GENERATED / GL_TRANSFORM_FEEDBACK_PRIMITIVES_WRITTEN queries.
//
// The shader files are read at run time from $TESSREF_DATA_DIR/shaders when that
// environment variable is set, else from ../share/tessref/shaders beside the running
// executable (an installed tessref), else, in a build tree, from the source data/shaders.
//
// llvmpipe runs its draws with denormals flushed to zero: a denormal outer level culls
// the patch there (tessellate() models this); the calling thread's FP mode is left as is.
//
// A Context is current on the thread that created it; use it from that thread only.
//
// A whole scene drawn through its GLSL twins on such a context (`tessref gl`) is
// gl_render.h's.
#pragma once

#include <cstddef>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "tessref/tessellator.h"

namespace tessref::gl {

// An offscreen OSMesa OpenGL 4.5 core-profile context, with the capture programs it has
// compiled (one per domain x spacing x winding x point mode, built on first use).
class Context {
public:
    // Creates the context and makes it current on the calling thread. Throws
    // tessref::Error when libOSMesa cannot give a 4.5 core context or a GL call fails.
    static Context create();

    Context(Context&&) noexcept;
    Context& operator=(Context&&) noexcept;
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;
    ~Context();

    const std::string& renderer() const;  // GL_RENDERER, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"
    const std::string& version() const;   // GL_VERSION, e.g. "4.5 (Core Profile) Mesa 22.3.6"

    struct Impl;
    Impl& impl() { return *impl_; }

private:
    explicit Context(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

// What the GL primitive generator emitted for one patch.
struct CapturedPatch {
    bool emitted_nothing = true;     // no primitive at all (the patch was culled)
    int vertices_per_primitive = 3;  // 3 triangles, 2 isolines, 1 point mode
    // Flat list: primitive i is vertices[i*vpp .. i*vpp + vpp - 1], in the order transform
    // feedback wrote them, each component exactly the float bits it returned (gl_TessCoord).
    std::vector<TessCoord> vertices;

    std::size_t primitive_count() const {
        return vertices.size() / static_cast<std::size_t>(vertices_per_primitive);
    }
};

// Runs every level set as one patch through the GL pipeline with the given layout and
// returns, in the same order, what each patch emitted. Throws tessref::Error (patch_id =
// index of the level set where known) on a GL error, a shader that does not compile, or a
// batch whose transform feedback overflowed or came back inconsistent.
std::vector<CapturedPatch> capture_patterns(Context& context, const TessSettings& settings,
                                            std::span<const TessLevels> level_sets);

// One level set; a convenience around capture_patterns.
CapturedPatch capture_pattern(Context& context, const TessSettings& settings,
                              const TessLevels& levels);

// Human-readable dump of one captured patch, one primitive a line, each coordinate as
// %.9g and as the hexadecimal float bits: for debugging a mismatch by hand.
std::string dump(const CapturedPatch& patch);

// ---- A float expression on llvmpipe ------------------------------------------------------
//
// Evaluates the GLSL float expression `expression` of `float x` and `float y` once per
// element of x (y[i] as its second operand; y may be empty, then y = 0), in a vertex shader
// whose inputs arrive as raw bits, and returns each result's bits as transform feedback
// wrote them. The vertex stage runs where llvmpipe runs every stage before the rasterizer,
// in the same floating-point environment (denormals flushed), so this is how llvmpipe
// computes the expression in a control shader too. tests/test_llvmpipe_math.cpp holds
// shader/llvmpipe_math.h to it. `functions` (declarations, functions) goes before main,
// for expressions that call them. Throws tessref::Error when the expression does not compile.
std::vector<float> evaluate(Context& context, const std::string& expression,
                            std::span<const float> x, std::span<const float> y = {},
                            const std::string& functions = "");
// The vertex shader evaluate() runs for `expression` and `functions`: location 0 an input
// uvec2 `operands` (x's and y's bits), `out float result` (location 0) the expression.
std::string evaluate_shader(const std::string& expression, const std::string& functions = "");

}  // namespace tessref::gl
