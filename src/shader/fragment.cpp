// The fragment stage's driver: the four invocations of a 2x2 quad as one batch of four
// lanes (tessref/shader.h, Executable::fragment), so that the executor takes derivatives
// and texture()'s implicit lod across the quad (ExecContext::quad).
//
// llvmpipe runs a quad's fragments in SIMD lanes under an execution mask: a branch that
// parts them runs both ways with the lanes masked, and after it every lane is there again,
// so derivatives after an if, or after a loop that the lanes left at different
// iterations, are the quad's. Here the batch stops before such a branch
// (Batch::Status::diverged); each way runs as a batch of its own up to the block where the
// ways meet again (the OpSelectionMerge or OpLoopMerge of the construct; for a loop's exit,
// the loop's merge block), and the ways are joined there into one batch (Batch::join).
// A way that breaks out of the innermost loop around the branch waits at the loop's merge
// block, and the others, once met at the branch's own merge, run on until they leave the
// loop too: all meet there, so derivatives after a loop left by `break` are the quad's.
// Where a way never reaches either block (an early return, a break out of a loop around
// an inner one) its lanes run on alone; derivatives in a batch that is not the whole quad
// are undefined in GLSL and 0 here, with a warning.
//
// `if (c) discard;` (a branch to a block that only discards) parts nothing: the lanes that
// discard are marked so and go on with the others, as llvmpipe's masked lanes do, so that
// the quad's derivatives stay available after it (what SPIR-V calls demoting to a helper
// invocation). A discard anywhere else ends the lanes that reach it.
#include <algorithm>
#include <set>

#include "shader/driver.h"
#include "shader/executor.h"

namespace tessref::shader {

namespace {

// A batch of some of the quad's lanes with its shared memory (lane-interleaved as the
// batch's lanes) and the quad lane of each of its lanes, in increasing order.
struct Work {
    Batch batch;
    std::vector<std::uint32_t> shared;
    std::vector<std::uint32_t> lanes;
};

// Whether the block `label` only discards (OpKill or OpTerminateInvocation, after debug
// line instructions).
bool only_discards(const Module::Impl& m, std::uint32_t label) {
    for (std::uint32_t k = m.label_at[label] + 1; k < m.code.size(); ++k) {
        const std::uint16_t op = m.code[k].op;
        if (op == spv::OpLine || op == spv::OpNoLine) continue;
        return op == spv::OpKill || op == spv::OpTerminateInvocation;
    }
    return false;
}

// The block where the ways of the branch at `pc` meet again: the merge block of the
// construct the branch heads (the OpSelectionMerge or OpLoopMerge just before it), else,
// for a branch that leaves a loop (its exit test), the loop's merge block; kNone if neither.
std::uint32_t meeting_block(const Module::Impl& m, std::uint32_t pc, std::span<const std::uint32_t> targets) {
    if (pc > 0) {
        const Instr& merge = m.code[pc - 1];
        if (merge.op == spv::OpSelectionMerge || merge.op == spv::OpLoopMerge) return m.words[merge.at];
    }
    for (const Instr& in : m.code)
        if (in.op == spv::OpLoopMerge && std::find(targets.begin(), targets.end(), m.words[in.at]) != targets.end())
            return m.words[in.at];
    return kNone;
}

// The merge block of the innermost loop whose body holds the instruction at `pc`, where a
// way that breaks out of that loop waits for the quad's other lanes; kNone outside loops.
// glslang lays a loop's blocks out between its header (the OpLoopMerge) and its merge
// block, which SPIR-V's structured order allows, so the innermost loop is the one with the
// last header before `pc` whose merge block comes after it.
std::uint32_t enclosing_loop_exit(const Module::Impl& m, std::uint32_t pc) {
    std::uint32_t exit = kNone;
    for (std::uint32_t k = 0; k < pc && k < m.code.size(); ++k) {
        if (m.code[k].op != spv::OpLoopMerge) continue;
        const std::uint32_t merge = m.words[m.code[k].at];
        if (m.label_at[merge] > pc) exit = merge;
    }
    return exit;
}

}  // namespace

std::array<FragmentResult, 4> Executable::fragment(std::span<const QuadFragment, 4> quad, bool front_facing,
                                                   long long primitive_id) const {
    const Module::Impl& m = state_->module.impl();
    require_stage(m, ShaderStage::fragment, "fragment");
    // What every lane reads alike, then each lane's own inputs.
    std::vector<std::uint32_t> one = state_->shared;
    for (const Variable& v : m.variables) {
        if (!is_input(v)) continue;
        if (v.builtin == spv::BuiltInFrontFacing) one[v.address] = front_facing ? 1u : 0u;
        else if (v.builtin == spv::BuiltInPrimitiveId) one[v.address] = static_cast<std::uint32_t>(primitive_id);
    }
    std::vector<std::uint32_t> shared = broadcast_lanes(one, 4);
    for (std::uint32_t l = 0; l < 4; ++l) {
        const QuadFragment& q = quad[l];
        std::vector<std::uint32_t> element;
        for (const Variable& v : m.variables) {
            if (!is_input(v)) continue;
            const auto put = [&](std::uint32_t offset, std::uint32_t word) { shared[(v.address + offset) * 4 + l] = word; };
            if (v.builtin == spv::BuiltInFragCoord) {
                for (std::uint32_t j = 0; j < 4; ++j) put(j, std::bit_cast<std::uint32_t>(q.frag_coord[static_cast<int>(j)]));
            } else if (v.builtin == spv::BuiltInHelperInvocation) {
                put(0, q.covered ? 0u : 1u);
            } else if (v.builtin < 0) {
                element.assign(m.types[v.type].words, 0u);
                for (const InterfacePart& p : v.parts)
                    if (p.builtin < 0) from_slot(q.inputs, p.location, element.data() + p.offset, p.words);
                for (std::uint32_t j = 0; j < element.size(); ++j) put(j, element[j]);
            }
        }
    }

    std::array<FragmentResult, 4> out;
    for (std::uint32_t l = 0; l < 4; ++l) out[l].helper = !quad[l].covered;
    std::set<std::uint32_t> warned;
    const std::string name = std::string(to_string(m.stage)) + " shader " + m.path + ", primitive " +
                             std::to_string(primitive_id) + ", fragment (" + std::to_string(quad[0].frag_coord.x) + ", " +
                             std::to_string(quad[0].frag_coord.y) + ")'s quad";
    const auto read_results = [&](const Work& w) {
        const std::uint32_t n = static_cast<std::uint32_t>(w.lanes.size());
        std::vector<std::uint32_t> element;
        for (std::uint32_t k = 0; k < n; ++k) {
            FragmentResult& r = out[w.lanes[k]];
            for (const Variable& v : m.variables) {
                if (!is_output(v)) continue;
                element.resize(m.types[v.type].words);
                for (std::size_t j = 0; j < element.size(); ++j) element[j] = w.shared[(v.address + j) * n + k];
                if (v.builtin == spv::BuiltInFragDepth) {
                    r.depth_written = true;
                    r.depth = std::bit_cast<float>(element[0]);
                    continue;
                }
                for (const InterfacePart& p : v.parts)
                    if (p.builtin < 0) to_slot(r.outputs, p.location, element.data() + p.offset, p.words);
            }
        }
    };
    // The ways that reached the same block, joined into one batch of their lanes in quad order.
    const auto join = [&](std::vector<Work>& arrived) {
        std::vector<std::uint32_t> lanes;
        for (const Work& a : arrived) lanes.insert(lanes.end(), a.lanes.begin(), a.lanes.end());
        std::sort(lanes.begin(), lanes.end());
        const auto position = [&](std::uint32_t lane) {
            return static_cast<std::uint32_t>(std::lower_bound(lanes.begin(), lanes.end(), lane) - lanes.begin());
        };
        std::vector<std::pair<const Batch*, std::vector<std::uint32_t>>> parts;
        const std::uint32_t joined = static_cast<std::uint32_t>(lanes.size());
        const std::uint32_t first = static_cast<std::uint32_t>(arrived.front().lanes.size());
        std::vector<std::uint32_t> joined_shared(arrived.front().shared.size() / first * joined, 0u);
        for (const Work& a : arrived) {
            std::vector<std::uint32_t> at;
            for (const std::uint32_t lane : a.lanes) at.push_back(position(lane));
            const std::uint32_t an = static_cast<std::uint32_t>(a.lanes.size());
            for (std::size_t j = 0; j < a.shared.size() / an; ++j)
                for (std::uint32_t k = 0; k < an; ++k) joined_shared[j * joined + at[k]] = a.shared[j * an + k];
            parts.emplace_back(&a.batch, std::move(at));
        }
        return Work{Batch::join(parts, joined), std::move(joined_shared), std::move(lanes)};
    };
    // Runs `w` until its lanes end (their results read) or they enter the block `stop` or
    // `exit` (the merge block of a loop they may break out of); returns them there, as one
    // batch per block reached (the lanes that broke out and the others can come back apart
    // when `exit` is the caller's to wait at).
    const auto drive = [&](auto& self, Work w, std::uint32_t stop, std::uint32_t exit) -> std::vector<Work> {
        for (;;) {
            w.batch.stop_at(stop, exit);
            ExecContext c{m, w.shared, state_->units, state_->options, name, &warned};
            c.quad = w.lanes.size() == 4;
            const auto traced = std::find(w.lanes.begin(), w.lanes.end(),
                                          static_cast<std::uint32_t>(state_->options.observed_lane));
            c.observed_lane = traced == w.lanes.end() ? kNone : static_cast<std::uint32_t>(traced - w.lanes.begin());
            const Batch::Status status = w.batch.run(c);
            std::vector<Work> back;
            switch (status) {
                case Batch::Status::done: read_results(w); return back;
                case Batch::Status::killed:
                    for (const std::uint32_t l : w.lanes) out[l].discarded = true;
                    return back;
                case Batch::Status::at_stop: back.push_back(std::move(w)); return back;
                case Batch::Status::diverged: break;
                default:
                    throw Error("the " + name + " stopped at an instruction a fragment shader has no use for",
                                Where::in_file(m.path));
            }
            const std::vector<std::uint32_t> targets = w.batch.targets(c);
            std::vector<std::uint32_t> distinct;
            for (const std::uint32_t t : targets)
                if (std::find(distinct.begin(), distinct.end(), t) == distinct.end()) distinct.push_back(t);
            if (distinct.size() == 2 && only_discards(m, distinct[0]) != only_discards(m, distinct[1])) {
                // if (c) discard;: those lanes discard and go on as helpers.
                const std::uint32_t kill = only_discards(m, distinct[0]) ? distinct[0] : distinct[1];
                for (std::size_t k = 0; k < targets.size(); ++k)
                    if (targets[k] == kill) out[w.lanes[k]].discarded = true;
                w.batch.branch_to(kill == distinct[0] ? distinct[1] : distinct[0]);
                continue;
            }
            const std::uint32_t meet = meeting_block(m, w.batch.pc(), distinct);
            const std::uint32_t until = meet != kNone ? meet : stop;
            // A way that breaks out of the innermost loop around the branch waits at the
            // loop's merge block for the others, which go on looping until they leave it too.
            std::uint32_t breaks = enclosing_loop_exit(m, w.batch.pc());
            if (breaks == until) breaks = kNone;
            const std::uint32_t n = static_cast<std::uint32_t>(w.lanes.size());
            std::vector<Work> arrived, waiting;  // at `until`; at `breaks`
            for (const std::vector<std::uint32_t>& way : w.batch.ways(c)) {
                Work part{w.batch.split(way), gather_lanes(w.shared, n, way), {}};
                for (const std::uint32_t k : way) part.lanes.push_back(w.lanes[k]);
                for (Work& at : self(self, std::move(part), until, breaks))
                    (breaks != kNone && at.batch.block() == breaks ? waiting : arrived).push_back(std::move(at));
            }
            if (!waiting.empty() && breaks == exit) {
                // The caller waits at this loop's exit: the lanes that broke out go back to it,
                // the others go on (to `stop`, or to the exit as well).
                back.push_back(join(waiting));
                if (arrived.empty()) return back;
                Work rest = join(arrived);
                if (until != stop)
                    for (Work& at : self(self, std::move(rest), stop, exit)) back.push_back(std::move(at));
                else
                    back.push_back(std::move(rest));
                return back;
            }
            if (!waiting.empty()) {
                // This call waits at the loop's exit: the ways that met at `until` run on until
                // they leave the loop too, and all meet there.
                if (!arrived.empty())
                    for (Work& at : self(self, join(arrived), breaks, kNone)) waiting.push_back(std::move(at));
                w = join(waiting);
                if (breaks == stop) {
                    back.push_back(std::move(w));
                    return back;
                }
                continue;
            }
            if (arrived.empty()) return back;
            w = join(arrived);
            if (until == stop || (exit != kNone && w.batch.block() == exit)) {
                back.push_back(std::move(w));  // at this call's own stop (a loop's exit met again inside the loop)
                return back;
            }
        }
    };
    Work first{Batch(m, 4), std::move(shared), {0, 1, 2, 3}};
    drive(drive, std::move(first), kNone, kNone);
    return out;
}

}  // namespace tessref::shader
