// src/shader/executor.h — a batch of invocations of a module run in lockstep, instruction
// by instruction (private to src/shader/; the stage drivers in stages.cpp set up its memory
// and read it).
//
// A batch holds `lanes` invocations (one for a control shader's invocation or a vertex; up
// to kBatchLanes evaluation invocations of one patch). Every word of a register or of
// memory is stored lane by lane: word j of the value in register r of lane l is
// regs[(r + j) * lanes + l], and memory address a of lane l is memory[a * lanes + l], so an
// instruction is one loop over its components times the lanes, which the compiler turns into
// SIMD where the operation allows. The lanes run the same instruction as long as their
// branches agree; where a branch parts them, run() stops before it (Status::diverged) and
// split() makes one batch per way, each continuing on its own. Each lane computes exactly
// what it would compute alone: the operations are the scalar ones, applied lane by lane.
#pragma once

#include <cstdint>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "shader/module.h"

namespace tessref::shader {

// The lanes of one evaluation batch: large enough that the interpreter's dispatch per
// instruction is small beside its work, small enough that a batch's registers stay in the
// cache (a level-16 quad patch's 289 points run as 5 batches).
constexpr std::uint32_t kBatchLanes = 64;

// What a batch reads besides its own registers: the shared memory (uniforms, inputs,
// outputs; shared_words words per lane, laid out as the batch's lanes), the textures by
// unit, and the options.
struct ExecContext {
    const Module::Impl& module;
    std::vector<std::uint32_t>& shared;
    const std::vector<const Texture*>& units;
    const RunOptions& options;
    std::string who;  // "tess_evaluation shader x.tese, patch 3, invocation 0": for errors
    std::set<std::uint32_t>* warned = nullptr;  // instructions that already warned
    // Shared memory kept once for all lanes where every lane holds the same words (an
    // evaluation batch's uniforms and patch inputs, which the shader only reads): when
    // lane_slot is set, the word at shared address a is invariant[a] in every lane if
    // lane_slot[a] is kNone, else word lane_slot[a] of `shared` (lane-interleaved). A
    // variable's words are all of one kind, and consecutive in `shared`. Without lane_slot,
    // `shared` holds every address, lane by lane.
    const std::uint32_t* invariant = nullptr;
    const std::vector<std::uint32_t>* lane_slot = nullptr;
    // A fragment shader's batch that holds a whole 2x2 quad, lanes in the order of
    // fragment.cpp (top-left, top-right, bottom-left, bottom-right): derivatives and
    // texture()'s implicit lod are taken across it. A fragment batch without it (the lanes
    // of a quad that a branch parted) has no derivatives: they are 0, with a warning.
    bool quad = false;
    // The lane whose lines and stores RunOptions::observer records (a fragment quad's traced
    // fragment, as this batch numbers its lanes); kNone: none of this batch's lanes.
    std::uint32_t observed_lane = 0;
};

// The words of lanes `pick` (in that order) of a lane-interleaved array of `lanes` lanes.
std::vector<std::uint32_t> gather_lanes(const std::vector<std::uint32_t>& from, std::uint32_t lanes,
                                        std::span<const std::uint32_t> pick);
// `lanes` copies of a one-lane array, interleaved.
std::vector<std::uint32_t> broadcast_lanes(const std::vector<std::uint32_t>& one, std::uint32_t lanes);

class Batch {
public:
    explicit Batch(const Module::Impl& module, std::uint32_t lanes = 1);
    enum class Status : std::uint8_t { done, barrier, killed, diverged, emit, end_primitive, at_stop };
    // Runs until the entry point returns, a barrier() or a discard, a geometry shader's
    // EmitVertex() or EndPrimitive() (the driver takes the outputs and runs on), or until a
    // branch whose lanes go different ways (the batch then stands before that branch).
    Status run(ExecContext& context);
    std::uint32_t lanes() const { return lanes_; }
    // After Status::diverged: the lanes grouped by the way their branch goes, each group in
    // lane order, the groups in the order of their first lane.
    std::vector<std::vector<std::uint32_t>> ways(const ExecContext& context) const;
    // After Status::diverged: the label each lane's branch goes to.
    std::vector<std::uint32_t> targets(const ExecContext& context) const;
    // The index in Module::Impl::code of the instruction the batch stands before.
    std::uint32_t pc() const { return pc_; }
    // After Status::diverged: every lane takes the branch to `label` (a fragment quad's lanes
    // that discard there go on as helpers, fragment.cpp).
    void branch_to(std::uint32_t label);
    // run() stops (Status::at_stop) when it enters the block `label`, or the block `exit`,
    // after its OpPhis, so that the ways of a parted batch meet again there (fragment.cpp:
    // `exit` is the merge block of the loop a way may break out of); kNone: never.
    void stop_at(std::uint32_t label, std::uint32_t exit = 0xffffffffu) {
        stop_label_ = label;
        exit_label_ = exit;
    }
    // The block the batch is in (after Status::at_stop: the one it stopped at).
    std::uint32_t block() const { return label_; }
    // The batch of `lanes` lanes whose lanes parts[k].second[i] are lane i of parts[k].first,
    // all standing at the same instruction (after run() gave Status::at_stop for each).
    static Batch join(std::span<const std::pair<const Batch*, std::vector<std::uint32_t>>> parts, std::uint32_t lanes);
    // The batch of lanes `pick` of this one, at the same instruction.
    Batch split(std::span<const std::uint32_t> pick) const;
    // The batch back at the entry point for another set of invocations of as many lanes:
    // Private and Function variables as initialized, the registers kept (constants and
    // variables' addresses never change; every other register is written before it is read,
    // as SPIR-V's dominance rules, checked by the validator, require).
    void restart();

private:
    template <std::uint32_t kLanes>
    Status run_lanes(ExecContext& context);
    // The words of `address`: word j of lane l at result[j * stride + l], stride the lanes;
    // or, where every lane shares the memory (ExecContext::invariant), stride 0 and word j
    // at result[j].
    std::uint32_t* memory(ExecContext& context, std::uint32_t address, std::uint32_t words, std::uint32_t& stride);
    void observe_store(ExecContext& context, std::uint32_t address, std::uint32_t value, std::uint32_t words);
    struct Frame {
        std::uint32_t return_pc;
        std::uint32_t result;  // the OpFunctionCall's result id
        std::uint32_t label;   // the caller's current block
    };
    const Module::Impl* module_;
    std::uint32_t lanes_ = 1;
    std::vector<std::uint32_t> regs_;
    std::vector<std::uint32_t> local_;
    std::vector<Frame> stack_;
    std::uint32_t pc_ = 0;
    std::uint32_t label_ = 0, previous_label_ = 0;
    std::uint64_t executed_ = 0;
    std::uint32_t observed_line_ = 0, observed_file_ = 0;  // RunOptions::observer: the last line told
    std::uint32_t stop_label_ = 0xffffffffu;  // stop_at()
    std::uint32_t exit_label_ = 0xffffffffu;  // stop_at()
    bool stopping_ = false;   // entered stop_label_'s block: stop after its OpPhis
    bool keep_line_ = false;  // the next run() goes on where this one stopped, for the observer
};

}  // namespace tessref::shader
