// The chains Mesa's GLSL compiler rebalances (rebalance.h), found on glslang's SPIR-V.
//
// Mesa 22.3's pass (opt_rebalance_tree.cpp) and where it runs decide which chains change.
// The pass visits every expression that is the operand of another expression, a function's
// return value, a call's argument, an if's condition, a swizzle's or texture's operand; not
// the right-hand side of an assignment itself (it skips assignments and visits only the
// operands of their top expression). An expression it visits is rebalanced when its whole
// tree is three or more of one operation (+ or *) of one type whose leaves are variables
// (swizzled or not) and at most one constant: no other operation, no array element or struct
// member. Then it goes on into the (new) tree's operands. The pass runs at compile time
// after lower_builtins has inlined every built-in function and after copy propagation,
// constant propagation and tree grafting, before user functions are inlined. So, for a leaf:
//
// - a user function's result, a function parameter, an input, a uniform: a variable;
// - a local variable stored once and read once in the same block: grafted, it becomes what
//   was stored (the body of acos(), a product, ...), so its tree is not a reduction; stored
//   once with a constant: a constant; read twice, or in another block: a variable;
// - a built-in's result written in the chain: its inlined body, not a reduction.
//
// And for the place of a chain's top:
//
// - a return value, an operand of any other operation, a user function's argument (glslang
//   copies it into a variable that only the call reads): visited;
// - stored into a variable: an assignment, not visited itself (its operands are), unless the
//   variable is grafted into a place that is visited (read once, in the same block, by an
//   operation, not by a return);
// - an argument of a built-in: the inlined body's parameter is assigned the chain and then
//   grafted into the body where the body reads it once (sqrt, exp2, min, ...), not where it
//   reads it more often (acos, length, ...);
// - a vector constructor's component, a ?: branch: assignments.
//
// NIR's algebraic pass rewrites further (for one, (a*b + c*d) + e becomes (a*b + e) + c*d
// when e is not a product), and the link-time run can rebalance what inlining user functions
// puts together; neither is modelled. Precise (NoContraction) chains, and chains of more than
// about a thousand operations (Finder::kMaxNodes), are left as written.
#define SPV_ENABLE_UTILITY_CODE
#include "shader/rebalance.h"

#include <glslang/SPIRV/GLSL.std.450.h>
#include <glslang/SPIRV/spirv.hpp>

#include "shader/llvmpipe_math.h"

namespace tessref::shader {

namespace {

// How the pass sees a chain's operand.
enum class Leaf : std::uint8_t { variable, constant, other };

// The built-ins whose inlined body reads the parameter once (a single expression of it, in
// Mesa's builtin_functions.cpp): an argument of theirs is grafted into that expression.
bool reads_argument_once(std::uint32_t instruction) {
    switch (instruction) {
        case GLSLstd450Round:
        case GLSLstd450RoundEven:
        case GLSLstd450Trunc:
        case GLSLstd450FAbs:
        case GLSLstd450FSign:
        case GLSLstd450Floor:
        case GLSLstd450Ceil:
        case GLSLstd450Fract:
        case GLSLstd450Radians:
        case GLSLstd450Degrees:
        case GLSLstd450Sin:
        case GLSLstd450Cos:
        case GLSLstd450Atan:
        case GLSLstd450Pow:
        case GLSLstd450Exp:
        case GLSLstd450Log:
        case GLSLstd450Exp2:
        case GLSLstd450Log2:
        case GLSLstd450Sqrt:
        case GLSLstd450InverseSqrt:
        case GLSLstd450FMin:
        case GLSLstd450FMax:
        case GLSLstd450FClamp:
        case GLSLstd450FMix:
        case GLSLstd450Distance:
            return true;
        default:
            return false;
    }
}

class Finder {
public:
    explicit Finder(Module::Impl& m) : m_(m) {}

    void run() {
        index();
        std::vector<std::pair<std::uint32_t, Chain>> found;  // (root's index in code, chain)
        std::vector<std::uint32_t> nops;
        for (std::uint32_t i = 0; i < m_.code.size(); ++i) {
            const Instr& in = m_.code[i];
            if (in.op != spv::OpFAdd && in.op != spv::OpFMul) continue;
            const std::uint32_t root = word(in, 1);
            if (m_.types[m_.type_of[root]].scalar != Kind::float_ || joins_parent(root)) continue;
            std::vector<Node> tree;
            if (!build(tree, root, in.op, m_.type_of[root], block_[i])) continue;
            std::uint32_t operations = 0;
            bool precise = false;
            for (const Node& n : tree) {
                operations += n.operation();
                precise = precise || (n.operation() && precise_[n.id]);
            }
            if (operations < 3 || precise) continue;
            Chain chain;
            chain.op = in.op;
            const Type& t = m_.types[m_.type_of[root]];
            chain.components = t.kind == Kind::vector ? t.count : 1;
            emit(tree, 0, chain.as_written);
            // The pass: at the top if the place is one it visits, below it in any case.
            visit(tree, 0, visited(root, 0));
            emit(tree, 0, chain.llvmpipe);
            if (chain.llvmpipe == chain.as_written) continue;
            for (const Node& n : tree)
                if (n.operation() && n.id != root) nops.push_back(def_[n.id]);
            found.emplace_back(i, std::move(chain));
        }
        for (const std::uint32_t k : nops) m_.code[k].op = spv::OpNop;
        for (auto& [k, chain] : found) {
            Instr& root = m_.code[k];
            root.op = kOpChain;
            root.count = 0;
            root.at = static_cast<std::uint32_t>(m_.chains.size());
            m_.chains.push_back(std::move(chain));
        }
    }

private:
    // A node of a chain's tree: an operation (two children) or a leaf (an operand's id).
    struct Node {
        std::uint32_t id = 0;
        std::uint32_t child[2] = {kNone, kNone};
        Leaf leaf = Leaf::other;
        bool operation() const { return child[0] != kNone; }
    };
    // How the function's code uses a Function or Private variable.
    struct Access {
        std::uint32_t stores = 0, loads = 0, calls = 0, other = 0;
        std::uint32_t store_at = kNone, load_at = kNone;  // in code: the last store and load
        std::uint32_t stored = 0;                          // the value of the last store
    };

    Module::Impl& m_;
    std::vector<std::uint32_t> def_;     // by id: index in code of the instruction that defines it
    std::vector<std::uint32_t> uses_;    // by id: how often code names it as an operand
    std::vector<std::uint32_t> use_at_;  // by id: index in code of its last use
    std::vector<std::uint32_t> block_;   // by index in code: the label of its block
    std::vector<std::uint8_t> parameter_, precise_;  // by id
    std::vector<Access> access_;         // by index in m_.variables

    std::uint32_t word(const Instr& in, std::uint32_t k) const { return m_.words[in.at + k]; }

    // Where an instruction's operands start (after its result type and result).
    static std::uint32_t first_operand(const Instr& in) {
        bool has_result = false, has_type = false;
        spv::HasResultAndType(static_cast<spv::Op>(in.op), &has_result, &has_type);
        return (has_result ? 1u : 0u) + (has_type ? 1u : 0u);
    }

    void index() {
        const std::uint32_t bound = m_.bound;
        def_.assign(bound, kNone);
        uses_.assign(bound, 0);
        use_at_.assign(bound, kNone);
        parameter_.assign(bound, 0);
        precise_.assign(bound, 0);
        block_.assign(m_.code.size(), 0);
        access_.assign(m_.variables.size(), Access{});
        for (const auto& [id, function] : m_.functions)
            for (const std::uint32_t p : function.params) parameter_[p] = 1;
        const std::vector<std::uint32_t>& w = m_.words;
        for (std::size_t pos = 5; pos < w.size() && (w[pos] >> 16) != 0; pos += w[pos] >> 16)
            if ((w[pos] & 0xffff) == spv::OpDecorate && pos + 2 < w.size() && w[pos + 2] == spv::DecorationNoContraction &&
                w[pos + 1] < bound)
                precise_[w[pos + 1]] = 1;
        std::uint32_t label = 0;
        for (std::uint32_t i = 0; i < m_.code.size(); ++i) {
            const Instr& in = m_.code[i];
            if (in.op == spv::OpLabel) label = word(in, 0);
            block_[i] = label;
            const std::uint32_t first = first_operand(in);
            if (first > 0) {
                const std::uint32_t result = word(in, first - 1);
                if (result < bound) def_[result] = i;
            }
            for (std::uint32_t k = first; k < in.count; ++k) {
                const std::uint32_t id = word(in, k);
                if (id >= bound) continue;  // a literal
                ++uses_[id];
                use_at_[id] = i;
                const Variable* v = m_.variable(id);
                if (!v || (v->storage != spv::StorageClassFunction && v->storage != spv::StorageClassPrivate)) continue;
                Access& a = access_[m_.variable_of[id]];
                if (in.op == spv::OpStore && k == 0) {
                    ++a.stores;
                    a.store_at = i;
                    a.stored = word(in, 1);
                } else if (in.op == spv::OpLoad && k == 2) {
                    ++a.loads;
                    a.load_at = i;
                } else if (in.op == spv::OpFunctionCall && k >= 3) {
                    ++a.calls;
                } else {
                    ++a.other;
                }
            }
            if (in.op == spv::OpVariable && in.count > 3) {  // an initializer: a store
                const std::uint32_t v = word(in, 1);
                if (v < bound && m_.variable_of[v] != kNone) {
                    Access& a = access_[m_.variable_of[v]];
                    ++a.stores;
                    a.store_at = i;
                    a.stored = word(in, 3);
                }
            }
        }
    }

    // A constant: a value every register file holds before any instruction runs (the first
    // fixed run, module.h), which is not a variable's address.
    bool is_constant(std::uint32_t id) const {
        return id < m_.bound && def_[id] == kNone && !parameter_[id] && !m_.variable(id) && m_.reg[id] != kNone &&
               !m_.fixed_regs.empty() && m_.reg[id] < m_.fixed_regs.front().second;
    }

    // Tree grafting moves a variable's one store into its one read in the same block.
    bool grafted(const Access& a) const {
        return a.stores == 1 && a.loads == 1 && a.calls == 0 && a.other == 0 && a.store_at < a.load_at &&
               block_[a.store_at] == block_[a.load_at];
    }

    Leaf leaf(std::uint32_t id, int depth) const {
        if (id >= m_.bound || depth > 16) return Leaf::other;
        if (is_constant(id)) return Leaf::constant;
        if (parameter_[id]) return Leaf::variable;
        if (def_[id] == kNone) return Leaf::other;
        const Instr& in = m_.code[def_[id]];
        switch (in.op) {
            case spv::OpFunctionCall: return Leaf::variable;  // the call's return temporary
            case spv::OpLoad: return loaded(word(in, 2), depth);
            case spv::OpCopyObject: return leaf(word(in, 2), depth + 1);
            case spv::OpCompositeExtract:  // a swizzle, of a vector only
                return m_.types[m_.type_of[word(in, 2)]].kind == Kind::vector ? leaf(word(in, 2), depth + 1) : Leaf::other;
            case spv::OpVectorShuffle:
                return word(in, 2) == word(in, 3) ? leaf(word(in, 2), depth + 1) : Leaf::other;
            case spv::OpCompositeConstruct: {
                // glslang's splat of a scalar operand (v + s); Mesa keeps the scalar itself.
                for (std::uint32_t k = 3; k < in.count; ++k)
                    if (word(in, k) != word(in, 2) || m_.types[m_.type_of[word(in, 2)]].kind == Kind::vector) return Leaf::other;
                return leaf(word(in, 2), depth + 1);
            }
            default: return Leaf::other;
        }
    }

    Leaf loaded(std::uint32_t pointer, int depth) const {
        if (pointer >= m_.bound) return Leaf::other;
        if (const Variable* v = m_.variable(pointer)) {
            if (v->storage == spv::StorageClassFunction || v->storage == spv::StorageClassPrivate) {
                const Access& a = access_[m_.variable_of[pointer]];
                if (a.stores == 1 && a.calls == 0 && a.other == 0 && is_constant(a.stored)) return Leaf::constant;
                if (grafted(a)) return leaf(a.stored, depth + 1);
            }
            return Leaf::variable;
        }
        if (parameter_[pointer]) return Leaf::variable;
        if (def_[pointer] == kNone) return Leaf::other;
        const Instr& chain = m_.code[def_[pointer]];
        if (chain.op != spv::OpAccessChain && chain.op != spv::OpInBoundsAccessChain) return Leaf::other;
        // A vector variable's component is a swizzle; an array's element, a struct's member
        // or a matrix's column stops the pass.
        const std::uint32_t base = word(chain, 2);
        const Type& pointee = m_.types[m_.types[m_.type_of[base]].element];
        if (chain.count != 4 || pointee.kind != Kind::vector) return Leaf::other;
        return m_.variable(base) || parameter_[base] ? Leaf::variable : Leaf::other;
    }

    // Whether `id` is an operation its one user continues as part of the same chain.
    bool joins_parent(std::uint32_t id) const {
        if (uses_[id] != 1 || precise_[id] || def_[id] == kNone) return false;
        const Instr& user = m_.code[use_at_[id]];
        return user.op == m_.code[def_[id]].op && m_.type_of[word(user, 1)] == m_.type_of[id] &&
               block_[use_at_[id]] == block_[def_[id]];
    }

    // The tree under `id` into `tree` (its top at tree[0]); false for a chain of more than
    // kMaxNodes nodes, which is left as written (the walks here recurse once per level, and
    // visit() collects a subtree's leaves at every level).
    static constexpr std::size_t kMaxNodes = 2048;
    bool build(std::vector<Node>& tree, std::uint32_t id, std::uint16_t op, std::uint32_t type, std::uint32_t block) {
        if (tree.size() >= kMaxNodes) return false;
        const auto n = static_cast<std::uint32_t>(tree.size());
        tree.push_back(Node{id});
        const std::uint32_t d = id < m_.bound ? def_[id] : kNone;
        const bool operation = d != kNone && m_.code[d].op == op && m_.type_of[id] == type && block_[d] == block &&
                               (n == 0 || (uses_[id] == 1 && !precise_[id]));
        if (!operation) {
            tree[n].leaf = leaf(id, 0);
            return true;
        }
        tree[n].child[0] = static_cast<std::uint32_t>(tree.size());
        if (!build(tree, word(m_.code[d], 2), op, type, block)) return false;
        tree[n].child[1] = static_cast<std::uint32_t>(tree.size());
        return build(tree, word(m_.code[d], 3), op, type, block);
    }

    // Whether the pass visits the expression `id` as a whole (the comment at the top).
    bool visited(std::uint32_t id, int depth) const {
        if (uses_[id] != 1 || depth > 16) return false;
        const Instr& user = m_.code[use_at_[id]];
        switch (user.op) {
            case spv::OpReturnValue: return depth == 0;  // a variable read by a return is not grafted there
            case spv::OpStore: {
                const Variable* v = m_.variable(word(user, 0));
                if (!v || word(user, 1) != id ||
                    (v->storage != spv::StorageClassFunction && v->storage != spv::StorageClassPrivate))
                    return false;
                const Access& a = access_[m_.variable_of[word(user, 0)]];
                if (a.stores == 1 && a.loads == 0 && a.other == 0 && a.calls > 0) return true;  // a call's argument
                if (grafted(a)) return visited(word(m_.code[a.load_at], 1), depth + 1);
                return false;
            }
            case spv::OpExtInst: return word(user, 2) == m_.std450 && reads_argument_once(word(user, 3));
            case spv::OpCompositeConstruct:
            case spv::OpSelect:
            case spv::OpPhi:
            case spv::OpCompositeInsert:
                return false;
            default: return true;
        }
    }

    void leaves_of(const std::vector<Node>& tree, std::uint32_t n, std::vector<std::uint32_t>& leaves,
                   std::vector<std::uint32_t>& operations) const {
        if (!tree[n].operation()) {
            leaves.push_back(n);
            return;
        }
        operations.push_back(n);
        leaves_of(tree, tree[n].child[0], leaves, operations);
        leaves_of(tree, tree[n].child[1], leaves, operations);
    }

    // opt_rebalance_tree's visit of node n: rebalanced if visited and a reduction of three
    // or more operations, then its operands visited. Balancing keeps the leaves' order and
    // the top node's id; the other operations' ids are the chain's own registers.
    void visit(std::vector<Node>& tree, std::uint32_t n, bool is_visited) const {
        if (!tree[n].operation()) return;
        if (is_visited) {
            std::vector<std::uint32_t> leaves, operations;
            leaves_of(tree, n, leaves, operations);
            std::uint32_t constants = 0;
            bool reduction = true;
            for (const std::uint32_t l : leaves) {
                constants += tree[l].leaf == Leaf::constant;
                reduction = reduction && tree[l].leaf != Leaf::other;
            }
            if (reduction && constants <= 1 && operations.size() >= 3) {
                const auto k = static_cast<std::uint32_t>(leaves.size());
                const std::vector<llvmpipe_math::BalancedStep> steps = llvmpipe_math::balanced_order(k);
                // Step s becomes node operations[s + 1]; the last step, the top, node n.
                std::vector<std::uint32_t> node_of(leaves);
                for (std::size_t s = 0; s < steps.size(); ++s)
                    node_of.push_back(s + 1 == steps.size() ? n : operations[s + 1]);
                for (std::size_t s = 0; s < steps.size(); ++s) {
                    Node& op = tree[node_of[k + s]];
                    op.child[0] = node_of[steps[s].left];
                    op.child[1] = node_of[steps[s].right];
                }
            }
        }
        visit(tree, tree[n].child[0], true);
        visit(tree, tree[n].child[1], true);
    }

    // The operations under n in post-order: (result, left, right) by id.
    static std::uint32_t emit(const std::vector<Node>& tree, std::uint32_t n,
                              std::vector<std::array<std::uint32_t, 3>>& steps) {
        if (!tree[n].operation()) return tree[n].id;
        const std::uint32_t left = emit(tree, tree[n].child[0], steps);
        const std::uint32_t right = emit(tree, tree[n].child[1], steps);
        steps.push_back({tree[n].id, left, right});
        return tree[n].id;
    }
};

}  // namespace

void find_rebalanced_chains(Module::Impl& module) { Finder(module).run(); }

}  // namespace tessref::shader
