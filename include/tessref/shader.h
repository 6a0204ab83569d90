// tessref/shader.h — GLSL shader stages executed on the CPU, exactly.
//
// A stage's GLSL (a twin of data/shaders/ or a user's file) is compiled to SPIR-V by
// glslang, validated by SPIRV-Tools, and run by tessref's own SPIR-V interpreter (an
// evaluation shader a batch of invocations at a time, each instruction over the batch),
// with the GL stage interface the GL backend sets up: the same #version and defines, loose
// uniforms set by name (as glUniform*), samplers read through tessref::Texture at their
// layout(binding = N) unit, inputs and outputs matched by location.
//
//   shader::Module tese = shader::Module::compile({ShaderStage::tess_evaluation, path, text});
//   shader::Bindings b;
//   b.set("scaleXY", 1.0f);
//   b.bind_texture(0, &heightMap);
//   shader::Executable run(tese, b, {});
//   shader::ShaderVertex v = run.evaluate(patch, {u, v, 0}, patch_id);
//
// Float semantics: every operation is rounded to float32 on its own, as the GPU rounds it
// (no contraction: the build passes -ffp-contract=off); denormals are kept. Integer
// operations wrap as SPIR-V defines them. The few results SPIR-V leaves undefined are
// defined here, each with a warning naming the source line (RunOptions::warnings):
//   - integer division or remainder by zero: x / 0 = all ones (unsigned 0xffffffff,
//     signed -1), x % 0 = x; INT_MIN / -1 = INT_MIN, INT_MIN % -1 = 0;
//   - a shift by 32 or more shifts by the count modulo 32 (as x86 and llvmpipe do);
//   - float -> integer conversion of NaN or of a value out of range: 0 for NaN, else
//     saturated to the integer type's range;
//   - an array or vector index out of range is clamped into the range.
// A sampler whose unit has no texture reads (0, 0, 0, 1), as GL's incomplete texture does.
// GLSL mix(x, y, a) is x + a * (y - x), as llvmpipe computes it. The order of a sum of
// products follows the math mode: in `exact` mode the C++ models' (GLM's) order, a matrix
// times a vector pairwise for four columns, (c0 v.x + c1 v.y) + (c2 v.z + c3 v.w), from the
// first column on for two and three, a dot product from the first component on; in
// `llvmpipe` mode llvmpipe's, a matrix times a vector from the first column on whatever
// the count (GLSL's compiler writes it so), a dot product (and length, distance,
// normalize, v * M built on it) from the last component to the first (NIR splits it so).
// A chain of + or * (a + b + c + d) runs as written in `exact` mode; in `llvmpipe` mode as
// Mesa's GLSL compiler leaves it, rebalanced ((a + b) + (c + d)) where its
// opt_rebalance_tree pass rebalances it (src/shader/rebalance.h has the rule).
//
// The GLSL.std.450 functions run in one of two math modes (MathMode): `exact`, correctly
// rounded float results (each computed in double and rounded once, see src/shader/std450.cpp
// for where that is exact and the exceptions), and `llvmpipe`, the approximations Mesa's
// llvmpipe uses.
//
// Stages: vertex, tessellation control and evaluation, geometry (EmitVertex/EndPrimitive,
// strips assembled as GL assembles them) and fragment (2x2 quads: derivatives, helper
// invocations, discard, implicit lod), each through its Executable call below.
//
// Bad input throws tessref::Error: a GLSL compile error (glslang's log, at the file and
// line), SPIR-V that fails validation (the validator's message), an opcode, capability or
// execution model the interpreter does not run (naming the opcode and the source
// file:line), a uniform set with another type than the shader declares, and an invocation
// that runs past RunOptions::max_instructions (naming the stage, patch and invocation).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/scene.h"  // ShaderStage
#include "tessref/texture.h"

namespace tessref::shader {

enum class MathMode : std::uint8_t { exact, llvmpipe };
const char* to_string(MathMode mode);  // "exact", "llvmpipe"

// One interface location: four 32-bit components as bit patterns (a float's or an int's).
using Slot = std::array<std::uint32_t, 4>;
Slot slot(glm::vec4 v);
glm::vec4 as_vec4(const Slot& s);

// A stage's GLSL text. `prefix` is inserted right after the #version line (the GL backend's
// #defines); the file's own line numbers are kept for errors and OpLine.
struct Source {
    ShaderStage stage = ShaderStage::vertex;
    std::string path;  // as errors and the debug line information name the file
    std::string text;
    std::string prefix;
};

// The tessellation layout of an evaluation shader's `layout(...) in;` (its execution modes).
struct TessLayout {
    Domain domain = Domain::triangles;
    Spacing spacing = Spacing::equal;
    Winding winding = Winding::ccw;
    bool point_mode = false;
};

// A geometry shader's layout: `layout(triangles) in;` and `layout(triangle_strip,
// max_vertices = 3) out;` (its execution modes), and `layout(invocations = N) in;`.
enum class GeometryOutput : std::uint8_t { points, line_strip, triangle_strip };
struct GeometryLayout {
    int input_vertices = 3;  // points 1, lines 2, lines_adjacency 4, triangles 3, triangles_adjacency 6
    GeometryOutput output = GeometryOutput::triangle_strip;
    int max_vertices = 0;
    int invocations = 1;
};

// A compiled, validated stage: immutable, cheap to copy (shared), safe to run from many
// threads at once.
class Module {
public:
    // GLSL -> SPIR-V (with debug line information) -> validated -> ready to run.
    static Module compile(const Source& source);
    // A SPIR-V binary (validated here as well); `path` names it in errors.
    static Module load(std::vector<std::uint32_t> spirv, const std::string& path);

    ShaderStage stage() const;
    const std::string& path() const;
    const std::vector<std::uint32_t>& spirv() const;
    // The uniforms (not samplers) the stage declares, by name.
    std::vector<std::string> uniform_names() const;
    // The samplers the stage declares, by name, with the texture unit each reads: its
    // layout(binding = N), or 0 without one (GL's default value of a sampler uniform).
    struct Sampler {
        std::string name;
        int unit = 0;
    };
    std::vector<Sampler> samplers() const;
    // The user-defined outputs (not built-ins), each location with its component count (a
    // block's members one by one), in declaration order.
    struct Output {
        int location = 0;
        int components = 0;
    };
    std::vector<Output> outputs() const;
    // A control shader's layout(vertices = N) out; 0 for other stages.
    int output_vertices() const;
    // An evaluation shader's layout; throws tessref::Error for other stages.
    TessLayout tess_layout() const;
    // A geometry shader's layout; throws tessref::Error for other stages.
    GeometryLayout geometry_layout() const;

    struct Impl;
    const Impl& impl() const { return *impl_; }

private:
    explicit Module(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}
    std::shared_ptr<const Impl> impl_;
};

// Uniform values by name and textures by unit, as a GL program's state. A name the module
// does not declare is ignored (GL's location -1); an undeclared uniform the module reads
// holds its initializer, or zero.
class Bindings {
public:
    void set(const std::string& name, float v);
    void set(const std::string& name, int v);
    void set(const std::string& name, glm::vec2 v);
    void set(const std::string& name, glm::vec3 v);
    void set(const std::string& name, glm::vec4 v);
    void set(const std::string& name, const glm::mat3& m);
    void set(const std::string& name, const glm::mat4& m);
    // The texture read by the sampler with layout(binding = unit); not owned.
    void bind_texture(int unit, const Texture* texture);

    enum class Type : std::uint8_t { float_, int_, vec2, vec3, vec4, mat3, mat4 };
    struct Value {
        Type type;
        std::vector<std::uint32_t> words;  // column-major for matrices
    };
    const std::map<std::string, Value>& values() const { return values_; }
    const std::map<int, const Texture*>& textures() const { return textures_; }

private:
    std::map<std::string, Value> values_;
    std::map<int, const Texture*> textures_;
};

// What an invocation executes, as it executes it (`tessref trace`): set RunOptions::observer.
// Without one the executor tests a single pointer per instruction and records nothing.
// Called on the thread that runs the invocation.
class Observer {
public:
    virtual ~Observer() = default;
    // A control shader's invocation `index` starts or resumes (after a barrier()).
    virtual void invocation(int /*index*/) {}
    // An instruction of source `file`:`line` (OpLine) is about to run; called when the line
    // differs from the previous instruction's.
    virtual void line(const std::string& file, std::uint32_t line) = 0;
    // A store into the variable `name` (OpName; "" when the module has none) at word
    // `offset` of it: the words stored, each a float, a signed or an unsigned int or a bool
    // as `kind` says ('f', 'i', 'u', 'b').
    virtual void store(const std::string& name, std::uint32_t offset, char kind, std::span<const std::uint32_t> words) = 0;
};

// The budget RunOptions starts from: 10 000 000 instructions, or what `--max-instructions`
// set for the process (render, mesh, gl: the pipeline makes the RunOptions of a scene's
// user shaders itself, user_program.cpp, with no caller between that could pass one).
std::uint64_t default_max_instructions();
void set_default_max_instructions(std::uint64_t max_instructions);  // >= 1

struct RunOptions {
    MathMode math = MathMode::exact;
    // Instructions one invocation may execute before it is stopped with an Error. The
    // invocations of an evaluation batch run together, each executing every instruction:
    // an endless evaluation shader is stopped when its batch reaches the budget, after up to
    // 64 times the work of one invocation.
    std::uint64_t max_instructions = default_max_instructions();
    // Where warnings (undefined behaviour met at run time, each once per source line) go;
    // nullptr: nowhere.
    std::vector<std::string>* warnings = nullptr;
    Observer* observer = nullptr;  // not owned; nullptr: nothing is recorded
    // Executable::fragment: the quad's lane (0 top-left .. 3 bottom-right) the observer
    // records; the other three run unrecorded.
    int observed_lane = 0;
};

// A vertex as one stage hands it to the next: gl_Position and the locations it wrote.
struct ShaderVertex {
    glm::vec4 position{0.0f, 0.0f, 0.0f, 1.0f};
    std::vector<Slot> locations;  // indexed by location
};

// The outputs of many evaluation invocations, flat: vertex k's gl_Position is positions[k]
// and its location j is locations[k * location_count + j], as vertex(k) hands them on (zero
// where the shader writes none). One allocation per call instead of one per vertex.
struct ShaderVertices {
    std::vector<glm::vec4> positions;
    std::size_t location_count = 0;
    std::vector<Slot> locations;
    std::size_t size() const { return positions.size(); }
    const Slot& location(std::size_t k, std::size_t j) const { return locations[k * location_count + j]; }
    ShaderVertex vertex(std::size_t k) const;
};

// A control shader's patch: its output vertices, per-patch locations and levels.
struct ShaderPatch {
    std::vector<ShaderVertex> vertices;
    std::vector<Slot> patch_locations;  // `patch out` variables, indexed by location
    std::array<float, 4> outer{0.0f, 0.0f, 0.0f, 0.0f};
    std::array<float, 2> inner{0.0f, 0.0f};
};

// What a geometry shader made of one input primitive: every vertex EmitVertex() wrote, in
// the order written (invocation 0's first, with layout(invocations = N)), and the primitives
// GL assembles from them, as indices into `vertices`, `per_primitive` (1, 2 or 3) each:
// points one by one, a line strip's lines (k, k + 1), a triangle strip's triangles
// (k, k + 1, k + 2) for even k and (k + 1, k, k + 2) for odd k, so that every triangle keeps
// the first one's orientation and its last vertex provokes (GL's default provoking vertex,
// as Mesa's draw module decomposes a strip for llvmpipe). EndPrimitive() and the end
// of an invocation end a strip; a strip too short for one primitive makes none.
struct ShaderPrimitives {
    GeometryOutput output = GeometryOutput::triangle_strip;
    std::vector<ShaderVertex> vertices;
    std::vector<std::uint32_t> indices;
    int per_primitive() const { return output == GeometryOutput::points ? 1 : output == GeometryOutput::line_strip ? 2 : 3; }
    std::size_t primitive_count() const { return indices.size() / static_cast<std::size_t>(per_primitive()); }
};

// One fragment of a 2x2 quad as a fragment shader's invocation reads it.
struct QuadFragment {
    glm::vec4 frag_coord{0.0f, 0.0f, 0.0f, 1.0f};  // gl_FragCoord
    std::vector<Slot> inputs;                        // the interpolated inputs, by location
    bool covered = true;  // false: a helper invocation (gl_HelperInvocation), run for the derivatives only
};

// What a fragment shader's invocation wrote: its outputs by location (a location it did not
// write reads zero), gl_FragDepth if written, and whether it discarded. A helper
// invocation's result is not a fragment: `helper` says so.
struct FragmentResult {
    std::vector<Slot> outputs;
    bool depth_written = false;
    float depth = 0.0f;
    bool discarded = false;
    bool helper = false;
};

// A module with its uniforms and textures resolved: the stage drivers. Const and
// thread-safe; each call runs its own invocations.
class Executable {
public:
    Executable(Module module, const Bindings& bindings, RunOptions options);
    ~Executable();
    Executable(Executable&&) noexcept;
    Executable& operator=(Executable&&) noexcept;

    const Module& module() const;

    // Vertex shader: attributes by location; gl_VertexID = vertex_id.
    ShaderVertex vertex(std::span<const Slot> attributes, int vertex_id) const;
    // Tessellation control: every invocation of the patch (layout(vertices = N)), run to each
    // barrier() before any passes it. gl_PrimitiveID = patch_id.
    ShaderPatch control(std::span<const ShaderVertex> in, long long patch_id) const;
    // Tessellation evaluation at one domain point of a patch.
    ShaderVertex evaluate(const ShaderPatch& patch, glm::vec3 tess_coord, long long patch_id) const;
    // At many domain points of one patch: result k is evaluate(patch, tess_coords[k],
    // patch_id), bit for bit, computed a batch of points at a time (each instruction over
    // all the batch's invocations). A warning is given once per source line of the call.
    std::vector<ShaderVertex> evaluate(const ShaderPatch& patch, std::span<const glm::vec3> tess_coords,
                                       long long patch_id) const;
    // The same into `out` (resized; its storage reused from call to call): what the
    // pipeline runs.
    void evaluate(const ShaderPatch& patch, std::span<const glm::vec3> tess_coords, long long patch_id,
                  ShaderVertices& out) const;

    // Geometry: every invocation (layout(invocations = N); gl_InvocationID) of one input
    // primitive, `in` its vertices as gl_in[] and the input blocks read them (as many as the
    // input layout takes). gl_PrimitiveIDIn = primitive_id. A vertex emitted past
    // max_vertices is dropped with a warning (GL leaves it undefined; llvmpipe drops it).
    ShaderPrimitives geometry(std::span<const ShaderVertex> in, long long primitive_id) const;
    // Over many input primitives at once, as the pipeline runs it: primitive k's vertices are
    // in.vertex(indices[k * n + j]) for j < n, n the input layout's vertex count; out[k] is
    // geometry() of those vertices, bit for bit, computed a batch of primitives at a time
    // (each instruction over all the batch's invocations, as evaluate() batches points).
    void geometry(const ShaderVertices& in, std::span<const std::uint32_t> indices, long long primitive_id,
                  std::vector<ShaderPrimitives>& out) const;
    // Fragment: the four invocations of a 2x2 quad, as llvmpipe runs them, lanes in the order
    // top-left, top-right, bottom-left, bottom-right (rows as the framebuffer's: the top row
    // has the higher window y). dFdx = right minus left in the lane's row, dFdy = top minus
    // bottom in its column (each rounded; Fine and Coarse the same, as llvmpipe computes
    // them), fwidth = abs(dFdx) + abs(dFdy); texture()'s implicit lod from one pair of
    // derivatives for the quad, the top-left fragment's (tessref/shading.h, fragment_lod).
    // The quad runs in lockstep; where a branch parts its lanes each way runs on its own and
    // the ways meet again at the branch's merge block (the end of the if, the loop's exit;
    // lanes that break out of a loop wait at its exit for the others), so that derivatives
    // after it are the quad's again; inside a parted branch they are
    // undefined in GLSL and 0 here, with a warning. `if (c) discard;` parts nothing: as on
    // llvmpipe, the discarding fragments go on as helpers (their derivatives stay
    // available), their results discarded. gl_FrontFacing = front_facing, gl_PrimitiveID =
    // primitive_id.
    std::array<FragmentResult, 4> fragment(std::span<const QuadFragment, 4> quad, bool front_facing,
                                           long long primitive_id) const;

    struct State;

private:
    std::unique_ptr<const State> state_;
};

}  // namespace tessref::shader
