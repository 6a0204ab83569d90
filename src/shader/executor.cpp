// The interpreter proper: a batch of invocations, one instruction at a time over all its
// lanes. See executor.h and, for the float and integer semantics it implements,
// tessref/shader.h.
//
// Control flow follows the branches as they are (OpSelectionMerge and OpLoopMerge only
// declare structure); OpPhi picks the value of the block the branch came from. Calls push
// a frame and run the callee's blocks in the same loop, so that a control shader's
// invocation can stop at a barrier inside any function and resume there. The lanes of a
// batch share the control flow: a branch they take different ways stops the batch, and the
// stage driver continues each way as a batch of its own (executor.h).
#define SPV_ENABLE_UTILITY_CODE
#include "shader/executor.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include <glslang/SPIRV/spirv.hpp>

#include "shader/std450.h"
#include "tessref/shading.h"  // textureGrad: texture() with a fragment quad's derivatives

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

// The one loop of every component-wise operation: `count` words (components times lanes),
// each the operation on the operands' words at the same place.
template <class F>
inline void each1(std::uint32_t* out, const std::uint32_t* x, std::uint32_t count, F op) {
    for (std::uint32_t k = 0; k < count; ++k) out[k] = op(x[k]);
}
template <class F>
inline void each2(std::uint32_t* out, const std::uint32_t* x, const std::uint32_t* y, std::uint32_t count, F op) {
    for (std::uint32_t k = 0; k < count; ++k) out[k] = op(x[k], y[k]);
}

// Float comparisons: Ord false with a NaN, Unord true.
template <class F>
inline std::uint32_t ordered(std::uint32_t p, std::uint32_t q, std::uint32_t unordered, F compare) {
    const float x = f(p), y = f(q);
    return std::isnan(x) || std::isnan(y) ? unordered : (compare(x, y) ? 1u : 0u);
}

// Whether every lane of a one-word register holds the same word.
inline bool uniform(const std::uint32_t* v, std::uint32_t lanes) {
    for (std::uint32_t l = 1; l < lanes; ++l)
        if (v[l] != v[0]) return false;
    return true;
}

}  // namespace

std::vector<std::uint32_t> gather_lanes(const std::vector<std::uint32_t>& from, std::uint32_t lanes,
                                        std::span<const std::uint32_t> pick) {
    const std::size_t words = from.size() / lanes, n = pick.size();
    std::vector<std::uint32_t> out(words * n);
    for (std::size_t j = 0; j < words; ++j)
        for (std::size_t k = 0; k < n; ++k) out[j * n + k] = from[j * lanes + pick[k]];
    return out;
}

std::vector<std::uint32_t> broadcast_lanes(const std::vector<std::uint32_t>& one, std::uint32_t lanes) {
    std::vector<std::uint32_t> out(one.size() * lanes);
    for (std::size_t j = 0; j < one.size(); ++j) std::fill_n(out.begin() + static_cast<std::ptrdiff_t>(j * lanes), lanes, one[j]);
    return out;
}

Batch::Batch(const Module::Impl& m, std::uint32_t lanes)
    : module_(&m),
      lanes_(lanes),
      regs_(m.reg_init.size() * lanes, 0),
      local_(broadcast_lanes(m.local_init, lanes)),
      pc_(m.functions.at(m.entry).first) {
    // Only the registers that hold a value before the first instruction (module.h).
    for (const auto& [first, words] : m.fixed_regs)
        for (std::uint32_t j = first; j < first + words; ++j)
            std::fill_n(regs_.begin() + static_cast<std::ptrdiff_t>(j) * lanes, lanes, m.reg_init[j]);
}

void Batch::restart() {
    const Module::Impl& m = *module_;
    for (std::size_t j = 0; j < m.local_init.size(); ++j)
        std::fill_n(local_.begin() + static_cast<std::ptrdiff_t>(j * lanes_), lanes_, m.local_init[j]);
    stack_.clear();
    pc_ = m.functions.at(m.entry).first;
    label_ = previous_label_ = 0;
    executed_ = 0;
}

Batch Batch::split(std::span<const std::uint32_t> pick) const {
    Batch b(*this);
    b.lanes_ = static_cast<std::uint32_t>(pick.size());
    b.regs_ = gather_lanes(regs_, lanes_, pick);
    b.local_ = gather_lanes(local_, lanes_, pick);
    return b;
}

// The words of `address` in memory (executor.h).
std::uint32_t* Batch::memory(ExecContext& c, std::uint32_t address, std::uint32_t words, std::uint32_t& stride) {
    const Module::Impl& m = c.module;
    stride = lanes_;
    if (address < m.shared_words) {
        if (address + words > m.shared_words) throw Error("interpreter: memory access out of range (" + c.who + ")");
        if (!c.lane_slot) return &c.shared[static_cast<std::size_t>(address) * lanes_];
        const std::uint32_t slot = (*c.lane_slot)[address];
        if (slot != kNone) return &c.shared[static_cast<std::size_t>(slot) * lanes_];
        stride = 0;
        return const_cast<std::uint32_t*>(c.invariant + address);  // only read: see `access`
    }
    const std::uint32_t at = address - m.shared_words;
    if (static_cast<std::size_t>(at + words) * lanes_ > local_.size())
        throw Error("interpreter: memory access out of range (" + c.who + ")");
    return &local_[static_cast<std::size_t>(at) * lanes_];
}

// The variable a store's address falls in, named as the source names it (an array's
// element as name[i], a word further in as +k; the unnamed gl_PerVertex block by its
// built-in), and the kind of the stored value's scalars, for RunOptions::observer (which
// records one lane, ExecContext::observed_lane).
void Batch::observe_store(ExecContext& c, std::uint32_t address, std::uint32_t value, std::uint32_t words) {
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
            name += '[';  // appended piece by piece: GCC 12 at -O3 warns (-Wrestrict) on "[" + s + "]"
            name += std::to_string(offset / element);
            name += ']';
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
    std::vector<std::uint32_t> stored(words);
    for (std::uint32_t j = 0; j < words; ++j)
        stored[j] = regs_[static_cast<std::size_t>(m.reg[value] + j) * lanes_ + c.observed_lane];
    c.options.observer->store(name, offset, kind, stored);
}

std::vector<std::uint32_t> Batch::targets(const ExecContext& c) const {
    const Module::Impl& m = c.module;
    const Instr& in = m.code[pc_];
    const std::uint32_t* a = m.words.data() + in.at;
    const std::uint32_t* selector = regs_.data() + static_cast<std::size_t>(m.reg[a[0]]) * lanes_;
    std::vector<std::uint32_t> target(lanes_);
    for (std::uint32_t l = 0; l < lanes_; ++l) {
        if (in.op == spv::OpBranchConditional) {
            target[l] = selector[l] ? a[1] : a[2];
            continue;
        }
        target[l] = a[1];
        for (std::uint32_t j = 2; j + 1 < in.count; j += 2)
            if (a[j] == selector[l]) {
                target[l] = a[j + 1];
                break;
            }
    }
    return target;
}

std::vector<std::vector<std::uint32_t>> Batch::ways(const ExecContext& c) const {
    const std::vector<std::uint32_t> target = targets(c);
    std::vector<std::uint32_t> labels;
    std::vector<std::vector<std::uint32_t>> out;
    for (std::uint32_t l = 0; l < lanes_; ++l) {
        const auto at = std::find(labels.begin(), labels.end(), target[l]);
        if (at == labels.end()) {
            labels.push_back(target[l]);
            out.push_back({l});
        } else {
            out[static_cast<std::size_t>(at - labels.begin())].push_back(l);
        }
    }
    return out;
}

void Batch::branch_to(std::uint32_t label) {
    ++executed_;  // the branch, as run() would have counted it
    pc_ = module_->label_at[label];
}

Batch Batch::join(std::span<const std::pair<const Batch*, std::vector<std::uint32_t>>> parts, std::uint32_t lanes) {
    Batch b(*parts.front().first);
    b.lanes_ = lanes;
    const auto scatter = [&](std::vector<std::uint32_t> Batch::*field) {
        const std::size_t words = (parts.front().first->*field).size() / parts.front().first->lanes_;
        std::vector<std::uint32_t> out(words * lanes, 0);
        for (const auto& [part, picks] : parts)
            for (std::size_t j = 0; j < words; ++j)
                for (std::size_t k = 0; k < picks.size(); ++k) out[j * lanes + picks[k]] = (part->*field)[j * part->lanes_ + k];
        b.*field = std::move(out);
    };
    scatter(&Batch::regs_);
    scatter(&Batch::local_);
    for (const auto& part : parts) b.executed_ = std::max(b.executed_, part.first->executed_);
    return b;
}

Batch::Status Batch::run(ExecContext& c) {
    if (lanes_ == 1) return run_lanes<1>(c);
    if (lanes_ == kBatchLanes) return run_lanes<kBatchLanes>(c);
    return run_lanes<0>(c);
}

// kLanes: the lane count known at compile time (1: a control shader's invocation, a vertex,
// a traced invocation, whose loops over the lanes then vanish; kBatchLanes: a full
// evaluation batch, whose loops the compiler unrolls and vectorises), or 0: lanes_.
template <std::uint32_t kLanes>
Batch::Status Batch::run_lanes(ExecContext& c) {
    const Module::Impl& m = c.module;
    const std::uint32_t L = kLanes != 0 ? kLanes : lanes_;
    const std::uint32_t* const words = m.words.data();
    std::uint32_t* const regs = regs_.data();
    // A register's words, lane by lane: component j of lane l is R(id)[j * L + l].
    const auto R = [&](std::uint32_t id) -> std::uint32_t* { return regs + static_cast<std::size_t>(m.reg[id]) * L; };
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
    // The integer in lane `l` of a one-word register, signed or unsigned as its type says.
    const auto index_value = [&](std::uint32_t id, std::uint32_t l) -> std::int64_t {
        const std::uint32_t v = R(id)[l];
        return T(m.type_of[id]).is_signed ? static_cast<std::int64_t>(s(v)) : static_cast<std::int64_t>(v);
    };
    // The word offset of a chain of indices into a type, in lane `l`; `literal` indices are
    // the instruction's words, the others registers.
    const auto offset_of = [&](const Instr& in, std::uint32_t type_id, const std::uint32_t* index, std::uint32_t n,
                               bool literal, std::uint32_t l, std::uint32_t& result_type) -> std::uint32_t {
        std::uint32_t offset = 0;
        for (std::uint32_t k = 0; k < n; ++k) {
            const Type& t = T(type_id);
            const std::int64_t i = literal ? static_cast<std::int64_t>(index[k]) : index_value(index[k], l);
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
    // A store into memory the lanes share (ExecContext::invariant): inputs and uniforms,
    // which the validator does not let a shader write.
    const auto read_only = [&](std::uint32_t address) {
        throw Error("interpreter: a store into read-only memory at address " + std::to_string(address) + " (" + c.who + ")",
                    m.where(m.code[pc_ - 1]));
    };
    // A load or store of `size` words between registers and memory, lane by lane through
    // each lane's pointer (one contiguous copy when every lane points at the same place).
    const auto access = [&](std::uint32_t pointer, std::uint32_t size, std::uint32_t* value, bool store) {
        const std::uint32_t* p = R(pointer);
        std::uint32_t stride = 0;
        if (m.lane_invariant[pointer] || uniform(p, L)) {
            std::uint32_t* at = memory(c, p[0], size, stride);
            if (stride == 0) {
                if (store) read_only(p[0]);
                for (std::uint32_t j = 0; j < size; ++j) std::fill_n(value + j * L, L, at[j]);
            } else if (store) {
                std::copy_n(value, size * L, at);
            } else {
                std::copy_n(at, size * L, value);
            }
            return;
        }
        for (std::uint32_t l = 0; l < L; ++l) {
            std::uint32_t* at = memory(c, p[l], size, stride);
            if (stride == 0 && store) read_only(p[l]);
            // Word j of this lane: at[j * L + l], or at[j] where the lanes share it.
            const std::uint32_t step = stride ? stride : 1, lane = stride ? l : 0;
            for (std::uint32_t j = 0; j < size; ++j) {
                if (store) at[j * step + lane] = value[j * L + l];
                else value[j * L + l] = at[j * step + lane];
            }
        }
    };
    // A branch whose lanes disagree: stand before it, uncounted, for the driver to split.
    const auto diverge = [&]() {
        --pc_;
        --executed_;
        return Status::diverged;
    };

    // A resumed invocation tells its line again (a control shader's invocations take turns),
    // but not after EmitVertex() or EndPrimitive(), where the same invocation goes on.
    if (!keep_line_) observed_line_ = observed_file_ = 0;
    keep_line_ = false;
    for (;;) {
        const Instr& in = m.code[pc_];
        if (c.options.observer && c.observed_lane != kNone && in.line != 0 &&
            (in.line != observed_line_ || in.file != observed_file_)) {
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
        // The result's words times the lanes, for the component-wise operations.
        const auto count = [&]() { return N(a[0]) * L; };
        switch (op) {
            case spv::OpLabel:
                previous_label_ = label_;
                label_ = a[0];
                if (label_ == stop_label_ || label_ == exit_label_) {  // where a fragment quad's ways meet (executor.h)
                    if (m.code[pc_].op != spv::OpPhi) return Status::at_stop;
                    stopping_ = true;
                }
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
                    const std::uint32_t size = T(p[0]).words * L;
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
                if (stopping_) {
                    stopping_ = false;
                    return Status::at_stop;
                }
                break;
            }
            case spv::OpBranch: pc_ = m.label_at[a[0]]; break;
            case spv::OpBranchConditional: {
                const std::uint32_t* condition = R(a[0]);
                for (std::uint32_t l = 1; l < L; ++l)
                    if (!condition[l] != !condition[0]) return diverge();
                pc_ = m.label_at[condition[0] ? a[1] : a[2]];
                break;
            }
            case spv::OpSwitch: {
                const std::uint32_t* selector = R(a[0]);
                if (!uniform(selector, L)) return diverge();
                std::uint32_t target = a[1];
                for (std::uint32_t j = 2; j + 1 < in.count; j += 2)
                    if (a[j] == selector[0]) {
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
                if (op == spv::OpReturnValue) std::copy_n(R(a[0]), T(m.type_of[frame.result]).words * L, R(frame.result));
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
                    std::copy_n(R(a[3 + j]), T(m.type_of[param]).words * L, R(param));
                }
                stack_.push_back(Frame{pc_, a[1], label_});
                pc_ = callee.first;
                break;
            }
            case spv::OpControlBarrier: return Status::barrier;
            // The geometry driver (geometry.cpp) reads the outputs and runs the batch on.
            case spv::OpEmitVertex: keep_line_ = true; return Status::emit;
            case spv::OpEndPrimitive: keep_line_ = true; return Status::end_primitive;
            case spv::OpVariable:
                if (in.count > 3) access(a[1], T(T(a[0]).element).words, R(a[3]), true);
                break;
            case spv::OpLoad: access(a[2], T(a[0]).words, R(a[1]), false); break;
            case spv::OpStore: {
                const std::uint32_t size = T(T(m.type_of[a[0]]).element).words;
                access(a[0], size, R(a[1]), true);
                if (c.options.observer && c.observed_lane != kNone)
                    observe_store(c, R(a[0])[c.observed_lane], a[1], size);
                break;
            }
            case spv::OpCopyMemory: {
                const std::uint32_t size = T(T(m.type_of[a[0]]).element).words;
                std::vector<std::uint32_t> v(static_cast<std::size_t>(size) * L);
                const std::uint32_t* from = R(a[1]);
                const std::uint32_t* to = R(a[0]);
                for (std::uint32_t l = 0; l < L; ++l) {
                    std::uint32_t from_stride = 0, to_stride = 0;
                    const std::uint32_t* source = memory(c, from[l], size, from_stride);
                    std::uint32_t* target = memory(c, to[l], size, to_stride);
                    if (to_stride == 0) read_only(to[l]);
                    for (std::uint32_t j = 0; j < size; ++j) v[j] = from_stride ? source[j * from_stride + l] : source[j];
                    for (std::uint32_t j = 0; j < size; ++j) target[j * L + l] = v[j];
                }
                break;
            }
            case spv::OpAccessChain:
            case spv::OpInBoundsAccessChain: {
                // One walk through the type when the indices are the same in every lane
                // (constants, uniforms), else one per lane.
                const std::uint32_t n = in.count - 3u;
                bool same = true;
                for (std::uint32_t k = 0; k < n && same; ++k) same = m.lane_invariant[a[3 + k]] || uniform(R(a[3 + k]), L);
                const std::uint32_t* base = R(a[2]);
                std::uint32_t* out = R(a[1]);
                std::uint32_t result_type = 0;
                const std::uint32_t pointee = T(m.type_of[a[2]]).element;
                if (same) {
                    const std::uint32_t offset = offset_of(in, pointee, a + 3, n, false, 0, result_type);
                    for (std::uint32_t l = 0; l < L; ++l) out[l] = base[l] + offset;
                } else {
                    for (std::uint32_t l = 0; l < L; ++l) out[l] = base[l] + offset_of(in, pointee, a + 3, n, false, l, result_type);
                }
                break;
            }
            case spv::OpCopyObject:
            case spv::OpCopyLogical: std::copy_n(R(a[2]), T(a[0]).words * L, R(a[1])); break;
            case spv::OpCompositeConstruct: {
                std::uint32_t* out = R(a[1]);
                const std::uint32_t size = T(a[0]).words;
                std::uint32_t at = 0;
                for (std::uint32_t j = 2; j < in.count; ++j) {
                    const std::uint32_t part = T(m.type_of[a[j]]).words;
                    if (at + part > size) throw Error("OpCompositeConstruct larger than its type", m.where(in));
                    std::copy_n(R(a[j]), part * L, out + at * L);
                    at += part;
                }
                break;
            }
            case spv::OpCompositeExtract: {
                std::uint32_t result_type = 0;
                const std::uint32_t offset = offset_of(in, m.type_of[a[2]], a + 3, in.count - 3u, true, 0, result_type);
                std::copy_n(R(a[2]) + offset * L, T(a[0]).words * L, R(a[1]));
                break;
            }
            case spv::OpCompositeInsert: {
                std::uint32_t result_type = 0;
                const std::uint32_t offset = offset_of(in, a[0], a + 4, in.count - 4u, true, 0, result_type);
                std::uint32_t* out = R(a[1]);
                std::copy_n(R(a[3]), T(a[0]).words * L, out);
                std::copy_n(R(a[2]), T(result_type).words * L, out + offset * L);
                break;
            }
            case spv::OpVectorShuffle: {
                const std::uint32_t n1 = N(m.type_of[a[2]]), n2 = N(m.type_of[a[3]]);
                std::uint32_t* out = R(a[1]);
                for (std::uint32_t j = 4; j < in.count; ++j) {
                    std::uint32_t* to = out + (j - 4) * L;
                    if (a[j] == 0xffffffffu) {
                        std::fill_n(to, L, 0u);
                        continue;
                    }
                    const std::uint32_t k = std::min(a[j], n1 + n2 - 1);
                    std::copy_n(k < n1 ? R(a[2]) + k * L : R(a[3]) + (k - n1) * L, L, to);
                }
                break;
            }
            case spv::OpVectorExtractDynamic: {
                const std::uint32_t n = T(m.type_of[a[2]]).count;
                const std::uint32_t* v = R(a[2]);
                std::uint32_t* out = R(a[1]);
                for (std::uint32_t l = 0; l < L; ++l) out[l] = v[clamp_index(in, index_value(a[3], l), n) * L + l];
                break;
            }
            case spv::OpVectorInsertDynamic: {
                const std::uint32_t n = T(a[0]).count;
                std::uint32_t* out = R(a[1]);
                std::copy_n(R(a[2]), n * L, out);
                for (std::uint32_t l = 0; l < L; ++l) out[clamp_index(in, index_value(a[4], l), n) * L + l] = R(a[3])[l];
                break;
            }
            case spv::OpSelect: {
                const std::uint32_t size = T(a[0]).words;
                const bool per_component = T(m.type_of[a[2]]).kind == Kind::vector;
                std::uint32_t* out = R(a[1]);
                const std::uint32_t* cond = R(a[2]);
                const std::uint32_t* x = R(a[3]);
                const std::uint32_t* y = R(a[4]);
                for (std::uint32_t j = 0; j < size; ++j)
                    for (std::uint32_t l = 0; l < L; ++l) {
                        const std::uint32_t k = j * L + l;
                        out[k] = cond[per_component ? k : l] ? x[k] : y[k];
                    }
                break;
            }

            // ---- float arithmetic, each operation rounded on its own ---------------------
            case spv::OpFAdd: each2(R(a[1]), R(a[2]), R(a[3]), count(), [](std::uint32_t p, std::uint32_t q) { return w(f(p) + f(q)); }); break;
            case spv::OpFSub: each2(R(a[1]), R(a[2]), R(a[3]), count(), [](std::uint32_t p, std::uint32_t q) { return w(f(p) - f(q)); }); break;
            case spv::OpFMul: each2(R(a[1]), R(a[2]), R(a[3]), count(), [](std::uint32_t p, std::uint32_t q) { return w(f(p) * f(q)); }); break;
            case spv::OpFDiv: each2(R(a[1]), R(a[2]), R(a[3]), count(), [](std::uint32_t p, std::uint32_t q) { return w(f(p) / f(q)); }); break;
            // GLSL mod(x, y) = x - y * floor(x / y); OpFRem x - y * trunc(x / y); each step rounded.
            case spv::OpFMod:
                each2(R(a[1]), R(a[2]), R(a[3]), count(), [](std::uint32_t p, std::uint32_t q) {
                    const float floored = std::floor(f(p) / f(q)), product = f(q) * floored;
                    return w(f(p) - product);
                });
                break;
            case spv::OpFRem:
                each2(R(a[1]), R(a[2]), R(a[3]), count(), [](std::uint32_t p, std::uint32_t q) {
                    const float truncated = std::trunc(f(p) / f(q)), product = f(q) * truncated;
                    return w(f(p) - product);
                });
                break;
            case spv::OpFNegate: each1(R(a[1]), R(a[2]), count(), [](std::uint32_t p) { return p ^ 0x80000000u; }); break;
            case spv::OpVectorTimesScalar:
            case spv::OpMatrixTimesScalar: {
                const std::uint32_t size = T(a[0]).words;
                const std::uint32_t* x = R(a[2]);
                const std::uint32_t* k = R(a[3]);
                std::uint32_t* out = R(a[1]);
                for (std::uint32_t j = 0; j < size; ++j)
                    for (std::uint32_t l = 0; l < L; ++l) out[j * L + l] = w(f(x[j * L + l]) * f(k[l]));
                break;
            }
            case spv::OpDot: {
                // Every product and sum rounded, in the math mode's order (std450.h).
                const std::uint32_t n = N(m.type_of[a[2]]);
                const std::uint32_t* x = R(a[2]);
                const std::uint32_t* y = R(a[3]);
                std::uint32_t* out = R(a[1]);
                for (std::uint32_t l = 0; l < L; ++l) out[l] = w(dot_product(x + l, y + l, n, L, c.options.math));
                break;
            }
            case spv::OpMatrixTimesVector:
            case spv::OpMatrixTimesMatrix:
            case spv::OpVectorTimesMatrix: {
                // Left operand's columns (rows of the result) times the right operand's
                // columns; column k of the result = sum over j of left column j * right[k][j],
                // in GLM's order in exact mode (shader.h): four columns pairwise, else from
                // j = 0 on; in llvmpipe mode from j = 0 on always, as GLSL's compiler writes
                // it. v * M is a dot product per column (dot_product's order).
                const Type& lt = T(m.type_of[a[2]]);
                const Type& rt = T(m.type_of[a[3]]);
                const std::uint32_t* l_ = R(a[2]);
                const std::uint32_t* r_ = R(a[3]);
                std::uint32_t* out = R(a[1]);
                const bool pairwise = c.options.math == MathMode::exact;
                if (op == spv::OpVectorTimesMatrix) {
                    // v * M: result[k] = dot(v, M column k), summed from the first component.
                    const std::uint32_t rows = lt.count;
                    for (std::uint32_t lane = 0; lane < L; ++lane)
                        for (std::uint32_t k = 0; k < rt.count; ++k)
                            out[k * L + lane] = w(dot_product(l_ + lane, r_ + k * rows * L + lane, rows, L, c.options.math));
                    break;
                }
                // Row i of result column k, over all lanes at once (the lanes innermost, where
                // the compiler vectorises): left[j][i] is row (j * rows + i), right[k][j] row
                // (k * columns + j), each a row of L lanes.
                const std::uint32_t rows = T(lt.element).count;  // the left matrix's column size
                const std::uint32_t columns = lt.count;
                const std::uint32_t results = op == spv::OpMatrixTimesVector ? 1 : rt.count;
                const auto row = [&](const std::uint32_t* base, std::uint32_t j) { return base + static_cast<std::size_t>(j) * L; };
                for (std::uint32_t k = 0; k < results; ++k) {
                    const std::uint32_t v = k * columns;
                    for (std::uint32_t i = 0; i < rows; ++i) {
                        std::uint32_t* __restrict sum = out + static_cast<std::size_t>(k * rows + i) * L;
                        if (columns == 4 && pairwise) {
                            const std::uint32_t* __restrict l0 = row(l_, i);
                            const std::uint32_t* __restrict l1 = row(l_, rows + i);
                            const std::uint32_t* __restrict l2 = row(l_, 2 * rows + i);
                            const std::uint32_t* __restrict l3 = row(l_, 3 * rows + i);
                            const std::uint32_t* __restrict r0 = row(r_, v);
                            const std::uint32_t* __restrict r1 = row(r_, v + 1);
                            const std::uint32_t* __restrict r2 = row(r_, v + 2);
                            const std::uint32_t* __restrict r3 = row(r_, v + 3);
                            for (std::uint32_t lane = 0; lane < L; ++lane) {
                                const float p0 = f(l0[lane]) * f(r0[lane]), p1 = f(l1[lane]) * f(r1[lane]);
                                const float p2 = f(l2[lane]) * f(r2[lane]), p3 = f(l3[lane]) * f(r3[lane]);
                                const float s01 = p0 + p1, s23 = p2 + p3;
                                sum[lane] = w(s01 + s23);
                            }
                            continue;
                        }
                        for (std::uint32_t j = 0; j < columns; ++j) {
                            const std::uint32_t* __restrict lj = row(l_, j * rows + i);
                            const std::uint32_t* __restrict rj = row(r_, v + j);
                            for (std::uint32_t lane = 0; lane < L; ++lane) {
                                const float product = f(lj[lane]) * f(rj[lane]);
                                sum[lane] = w(j == 0 ? product : f(sum[lane]) + product);
                            }
                        }
                    }
                }
                break;
            }
            case spv::OpOuterProduct: {
                const std::uint32_t rows = N(m.type_of[a[2]]), columns = N(m.type_of[a[3]]);
                const std::uint32_t* x = R(a[2]);
                const std::uint32_t* y = R(a[3]);
                std::uint32_t* out = R(a[1]);
                for (std::uint32_t k = 0; k < columns; ++k)
                    for (std::uint32_t i = 0; i < rows; ++i)
                        each2(out + (k * rows + i) * L, x + i * L, y + k * L, L,
                              [](std::uint32_t p, std::uint32_t q) { return w(f(p) * f(q)); });
                break;
            }
            case spv::OpTranspose: {
                const Type& rt = T(a[0]);
                const std::uint32_t columns = rt.count, rows = T(rt.element).count;
                for (std::uint32_t k = 0; k < columns; ++k)
                    for (std::uint32_t i = 0; i < rows; ++i) std::copy_n(R(a[2]) + (i * columns + k) * L, L, R(a[1]) + (k * rows + i) * L);
                break;
            }

            // ---- integers: two's complement, wrapping ------------------------------------
#define TESSREF_INT_BINARY(OP, EXPR) \
    case spv::OP: each2(R(a[1]), R(a[2]), R(a[3]), count(), [](std::uint32_t p, std::uint32_t q) -> std::uint32_t { return (EXPR); }); break;
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
                bool by_zero = false;
                each2(R(a[1]), R(a[2]), R(a[3]), count(), [&](std::uint32_t p, std::uint32_t q) -> std::uint32_t {
                    if (q == 0) {
                        by_zero = true;
                        return (op == spv::OpSDiv || op == spv::OpUDiv) ? 0xffffffffu : p;
                    }
                    if (op == spv::OpUDiv) return p / q;
                    if (op == spv::OpUMod) return p % q;
                    if (s(p) == std::numeric_limits<std::int32_t>::min() && s(q) == -1)
                        return op == spv::OpSDiv ? p : 0u;  // INT_MIN / -1 wraps; the remainder is 0
                    if (op == spv::OpSDiv) return static_cast<std::uint32_t>(s(p) / s(q));
                    std::int32_t rem = s(p) % s(q);  // the sign of p (OpSRem)
                    if (op == spv::OpSMod && rem != 0 && ((rem < 0) != (s(q) < 0))) rem += s(q);  // the sign of q
                    return static_cast<std::uint32_t>(rem);
                });
                if (by_zero)
                    warn(in, std::string("warning: integer ") + (op == spv::OpSDiv || op == spv::OpUDiv ? "division" : "remainder") +
                                 " by zero (" + opcode_name(op) + "), result " +
                                 (op == spv::OpSDiv || op == spv::OpUDiv ? "all ones" : "the dividend"));
                break;
            }
            case spv::OpSNegate: each1(R(a[1]), R(a[2]), count(), [](std::uint32_t p) { return 0u - p; }); break;
            case spv::OpNot: each1(R(a[1]), R(a[2]), count(), [](std::uint32_t p) { return ~p; }); break;
            case spv::OpLogicalNot: each1(R(a[1]), R(a[2]), count(), [](std::uint32_t p) { return p ? 0u : 1u; }); break;
            case spv::OpBitCount:
                each1(R(a[1]), R(a[2]), count(), [](std::uint32_t p) { return static_cast<std::uint32_t>(std::popcount(p)); });
                break;
            case spv::OpAny:
            case spv::OpAll: {
                const std::uint32_t n = N(m.type_of[a[2]]);
                const std::uint32_t* x = R(a[2]);
                std::uint32_t* out = R(a[1]);
                for (std::uint32_t l = 0; l < L; ++l) {
                    bool any = false, all = true;
                    for (std::uint32_t j = 0; j < n; ++j) {
                        any = any || x[j * L + l];
                        all = all && x[j * L + l];
                    }
                    out[l] = (op == spv::OpAny ? any : all) ? 1u : 0u;
                }
                break;
            }

            // ---- float comparisons (Ord: false with a NaN; Unord: true) -------------------
#define TESSREF_FLOAT_COMPARE(OP, EXPR, UNORDERED)                                                               \
    case spv::OP:                                                                                                \
        each2(R(a[1]), R(a[2]), R(a[3]), count(), [](std::uint32_t p, std::uint32_t q) {                         \
            return ordered(p, q, UNORDERED, [](float x, float y) { return EXPR; });                              \
        });                                                                                                      \
        break;
            TESSREF_FLOAT_COMPARE(OpFOrdEqual, x == y, 0u)
            TESSREF_FLOAT_COMPARE(OpFOrdNotEqual, x != y, 0u)
            TESSREF_FLOAT_COMPARE(OpFOrdLessThan, x < y, 0u)
            TESSREF_FLOAT_COMPARE(OpFOrdGreaterThan, x > y, 0u)
            TESSREF_FLOAT_COMPARE(OpFOrdLessThanEqual, x <= y, 0u)
            TESSREF_FLOAT_COMPARE(OpFOrdGreaterThanEqual, x >= y, 0u)
            TESSREF_FLOAT_COMPARE(OpFUnordEqual, x == y, 1u)
            TESSREF_FLOAT_COMPARE(OpFUnordNotEqual, x != y, 1u)
            TESSREF_FLOAT_COMPARE(OpFUnordLessThan, x < y, 1u)
            TESSREF_FLOAT_COMPARE(OpFUnordGreaterThan, x > y, 1u)
            TESSREF_FLOAT_COMPARE(OpFUnordLessThanEqual, x <= y, 1u)
            TESSREF_FLOAT_COMPARE(OpFUnordGreaterThanEqual, x >= y, 1u)
#undef TESSREF_FLOAT_COMPARE
            case spv::OpIsNan: each1(R(a[1]), R(a[2]), count(), [](std::uint32_t p) { return std::isnan(f(p)) ? 1u : 0u; }); break;
            case spv::OpIsInf: each1(R(a[1]), R(a[2]), count(), [](std::uint32_t p) { return std::isinf(f(p)) ? 1u : 0u; }); break;

            // ---- conversions ---------------------------------------------------------------
            case spv::OpConvertFToS:
            case spv::OpConvertFToU: {
                bool undefined = false;
                each1(R(a[1]), R(a[2]), count(), [&](std::uint32_t p) {
                    return op == spv::OpConvertFToS ? to_signed(f(p), undefined) : to_unsigned(f(p), undefined);
                });
                if (undefined) warn(in, "warning: float to integer conversion of NaN or out of range, result saturated (NaN: 0)");
                break;
            }
            case spv::OpConvertSToF: each1(R(a[1]), R(a[2]), count(), [](std::uint32_t p) { return w(static_cast<float>(s(p))); }); break;
            case spv::OpConvertUToF: each1(R(a[1]), R(a[2]), count(), [](std::uint32_t p) { return w(static_cast<float>(p)); }); break;
            case spv::OpBitcast:
            case spv::OpSConvert:
            case spv::OpUConvert:
            case spv::OpFConvert: std::copy_n(R(a[2]), T(a[0]).words * L, R(a[1])); break;

            // ---- GLSL.std.450 ---------------------------------------------------------------
            case spv::OpExtInst: {
                if (a[2] != m.std450) unsupported(in, "an extended instruction set other than GLSL.std.450");
                Std450Args args;
                args.count = std::min<std::uint32_t>(in.count - 4u, 3);
                args.stride = L;
                for (std::uint32_t j = 0; j < args.count; ++j) {
                    const std::uint32_t id = a[4 + j];
                    const Type& t = T(m.type_of[id]);
                    args.components[j] = t.kind == Kind::vector ? t.count : 1;
                    args.scalar[j] = t.scalar;
                }
                const Type& rt = T(a[0]);
                for (std::uint32_t j = 0; j < args.count; ++j) args.value[j] = R(a[4 + j]);
                if (!run_std450(a[3], c.options.math, rt.scalar, rt.kind == Kind::vector ? rt.count : 1, args, L, R(a[1])))
                    unsupported(in, std450_name(a[3]));
                break;
            }

            // ---- textures --------------------------------------------------------------------
            case spv::OpSampledImage:
            case spv::OpImage: std::copy_n(R(a[2]), L, R(a[1])); break;
            case spv::OpImageSampleImplicitLod:
            case spv::OpImageSampleExplicitLod: {
                const std::uint32_t* unit = R(a[2]);
                const std::uint32_t* st = R(a[3]);
                std::uint32_t* out = R(a[1]);
                const bool with_lod = in.count > 4 && (a[4] & spv::ImageOperandsLodMask);
                // textureGrad(): each fragment's own gradients (as given: for gradients that
                // are the quad's derivatives, as pom.frag passes, one lod for the quad).
                const bool with_grad = in.count > 6 && (a[4] & spv::ImageOperandsGradMask);
                if (in.count > 4 && (a[4] & ~static_cast<std::uint32_t>(spv::ImageOperandsLodMask | spv::ImageOperandsGradMask)))
                    unsupported(in, "image operands other than Lod and Grad (bias, offsets)");
                const std::uint32_t* lod = with_lod ? R(a[5]) : nullptr;
                const std::uint32_t* grad_x = with_grad ? R(a[5]) : nullptr;
                const std::uint32_t* grad_y = with_grad ? R(a[6]) : nullptr;
                // texture() in a fragment quad: the lod from the quad's derivatives of the
                // coordinate, one for the quad, as llvmpipe takes them (from the top-left
                // fragment: right minus it, it minus the one below), each fragment sampled at
                // its own coordinate. Elsewhere no derivatives: the implicit lod is 0.
                const bool quad_lod = op == spv::OpImageSampleImplicitLod && c.quad && L == 4;
                if (op == spv::OpImageSampleImplicitLod && m.stage == ShaderStage::fragment && !quad_lod)
                    warn(in, "warning: texture() in a fragment batch that a branch parted from its quad: no "
                             "derivatives (undefined in GLSL), lod 0");
                const glm::vec2 dPdx = quad_lod ? glm::vec2(f(st[1]) - f(st[0]), f(st[L + 1]) - f(st[L])) : glm::vec2(0.0f);
                const glm::vec2 dPdy = quad_lod ? glm::vec2(f(st[0]) - f(st[2]), f(st[L]) - f(st[L + 2])) : glm::vec2(0.0f);
                for (std::uint32_t l = 0; l < L; ++l) {
                    const Texture* texture = unit[l] < c.units.size() ? c.units[unit[l]] : nullptr;
                    glm::vec4 v(0.0f, 0.0f, 0.0f, 1.0f);  // no texture at the unit: GL's incomplete texture
                    if (texture) {
                        const glm::vec2 coordinate(f(st[l]), f(st[L + l]));
                        if (quad_lod) v = textureGrad(texture, coordinate, dPdx, dPdy);
                        else if (with_grad)
                            v = textureGrad(texture, coordinate, glm::vec2(f(grad_x[l]), f(grad_x[L + l])),
                                            glm::vec2(f(grad_y[l]), f(grad_y[L + l])));
                        else v = op == spv::OpImageSampleImplicitLod ? texture->texture(coordinate)
                                                                     : texture->textureLod(coordinate, lod ? f(lod[l]) : 0.0f);
                    }
                    for (std::uint32_t j = 0; j < 4; ++j) out[j * L + l] = w(v[static_cast<int>(j)]);
                }
                break;
            }
            case spv::OpImageQuerySizeLod: {
                for (std::uint32_t l = 0; l < L; ++l) {
                    const std::uint32_t unit = R(a[2])[l];
                    const Texture* texture = unit < c.units.size() ? c.units[unit] : nullptr;
                    if (!texture) throw Error("no texture is bound to unit " + std::to_string(unit), m.where(in));
                    const std::uint32_t lod =
                        std::min<std::uint32_t>(R(a[3])[l], static_cast<std::uint32_t>(texture->level_count() - 1));
                    R(a[1])[l] = static_cast<std::uint32_t>(texture->level(static_cast<int>(lod)).width);
                    R(a[1])[L + l] = static_cast<std::uint32_t>(texture->level(static_cast<int>(lod)).height);
                }
                break;
            }

            // ---- derivatives across a fragment quad (ExecContext::quad), as llvmpipe -------
            // Lanes: 0 top-left, 1 top-right, 2 bottom-left, 3 bottom-right. dFdx is per row
            // (right minus left), dFdy per column (top minus bottom: window y grows upwards);
            // llvmpipe computes the Fine and Coarse forms as these (lp_build_ddx/ddy for all
            // three), and fwidth as abs(dFdx) + abs(dFdy).
            case spv::OpDPdx:
            case spv::OpDPdxFine:
            case spv::OpDPdxCoarse:
            case spv::OpDPdy:
            case spv::OpDPdyFine:
            case spv::OpDPdyCoarse:
            case spv::OpFwidth:
            case spv::OpFwidthFine:
            case spv::OpFwidthCoarse: {
                const std::uint32_t n = N(a[0]);
                std::uint32_t* out = R(a[1]);
                const std::uint32_t* x = R(a[2]);
                if (!c.quad || L != 4) {
                    warn(in, "warning: " + opcode_name(in.op) + " outside a whole 2x2 fragment quad (a branch parted "
                             "its lanes, or not a fragment shader; undefined in GLSL): 0");
                    std::fill_n(out, n * L, 0u);
                    break;
                }
                const bool dx = op == spv::OpDPdx || op == spv::OpDPdxFine || op == spv::OpDPdxCoarse;
                const bool dy = op == spv::OpDPdy || op == spv::OpDPdyFine || op == spv::OpDPdyCoarse;
                for (std::uint32_t j = 0; j < n; ++j) {
                    const std::uint32_t* v = x + j * 4;
                    const float top = f(v[1]) - f(v[0]), bottom = f(v[3]) - f(v[2]);
                    const float left = f(v[0]) - f(v[2]), right = f(v[1]) - f(v[3]);
                    const float ddx[4] = {top, top, bottom, bottom}, ddy[4] = {left, right, left, right};
                    for (std::uint32_t l = 0; l < 4; ++l)
                        out[j * 4 + l] = w(dx ? ddx[l] : dy ? ddy[l] : std::fabs(ddx[l]) + std::fabs(ddy[l]));
                }
                break;
            }
            default:
                // A chain Mesa's GLSL compiler rebalances (rebalance.h): in llvmpipe math in
                // its order, else as written. Here, out of the switch's way of every other
                // instruction.
                if (in.op == kOpChain) {
                    const Chain& chain = m.chains[in.at];
                    const std::uint32_t n = chain.components * L;
                    const auto& steps = c.options.math == MathMode::llvmpipe ? chain.llvmpipe : chain.as_written;
                    for (const auto& [result, left, right] : steps) {
                        if (chain.op == spv::OpFAdd)
                            each2(R(result), R(left), R(right), n, [](std::uint32_t p, std::uint32_t q) { return w(f(p) + f(q)); });
                        else
                            each2(R(result), R(left), R(right), n, [](std::uint32_t p, std::uint32_t q) { return w(f(p) * f(q)); });
                    }
                    break;
                }
                unsupported(in, opcode_name(in.op));
        }
    }
}

}  // namespace tessref::shader
