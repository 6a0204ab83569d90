// src/shader/std450.h — the GLSL.std.450 extended instructions: the one place that
// dispatches (instruction, math mode, arguments), private to src/shader/.
#pragma once

#include <cstdint>
#include <string>

#include "shader/module.h"

namespace tessref::shader {

// The arguments of one GLSL.std.450 instruction, flattened (module.h): component i of
// argument k is value[k][i * stride] (a batch's lane, executor.h), and so is the result's.
struct Std450Args {
    const std::uint32_t* value[3] = {nullptr, nullptr, nullptr};
    std::uint32_t stride = 1;
    std::uint32_t components[3] = {0, 0, 0};  // each argument's scalar count (1 for a scalar)
    Kind scalar[3] = {Kind::none, Kind::none, Kind::none};
    std::uint32_t count = 0;
};

// Runs instruction `op` (GLSLstd450) in `mode` for `lanes` lanes (args.value[k][l] is lane
// l's first component, as is out[l]): the result's `components` words of leaf kind
// `scalar`, component i of lane l to out[i * stride + l]. Returns false for an instruction
// the interpreter does not run.
bool run_std450(std::uint32_t op, MathMode mode, Kind scalar, std::uint32_t components, const Std450Args& args,
                std::uint32_t lanes, std::uint32_t* out);

// A dot product of n components (component i of a vector at [i * stride]), every product
// and sum rounded: summed from the first component in exact mode, from the last in llvmpipe
// mode, as NIR splits it. OpDot, v * M and the GLSL.std.450 functions built on a dot use it.
float dot_product(const std::uint32_t* a, const std::uint32_t* b, std::uint32_t n, std::uint32_t stride, MathMode mode);

// The instruction's name ("Acos"), for errors and traces.
std::string std450_name(std::uint32_t op);

}  // namespace tessref::shader
