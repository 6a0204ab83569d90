// src/shader/module.h — a SPIR-V module as the interpreter runs it (private to src/shader/).
//
// Loading (module.cpp) decodes the binary once into tables indexed by SPIR-V id: every
// type's flattened size, every value's place in one flat register file, every variable's
// place in one flat memory, every instruction with its source line. Execution
// (executor.cpp) then needs no lookups by name or by map.
//
// Values are flattened into 32-bit words: a scalar is one word (bool 0 or 1), a vector or
// matrix its components in order (matrices column by column), an array or struct its
// elements in order. A pointer is one word, an address in memory. Memory has two regions:
// the shared one (uniforms, inputs, outputs: a control shader's invocations share their
// outputs) at addresses [0, shared_words), and each invocation's own (Private and Function
// variables) at [shared_words, shared_words + local_words). GLSL has no recursion, so every
// Function variable and every value has one fixed place.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "tessref/error.h"
#include "tessref/shader.h"

namespace tessref::shader {

std::vector<std::uint32_t> compile_glsl(const Source& source);
// Throws tessref::Error with the validator's message.
void validate_spirv(const std::vector<std::uint32_t>& spirv, const std::string& path);

constexpr std::uint32_t kNone = 0xffffffffu;

enum class Kind : std::uint8_t { none, void_, bool_, int_, float_, vector, matrix, array, struct_, pointer, function,
                                 image, sampled_image, sampler };

struct Type {
    Kind kind = Kind::none;
    bool is_signed = false;            // int
    std::uint32_t element = 0;         // vector/matrix/array: component/column/element; pointer: pointee
    std::uint32_t count = 0;           // vector components, matrix columns, array length
    std::vector<std::uint32_t> members;
    std::vector<std::uint32_t> member_offset;  // in words
    std::uint32_t words = 0;           // flattened size
    std::uint32_t storage = 0;         // pointer: storage class
    Kind scalar = Kind::none;          // the leaf kind of a scalar or vector (bool, int, float)
};

// A variable's interface binding: one flattened part of it (a scalar or a vector, four
// words at most) bound to a location or a built-in.
struct InterfacePart {
    std::uint32_t offset = 0;   // words into the variable (for an arrayed variable: into one vertex's element)
    std::uint32_t words = 0;
    int location = -1;          // with component 0 at offset
    int builtin = -1;           // spv::BuiltIn
};

struct Variable {
    std::uint32_t id = 0;
    std::uint32_t type = 0;     // the pointee type
    std::uint32_t storage = 0;  // spv::StorageClass
    std::uint32_t address = 0;
    std::uint32_t init = 0;     // constant id or 0
    std::string name;
    // Interface (Input/Output) variables:
    bool arrayed = false;       // one element per vertex (control/evaluation inputs, control per-vertex outputs)
    bool patch = false;         // a `patch` variable
    std::uint32_t element_words = 0;  // arrayed: one vertex's element
    std::uint32_t vertices = 0;       // arrayed: the array's length
    std::vector<InterfacePart> parts;
    int binding = -1;           // samplers: layout(binding = N)
    int builtin = -1;           // a built-in variable (not a block)
};

// One decoded instruction: the opcode, its operand words (words[at .. at + count)), and
// what is known of its result before running.
struct Instr {
    std::uint16_t op = 0;
    std::uint16_t count = 0;     // operand words (after the opcode word)
    std::uint32_t at = 0;        // index of the first operand word in Module::Impl::words
    std::uint32_t line = 0;      // source line (OpLine), 0 unknown
    std::uint32_t file = 0;      // OpString id of the file, 0 unknown
};

// A chain of one associative float operation that Mesa's GLSL compiler rebalances
// (rebalance.h): the instruction at its root runs the whole chain (kOpChain), the chain's
// other instructions are OpNop. Each step is (result, left, right) by id; the chain's own
// intermediate results are its registers. `as_written` is the source's order, `llvmpipe`
// Mesa's; which one runs follows RunOptions::math.
struct Chain {
    std::uint16_t op = 0;            // spv::OpFAdd or spv::OpFMul
    std::uint32_t components = 1;    // of the result: a scalar or a vector
    std::vector<std::array<std::uint32_t, 3>> as_written, llvmpipe;
};
// The opcode of an Instr that runs Module::Impl::chains[at] (no SPIR-V opcode is this large).
constexpr std::uint16_t kOpChain = 0xffff;

struct Function {
    std::uint32_t first = 0;     // index in code of its first OpLabel
    std::vector<std::uint32_t> params;
};

struct Module::Impl {
    ShaderStage stage = ShaderStage::vertex;
    std::string path;
    std::vector<std::uint32_t> words;  // the binary

    std::uint32_t bound = 0;
    std::vector<Type> types;            // by id
    std::vector<std::uint32_t> type_of; // result type by id (0: none)
    std::vector<std::uint32_t> reg;     // register offset by id (kNone: none)
    std::vector<std::uint32_t> reg_init;  // the register file with every constant in place
    // The runs (first word, words) of reg_init that hold a value before any instruction
    // runs: the constants and global variables' addresses (every register allocated before
    // the first function) and each Function variable's address. A batch sets up only these;
    // every other register is written before it is read (executor.h, Batch::restart).
    std::vector<std::pair<std::uint32_t, std::uint32_t>> fixed_regs;
    // By id: 1 where the value is the same in every lane of any batch, known before running
    // (constants, variables' addresses, access chains into them with such indices), so that
    // a load, store or access chain through it needs no test of its lanes.
    std::vector<std::uint8_t> lane_invariant;
    std::vector<std::string> names;     // OpName by id
    std::map<std::uint32_t, std::string> strings;  // OpString
    std::uint32_t std450 = 0;           // the GLSL.std.450 import's id

    std::vector<Instr> code;
    std::vector<Chain> chains;               // kOpChain's operands
    std::vector<std::uint32_t> label_at;     // by label id: index in code
    std::map<std::uint32_t, Function> functions;
    std::uint32_t entry = 0;

    std::vector<Variable> variables;
    std::vector<std::uint32_t> variable_of;  // by id: index in variables (kNone)
    std::uint32_t shared_words = 0;
    std::uint32_t local_words = 0;
    std::vector<std::uint32_t> shared_init;  // uniform initializers, zero elsewhere
    std::vector<std::uint32_t> local_init;   // Private initializers

    int output_vertices = 0;           // a control shader's vertices, a geometry shader's max_vertices
    TessLayout layout;
    GeometryLayout geometry;
    bool has_layout = false;

    // "file:line" of an instruction, or the module's path.
    Where where(const Instr& instr) const;
    std::string where_text(const Instr& instr) const;
    const Variable* variable(std::uint32_t id) const {
        return id < variable_of.size() && variable_of[id] != kNone ? &variables[variable_of[id]] : nullptr;
    }
};

// The opcode's name ("OpFAdd"), for errors.
std::string opcode_name(std::uint32_t op);

}  // namespace tessref::shader
