// Loading a SPIR-V module into the interpreter's tables: see module.h.
#define SPV_ENABLE_UTILITY_CODE
#include "shader/module.h"

#include <algorithm>
#include <cstring>

#include <glslang/SPIRV/GLSL.std.450.h>
#include <glslang/SPIRV/spirv.hpp>
#include <spirv-tools/libspirv.hpp>

#include "shader/rebalance.h"

namespace tessref::shader {

// The names come from SPIRV-Tools, not from glslang's SPIRV/doc.cpp: linking that file
// costs every tessref process a 7 MB table that its static constructors build at start-up
// (about 4 ms, more than half of `tessref --version`), for three names in error messages.
std::string opcode_name(std::uint32_t op) {
    const char* name = spvOpcodeString(op);  // without its "Op"; "unknown" for no opcode
    if (name && std::strcmp(name, "unknown") != 0) return std::string("Op") + name;
    return "opcode " + std::to_string(op);
}

namespace {

// The spelling of an operand of `OpCapability value` (kind capability) or of `OpEntryPoint
// value %1 "main"` (kind execution model) as SPIRV-Tools' disassembler writes it: the
// public API has no name lookup for operands, and this runs only on the way to an error.
// The number where the disassembler knows no such value.
std::string operand_name(spv::Op op, std::uint32_t value) {
    std::vector<std::uint32_t> words = {spv::MagicNumber, 0x00010000u, 0, 2, 0};
    if (op == spv::OpCapability) {
        words.insert(words.end(), {2u << 16 | spv::OpCapability, value});
    } else {
        std::uint32_t main_name = 0;  // "main" and its terminating NUL: two words
        std::memcpy(&main_name, "main", 4);
        words.insert(words.end(), {5u << 16 | spv::OpEntryPoint, value, 1, main_name, 0});
    }
    std::string text;
    spvtools::SpirvTools tools(SPV_ENV_UNIVERSAL_1_6);
    tools.SetMessageConsumer([](spv_message_level_t, const char*, const spv_position_t&, const char*) {});
    const std::string instruction = op == spv::OpCapability ? "OpCapability " : "OpEntryPoint ";
    if (tools.Disassemble(words, &text, SPV_BINARY_TO_TEXT_OPTION_NO_HEADER)) {
        const std::size_t at = text.find(instruction);
        if (at != std::string::npos) {
            const std::size_t begin = at + instruction.size();
            const std::size_t end = text.find_first_of(" \n", begin);
            if (end > begin) return text.substr(begin, end - begin);
        }
    }
    return std::to_string(value);
}

}  // namespace

Where Module::Impl::where(const Instr& instr) const {
    const auto file = strings.find(instr.file);
    return Where::in_file(file != strings.end() ? file->second : path, instr.line);
}

std::string Module::Impl::where_text(const Instr& instr) const { return where(instr).str(); }

namespace {

struct Decorations {
    int builtin = -1;
    int location = -1;
    int binding = -1;
    bool patch = false;
    std::map<std::uint32_t, int> member_builtin;
    std::map<std::uint32_t, int> member_location;
};

std::string literal_string(const std::uint32_t* w, std::size_t count) {
    std::string s(reinterpret_cast<const char*>(w), count * 4);
    return s.substr(0, s.find('\0'));
}

Type type_of_kind(Kind kind) {
    Type t;
    t.kind = kind;
    return t;
}

class Loader {
public:
    Loader(Module::Impl& m) : m_(m) {}

    void load() {
        const std::vector<std::uint32_t>& w = m_.words;
        if (w.size() < 5 || w[0] != spv::MagicNumber) fail("not a SPIR-V binary (no magic number)");
        m_.bound = w[3];
        if (m_.bound > (1u << 22)) fail("SPIR-V id bound " + std::to_string(m_.bound) + " is too large");
        m_.types.resize(m_.bound);
        m_.type_of.assign(m_.bound, 0);
        m_.reg.assign(m_.bound, kNone);
        m_.names.resize(m_.bound);
        m_.label_at.assign(m_.bound, kNone);
        m_.variable_of.assign(m_.bound, kNone);
        std::uint32_t line = 0, file = 0;
        Function* function = nullptr;
        std::uint32_t function_id = 0;
        for (std::size_t pos = 5; pos < w.size();) {
            const std::uint32_t op = w[pos] & 0xffff, n = w[pos] >> 16;
            if (n == 0 || pos + n > w.size()) fail("a truncated instruction at word " + std::to_string(pos));
            Instr in;
            in.op = static_cast<std::uint16_t>(op);
            in.count = static_cast<std::uint16_t>(n - 1);
            in.at = static_cast<std::uint32_t>(pos + 1);
            in.line = line;
            in.file = file;
            const std::uint32_t* a = &w[pos + 1];
            pos += n;
            switch (static_cast<spv::Op>(op)) {
                case spv::OpLine: file = a[0]; line = a[1]; continue;
                case spv::OpNoLine: line = 0; continue;
                default: break;
            }
            current_ = in;
            if (function) {
                if (op == spv::OpFunctionEnd) {
                    function = nullptr;
                    line = 0;
                    continue;
                }
                if (op == spv::OpFunctionParameter) {
                    function->params.push_back(a[1]);
                    value(a[0], a[1]);
                    continue;
                }
                if (op == spv::OpLabel) {
                    m_.label_at[check_id(a[0])] = static_cast<std::uint32_t>(m_.code.size());
                    if (function->first == kNone) function->first = static_cast<std::uint32_t>(m_.code.size());
                } else if (op == spv::OpVariable) {
                    variable(a[0], a[1], a[2], in.count > 3 ? a[3] : 0);
                } else if (op == spv::OpUndef) {
                    value(a[0], a[1]);
                    continue;
                } else {
                    bool has_result = false, has_type = false;
                    spv::HasResultAndType(static_cast<spv::Op>(op), &has_result, &has_type);
                    if (has_result && has_type) value(a[0], a[1]);
                    else if (has_result) check_id(a[0]);
                }
                m_.code.push_back(in);
                continue;
            }
            global(in, a, function, function_id);
        }
        if (function) fail("a function without OpFunctionEnd");
        if (!m_.entry) fail("no entry point");
        finish_variables();
        find_lane_invariants();
        find_rebalanced_chains(m_);
    }

private:
    Module::Impl& m_;
    Instr current_;
    std::vector<Decorations> decorations_;
    std::vector<std::uint32_t> execution_model_;

    [[noreturn]] void fail(const std::string& what) const {
        throw Error("SPIR-V module: " + what, current_.line ? m_.where(current_) : Where::in_file(m_.path));
    }
    std::uint32_t check_id(std::uint32_t id) const {
        if (id == 0 || id >= m_.bound) fail("id " + std::to_string(id) + " is outside the module's bound");
        return id;
    }
    Decorations& deco(std::uint32_t id) {
        if (decorations_.size() < m_.bound) decorations_.resize(m_.bound);
        return decorations_[check_id(id)];
    }
    const Type& type(std::uint32_t id) const {
        const Type& t = m_.types[check_id(id)];
        if (t.kind == Kind::none) fail("id " + std::to_string(id) + " is not a type");
        return t;
    }
    // A value of type `type_id` at id: its register.
    void value(std::uint32_t type_id, std::uint32_t id) {
        const Type& t = type(type_id);
        check_id(id);
        m_.type_of[id] = type_id;
        if (m_.reg[id] != kNone) return;
        m_.reg[id] = static_cast<std::uint32_t>(m_.reg_init.size());
        m_.reg_init.resize(m_.reg_init.size() + std::max<std::uint32_t>(t.words, 1), 0);
    }
    std::uint32_t constant_u32(std::uint32_t id) const {
        if (m_.reg[check_id(id)] == kNone) fail("id " + std::to_string(id) + " is not a constant");
        return m_.reg_init[m_.reg[id]];
    }
    void variable(std::uint32_t pointer_type, std::uint32_t id, std::uint32_t storage, std::uint32_t init) {
        const Type& p = type(pointer_type);
        if (p.kind != Kind::pointer) fail("OpVariable of a non-pointer type");
        value(pointer_type, id);
        Variable v;
        v.id = id;
        v.type = p.element;
        v.storage = storage;
        v.init = init;
        v.name = m_.names[id];
        m_.variable_of[id] = static_cast<std::uint32_t>(m_.variables.size());
        m_.variables.push_back(std::move(v));
    }

    void add_type(std::uint32_t id, Type t) {
        check_id(id);
        m_.types[id] = std::move(t);
    }

    void global(const Instr& in, const std::uint32_t* a, Function*& function, std::uint32_t& function_id) {
        const spv::Op op = static_cast<spv::Op>(in.op);
        const std::uint32_t n = in.count;
        switch (op) {
            case spv::OpNop:
            case spv::OpSource:
            case spv::OpSourceContinued:
            case spv::OpSourceExtension:
            case spv::OpModuleProcessed:
            case spv::OpMemoryModel:
            case spv::OpDecorationGroup:
            case spv::OpExtension:
                return;
            case spv::OpCapability: {
                switch (static_cast<spv::Capability>(a[0])) {
                    case spv::CapabilityMatrix:
                    case spv::CapabilityShader:
                    case spv::CapabilityTessellation:
                    case spv::CapabilityGeometry:
                    case spv::CapabilityClipDistance:
                    case spv::CapabilityCullDistance:
                    case spv::CapabilityTessellationPointSize:
                    case spv::CapabilityGeometryPointSize:
                    case spv::CapabilityImageQuery:
                    case spv::CapabilitySampled1D:
                    case spv::CapabilityDerivativeControl:
                        return;
                    default:
                        fail(std::string("capability ") + operand_name(spv::OpCapability, a[0]) +
                             " is not supported by the interpreter");
                }
            }
            case spv::OpExtInstImport:
                if (literal_string(a + 1, n - 1) != "GLSL.std.450")
                    fail("extended instruction set " + literal_string(a + 1, n - 1) + " is not supported");
                m_.std450 = check_id(a[0]);
                return;
            case spv::OpString: m_.strings[check_id(a[0])] = literal_string(a + 1, n - 1); return;
            case spv::OpName: m_.names[check_id(a[0])] = literal_string(a + 1, n - 1); return;
            case spv::OpMemberName: return;
            case spv::OpEntryPoint: {
                if (m_.entry) fail("more than one entry point");
                m_.entry = check_id(a[1]);
                switch (static_cast<spv::ExecutionModel>(a[0])) {
                    case spv::ExecutionModelVertex: m_.stage = ShaderStage::vertex; break;
                    case spv::ExecutionModelTessellationControl: m_.stage = ShaderStage::tess_control; break;
                    case spv::ExecutionModelTessellationEvaluation: m_.stage = ShaderStage::tess_evaluation; break;
                    case spv::ExecutionModelGeometry: m_.stage = ShaderStage::geometry; break;
                    case spv::ExecutionModelFragment: m_.stage = ShaderStage::fragment; break;
                    default:
                        fail(std::string("execution model ") + operand_name(spv::OpEntryPoint, a[0]) +
                             " is not supported by the interpreter (vertex, tessellation control, "
                             "tessellation evaluation, geometry and fragment are)");
                }
                return;
            }
            case spv::OpExecutionMode: {
                // The entry point comes first (SPIR-V's logical layout): the stage is known.
                GeometryLayout& g = m_.geometry;
                switch (static_cast<spv::ExecutionMode>(a[1])) {
                    case spv::ExecutionModeOutputVertices:
                        m_.output_vertices = static_cast<int>(a[2]);
                        g.max_vertices = static_cast<int>(a[2]);
                        break;
                    case spv::ExecutionModeInputPoints: g.input_vertices = 1; break;
                    case spv::ExecutionModeInputLines: g.input_vertices = 2; break;
                    case spv::ExecutionModeInputLinesAdjacency: g.input_vertices = 4; break;
                    case spv::ExecutionModeInputTrianglesAdjacency: g.input_vertices = 6; break;
                    case spv::ExecutionModeOutputPoints: g.output = GeometryOutput::points; break;
                    case spv::ExecutionModeOutputLineStrip: g.output = GeometryOutput::line_strip; break;
                    case spv::ExecutionModeOutputTriangleStrip: g.output = GeometryOutput::triangle_strip; break;
                    case spv::ExecutionModeInvocations: g.invocations = static_cast<int>(a[2]); break;
                    case spv::ExecutionModeTriangles:
                        g.input_vertices = 3;
                        m_.layout.domain = Domain::triangles;
                        m_.has_layout = m_.stage == ShaderStage::tess_evaluation;
                        break;
                    case spv::ExecutionModeQuads: m_.layout.domain = Domain::quads; m_.has_layout = true; break;
                    case spv::ExecutionModeIsolines: m_.layout.domain = Domain::isolines; m_.has_layout = true; break;
                    case spv::ExecutionModeSpacingEqual: m_.layout.spacing = Spacing::equal; break;
                    case spv::ExecutionModeSpacingFractionalEven: m_.layout.spacing = Spacing::fractional_even; break;
                    case spv::ExecutionModeSpacingFractionalOdd: m_.layout.spacing = Spacing::fractional_odd; break;
                    case spv::ExecutionModeVertexOrderCw: m_.layout.winding = Winding::cw; break;
                    case spv::ExecutionModeVertexOrderCcw: m_.layout.winding = Winding::ccw; break;
                    case spv::ExecutionModePointMode: m_.layout.point_mode = true; break;
                    default: break;
                }
                return;
            }
            case spv::OpDecorate: {
                Decorations& d = deco(a[0]);
                switch (static_cast<spv::Decoration>(a[1])) {
                    case spv::DecorationBuiltIn: d.builtin = static_cast<int>(a[2]); break;
                    case spv::DecorationLocation: d.location = static_cast<int>(a[2]); break;
                    case spv::DecorationBinding: d.binding = static_cast<int>(a[2]); break;
                    case spv::DecorationPatch: d.patch = true; break;
                    case spv::DecorationComponent: fail("layout(component = N) is not supported by the interpreter");
                    default: break;
                }
                return;
            }
            case spv::OpMemberDecorate: {
                Decorations& d = deco(a[0]);
                switch (static_cast<spv::Decoration>(a[2])) {
                    case spv::DecorationBuiltIn: d.member_builtin[a[1]] = static_cast<int>(a[3]); break;
                    case spv::DecorationLocation: d.member_location[a[1]] = static_cast<int>(a[3]); break;
                    case spv::DecorationPatch: d.patch = true; break;
                    default: break;
                }
                return;
            }
            case spv::OpTypeVoid: add_type(a[0], type_of_kind(Kind::void_)); return;
            case spv::OpTypeBool: {
                Type t = type_of_kind(Kind::bool_);
                t.words = 1;
                t.scalar = Kind::bool_;
                add_type(a[0], t);
                return;
            }
            case spv::OpTypeInt:
            case spv::OpTypeFloat: {
                if (a[1] != 32)
                    fail(std::to_string(a[1]) + "-bit " + (op == spv::OpTypeInt ? "integers" : "floats") +
                         " are not supported by the interpreter (32-bit are)");
                Type t = type_of_kind(op == spv::OpTypeInt ? Kind::int_ : Kind::float_);
                t.is_signed = op == spv::OpTypeInt && a[2] != 0;
                t.words = 1;
                t.scalar = t.kind;
                add_type(a[0], t);
                return;
            }
            case spv::OpTypeVector:
            case spv::OpTypeMatrix:
            case spv::OpTypeArray: {
                const Type& e = type(a[1]);
                Type t = type_of_kind(op == spv::OpTypeVector ? Kind::vector : op == spv::OpTypeMatrix ? Kind::matrix : Kind::array);
                t.element = a[1];
                t.count = op == spv::OpTypeArray ? constant_u32(a[2]) : a[2];
                if (t.count == 0 || t.count > (1u << 20)) fail("an array of " + std::to_string(t.count) + " elements");
                const std::uint64_t words = std::uint64_t{e.words} * t.count;
                if (words > (1u << 24)) fail("a type of " + std::to_string(words) + " words");
                t.words = static_cast<std::uint32_t>(words);
                t.scalar = op == spv::OpTypeVector ? e.scalar : Kind::none;
                add_type(a[0], t);
                return;
            }
            case spv::OpTypeRuntimeArray: fail("runtime arrays are not supported by the interpreter");
            case spv::OpTypeStruct: {
                Type t = type_of_kind(Kind::struct_);
                std::uint64_t words = 0;
                for (std::uint32_t i = 1; i < n; ++i) {
                    t.members.push_back(a[i]);
                    t.member_offset.push_back(static_cast<std::uint32_t>(words));
                    words += type(a[i]).words;
                }
                if (words > (1u << 24)) fail("a struct of " + std::to_string(words) + " words");
                t.words = static_cast<std::uint32_t>(words);
                add_type(a[0], t);
                return;
            }
            case spv::OpTypePointer: {
                Type t = type_of_kind(Kind::pointer);
                t.storage = a[1];
                t.element = a[2];
                t.words = 1;
                add_type(a[0], t);
                return;
            }
            case spv::OpTypeFunction: add_type(a[0], type_of_kind(Kind::function)); return;
            case spv::OpTypeImage: {
                Type t = type_of_kind(Kind::image);
                t.words = 1;
                if (a[2] != spv::Dim2D) fail("only 2D images are supported by the interpreter");
                add_type(a[0], t);
                return;
            }
            case spv::OpTypeSampler: {
                Type t = type_of_kind(Kind::sampler);
                t.words = 1;
                add_type(a[0], t);
                return;
            }
            case spv::OpTypeSampledImage: {
                Type t = type_of_kind(Kind::sampled_image);
                t.words = 1;
                add_type(a[0], t);
                return;
            }
            case spv::OpConstant:
            case spv::OpSpecConstant: {
                value(a[0], a[1]);
                m_.reg_init[m_.reg[a[1]]] = a[2];
                return;
            }
            case spv::OpConstantTrue:
            case spv::OpConstantFalse:
            case spv::OpSpecConstantTrue:
            case spv::OpSpecConstantFalse:
                value(a[0], a[1]);
                m_.reg_init[m_.reg[a[1]]] = op == spv::OpConstantTrue || op == spv::OpSpecConstantTrue;
                return;
            case spv::OpConstantComposite:
            case spv::OpSpecConstantComposite: {
                value(a[0], a[1]);
                std::uint32_t at = m_.reg[a[1]];
                const std::uint32_t end = at + type(a[0]).words;
                for (std::uint32_t i = 2; i < n; ++i) {
                    const std::uint32_t c = check_id(a[i]);
                    if (m_.reg[c] == kNone) fail("a composite constant of a non-constant");
                    const std::uint32_t words = type(m_.type_of[c]).words;
                    if (at + words > end) fail("a composite constant larger than its type");
                    std::copy_n(m_.reg_init.begin() + m_.reg[c], words, m_.reg_init.begin() + at);
                    at += words;
                }
                return;
            }
            case spv::OpConstantNull:
            case spv::OpUndef:
                value(a[0], a[1]);
                return;
            case spv::OpVariable:
                variable(a[0], a[1], a[2], n > 3 ? a[3] : 0);
                return;
            case spv::OpFunction: {
                if (m_.fixed_regs.empty()) m_.fixed_regs.emplace_back(0, static_cast<std::uint32_t>(m_.reg_init.size()));
                function_id = check_id(a[1]);
                function = &m_.functions[function_id];
                function->first = kNone;
                value(a[0], a[1]);  // the call's result register
                return;
            }
            default:
                fail(opcode_name(in.op) + " outside a function is not supported by the interpreter");
        }
    }

    // Interface parts of a (non-arrayed) type starting at `location`, members' own
    // locations and built-ins from the struct's decorations.
    void parts(std::uint32_t type_id, std::uint32_t offset, int& location, std::vector<InterfacePart>& out) {
        const Type& t = type(type_id);
        switch (t.kind) {
            case Kind::bool_:
            case Kind::int_:
            case Kind::float_:
            case Kind::vector:
                out.push_back(InterfacePart{offset, t.words, location < 0 ? -1 : location++, -1});
                return;
            case Kind::matrix:
            case Kind::array:
                for (std::uint32_t i = 0; i < t.count; ++i) parts(t.element, offset + i * type(t.element).words, location, out);
                return;
            case Kind::struct_: {
                const Decorations* d = type_id < decorations_.size() ? &decorations_[type_id] : nullptr;
                for (std::uint32_t i = 0; i < t.members.size(); ++i) {
                    if (d) {
                        if (auto b = d->member_builtin.find(i); b != d->member_builtin.end()) {
                            out.push_back(InterfacePart{offset + t.member_offset[i], type(t.members[i]).words, -1, b->second});
                            continue;
                        }
                        if (auto l = d->member_location.find(i); l != d->member_location.end()) location = l->second;
                    }
                    parts(t.members[i], offset + t.member_offset[i], location, out);
                }
                return;
            }
            default: return;
        }
    }

    bool arrayed_storage(std::uint32_t storage) const {
        switch (m_.stage) {
            case ShaderStage::tess_control: return storage == spv::StorageClassInput || storage == spv::StorageClassOutput;
            case ShaderStage::tess_evaluation:
            case ShaderStage::geometry: return storage == spv::StorageClassInput;
            default: return false;
        }
    }

    // Module::Impl::lane_invariant. A block comes after the blocks that dominate it, so one
    // pass in code order sees an access chain's operands first (a later operand, through a
    // phi, leaves it unmarked: the executor then tests the lanes).
    void find_lane_invariants() {
        m_.lane_invariant.assign(m_.bound, 0);
        if (!m_.fixed_regs.empty())
            for (std::uint32_t id = 0; id < m_.bound; ++id)
                if (m_.reg[id] != kNone && m_.reg[id] < m_.fixed_regs.front().second) m_.lane_invariant[id] = 1;
        for (const Variable& v : m_.variables) m_.lane_invariant[v.id] = 1;
        for (const Instr& in : m_.code) {
            if (in.op != spv::OpAccessChain && in.op != spv::OpInBoundsAccessChain) continue;
            const std::uint32_t* a = &m_.words[in.at];
            bool invariant = true;
            for (std::uint32_t k = 2; k < in.count && invariant; ++k) invariant = m_.lane_invariant[a[k]] != 0;
            m_.lane_invariant[a[1]] = invariant ? 1 : 0;
        }
    }

    void finish_variables() {
        if (decorations_.size() < m_.bound) decorations_.resize(m_.bound);
        std::uint64_t shared = 0, local = 0;
        for (Variable& v : m_.variables) {
            const Type& t = type(v.type);
            const bool is_local = v.storage == spv::StorageClassPrivate || v.storage == spv::StorageClassFunction;
            std::uint64_t& top = is_local ? local : shared;
            v.address = static_cast<std::uint32_t>(top);
            top += t.words;
            if (top > (1u << 26)) fail("variables of more than 2^26 words");
            const Decorations& d = decorations_[v.id];
            v.binding = d.binding;
            v.builtin = d.builtin;
            v.patch = d.patch;
            if (v.storage == spv::StorageClassInput || v.storage == spv::StorageClassOutput) {
                const bool tess_level = d.builtin == spv::BuiltInTessLevelOuter || d.builtin == spv::BuiltInTessLevelInner;
                v.arrayed = arrayed_storage(v.storage) && !v.patch && !tess_level && t.kind == Kind::array &&
                            d.builtin < 0;
                const std::uint32_t element = v.arrayed ? t.element : v.type;
                if (v.arrayed) {
                    v.element_words = type(element).words;
                    v.vertices = t.count;
                }
                if (d.builtin >= 0) {
                    v.parts.push_back(InterfacePart{0, t.words, -1, d.builtin});
                } else {
                    int location = d.location;
                    parts(element, 0, location, v.parts);
                }
            }
        }
        m_.shared_words = static_cast<std::uint32_t>(shared);
        m_.local_words = static_cast<std::uint32_t>(local);
        m_.shared_init.assign(m_.shared_words, 0);
        m_.local_init.assign(m_.local_words, 0);
        for (Variable& v : m_.variables) {
            const bool is_local = v.storage == spv::StorageClassPrivate || v.storage == spv::StorageClassFunction;
            if (is_local) v.address += m_.shared_words;
            m_.reg_init[m_.reg[v.id]] = v.address;  // OpVariable's result: the address, fixed (no recursion)
            if (v.storage == spv::StorageClassFunction) m_.fixed_regs.emplace_back(m_.reg[v.id], 1);
            if (v.storage != spv::StorageClassFunction) {  // a Function variable's initializer runs with OpVariable
                if (v.init) {
                    const std::uint32_t words = type(v.type).words;
                    std::uint32_t* to = is_local ? &m_.local_init[v.address - m_.shared_words] : &m_.shared_init[v.address];
                    std::copy_n(m_.reg_init.begin() + m_.reg[check_id(v.init)], words, to);
                }
            }
        }
    }
};

}  // namespace

Module Module::load(std::vector<std::uint32_t> spirv, const std::string& path) {
    validate_spirv(spirv, path);
    auto impl = std::make_shared<Impl>();
    impl->path = path;
    impl->words = std::move(spirv);
    Loader(*impl).load();
    return Module(std::move(impl));
}

ShaderStage Module::stage() const { return impl_->stage; }
const std::string& Module::path() const { return impl_->path; }
const std::vector<std::uint32_t>& Module::spirv() const { return impl_->words; }
int Module::output_vertices() const { return impl_->stage == ShaderStage::tess_control ? impl_->output_vertices : 0; }

GeometryLayout Module::geometry_layout() const {
    if (impl_->stage != ShaderStage::geometry)
        throw Error("the " + std::string(to_string(impl_->stage)) + " shader has no geometry layout",
                    Where::in_file(impl_->path));
    return impl_->geometry;
}

TessLayout Module::tess_layout() const {
    if (impl_->stage != ShaderStage::tess_evaluation || !impl_->has_layout)
        throw Error("the " + std::string(to_string(impl_->stage)) + " shader has no tessellation layout",
                    Where::in_file(impl_->path));
    return impl_->layout;
}

std::vector<std::string> Module::uniform_names() const {
    std::vector<std::string> names;
    for (const Variable& v : impl_->variables)
        if (v.storage == spv::StorageClassUniformConstant && impl_->types[v.type].kind != Kind::sampled_image)
            names.push_back(v.name);
    return names;
}

std::vector<Module::Output> Module::outputs() const {
    std::vector<Output> out;
    for (const Variable& v : impl_->variables)
        if (v.storage == spv::StorageClassOutput)
            for (const InterfacePart& p : v.parts)
                if (p.builtin < 0 && p.location >= 0) out.push_back({p.location, static_cast<int>(p.words)});
    return out;
}

std::vector<Module::Sampler> Module::samplers() const {
    std::vector<Sampler> out;
    for (const Variable& v : impl_->variables)
        if (v.storage == spv::StorageClassUniformConstant && impl_->types[v.type].kind == Kind::sampled_image)
            out.push_back({v.name, std::max(v.binding, 0)});  // as Executable binds it (stages.cpp)
    return out;
}

const char* to_string(MathMode mode) { return mode == MathMode::exact ? "exact" : "llvmpipe"; }

Slot slot(glm::vec4 v) {
    Slot s;
    std::memcpy(s.data(), &v[0], sizeof s);
    return s;
}
glm::vec4 as_vec4(const Slot& s) {
    glm::vec4 v;
    std::memcpy(&v[0], s.data(), sizeof s);
    return v;
}

}  // namespace tessref::shader
