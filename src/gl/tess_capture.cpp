// Transform-feedback capture of what the GL primitive generator emits (OSMesa / llvmpipe).
//
// Pipeline per draw: one vertex per patch carries the six level bits
// (data/shaders/capture_tess_coord.vert) -> the control shader writes them as levels
// (.tesc) -> the fixed-function generator -> the evaluation shader (.tese) outputs
// gl_TessCoord and gl_PrimitiveID -> transform feedback, rasterizer discarded.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "gl/gl_api.h"
#include "gl/program.h"
#include "tessref/error.h"

namespace tessref::gl {

namespace {

// llvmpipe corrupts tessellated draws that produce a few hundred thousand primitives
// (TESSELLATION.md, last section); every draw stays under this many, counted with the
// worst case of each patch.
constexpr std::size_t kMaxPrimitivesPerDraw = 32768;
// The worst case of one patch: see primitive_bound.
constexpr std::size_t kMaxPrimitivesPerPatch = 2 * 64 * 64 + 6 * 64;

// One transform-feedback record, as the interleaved varyings lay it out.
struct FeedbackVertex {
    float tess_coord[3];
    std::int32_t patch_id;
};
static_assert(sizeof(FeedbackVertex) == 16);

int vertices_per_primitive(const TessSettings& s) {
    if (s.point_mode) return 1;
    return s.domain == Domain::isolines ? 2 : 3;
}

GLenum feedback_mode(const TessSettings& s) {
    if (s.point_mode) return GL_POINTS;
    return s.domain == Domain::isolines ? GL_LINES : GL_TRIANGLES;
}

// One stage of the capture program; `defines` go right after the #version line.
StageSource capture_stage(GLenum stage, const std::string& file, const std::string& defines = "") {
    StageSource s;
    s.stage = stage;
    s.path = shader_data_dir() + "/shaders/" + file;
    s.text = read_shader(file);
    s.prefix = defines;
    return s;
}

GLuint capture_program(Context::Impl& c, const TessSettings& s) {
    const auto key = std::make_tuple(static_cast<int>(s.domain), static_cast<int>(s.spacing),
                                     static_cast<int>(s.winding), s.point_mode);
    if (auto it = c.programs.find(key); it != c.programs.end()) return it->second.program;

    std::string tese_defines = std::string("#define TESSREF_DOMAIN ") +
                               domain_qualifier(s.domain) + "\n#define TESSREF_SPACING " +
                               spacing_qualifier(s.spacing) + "\n#define TESSREF_WINDING " +
                               (s.winding == Winding::cw ? "cw" : "ccw") + "\n";
    if (s.point_mode) tese_defines += "#define TESSREF_POINT_MODE\n";

    const GLuint program =
        link(c.gl, {capture_stage(GL_VERTEX_SHADER, "capture_tess_coord.vert"),
                    capture_stage(GL_TESS_CONTROL_SHADER, "capture_tess_coord.tesc"),
                    capture_stage(GL_TESS_EVALUATION_SHADER, "capture_tess_coord.tese", tese_defines)},
             {"tess_coord", "patch_id"}, "the tess-coord capture program");
    c.check_error("building the capture program");
    c.programs[key].program = program;
    return program;
}

// Number of segments a level can give at most: the clamp range tops at 64, parity adds
// at most one, NaN clamps to the low end.
std::size_t segment_bound(float level) {
    if (!(level >= 1.0f)) return 1;  // NaN and everything below 1 clamp to the low end (<= 2)
    if (level >= 64.0f) return 64;
    return std::min<std::size_t>(64, static_cast<std::size_t>(std::ceil(level)) + 1);
}

// An upper bound of the primitives one patch emits (exact counts are the generator's job;
// this only sizes draws). Culled patches (an outer level that is NaN or <= 0) emit none.
std::size_t primitive_bound(const TessSettings& s, const TessLevels& levels) {
    const int outer_used = s.domain == Domain::quads ? 4 : s.domain == Domain::triangles ? 3 : 2;
    std::size_t m = 3;  // inner point counts are at least 3 or 4 per axis
    for (int i = 0; i < outer_used; ++i) {
        const float x = levels.outer[static_cast<std::size_t>(i)];
        if (!(x > 0.0f)) return 0;
        m = std::max(m, segment_bound(x));
    }
    if (s.domain != Domain::isolines)
        for (float x : levels.inner) m = std::max(m, segment_bound(x));
    return 2 * m * m + 6 * m;  // quads: 2(i0-2)(i1-2)+2(i0-2)+2(i1-2)+sum(outer) <= 2m^2+4m
}

void ensure_objects(Context::Impl& c) {
    auto& gl = c.gl;
    if (c.vertex_array) return;
    gl.GenVertexArrays(1, &c.vertex_array);
    gl.GenBuffers(1, &c.level_buffer);
    gl.GenBuffers(1, &c.feedback_buffer);
    gl.GenQueries(1, &c.query_generated);
    gl.GenQueries(1, &c.query_written);
    gl.BindVertexArray(c.vertex_array);
    gl.BindBuffer(GL_ARRAY_BUFFER, c.level_buffer);
    gl.VertexAttribIPointer(0, 4, GL_UNSIGNED_INT, 6 * sizeof(std::uint32_t), nullptr);
    gl.VertexAttribIPointer(1, 2, GL_UNSIGNED_INT, 6 * sizeof(std::uint32_t),
                            reinterpret_cast<const void*>(4 * sizeof(std::uint32_t)));
    gl.EnableVertexAttribArray(0);
    gl.EnableVertexAttribArray(1);
    c.check_error("creating the capture buffers");
}

}  // namespace

std::vector<CapturedPatch> capture_patterns(Context& context, const TessSettings& settings,
                                            std::span<const TessLevels> level_sets) {
    Context::Impl& c = context.impl();
    c.make_current();
    auto& gl = c.gl;
    const GLuint program = capture_program(c, settings);
    ensure_objects(c);

    const int vpp = vertices_per_primitive(settings);
    std::vector<CapturedPatch> result(level_sets.size());
    for (auto& patch : result) patch.vertices_per_primitive = vpp;
    if (level_sets.empty()) return result;

    // Every patch's levels, as bits, in one buffer; draws take consecutive ranges.
    std::vector<std::uint32_t> bits(level_sets.size() * 6);
    for (std::size_t i = 0; i < level_sets.size(); ++i) {
        std::memcpy(&bits[i * 6], level_sets[i].outer.data(), 4 * sizeof(float));
        std::memcpy(&bits[i * 6 + 4], level_sets[i].inner.data(), 2 * sizeof(float));
    }
    gl.BindVertexArray(c.vertex_array);
    gl.BindBuffer(GL_ARRAY_BUFFER, c.level_buffer);
    gl.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(bits.size() * sizeof(std::uint32_t)),
                  bits.data(), GL_STATIC_DRAW);

    // Room for a full batch plus one worst-case patch of slack: an overflow is still
    // detected by the queries, this only keeps it from happening when a bound is tight.
    const GLsizeiptr capacity = static_cast<GLsizeiptr>(
        (kMaxPrimitivesPerDraw + kMaxPrimitivesPerPatch) * vpp * sizeof(FeedbackVertex));
    gl.BindBuffer(GL_TRANSFORM_FEEDBACK_BUFFER, c.feedback_buffer);
    if (c.feedback_capacity < capacity) {
        gl.BufferData(GL_TRANSFORM_FEEDBACK_BUFFER, capacity, nullptr, GL_STREAM_READ);
        c.feedback_capacity = capacity;
    }
    gl.BindBufferBase(GL_TRANSFORM_FEEDBACK_BUFFER, 0, c.feedback_buffer);
    gl.UseProgram(program);
    gl.PatchParameteri(GL_PATCH_VERTICES, 1);
    gl.Enable(GL_RASTERIZER_DISCARD);
    c.check_error("setting up the capture");

    const GLuint buffer_primitives = static_cast<GLuint>(
        static_cast<std::size_t>(c.feedback_capacity) / (vpp * sizeof(FeedbackVertex)));
    std::size_t first = 0;
    while (first < level_sets.size()) {
        // The batch: as many patches as fit the per-draw primitive budget (at least one).
        std::size_t count = 0, budget = 0;
        while (first + count < level_sets.size()) {
            const std::size_t bound = primitive_bound(settings, level_sets[first + count]);
            if (count > 0 && budget + bound > kMaxPrimitivesPerDraw) break;
            budget += bound;
            ++count;
        }

        gl.BeginQuery(GL_PRIMITIVES_GENERATED, c.query_generated);
        gl.BeginQuery(GL_TRANSFORM_FEEDBACK_PRIMITIVES_WRITTEN, c.query_written);
        gl.BeginTransformFeedback(feedback_mode(settings));
        gl.DrawArrays(GL_PATCHES, static_cast<GLint>(first), static_cast<GLsizei>(count));
        gl.EndTransformFeedback();
        gl.EndQuery(GL_TRANSFORM_FEEDBACK_PRIMITIVES_WRITTEN);
        gl.EndQuery(GL_PRIMITIVES_GENERATED);
        GLuint generated = 0, written = 0;
        gl.GetQueryObjectuiv(c.query_generated, GL_QUERY_RESULT, &generated);
        gl.GetQueryObjectuiv(c.query_written, GL_QUERY_RESULT, &written);
        c.check_error("the capture draw");

        const auto batch_error = [&](const std::string& what) {
            return Error(what + " (draw of patches " + std::to_string(first) + ".." +
                             std::to_string(first + count - 1) + ", " + std::to_string(generated) +
                             " primitives generated, " + std::to_string(written) + " written)",
                         Where::at_patch(static_cast<long long>(first)));
        };
        if (generated != written || written > buffer_primitives)
            throw batch_error("transform feedback overflowed");

        if (written > 0) {
            const auto bytes = static_cast<GLsizeiptr>(written) * vpp *
                               static_cast<GLsizeiptr>(sizeof(FeedbackVertex));
            const void* mapped =
                gl.MapBufferRange(GL_TRANSFORM_FEEDBACK_BUFFER, 0, bytes, GL_MAP_READ_BIT);
            if (!mapped) {
                c.check_error("mapping the transform feedback buffer");
                throw batch_error("cannot map the transform feedback buffer");
            }
            std::vector<FeedbackVertex> records(static_cast<std::size_t>(written) * vpp);
            std::memcpy(records.data(), mapped, records.size() * sizeof(FeedbackVertex));
            gl.UnmapBuffer(GL_TRANSFORM_FEEDBACK_BUFFER);

            for (std::size_t p = 0; p < written; ++p) {
                const FeedbackVertex* prim = &records[p * vpp];
                const std::int32_t id = prim[0].patch_id;
                bool consistent = id >= 0 && static_cast<std::size_t>(id) < count;
                for (int k = 1; k < vpp; ++k) consistent = consistent && prim[k].patch_id == id;
                if (!consistent)
                    throw batch_error("transform feedback primitive " + std::to_string(p) +
                                      " has a gl_PrimitiveID outside the draw (" +
                                      std::to_string(id) + ")");
                auto& out = result[first + static_cast<std::size_t>(id)].vertices;
                for (int k = 0; k < vpp; ++k)
                    out.push_back(TessCoord{prim[k].tess_coord[0], prim[k].tess_coord[1],
                                            prim[k].tess_coord[2]});
            }
        }
        first += count;
    }
    gl.Disable(GL_RASTERIZER_DISCARD);
    c.check_error("reading the capture back");
    for (auto& patch : result) patch.emitted_nothing = patch.vertices.empty();
    return result;
}

CapturedPatch capture_pattern(Context& context, const TessSettings& settings,
                              const TessLevels& levels) {
    return capture_patterns(context, settings, std::span<const TessLevels>(&levels, 1)).front();
}

std::string dump(const CapturedPatch& patch) {
    std::string out;
    char line[160];
    std::snprintf(line, sizeof line, "%zu primitives of %d vertices%s\n", patch.primitive_count(),
                  patch.vertices_per_primitive, patch.emitted_nothing ? " (nothing emitted)" : "");
    out += line;
    const auto bits = [](float f) {
        std::uint32_t b;
        std::memcpy(&b, &f, sizeof b);
        return b;
    };
    for (std::size_t p = 0; p < patch.primitive_count(); ++p) {
        std::snprintf(line, sizeof line, "%zu:", p);
        out += line;
        for (int k = 0; k < patch.vertices_per_primitive; ++k) {
            const TessCoord& v = patch.vertices[p * patch.vertices_per_primitive + k];
            std::snprintf(line, sizeof line, " (%.9g %.9g %.9g | %08x %08x %08x)", v.u, v.v, v.w,
                          bits(v.u), bits(v.v), bits(v.w));
            out += line;
        }
        out += '\n';
    }
    return out;
}

}  // namespace tessref::gl
