// src/common/isolated.h — running untrusted work in a child process with its own limits.
//
// A user's GLSL shader is compiled and run by Mesa inside the process that asks for it,
// where no limit of tessref's applies: `float a[2147483647]` made llvmpipe grow to 22 GB
// until the kernel killed the process, a shader looping for minutes hangs it, and a crash in
// the driver (a segfault in OSMesaCreateContextAttribs under MESA_GLSL_VERSION_OVERRIDE=110)
// takes tessref down with it, leaving temporary output files behind. run_isolated() runs
// such work in a fork()ed child (no exec: the parent's scene, pipeline and textures are
// shared copy-on-write) under
//  - an address-space limit (RLIMIT_AS): what the parent had mapped at the fork plus the
//    memory budget (limits.h: --max-memory, TESSREF_MAX_MEMORY, 3/4 of physical memory);
//  - a wall-clock limit: TESSREF_GL_TIME_LIMIT seconds (default 600), after which the child
//    is killed;
//  - no core dump.
// The child's result comes back through a pipe as bytes; a tessref::Error it throws comes
// back as the same Error. A child that crashes, is killed by a limit or runs past the time
// becomes an Error naming what it was doing (set_isolated_phase: "compiling the fragment
// shader arr.frag of --shader frag=arr.frag") and that file. The parent's outputs are
// untouched by the child; the parent's AtomicOutputs remove their temporary files as usual.
//
// The child must not use oneTBB (its worker threads are not in the child): do the parallel
// work before run_isolated() and hand it in.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "tessref/error.h"

namespace tessref {

struct IsolationLimits {
    std::uint64_t memory_bytes = 0;  // added to what the parent maps; 0: the memory budget
    double seconds = 0.0;            // wall clock; 0: TESSREF_GL_TIME_LIMIT or 600
};

// The default time limit: TESSREF_GL_TIME_LIMIT when set (seconds, > 0; an invalid value is
// an Error naming the variable), else 600: far above any real draw, which must never be
// killed (`golden verify thesis-constant-64`, the largest, took 128 s in all on a loaded
// two-core machine).
double isolation_time_limit();

// Runs `work` in a child process under `limits` and returns the bytes it returned. `what`
// names the work in messages ("the GL backend (llvmpipe)"). `meanwhile`, when given, runs
// here in the parent while the child works (after the fork, before its answer is read; the
// child's time limit runs through it): `golden verify` computes the CPU side of a scene
// while llvmpipe draws it. An exception from it kills the child, reaps it and goes on.
//
// `on_chunk`, when given, receives here, in order, every piece of bytes the child sends
// ahead of its answer with send_to_parent(), as it arrives (after `meanwhile`): a child
// whose result is large streams it piece by piece, and neither process holds it whole
// (while `meanwhile` runs, the child waits once the pipe is full). An exception from it
// kills the child, reaps it and goes on.
std::string run_isolated(const std::string& what, const std::function<std::string()>& work,
                         const IsolationLimits& limits = {}, const std::function<void()>& meanwhile = {},
                         const std::function<void(std::string_view)>& on_chunk = {});

// run_isolated() in two halves: start_isolated() forks the child, which starts its work at
// once; finish() runs `meanwhile`, takes the pieces and the answer, reaps the child and
// throws as run_isolated() does. Between the two the caller may do anything, start other
// children included: `golden verify` starts the next scene's llvmpipe child before it
// computes this scene's CPU side, so that the one core llvmpipe's compiler and tessellation
// use is never the only one busy. A child's time limit counts from the start of finish();
// one that fills its pipe waits there until finish() reads it. A child not finished (its
// IsolatedChild destroyed, an exception on the way) is killed and reaped.
// Fork only while no other thread of this process runs: the child gets the forking thread
// alone, and a lock another thread held stays held in the child for ever.
class IsolatedChild {
public:
    IsolatedChild();
    IsolatedChild(IsolatedChild&&) noexcept;
    IsolatedChild& operator=(IsolatedChild&&) noexcept;
    IsolatedChild(const IsolatedChild&) = delete;
    IsolatedChild& operator=(const IsolatedChild&) = delete;
    ~IsolatedChild();

    bool started() const { return state_ != nullptr; }
    // Once only; afterwards started() is false.
    std::string finish(const std::function<void()>& meanwhile = {},
                       const std::function<void(std::string_view)>& on_chunk = {});

    struct State;

private:
    explicit IsolatedChild(std::unique_ptr<State> state);
    friend IsolatedChild start_isolated(const std::string&, const std::function<std::string()>&,
                                        const IsolationLimits&);
    std::unique_ptr<State> state_;
};

IsolatedChild start_isolated(const std::string& what, const std::function<std::string()>& work,
                             const IsolationLimits& limits = {});

// In the child: sends `bytes` to the parent's `on_chunk` now, ahead of the answer. Throws
// tessref::Error when the parent no longer reads. Not for use outside run_isolated().
void send_to_parent(std::string_view bytes);

// In the child: what it is doing now, and the file that is about to be used (a shader),
// for the message if it dies there. Does nothing outside run_isolated().
void set_isolated_phase(const std::string& doing, const Where& where = {});

}  // namespace tessref
