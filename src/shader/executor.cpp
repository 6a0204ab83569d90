// The interpreter proper: one invocation, one instruction at a time. See executor.h and,
// for the float and integer semantics it implements, tessref/shader.h.
//
// Control flow follows the branches as they are (OpSelectionMerge and OpLoopMerge only
// declare structure); OpPhi picks the value of the block the branch came from. Calls push
// a frame and run the callee's blocks in the same loop, so that a control shader's
// invocation can stop at a barrier inside any function and resume there.
#define SPV_ENABLE_UTILITY_CODE
#include "shader/executor.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include <glslang/SPIRV/spirv.hpp>

#include "shader/std450.h"

namespace tessref::shader {

namespace {

inline float f(std::uint32_t w) { return std::bit_cast<float>(w); }
inline std::uint32_t w(float x) { return std::bit_cast<std::uint32_t>(x); }
inline std::int32_t s(std::uint32_t w) { return static_cast<std::int32_t>(w); }

// float -> int as documented in shader.h: NaN 0, out of range saturated.
std::uint32_t to_signed(float x, bool& undefined) {
    if (std::isnan(x)) { undefined = true; return 0; }
    if (x >= 2147483648.0f) { undefined = true; return 0x7fffffffu; }
    if (x < -2147483648.0f) { undefined = true; return 0x80000000u; }
    return static_cast<std::uint32_t>(static_cast<std::int32_t>(x));
}
std::uint32_t to_unsigned(float x, bool& undefined) {
    if (std::isnan(x)) { undefined = true; return 0; }
    if (x >= 4294967296.0f) { undefined = true; return 0xffffffffu; }
    if (x <= -1.0f) { undefined = true; return 0; }
    return static_cast<std::uint32_t>(x);
}

}  // namespace

Invocation::Invocation(const Module::Impl& m)
    : regs_(m.reg_init), local_(m.local_init), pc_(m.functions.at(m.entry).first) {}

std::uint32_t* Invocation::memory(ExecContext& c, std::uint32_t address, std::uint32_t words) {
    const Module::Impl& m = c.module;
    if (address < m.shared_words) {
        if (address + words > m.shared_words) throw Error("interpreter: memory access out of range (" + c.who + ")");
        return &c.shared[address];
    }
    const std::uint32_t at = address - m.shared_words;
    if (at + words > local_.size()) throw Error("interpreter: memory access out of range (" + c.who + ")");
    return &local_[at];
}

// The variable a store's address falls in, named as the source names it (an array's
// element as name[i], a word further in as +k; the unnamed gl_PerVertex block by its
// built-in), and the kind of the stored value's scalars, for RunOptions::observer.
void Invocation::observe_store(ExecContext& c, std::uint32_t address, std::uint32_t value, std::uint32_t words) {
    const Module::Impl& m = c.module;
    std::string name;
    std::uint32_t offset = 0;
    for (const Variable& v : m.variables) {
        if (address < v.address || address >= v.address + m.types[v.type].words) continue;
        name = v.name;
        offset = address - v.address;
        const Type& t = m.types[v.type];
        if (t.kind == Kind::array && m.types[t.element].words > 0) {
            const std::uint32_t element = m.types[t.element].words;
            name += "[" + std::to_string(offset / element) + "]";
            offset %= element;
        }
        if (v.name.empty())
            for (const InterfacePart& part : v.parts)
                if (part.builtin == spv::BuiltInPosition && offset >= part.offset && offset < part.offset + part.words) {
                    name = "gl_Position" + name;
                    offset -= part.offset;
                }
        break;
    }
    // The scalar beneath vectors, matrices and arrays.
    const Type* t = &m.types[m.type_of[value]];
    while (t->kind == Kind::vector || t->kind == Kind::matrix || t->kind == Kind::array) t = &m.types[t->element];
    const char kind = t->kind == Kind::bool_ ? 'b' : t->kind == Kind::int_ ? (t->is_signed ? 'i' : 'u') : 'f';
    c.options.observer->store(name, offset, kind, std::span<const std::uint32_t>(regs_.data() + m.reg[value], words));
}

Invocation::Status Invocation::run(ExecContext& c) {
    const Module::Impl& m = c.module;
    const std::uint32_t* const words = m.words.data();
    std::uint32_t* const regs = regs_.data();
    const auto R = [&](std::uint32_t id) -> std::uint32_t* { return regs + m.reg[id]; };
    const auto T = [&](std::uint32_t type_id) -> const Type& { return m.types[type_id]; };
    // Components of a scalar or vector type.
    const auto N = [&](std::uint32_t type_id) -> std::uint32_t {
        const Type& t = m.types[type_id];
        return t.kind == Kind::vector ? t.count : 1;
    };
    const auto warn = [&](const Instr& in, const std::string& what) {
        if (!c.options.warnings) return;
        const std::uint32_t index = static_cast<std::uint32_t>(&in - m.code.data());
        if (c.warned && !c.warned->insert(index).second) return;
        c.options.warnings->push_back(what + " (" + m.where_text(in) + ", " + c.who + ")");
    };
    const auto unsupported = [&](const Instr& in, const std::string& what) {
        throw Error(what + " is not supported by the interpreter (" + c.who + ")", m.where(in));
    };
    // An element index clamped into [0, count) with a warning, as shader.h documents.
    const auto clamp_index = [&](const Instr& in, std::int64_t index, std::uint32_t count) -> std::uint32_t {
        if (index >= 0 && index < count) return static_cast<std::uint32_t>(index);
        warn(in, "warning: index " + std::to_string(index) + " out of range [0, " + std::to_string(count) +
                     "), clamped");
        return index < 0 ? 0 : count - 1;
    };
    // The word offset of a chain of indices into a type; `constant` indices are literals.
    const auto offset_of = [&](const Instr& in, std::uint32_t type_id, const std::uint32_t* index, std::uint32_t n,
                               bool literal, std::uint32_t& result_type) -> std::uint32_t {
        std::uint32_t offset = 0;
        for (std::uint32_t k = 0; k < n; ++k) {
            const Type& t = T(type_id);
            std::int64_t i;
            if (literal) {
                i = index[k];
            } else {
                const Type& it = T(m.type_of[index[k]]);
                i = it.is_signed ? static_cast<std::int64_t>(s(*R(index[k]))) : static_cast<std::int64_t>(*R(index[k]));
            }
            if (t.kind == Kind::struct_) {
                const std::uint32_t member = clamp_index(in, i, static_cast<std::uint32_t>(t.members.size()));
                offset += t.member_offset[member];
                type_id = t.members[member];
            } else {
                const std::uint32_t e = clamp_index(in, i, t.count);
                type_id = t.element;
                offset += e * T(type_id).words;
            }
        }
        result_type = type_id;
        return offset;
    };

    observed_line_ = observed_file_ = 0;  // a resumed invocation tells its line again
    for (;;) {
        const Instr& in = m.code[pc_];
        if (c.options.observer && in.line != 0 && (in.line != observed_line_ || in.file != observed_file_)) {
            observed_line_ = in.line;
            observed_file_ = in.file;
            const auto file = m.strings.find(in.file);
            c.options.observer->line(file != m.strings.end() ? file->second : m.path, in.line);
        }
        if (++executed_ > c.options.max_instructions)
            throw Error("the " + c.who + " ran past its instruction budget of " +
                            std::to_string(c.options.max_instructions) +
                            " instructions (does it terminate? --max-instructions raises the budget)",
                        m.where(in));
        const std::uint32_t* a = words + in.at;
        const spv::Op op = static_cast<spv::Op>(in.op);
        ++pc_;
        switch (op) {
            case spv::OpLabel:
                previous_label_ = label_;
                label_ = a[0];
                break;
            case spv::OpSelectionMerge:
            case spv::OpLoopMerge:
            case spv::OpNop:
            case spv::OpMemoryBarrier:
            case spv::OpLine:
            case spv::OpNoLine:
                break;
            case spv::OpPhi: {
                // Every OpPhi at the head of the block reads the values as they were on entry.
                std::vector<std::pair<std::uint32_t, std::vector<std::uint32_t>>> values;
                std::uint32_t k = pc_ - 1;
                for (; k < m.code.size() && m.code[k].op == spv::OpPhi; ++k) {
                    const Instr& phi = m.code[k];
                    const std::uint32_t* p = words + phi.at;
                    const std::uint32_t size = T(p[0]).words;
                    bool found = false;
                    for (std::uint32_t j = 2; j + 1 < phi.count; j += 2) {
                        if (p[j + 1] != previous_label_) continue;
                        values.emplace_back(p[1], std::vector<std::uint32_t>(R(p[j]), R(p[j]) + size));
                        found = true;
                        break;
                    }
                    if (!found) throw Error("OpPhi without an entry for the block it came from", m.where(phi));
                }
                for (const auto& [id, v] : values) std::copy(v.begin(), v.end(), R(id));
                pc_ = k;
                break;
            }
            case spv::OpBranch: pc_ = m.label_at[a[0]]; break;
            case spv::OpBranchConditional: pc_ = m.label_at[*R(a[0]) ? a[1] : a[2]]; break;
            case spv::OpSwitch: {
                const std::uint32_t selector = *R(a[0]);
                std::uint32_t target = a[1];
                for (std::uint32_t j = 2; j + 1 < in.count; j += 2)
                    if (a[j] == selector) {
                        target = a[j + 1];
                        break;
                    }
                pc_ = m.label_at[target];
                break;
            }
            case spv::OpReturn:
            case spv::OpReturnValue: {
                if (stack_.empty()) return Status::done;
                const Frame frame = stack_.back();
                stack_.pop_back();
                if (op == spv::OpReturnValue)
                    std::copy_n(R(a[0]), T(m.type_of[frame.result]).words, R(frame.result));
                pc_ = frame.return_pc;
                label_ = frame.label;
                break;
            }
            case spv::OpKill:
            case spv::OpTerminateInvocation: return Status::killed;
            case spv::OpUnreachable: throw Error("OpUnreachable was reached (" + c.who + ")", m.where(in));
            case spv::OpFunctionCall: {
                const auto fn = m.functions.find(a[2]);
                if (fn == m.functions.end() || fn->second.first == kNone)
                    throw Error("a call of an undefined function", m.where(in));
                const Function& callee = fn->second;
                if (stack_.size() > 256) throw Error("calls nested deeper than 256 (" + c.who + ")", m.where(in));
                for (std::uint32_t j = 0; j < callee.params.size() && 3 + j < in.count; ++j) {
                    const std::uint32_t param = callee.params[j];
                    std::copy_n(R(a[3 + j]), T(m.type_of[param]).words, R(param));
                }
                stack_.push_back(Frame{pc_, a[1], label_});
                pc_ = callee.first;
                break;
            }
            case spv::OpControlBarrier: return Status::barrier;
            case spv::OpVariable:
                if (in.count > 3) std::copy_n(R(a[3]), T(T(a[0]).element).words, memory(c, *R(a[1]), T(T(a[0]).element).words));
                break;
            case spv::OpLoad: {
                const std::uint32_t size = T(a[0]).words;
                std::copy_n(memory(c, *R(a[2]), size), size, R(a[1]));
                break;
            }
            case spv::OpStore: {
                const std::uint32_t size = T(T(m.type_of[a[0]]).element).words;
                std::copy_n(R(a[1]), size, memory(c, *R(a[0]), size));
                if (c.options.observer) observe_store(c, *R(a[0]), a[1], size);
                break;
            }
            case spv::OpCopyMemory: {
                const std::uint32_t size = T(T(m.type_of[a[0]]).element).words;
                std::copy_n(memory(c, *R(a[1]), size), size, memory(c, *R(a[0]), size));
                break;
            }
            case spv::OpAccessChain:
            case spv::OpInBoundsAccessChain: {
                std::uint32_t result_type = 0;
                const std::uint32_t base = *R(a[2]);
                const std::uint32_t offset =
                    offset_of(in, T(m.type_of[a[2]]).element, a + 3, in.count - 3u, false, result_type);
                *R(a[1]) = base + offset;
                break;
            }
            case spv::OpCopyObject:
            case spv::OpCopyLogical: std::copy_n(R(a[2]), T(a[0]).words, R(a[1])); break;
            case spv::OpCompositeConstruct: {
                std::uint32_t* out = R(a[1]);
                const std::uint32_t size = T(a[0]).words;
                std::uint32_t at = 0;
                for (std::uint32_t j = 2; j < in.count; ++j) {
                    const std::uint32_t part = T(m.type_of[a[j]]).words;
                    if (at + part > size) throw Error("OpCompositeConstruct larger than its type", m.where(in));
                    std::copy_n(R(a[j]), part, out + at);
                    at += part;
                }
                break;
            }
            case spv::OpCompositeExtract: {
                std::uint32_t result_type = 0;
                const std::uint32_t offset = offset_of(in, m.type_of[a[2]], a + 3, in.count - 3u, true, result_type);
                std::copy_n(R(a[2]) + offset, T(a[0]).words, R(a[1]));
                break;
            }
            case spv::OpCompositeInsert: {
                const std::uint32_t size = T(a[0]).words;
                std::vector<std::uint32_t> v(R(a[3]), R(a[3]) + size);
                std::uint32_t result_type = 0;
                const std::uint32_t offset = offset_of(in, a[0], a + 4, in.count - 4u, true, result_type);
                std::copy_n(R(a[2]), T(result_type).words, v.begin() + offset);
                std::copy(v.begin(), v.end(), R(a[1]));
                break;
            }
            case spv::OpVectorShuffle: {
                const std::uint32_t n1 = N(m.type_of[a[2]]);
                std::uint32_t v[8] = {};
                const std::uint32_t n2 = N(m.type_of[a[3]]);
                std::copy_n(R(a[2]), n1, v);
                std::copy_n(R(a[3]), n2, v + n1);
                std::uint32_t* out = R(a[1]);
                for (std::uint32_t j = 4; j < in.count; ++j)
                    out[j - 4] = a[j] == 0xffffffffu ? 0 : v[std::min(a[j], n1 + n2 - 1)];
                break;
            }
            case spv::OpVectorExtractDynamic: {
                const Type& vt = T(m.type_of[a[2]]);
                const Type& it = T(m.type_of[a[3]]);
                const std::int64_t i = it.is_signed ? s(*R(a[3])) : static_cast<std::int64_t>(*R(a[3]));
                *R(a[1]) = R(a[2])[clamp_index(in, i, vt.count)];
                break;
            }
            case spv::OpVectorInsertDynamic: {
                const Type& vt = T(a[0]);
                const Type& it = T(m.type_of[a[4]]);
                const std::int64_t i = it.is_signed ? s(*R(a[4])) : static_cast<std::int64_t>(*R(a[4]));
                std::uint32_t v[4];
                std::copy_n(R(a[2]), vt.count, v);
                v[clamp_index(in, i, vt.count)] = *R(a[3]);
                std::copy_n(v, vt.count, R(a[1]));
                break;
            }
            case spv::OpSelect: {
                const std::uint32_t size = T(a[0]).words;
                const Type& ct = T(m.type_of[a[2]]);
                std::uint32_t* out = R(a[1]);
                const std::uint32_t* cond = R(a[2]);
                const std::uint32_t* x = R(a[3]);
                const std::uint32_t* y = R(a[4]);
                if (ct.kind == Kind::vector) {
                    for (std::uint32_t j = 0; j < size; ++j) out[j] = cond[j] ? x[j] : y[j];
                } else {
                    std::vector<std::uint32_t> v(cond[0] ? x : y, (cond[0] ? x : y) + size);
                    std::copy(v.begin(), v.end(), out);
                }
                break;
            }

            // ---- float arithmetic, each operation rounded on its own ---------------------
#define TESSREF_FLOAT_BINARY(OP, EXPR)                                          \
    case spv::OP: {                                                             \
        const std::uint32_t n = N(a[0]);                                        \
        const std::uint32_t* x = R(a[2]);                                       \
        const std::uint32_t* y = R(a[3]);                                       \
        std::uint32_t* out = R(a[1]);                                           \
        for (std::uint32_t j = 0; j < n; ++j) {                                 \
            const float p = f(x[j]), q = f(y[j]);                               \
            out[j] = w(EXPR);                                                   \
        }                                                                       \
        break;                                                                  \
    }
            TESSREF_FLOAT_BINARY(OpFAdd, p + q)
            TESSREF_FLOAT_BINARY(OpFSub, p - q)
            TESSREF_FLOAT_BINARY(OpFMul, p * q)
            TESSREF_FLOAT_BINARY(OpFDiv, p / q)
            // GLSL mod(x, y) = x - y * floor(x / y); OpFRem x - y * trunc(x / y); each step rounded.
            TESSREF_FLOAT_BINARY(OpFMod, p - q * std::floor(p / q))
            TESSREF_FLOAT_BINARY(OpFRem, p - q * std::trunc(p / q))
#undef TESSREF_FLOAT_BINARY
            case spv::OpFNegate: {
                const std::uint32_t n = N(a[0]);
                for (std::uint32_t j = 0; j < n; ++j) R(a[1])[j] = R(a[2])[j] ^ 0x80000000u;
                break;
            }
            case spv::OpVectorTimesScalar:
            case spv::OpMatrixTimesScalar: {
                const std::uint32_t size = T(a[0]).words;
                const float k = f(*R(a[3]));
                for (std::uint32_t j = 0; j < size; ++j) R(a[1])[j] = w(f(R(a[2])[j]) * k);
                break;
            }
            case spv::OpDot: {
                const std::uint32_t n = N(m.type_of[a[2]]);
                const std::uint32_t* x = R(a[2]);
                const std::uint32_t* y = R(a[3]);
                float sum = f(x[0]) * f(y[0]);
                for (std::uint32_t j = 1; j < n; ++j) {
                    const float product = f(x[j]) * f(y[j]);
                    sum = sum + product;
                }
                *R(a[1]) = w(sum);
                break;
            }
            case spv::OpMatrixTimesVector:
            case spv::OpMatrixTimesMatrix:
            case spv::OpVectorTimesMatrix: {
                // Left operand's columns (rows of the result) times the right operand's
                // columns; column k of the result = sum over j of left column j * right[k][j],
                // in GLM's order (shader.h): four columns pairwise, else from j = 0 on.
                const Type& lt = T(m.type_of[a[2]]);
                const Type& rt = T(m.type_of[a[3]]);
                const std::uint32_t* l = R(a[2]);
                const std::uint32_t* r = R(a[3]);
                std::vector<std::uint32_t> out(T(a[0]).words);
                if (op == spv::OpVectorTimesMatrix) {
                    // v * M: result[k] = dot(v, M column k), summed from the first component.
                    const std::uint32_t rows = lt.count;
                    for (std::uint32_t k = 0; k < rt.count; ++k) {
                        float sum = f(l[0]) * f(r[k * rows]);
                        for (std::uint32_t j = 1; j < rows; ++j) {
                            const float product = f(l[j]) * f(r[k * rows + j]);
                            sum = sum + product;
                        }
                        out[k] = w(sum);
                    }
                } else {
                    const std::uint32_t rows = T(lt.element).count;  // the left matrix's column size
                    const std::uint32_t columns = lt.count;
                    const std::uint32_t results = op == spv::OpMatrixTimesVector ? 1 : rt.count;
                    for (std::uint32_t k = 0; k < results; ++k) {
                        const std::uint32_t* v = r + k * columns;
                        for (std::uint32_t i = 0; i < rows; ++i) {
                            if (columns == 4) {
                                const float p0 = f(l[i]) * f(v[0]), p1 = f(l[rows + i]) * f(v[1]);
                                const float p2 = f(l[2 * rows + i]) * f(v[2]), p3 = f(l[3 * rows + i]) * f(v[3]);
                                const float s01 = p0 + p1, s23 = p2 + p3;
                                out[k * rows + i] = w(s01 + s23);
                                continue;
                            }
                            float sum = f(l[i]) * f(v[0]);
                            for (std::uint32_t j = 1; j < columns; ++j) {
                                const float product = f(l[j * rows + i]) * f(v[j]);
                                sum = sum + product;
                            }
                            out[k * rows + i] = w(sum);
                        }
                    }
                }
                std::copy(out.begin(), out.end(), R(a[1]));
                break;
            }
            case spv::OpOuterProduct: {
                const std::uint32_t rows = N(m.type_of[a[2]]), columns = N(m.type_of[a[3]]);
                for (std::uint32_t k = 0; k < columns; ++k)
                    for (std::uint32_t i = 0; i < rows; ++i)
                        R(a[1])[k * rows + i] = w(f(R(a[2])[i]) * f(R(a[3])[k]));
                break;
            }
            case spv::OpTranspose: {
                const Type& rt = T(a[0]);
                const std::uint32_t columns = rt.count, rows = T(rt.element).count;
                std::vector<std::uint32_t> out(columns * rows);
                for (std::uint32_t k = 0; k < columns; ++k)
                    for (std::uint32_t i = 0; i < rows; ++i) out[k * rows + i] = R(a[2])[i * columns + k];
                std::copy(out.begin(), out.end(), R(a[1]));
                break;
            }

            // ---- integers: two's complement, wrapping ------------------------------------
#define TESSREF_INT_BINARY(OP, EXPR)                                            \
    case spv::OP: {                                                             \
        const std::uint32_t n = N(a[0]);                                        \
        const std::uint32_t* x = R(a[2]);                                       \
        const std::uint32_t* y = R(a[3]);                                       \
        std::uint32_t* out = R(a[1]);                                           \
        for (std::uint32_t j = 0; j < n; ++j) {                                 \
            const std::uint32_t p = x[j], q = y[j];                             \
            out[j] = (EXPR);                                                    \
        }                                                                       \
        break;                                                                  \
    }
            TESSREF_INT_BINARY(OpIAdd, p + q)
            TESSREF_INT_BINARY(OpISub, p - q)
            TESSREF_INT_BINARY(OpIMul, p * q)
            TESSREF_INT_BINARY(OpBitwiseAnd, p & q)
            TESSREF_INT_BINARY(OpBitwiseOr, p | q)
            TESSREF_INT_BINARY(OpBitwiseXor, p ^ q)
            TESSREF_INT_BINARY(OpShiftLeftLogical, p << (q & 31u))
            TESSREF_INT_BINARY(OpShiftRightLogical, p >> (q & 31u))
            TESSREF_INT_BINARY(OpShiftRightArithmetic, static_cast<std::uint32_t>(s(p) >> (q & 31u)))
            TESSREF_INT_BINARY(OpIEqual, p == q)
            TESSREF_INT_BINARY(OpINotEqual, p != q)
            TESSREF_INT_BINARY(OpUGreaterThan, p > q)
            TESSREF_INT_BINARY(OpUGreaterThanEqual, p >= q)
            TESSREF_INT_BINARY(OpULessThan, p < q)
            TESSREF_INT_BINARY(OpULessThanEqual, p <= q)
            TESSREF_INT_BINARY(OpSGreaterThan, s(p) > s(q))
            TESSREF_INT_BINARY(OpSGreaterThanEqual, s(p) >= s(q))
            TESSREF_INT_BINARY(OpSLessThan, s(p) < s(q))
            TESSREF_INT_BINARY(OpSLessThanEqual, s(p) <= s(q))
            TESSREF_INT_BINARY(OpLogicalAnd, (p && q) ? 1u : 0u)
            TESSREF_INT_BINARY(OpLogicalOr, (p || q) ? 1u : 0u)
            TESSREF_INT_BINARY(OpLogicalEqual, (!p == !q) ? 1u : 0u)
            TESSREF_INT_BINARY(OpLogicalNotEqual, (!p != !q) ? 1u : 0u)
#undef TESSREF_INT_BINARY
            case spv::OpSDiv:
            case spv::OpUDiv:
            case spv::OpSRem:
            case spv::OpSMod:
            case spv::OpUMod: {
                const std::uint32_t n = N(a[0]);
                bool by_zero = false;
                for (std::uint32_t j = 0; j < n; ++j) {
                    const std::uint32_t p = R(a[2])[j], q = R(a[3])[j];
                    std::uint32_t r;
                    if (q == 0) {
                        by_zero = true;
                        r = (op == spv::OpSDiv || op == spv::OpUDiv) ? 0xffffffffu : p;
                    } else if (op == spv::OpUDiv) {
                        r = p / q;
                    } else if (op == spv::OpUMod) {
                        r = p % q;
                    } else if (s(p) == std::numeric_limits<std::int32_t>::min() && s(q) == -1) {
                        r = op == spv::OpSDiv ? p : 0u;  // INT_MIN / -1 wraps; the remainder is 0
                    } else if (op == spv::OpSDiv) {
                        r = static_cast<std::uint32_t>(s(p) / s(q));
                    } else {
                        std::int32_t rem = s(p) % s(q);  // the sign of p (OpSRem)
                        if (op == spv::OpSMod && rem != 0 && ((rem < 0) != (s(q) < 0))) rem += s(q);  // the sign of q
                        r = static_cast<std::uint32_t>(rem);
                    }
                    R(a[1])[j] = r;
                }
                if (by_zero)
                    warn(in, std::string("warning: integer ") + (op == spv::OpSDiv || op == spv::OpUDiv ? "division" : "remainder") +
                                 " by zero (" + opcode_name(op) + "), result " +
                                 (op == spv::OpSDiv || op == spv::OpUDiv ? "all ones" : "the dividend"));
                break;
            }
            case spv::OpSNegate: {
                const std::uint32_t n = N(a[0]);
                for (std::uint32_t j = 0; j < n; ++j) R(a[1])[j] = 0u - R(a[2])[j];
                break;
            }
            case spv::OpNot: {
                const std::uint32_t n = N(a[0]);
                for (std::uint32_t j = 0; j < n; ++j) R(a[1])[j] = ~R(a[2])[j];
                break;
            }
            case spv::OpLogicalNot: {
                const std::uint32_t n = N(a[0]);
                for (std::uint32_t j = 0; j < n; ++j) R(a[1])[j] = R(a[2])[j] ? 0u : 1u;
                break;
            }
            case spv::OpBitCount: {
                const std::uint32_t n = N(a[0]);
                for (std::uint32_t j = 0; j < n; ++j) R(a[1])[j] = static_cast<std::uint32_t>(std::popcount(R(a[2])[j]));
                break;
            }
            case spv::OpAny:
            case spv::OpAll: {
                const std::uint32_t n = N(m.type_of[a[2]]);
                bool any = false, all = true;
                for (std::uint32_t j = 0; j < n; ++j) {
                    any = any || R(a[2])[j];
                    all = all && R(a[2])[j];
                }
                *R(a[1]) = (op == spv::OpAny ? any : all) ? 1u : 0u;
                break;
            }

            // ---- float comparisons (Ord: false with a NaN; Unord: true) -------------------
#define TESSREF_FLOAT_COMPARE(OP, EXPR, UNORDERED)                              \
    case spv::OP: {                                                             \
        const std::uint32_t n = N(a[0]);                                        \
        for (std::uint32_t j = 0; j < n; ++j) {                                 \
            const float p = f(R(a[2])[j]), q = f(R(a[3])[j]);                   \
            const bool nan = std::isnan(p) || std::isnan(q);                    \
            R(a[1])[j] = nan ? (UNORDERED) : ((EXPR) ? 1u : 0u);                \
        }                                                                       \
        break;                                                                  \
    }
            TESSREF_FLOAT_COMPARE(OpFOrdEqual, p == q, 0u)
            TESSREF_FLOAT_COMPARE(OpFOrdNotEqual, p != q, 0u)
            TESSREF_FLOAT_COMPARE(OpFOrdLessThan, p < q, 0u)
            TESSREF_FLOAT_COMPARE(OpFOrdGreaterThan, p > q, 0u)
            TESSREF_FLOAT_COMPARE(OpFOrdLessThanEqual, p <= q, 0u)
            TESSREF_FLOAT_COMPARE(OpFOrdGreaterThanEqual, p >= q, 0u)
            TESSREF_FLOAT_COMPARE(OpFUnordEqual, p == q, 1u)
            TESSREF_FLOAT_COMPARE(OpFUnordNotEqual, p != q, 1u)
            TESSREF_FLOAT_COMPARE(OpFUnordLessThan, p < q, 1u)
            TESSREF_FLOAT_COMPARE(OpFUnordGreaterThan, p > q, 1u)
            TESSREF_FLOAT_COMPARE(OpFUnordLessThanEqual, p <= q, 1u)
            TESSREF_FLOAT_COMPARE(OpFUnordGreaterThanEqual, p >= q, 1u)
#undef TESSREF_FLOAT_COMPARE
            case spv::OpIsNan:
            case spv::OpIsInf: {
                const std::uint32_t n = N(a[0]);
                for (std::uint32_t j = 0; j < n; ++j) {
                    const float p = f(R(a[2])[j]);
                    R(a[1])[j] = (op == spv::OpIsNan ? std::isnan(p) : std::isinf(p)) ? 1u : 0u;
                }
                break;
            }

            // ---- conversions ---------------------------------------------------------------
            case spv::OpConvertFToS:
            case spv::OpConvertFToU: {
                const std::uint32_t n = N(a[0]);
                bool undefined = false;
                for (std::uint32_t j = 0; j < n; ++j)
                    R(a[1])[j] = op == spv::OpConvertFToS ? to_signed(f(R(a[2])[j]), undefined)
                                                          : to_unsigned(f(R(a[2])[j]), undefined);
                if (undefined) warn(in, "warning: float to integer conversion of NaN or out of range, result saturated (NaN: 0)");
                break;
            }
            case spv::OpConvertSToF:
            case spv::OpConvertUToF: {
                const std::uint32_t n = N(a[0]);
                for (std::uint32_t j = 0; j < n; ++j)
                    R(a[1])[j] = op == spv::OpConvertSToF ? w(static_cast<float>(s(R(a[2])[j])))
                                                          : w(static_cast<float>(R(a[2])[j]));
                break;
            }
            case spv::OpBitcast:
            case spv::OpSConvert:
            case spv::OpUConvert:
            case spv::OpFConvert: std::copy_n(R(a[2]), T(a[0]).words, R(a[1])); break;

            // ---- GLSL.std.450 ---------------------------------------------------------------
            case spv::OpExtInst: {
                if (a[2] != m.std450) unsupported(in, "an extended instruction set other than GLSL.std.450");
                Std450Args args;
                args.count = std::min<std::uint32_t>(in.count - 4u, 3);
                for (std::uint32_t j = 0; j < args.count; ++j) {
                    const std::uint32_t id = a[4 + j];
                    const Type& t = T(m.type_of[id]);
                    args.value[j] = R(id);
                    args.components[j] = t.kind == Kind::vector ? t.count : 1;
                    args.scalar[j] = t.scalar;
                }
                const Type& rt = T(a[0]);
                if (!run_std450(a[3], c.options.math, rt.scalar, rt.kind == Kind::vector ? rt.count : 1, args, R(a[1])))
                    unsupported(in, std450_name(a[3]));
                break;
            }

            // ---- textures --------------------------------------------------------------------
            case spv::OpSampledImage:
            case spv::OpImage: *R(a[1]) = *R(a[2]); break;
            case spv::OpImageSampleImplicitLod:
            case spv::OpImageSampleExplicitLod: {
                const std::uint32_t unit = *R(a[2]);
                const Texture* texture = unit < c.units.size() ? c.units[unit] : nullptr;
                std::uint32_t* out = R(a[1]);
                if (!texture) {  // no texture at the unit: GL's incomplete texture reads (0, 0, 0, 1)
                    out[0] = out[1] = out[2] = 0;
                    out[3] = w(1.0f);
                    break;
                }
                const std::uint32_t* st = R(a[3]);
                const glm::vec2 coordinate(f(st[0]), f(st[1]));
                float lod = 0.0f;
                if (in.count > 4) {
                    const std::uint32_t mask = a[4];
                    if (mask & ~static_cast<std::uint32_t>(spv::ImageOperandsLodMask))
                        unsupported(in, "image operands other than Lod (bias, offsets, gradients)");
                    if (mask & spv::ImageOperandsLodMask) lod = f(*R(a[5]));
                }
                // texture() outside a fragment shader: no derivatives, the implicit lod is 0.
                const glm::vec4 v = op == spv::OpImageSampleImplicitLod ? texture->texture(coordinate)
                                                                        : texture->textureLod(coordinate, lod);
                for (int j = 0; j < 4; ++j) out[j] = w(v[j]);
                break;
            }
            case spv::OpImageQuerySizeLod: {
                const std::uint32_t unit = *R(a[2]);
                const Texture* texture = unit < c.units.size() ? c.units[unit] : nullptr;
                if (!texture) throw Error("no texture is bound to unit " + std::to_string(unit), m.where(in));
                const std::uint32_t lod = std::min<std::uint32_t>(*R(a[3]), static_cast<std::uint32_t>(texture->level_count() - 1));
                R(a[1])[0] = static_cast<std::uint32_t>(texture->level(static_cast<int>(lod)).width);
                R(a[1])[1] = static_cast<std::uint32_t>(texture->level(static_cast<int>(lod)).height);
                break;
            }
            default: unsupported(in, opcode_name(in.op));
        }
    }
}

}  // namespace tessref::shader
