// src/shader/rebalance.h — the chains of + and * that Mesa's GLSL compiler rebalances before
// llvmpipe runs them, found in a loaded module (private to src/shader/).
//
// Mesa's GLSL compiler (opt_rebalance_tree.cpp, Mesa 22.3) turns a tree of three or more
// additions (or multiplications) of one type, written a + b + c + d = ((a + b) + c) + d,
// into the balanced tree (a + b) + (c + d) (llvmpipe_math.h, balanced_order), which rounds
// differently. It does so only for some trees, and the rule follows from where the pass
// runs: once at compile time, after the built-ins are inlined, after copy propagation and
// tree grafting, before user functions are inlined (and once more at link time, after
// them). rebalance.cpp states the rule in terms of glslang's SPIR-V; docs/ARCHITECTURE.md
// ("Which chains Mesa rebalances") gives the probes that show it.
//
// find_rebalanced_chains rewrites each chain that the rule rebalances into one instruction
// (module.h, Chain and kOpChain) that runs it in the source's order in exact math and in
// Mesa's in llvmpipe math; every other instruction is left as it is.
#pragma once

#include "shader/module.h"

namespace tessref::shader {

void find_rebalanced_chains(Module::Impl& module);

}  // namespace tessref::shader
