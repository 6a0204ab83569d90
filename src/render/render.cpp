// The renderer: scene -> pipeline -> gl_Position -> rasterizer -> fragment stage (render.h).
#include "tessref/render.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <mutex>
#include <span>
#include <unordered_map>
#include <string>
#include <utility>

#include "common/huge_pages.h"
#include "common/parallel.h"
#include "common/unorm8.h"

#include "pipeline/gl_position.h"
#include "render/render_internal.h"
#include "render/user_fragment.h"
#include "tessref/compare.h"
#include "tessref/error.h"
#include "tessref/limits.h"

namespace tessref {

using render_detail::Derivatives;
using render_detail::perspective_weights;
using render_detail::pixel_ndc;
using render_detail::window_depth;
using pipeline::gl_position;

namespace render_detail {

void allocate(RenderResult& r, int width, int height, bool visibility, bool provenance, bool colour8) {
    r.width = width;
    r.height = height;
    const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    if (colour8) {
        glm::u8vec4 background;
        unorm8_rgba(&r.shading.background[0], &background[0]);
        assign_on_huge_pages(r.rgba8, n, background);
    } else {
        assign_on_huge_pages(r.colour, n, r.shading.background);
    }
    if (provenance) {
        assign_on_huge_pages(r.patch_id, n, kNoPixelId);
        assign_on_huge_pages(r.tess_coord, n, glm::vec3(0.0f));
        assign_on_huge_pages(r.barycentric, n, glm::vec3(0.0f));
        assign_on_huge_pages(r.level, n, std::numeric_limits<float>::quiet_NaN());
    }
    if (!visibility) return;
    assign_on_huge_pages(r.depth, n, 1.0f);
    assign_on_huge_pages(r.triangle_id, n, kNoPixelId);
}

void keep_colour8(RenderResult& r) {
    r.rgba8.resize(r.colour.size());
    to_rgba8(r, reinterpret_cast<std::uint8_t*>(r.rgba8.data()));
    std::vector<glm::vec4>().swap(r.colour);
}

void take_visibility(RenderResult& r, Framebuffer& fb) {
    r.depth = std::move(fb.depth);
    r.triangle_id = std::move(fb.triangle_id);
}

SceneCamera camera_for(const Scene& scene, const RenderOptions& options) {
    if (!scene.camera) {
        throw Error("rendering needs a [camera] in the scene", Where::at_key(scene.file, "camera"));
    }
    SceneCamera camera = *scene.camera;
    if (options.size != glm::ivec2(0, 0)) camera.viewport = options.size;
    const glm::ivec2 s = camera.viewport;
    if (s.x < 1 || s.y < 1 || s.x > 16384 || s.y > 16384)
        throw Error("image size " + std::to_string(s.x) + "x" + std::to_string(s.y) + " is outside 1..16384",
                    Where::at_key("size"));
    return camera;
}

}  // namespace render_detail

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
}

// Everything the per-pixel passes read of the triangles a pass drew: the whole surface
// (run_pipeline's mesh) or the patches of one streamed chunk (then triangle indices are the
// chunk's and positions the evaluation's, relative to origin when camera-relative).
struct SurfaceView {
    const SurfaceMesh& mesh;
    // mesh.triangles, or for a streamed chunk of one patch the pattern's own
    // (PatchStream::shared_triangles), which emit() then does not copy.
    std::span<const std::array<std::uint32_t, 3>> triangles;
    const std::vector<glm::dvec3>& face_normals;  // per triangle with [geometry] normals = "face"
    const std::vector<glm::vec4>& clip;
    bool use_face_normals = false;
    glm::dvec3 origin{0.0};  // added to mesh positions (in double) to make world positions

    std::array<glm::dvec4, 3> clip_corners(std::uint32_t triangle) const {
        const auto& t = triangles[triangle];
        return {glm::dvec4(clip[t[0]]), glm::dvec4(clip[t[1]]), glm::dvec4(clip[t[2]])};
    }
    // texCoord of the triangle at weights b, in float as a varying is interpolated.
    glm::vec2 uv_at(std::uint32_t triangle, const glm::vec3& b) const {
        const auto& t = triangles[triangle];
        return b[0] * glm::vec2(mesh.uvs[t[0]]) + b[1] * glm::vec2(mesh.uvs[t[1]]) + b[2] * glm::vec2(mesh.uvs[t[2]]);
    }
    glm::vec3 world(std::uint32_t vertex) const { return glm::vec3(mesh.positions[vertex] + origin); }
    render_detail::QuadTriangle quad_triangle(std::uint32_t triangle) const {
        const auto& t = triangles[triangle];
        return {{clip[t[0]], clip[t[1]], clip[t[2]]},
                {glm::vec2(mesh.uvs[t[0]]), glm::vec2(mesh.uvs[t[1]]), glm::vec2(mesh.uvs[t[2]])}};
    }
};

// The fragment inputs of a pixel whose visible triangle and weights are known, written into
// f where the model needs them (the others keep f's values; the texture coordinate's
// derivatives are the caller's: quad_derivatives).
void fragment_inputs(const SurfaceView& s, const FragmentNeeds& needs, std::uint32_t triangle, const glm::vec3& b,
                     float depth, FragmentInputs& f) {
    const auto& t = s.triangles[triangle];
    f.depth = depth;
    if (needs.worldPosition) f.worldPosition = b[0] * s.world(t[0]) + b[1] * s.world(t[1]) + b[2] * s.world(t[2]);
    if (needs.normal) {
        if (s.use_face_normals) {
            f.normal = glm::vec3(s.face_normals[triangle]);
        } else if (!s.mesh.normals.empty()) {
            f.normal = b[0] * glm::vec3(s.mesh.normals[t[0]]) + b[1] * glm::vec3(s.mesh.normals[t[1]]) +
                       b[2] * glm::vec3(s.mesh.normals[t[2]]);
        }
    }
    if (needs.texCoord && !s.mesh.uvs.empty()) f.texCoord = s.uv_at(triangle, b);
    if (needs.uv_derivatives && !s.mesh.uvs.empty()) {
        // pom.frag's dFdx/dFdy of position and uv, solved per triangle (parallax.h)
        const UvDerivatives d = triangle_uv_derivatives(s.world(t[0]), s.world(t[1]), s.world(t[2]),
                                                        glm::vec2(s.mesh.uvs[t[0]]), glm::vec2(s.mesh.uvs[t[1]]),
                                                        glm::vec2(s.mesh.uvs[t[2]]));
        f.dPdu = d.dPdu;
        f.dPdv = d.dPdv;
    }
}

// Window depth of the triangle's plane at the centre of pixel (x, row).
double plane_depth(const std::array<glm::dvec4, 3>& c, int x, int row, int width, int height) {
    const glm::dvec3 w = perspective_weights(c, pixel_ndc(x, row, width, height));
    return window_depth(w.x * c[0] + w.y * c[1] + w.z * c[2]);
}

}  // namespace


namespace {

// render.h's LEVEL rule for a triangle with these tess coords in a patch with these levels.
float level_of(const TessLevels& levels, Domain domain, const std::array<glm::vec3, 3>& tess_coords,
               std::string* source) {
    const int edges = domain == Domain::quads ? 4 : 3;
    int best_edge = -1, best_count = 0;
    for (int e = 0; e < edges; ++e) {
        int count = 0;
        for (const glm::vec3& c : tess_coords) count += on_outer_edge(domain, TessCoord{c.x, c.y, c.z}, e) ? 1 : 0;
        if (count > best_count) {
            best_count = count;
            best_edge = e;
        }
    }
    if (best_edge >= 0) {
        if (source) *source = "outer[" + std::to_string(best_edge) + "]";
        return levels.outer[static_cast<std::size_t>(best_edge)];
    }
    if (source) *source = "inner";
    return domain == Domain::quads ? std::max(levels.inner[0], levels.inner[1]) : levels.inner[0];
}

// The same for the triangle of mesh's vertices t.
float level_of(const SurfaceMesh& mesh, const std::vector<TessLevels>& levels, Domain domain,
               const std::array<std::uint32_t, 3>& t, std::string* source = nullptr) {
    return level_of(levels.at(mesh.patch_ids[t[0]]), domain,
                    {mesh.tess_coords[t[0]], mesh.tess_coords[t[1]], mesh.tess_coords[t[2]]}, source);
}


// The triangle ids [first, first + count) a pass drew. The resolve skips the others on the
// id alone, a quad at a time: a streamed batch's drawn rectangles hold pixels of other
// batches too.
struct IdRange {
    std::uint32_t first = 0, count = 0;
    bool holds(std::uint32_t id) const { return id - first < count; }  // unsigned: below first wraps
};

// The visible-surface buffers of RenderResult and the fragment stage's colour, for the pixels of
// quad rows [quad_row_begin, quad_row_end) and columns [x_begin, x_end) (even) whose visible triangle (id) is in a view that
// owns(id) returns, with the triangle's index in it (null: not this pass's), and whose weights
// `weights` holds. Quad by quad (2x2 pixels, as llvmpipe shades): the pixels of a quad that
// show the same triangle share its derivatives and level.
template <typename Owns>
void resolve(RenderResult& result, const Framebuffer& fb, const WeightsView& weights,
             const std::vector<TessLevels>& levels, Domain domain, const FragmentNeeds& needs, bool derivatives,
             bool line_derivatives, bool provenance, int quad_row_begin, int quad_row_end, IdRange ids,
             const Owns& owns, int x_begin = 0, int x_end = -1) {
    const int width = result.width, height = result.height;
    if (x_end < 0) x_end = width;
    const bool colour8 = result.colour.empty();  // RenderOptions::colour8: the codes only
    for (int quad_row = quad_row_begin; quad_row < quad_row_end; ++quad_row) {
        const int row0 = 2 * quad_row;
        const std::uint32_t* top = &fb.triangle_id[result.index(0, row0)];
        const std::uint32_t* bottom = row0 + 1 < height ? top + width : top;  // a last odd row: itself again
        for (int x0 = x_begin; x0 < x_end; x0 += 2) {
            const int x1 = std::min(x0 + 1, width - 1);  // a last odd column: itself again
            if (!(ids.holds(top[x0]) | ids.holds(top[x1]) | ids.holds(bottom[x0]) | ids.holds(bottom[x1]))) continue;
            // The quad's pixels this pass resolves and the distinct triangles they show, first:
            // the triangles' derivatives are then computed together.
            struct Pixel {
                std::size_t i;
                int x, row;
                const SurfaceView* view;
                std::uint32_t triangle;
                int k;  // its triangle among the quad's
            };
            Pixel pixels[4];
            std::uint32_t triangle_ids[4];
            render_detail::QuadTriangle triangles[4];
            float triangle_levels[4];
            int pixel_count = 0, triangle_count = 0;
            for (int row = row0; row < std::min(row0 + 2, height); ++row) {
                for (int x = x0; x < std::min(x0 + 2, width); ++x) {
                    const std::size_t i = result.index(x, row);  // the framebuffer's layout too
                    const std::uint32_t id = fb.triangle_id[i];
                    if (!ids.holds(id)) continue;
                    const auto [view, tri] = owns(id);
                    if (!view) continue;
                    int k = 0;
                    while (k < triangle_count && triangle_ids[k] != id) ++k;
                    if (k == triangle_count) {
                        triangle_ids[k] = id;
                        if (provenance) triangle_levels[k] = level_of(view->mesh, levels, domain, view->triangles[tri]);
                        if (derivatives && !line_derivatives) triangles[k] = view->quad_triangle(tri);
                        ++triangle_count;
                    }
                    pixels[pixel_count++] = {i, x, row, view, tri, k};
                }
            }
            Derivatives quad[4];
            if (derivatives && !line_derivatives)
                render_detail::quad_derivatives(triangles, triangle_count,
                                                {pixel_ndc(x0, row0, width, height),
                                                 pixel_ndc(x0 + 1, row0 + 1, width, height)},
                                                quad);
            FragmentInputs fragments[4];  // the inputs a model does not read at their defaults
            for (int p = 0; p < pixel_count; ++p) {
                const auto [i, x, row, view_of, tri, k] = pixels[p];
                const SurfaceView& view = *view_of;
                const glm::vec3 b = weights.at(x, row);
                if (provenance) {
                    const auto& t = view.triangles[tri];
                    result.barycentric[i] = b;
                    result.patch_id[i] = view.mesh.patch_ids[t[0]];
                    result.tess_coord[i] = b[0] * view.mesh.tess_coords[t[0]] + b[1] * view.mesh.tess_coords[t[1]] +
                                           b[2] * view.mesh.tess_coords[t[2]];
                    result.level[i] = triangle_levels[k];
                }
                FragmentInputs& f = fragments[p];
                fragment_inputs(view, needs, tri, b, fb.depth[i], f);
                if (line_derivatives) {
                    // Per pixel: two edges of one triangle in a quad are two lines.
                    // uv_at is linear: the weights' differences give the uv's.
                    f.texCoord_dx = view.uv_at(tri, fb.barycentric_dx[i]);
                    f.texCoord_dy = view.uv_at(tri, fb.barycentric_dy[i]);
                } else {
                    f.texCoord_dx = quad[k].dx;
                    f.texCoord_dy = quad[k].dy;
                }
            }
            // The quad's fragments shaded together, as llvmpipe runs a quad's shader.
            glm::vec4 colours[4];
            const auto count = static_cast<std::size_t>(pixel_count);
            shade(result.shading.model, std::span<const FragmentInputs>(fragments, count),
                  std::span<glm::vec4>(colours, count));
            if (colour8) {
                for (int p = 0; p < pixel_count; ++p) unorm8_rgba(&colours[p][0], &result.rgba8[pixels[p].i][0]);
            } else {
                for (int p = 0; p < pixel_count; ++p) result.colour[pixels[p].i] = colours[p];
            }
        }
    }
}

// The pixels with a visible surface.
std::uint64_t covered_pixels(const RenderResult& result) {
    // In parallel: between the render and the image write, where nothing else runs.
    const std::uint32_t* ids = result.triangle_id.data();
    return tessref::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, result.triangle_id.size(), 65536), std::uint64_t{0},
        [&](const tbb::blocked_range<std::size_t>& r, std::uint64_t n) {
            for (std::size_t i = r.begin(); i < r.end(); ++i) n += ids[i] != kNoPixelId;
            return n;
        },
        std::plus<>());
}

}  // namespace

float triangle_level(const PipelineResult& pipeline, Domain domain, std::uint32_t triangle, std::string* source) {
    return level_of(pipeline.mesh, pipeline.levels, domain, pipeline.mesh.triangles.at(triangle), source);
}

namespace {

// A few patches of a streamed surface, evaluated, projected and drawn together: storage
// reused from batch to batch.
struct PatchChunk {
    std::size_t first_patch = 0, last_patch = 0;
    std::uint32_t first_triangle = 0;
    SurfaceMesh mesh;
    // mesh.triangles, or for a chunk of one patch whose triangles are its pattern's, those
    // (PatchStream::shared_triangles): emit() copied and offset every one of them, most of
    // which the box test rejects (5 % of the render at level 63, 8192 triangles a patch).
    std::span<const std::array<std::uint32_t, 3>> triangles;
    bool shared_triangles = false;  // triangles are the pattern's (below its point count)
    std::span<const TriangleBlock> blocks;  // the pattern's triangle_blocks, with shared_triangles
    std::vector<glm::dvec3> face_normals;
    std::vector<glm::vec4> clip;
    // Per vertex, with deferred vertex normals: whether a triangle of it won a pixel in this
    // batch's draw (then its normal is computed before the resolve reads it).
    std::vector<std::uint8_t> wins;
    bool finite = true;
};

// Triangles per chunk (a chunk is one setup task) and per batch (what is evaluated and
// held at once: about 100 bytes a vertex, half a vertex per triangle, so 2^16 triangles
// hold about 4 MB). The resolve reads the batch's vertices in pixel order, not in the
// order they were written: a batch near the size of a core's L2 cache (2 MB here) keeps
// those reads out of memory. Measured on the bench terrain (bench/scenes), median CPU time
// of `tessref render --threads 1`: level 16 507 ms at 2^18, 455 ms at 2^16; level 63
// 2356 -> 1817 ms; 2^15 was no better than 2^16 at level 16 and worse at 63. A batch holds
// at least 2^15 triangles a worker thread, so that every worker has chunks (and its own
// L2 cache's worth) in each of the batch's parallel steps.
constexpr std::size_t kStreamChunkTriangles = 8192;
constexpr std::size_t kStreamBatchTriangles = std::size_t{1} << 16;
constexpr std::size_t kStreamBatchTrianglesPerThread = std::size_t{1} << 15;
// Vertex normals are deferred to the vertices of winning triangles above this many
// triangles a pixel (render_streamed).
constexpr std::uint64_t kDeferNormalsTrianglesPerPixel = 8;

// triangle_blocks of each pattern whose own triangles chunks are drawn from (PatchStream::
// shared_triangles), made the first time a chunk asks: at a uniform level one pattern serves
// every patch, so its blocks are made once for the whole render.
class SharedBlocks {
public:
    std::span<const TriangleBlock> of(std::span<const std::array<std::uint32_t, 3>> triangles) {
        const std::lock_guard<std::mutex> lock(mutex_);
        std::vector<TriangleBlock>& blocks = made_[triangles.data()];
        if (blocks.empty()) blocks = triangle_blocks(triangles);
        return blocks;
    }

private:
    std::mutex mutex_;
    std::unordered_map<const void*, std::vector<TriangleBlock>> made_;  // by the pattern's triangles
};

// The next batch's chunk boundaries, in patch order, from `next_patch` on: runs of whole
// patches of about kStreamChunkTriangles triangles until the batch holds `batch_size`.
// Reuses `chunks`' storage; returns how many chunks the batch has, and moves next_patch on.
std::size_t plan_batch(const PatchStream& stream, std::size_t& next_patch, std::size_t batch_size,
                       std::vector<PatchChunk>& chunks) {
    chunks.reserve(64);
    std::size_t used = 0, batch_triangles = 0;
    while (next_patch < stream.patch_count() && batch_triangles < batch_size) {
        if (chunks.size() <= used) chunks.emplace_back();
        PatchChunk& c = chunks[used++];
        c.first_patch = next_patch;
        c.first_triangle = static_cast<std::uint32_t>(stream.triangle_base(next_patch));
        next_patch = c.last_patch = stream.run_end(next_patch, kStreamChunkTriangles);
        batch_triangles += stream.triangle_base(c.last_patch) - c.first_triangle;
    }
    return used;
}

// Evaluates and projects a chunk's patches (pass 4 of the pipeline, with gl_Position of each
// block of points as it is evaluated: PatchStream::Projection), noting whether every vertex
// is finite.
void evaluate_chunk(const PatchStream& stream, PatchChunk& c, const glm::mat4& mvp, bool positions,
                    PatchStream::VertexNormals normals_mode, PatchStream::Provenance provenance,
                    SharedBlocks& shared_blocks) {
    SurfaceMesh& m = c.mesh;
    const auto shared = c.last_patch == c.first_patch + 1 ? stream.shared_triangles(c.first_patch)
                                                          : std::span<const std::array<std::uint32_t, 3>>();
    c.clip.resize(stream.vertex_base(c.last_patch) - stream.vertex_base(c.first_patch));
    PatchStream::Projection projection{mvp, c.clip.data(), positions};
    stream.emit_run(c.first_patch, c.last_patch, m, &c.face_normals, normals_mode, provenance,
                    shared.empty() ? PatchStream::Triangles::write : PatchStream::Triangles::shared, &projection);
    c.finite = projection.finite;
    c.triangles = shared.empty() ? std::span<const std::array<std::uint32_t, 3>>(m.triangles) : shared;
    c.shared_triangles = !shared.empty();
    c.blocks = shared.empty() ? std::span<const TriangleBlock>() : shared_blocks.of(shared);
    if (normals_mode == PatchStream::VertexNormals::later) c.wins.assign(m.positions.size(), 0);
}

// A triangle id of a batch: its chunk and its index there; the chunk count for an id outside
// the batch. Asked for every resolved pixel: per block of 2^10 ids, the chunk that holds the
// block's first id, and from there the chunks that start inside the block, in order (chunks
// hold about kStreamChunkTriangles, so a block holds one start at most but for small chunks:
// a load and a compare instead of a binary search).
class BatchIds {
public:
    BatchIds(std::span<const PatchChunk> chunks, std::uint32_t batch_end)
        : batch_{chunks.front().first_triangle, batch_end - chunks.front().first_triangle} {
        for (const PatchChunk& c : chunks) chunk_first_.push_back(c.first_triangle);
        block_chunk_.resize((std::size_t{batch_.count} + (1u << kIdBlockBits) - 1) >> kIdBlockBits);
        for (std::size_t b = 0, k = 0; b < block_chunk_.size(); ++b) {
            const std::uint32_t first = batch_.first + static_cast<std::uint32_t>(b << kIdBlockBits);
            while (k + 1 < chunk_first_.size() && chunk_first_[k + 1] <= first) ++k;
            block_chunk_[b] = static_cast<std::uint32_t>(k);
        }
    }
    IdRange range() const { return batch_; }
    std::size_t none() const { return chunk_first_.size(); }
    std::pair<std::size_t, std::uint32_t> find(std::uint32_t id) const {
        if (!batch_.holds(id)) return {none(), 0};
        std::size_t k = block_chunk_[(id - batch_.first) >> kIdBlockBits];
        while (k + 1 < chunk_first_.size() && chunk_first_[k + 1] <= id) ++k;
        return {k, id - chunk_first_[k]};
    }

private:
    static constexpr int kIdBlockBits = 10;
    IdRange batch_;
    std::vector<std::uint32_t> chunk_first_;
    std::vector<std::uint32_t> block_chunk_;
};

// The deferred vertex normals of the vertices the resolve reads: every pixel of the whole
// quads it visits in the rectangles the draw changed (a superset does no harm) marks its
// triangle's vertices; then their normals are computed chunk by chunk by
// PatchStream::later_normals, so every value is the one emit() would have written.
void complete_normals(const PatchStream& stream, std::span<PatchChunk> chunks, const BatchIds& ids,
                      const Framebuffer& fb, const RenderResult& result,
                      const std::vector<Rasterizer::Rect>& drawn) {
    const int width = result.width, height = result.height;
    tessref::parallel_for(std::size_t{0}, drawn.size(), [&](std::size_t r) {
        const Rasterizer::Rect& rect = drawn[r];
        const int row_end = std::min(2 * ((rect.row + rect.height + 1) / 2), height);
        const int x_end = std::min(rect.x + 2 * ((rect.width + 1) / 2), width);
        for (int row = 2 * (rect.row / 2); row < row_end; ++row) {
            for (int x = rect.x; x < x_end; ++x) {
                const auto [k, tri] = ids.find(fb.triangle_id[result.index(x, row)]);
                if (k == ids.none()) continue;
                PatchChunk& c = chunks[k];
                for (const std::uint32_t v : c.triangles[tri])
                    std::atomic_ref<std::uint8_t>(c.wins[v]).store(1, std::memory_order_relaxed);
            }
        }
    });
    tessref::parallel_for(std::size_t{0}, chunks.size(), [&](std::size_t k) {
        PatchChunk& c = chunks[k];
        const std::size_t v0 = stream.vertex_base(c.first_patch);
        std::vector<std::uint32_t> points;
        const std::uint8_t* const wins = c.wins.data();
        for (std::size_t p = c.first_patch; p < c.last_patch; ++p) {
            const std::size_t first = stream.vertex_base(p) - v0, end = stream.vertex_base(p + 1) - v0;
            // The winning vertices' indices in the patch, in order, without a branch on each
            // (about one vertex in ten wins at level 63, here and there: a branch per vertex
            // mispredicted, and this scan of every vertex was 6 % of the render).
            if (points.size() < end - first) points.resize(end - first);
            std::size_t count = 0;
            for (std::size_t v = first; v < end; ++v) {
                points[count] = static_cast<std::uint32_t>(v - first);
                count += wins[v] != 0;
            }
            if (count == 0) continue;
            stream.later_normals(p, std::span<const std::uint32_t>(points.data(), count), c.mesh, first);
        }
    });
}

// Fill mode, streamed: the surface is evaluated, projected, rasterized and resolved a
// batch of patches at a time and never held whole (render.h, RenderOptions::keep_surface).
// Every value is the one the materialized path computes: PatchStream::emit writes what
// run_pipeline writes, the rasterizer's draws in submission order leave the pixels one
// pass leaves, and each pixel is resolved from the batch that drew its final triangle.
RenderResult render_streamed(const Scene& scene, const Scene& pipeline_scene, const RenderOptions& options) {
    const auto start = Clock::now();
    auto progress = [&](std::string_view stage, double fraction) {
        if (options.progress) options.progress(stage, fraction);
    };
    PipelineOptions pipeline_options;
    pipeline_options.precision = options.precision;
    pipeline_options.math = options.math;
    pipeline_options.camera_relative = options.camera_relative;
    // The stream reads its scene for as long as it lives (pixel_provenance evaluates from it
    // after this returns): it keeps a copy of its own.
    struct Owned {
        Scene scene;
        PatchStream stream;
        Owned(const Scene& s, const PipelineOptions& o) : scene(s), stream(scene, o) {}
    };
    const auto owned = std::make_shared<const Owned>(pipeline_scene, pipeline_options);
    const std::shared_ptr<const PatchStream> shared_stream(owned, &owned->stream);
    const PatchStream& stream = *shared_stream;
    const std::size_t n = stream.patch_count();

    RenderResult result;
    result.camera = render_detail::camera_for(scene, options);
    result.shading = scene.shading;
    const int width = result.camera.viewport.x, height = result.camera.viewport.y;
    const glm::dvec3 origin = stream.origin();
    const bool relative = origin != glm::dvec3(0.0);
    result.mvp = glm::mat4(relative ? camera_moved_by(result.camera, origin).view_projection()
                                    : result.camera.view_projection());
    auto pipe = std::make_shared<PipelineResult>();
    pipe->levels = stream.levels();
    pipe->estimated_triangles = stream.estimated_triangles();
    pipe->distinct_patterns = stream.distinct_patterns();
    pipe->origin = origin;
    pipe->stages = {scene.control.has_value(), true, scene.geometry.has_value()};
    pipe->geometry_shader = stream.geometry_shader();
    pipe->reversed = stream.reversed();
    result.pipeline = pipe;
    result.stream = shared_stream;
    result.stats.triangles = stream.triangle_base(n);
    result.stats.vertices = stream.vertex_base(n);
    const Domain domain = scene.generator.domain;
    result.domain = domain;
    result.stats.seconds_pipeline = seconds_since(start);

    const auto buffers_start = Clock::now();
    // The framebuffer's depth and ids become the result's at the end; its weights the
    // rasterizer keeps per tile for one draw (Rasterizer::Rect::weights), and the result has
    // them only with the provenance buffers, written by the resolve. The two sets of buffers
    // are filled on two threads: their first touch is the kernel clearing every page, which
    // on one thread (36 MB at 1280x800 when the weights were whole-image) had one core idle
    // for about a tenth of the render.
    Framebuffer fb;
    tessref::parallel_for(0, 2, [&](int k) {
        if (k == 0)
            render_detail::allocate(result, width, height, false, options.provenance, options.colour8);
        else
            fb = Framebuffer::create_visibility(width, height);
    });
    RasterSettings settings;
    settings.depth_func = DepthFunc::less;
    Rasterizer rasterizer(fb, settings);
    const FragmentNeeds needs = fragment_needs(result.shading.model.kind);
    const bool derivatives = needs.texCoord && needs.texCoord_derivatives && stream.has_uvs();
    const glm::mat4 mvp = result.mvp;
    // The geometry stage's vertex normals (a normal-map fetch or a height-field difference
    // each) only for the vertices of triangles that win a pixel: at level 63 on the bench
    // terrain about 1 vertex in 10. They are computed between the draw and the resolve from
    // the positions and uvs emit() wrote (PatchStream::later_normals), so every value is the
    // one emit() would have written. Only where triangles far outnumber pixels: with fewer, most
    // vertices win a pixel and marking them costs more than it saves (measured on the bench
    // terrain at 1280x800: level 63, 32 triangles a pixel, 30 % less time deferred; level 16,
    // 2.3 a pixel, 7 % more).
    const std::uint64_t pixels = static_cast<std::uint64_t>(width) * static_cast<std::uint64_t>(height);
    const bool defer_normals = stream.has_normals() && result.stats.triangles > kDeferNormalsTrianglesPerPixel * pixels;
    const auto normals_mode = defer_normals ? PatchStream::VertexNormals::later : PatchStream::VertexNormals::now;
    // Each vertex's patch id and tess coord are read only for the provenance buffers.
    const auto provenance = options.provenance ? PatchStream::Provenance::now : PatchStream::Provenance::later;
    // The evaluation's positions (in double) are read after the projection only by the
    // resolve's world position (a model that takes one, pom's uv derivatives) and the deferred
    // height-field normals (emit() keeps them for its face normals itself): without those,
    // only the clip positions are kept (PatchStream::Projection::positions).
    const bool positions = needs.worldPosition || needs.uv_derivatives ||
                           (scene.geometry && scene.geometry->normals == GeometryNormals::height_field);

    result.stats.seconds_shade += seconds_since(buffers_start);  // the image buffers
    std::vector<PatchChunk> chunks;
    SharedBlocks shared_blocks;
    const std::size_t batch_size =
        std::max(kStreamBatchTriangles, kStreamBatchTrianglesPerThread * static_cast<std::size_t>(worker_threads()));
    std::size_t next_patch = 0;
    while (next_patch < n) {
        auto lap = Clock::now();
        const std::size_t used = plan_batch(stream, next_patch, batch_size, chunks);
        const std::span<PatchChunk> batch_chunks(chunks.data(), used);
        // Each chunk is evaluated, projected and set up in one task (Rasterizer::draw with
        // make): its vertices are prepared and box-tested while they are in that core's
        // cache, and the batch waits at one barrier where evaluating, then drawing waited
        // at two. A chunk with a non-finite vertex draws nothing: the render stops below.
        rasterizer.draw(used, [&](std::size_t k) -> RasterChunk {
            PatchChunk& c = batch_chunks[k];
            evaluate_chunk(stream, c, mvp, positions, normals_mode, provenance, shared_blocks);
            if (!c.finite) return {};
            return {c.clip, c.triangles, c.first_triangle, c.shared_triangles, c.blocks};
        });
        for (const PatchChunk& c : batch_chunks) {
            if (!c.finite) {
                // The materialized pipeline names the first non-finite vertex (and throws).
                run_pipeline(pipeline_scene, pipeline_options);
                throw Error("the surface has a non-finite vertex", Where::in_file(scene.file));
            }
        }
        result.stats.seconds_raster += seconds_since(lap);
        lap = Clock::now();

        // Resolve the pixels whose visible triangle this batch drew, only where the draw
        // changed a pixel (the rasterizer's tiles).
        const BatchIds ids(batch_chunks, static_cast<std::uint32_t>(stream.triangle_base(chunks[used - 1].last_patch)));
        std::vector<SurfaceView> chunk_views;
        for (const PatchChunk& c : batch_chunks)
            chunk_views.push_back({c.mesh, c.triangles, c.face_normals, c.clip, stream.face_normals(), origin});
        const std::vector<Rasterizer::Rect> drawn = rasterizer.drawn();
        if (defer_normals && needs.normal) complete_normals(stream, batch_chunks, ids, fb, result, drawn);
        tessref::parallel_for(std::size_t{0}, drawn.size(), [&](std::size_t r) {
            const Rasterizer::Rect& rect = drawn[r];
            resolve(result, fb, rect.weights, pipe->levels, domain, needs, derivatives, false, options.provenance,
                    rect.row / 2,
                    (rect.row + rect.height + 1) / 2, ids.range(),
                    [&](std::uint32_t id) -> std::pair<const SurfaceView*, std::uint32_t> {
                        const auto [k, tri] = ids.find(id);
                        if (k == ids.none()) return {nullptr, 0};
                        return {&chunk_views[k], tri};
                    },
                    rect.x, rect.x + rect.width);
        });
        result.stats.seconds_shade += seconds_since(lap);
        progress("rasterizing", static_cast<double>(next_patch) / static_cast<double>(n));
    }
    result.stats.raster = rasterizer.stats();
    render_detail::take_visibility(result, fb);
    result.stats.covered_pixels = covered_pixels(result);
    return result;
}

}  // namespace

RenderResult render_scene(const Scene& scene, const RenderOptions& options) {
    const SceneCamera camera = render_detail::camera_for(scene, options);
    // The pipeline sees the image's viewport, as it would see the application's window.
    Scene resized;
    if (camera.viewport != scene.camera->viewport) {
        resized = scene;
        resized.camera = camera;
    }
    const Scene& pipeline_scene = camera.viewport != scene.camera->viewport ? resized : scene;
    if (const StageShader* fragment = user_fragment_shader(scene))  // a user's shader, not a model
        return render_detail::render_user_fragment(scene, options, *fragment);
    if (!options.keep_surface && options.mode == RenderMode::fill && PatchStream::streams(scene) &&
        !(scene.geometry && scene.geometry->normals == GeometryNormals::smooth))
        return render_streamed(scene, pipeline_scene, options);

    const auto start = Clock::now();
    PipelineOptions pipeline_options;
    pipeline_options.precision = options.precision;
    pipeline_options.math = options.math;
    pipeline_options.camera_relative = options.camera_relative;
    if (options.progress) {
        pipeline_options.progress = [&](std::size_t done, std::size_t total) {
            options.progress("tessellating", total ? static_cast<double>(done) / static_cast<double>(total) : 1.0);
        };
    }
    auto pipeline = std::make_shared<const PipelineResult>(run_pipeline(pipeline_scene, pipeline_options));
    const double seconds_pipeline = seconds_since(start);
    RenderResult result = render_surface(scene, std::move(pipeline), options);
    result.stats.seconds_pipeline = seconds_pipeline;
    return result;
}

RenderResult render_surface(const Scene& scene, std::shared_ptr<const PipelineResult> pipeline,
                            const RenderOptions& options) {
    if (!pipeline) throw Error("render_surface needs a pipeline result", Where::at_key("pipeline"));
    RenderResult result;
    result.camera = render_detail::camera_for(scene, options);
    result.shading = scene.shading;
    const int width = result.camera.viewport.x, height = result.camera.viewport.y;
    // Camera-relative (the pipeline kept origin-relative positions): the camera moved by
    // -origin, its view-projection built in double and rounded once (pipeline.h).
    const bool relative = !pipeline->relative_positions.empty();
    result.mvp = glm::mat4(relative ? camera_moved_by(result.camera, pipeline->origin).view_projection()
                                    : result.camera.view_projection());
    auto progress = [&](std::string_view stage, double fraction) {
        if (options.progress) options.progress(stage, fraction);
    };
    result.pipeline = std::move(pipeline);
    const PipelineResult& pipe = *result.pipeline;
    const SurfaceMesh& mesh = pipe.mesh;
    if (mesh.patch_ids.size() != mesh.positions.size() || mesh.tess_coords.size() != mesh.positions.size() ||
        (!mesh.uvs.empty() && mesh.uvs.size() != mesh.positions.size()) ||
        (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size()) ||
        (relative && pipe.relative_positions.size() != mesh.positions.size()) ||
        pipe.levels.size() != scene.patch_count())
        throw Error("the pipeline result does not fit the scene (vertex attributes or patch count)",
                    Where::at_key("pipeline"));
    const bool face_normals = scene.geometry && scene.geometry->normals == GeometryNormals::face;
    if (face_normals && pipe.face_normals.size() != mesh.triangles.size())
        throw Error("the pipeline result has no face normals", Where::at_key("pipeline"));
    result.stats.triangles = mesh.triangles.size();
    result.stats.vertices = mesh.positions.size();

    // ---- gl_Position = mvp * vec4(position, 1.0) (thesis_terrain.tese:38), in float ---------
    auto start = Clock::now();
    progress("rasterizing", 0.0);
    std::vector<glm::vec4> clip(mesh.positions.size());
    const glm::mat4 mvp = result.mvp;
    tessref::parallel_for(tbb::blocked_range<std::size_t>(0, clip.size(), 16384), [&](const auto& r) {
        for (std::size_t i = r.begin(); i < r.end(); ++i)
            clip[i] = gl_position(mvp, relative ? pipe.relative_positions[i] : glm::vec3(mesh.positions[i]));
    });

    RasterInput input;
    input.positions = clip;
    input.triangles = mesh.triangles;
    RasterSettings settings;
    settings.depth_func = DepthFunc::less;
    settings.polygon_mode = options.mode == RenderMode::wireframe ? PolygonMode::line : PolygonMode::fill;
    const FragmentNeeds needs = fragment_needs(result.shading.model.kind);
    const bool derivatives = needs.texCoord && needs.texCoord_derivatives && !mesh.uvs.empty();
    // A line's quad differences come from the line's interpolation, which only the rasterizer
    // knows (the winning edge, its direction and clipping); a filled triangle's from its plane.
    const bool line_derivatives = derivatives && settings.polygon_mode == PolygonMode::line;
    settings.quad_derivatives = line_derivatives;
    Framebuffer fb = Framebuffer::create(width, height, 0);
    result.stats.raster = rasterize(fb, input, settings);

    Framebuffer lines;
    if (options.mode == RenderMode::fill_with_wireframe) {
        lines = Framebuffer::create(width, height, 0);
        RasterSettings line_settings = settings;
        line_settings.polygon_mode = PolygonMode::line;
        rasterize(lines, input, line_settings);
    }
    result.stats.seconds_raster = seconds_since(start);

    // ---- resolve and shade every pixel -----------------------------------------------------
    start = Clock::now();
    progress("shading", 0.0);
    render_detail::allocate(result, width, height, false, options.provenance);  // fb's visibility at the end
    const SurfaceView view{mesh, mesh.triangles, pipe.face_normals, clip, face_normals};  // world positions
    const Domain domain = scene.generator.domain;
    result.domain = domain;
    tessref::parallel_for(tbb::blocked_range<int>(0, (height + 1) / 2), [&](const tbb::blocked_range<int>& rows) {
        resolve(result, fb, WeightsView::of(fb), pipe.levels, domain, needs, derivatives, line_derivatives,
                options.provenance, rows.begin(),
                rows.end(), IdRange{0, static_cast<std::uint32_t>(mesh.triangles.size())},
                [&view](std::uint32_t id) { return std::pair{&view, id}; });
    });

    if (options.mode == RenderMode::fill_with_wireframe) {
        // The lines over the filled image where they are not behind it (render.h).
        tessref::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
            for (int row = rows.begin(); row < rows.end(); ++row) {
                for (int x = 0; x < width; ++x) {
                    const std::size_t i = result.index(x, row);
                    if (lines.triangle_id[i] == kNoTriangle) continue;
                    const std::uint32_t tri = fb.triangle_id[i];
                    bool visible = tri == kNoTriangle;
                    if (!visible) {
                        const auto c = view.clip_corners(tri);
                        const double z = plane_depth(c, x, row, width, height);
                        const double slope = std::max(std::abs(plane_depth(c, x + 1, row, width, height) - z),
                                                      std::abs(plane_depth(c, x, row + 1, width, height) - z));
                        const double offset = (std::isfinite(slope) ? slope : 0.0) + std::ldexp(1.0, -20);
                        visible = static_cast<double>(lines.depth[i]) <= static_cast<double>(fb.depth[i]) + offset;
                    }
                    if (visible) result.colour[i] = result.shading.wireframe_colour;
                }
            }
        });
    }
    render_detail::take_visibility(result, fb);
    if (options.colour8) render_detail::keep_colour8(result);
    result.stats.covered_pixels = covered_pixels(result);
    result.stats.seconds_shade = seconds_since(start);
    progress("shading", 1.0);
    return result;
}

std::uint64_t estimate_render_memory(glm::ivec2 size, RenderMode mode, bool raytrace, ImageFormat format,
                                     const AovSelection& aovs) {
    // Per pixel, from the buffers each phase holds at once. A render that materializes the
    // surface (wireframe, smooth normals, a geomipmapped terrain, keep_surface) keeps a full
    // Framebuffer, 57 bytes a pixel, and the RenderResult, 56, while shading; the streamed
    // fill render holds only a visibility framebuffer (depth and id: 8 bytes, its weights
    // per tile for one draw) that becomes part of the 56-byte result (12 for a PNG, without
    // the provenance buffers and with 8-bit colour: RenderOptions::provenance, colour8). The
    // estimate takes the larger and errs high for the streamed render. Measured peaks, `/usr/bin/time -f %M tessref render SCENE --size S
    // -o x.png --threads 1` (maximum resident set), 2048x2048 and 4096x4096:
    // data/scenes/thesis-map-4.toml (streamed) 189 and 670 MiB, 40 bytes/pixel above a base
    // of about 29 MiB; data/scenes/jacksboro-geomipmap.toml (materialized) 349 and 1275 MiB,
    // 77 bytes/pixel above about 40 MiB (60 and 97 bytes/pixel with the provenance buffers,
    // as an EXR with their channels still takes). Before the streamed render (same command,
    // thesis-map-4): 117 bytes/pixel; .exr with every AOV 117.4 bytes/pixel (the write phase,
    // RenderResult + 14 float channels, stays under the render phase); --overlay-wireframe
    // +57 bytes/pixel (the lines' Framebuffer); --wireframe of a textured scene +24
    // bytes/pixel, the lines' quad derivatives. The slack keeps the estimate above those.
    constexpr std::uint64_t framebuffer = 57, result = 56, slack = 8, line_derivatives = 24;
    const std::uint64_t render_phase =
        (raytrace ? 0 : framebuffer) * (mode == RenderMode::fill_with_wireframe ? 2 : 1) +
        (mode == RenderMode::wireframe && !raytrace ? line_derivatives : 0) + result + slack;
    std::uint64_t channels = 4;
    if (format == ImageFormat::exr) {
        channels += aovs.depth + aovs.patch + aovs.triangle + 3 * aovs.tesscoord + 4 * aovs.level;
    }
    const std::uint64_t write_phase = result + (format == ImageFormat::exr ? 4 * channels : 4) + slack;
    const std::uint64_t pixels = saturating_bytes(static_cast<std::uint64_t>(std::max(size.x, 0)),
                                                  static_cast<std::uint64_t>(std::max(size.y, 0)));
    return saturating_bytes(pixels, std::max(render_phase, write_phase));
}

PixelProvenance pixel_provenance(const RenderResult& result, int x, int y) {
    if (x < 0 || y < 0 || x >= result.width || y >= result.height)
        throw Error("pixel " + std::to_string(x) + "," + std::to_string(y) + " is outside the " +
                        std::to_string(result.width) + "x" + std::to_string(result.height) + " image",
                    Where::at_key("pixel"));
    if (result.colour.empty())
        throw Error("the image was rendered without its float colour (RenderOptions::colour8)",
                    Where::at_key("colour8"));
    if (result.patch_id.size() != result.colour.size())
        throw Error("the image was rendered without its provenance buffers (RenderOptions::provenance)",
                    Where::at_key("provenance"));
    PixelProvenance p;
    p.x = x;
    p.y = y;
    p.window_x = x;
    p.window_y = result.height - 1 - y;
    const std::size_t i = result.index(x, y);
    p.colour = result.colour[i];
    p.depth = result.depth[i];
    p.triangle_id = result.triangle_id[i];
    p.patch_id = result.patch_id[i];
    p.covered = p.triangle_id != kNoPixelId;
    if (!p.covered) return p;
    p.barycentric = result.barycentric[i];
    p.tess_coord = result.tess_coord[i];
    p.level = result.level[i];
    if (!result.pipeline) return p;  // a ray-traced image: no tessellation
    const PipelineResult& pipe = *result.pipeline;
    // A streamed render kept no surface: its one triangle, evaluated again (the same bits).
    SurfaceMesh one;
    glm::dvec3 face_normal(0.0);
    const bool streamed = pipe.mesh.triangles.empty() && result.stream;
    if (streamed) p.vertices = result.stream->triangle(p.triangle_id, one, &face_normal);
    const SurfaceMesh& mesh = streamed ? one : pipe.mesh;
    const std::uint32_t triangle = streamed ? 0 : p.triangle_id;
    const auto& t = mesh.triangles.at(triangle);
    if (!streamed) p.vertices = t;
    const glm::dvec3 b(p.barycentric);
    for (int k = 0; k < 3; ++k) {
        p.vertex_tess_coords[static_cast<std::size_t>(k)] = mesh.tess_coords[t[static_cast<std::size_t>(k)]];
        p.world_position += b[k] * mesh.positions[t[static_cast<std::size_t>(k)]];
    }
    if (streamed && result.stream->face_normals()) {
        p.normal = face_normal;
    } else if (!pipe.face_normals.empty()) {
        p.normal = pipe.face_normals[p.triangle_id];
    } else if (!mesh.normals.empty()) {
        p.normal = b[0] * mesh.normals[t[0]] + b[1] * mesh.normals[t[1]] + b[2] * mesh.normals[t[2]];
    }
    if (!mesh.uvs.empty()) p.uv = b[0] * mesh.uvs[t[0]] + b[1] * mesh.uvs[t[1]] + b[2] * mesh.uvs[t[2]];
    p.patch_levels = pipe.levels.at(p.patch_id);
    level_of(mesh, pipe.levels, result.domain, t, &p.level_source);
    return p;
}

glm::vec3 level_heat_colour(float level) {
    if (std::isnan(level)) return glm::vec3(0.0f);
    const float t = std::clamp(std::log2(std::max(level, 1.0f)) / 6.0f, 0.0f, 1.0f);
    static const glm::vec3 stops[5] = {{0.0f, 0.0f, 1.0f}, {0.0f, 1.0f, 1.0f}, {0.0f, 1.0f, 0.0f},
                                       {1.0f, 1.0f, 0.0f}, {1.0f, 0.0f, 0.0f}};
    const float s = t * 4.0f;
    const int k = std::min(3, static_cast<int>(s));
    return glm::mix(stops[k], stops[k + 1], s - static_cast<float>(k));
}

void render_detail::to_rgba8(const RenderResult& result, std::uint8_t* out) {
    if (result.colour.empty()) {  // RenderOptions::colour8: the codes themselves
        if (!result.rgba8.empty()) std::memcpy(out, result.rgba8.data(), result.rgba8.size() * sizeof(glm::u8vec4));
        return;
    }
    // In parallel: it sits between the render and the image write, where nothing else runs.
    tessref::parallel_for(tbb::blocked_range<std::size_t>(0, result.colour.size(), 65536),
                          [&](const tbb::blocked_range<std::size_t>& r) {
                              for (std::size_t i = r.begin(); i < r.end(); ++i)
                                  unorm8_rgba(&result.colour[i][0], &out[i * 4]);
                          });
}

std::vector<std::uint8_t> to_rgba8(const RenderResult& result) {
    std::vector<std::uint8_t> out((result.colour.empty() ? result.rgba8.size() : result.colour.size()) * 4);
    render_detail::to_rgba8(result, out.data());
    return out;
}

ImageDifference compare_images(const RenderResult& a, const RenderResult& b) {
    // The clamped R, G, B a unorm8 framebuffer would hold (before quantization), through
    // the one comparison of compare.h; coverage is what only a render knows.
    if ((a.colour.empty() && !a.rgba8.empty()) || (b.colour.empty() && !b.rgba8.empty()))
        throw Error("comparing renders needs their float colour (RenderOptions::colour8 kept only 8-bit codes)",
                    Where::at_key("colour8"));
    const auto clamped_rgb = [](const RenderResult& r) {
        FloatImage image;
        image.width = r.width;
        image.height = r.height;
        image.channels = 3;
        image.samples.resize(r.colour.size() * 3);
        for (std::size_t i = 0; i < r.colour.size(); ++i)
            for (int c = 0; c < 3; ++c) {
                const float v = r.colour[i][c];
                image.samples[i * 3 + static_cast<std::size_t>(c)] = std::isnan(v) ? 0.0f : std::clamp(v, 0.0f, 1.0f);
            }
        return image;
    };
    const CompareResult compared = compare_images(clamped_rgb(a), clamped_rgb(b));
    ImageDifference d;
    d.pixels = compared.pixels;
    d.rmse = compared.rmse;
    d.max_abs = compared.max_error;
    for (std::size_t i = 0; i < a.triangle_id.size() && i < b.triangle_id.size(); ++i)
        if ((a.triangle_id[i] == kNoPixelId) != (b.triangle_id[i] == kNoPixelId)) ++d.coverage_mismatch;
    return d;
}

}  // namespace tessref
