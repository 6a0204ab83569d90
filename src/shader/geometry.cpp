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

}  // namespace tessref::shader
