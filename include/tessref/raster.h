// tessref/raster.h — the software rasterizer: clip-space triangles in, image buffers out.
//
// It computes which pixels Mesa's llvmpipe (the OSMesa/GL backend, Mesa 22.3) covers, so that a
// golden image and an llvmpipe rendering agree pixel for pixel:
//
//  * clipping: homogeneous, against -w <= x, y, z <= w, no guard band, with the same plane
//    order, clip distances, intersection parameters and float arithmetic as Mesa's draw
//    module (draw_pipe_clip.c); a clipped polygon is emitted as a fan, like draw does;
//  * window coordinates as draw computes them, in float: (x * (1/w)) * scale + translate,
//    the last multiply-add fused or not depending on the path (see WindowTransform);
//  * coverage as llvmpipe's setup computes it (lp_setup_tri.c): vertices snapped to 8
//    sub-pixel bits (1/256 pixel) with round-to-nearest-even, pixel centres at +0.5, 64-bit
//    integer edge functions, a strict inequality with a fill-rule bias that includes LEFT
//    edges and BOTTOM edges in GL window coordinates; zero-area triangles are culled and
//    clockwise ones swapped (or culled when culling is asked for);
//  * wireframe (PolygonMode::line) as glPolygonMode(GL_FRONT_AND_BACK, GL_LINE) draws it on
//    llvmpipe: each clipped triangle's original edges (not the ones along a clip plane, not
//    the fan's diagonals) as one-pixel GL lines with llvmpipe's diamond-exit line setup
//    (lp_setup_line.c: its own approximation of the diamond-exit rule, snapping with
//    round-half-away-from-zero), in the order draw's unfilled stage emits them; culling there
//    uses draw's float determinant, a zero one counting as back-facing.
//
// tests/test_raster_llvmpipe.cpp holds all of this to exact agreement with Mesa 22.3.6's
// llvmpipe (Debian bookworm), fill and wireframe, with and without culling, plain and
// tessellated draws, and the shipped scenes. Other Mesa versions differ in details (later
// ones changed the clipper's handling of vertices on a plane and a line-end rule).
//
// A window-system framebuffer is emulated (OSMesa's own buffer, not a user FBO): Mesa
// renders it upside down internally (row 0 on top), so window y is computed and snapped in
// that orientation, as llvmpipe does. A user FBO (rendered the other way up, with the mirror
// fill convention) is not modelled: it can differ where y rounds differently.
//
// Attributes are not exact to llvmpipe's bits: depth (window z, interpolated linearly in
// screen space, clamped to [0,1]) and the perspective-correct barycentric weights of the
// source triangle are computed in float from the UNSNAPPED vertices (plane equations, divided
// per pixel by the interpolated 1/w). Varyings, tess coords and ids of the visible surface are
// resolved from those weights after the pass ("deferred"): with depth LESS and no blending
// that is exactly what forward shading of the last fragment that passed would produce.
//
// Images: every per-pixel buffer is row-major with row 0 the TOP row of the picture (GL
// window y = height - 1), the order image files are written in; GL window coordinates (x, y)
// with y up map to index(x, y). OSMesa/glReadPixels buffers have row 0 at the bottom.
//
// Work is split into 64x64 tiles rasterized in parallel with oneTBB; every tile processes the
// primitives that overlap it in submission order, so the output is byte-identical whatever
// the thread count.
//
//   auto fb = tessref::Framebuffer::create(1280, 800, /*varying_count=*/3);
//   tessref::RasterInput in;
//   in.positions = clip_positions; in.triangles = tris; in.varyings = normals; in.varying_count = 3;
//   tessref::rasterize(fb, in, {});
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

namespace tessref {

inline constexpr std::uint32_t kNoTriangle = 0xFFFFFFFFu;  // triangle_id/patch_id of an empty pixel
inline constexpr int kMaxVaryings = 16;                    // floats per vertex

enum class PolygonMode { fill, line };
enum class CullMode { none, back, front };   // front = counter-clockwise in GL window coordinates
enum class DepthFunc { less, lequal, always };

// Which of Mesa's two window transforms made the vertices' window coordinates (the clipper's
// new vertices always use the second):
//  * vertex_shader: llvmpipe's vertex-shader JIT, fma(x * (1/w), scale, translate) where the
//    CPU has FMA (every x86-64 since 2013; checked at run time, as LLVM does) — a draw with
//    only a vertex shader;
//  * tessellation: draw's C post-shader path, (x * (1/w)) * scale + translate rounded twice —
//    every draw with a tessellation or geometry shader, which is what the GL backend renders.
// They differ by an ulp now and then, which moves a snapped vertex on a rounding tie or
// flips a line's diamond-exit decision at a pixel-exact endpoint.
enum class WindowTransform { tessellation, vertex_shader };

// What one pass draws. Plain views: the caller owns the data for the call's duration.
struct RasterInput {
    std::span<const glm::vec4> positions;                      // gl_Position of every vertex
    // Vertex indices, any winding. As on the GPU, a triangle's vertex order decides the
    // direction of its wireframe lines (and so their end pixels) and, when it is clipped,
    // the fan: keep the order the GPU sees (the primitive generator's, for tessellation).
    std::span<const std::array<std::uint32_t, 3>> triangles;
    std::span<const float> varyings = {};                      // varying_count floats per vertex
    int varying_count = 0;                                     // 0..kMaxVaryings
    std::span<const std::uint32_t> triangle_ids = {};  // id written per triangle; default its index
    std::span<const std::uint32_t> patch_ids = {};     // per triangle; default kNoTriangle
    std::span<const glm::vec3> tess_coords = {};       // per vertex gl_TessCoord; default 0
};

struct RasterSettings {
    PolygonMode polygon_mode = PolygonMode::fill;
    CullMode cull = CullMode::none;
    DepthFunc depth_func = DepthFunc::less;
    bool depth_write = true;
    WindowTransform window_transform = WindowTransform::tessellation;
    glm::vec4 colour{1.0f};  // written to Framebuffer::colour by every fragment that passes
    // Also record Framebuffer::barycentric_dx/dy (sized by rasterize() when asked).
    bool quad_derivatives = false;
    int threads = 0;        // 0: the calling oneTBB arena; N > 0: an arena of N threads
};

// The image buffers. All have width*height entries, row 0 = top row (see above).
struct Framebuffer {
    int width = 0;
    int height = 0;
    int varying_count = 0;
    std::vector<glm::vec4> colour;              // cleared to (0,0,0,0)
    std::vector<float> depth;                   // window z in [0,1], cleared to 1
    std::vector<std::uint32_t> triangle_id;     // visible triangle's id, kNoTriangle if none
    std::vector<std::uint32_t> patch_id;        // its patch, kNoTriangle if none/unknown
    std::vector<glm::vec3> barycentric;         // perspective-correct weights of its vertices
    // With RasterSettings::quad_derivatives, the visible primitive's weights differenced over
    // the pixel's 2x2 quad as llvmpipe derives dFdx/dFdy: for the quad whose top-left pixel is
    // column qx, row qr (row 0 on top, as above), the weights at (qx + 1, qr) minus (qx, qr),
    // and at (qx, qr) minus (qx, qr + 1) (window y grows upwards), from the primitive's own
    // planes, evaluated outside it where the quad leaves it. For a line that is the line's
    // interpolation (constant across it), not its triangle's: what the fragment shader of
    // glPolygonMode(GL_LINE) sees. Empty unless asked for.
    std::vector<glm::vec3> barycentric_dx;
    std::vector<glm::vec3> barycentric_dy;
    std::vector<glm::vec3> tess_coord;          // interpolated gl_TessCoord
    std::vector<float> varyings;                // varying_count floats per pixel, interpolated
    std::vector<std::uint8_t> front_facing;     // 1 if the visible primitive is front-facing
    std::vector<std::uint32_t> fragment_count;  // fragments generated (before the depth test)

    // Throws tessref::Error for a size outside 1..16384 or varying_count outside 0..16.
    static Framebuffer create(int width, int height, int varying_count = 0);
    // Only what a batched draw's depth test needs and a renderer resolves its pixels by:
    // depth and triangle_id (and the quad differences when asked for). Every other buffer
    // stays empty and the Rasterizer class (not rasterize(), which refuses it) leaves it so;
    // the weights, needed only between a draw and the resolve of what it drew, the
    // Rasterizer keeps per tile for the last draw (Rasterizer::Rect::weights). 8 bytes a
    // pixel to clear and fault in for each image, where create() has 57.
    static Framebuffer create_visibility(int width, int height);
    void clear();  // every buffer to its cleared value

    std::size_t index(int x, int y_gl) const {  // GL window coordinates, y up
        return static_cast<std::size_t>(height - 1 - y_gl) * static_cast<std::size_t>(width) +
               static_cast<std::size_t>(x);
    }
};

struct RasterStats {
    std::uint64_t triangles_in = 0;       // input triangles
    std::uint64_t triangles_clipped = 0;  // that needed the clipper (partly outside)
    std::uint64_t triangles_rejected = 0; // wholly outside one clip plane, or non-finite
    std::uint64_t primitives = 0;         // set-up triangles (after clipping) or lines
    std::uint64_t primitives_culled = 0;  // zero area, or culled by face
    std::uint64_t fragments = 0;          // covered pixel samples
    std::uint64_t fragments_passed = 0;   // that passed the depth test
};

// Draws one pass into fb (which keeps what earlier passes drew: clear() it first for a new
// image). The viewport is the whole framebuffer, depth range [0,1]. Throws tessref::Error on
// a vertex index out of range, varying_count out of range or spans of the wrong size.
RasterStats rasterize(Framebuffer& fb, const RasterInput& input, const RasterSettings& settings);

// Drawing in batches: a streamed draw (render.h: the renderer evaluates a few patches,
// draws them, and reuses their memory). draw() sets up, bins and rasterizes its chunks
// before it returns, chunk after chunk in the order given, so a sequence of draws leaves
// the pixels one rasterize() of all the triangles in that order would. The framebuffer
// gets triangle_id (the chunk's first_id + the triangle's index in it), depth, colour,
// barycentric (and barycentric_dx/dy with quad_derivatives), front_facing and
// fragment_count as a draw writes them, those it has; patch_id, tess_coord and varyings
// are left to the caller, which knows its vertices (render.cpp resolves them after each
// draw). A framebuffer without barycentric (create_visibility) gets its weights per tile
// instead, for the last draw only: Rect::weights.

// The perspective-correct weights a draw wrote into part of the image: pixel (x, row) (row
// 0 on top) at base[(row - row0) * stride + (x - x0)].
struct WeightsView {
    const glm::vec3* base = nullptr;
    std::size_t stride = 0;
    int x0 = 0, row0 = 0;

    const glm::vec3& at(int x, int row) const {
        return base[static_cast<std::size_t>(row - row0) * stride + static_cast<std::size_t>(x - x0)];
    }
    // A framebuffer's own barycentric buffer (which it must have).
    static WeightsView of(const Framebuffer& fb) {
        return {fb.barycentric.data(), static_cast<std::size_t>(fb.width), 0, 0};
    }
};
// Where the vertices of kTriangleBlock consecutive triangles lie: two runs of vertex indices,
// [first[r], first[r] + count[r]), that hold every one of them (and perhaps others), each
// of 2 to kMaxTriangleBlockRun vertices, or count[0] = 0 where two such runs do not. The box test rejects a
// block whose vertices' joint box holds no pixel centre at once (each triangle's box lies in
// it), reading the runs' bounds in order where it read three vertices through the indices
// for each triangle. Made once for a pattern that many chunks share (triangle_blocks).
inline constexpr std::size_t kTriangleBlock = 8;
inline constexpr std::uint32_t kMaxTriangleBlockRun = 8;
struct TriangleBlock {
    std::array<std::uint32_t, 2> first{};
    std::array<std::uint32_t, 2> count{};
};
// The blocks of triangles [kTriangleBlock * b, kTriangleBlock * (b + 1)), the last one
// possibly shorter: each block's two runs split its distinct vertex indices at their
// largest gap (a run of one vertex takes a neighbour too; the same run twice where the
// indices have no gap).
std::vector<TriangleBlock> triangle_blocks(std::span<const std::array<std::uint32_t, 3>> triangles);

struct RasterChunk {
    std::span<const glm::vec4> positions;  // gl_Position of the vertices the triangles index
    std::span<const std::array<std::uint32_t, 3>> triangles;
    std::uint32_t first_id = 0;            // id of triangles[0]; the others follow it
    // The caller's triangles index below positions.size() by construction (the streamed
    // render's chunk of one patch: its pattern's own indices, PatchStream::shared_triangles):
    // the draw does not scan them for an index out of range, which it otherwise does for
    // every chunk (3 % of a level-63 render, the same pattern's indices each time).
    bool indices_in_range = false;
    // triangle_blocks(triangles), or empty: the triangles are box-tested one by one.
    std::span<const TriangleBlock> blocks{};
};

class Rasterizer {
public:
    // settings.threads is ignored: draws run in the caller's oneTBB arena.
    Rasterizer(Framebuffer& fb, const RasterSettings& settings);
    ~Rasterizer();
    Rasterizer(const Rasterizer&) = delete;
    Rasterizer& operator=(const Rasterizer&) = delete;
    // Throws tessref::Error on a vertex index outside its chunk.
    void draw(std::span<const RasterChunk> chunks);
    // draw() of `count` chunks that make(c) produces, each on the thread that then sets it
    // up, in the same task: a streamed renderer evaluates chunk c's vertices there, so the
    // vertices are still in that core's cache when they are prepared and box-tested, and
    // the draw has one barrier where evaluating all the chunks, then drawing them had two.
    // The spans make(c) returns are read only in that task; an exception from make leaves
    // the draw with nothing drawn.
    void draw(std::size_t count, const std::function<RasterChunk(std::size_t)>& make);
    RasterStats stats() const;  // of every draw so far
    // The parts of the image the last draw changed: rectangles (x, row from the top, width,
    // height; whole 2x2 quads, so no quad straddles two), one per tile where a fragment passed,
    // around the boxes of the triangles drawn there, outside which no pixel's depth, triangle
    // or weights changed. `weights` holds the weights of the rectangle's pixels that the last
    // draw wrote (the pixels whose triangle_id is one of its triangles'; the others' are
    // undefined where the framebuffer has no barycentric of its own) until the next draw.
    struct Rect {
        int x, row, width, height;
        WeightsView weights;
    };
    std::vector<Rect> drawn() const;

    struct State;

private:
    std::unique_ptr<State> state_;
};

// GL's float -> unorm8 conversion (clamp to [0,1], x*255 rounded to nearest), row 0 on top:
// width*height*4 bytes RGBA.
std::vector<std::uint8_t> to_rgba8(const Framebuffer& fb);

// The fixed-point window position llvmpipe snaps a window-space coordinate to
// (round-to-nearest-even of (v - 0.5) * 256); exposed for tests and debugging.
std::int32_t snap_subpixel(float window_coordinate);

}  // namespace tessref
