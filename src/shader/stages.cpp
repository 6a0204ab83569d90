// The stage drivers: uniforms and textures resolved once (Executable), a stage's inputs
// written into its invocation's memory, the invocations run, its outputs read back, with
// the GL stage interface: locations and built-ins (tessref/shader.h).
#define SPV_ENABLE_UTILITY_CODE
#include <atomic>
#include <algorithm>
#include <bit>
#include <cstring>
#include <optional>
#include <set>

#include <glslang/SPIRV/spirv.hpp>

#include "shader/driver.h"
#include "shader/executor.h"
#include "shader/module.h"

namespace tessref::shader {

namespace {
std::atomic<std::uint64_t> g_default_max_instructions{10'000'000};
}  // namespace

std::uint64_t default_max_instructions() { return g_default_max_instructions.load(std::memory_order_relaxed); }
void set_default_max_instructions(std::uint64_t max_instructions) {
    g_default_max_instructions.store(max_instructions, std::memory_order_relaxed);
}

// ---- Bindings ------------------------------------------------------------------------------

namespace {

template <class T>
std::vector<std::uint32_t> words_of(const T& v, std::size_t n) {
    std::vector<std::uint32_t> out(n);
    std::memcpy(out.data(), &v, n * 4);
    return out;
}

const char* type_name(Bindings::Type t) {
    switch (t) {
        case Bindings::Type::float_: return "float";
        case Bindings::Type::int_: return "int";
        case Bindings::Type::vec2: return "vec2";
        case Bindings::Type::vec3: return "vec3";
        case Bindings::Type::vec4: return "vec4";
        case Bindings::Type::mat3: return "mat3";
        case Bindings::Type::mat4: return "mat4";
    }
    return "?";
}

// Whether a value of Bindings type `b` may set a uniform of module type `t` (as glUniform*
// of that type may: glUniform1i also sets a bool).
bool fits(const Module::Impl& m, const Type& t, Bindings::Type b) {
    const auto vec = [&](std::uint32_t n) { return t.kind == Kind::vector && t.count == n && t.scalar == Kind::float_; };
    const auto mat = [&](std::uint32_t n) {
        return t.kind == Kind::matrix && t.count == n && m.types[t.element].count == n;
    };
    switch (b) {
        case Bindings::Type::float_: return t.kind == Kind::float_;
        case Bindings::Type::int_: return t.kind == Kind::int_ || t.kind == Kind::bool_;
        case Bindings::Type::vec2: return vec(2);
        case Bindings::Type::vec3: return vec(3);
        case Bindings::Type::vec4: return vec(4);
        case Bindings::Type::mat3: return mat(3);
        case Bindings::Type::mat4: return mat(4);
    }
    return false;
}

}  // namespace

void Bindings::set(const std::string& name, float v) { values_[name] = {Type::float_, words_of(v, 1)}; }
void Bindings::set(const std::string& name, int v) { values_[name] = {Type::int_, words_of(v, 1)}; }
void Bindings::set(const std::string& name, glm::vec2 v) { values_[name] = {Type::vec2, words_of(v, 2)}; }
void Bindings::set(const std::string& name, glm::vec3 v) { values_[name] = {Type::vec3, words_of(v, 3)}; }
void Bindings::set(const std::string& name, glm::vec4 v) { values_[name] = {Type::vec4, words_of(v, 4)}; }
void Bindings::set(const std::string& name, const glm::mat3& m) { values_[name] = {Type::mat3, words_of(m, 9)}; }
void Bindings::set(const std::string& name, const glm::mat4& m) { values_[name] = {Type::mat4, words_of(m, 16)}; }
void Bindings::bind_texture(int unit, const Texture* texture) {
    if (unit < 0 || unit > 255) throw Error("texture unit " + std::to_string(unit) + " is outside [0, 255]");
    textures_[unit] = texture;
}

// ---- Executable ----------------------------------------------------------------------------

Executable::Executable(Module module, const Bindings& bindings, RunOptions options) {
    auto state = std::make_unique<State>(std::move(module));
    const Module::Impl& m = state->module.impl();
    state->options = options;
    state->shared = m.shared_init;
    for (const Variable& v : m.variables) {
        if (v.storage != spv::StorageClassUniformConstant) continue;
        const Type& t = m.types[v.type];
        if (t.kind == Kind::sampled_image) {
            state->shared[v.address] = static_cast<std::uint32_t>(std::max(v.binding, 0));
            continue;
        }
        const auto value = bindings.values().find(v.name);
        if (value == bindings.values().end()) continue;
        if (!fits(m, t, value->second.type))
            throw Error("the uniform " + v.name + " is set as a " + type_name(value->second.type) +
                            " but the shader declares another type",
                        Where::in_file(m.path));
        std::copy(value->second.words.begin(), value->second.words.end(), state->shared.begin() + v.address);
    }
    if (m.stage == ShaderStage::tess_evaluation) {
        state->lane_slot.assign(m.shared_words, kNone);
        for (const Variable& v : m.variables) {
            if (v.storage != spv::StorageClassOutput && v.builtin != spv::BuiltInTessCoord) continue;
            for (std::uint32_t j = 0; j < m.types[v.type].words; ++j) state->lane_slot[v.address + j] = state->lane_words++;
            for (const InterfacePart& p : v.parts)
                if (v.storage == spv::StorageClassOutput && p.builtin < 0 && p.location >= 0)
                    state->location_count = std::max(state->location_count, static_cast<std::size_t>(p.location) + 1);
        }
    }
    for (const auto& [unit, texture] : bindings.textures()) {
        if (state->units.size() <= static_cast<std::size_t>(unit)) state->units.resize(static_cast<std::size_t>(unit) + 1);
        state->units[static_cast<std::size_t>(unit)] = texture;
    }
    state_ = std::move(state);
}

Executable::~Executable() = default;
Executable::Executable(Executable&&) noexcept = default;
Executable& Executable::operator=(Executable&&) noexcept = default;
const Module& Executable::module() const { return state_->module; }

ShaderVertex Executable::vertex(std::span<const Slot> attributes, int vertex_id) const {
    const Module::Impl& m = state_->module.impl();
    require_stage(m, ShaderStage::vertex, "vertex");
    std::vector<std::uint32_t> shared = state_->shared;
    const std::vector<Slot> attribute_slots(attributes.begin(), attributes.end());
    for (const Variable& v : m.variables) {
        if (!is_input(v)) continue;
        if (v.builtin == spv::BuiltInVertexId || v.builtin == spv::BuiltInVertexIndex) {
            shared[v.address] = static_cast<std::uint32_t>(vertex_id);
            continue;
        }
        for (const InterfacePart& p : v.parts) {
            if (p.builtin >= 0) continue;  // gl_InstanceID and the like: 0
            // An attribute the draw does not supply reads as GL's current value (0, 0, 0, 1).
            const Slot fallback = slot(glm::vec4(0.0f, 0.0f, 0.0f, 1.0f));
            const Slot& s = p.location >= 0 && static_cast<std::size_t>(p.location) < attribute_slots.size()
                                ? attribute_slots[static_cast<std::size_t>(p.location)]
                                : fallback;
            std::copy_n(s.begin(), std::min<std::uint32_t>(p.words, 4), &shared[v.address + p.offset]);
        }
    }
    std::set<std::uint32_t> warned;
    ExecContext c{m, shared, state_->units, state_->options, who(m, -1, vertex_id), &warned};
    Batch invocation(m);
    if (invocation.run(c) != Batch::Status::done)
        throw Error("the " + c.who + " stopped at a barrier or discard outside a control or fragment shader",
                    Where::in_file(m.path));
    return read_outputs(m, shared);
}

ShaderPatch Executable::control(std::span<const ShaderVertex> in, long long patch_id) const {
    const Module::Impl& m = state_->module.impl();
    require_stage(m, ShaderStage::tess_control, "control");
    std::vector<std::uint32_t> shared = state_->shared;
    const int vertices_out = m.output_vertices;
    std::uint32_t invocation_id_address = kNone;
    for (const Variable& v : m.variables) {
        if (!is_input(v)) continue;
        if (v.builtin == spv::BuiltInInvocationId) invocation_id_address = v.address;
        else if (v.builtin == spv::BuiltInPrimitiveId) shared[v.address] = static_cast<std::uint32_t>(patch_id);
        else if (v.builtin == spv::BuiltInPatchVertices) shared[v.address] = static_cast<std::uint32_t>(in.size());
        else if (v.arrayed)
            for (std::uint32_t k = 0; k < v.vertices && k < in.size(); ++k)
                write_vertex(v, &shared[v.address + k * v.element_words], in[k]);
    }
    // Every invocation runs to the next barrier() (or its end) before any runs past it.
    std::vector<Batch> invocations(static_cast<std::size_t>(vertices_out), Batch(m));
    std::vector<bool> finished(invocations.size(), false);
    std::set<std::uint32_t> warned;
    for (std::size_t remaining = invocations.size(); remaining > 0;) {
        for (std::size_t i = 0; i < invocations.size(); ++i) {
            if (finished[i]) continue;
            if (invocation_id_address != kNone) shared[invocation_id_address] = static_cast<std::uint32_t>(i);
            if (state_->options.observer) state_->options.observer->invocation(static_cast<int>(i));
            ExecContext c{m, shared, state_->units, state_->options, who(m, patch_id, static_cast<int>(i)), &warned};
            const Batch::Status status = invocations[i].run(c);
            if (status == Batch::Status::killed)
                throw Error("the " + c.who + " executed discard outside a fragment shader", Where::in_file(m.path));
            if (status == Batch::Status::done) {
                finished[i] = true;
                --remaining;
            }
        }
    }
    ShaderPatch patch;
    patch.vertices.resize(static_cast<std::size_t>(vertices_out));
    for (const Variable& v : m.variables) {
        if (!is_output(v)) continue;
        if (v.builtin == spv::BuiltInTessLevelOuter) {
            for (std::uint32_t k = 0; k < 4 && k < m.types[v.type].words; ++k)
                patch.outer[k] = std::bit_cast<float>(shared[v.address + k]);
        } else if (v.builtin == spv::BuiltInTessLevelInner) {
            for (std::uint32_t k = 0; k < 2 && k < m.types[v.type].words; ++k)
                patch.inner[k] = std::bit_cast<float>(shared[v.address + k]);
        } else if (v.arrayed) {
            for (std::uint32_t k = 0; k < v.vertices && k < patch.vertices.size(); ++k)
                read_vertex(v, &shared[v.address + k * v.element_words], patch.vertices[k]);
        } else {
            for (const InterfacePart& p : v.parts)
                if (p.builtin < 0) to_slot(patch.patch_locations, p.location, &shared[v.address + p.offset], p.words);
        }
    }
    return patch;
}

ShaderVertex Executable::evaluate(const ShaderPatch& patch, glm::vec3 tess_coord, long long patch_id) const {
    return evaluate(patch, std::span<const glm::vec3>(&tess_coord, 1), patch_id).front();
}

// The points of the patch in batches of kBatchLanes lanes (one lane with an observer, which
// follows one invocation); a batch whose branches part ways continues as one batch per way
// (executor.h), the ways run in the order of their first point.
ShaderVertex ShaderVertices::vertex(std::size_t k) const {
    ShaderVertex v;
    v.position = positions[k];
    v.locations.assign(locations.begin() + static_cast<std::ptrdiff_t>(k * location_count),
                       locations.begin() + static_cast<std::ptrdiff_t>((k + 1) * location_count));
    return v;
}

std::vector<ShaderVertex> Executable::evaluate(const ShaderPatch& patch, std::span<const glm::vec3> tess_coords,
                                               long long patch_id) const {
    ShaderVertices flat;
    evaluate(patch, tess_coords, patch_id, flat);
    std::vector<ShaderVertex> out(flat.size());
    for (std::size_t k = 0; k < out.size(); ++k) out[k] = flat.vertex(k);
    return out;
}

void Executable::evaluate(const ShaderPatch& patch, std::span<const glm::vec3> tess_coords, long long patch_id,
                          ShaderVertices& out) const {
    const Module::Impl& m = state_->module.impl();
    require_stage(m, ShaderStage::tess_evaluation, "evaluate");
    // One lane's shared memory: everything but gl_TessCoord is the patch's.
    std::vector<std::uint32_t> one = state_->shared;
    std::uint32_t tess_coord_address = kNone;
    for (const Variable& v : m.variables) {
        if (!is_input(v)) continue;
        std::uint32_t* at = &one[v.address];
        switch (v.builtin) {
            case spv::BuiltInTessCoord: tess_coord_address = v.address; continue;
            case spv::BuiltInPrimitiveId: *at = static_cast<std::uint32_t>(patch_id); continue;
            case spv::BuiltInPatchVertices: *at = static_cast<std::uint32_t>(patch.vertices.size()); continue;
            case spv::BuiltInTessLevelOuter: std::memcpy(at, patch.outer.data(), 4 * std::min<std::uint32_t>(4, m.types[v.type].words)); continue;
            case spv::BuiltInTessLevelInner: std::memcpy(at, patch.inner.data(), 4 * std::min<std::uint32_t>(2, m.types[v.type].words)); continue;
            default: break;
        }
        if (v.arrayed) {
            for (std::uint32_t k = 0; k < v.vertices && k < patch.vertices.size(); ++k)
                write_vertex(v, at + k * v.element_words, patch.vertices[k]);
        } else {
            for (const InterfacePart& p : v.parts)
                if (p.builtin < 0) from_slot(patch.patch_locations, p.location, at + p.offset, p.words);
        }
    }
    out.positions.assign(tess_coords.size(), glm::vec4(0.0f, 0.0f, 0.0f, 1.0f));
    out.location_count = state_->location_count;
    out.locations.assign(tess_coords.size() * out.location_count, Slot{});
    const std::size_t chunk = state_->options.observer ? 1 : kBatchLanes;
    std::set<std::uint32_t> warned;
    struct Work {
        Batch batch;
        std::vector<std::uint32_t> shared;
        std::vector<std::size_t> points;  // each lane's index in tess_coords
    };
    // The first batch of the patch's points is set up in full; the next batches of as many
    // lanes reuse it (Batch::restart), with only what changes between them written again:
    // the outputs, gl_TessCoord, Private and Function variables.
    std::optional<Work> fresh;
    std::vector<Work> work;  // the ways of a divergence, each a batch of its own
    const std::string invocations = who(m, patch_id, -1);
    const auto run = [&](Work& w) {
        ExecContext c{m, w.shared, state_->units, state_->options, invocations, &warned, one.data(), &state_->lane_slot};
        const Batch::Status status = w.batch.run(c);
        const std::uint32_t n = w.batch.lanes();
        if (status == Batch::Status::diverged) {
            const std::vector<std::vector<std::uint32_t>> ways = w.batch.ways(c);
            for (auto way = ways.rbegin(); way != ways.rend(); ++way) {  // the first way runs first
                Work part{w.batch.split(*way), gather_lanes(w.shared, n, *way), {}};
                for (const std::uint32_t l : *way) part.points.push_back(w.points[l]);
                work.push_back(std::move(part));
            }
            return;
        }
        if (status != Batch::Status::done)
            throw Error("the " + c.who + " stopped at a barrier or discard outside a control or fragment shader",
                        Where::in_file(m.path));
        // Each lane's outputs, gathered from the lane-interleaved memory (read_vertex's
        // parts: gl_Position, and the locations' components).
        for (const Variable& v : m.variables) {
            if (!is_output(v)) continue;
            const std::uint32_t slot = state_->lane_slot[v.address];
            for (const InterfacePart& p : v.parts) {
                const bool position = p.builtin == spv::BuiltInPosition;
                if (!position && (p.builtin >= 0 || p.location < 0)) continue;
                const std::uint32_t words = position ? 4 : std::min<std::uint32_t>(p.words, 4);
                for (std::uint32_t l = 0; l < n; ++l) {
                    const std::size_t k = w.points[l];
                    Slot word{};
                    for (std::uint32_t j = 0; j < words; ++j) word[j] = w.shared[(slot + p.offset + j) * n + l];
                    if (position) std::memcpy(&out.positions[k][0], word.data(), 16);
                    else std::copy_n(word.begin(), words, out.locations[k * out.location_count + static_cast<std::size_t>(p.location)].begin());
                }
            }
        }
    };
    for (std::size_t first = 0; first < tess_coords.size(); first += chunk) {
        const std::uint32_t lanes = static_cast<std::uint32_t>(std::min(chunk, tess_coords.size() - first));
        if (fresh && fresh->batch.lanes() == lanes) {
            fresh->batch.restart();
        } else {
            fresh.emplace(Work{Batch(m, lanes), std::vector<std::uint32_t>(state_->lane_words * lanes), {}});
        }
        for (const Variable& v : m.variables)
            if (is_output(v))
                for (std::uint32_t j = 0; j < m.types[v.type].words; ++j)
                    std::fill_n(fresh->shared.begin() + static_cast<std::ptrdiff_t>(state_->lane_slot[v.address + j] * lanes), lanes,
                                one[v.address + j]);
        fresh->points.clear();
        for (std::uint32_t l = 0; l < lanes; ++l) {
            fresh->points.push_back(first + l);
            if (tess_coord_address == kNone) continue;
            for (std::uint32_t j = 0; j < 3; ++j)
                fresh->shared[(state_->lane_slot[tess_coord_address + j]) * lanes + l] =
                    std::bit_cast<std::uint32_t>(tess_coords[first + l][static_cast<int>(j)]);
        }
        run(*fresh);
        while (!work.empty()) {
            Work w = std::move(work.back());
            work.pop_back();
            run(w);
        }
    }
}

}  // namespace tessref::shader
