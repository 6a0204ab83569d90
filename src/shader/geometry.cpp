// The geometry stage's driver: a geometry shader's invocations over one input primitive,
// EmitVertex() taking a copy of the outputs, EndPrimitive() cutting the strip, and the
// output strips assembled into points, lines or triangles as GL assembles them
// (tessref/shader.h, ShaderPrimitives).
//
// The interpreter stops an invocation at each EmitVertex() and EndPrimitive()
// (Batch::Status::emit, end_primitive); the driver reads the output variables then, as the
// vertex that EmitVertex() hands on, and runs the invocation on. The outputs keep their
// values after EmitVertex() (GL leaves them undefined; a shader that writes every output
// before each EmitVertex(), as GL asks, sees no difference).
#include <cstring>
#include <optional>
#include <set>

#include "shader/driver.h"
#include "shader/executor.h"

namespace tessref::shader {

namespace {

// A finished strip's primitives, appended to `out` as indices of out.vertices; `first` is
// the strip's first vertex there.
void assemble(ShaderPrimitives& out, std::uint32_t first) {
    const std::uint32_t n = static_cast<std::uint32_t>(out.vertices.size()) - first;
    switch (out.output) {
        case GeometryOutput::points:
            for (std::uint32_t k = 0; k < n; ++k) out.indices.push_back(first + k);
            return;
        case GeometryOutput::line_strip:
            for (std::uint32_t k = 0; k + 1 < n; ++k) out.indices.insert(out.indices.end(), {first + k, first + k + 1});
            return;
        case GeometryOutput::triangle_strip:
            // Every other triangle with its first two vertices swapped, so that all keep the
            // first triangle's orientation and the last vertex is the newest.
            for (std::uint32_t k = 0; k + 2 < n; ++k) {
                const std::uint32_t v = first + k;
                if (k % 2 == 0) out.indices.insert(out.indices.end(), {v, v + 1, v + 2});
                else out.indices.insert(out.indices.end(), {v + 1, v, v + 2});
            }
            return;
    }
}

}  // namespace

ShaderPrimitives Executable::geometry(std::span<const ShaderVertex> in, long long primitive_id) const {
    const Module::Impl& m = state_->module.impl();
    require_stage(m, ShaderStage::geometry, "geometry");
    const GeometryLayout& layout = m.geometry;
    std::vector<std::uint32_t> shared = state_->shared;
    std::uint32_t invocation_id_address = kNone;
    for (const Variable& v : m.variables) {
        if (!is_input(v)) continue;
        if (v.builtin == spv::BuiltInInvocationId) invocation_id_address = v.address;
        else if (v.builtin == spv::BuiltInPrimitiveId) shared[v.address] = static_cast<std::uint32_t>(primitive_id);
        else if (v.arrayed)  // gl_in[] and the input blocks: one element per vertex of the primitive
            for (std::uint32_t k = 0; k < v.vertices && k < in.size(); ++k)
                write_vertex(v, &shared[v.address + k * v.element_words], in[k]);
    }
    ShaderPrimitives out;
    out.output = layout.output;
    const std::vector<std::uint32_t> inputs = shared;  // each invocation starts from the inputs alone
    std::set<std::uint32_t> warned;
    bool dropped = false;
    for (int invocation = 0; invocation < std::max(layout.invocations, 1); ++invocation) {
        shared = inputs;
        if (invocation_id_address != kNone) shared[invocation_id_address] = static_cast<std::uint32_t>(invocation);
        const std::string name = std::string(to_string(m.stage)) + " shader " + m.path + ", primitive " +
                                 std::to_string(primitive_id) + ", invocation " + std::to_string(invocation);
        if (state_->options.observer) state_->options.observer->invocation(invocation);
        ExecContext c{m, shared, state_->units, state_->options, name, &warned};
        Batch batch(m);
        int emitted = 0;  // by this invocation: max_vertices counts per invocation
        std::uint32_t strip = static_cast<std::uint32_t>(out.vertices.size());
        for (;;) {
            const Batch::Status status = batch.run(c);
            if (status == Batch::Status::emit) {
                if (emitted++ < layout.max_vertices) {
                    out.vertices.push_back(read_outputs(m, shared));
                } else if (!dropped && state_->options.warnings) {
                    dropped = true;
                    state_->options.warnings->push_back("warning: EmitVertex() past max_vertices = " +
                                                        std::to_string(layout.max_vertices) +
                                                        ", the vertex is dropped (" + name + ")");
                }
                continue;
            }
            if (status == Batch::Status::end_primitive || status == Batch::Status::done) {
                assemble(out, strip);
                strip = static_cast<std::uint32_t>(out.vertices.size());
                if (status == Batch::Status::done) break;
                continue;
            }
            throw Error("the " + name + " stopped at a barrier or discard outside a control or fragment shader",
                        Where::in_file(m.path));
        }
    }
    return out;
}

// The input primitives a batch of kBatchLanes at a time, one lane per primitive: every
// lane stops at the same EmitVertex() or EndPrimitive() as long as their branches agree (the
// driver then reads each lane's outputs as its primitive's vertex); a branch that parts them
// continues as one batch per way (executor.h), as the evaluation's batches do. Each lane
// computes what geometry() computes for its primitive alone.
void Executable::geometry(const ShaderVertices& in, std::span<const std::uint32_t> indices, long long primitive_id,
                          std::vector<ShaderPrimitives>& out) const {
    const Module::Impl& m = state_->module.impl();
    require_stage(m, ShaderStage::geometry, "geometry");
    const GeometryLayout& layout = m.geometry;
    const std::size_t per_input = static_cast<std::size_t>(layout.input_vertices);
    const std::size_t count = indices.size() / per_input;
    out.assign(count, ShaderPrimitives{});
    for (ShaderPrimitives& p : out) p.output = layout.output;
    std::uint32_t invocation_id_address = kNone;
    std::vector<std::uint32_t> one = state_->shared;
    for (const Variable& v : m.variables) {
        if (!is_input(v)) continue;
        if (v.builtin == spv::BuiltInInvocationId) invocation_id_address = v.address;
        else if (v.builtin == spv::BuiltInPrimitiveId) one[v.address] = static_cast<std::uint32_t>(primitive_id);
    }
    // Vertex k of `in` written into one lane's element of an arrayed input (write_vertex's
    // parts, read from the flat outputs).
    const auto write_input = [&](const Variable& v, std::uint32_t* element, std::size_t k) {
        for (const InterfacePart& p : v.parts) {
            if (p.builtin == spv::BuiltInPosition) std::memcpy(element + p.offset, &in.positions[k][0], 16);
            else if (p.builtin == spv::BuiltInPointSize) element[p.offset] = std::bit_cast<std::uint32_t>(1.0f);
            else if (p.builtin < 0 && p.location >= 0 && static_cast<std::size_t>(p.location) < in.location_count)
                std::copy_n(in.location(k, static_cast<std::size_t>(p.location)).begin(), std::min<std::uint32_t>(p.words, 4),
                            element + p.offset);
        }
    };
    std::set<std::uint32_t> warned;
    bool dropped = false;
    struct Work {
        Batch batch;
        std::vector<std::uint32_t> shared;
        std::vector<std::size_t> primitives;  // each lane's primitive
    };
    std::vector<Work> work;
    std::vector<int> emitted(count, 0);        // by the current invocation: max_vertices counts per invocation
    std::vector<std::uint32_t> strip(count, 0); // the current strip's first vertex
    std::vector<std::uint32_t> words;
    for (int invocation = 0; invocation < std::max(layout.invocations, 1); ++invocation) {
        const std::string name = std::string(to_string(m.stage)) + " shader " + m.path + ", primitive " +
                                 std::to_string(primitive_id) + ", invocation " + std::to_string(invocation);
        if (invocation_id_address != kNone) one[invocation_id_address] = static_cast<std::uint32_t>(invocation);
        for (std::size_t k = 0; k < count; ++k) {
            emitted[k] = 0;
            strip[k] = static_cast<std::uint32_t>(out[k].vertices.size());
        }
        const auto run = [&](Work& w) {
            const std::uint32_t n = w.batch.lanes();
            for (;;) {
                ExecContext c{m, w.shared, state_->units, state_->options, name, &warned};
                const Batch::Status status = w.batch.run(c);
                if (status == Batch::Status::diverged) {
                    const std::vector<std::vector<std::uint32_t>> ways = w.batch.ways(c);
                    for (auto way = ways.rbegin(); way != ways.rend(); ++way) {  // the first way runs first
                        Work part{w.batch.split(*way), gather_lanes(w.shared, n, *way), {}};
                        for (const std::uint32_t l : *way) part.primitives.push_back(w.primitives[l]);
                        work.push_back(std::move(part));
                    }
                    return;
                }
                if (status == Batch::Status::emit) {
                    for (std::uint32_t l = 0; l < n; ++l) {
                        const std::size_t k = w.primitives[l];
                        if (emitted[k]++ >= layout.max_vertices) {
                            if (!dropped && state_->options.warnings)
                                state_->options.warnings->push_back("warning: EmitVertex() past max_vertices = " +
                                                                    std::to_string(layout.max_vertices) +
                                                                    ", the vertex is dropped (" + name + ")");
                            dropped = true;
                            continue;
                        }
                        ShaderVertex vertex;
                        for (const Variable& v : m.variables) {
                            if (!is_output(v)) continue;
                            const std::uint32_t size = m.types[v.type].words;
                            words.resize(size);
                            for (std::uint32_t j = 0; j < size; ++j) words[j] = w.shared[(v.address + j) * n + l];
                            read_vertex(v, words.data(), vertex);
                        }
                        out[k].vertices.push_back(std::move(vertex));
                    }
                    continue;
                }
                if (status == Batch::Status::end_primitive || status == Batch::Status::done) {
                    for (std::uint32_t l = 0; l < n; ++l) {
                        const std::size_t k = w.primitives[l];
                        assemble(out[k], strip[k]);
                        strip[k] = static_cast<std::uint32_t>(out[k].vertices.size());
                    }
                    if (status == Batch::Status::done) return;
                    continue;
                }
                throw Error("the " + name + " stopped at a barrier or discard outside a control or fragment shader",
                            Where::in_file(m.path));
            }
        };
        const std::size_t chunk = state_->options.observer ? 1 : kBatchLanes;
        // As the evaluation does: the next batches of as many lanes reuse the first one's
        // registers (Batch::restart), with the memory written afresh.
        std::optional<Work> reused;
        for (std::size_t first = 0; first < count; first += chunk) {
            const std::uint32_t lanes = static_cast<std::uint32_t>(std::min(chunk, count - first));
            if (reused && reused->batch.lanes() == lanes) {
                reused->batch.restart();
                reused->shared = broadcast_lanes(one, lanes);
                reused->primitives.clear();
            } else {
                reused.emplace(Work{Batch(m, lanes), broadcast_lanes(one, lanes), {}});
            }
            Work& fresh = *reused;
            for (std::uint32_t l = 0; l < lanes; ++l) {
                const std::size_t k = first + l;
                fresh.primitives.push_back(k);
                for (const Variable& v : m.variables) {
                    if (!is_input(v) || !v.arrayed || v.builtin == spv::BuiltInInvocationId) continue;
                    // gl_in[] and the input blocks: one element per vertex of the primitive
                    words.assign(v.vertices * v.element_words, 0);
                    for (std::uint32_t j = 0; j < words.size(); ++j) words[j] = one[v.address + j];
                    for (std::uint32_t j = 0; j < v.vertices && j < per_input; ++j)
                        write_input(v, &words[j * v.element_words], indices[k * per_input + j]);
                    for (std::uint32_t j = 0; j < words.size(); ++j) fresh.shared[(v.address + j) * lanes + l] = words[j];
                }
            }
            run(fresh);
            while (!work.empty()) {
                Work w = std::move(work.back());
                work.pop_back();
                run(w);
            }
        }
    }
}

}  // namespace tessref::shader
