// src/shader/driver.h — what the stage drivers share (private to src/shader/): an
// Executable's resolved state, and a vertex's interface variables written into and read
// from an invocation's memory by location and built-in. The drivers: vertex, control and
// evaluation in stages.cpp, geometry in geometry.cpp.
#pragma once

#define SPV_ENABLE_UTILITY_CODE
#include <algorithm>
#include <bit>
#include <cstring>
#include <string>
#include <vector>

#include <glslang/SPIRV/spirv.hpp>

#include "shader/module.h"

namespace tessref::shader {

struct Executable::State {
    Module module;
    RunOptions options;
    std::vector<std::uint32_t> shared;  // uniforms set, samplers' units; inputs and outputs zero
    std::vector<const Texture*> units;
    // An evaluation batch's shared memory (ExecContext::lane_slot): the outputs and
    // gl_TessCoord lane by lane, lane_words words per lane; the rest once for all lanes.
    std::vector<std::uint32_t> lane_slot;
    std::uint32_t lane_words = 0;
    std::size_t location_count = 0;  // an evaluation shader's output locations (ShaderVertices)
    explicit State(Module m) : module(std::move(m)) {}
};

inline bool is_input(const Variable& v) { return v.storage == spv::StorageClassInput; }
inline bool is_output(const Variable& v) { return v.storage == spv::StorageClassOutput; }

inline void to_slot(std::vector<Slot>& slots, int location, const std::uint32_t* from, std::uint32_t words) {
    if (location < 0) return;
    if (slots.size() <= static_cast<std::size_t>(location)) slots.resize(static_cast<std::size_t>(location) + 1, Slot{});
    Slot& s = slots[static_cast<std::size_t>(location)];
    std::copy_n(from, std::min<std::uint32_t>(words, 4), s.begin());
}

inline void from_slot(const std::vector<Slot>& slots, int location, std::uint32_t* to, std::uint32_t words) {
    if (location < 0 || static_cast<std::size_t>(location) >= slots.size()) return;  // unwritten: zero
    std::copy_n(slots[static_cast<std::size_t>(location)].begin(), std::min<std::uint32_t>(words, 4), to);
}

// One vertex's element of an interface variable (the whole variable when not arrayed):
// written from / read into a ShaderVertex.
inline void write_vertex(const Variable& v, std::uint32_t* element, const ShaderVertex& from) {
    for (const InterfacePart& p : v.parts) {
        if (p.builtin == spv::BuiltInPosition) std::memcpy(element + p.offset, &from.position[0], 16);
        else if (p.builtin == spv::BuiltInPointSize) element[p.offset] = std::bit_cast<std::uint32_t>(1.0f);
        else if (p.builtin < 0) from_slot(from.locations, p.location, element + p.offset, p.words);
    }
}
inline void read_vertex(const Variable& v, const std::uint32_t* element, ShaderVertex& to) {
    for (const InterfacePart& p : v.parts) {
        if (p.builtin == spv::BuiltInPosition) std::memcpy(&to.position[0], element + p.offset, 16);
        else if (p.builtin < 0) to_slot(to.locations, p.location, element + p.offset, p.words);
    }
}

inline std::string who(const Module::Impl& m, long long patch, int invocation) {
    std::string s = std::string(to_string(m.stage)) + " shader " + m.path;
    if (patch >= 0) s += ", patch " + std::to_string(patch);
    if (invocation >= 0) s += ", invocation " + std::to_string(invocation);
    return s;
}

inline void require_stage(const Module::Impl& m, ShaderStage stage, const char* call) {
    if (m.stage != stage)
        throw Error(std::string("Executable::") + call + " runs a " + to_string(stage) + " shader, not a " +
                        to_string(m.stage) + " shader",
                    Where::in_file(m.path));
}

// Reads a single invocation's outputs (vertex and evaluation shaders).
inline ShaderVertex read_outputs(const Module::Impl& m, const std::vector<std::uint32_t>& shared) {
    ShaderVertex out;
    for (const Variable& v : m.variables)
        if (is_output(v)) read_vertex(v, &shared[v.address], out);
    return out;
}

}  // namespace tessref::shader
