// The streamed render (render.h RenderOptions::keep_surface off) against the materialized
// one: a filled image evaluated, rasterized and resolved a batch of patches at a time must
// give every per-pixel buffer the whole-surface pass gives, bit for bit, for every shipped
// scene, both precisions, camera-relative evaluation and any thread count. And the
// rasterizer's batched draws (raster.h Rasterizer) against one rasterize() of the same
// triangles, and the 8-bit colour of RenderOptions::colour8 against the float colour's codes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <tbb/global_control.h>

#include "common/simd.h"
#include "render_compare.h"
#include "tessref/error.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"
#include "tessref/raster.h"
#include "tessref/render.h"
#include "tessref/scene.h"
#include "tessref/tessellator.h"

namespace fs = std::filesystem;

namespace {

const fs::path kScenes = fs::path(TESSREF_SOURCE_DIR) / "data" / "scenes";

// The streamed render never keeps the surface; the materialized one does.
void compare_paths(const tessref::Scene& scene, tessref::RenderOptions options) {
    options.keep_surface = false;
    const tessref::RenderResult streamed = tessref::render_scene(scene, options);
    options.keep_surface = true;
    const tessref::RenderResult whole = tessref::render_scene(scene, options);
    ASSERT_TRUE(streamed.pipeline && whole.pipeline);
    // A geomipmapped terrain and smooth normals need the whole surface: those fall back to it.
    const bool streams = tessref::PatchStream::streams(scene) &&
                         !(scene.geometry && scene.geometry->normals == tessref::GeometryNormals::smooth);
    EXPECT_EQ(streamed.pipeline->mesh.triangles.empty(), streams) << "streamed (surface not held): " << streams;
    EXPECT_EQ(whole.pipeline->mesh.triangles.size(), whole.stats.triangles);
    EXPECT_GT(streamed.stats.covered_pixels, 0u);
    expect_identical_renders(streamed, whole);
}

std::vector<fs::path> shipped_scenes() {
    std::vector<fs::path> out;
    for (const auto& e : fs::directory_iterator(kScenes))
        if (e.path().extension() == ".toml") out.push_back(e.path());
    std::sort(out.begin(), out.end());
    return out;
}

// Every count of two draws of the same triangles (raster.h RasterStats), field by field.
void expect_same_counts(const tessref::RasterStats& a, const tessref::RasterStats& b) {
    EXPECT_EQ(a.triangles_in, b.triangles_in);
    EXPECT_EQ(a.triangles_clipped, b.triangles_clipped);
    EXPECT_EQ(a.triangles_rejected, b.triangles_rejected);
    EXPECT_EQ(a.primitives, b.primitives);
    EXPECT_EQ(a.primitives_culled, b.primitives_culled);
    EXPECT_EQ(a.fragments, b.fragments);
    EXPECT_EQ(a.fragments_passed, b.fragments_passed);
}

}  // namespace

TEST(RenderStream, EveryShippedSceneMatchesTheWholeSurfacePass) {
    std::size_t compared = 0;
    for (const fs::path& path : shipped_scenes()) {
        SCOPED_TRACE(path.filename().string());
        const tessref::Scene scene = tessref::load_scene(path.string());
        if (!scene.camera) continue;
        tessref::RenderOptions options;
        options.size = {320, 200};  // a smaller image keeps the suite quick; every scene's surface is whole
        compare_paths(scene, options);
        ++compared;
    }
    EXPECT_GE(compared, 14u);  // the shipped scenes with a camera
}

// Patches of more than half a chunk's triangles (level 63: 7938 each) are streamed a patch a
// chunk, drawn and resolved from the pattern's own triangles (PatchStream::shared_triangles)
// and, at 31 triangles a pixel, with deferred vertex normals; reversed, they are copied as
// before. Both match the whole surface's pass.
TEST(RenderStream, ChunksOfOnePatchMatchTheWholeSurfacePass) {
    for (const auto winding : {tessref::Winding::ccw, tessref::Winding::cw}) {
        SCOPED_TRACE(winding == tessref::Winding::ccw ? "ccw" : "cw");
        tessref::Scene scene = tessref::load_scene((kScenes / "thesis-all-10.toml").string());
        scene.control->model = tessref::ControlModel::constant;
        scene.control->constant.level = 63.0;
        scene.generator.winding = winding;
        tessref::RenderOptions options;
        options.size = {320, 200};
        compare_paths(scene, options);
    }
}

TEST(RenderStream, ExactPrecisionAndCameraRelativeMatch) {
    for (const char* name : {"thesis-all-10.toml", "cosc422-eye.toml", "lab4-canyon.toml", "pn-triangles.toml"}) {
        SCOPED_TRACE(name);
        const tessref::Scene scene = tessref::load_scene((kScenes / name).string());
        tessref::RenderOptions options;
        options.size = {256, 160};
        options.precision = tessref::Precision::exact;
        compare_paths(scene, options);
        options.precision = tessref::Precision::gpu;
        options.camera_relative = true;
        compare_paths(scene, options);
    }
}

// The streamed render defers vertex normals to the vertices of winning triangles where
// there are more than 8 triangles a pixel (render.cpp): an 8x5 image makes every scene with
// vertex normals take that path (normal-map, height-field and PN normals, both precisions,
// camera-relative evaluation), and it must still equal the whole-surface pass.
TEST(RenderStream, DeferredVertexNormalsMatchTheWholeSurfacePass) {
    for (const char* name : {"thesis-all-10.toml", "jacksboro.toml", "lab4-canyon.toml", "terrain-pom.toml",
                             "pn-triangles.toml"}) {
        for (int variant = 0; variant < 3; ++variant) {
            SCOPED_TRACE(std::string(name) + " variant " + std::to_string(variant));
            tessref::Scene scene = tessref::load_scene((kScenes / name).string());
            if (scene.control && scene.control->model == tessref::ControlModel::pn) {
                // The PN control stage's levels follow the image's pixels: a fixed level instead.
                scene.control->model = tessref::ControlModel::constant;
                scene.control->constant.level = 16.0;
            }
            tessref::RenderOptions options;
            options.size = {8, 5};
            options.precision = variant == 1 ? tessref::Precision::exact : tessref::Precision::gpu;
            options.camera_relative = variant == 2;
            options.keep_surface = false;
            const tessref::RenderResult streamed = tessref::render_scene(scene, options);
            ASSERT_GT(streamed.stats.triangles, 8u * 8u * 5u) << "too few triangles to defer the normals";
            compare_paths(scene, options);
        }
    }
}

// A surface large enough for many batches (2.0 M triangles at level 63: about 31 batches
// of 2^16) at the camera's full size.
TEST(RenderStream, ManyBatchesMatchAtFullSize) {
    const tessref::Scene scene = tessref::load_scene((kScenes / "thesis-constant-64.toml").string());
    compare_paths(scene, {});
}

TEST(RenderStream, ThreadCountDoesNotChangeTheImage) {
    const tessref::Scene scene = tessref::load_scene((kScenes / "jacksboro.toml").string());
    tessref::RenderOptions options;
    options.size = {640, 400};
    const tessref::RenderResult many = tessref::render_scene(scene, options);
    tessref::RenderResult one;
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
        one = tessref::render_scene(scene, options);
    }
    expect_identical_renders(one, many);
}

// Batched draws leave the pixels one rasterize() of all the triangles leaves: a random soup
// with clipped, culled, sub-pixel and overlapping triangles, cut into uneven chunks.
TEST(Rasterizer, ChunkedDrawsEqualOnePass) {
    std::mt19937 rng(12345);
    std::uniform_real_distribution<float> pos(-1.4f, 1.4f), small(-0.01f, 0.01f), depth(-0.9f, 0.9f),
        w(0.6f, 1.6f);
    std::vector<glm::vec4> positions;
    std::vector<std::array<std::uint32_t, 3>> triangles;
    for (std::uint32_t t = 0; t < 6000; ++t) {
        const float cx = pos(rng), cy = pos(rng);
        const bool tiny = t % 3 == 0;
        for (int k = 0; k < 3; ++k) {
            const float ww = w(rng);
            const float x = tiny ? cx + small(rng) : pos(rng), y = tiny ? cy + small(rng) : pos(rng);
            positions.emplace_back(x * ww, y * ww, depth(rng) * ww, ww);
        }
        triangles.push_back({3 * t, 3 * t + 1, 3 * t + 2});
    }
    positions[7].w = -0.5f;  // one vertex behind the eye: clipped

    tessref::Framebuffer whole = tessref::Framebuffer::create(173, 97);
    tessref::RasterInput input;
    input.positions = positions;
    input.triangles = triangles;
    tessref::RasterSettings settings;
    settings.quad_derivatives = true;
    const tessref::RasterStats one = tessref::rasterize(whole, input, settings);

    tessref::Framebuffer batched = tessref::Framebuffer::create(173, 97);
    tessref::Rasterizer rasterizer(batched, settings);
    // The same draws into a visibility framebuffer (depth and ids only): each draw's weights
    // are the drawn rectangles' (per tile, until the next draw), gathered here where the
    // draw's own triangles are visible.
    tessref::Framebuffer visible = tessref::Framebuffer::create_visibility(173, 97);
    ASSERT_TRUE(visible.colour.empty() && visible.fragment_count.empty() && visible.front_facing.empty() &&
                visible.barycentric.empty());
    tessref::Rasterizer visible_rasterizer(visible, settings);
    std::vector<glm::vec3> visible_weights(visible.depth.size(), glm::vec3(0.0f));
    // Uneven chunks, each indexing its own vertices from 0, two or three per draw.
    std::vector<std::vector<glm::vec4>> chunk_positions;
    std::vector<std::vector<std::array<std::uint32_t, 3>>> chunk_triangles;
    std::vector<std::uint32_t> chunk_first;
    for (std::uint32_t first = 0; first < triangles.size();) {
        const std::uint32_t count = std::min<std::uint32_t>(1 + (first * 7919u) % 900u,
                                                            static_cast<std::uint32_t>(triangles.size()) - first);
        chunk_positions.emplace_back(positions.begin() + 3 * first, positions.begin() + 3 * (first + count));
        std::vector<std::array<std::uint32_t, 3>> local;
        for (std::uint32_t t = 0; t < count; ++t) local.push_back({3 * t, 3 * t + 1, 3 * t + 2});
        chunk_triangles.push_back(local);
        chunk_first.push_back(first);
        first += count;
    }
    for (std::size_t c = 0; c < chunk_first.size();) {
        std::vector<tessref::RasterChunk> draw;
        const std::uint32_t draw_first = chunk_first[c];
        for (std::size_t k = 0; k < 2 + c % 2 && c < chunk_first.size(); ++k, ++c)
            draw.push_back({chunk_positions[c], chunk_triangles[c], chunk_first[c]});
        const std::uint32_t draw_end = c < chunk_first.size() ? chunk_first[c] : static_cast<std::uint32_t>(triangles.size());
        rasterizer.draw(draw);
        const tessref::Framebuffer before = visible;
        visible_rasterizer.draw(draw);
        // drawn(): whole 2x2 quads inside the image, no pixel in two, and every pixel whose
        // depth or triangle the draw changed inside one (a fragment that passes the depth
        // test LESS changes the depth: its weights change nowhere else).
        std::vector<int> owner(visible.depth.size(), 0);
        for (const tessref::Rasterizer::Rect& r : visible_rasterizer.drawn()) {
            EXPECT_TRUE(r.x % 2 == 0 && r.row % 2 == 0 && r.width > 0 && r.height > 0);
            EXPECT_TRUE((r.width % 2 == 0 || r.x + r.width == 173) && (r.height % 2 == 0 || r.row + r.height == 97));
            ASSERT_TRUE(r.x + r.width <= 173 && r.row + r.height <= 97);
            ASSERT_NE(r.weights.base, nullptr);
            for (int y = r.row; y < r.row + r.height; ++y)
                for (int x = r.x; x < r.x + r.width; ++x) {
                    const std::size_t i = static_cast<std::size_t>(y) * 173 + static_cast<std::size_t>(x);
                    ++owner[i];
                    const std::uint32_t id = visible.triangle_id[i];
                    if (id != tessref::kNoTriangle && id >= draw_first && id < draw_end) visible_weights[i] = r.weights.at(x, y);
                }
        }
        for (std::size_t i = 0; i < owner.size(); ++i) {
            EXPECT_LE(owner[i], 1) << "pixel " << i << " in two rectangles";
            const bool changed = visible.triangle_id[i] != before.triangle_id[i] || visible.depth[i] != before.depth[i];
            if (changed) EXPECT_EQ(owner[i], 1) << "pixel " << i << " changed outside drawn()";
        }
    }
    const tessref::RasterStats many = rasterizer.stats();
    EXPECT_GT(one.fragments_passed, 1000u);
    EXPECT_GT(one.triangles_clipped, 0u);
    EXPECT_GT(one.primitives_culled, 0u);
    EXPECT_TRUE(same_bytes(batched.triangle_id, whole.triangle_id));
    EXPECT_TRUE(same_bytes(batched.depth, whole.depth));
    EXPECT_TRUE(same_bytes(batched.barycentric, whole.barycentric));
    EXPECT_TRUE(same_bytes(batched.barycentric_dx, whole.barycentric_dx));
    EXPECT_TRUE(same_bytes(batched.barycentric_dy, whole.barycentric_dy));
    EXPECT_TRUE(same_bytes(batched.fragment_count, whole.fragment_count));
    EXPECT_TRUE(same_bytes(batched.front_facing, whole.front_facing));
    expect_same_counts(many, one);
    EXPECT_TRUE(same_bytes(visible.triangle_id, whole.triangle_id));
    EXPECT_TRUE(same_bytes(visible.depth, whole.depth));
    EXPECT_TRUE(same_bytes(visible_weights, whole.barycentric));
    EXPECT_TRUE(visible.barycentric.empty());
    EXPECT_TRUE(same_bytes(visible.barycentric_dx, whole.barycentric_dx));
    EXPECT_TRUE(same_bytes(visible.barycentric_dy, whole.barycentric_dy));
    EXPECT_TRUE(visible.colour.empty() && visible.fragment_count.empty() && visible.front_facing.empty());
    const tessref::RasterStats lean = visible_rasterizer.stats();
    EXPECT_EQ(lean.primitives, one.primitives);
    EXPECT_EQ(lean.primitives_culled, one.primitives_culled);
    EXPECT_EQ(lean.fragments, one.fragments);
    EXPECT_EQ(lean.fragments_passed, one.fragments_passed);
}

// triangle_blocks: every block's two runs hold the vertices of its triangles, each run 2 to
// kMaxTriangleBlockRun vertices long and below the vertex count, or the block has none (then
// its triangles are tested one by one); on patterns of both domains at several levels and on
// a soup whose triangles' vertices lie far apart.
TEST(Rasterizer, TriangleBlocksHoldTheirTrianglesVertices) {
    std::vector<std::vector<std::array<std::uint32_t, 3>>> lists;
    for (const auto domain : {tessref::Domain::quads, tessref::Domain::triangles})
        for (const float level : {1.0f, 2.0f, 5.3f, 16.0f, 63.0f}) {
            const tessref::Pattern pattern =
                tessref::tessellate(tessref::TessSettings{domain, tessref::Spacing::fractional_odd},
                                    tessref::TessLevels{{level, level * 0.7f, level, 3.0f}, {level, level * 0.9f}});
            std::vector<std::array<std::uint32_t, 3>> tris;
            for (std::size_t t = 0; t < pattern.primitive_count(); ++t) {
                const auto p = pattern.primitive(t);
                tris.push_back({p[0], p[1], p[2]});
            }
            lists.push_back(tris);
        }
    std::mt19937 rng(63);
    std::uniform_int_distribution<std::uint32_t> index(0, 500);
    std::vector<std::array<std::uint32_t, 3>> soup(203);
    for (auto& tri : soup) tri = {index(rng), index(rng), index(rng)};
    soup[5] = {7, 7, 7};  // one vertex alone: a run takes a neighbour
    lists.push_back(soup);
    std::size_t testable = 0, blocks_seen = 0;
    for (const auto& tris : lists) {
        const std::vector<tessref::TriangleBlock> blocks = tessref::triangle_blocks(tris);
        ASSERT_EQ(blocks.size(), (tris.size() + tessref::kTriangleBlock - 1) / tessref::kTriangleBlock);
        std::uint32_t max_index = 0;
        for (const auto& tri : tris) max_index = std::max({max_index, tri[0], tri[1], tri[2]});
        for (std::size_t k = 0; k < blocks.size(); ++k) {
            const tessref::TriangleBlock& b = blocks[k];
            ++blocks_seen;
            if (b.count[0] == 0) continue;
            ++testable;
            for (int r = 0; r < 2; ++r) {
                EXPECT_GE(b.count[r], 2u);
                EXPECT_LE(b.count[r], tessref::kMaxTriangleBlockRun);
                EXPECT_LE(b.first[r] + b.count[r] - 1, max_index);
            }
            for (std::size_t t = k * tessref::kTriangleBlock; t < std::min(tris.size(), (k + 1) * tessref::kTriangleBlock); ++t)
                for (const std::uint32_t v : tris[t])
                    EXPECT_TRUE((v >= b.first[0] && v < b.first[0] + b.count[0]) ||
                                (v >= b.first[1] && v < b.first[1] + b.count[1]))
                        << "block " << k << " triangle " << t << " vertex " << v;
        }
    }
    EXPECT_GT(testable, blocks_seen * 9 / 10 - 30);  // the patterns' blocks nearly all have runs
}

// A chunk drawn with its triangle blocks leaves the buffers and counts it leaves without:
// a level-63 pattern at about 30 triangles a pixel, on a slope through the pixel grid, with a
// corner behind the eye (its blocks hold a vertex that is not inside) and one vertex on the
// viewport's edge.
TEST(Rasterizer, TriangleBlocksDrawWhatTheTrianglesDraw) {
    const tessref::Pattern pattern =
        tessref::tessellate(tessref::TessSettings{tessref::Domain::quads, tessref::Spacing::fractional_odd},
                            tessref::TessLevels{{63, 63, 63, 63}, {63, 63}});
    std::vector<std::array<std::uint32_t, 3>> tris;
    for (std::size_t t = 0; t < pattern.primitive_count(); ++t) {
        const auto p = pattern.primitive(t);
        tris.push_back({p[0], p[1], p[2]});
    }
    std::vector<glm::vec4> positions;
    for (const auto& q : pattern.points())
        positions.emplace_back(1.9f * q.u - 0.97f + 0.1f * q.v, 1.8f * q.v - 0.9f, 0.3f * q.u - 0.2f * q.v, 1.0f);
    positions[0].w = -0.5f;
    positions[positions.size() / 2].x = 1.0f;
    const std::vector<tessref::TriangleBlock> blocks = tessref::triangle_blocks(tris);
    tessref::RasterSettings settings;
    settings.depth_func = tessref::DepthFunc::less;
    tessref::Framebuffer plain = tessref::Framebuffer::create_visibility(31, 17);
    tessref::Framebuffer blocked = tessref::Framebuffer::create_visibility(31, 17);
    tessref::Rasterizer plain_rasterizer(plain, settings), blocked_rasterizer(blocked, settings);
    plain_rasterizer.draw(std::vector<tessref::RasterChunk>{{positions, tris, 5, true}});
    blocked_rasterizer.draw(std::vector<tessref::RasterChunk>{{positions, tris, 5, true, blocks}});
    const tessref::RasterStats a = plain_rasterizer.stats(), b = blocked_rasterizer.stats();
    ASSERT_GT(a.fragments_passed, 400u);
    EXPECT_GT(a.triangles_clipped, 0u);
    EXPECT_TRUE(same_bytes(blocked.triangle_id, plain.triangle_id));
    EXPECT_TRUE(same_bytes(blocked.depth, plain.depth));
    expect_same_counts(b, a);
    // Blocks of another chunk's triangles are refused.
    EXPECT_THROW(blocked_rasterizer.draw(std::vector<tessref::RasterChunk>{
                     {positions, std::span<const std::array<std::uint32_t, 3>>(tris).first(9), 0, true, blocks}}),
                 tessref::Error);
}

// A draw of one small triangle reports the quads around it, not its whole tile: the
// streamed render resolves only what drawn() names.
TEST(Rasterizer, DrawnIsTheQuadsAroundWhatWasDrawn) {
    tessref::Framebuffer fb = tessref::Framebuffer::create_visibility(173, 97);
    tessref::Rasterizer rasterizer(fb, {});
    // About three pixels wide, around NDC (0.2, 0): window (103.8, 48.5), inside tile (1, 0).
    const std::vector<glm::vec4> positions{{0.18f, -0.03f, 0.0f, 1.0f}, {0.23f, -0.03f, 0.0f, 1.0f}, {0.2f, 0.03f, 0.0f, 1.0f}};
    const std::vector<std::array<std::uint32_t, 3>> triangles{{0, 1, 2}};
    rasterizer.draw(std::vector<tessref::RasterChunk>{{positions, triangles, 0}});
    ASSERT_GT(rasterizer.stats().fragments_passed, 0u);
    const std::vector<tessref::Rasterizer::Rect> drawn = rasterizer.drawn();
    ASSERT_EQ(drawn.size(), 1u);
    EXPECT_LE(drawn[0].width, 6);
    EXPECT_LE(drawn[0].height, 6);
    for (int y = 0; y < 97; ++y)
        for (int x = 0; x < 173; ++x)
            if (fb.triangle_id[static_cast<std::size_t>(y) * 173 + static_cast<std::size_t>(x)] != tessref::kNoTriangle) {
                EXPECT_TRUE(x >= drawn[0].x && x < drawn[0].x + drawn[0].width && y >= drawn[0].row &&
                            y < drawn[0].row + drawn[0].height)
                    << x << ", " << y;
            }
}

TEST(Rasterizer, VertexIndexOutsideTheChunkIsAnError) {
    tessref::Framebuffer fb = tessref::Framebuffer::create(8, 8);
    tessref::Rasterizer rasterizer(fb, {});
    const std::vector<glm::vec4> positions(3, glm::vec4(0, 0, 0, 1));
    const std::vector<std::array<std::uint32_t, 3>> triangles{{0, 1, 3}};
    const std::vector<tessref::RasterChunk> draw{{positions, triangles, 0}};
    EXPECT_THROW(rasterizer.draw(draw), tessref::Error);
}

// A draw whose chunks are made in its tasks (the streamed render evaluates them there) and
// one of whose makers throws: the exception leaves the draw, which draws nothing, and the
// rasterizer draws on as before.
TEST(Rasterizer, AChunkThatCannotBeMadeDrawsNothing) {
    tessref::Framebuffer fb = tessref::Framebuffer::create_visibility(64, 64);
    tessref::Rasterizer rasterizer(fb, {});
    const std::vector<glm::vec4> positions{{-1.0f, -1.0f, 0.0f, 1.0f}, {1.0f, -1.0f, 0.0f, 1.0f}, {0.0f, 1.0f, 0.0f, 1.0f}};
    const std::vector<std::array<std::uint32_t, 3>> triangles{{0, 1, 2}};
    const tessref::Framebuffer before = fb;
    EXPECT_THROW(rasterizer.draw(4,
                                 [&](std::size_t c) -> tessref::RasterChunk {
                                     if (c == 2) throw tessref::Error("no chunk 2", tessref::Where::at_key("chunk"));
                                     return {positions, triangles, static_cast<std::uint32_t>(c)};
                                 }),
                 tessref::Error);
    EXPECT_TRUE(same_bytes(fb.triangle_id, before.triangle_id));
    EXPECT_TRUE(same_bytes(fb.depth, before.depth));
    EXPECT_EQ(rasterizer.stats().fragments, 0u);
    EXPECT_TRUE(rasterizer.drawn().empty());
    // The next draw makes its chunks c = 0, 1, 2 in any order and draws them in that order:
    // the same triangle three times at depth 0, LESS: the first one, id 10, stays.
    rasterizer.draw(3, [&](std::size_t c) -> tessref::RasterChunk {
        return {positions, triangles, static_cast<std::uint32_t>(10 + c)};
    });
    EXPECT_EQ(fb.triangle_id[32 * 64 + 32], 10u);
    EXPECT_GT(rasterizer.stats().fragments_passed, 0u);
}

// pixel_provenance of a streamed render evaluates its triangle again: the same vertices,
// world position, normal (face normals too), uv and level source as with the whole surface.
TEST(RenderStream, ProvenanceMatchesTheWholeSurface) {
    for (const char* name : {"thesis-all-10.toml", "cosc422.toml", "pn-triangles.toml", "lab4-canyon.toml"}) {
        SCOPED_TRACE(name);
        const tessref::Scene scene = tessref::load_scene((kScenes / name).string());
        tessref::RenderOptions options;
        options.size = {160, 100};
        options.camera_relative = std::string(name) == "lab4-canyon.toml";
        const tessref::RenderResult streamed = tessref::render_scene(scene, options);
        options.keep_surface = true;
        const tessref::RenderResult whole = tessref::render_scene(scene, options);
        ASSERT_TRUE(streamed.stream);
        int covered = 0;
        for (int y = 0; y < 100; y += 3) {
            for (int x = 0; x < 160; x += 3) {
                const tessref::PixelProvenance a = tessref::pixel_provenance(streamed, x, y);
                const tessref::PixelProvenance b = tessref::pixel_provenance(whole, x, y);
                ASSERT_EQ(a.covered, b.covered);
                if (!a.covered) continue;
                ++covered;
                EXPECT_EQ(a.vertices, b.vertices);
                EXPECT_EQ(a.barycentric, b.barycentric);
                EXPECT_EQ(a.vertex_tess_coords, b.vertex_tess_coords);
                EXPECT_EQ(a.world_position, b.world_position);
                EXPECT_EQ(a.normal, b.normal);
                EXPECT_EQ(a.uv, b.uv);
                EXPECT_EQ(a.level_source, b.level_source);
                EXPECT_EQ(a.patch_levels.outer, b.patch_levels.outer);
            }
        }
        EXPECT_GT(covered, 100);
    }
}

// RenderOptions::provenance off leaves patch_id, tess_coord, barycentric and level empty and
// changes no other buffer, streamed or whole, filled or with lines; pixel_provenance then
// refuses.
TEST(RenderStream, WithoutProvenanceTheOtherBuffersAreTheSame) {
    for (const char* name : {"thesis-all-10.toml", "jacksboro.toml", "pn-triangles.toml", "terrain-pom.toml"}) {
        for (const tessref::RenderMode mode :
             {tessref::RenderMode::fill, tessref::RenderMode::fill_with_wireframe, tessref::RenderMode::wireframe}) {
            for (const bool keep : {false, true}) {
                SCOPED_TRACE(std::string(name) + " mode " + std::to_string(static_cast<int>(mode)) + " keep " +
                             std::to_string(keep));
                const tessref::Scene scene = tessref::load_scene((kScenes / name).string());
                tessref::RenderOptions options;
                options.size = {160, 100};
                options.mode = mode;
                options.keep_surface = keep;
                const tessref::RenderResult with = tessref::render_scene(scene, options);
                options.provenance = false;
                const tessref::RenderResult without = tessref::render_scene(scene, options);
                EXPECT_EQ(with.patch_id.size(), 160u * 100u);
                EXPECT_EQ(with.barycentric.size(), 160u * 100u);
                EXPECT_TRUE(without.patch_id.empty() && without.tess_coord.empty() && without.level.empty());
                EXPECT_TRUE(without.barycentric.empty()) << "barycentric";
                EXPECT_GT(with.stats.covered_pixels, 0u);
                EXPECT_TRUE(same_bytes(with.colour, without.colour)) << "colour";
                EXPECT_TRUE(same_bytes(with.depth, without.depth)) << "depth";
                EXPECT_TRUE(same_bytes(with.triangle_id, without.triangle_id)) << "triangle_id";
                EXPECT_EQ(with.stats.covered_pixels, without.stats.covered_pixels);
                EXPECT_THROW(tessref::pixel_provenance(without, 80, 50), tessref::Error);
            }
        }
    }
}

// The weights a render with provenance keeps (RenderResult::barycentric, which `tessref
// inspect --pixel` prints) are those one rasterize() of the whole surface writes into its
// Framebuffer, byte for byte, where the streamed render keeps its weights per tile for one
// draw only: the surface of run_pipeline, projected as the renderer projects it (float mvp,
// ((m0 x + m1 y) + m2 z) + m3), in one pass. Streamed and whole, several batches.
TEST(RenderStream, WeightsAreOneRasterizePassesWeights) {
    for (const char* name : {"thesis-all-10.toml", "jacksboro.toml", "pn-triangles.toml", "thesis-constant-64.toml"}) {
        SCOPED_TRACE(name);
        tessref::Scene scene = tessref::load_scene((kScenes / name).string());
        scene.camera->viewport = {320, 200};
        const tessref::PipelineResult pipe = tessref::run_pipeline(scene, {});
        tessref::RenderOptions options;
        const tessref::RenderResult streamed = tessref::render_scene(scene, options);
        options.keep_surface = true;
        const tessref::RenderResult whole = tessref::render_scene(scene, options);
        ASSERT_TRUE(streamed.stream && streamed.pipeline->mesh.triangles.empty());

        const glm::mat4 m = streamed.mvp;
        std::vector<glm::vec4> clip;
        for (const glm::dvec3& position : pipe.mesh.positions) {
            const glm::vec3 p(position);
            glm::vec4 sum = m[0] * p.x;
            sum += m[1] * p.y;
            sum += m[2] * p.z;
            sum += m[3];
            clip.push_back(sum);
        }
        tessref::Framebuffer fb = tessref::Framebuffer::create(320, 200);
        tessref::RasterInput input;
        input.positions = clip;
        input.triangles = pipe.mesh.triangles;
        tessref::rasterize(fb, input, {});
        EXPECT_TRUE(same_bytes(streamed.triangle_id, fb.triangle_id)) << "triangle_id";
        EXPECT_TRUE(same_bytes(streamed.barycentric, fb.barycentric)) << "streamed";
        EXPECT_TRUE(same_bytes(whole.barycentric, fb.barycentric)) << "whole";
        EXPECT_GT(streamed.stats.covered_pixels, 1000u);
    }
}

// PatchStream::emit with VertexNormals::later writes everything but the vertex normals, and
// later_normals gives each vertex the normal emit() writes with VertexNormals::now: the
// streamed render relies on both to compute normals only where a triangle wins a pixel.
// Normal-map, height-field (at lab 4's mip level) and PN normals, both precisions and
// camera-relative evaluation.
TEST(PatchStream, DeferredVertexNormalsAreTheEmittedOnes) {
    using tessref::PatchStream;
    int patches_compared = 0;
    for (const char* name : {"thesis-all-10.toml", "lab4-canyon.toml", "terrain-pom.toml", "pn-triangles.toml"}) {
        for (int variant = 0; variant < 3; ++variant) {
            SCOPED_TRACE(std::string(name) + " variant " + std::to_string(variant));
            const tessref::Scene scene = tessref::load_scene((kScenes / name).string());
            tessref::PipelineOptions options;
            options.precision = variant == 1 ? tessref::Precision::exact : tessref::Precision::gpu;
            options.camera_relative = variant == 2;
            const PatchStream stream(scene, options);
            ASSERT_TRUE(stream.has_normals());
            const std::size_t n = stream.patch_count();
            for (std::size_t p = 0; p < n; p += std::max<std::size_t>(1, n / 16)) {
                const std::size_t vertices = stream.vertex_base(p + 1) - stream.vertex_base(p);
                const std::size_t triangles = stream.triangle_base(p + 1) - stream.triangle_base(p);
                tessref::SurfaceMesh now, later, some, lean;
                std::vector<glm::dvec3> faces, lean_faces;
                stream.size(now, faces, vertices, triangles);
                stream.size(later, faces, vertices, triangles);
                stream.size(lean, lean_faces, vertices, triangles);
                const glm::dvec3 untouched(std::numeric_limits<double>::quiet_NaN());
                std::fill(later.normals.begin(), later.normals.end(), untouched);
                std::fill(lean.normals.begin(), lean.normals.end(), untouched);
                std::fill(lean.tess_coords.begin(), lean.tess_coords.end(), glm::vec3(-1.0f));
                std::fill(lean.patch_ids.begin(), lean.patch_ids.end(), 0xdeadbeefu);
                stream.emit(p, now, 0, 0, &faces);
                stream.emit(p, later, 0, 0, &faces, PatchStream::VertexNormals::later);
                // Provenance::later as well (the renderer without provenance buffers): the
                // vertices' patch ids and tess coords are not written, all the rest is.
                stream.emit(p, lean, 0, 0, &lean_faces, PatchStream::VertexNormals::later,
                            PatchStream::Provenance::later);
                for (const glm::dvec3& normal : later.normals) ASSERT_TRUE(std::isnan(normal.x));
                EXPECT_TRUE(same_bytes(later.positions, now.positions));
                EXPECT_TRUE(same_bytes(later.uvs, now.uvs));
                EXPECT_TRUE(same_bytes(later.tess_coords, now.tess_coords));
                EXPECT_TRUE(same_bytes(later.patch_ids, now.patch_ids));
                EXPECT_TRUE(same_bytes(later.triangles, now.triangles));
                for (const glm::dvec3& normal : lean.normals) ASSERT_TRUE(std::isnan(normal.x));
                for (const glm::vec3& c : lean.tess_coords) ASSERT_EQ(c, glm::vec3(-1.0f));
                for (const std::uint32_t id : lean.patch_ids) ASSERT_EQ(id, 0xdeadbeefu);
                EXPECT_TRUE(same_bytes(lean.positions, now.positions));
                EXPECT_TRUE(same_bytes(lean.uvs, now.uvs));
                EXPECT_TRUE(same_bytes(lean.triangles, now.triangles));
                EXPECT_TRUE(same_bytes(lean_faces, faces));
                // Every other vertex, backwards: later_normals takes any subset in any order,
                // writes those vertices' normals and no other.
                std::vector<std::uint32_t> points;
                for (std::size_t v = vertices; v-- > 0;)
                    if (v % 2 == 0) points.push_back(static_cast<std::uint32_t>(v));
                stream.later_normals(p, points, later, 0);
                stream.later_normals(p, points, lean, 0);
                for (std::size_t v = 0; v < vertices; ++v) {
                    if (v % 2 != 0) {
                        ASSERT_TRUE(std::isnan(later.normals[v].x) && std::isnan(lean.normals[v].x)) << "vertex " << v;
                        continue;
                    }
                    ASSERT_EQ(std::memcmp(&later.normals[v], &now.normals[v], sizeof(glm::dvec3)), 0)
                        << "patch " << p << " vertex " << v;
                    ASSERT_EQ(std::memcmp(&lean.normals[v], &now.normals[v], sizeof(glm::dvec3)), 0)
                        << "patch " << p << " vertex " << v;
                }
                // In a run of patches (emit_run, as the streamed render emits a chunk), the
                // patch's vertices from its place in the run on.
                if (p + 1 < n) {
                    const std::size_t first = stream.vertex_base(p + 1) - stream.vertex_base(p);
                    const std::size_t next = stream.vertex_base(p + 2) - stream.vertex_base(p + 1);
                    stream.emit_run(p, p + 2, some, nullptr, PatchStream::VertexNormals::later, PatchStream::Provenance::later);
                    std::fill(some.normals.begin(), some.normals.end(), untouched);
                    std::vector<std::uint32_t> all(next);
                    for (std::size_t v = 0; v < next; ++v) all[v] = static_cast<std::uint32_t>(v);
                    stream.later_normals(p + 1, all, some, first);
                    tessref::SurfaceMesh alone;
                    stream.size(alone, faces, next, stream.triangle_base(p + 2) - stream.triangle_base(p + 1));
                    stream.emit(p + 1, alone, 0, 0, nullptr);
                    for (std::size_t v = 0; v < first; ++v) ASSERT_TRUE(std::isnan(some.normals[v].x));
                    for (std::size_t v = 0; v < next; ++v)
                        ASSERT_EQ(std::memcmp(&some.normals[first + v], &alone.normals[v], sizeof(glm::dvec3)), 0)
                            << "patch " << p + 1 << " vertex " << v;
                }
                ++patches_compared;
            }
        }
    }
    EXPECT_GE(patches_compared, 4 * 3 * 4);  // at least 4 patches of each of the 12 streams
}

// PatchStream::shared_triangles, where a patch has them, are the triangles emit() writes less
// the patch's first vertex, and emit with Triangles::shared writes everything else as it
// does with Triangles::write and leaves mesh.triangles alone: the streamed render draws and
// resolves a chunk of one patch from the pattern's own indices. A reversed surface, a
// geometry shader's output and a pattern without triangles have none (a culled patch's
// are empty too). Every shipped scene that
// streams, at most 16 patches each; both kinds of patch occur.
TEST(PatchStream, SharedTrianglesAreTheEmittedOnes) {
    using tessref::PatchStream;
    std::size_t shared_patches = 0, other_patches = 0;
    std::vector<std::pair<std::string, tessref::Scene>> scenes;
    for (const fs::path& path : shipped_scenes())
        scenes.emplace_back(path.filename().string(), tessref::load_scene(path.string()));
    // No shipped terrain is reversed: one made so (clockwise output, the grid facing up).
    tessref::Scene cw = tessref::load_scene((kScenes / "thesis-all-10.toml").string());
    cw.generator.winding = tessref::Winding::cw;
    scenes.emplace_back("thesis-all-10 clockwise", cw);
    for (const auto& [name, scene] : scenes) {
        if (!PatchStream::streams(scene)) continue;
        SCOPED_TRACE(name);
        const PatchStream stream(scene, {});
        const std::size_t n = stream.patch_count();
        for (std::size_t p = 0; p < n; p += std::max<std::size_t>(1, n / 16)) {
            const std::size_t vertices = stream.vertex_base(p + 1) - stream.vertex_base(p);
            const std::size_t triangles = stream.triangle_base(p + 1) - stream.triangle_base(p);
            const auto shared = stream.shared_triangles(p);
            if (triangles == 0) continue;  // a culled patch: nothing to share, nothing to refuse
            if (shared.empty()) {
                ++other_patches;
                EXPECT_TRUE(stream.reversed() || stream.geometry_shader() ||
                            stream.pattern(p).vertices_per_primitive() != 3)
                    << "patch " << p;
                tessref::SurfaceMesh mesh;
                std::vector<glm::dvec3> faces;
                stream.size(mesh, faces, vertices, triangles);
                EXPECT_THROW(stream.emit(p, mesh, 0, 0, &faces, PatchStream::VertexNormals::now,
                                         PatchStream::Provenance::now, PatchStream::Triangles::shared),
                             tessref::Error);
                continue;
            }
            ++shared_patches;
            // At an offset, as in a run: the emitted indices are the shared ones plus it.
            const std::size_t offset = 5;
            tessref::SurfaceMesh now, lean;
            std::vector<glm::dvec3> faces, lean_faces;
            stream.size(now, faces, offset + vertices, triangles);
            stream.size(lean, lean_faces, offset + vertices, triangles);
            const std::array<std::uint32_t, 3> untouched{7, 7, 7};
            std::fill(lean.triangles.begin(), lean.triangles.end(), untouched);
            stream.emit(p, now, offset, 0, &faces);
            stream.emit(p, lean, offset, 0, &lean_faces, PatchStream::VertexNormals::now, PatchStream::Provenance::now,
                        PatchStream::Triangles::shared);
            ASSERT_EQ(shared.size(), triangles);
            for (std::size_t t = 0; t < triangles; ++t) {
                for (int k = 0; k < 3; ++k) {
                    ASSERT_LT(shared[t][k], vertices) << "patch " << p << " triangle " << t;
                    ASSERT_EQ(shared[t][k] + offset, now.triangles[t][k]) << "patch " << p << " triangle " << t;
                }
                ASSERT_EQ(lean.triangles[t], untouched);
            }
            EXPECT_TRUE(same_bytes(lean.positions, now.positions));
            EXPECT_TRUE(same_bytes(lean.uvs, now.uvs));
            EXPECT_TRUE(same_bytes(lean.normals, now.normals));
            EXPECT_TRUE(same_bytes(lean.tess_coords, now.tess_coords));
            EXPECT_TRUE(same_bytes(lean.patch_ids, now.patch_ids));
            EXPECT_TRUE(same_bytes(lean_faces, faces));
        }
        // A run of one patch with Triangles::shared: no triangles, the face normals all there.
        if (!stream.shared_triangles(0).empty()) {
            tessref::SurfaceMesh run;
            std::vector<glm::dvec3> faces;
            stream.emit_run(0, 1, run, &faces, PatchStream::VertexNormals::now, PatchStream::Provenance::now,
                            PatchStream::Triangles::shared);
            EXPECT_TRUE(run.triangles.empty());
            EXPECT_EQ(faces.size(), stream.face_normals() ? stream.triangle_base(1) : 0u);
        }
    }
    EXPECT_GT(shared_patches, 100u);
    EXPECT_GT(other_patches, 0u);
}

// PatchStream::Projection: the clip positions emit() computes as it evaluates are gl_Position
// of the positions it writes, mvp * vec4(p rounded to float, 1) summed column by column in
// order, a rounding a step (llvmpipe's order, written out here), bit for bit, at every SIMD
// level the CPU runs; everything else emit() writes is unchanged, and positions false leaves
// mesh.positions as they were. Every shipped scene that streams (terrains and PN, a patch's
// vertices at an offset as in a run), both precisions and camera-relative evaluation.
TEST(PatchStream, ProjectionIsGlPositionOfTheEmittedPositions) {
    using tessref::PatchStream;
    const tessref::SimdLevel saved = tessref::simd_level();
    std::vector<tessref::SimdLevel> levels{tessref::SimdLevel::sse2};
    if (tessref::cpu_simd_level() == tessref::SimdLevel::avx2) levels.push_back(tessref::SimdLevel::avx2);
    std::size_t vertices_compared = 0;
    for (const fs::path& path : shipped_scenes()) {
        const tessref::Scene scene = tessref::load_scene(path.string());
        if (!PatchStream::streams(scene) || !scene.camera) continue;
        for (int variant = 0; variant < 3; ++variant) {
            // A user's shaders run in gpu precision and world coordinates only.
            if (variant > 0 && !scene.shaders.empty()) continue;
            tessref::PipelineOptions options;
            options.precision = variant == 1 ? tessref::Precision::exact : tessref::Precision::gpu;
            options.camera_relative = variant == 2;
            const PatchStream stream(scene, options);
            const glm::mat4 mvp(tessref::camera_moved_by(*scene.camera, stream.origin()).view_projection());
            for (const tessref::SimdLevel level : levels) {
                tessref::set_simd_level(level);
                SCOPED_TRACE(path.filename().string() + " variant " + std::to_string(variant) + " " +
                             tessref::simd_level_name(level));
                const std::size_t n = stream.patch_count();
                for (std::size_t p = 0; p < n; p += std::max<std::size_t>(1, n / 8)) {
                    const std::size_t offset = 3;
                    const std::size_t vertices = stream.vertex_base(p + 1) - stream.vertex_base(p);
                    const std::size_t triangles = stream.triangle_base(p + 1) - stream.triangle_base(p);
                    tessref::SurfaceMesh now, projected, lean;
                    std::vector<glm::dvec3> faces, projected_faces, lean_faces;
                    stream.size(now, faces, offset + vertices, triangles);
                    stream.size(projected, projected_faces, offset + vertices, triangles);
                    stream.size(lean, lean_faces, offset + vertices, triangles);
                    const glm::dvec3 untouched(-7.0);
                    std::fill(lean.positions.begin() + offset, lean.positions.end(), untouched);
                    const glm::vec4 unwritten(-9.0f);
                    std::vector<glm::vec4> clip(offset + vertices, unwritten), lean_clip(offset + vertices, unwritten);
                    PatchStream::Projection with{mvp, clip.data()};
                    PatchStream::Projection without{mvp, lean_clip.data(), false};
                    stream.emit(p, now, offset, 0, &faces);
                    stream.emit(p, projected, offset, 0, &projected_faces, PatchStream::VertexNormals::now,
                                PatchStream::Provenance::now, PatchStream::Triangles::write, &with);
                    stream.emit(p, lean, offset, 0, &lean_faces, PatchStream::VertexNormals::now,
                                PatchStream::Provenance::now, PatchStream::Triangles::write, &without);
                    EXPECT_TRUE(with.finite && without.finite);
                    for (std::size_t v = 0; v < offset; ++v) ASSERT_TRUE(same_bytes(std::vector{clip[v]}, {unwritten}));
                    for (std::size_t v = offset; v < offset + vertices; ++v) {
                        const glm::vec3 q(now.positions[v]);
                        glm::vec4 expected = mvp[0] * q.x;
                        const glm::vec4 y = mvp[1] * q.y;
                        expected += y;
                        const glm::vec4 z = mvp[2] * q.z;
                        expected += z;
                        expected += mvp[3];
                        ASSERT_EQ(std::memcmp(&clip[v], &expected, sizeof expected), 0) << "patch " << p << " vertex " << v;
                        ASSERT_EQ(std::memcmp(&lean_clip[v], &expected, sizeof expected), 0)
                            << "patch " << p << " vertex " << v;
                        ++vertices_compared;
                    }
                    EXPECT_TRUE(same_bytes(projected.positions, now.positions));
                    EXPECT_TRUE(same_bytes(projected.uvs, now.uvs));
                    EXPECT_TRUE(same_bytes(projected.normals, now.normals));
                    EXPECT_TRUE(same_bytes(projected.tess_coords, now.tess_coords));
                    EXPECT_TRUE(same_bytes(projected.triangles, now.triangles));
                    EXPECT_TRUE(same_bytes(projected_faces, faces));
                    // positions false: a terrain leaves them unless emit() computes face
                    // normals from them; a program without its own projection (PN) writes
                    // them as emit() always did. All the rest as emit() writes it.
                    const bool left = std::all_of(lean.positions.begin() + offset, lean.positions.end(),
                                                  [&](const glm::dvec3& q) { return q == untouched; });
                    EXPECT_TRUE(left || same_bytes(lean.positions, now.positions));
                    if (vertices > 0)  // a culled patch has none to leave
                        EXPECT_EQ(left, scene.evaluation.model != tessref::EvaluationModel::pn && !stream.face_normals());
                    EXPECT_TRUE(same_bytes(lean_faces, faces));
                    EXPECT_TRUE(same_bytes(lean.uvs, now.uvs));
                    EXPECT_TRUE(same_bytes(lean.normals, now.normals));
                    EXPECT_TRUE(same_bytes(lean.triangles, now.triangles));
                }
            }
        }
    }
    tessref::set_simd_level(saved);
    EXPECT_GT(vertices_compared, 100000u);
}

// RenderOptions::colour8 keeps the image as the unorm8 codes to_rgba8 gives of the float
// colour, byte for byte, background included, and leaves the float colour empty and every
// other buffer as it was: streamed (each pixel converted as it is shaded) and whole, filled
// or with lines, and ray traced. The codes come from the float render of the same options,
// an independent path (to_rgba8 of RenderResult::colour).
TEST(RenderStream, EightBitColourIsTheFloatColoursCodes) {
    std::size_t compared = 0, with_background = 0;
    for (const fs::path& path : shipped_scenes()) {
        const tessref::Scene scene = tessref::load_scene(path.string());
        if (!scene.camera) continue;
        const bool streams = tessref::PatchStream::streams(scene);
        for (int variant = 0; variant < (streams ? 5 : 1); ++variant) {
            SCOPED_TRACE(path.filename().string() + " variant " + std::to_string(variant));
            tessref::RenderOptions options;
            options.size = {160, 100};
            options.keep_surface = variant == 1;
            if (variant == 2) options.mode = tessref::RenderMode::fill_with_wireframe;
            if (variant == 3) options.provenance = false;
            if (variant == 4) options.mode = tessref::RenderMode::wireframe;
            const tessref::RenderResult floats = tessref::render_scene(scene, options);
            options.colour8 = true;
            const tessref::RenderResult codes = tessref::render_scene(scene, options);
            const std::vector<std::uint8_t> expected = tessref::to_rgba8(floats);
            ASSERT_EQ(codes.rgba8.size() * 4, expected.size());
            EXPECT_EQ(std::memcmp(codes.rgba8.data(), expected.data(), expected.size()), 0) << "rgba8";
            EXPECT_TRUE(codes.colour.empty());
            EXPECT_TRUE(floats.rgba8.empty());
            EXPECT_TRUE(same_bytes(tessref::to_rgba8(codes), expected));
            EXPECT_TRUE(same_bytes(floats.depth, codes.depth)) << "depth";
            EXPECT_TRUE(same_bytes(floats.triangle_id, codes.triangle_id)) << "triangle_id";
            EXPECT_TRUE(same_bytes(floats.barycentric, codes.barycentric)) << "barycentric";
            EXPECT_TRUE(same_bytes(floats.patch_id, codes.patch_id)) << "patch_id";
            EXPECT_TRUE(same_bytes(floats.level, codes.level)) << "level";
            EXPECT_GT(codes.stats.covered_pixels, 0u);
            with_background += codes.stats.covered_pixels < 160u * 100u;
            ++compared;
        }
    }
    EXPECT_GE(compared, 14u);
    EXPECT_GE(with_background, 10u);
    // Ray traced: converted at the end.
    const tessref::Scene scene = tessref::load_scene((kScenes / "jacksboro.toml").string());
    tessref::RenderOptions options;
    options.size = {96, 60};
    const tessref::RenderResult floats = tessref::raytrace_scene(scene, options);
    options.colour8 = true;
    const tessref::RenderResult codes = tessref::raytrace_scene(scene, options);
    const std::vector<std::uint8_t> expected = tessref::to_rgba8(floats);
    ASSERT_EQ(codes.rgba8.size() * 4, expected.size());
    EXPECT_EQ(std::memcmp(codes.rgba8.data(), expected.data(), expected.size()), 0);
    EXPECT_TRUE(codes.colour.empty());
    // What needs the float colour says so.
    EXPECT_THROW(tessref::pixel_provenance(codes, 10, 10), tessref::Error);
    EXPECT_THROW(tessref::compare_images(codes, floats), tessref::Error);
}
