// src/shader/executor.h — one invocation of a module, run instruction by instruction
// (private to src/shader/; the stage drivers in stages.cpp set up its memory and read it).
#pragma once

#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "shader/module.h"

namespace tessref::shader {

// What an invocation reads besides its own memory: the shared memory (uniforms, inputs,
// outputs), the textures by unit, and the options.
struct ExecContext {
    const Module::Impl& module;
    std::vector<std::uint32_t>& shared;
    const std::vector<const Texture*>& units;
    const RunOptions& options;
    std::string who;  // "tess_evaluation shader x.tese, patch 3, invocation 0": for errors
    std::set<std::uint32_t>* warned = nullptr;  // instructions that already warned
};

class Invocation {
public:
    Invocation(const Module::Impl& module);
    enum class Status : std::uint8_t { done, barrier, killed };
    // Runs until the entry point returns, a barrier() or a discard.
    Status run(ExecContext& context);
    std::uint32_t* memory(ExecContext& context, std::uint32_t address, std::uint32_t words);
    void observe_store(ExecContext& context, std::uint32_t address, std::uint32_t value, std::uint32_t words);

private:
    struct Frame {
        std::uint32_t return_pc;
        std::uint32_t result;  // the OpFunctionCall's result id
        std::uint32_t label;   // the caller's current block
    };
    std::vector<std::uint32_t> regs_;
    std::vector<std::uint32_t> local_;
    std::vector<Frame> stack_;
    std::uint32_t pc_ = 0;
    std::uint32_t label_ = 0, previous_label_ = 0;
    std::uint64_t executed_ = 0;
    std::uint32_t observed_line_ = 0, observed_file_ = 0;  // RunOptions::observer: the last line told
};

}  // namespace tessref::shader
