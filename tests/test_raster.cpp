// Rasterizer contract (tessref/raster.h), by properties and hand-derived cases; exact
// agreement with llvmpipe is tests/test_raster_llvmpipe.cpp's job.
//
//  * watertightness: triangles sharing edges (random quads split along a diagonal, a fan
//    around a vertex, a perturbed grid of quads reaching outside the view volume, with and
//    without perspective w) cover every pixel exactly once;
//  * the fill rule on pixel-centre-aligned edges (left and bottom edges in GL window
//    coordinates are in, right and top are out), derived by hand;
//  * snapping: round-to-nearest-even to 1/256 pixel, sub-pixel triangles;
//  * huge coordinates, non-finite input, triangles crossing the near plane (one or two
//    vertices behind the eye): only the visible part, no NaN or infinity anywhere;
//  * zero-area triangles are culled; back-face culling;
//  * perspective-correct barycentrics and varyings against the analytic ray/plane values;
//  * depth LESS / LEQUAL order semantics; provenance (ids, patch, tess coord) resolve;
//  * byte-identical buffers for 1, 2 and 4 threads;
//  * one-pixel lines of glPolygonMode(GL_LINE) on axis-aligned and diagonal edges through
//    pixel centres, derived from GL's diamond-exit rule;
//  * the fast paths against their references, bit for bit: vertices prepared four at a time
//    (SSE2) against prepare_vertex, the box test on per-vertex bounds against setup's box, and
//    the setup of a one-pixel box against setup_triangle and its planes.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <tbb/global_control.h>

#include "raster/raster_internal.h"
#include "render_compare.h"
#include "tessref/error.h"
#include "tessref/raster.h"

namespace {

using tessref::CullMode;
using tessref::DepthFunc;
using tessref::Framebuffer;
using tessref::PolygonMode;
using tessref::RasterInput;
using tessref::RasterSettings;
using tessref::RasterStats;
using Index3 = std::array<std::uint32_t, 3>;

struct Mesh {
    std::vector<glm::vec4> positions;
    std::vector<Index3> triangles;
    std::vector<float> varyings;
    int varying_count = 0;

    RasterInput input() const {
        RasterInput in;
        in.positions = positions;
        in.triangles = triangles;
        in.varyings = varyings;
        in.varying_count = varying_count;
        return in;
    }
    std::uint32_t add(glm::vec4 p) {
        positions.push_back(p);
        return static_cast<std::uint32_t>(positions.size() - 1);
    }
};

// Clip-space vertex (w = 1) at GL window position (x, y) of a width x height viewport.
glm::vec4 at_window(float x, float y, int width, int height, float z = 0.0f) {
    return {x * 2.0f / static_cast<float>(width) - 1.0f, y * 2.0f / static_cast<float>(height) - 1.0f, z,
            1.0f};
}

// A window coordinate near `centre` for triangles that put the fill rule to work: with
// probability p_centre exactly a pixel centre, then up to p_half half-way between two, else a
// point of the 1/256 snapping grid within `spread` of centre.
float snapped_near(std::mt19937& rng, float centre, float p_centre, float p_half, float spread) {
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    const float r = unit(rng);
    if (r < p_centre) return std::floor(centre) + 0.5f;
    if (r < p_half) return std::floor(centre);
    return std::round((centre + (unit(rng) * 2.0f * spread - spread)) * 256.0f) / 256.0f;
}

// One triangle a, b, c in GL window coordinates of a width x height viewport (w = 1, z = 0).
Mesh window_triangle(glm::vec2 a, glm::vec2 b, glm::vec2 c, int width, int height) {
    Mesh m;
    for (const glm::vec2& p : {a, b, c}) m.add(at_window(p.x, p.y, width, height));
    m.triangles = {{0, 1, 2}};
    return m;
}

RasterSettings counting() {
    RasterSettings s;
    s.depth_func = DepthFunc::always;  // every fragment counts, none is hidden
    return s;
}

std::vector<std::pair<int, int>> covered(const Framebuffer& fb) {
    std::vector<std::pair<int, int>> out;
    for (int y = 0; y < fb.height; ++y)
        for (int x = 0; x < fb.width; ++x)
            if (fb.fragment_count[fb.index(x, y)]) out.emplace_back(x, y);
    return out;
}

bool all_finite(const Framebuffer& fb) {
    for (float d : fb.depth)
        if (!std::isfinite(d) || d < 0.0f || d > 1.0f) return false;
    for (const glm::vec3& b : fb.barycentric)
        if (!std::isfinite(b.x) || !std::isfinite(b.y) || !std::isfinite(b.z)) return false;
    for (float v : fb.varyings)
        if (!std::isfinite(v)) return false;
    return true;
}

// ---------------------------------------------------------------------------------------
// Shared edges.

TEST(RasterSharedEdges, RandomQuadsSplitAlongADiagonalCoverEachInsidePixelOnce) {
    constexpr int W = 96, H = 80;
    std::mt19937 rng(12345u);
    std::uniform_real_distribution<float> pos(-10.0f, 106.0f), radius(0.3f, 30.0f), jitter(0.05f, 0.95f);
    Framebuffer fb = Framebuffer::create(W, H);
    int quads = 0;
    for (int trial = 0; trial < 600; ++trial) {
        // A convex quad: four points on a circle, one per quadrant.
        const float cx = pos(rng), cy = pos(rng) * H / W, r = radius(rng);
        glm::dvec2 p[4];
        for (int k = 0; k < 4; ++k) {
            const double a = (k + jitter(rng)) * 1.5707963267948966;
            p[k] = {cx + r * std::cos(a), cy + r * std::sin(a)};
        }
        Mesh m;
        for (const glm::dvec2& q : p) m.add(at_window(static_cast<float>(q.x), static_cast<float>(q.y), W, H));
        // Either diagonal, either winding.
        if (trial % 2) m.triangles = {{0, 1, 2}, {0, 2, 3}};
        else m.triangles = {{1, 2, 3}, {3, 0, 1}};
        if (trial % 3 == 0) m.triangles = {{0, 2, 1}, {0, 3, 2}};
        fb.clear();
        tessref::rasterize(fb, m.input(), counting());
        ++quads;
        // The snapped quad differs from the float one by < 1/256 px: test pixel centres more
        // than 0.01 px inside; on the outside, nothing may be covered twice anywhere.
        for (int y = 0; y < H; ++y) {
            for (int x = 0; x < W; ++x) {
                const std::uint32_t count = fb.fragment_count[fb.index(x, y)];
                ASSERT_LE(count, 1u) << "trial " << trial << " pixel " << x << "," << y;
                const glm::dvec2 c(x + 0.5, y + 0.5);
                double inside = 1e9;
                for (int k = 0; k < 4; ++k) {
                    const glm::dvec2 e = p[(k + 1) % 4] - p[k];
                    inside = std::min(inside, (e.x * (c.y - p[k].y) - e.y * (c.x - p[k].x)) / glm::length(e));
                }
                if (inside > 0.01) ASSERT_EQ(count, 1u) << "trial " << trial << " pixel " << x << "," << y;
                if (inside < -0.01) ASSERT_EQ(count, 0u) << "trial " << trial << " pixel " << x << "," << y;
            }
        }
    }
    EXPECT_EQ(quads, 600);
}

TEST(RasterSharedEdges, FanAroundAPixelCentreCoversEachPixelOnce) {
    constexpr int W = 64, H = 64;
    for (const glm::vec2 centre : {glm::vec2(32.5f, 32.5f), glm::vec2(31.0f, 33.0f), glm::vec2(30.37f, 29.81f)}) {
        Mesh m;
        const std::uint32_t c = m.add(at_window(centre.x, centre.y, W, H));
        const int spokes = 13;
        for (int k = 0; k < spokes; ++k) {
            const float a = 6.2831853f * static_cast<float>(k) / spokes;
            m.add(at_window(centre.x + 20.0f * std::cos(a), centre.y + 20.0f * std::sin(a), W, H));
        }
        for (int k = 0; k < spokes; ++k)
            m.triangles.push_back({c, 1u + static_cast<std::uint32_t>(k), 1u + static_cast<std::uint32_t>((k + 1) % spokes)});
        Framebuffer fb = Framebuffer::create(W, H);
        tessref::rasterize(fb, m.input(), counting());
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                const double d = glm::length(glm::dvec2(x + 0.5 - centre.x, y + 0.5 - centre.y));
                const std::uint32_t count = fb.fragment_count[fb.index(x, y)];
                EXPECT_LE(count, 1u);
                if (d < 17.0) EXPECT_EQ(count, 1u) << x << "," << y;  // well inside the 13-gon
                if (d > 20.5) EXPECT_EQ(count, 0u) << x << "," << y;
            }
    }
}

// A grid of quads whose outer ring lies outside the view volume, interior vertices
// perturbed, every vertex scaled by its own w: the clipped triangles still tile the screen.
Mesh screen_grid(unsigned seed, int nx, int ny, bool perspective_w) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> jitter(-0.3f, 0.3f), wdist(0.25f, 4.0f);
    Mesh m;
    const float x0 = -1.4f, x1 = 1.4f, y0 = -1.3f, y1 = 1.3f;
    for (int j = 0; j <= ny; ++j)
        for (int i = 0; i <= nx; ++i) {
            float x = x0 + (x1 - x0) * static_cast<float>(i) / static_cast<float>(nx);
            float y = y0 + (y1 - y0) * static_cast<float>(j) / static_cast<float>(ny);
            if (i > 0 && i < nx) x += jitter(rng) * (x1 - x0) / static_cast<float>(nx);
            if (j > 0 && j < ny) y += jitter(rng) * (y1 - y0) / static_cast<float>(ny);
            const float w = perspective_w ? wdist(rng) : 1.0f;
            m.add(glm::vec4(x, y, 0.25f * jitter(rng), 1.0f) * w);
        }
    auto at = [&](int i, int j) { return static_cast<std::uint32_t>(j * (nx + 1) + i); };
    for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
            if ((i + j) % 2) {
                m.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
                m.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
            } else {
                m.triangles.push_back({at(i, j), at(i + 1, j), at(i, j + 1)});
                m.triangles.push_back({at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)});
            }
        }
    return m;
}

TEST(RasterSharedEdges, PerturbedGridReachingOutsideTheViewTilesTheScreenExactlyOnce) {
    for (const bool w : {false, true}) {
        for (unsigned seed : {1u, 2u, 3u}) {
            const Mesh m = screen_grid(seed, 23, 17, w);
            Framebuffer fb = Framebuffer::create(157, 113);
            const RasterStats stats = tessref::rasterize(fb, m.input(), counting());
            EXPECT_GT(stats.triangles_clipped, 0u);
            std::size_t wrong = 0;
            for (std::uint32_t c : fb.fragment_count) wrong += c != 1u;
            EXPECT_EQ(wrong, 0u) << "seed " << seed << " perspective w " << w;
            EXPECT_EQ(stats.fragments, static_cast<std::uint64_t>(157 * 113));
        }
    }
}

// ---------------------------------------------------------------------------------------
// Fill rule, snapping, sub-pixel and degenerate triangles.

TEST(RasterFillRule, SquareWithEdgesThroughPixelCentresKeepsLeftAndBottom) {
    // Square (2.5,2.5)-(6.5,6.5) in GL window coordinates: the left edge x = 2.5 and the
    // bottom edge y = 2.5 pass through pixel centres and are included, the right (x = 6.5)
    // and top (y = 6.5) ones are not: columns 2..5 x rows 2..5, 16 pixels. Its two halves:
    // the lower-left one has the diagonal x + y = 9 as a right/top edge (centres on it are
    // out): i, j >= 2, i + j < 8, 10 pixels; the upper-right one gets the diagonal (a
    // left/bottom edge for it): 6 pixels.
    constexpr int W = 10, H = 10;
    Mesh m;
    m.add(at_window(2.5f, 2.5f, W, H));
    m.add(at_window(6.5f, 2.5f, W, H));
    m.add(at_window(6.5f, 6.5f, W, H));
    m.add(at_window(2.5f, 6.5f, W, H));
    const std::vector<Index3> lower = {{0, 1, 3}}, upper = {{1, 2, 3}};
    Framebuffer fb = Framebuffer::create(W, H);
    RasterInput in = m.input();
    in.triangles = lower;
    tessref::rasterize(fb, in, counting());
    std::vector<std::pair<int, int>> expected_lower;
    for (int j = 0; j < H; ++j)
        for (int i = 0; i < W; ++i)
            if (i >= 2 && j >= 2 && i + j < 8) expected_lower.emplace_back(i, j);
    auto sorted = [](std::vector<std::pair<int, int>> v) {
        std::sort(v.begin(), v.end(), [](auto a, auto b) { return std::tie(a.second, a.first) < std::tie(b.second, b.first); });
        return v;
    };
    EXPECT_EQ(sorted(covered(fb)), sorted(expected_lower));
    EXPECT_EQ(covered(fb).size(), 10u);

    fb.clear();
    in.triangles = upper;
    tessref::rasterize(fb, in, counting());
    EXPECT_EQ(covered(fb).size(), 6u);

    fb.clear();
    in.triangles = lower;
    tessref::rasterize(fb, in, counting());
    in.triangles = upper;
    tessref::rasterize(fb, in, counting());
    std::vector<std::pair<int, int>> square;
    for (int j = 2; j <= 5; ++j)
        for (int i = 2; i <= 5; ++i) square.emplace_back(i, j);
    EXPECT_EQ(sorted(covered(fb)), sorted(square));
    for (auto [x, y] : square) EXPECT_EQ(fb.fragment_count[fb.index(x, y)], 1u);
}

TEST(RasterFillRule, HorizontalEdgeThroughCentresIsInOnlyAtTheBottom) {
    // A triangle with a horizontal edge at y = 4.5 (through the centres of row 4) and its
    // apex above covers row 4; mirrored (apex below) it does not.
    constexpr int W = 16, H = 12;
    Framebuffer fb = Framebuffer::create(W, H);
    Mesh up;
    up.add(at_window(2.0f, 4.5f, W, H));
    up.add(at_window(14.0f, 4.5f, W, H));
    up.add(at_window(8.0f, 10.0f, W, H));
    up.triangles = {{0, 1, 2}};
    tessref::rasterize(fb, up.input(), counting());
    for (int x = 2; x <= 13; ++x) EXPECT_EQ(fb.fragment_count[fb.index(x, 4)], 1u) << x;
    EXPECT_EQ(fb.fragment_count[fb.index(1, 4)], 0u);

    fb.clear();
    Mesh down;
    down.add(at_window(2.0f, 4.5f, W, H));
    down.add(at_window(8.0f, 0.5f, W, H));
    down.add(at_window(14.0f, 4.5f, W, H));
    down.triangles = {{0, 1, 2}};
    tessref::rasterize(fb, down.input(), counting());
    for (int x = 0; x < W; ++x) EXPECT_EQ(fb.fragment_count[fb.index(x, 4)], 0u) << x;
    EXPECT_GT(fb.fragment_count[fb.index(8, 2)], 0u);
    // Vertical edges through centres: x = 3.5 on the left is in, on the right it is out.
    fb.clear();
    Mesh left;
    left.add(at_window(3.5f, 1.0f, W, H));
    left.add(at_window(10.0f, 5.0f, W, H));
    left.add(at_window(3.5f, 9.0f, W, H));
    left.triangles = {{0, 1, 2}};
    tessref::rasterize(fb, left.input(), counting());
    for (int y = 1; y <= 8; ++y) EXPECT_EQ(fb.fragment_count[fb.index(3, y)], 1u) << y;
    fb.clear();
    Mesh right;
    right.add(at_window(3.5f, 1.0f, W, H));
    right.add(at_window(3.5f, 9.0f, W, H));
    right.add(at_window(-3.0f, 5.0f, W, H));
    right.triangles = {{0, 1, 2}};
    tessref::rasterize(fb, right.input(), counting());
    for (int y = 0; y < H; ++y) EXPECT_EQ(fb.fragment_count[fb.index(3, y)], 0u) << y;
}

TEST(RasterSnapping, RoundsToNearestEvenOn256thsOfAPixel) {
    // snap(v) = rne((v - 0.5) * 256): ties go to the even neighbour.
    EXPECT_EQ(tessref::snap_subpixel(0.5f), 0);
    EXPECT_EQ(tessref::snap_subpixel(0.5f + 1.0f / 512.0f), 0);   // 0.5 -> 0
    EXPECT_EQ(tessref::snap_subpixel(0.5f + 3.0f / 512.0f), 2);   // 1.5 -> 2
    EXPECT_EQ(tessref::snap_subpixel(0.5f + 5.0f / 512.0f), 2);   // 2.5 -> 2
    EXPECT_EQ(tessref::snap_subpixel(0.5f - 1.0f / 512.0f), 0);   // -0.5 -> 0
    EXPECT_EQ(tessref::snap_subpixel(0.5f - 3.0f / 512.0f), -2);  // -1.5 -> -2
    EXPECT_EQ(tessref::snap_subpixel(10.75f), 2624);              // (10.25 * 256)
    EXPECT_EQ(tessref::snap_subpixel(10.5f + 0.7f / 256.0f), 2561);
}

TEST(RasterSubPixel, TinyTrianglesCoverTheCentreTheyContainAndNothingElse) {
    constexpr int W = 8, H = 8;
    Framebuffer fb = Framebuffer::create(W, H);
    auto draw = [&](glm::vec2 a, glm::vec2 b, glm::vec2 c) {
        const Mesh m = window_triangle(a, b, c, W, H);
        fb.clear();
        return tessref::rasterize(fb, m.input(), counting());
    };
    // Around the centre of pixel (3, 4): a 0.1-pixel triangle covers it alone.
    draw({3.45f, 4.45f}, {3.55f, 4.45f}, {3.5f, 4.56f});
    ASSERT_EQ(covered(fb).size(), 1u);
    EXPECT_EQ(covered(fb)[0], std::make_pair(3, 4));
    // A 0.3-pixel triangle in the corner of a pixel misses every centre.
    draw({3.0f, 4.0f}, {3.3f, 4.0f}, {3.0f, 4.3f});
    EXPECT_TRUE(covered(fb).empty());
    // Smaller than the snapping grid: all three vertices snap to one point, zero area, culled,
    // although the centre is inside the float triangle.
    const RasterStats s = draw({3.4995f, 4.4995f}, {3.5005f, 4.4995f}, {3.5f, 4.5008f});
    EXPECT_TRUE(covered(fb).empty());
    EXPECT_EQ(s.primitives_culled, 1u);
}

TEST(RasterSubPixel, ABoxHoldingACentreOutsideTheTriangleIsSetUpNotCulledAndDrawsNothing) {
    // (3.3, 4.3), (3.65, 4.3), (3.3, 4.65): counter-clockwise, area 0.06125 pixels, box
    // [3.3, 3.65] x [4.3, 4.65] around the centre (3.5, 4.5) of pixel (3, 4), which lies
    // beyond the long edge x + y = 7.95 (3.5 + 4.5 = 8). Setup keeps the triangle (non-zero
    // area, a pixel centre in its box), and its edge functions reject that centre: one
    // primitive, none culled, no fragment, through both entry points.
    constexpr int W = 8, H = 8;
    const Mesh m = window_triangle({3.3f, 4.3f}, {3.65f, 4.3f}, {3.3f, 4.65f}, W, H);
    Framebuffer fb = Framebuffer::create(W, H);
    const RasterStats s = tessref::rasterize(fb, m.input(), counting());
    EXPECT_TRUE(covered(fb).empty());
    EXPECT_EQ(s.primitives, 1u);
    EXPECT_EQ(s.primitives_culled, 0u);
    EXPECT_EQ(s.fragments, 0u);

    Framebuffer fb2 = Framebuffer::create(W, H);
    tessref::Rasterizer rasterizer(fb2, counting());
    const tessref::RasterChunk chunk{m.positions, m.triangles, 0};
    rasterizer.draw(std::span<const tessref::RasterChunk>(&chunk, 1));
    EXPECT_TRUE(covered(fb2).empty());
    EXPECT_EQ(rasterizer.stats().primitives, 1u);
    EXPECT_EQ(rasterizer.stats().primitives_culled, 0u);
    EXPECT_EQ(rasterizer.stats().fragments, 0u);
}

TEST(RasterSubPixel, SmallBoxFragmentsMatchTheTilesRasterizationOfTheirPlanes) {
    // A triangle whose box holds at most four pixels has its covered pixels' depth and weights
    // computed at setup, unless quad derivatives are asked for (they need its planes at the
    // tiles): the same pixels, depths, weights, ids and facing either way, byte for byte.
    // Random small triangles, overlapping (depth LESS decides between them), in both
    // windings, with perspective w, vertices on the 1/256 snapping grid (often exactly on a
    // pixel centre, an edge or a half-way point, where the fill rule decides), over tile
    // borders (64 pixels), and larger ones between them.
    constexpr int W = 160, H = 100;
    std::mt19937 rng(20261127);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    auto coordinate = [&](float centre) { return snapped_near(rng, centre, 0.15f, 0.25f, 1.2f); };
    Mesh m;
    for (int t = 0; t < 4000; ++t) {
        const float cx = unit(rng) * W, cy = unit(rng) * H;
        const float size = t % 20 == 0 ? 6.0f : 1.0f;  // some larger boxes among the small
        for (int k = 0; k < 3; ++k) {
            const float w = 0.5f + 1.5f * unit(rng);
            const glm::vec4 p = at_window(coordinate(cx) + (size - 1.0f) * unit(rng),
                                          coordinate(cy) + (size - 1.0f) * unit(rng), W, H,
                                          unit(rng) * 2.0f - 1.0f);
            m.add({p.x * w, p.y * w, p.z * w, w});
        }
        m.triangles.push_back({3u * t, 3u * t + 1, 3u * t + 2});
    }
    RasterSettings planes;
    planes.quad_derivatives = true;
    Framebuffer fast = Framebuffer::create(W, H), tiles = Framebuffer::create(W, H);
    const RasterStats a = tessref::rasterize(fast, m.input(), RasterSettings{});
    const RasterStats b = tessref::rasterize(tiles, m.input(), planes);
    ASSERT_GT(a.fragments, 1000u);
    EXPECT_GT(a.fragments, a.fragments_passed);  // the depth test decided some
    EXPECT_EQ(a.fragments, b.fragments);
    EXPECT_EQ(a.fragments_passed, b.fragments_passed);
    auto same = [](const auto& x, const auto& y) {
        return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])) == 0;
    };
    EXPECT_TRUE(same(fast.depth, tiles.depth));
    EXPECT_TRUE(same(fast.triangle_id, tiles.triangle_id));
    EXPECT_TRUE(same(fast.barycentric, tiles.barycentric));
    EXPECT_TRUE(same(fast.fragment_count, tiles.fragment_count));
    EXPECT_TRUE(same(fast.front_facing, tiles.front_facing));
    EXPECT_TRUE(same(fast.colour, tiles.colour));
}

// Clip positions that exercise the vertex preparation: inside and outside the view volume, on
// its planes, behind the eye, and non-finite, zero, tiny and huge components.
std::vector<glm::vec4> awkward_clip_positions(std::mt19937& rng, std::size_t count) {
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    const float specials[] = {0.0f, -0.0f, 1.0f, -1.0f, 1e-40f, -1e-40f, 1e-30f, 1e30f, -1e30f, 3e38f,
                              -3e38f, INFINITY, -INFINITY, NAN, 0.5f, 2.0f};
    std::vector<glm::vec4> out;
    for (std::size_t i = 0; i < count; ++i) {
        const float w = 0.25f + 2.0f * unit(rng);
        glm::vec4 p(w * (unit(rng) * 2.4f - 1.2f), w * (unit(rng) * 2.4f - 1.2f), w * (unit(rng) * 2.4f - 1.2f), w);
        const float r = unit(rng);
        if (r < 0.1f) {  // on a clip plane
            p[static_cast<int>(unit(rng) * 2.99f)] = unit(rng) < 0.5f ? p.w : -p.w;
        } else if (r < 0.3f) {  // one special component
            p[static_cast<int>(unit(rng) * 3.99f)] = specials[static_cast<int>(unit(rng) * 15.99f)];
        } else if (r < 0.35f) {  // behind the eye
            p.w = -p.w;
        }
        out.push_back(p);
    }
    return out;
}

// Equal bits, or both NaN: a NaN window position belongs to a vertex that is not inside, which
// setup never reads, and which NaN an operation propagates is the compiler's operand order.
bool same_float(float a, float b) {
    return (std::isnan(a) && std::isnan(b)) || std::memcmp(&a, &b, sizeof a) == 0;
}

TEST(RasterFastPaths, VerticesPreparedFourAtATimeMatchPrepareVertexBitForBit) {
    std::mt19937 rng(20261127);
    const std::vector<glm::vec4> clip = awkward_clip_positions(rng, 40003);
    namespace r = tessref::raster;
    std::size_t inside = 0, outside = 0;
    for (const auto& [width, height] : {std::pair{1280, 800}, std::pair{1, 1}, std::pair{7, 13}, std::pair{16384, 16384}}) {
        const r::Viewport vp = r::make_viewport(width, height);
        for (const bool fused : {false, true}) {
            // From vertex 1: blocks of four that start off the arrays' alignment, and a tail.
            std::vector<glm::vec4> win(clip.size());
            std::vector<r::FixedXY> fixed(clip.size());
            std::vector<r::BoxBounds> bounds(clip.size());
            r::prepare_vertices(clip.data(), 1, clip.size(), vp, fused, win.data(), fixed.data(), bounds.data());
            for (std::size_t i = 1; i < clip.size(); ++i) {
                glm::vec4 w;
                r::FixedXY f;
                r::BoxBounds b;
                r::prepare_vertex(clip[i], vp, fused, w, f, b);
                const bool same = same_float(win[i].x, w.x) && same_float(win[i].y, w.y) && same_float(win[i].z, w.z) &&
                                  same_float(win[i].w, w.w) && fixed[i].x == f.x && fixed[i].y == f.y &&
                                  std::memcmp(&bounds[i], &b, sizeof b) == 0;
                ASSERT_TRUE(same) << "vertex " << i << " (" << clip[i].x << ", " << clip[i].y << ", " << clip[i].z
                                  << ", " << clip[i].w << ") in " << width << "x" << height << (fused ? " fused" : "");
                ++(b.x0 >= 0 ? inside : outside);
            }
        }
    }
    EXPECT_GT(inside, 50000u);
    EXPECT_GT(outside, 50000u);
}

TEST(RasterFastPaths, BoxTestOnVertexBoundsMatchesSetupsBox) {
    // A triangle passes the box test iff a vertex is not inside (the clipper decides) or setup's
    // clamped box (triangle_bbox, clamp_bbox) holds a pixel, and then the box is setup's box.
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> pick(0, 5999);
    namespace r = tessref::raster;
    const std::vector<glm::vec4> clip = awkward_clip_positions(rng, 6000);
    std::size_t passed = 0, rejected = 0;
    for (const auto& [width, height] : {std::pair{40, 24}, std::pair{3, 2}}) {
        const r::Viewport vp = r::make_viewport(width, height);
        std::vector<glm::vec4> win(clip.size());
        std::vector<r::FixedXY> fixed(clip.size());
        std::vector<r::BoxBounds> bounds(clip.size());
        r::prepare_vertices(clip.data(), 0, clip.size(), vp, false, win.data(), fixed.data(), bounds.data());
        for (int t = 0; t < 200000; ++t) {
            const int v[3] = {pick(rng), pick(rng), pick(rng)};
            const r::BoxBounds box = r::triangle_box(bounds[v[0]], bounds[v[1]], bounds[v[2]]);
            const bool all_inside = bounds[v[0]].x0 >= 0 && bounds[v[1]].x0 >= 0 && bounds[v[2]].x0 >= 0;
            ASSERT_EQ(box.x0 >= 0, all_inside);
            if (!all_inside) {
                ASSERT_TRUE(r::box_has_pixels(box));
                continue;
            }
            const std::int32_t x[3] = {fixed[v[0]].x, fixed[v[1]].x, fixed[v[2]].x};
            const std::int32_t y[3] = {fixed[v[0]].y, fixed[v[1]].y, fixed[v[2]].y};
            r::Primitive prim;
            r::triangle_bbox(x, y, prim);
            const bool pixels = r::clamp_bbox(prim, vp);
            ASSERT_EQ(r::box_has_pixels(box), pixels);
            ++(pixels ? passed : rejected);
            if (pixels) {
                ASSERT_EQ(box.x0, prim.x0);
                ASSERT_EQ(box.y0, prim.y0);
                ASSERT_EQ(-box.neg_x1, prim.x1);
                ASSERT_EQ(-box.neg_y1, prim.y1);
            }
        }
    }
    EXPECT_GT(passed, 1000u);
    EXPECT_GT(rejected, 1000u);
}

// A vertex of the one-pixel setup tests' triangles: its window position near (cx, cy), in
// the GL coordinates of a width x height viewport (snapped_near, often on a pixel centre or
// half-way between two), at a random depth and perspective w, prepared as setup reads it.
void prepare_near(std::mt19937& rng, float cx, float cy, float spread, const tessref::raster::Viewport& vp, int width,
                  int height, glm::vec4& win, tessref::raster::FixedXY& fixed, tessref::raster::BoxBounds& bounds) {
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    const float w = 0.5f + 1.5f * unit(rng);
    const glm::vec4 p = at_window(snapped_near(rng, cx, 0.2f, 0.3f, spread), snapped_near(rng, cy, 0.2f, 0.3f, spread),
                                  width, height, unit(rng) * 2.0f - 1.0f);
    tessref::raster::prepare_vertex(p * w, vp, false, win, fixed, bounds);
}

TEST(RasterFastPaths, OnePixelSetupMatchesSetupTriangleAndItsPlanes) {
    // Triangles of inside vertices around pixel (5, 3), often on pixel centres, half-way points
    // or each other (centres on edges, where the fill rule decides; zero area), with
    // perspective w, in every face mode: setup_one_pixel's outcome, depth, weights and facing
    // are setup_triangle's and those its planes give at the pixel (fragment_depth,
    // fragment_weights), bit for bit.
    constexpr int W = 12, H = 8;
    namespace r = tessref::raster;
    const r::Viewport vp = r::make_viewport(W, H);
    std::mt19937 rng(20261128);
    const glm::vec3 unit_weights[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    std::size_t outcomes[3] = {}, on_edge = 0;
    for (int t = 0; t < 300000; ++t) {
        glm::vec4 win[3];
        r::FixedXY fixed[3];
        r::BoxBounds bounds[3];
        for (int k = 0; k < 3; ++k)  // GL coordinates: raster row 3 is GL y = H - 3 - 0.5
            prepare_near(rng, 5.5f, H - 3.5f, 1.0f, vp, W, H, win[k], fixed[k], bounds[k]);
        const r::BoxBounds box = r::triangle_box(bounds[0], bounds[1], bounds[2]);
        if (!r::one_pixel_box(box)) continue;
        for (const r::Face face : {r::Face::both, r::Face::front_only, r::Face::back_only}) {
            r::OnePixelFragment f;
            const r::Setup fast = r::setup_one_pixel(fixed[0], fixed[1], fixed[2], win[0], win[1], win[2], box.x0,
                                                     box.y0, face, f);
            r::Primitive prim;
            const r::Setup reference =
                r::setup_triangle({&win[0], &unit_weights[0], fixed[0].x, fixed[0].y},
                                  {&win[1], &unit_weights[1], fixed[1].x, fixed[1].y},
                                  {&win[2], &unit_weights[2], fixed[2].x, fixed[2].y}, face, vp, prim);
            ASSERT_EQ(static_cast<int>(fast), static_cast<int>(reference)) << "triangle " << t;
            ++outcomes[static_cast<int>(fast)];
            if (reference == r::Setup::culled) continue;
            ASSERT_EQ(prim.x0, box.x0);
            ASSERT_EQ(prim.y0, box.y0);
            ASSERT_EQ(prim.x1, box.x0);
            ASSERT_EQ(prim.y1, box.y0);
            if (face == r::Face::both) {
                for (int k = 0; k < 3; ++k) on_edge += prim.c[k] + prim.dcdy[k] * box.y0 - prim.dcdx[k] * box.x0 == 1;
            }
            if (reference == r::Setup::empty) continue;
            const float fx = static_cast<float>(box.x0) - prim.ox, fy = static_cast<float>(box.y0) - prim.oy;
            const float z = r::depth_value(r::eval_plane(prim.z, fx, fy));
            const float oow = r::eval_plane(prim.oow, fx, fy);
            ASSERT_EQ(f.front, prim.front);
            ASSERT_TRUE(std::memcmp(&f.z, &z, sizeof z) == 0) << "triangle " << t;
            for (int k = 0; k < 3; ++k) {
                const float weight = r::eval_plane(prim.bw[k], fx, fy) / oow;
                ASSERT_TRUE(std::memcmp(&f.weights[k], &weight, sizeof weight) == 0) << "triangle " << t << " weight " << k;
            }
        }
    }
    EXPECT_GT(outcomes[static_cast<int>(r::Setup::culled)], 1000u);
    EXPECT_GT(outcomes[static_cast<int>(r::Setup::empty)], 1000u);
    EXPECT_GT(outcomes[static_cast<int>(r::Setup::drawn)], 1000u);
    EXPECT_GT(on_edge, 1000u);  // the edge function 1: a biased centre on an edge line
}

#if defined(__SSE2__)
TEST(RasterFastPaths, FourAtATimeCoverageIsOnePixelCoverageLaneByLane) {
    // Triangles of inside vertices near pixel centres all over a small viewport (its border
    // rows and columns too, where the box bounds clamp), often on centres, half-way points or
    // each other (centres on edges, zero areas), four at a time, with triangles of larger
    // boxes or outside vertices among them: every lane whose box is one pixel has
    // one_pixel_coverage's outcome, winding and facing, in every face mode.
    constexpr int W = 12, H = 8;
    namespace r = tessref::raster;
    const r::Viewport vp = r::make_viewport(W, H);
    std::mt19937 rng(20261127);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::uniform_int_distribution<int> column(0, W - 1), row(0, H - 1);
    std::vector<r::FixedXY> fixed;
    std::vector<std::array<std::uint32_t, 3>> tris;
    std::vector<r::BoxBounds> boxes;
    for (std::uint32_t t = 0; t < 200000; ++t) {
        const float cx = static_cast<float>(column(rng)) + 0.5f, cy = static_cast<float>(row(rng)) + 0.5f;
        const float spread = unit(rng) < 0.8f ? 1.0f : 2.5f;
        r::BoxBounds bounds[3];
        for (int k = 0; k < 3; ++k) {
            glm::vec4 win;
            r::FixedXY f;
            prepare_near(rng, cx, cy, spread, vp, W, H, win, f, bounds[k]);
            fixed.push_back(f);
        }
        tris.push_back({3 * t, 3 * t + 1, 3 * t + 2});
        boxes.push_back(r::triangle_box(bounds[0], bounds[1], bounds[2]));
    }
    std::size_t outcomes[3] = {}, on_edge = 0, others = 0;
    std::int32_t farthest = 0;  // a one-pixel box's vertex from its pixel, in 1/256 pixel
    for (std::uint32_t first = 0; first + 4 <= tris.size(); first += 4) {
        const std::uint32_t t[4] = {first, first + 1, first + 2, first + 3};
        for (const r::Face face : {r::Face::both, r::Face::front_only, r::Face::back_only}) {
            const r::OnePixelCoverage4 c4 = r::one_pixel_coverage4(fixed.data(), tris.data(), t, &boxes[first], face);
            for (int l = 0; l < 4; ++l) {
                const r::BoxBounds& box = boxes[first + l];
                if (!r::one_pixel_box(box)) {
                    others += face == r::Face::both;
                    continue;
                }
                const auto& tri = tris[first + l];
                const r::FixedXY &v0 = fixed[tri[0]], &v1 = fixed[tri[1]], &v2 = fixed[tri[2]];
                const r::OnePixelCoverage scalar = r::one_pixel_coverage(v0, v1, v2, box.x0, box.y0, face);
                const r::OnePixelCoverage lane = c4.lane(l, v0, v1, v2, box.x0, box.y0);
                ASSERT_EQ(static_cast<int>(lane.setup), static_cast<int>(scalar.setup)) << "triangle " << first + l;
                ASSERT_EQ(lane.cw, scalar.cw) << "triangle " << first + l;
                ASSERT_EQ(lane.front, scalar.front) << "triangle " << first + l;
                ++outcomes[static_cast<int>(scalar.setup)];
                on_edge += (c4.on_edge >> l) & 1;
                for (const r::FixedXY* v : {&v0, &v1, &v2})
                    farthest = std::max({farthest, std::abs(v->x - box.x0 * r::kFixedOne),
                                         std::abs(v->y - box.y0 * r::kFixedOne)});
            }
        }
    }
    EXPECT_GT(outcomes[static_cast<int>(r::Setup::culled)], 1000u);
    EXPECT_GT(outcomes[static_cast<int>(r::Setup::empty)], 1000u);
    EXPECT_GT(outcomes[static_cast<int>(r::Setup::drawn)], 1000u);
    EXPECT_GT(on_edge, 1000u);   // a centre on an edge line, left to one_pixel_covered_on_edge
    EXPECT_GT(others, 10000u);  // lanes whose box is not one pixel, among the others
    EXPECT_LE(farthest, 256);   // the bound that makes 16 bits enough
    EXPECT_GT(farthest, 200);   // and the triangles went near it
}
#endif

TEST(RasterCulling, ZeroAreaTrianglesAreCulled) {
    constexpr int W = 16, H = 16;
    Mesh m;
    m.add(at_window(1.0f, 1.0f, W, H));
    m.add(at_window(8.0f, 8.0f, W, H));
    m.add(at_window(15.0f, 15.0f, W, H));  // collinear
    m.add(at_window(3.0f, 12.0f, W, H));
    m.triangles = {{0, 1, 2}, {0, 1, 1}, {3, 3, 3}};
    Framebuffer fb = Framebuffer::create(W, H);
    const RasterStats s = tessref::rasterize(fb, m.input(), counting());
    EXPECT_TRUE(covered(fb).empty());
    EXPECT_EQ(s.primitives_culled, 3u);
}

TEST(RasterCulling, BackFacesAreClockwiseInGlWindowCoordinates) {
    constexpr int W = 16, H = 16;
    Mesh m;
    m.add(at_window(2.0f, 2.0f, W, H));
    m.add(at_window(14.0f, 2.0f, W, H));
    m.add(at_window(2.0f, 14.0f, W, H));
    const std::vector<Index3> ccw = {{0, 1, 2}}, cw = {{0, 2, 1}};
    Framebuffer fb = Framebuffer::create(W, H);
    RasterSettings s = counting();
    s.cull = CullMode::back;
    RasterInput in = m.input();
    in.triangles = ccw;
    tessref::rasterize(fb, in, s);
    EXPECT_FALSE(covered(fb).empty());
    EXPECT_EQ(fb.front_facing[fb.index(3, 3)], 1u);
    fb.clear();
    in.triangles = cw;
    tessref::rasterize(fb, in, s);
    EXPECT_TRUE(covered(fb).empty());
    s.cull = CullMode::front;
    tessref::rasterize(fb, in, s);
    EXPECT_FALSE(covered(fb).empty());
    EXPECT_EQ(fb.front_facing[fb.index(3, 3)], 0u);
}

// ---------------------------------------------------------------------------------------
// Huge coordinates, non-finite input, near plane.

TEST(RasterClipping, HugeTriangleCoversTheScreenOnceWithoutOverflow) {
    constexpr int W = 97, H = 61;
    for (const float size : {3e2f, 3e6f}) {
        for (const float w : {1.0f, 1e-3f, 1e6f, 1e18f}) {
            Mesh m;
            m.add(glm::vec4(-size, -size, 0.5f, 1.0f) * w);
            m.add(glm::vec4(3.0f * size, -size, -0.5f, 1.0f) * w);
            m.add(glm::vec4(-size, 3.0f * size, 0.0f, 1.0f) * w);
            m.triangles = {{0, 1, 2}};
            Framebuffer fb = Framebuffer::create(W, H);
            const RasterStats s = tessref::rasterize(fb, m.input(), counting());
            EXPECT_EQ(s.triangles_clipped, 1u);
            EXPECT_TRUE(all_finite(fb));
            for (std::uint32_t c : fb.fragment_count) ASSERT_LE(c, 1u);
            if (size < 1e3f) {
                EXPECT_EQ(covered(fb).size(), static_cast<std::size_t>(W * H)) << "w " << w;
            } else {
                // Clipping in float at 1e6 moves the clipped corners by pixels (llvmpipe does
                // the same, see the differential test); most of the screen is still covered.
                EXPECT_GT(covered(fb).size(), static_cast<std::size_t>(W * H / 2)) << "w " << w;
            }
        }
    }
}

TEST(RasterClipping, NonFiniteAndOverflowingInputIsDroppedNotDrawn) {
    constexpr int W = 16, H = 16;
    const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
    Mesh m;
    m.add({0.0f, 0.0f, 0.0f, 1.0f});
    m.add({0.5f, 0.0f, 0.0f, 1.0f});
    m.add({0.0f, 0.5f, 0.0f, 1.0f});
    m.add({nan, 0.0f, 0.0f, 1.0f});
    m.add({inf, 0.0f, 0.0f, 1.0f});
    m.add({3e38f, 3e38f, 0.0f, 3e38f});  // x + w overflows in the clipper
    m.add({0.0f, 0.0f, 0.0f, 0.0f});     // the eye itself: inside every plane, 1/w infinite
    m.triangles = {{0, 1, 3}, {0, 4, 2}, {0, 1, 5}, {6, 1, 2}};
    Framebuffer fb = Framebuffer::create(W, H);
    const RasterStats s = tessref::rasterize(fb, m.input(), counting());
    EXPECT_TRUE(all_finite(fb));
    EXPECT_EQ(s.triangles_in, 4u);
    EXPECT_GE(s.triangles_rejected + s.primitives_culled, 3u);
}

struct Camera {
    glm::mat4 projection;
    float near_plane = 0.1f, far_plane = 100.0f;
    int width, height;
    Camera(int w, int h) : width(w), height(h) {
        projection = glm::perspective(glm::radians(60.0f), static_cast<float>(w) / static_cast<float>(h),
                                      near_plane, far_plane);
    }
    // View-space ray through the centre of GL pixel (x, y).
    glm::dvec3 ray(int x, int y) const {
        const double nx = (x + 0.5) * 2.0 / width - 1.0, ny = (y + 0.5) * 2.0 / height - 1.0;
        return {nx / projection[0][0], ny / projection[1][1], -1.0};
    }
};

// Analytic hit of the pixel's ray with a view-space triangle: barycentrics and view depth.
bool ray_hit(const glm::dvec3& d, const glm::dvec3 v[3], glm::dvec3& bary, double& depth) {
    const glm::dvec3 n = glm::cross(v[1] - v[0], v[2] - v[0]);
    const double denom = glm::dot(n, d);
    if (std::abs(denom) < 1e-300) return false;
    const double t = glm::dot(n, v[0]) / denom;
    const glm::dvec3 h = t * d;
    const double area = glm::dot(n, n);
    bary.x = glm::dot(glm::cross(v[1] - h, v[2] - h), n) / area;
    bary.y = glm::dot(glm::cross(v[2] - h, v[0] - h), n) / area;
    bary.z = 1.0 - bary.x - bary.y;
    depth = -h.z;
    return t > 0.0;
}

TEST(RasterClipping, NearPlaneCrossingDrawsOnlyTheVisiblePart) {
    constexpr int W = 160, H = 120;
    const Camera cam(W, H);
    std::mt19937 rng(2024u);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::size_t compared = 0, mismatched = 0, clipped = 0;
    for (int trial = 0; trial < 200; ++trial) {
        const int behind = 1 + trial % 2;  // vertices behind the eye (view z > 0)
        glm::dvec3 v[3];
        for (int k = 0; k < 3; ++k) {
            const double z = k < behind ? 0.05 + 2.0 * std::abs(u(rng)) : -(0.5 + 6.0 * std::abs(u(rng)));
            v[k] = {3.0 * u(rng), 2.0 * u(rng), z};
        }
        Mesh m;
        for (const glm::dvec3& p : v) m.add(cam.projection * glm::vec4(glm::vec3(p), 1.0f));
        m.triangles = {{0, 1, 2}};
        m.varying_count = 1;
        for (const glm::dvec3& p : v) m.varyings.push_back(static_cast<float>(-p.z));  // view depth
        Framebuffer fb = Framebuffer::create(W, H, 1);
        const RasterStats s = tessref::rasterize(fb, m.input(), counting());
        clipped += s.triangles_clipped;
        ASSERT_TRUE(all_finite(fb)) << "trial " << trial;
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                glm::dvec3 b;
                double depth = 0;
                const bool hit = ray_hit(cam.ray(x, y), v, b, depth);
                const double margin = std::min({b.x, b.y, b.z});
                const bool in = hit && margin > 0.01 && depth > cam.near_plane * 1.02 && depth < cam.far_plane * 0.98;
                const bool out = !hit || margin < -0.01 || depth < cam.near_plane * 0.98 || depth > cam.far_plane * 1.02;
                const bool drawn = fb.fragment_count[fb.index(x, y)] != 0;
                if (in || out) {
                    ++compared;
                    if (drawn != in) ++mismatched;
                }
                if (drawn && in) {  // the visible surface's varying is the view depth there
                    EXPECT_NEAR(fb.varyings[fb.index(x, y)], depth, 1e-4 * depth + 1e-5);
                }
            }
    }
    EXPECT_GT(clipped, 150u);  // the others lie wholly outside one plane
    EXPECT_GT(compared, 100000u);
    EXPECT_EQ(mismatched, 0u);
}

// ---------------------------------------------------------------------------------------
// Interpolation, depth, provenance.

TEST(RasterInterpolation, PerspectiveCorrectBarycentricsAndVaryingsMatchTheRayHit) {
    constexpr int W = 128, H = 96;
    const Camera cam(W, H);
    // A receding floor quad with texture coordinates.
    const glm::dvec3 q[4] = {{-4, -1, -1.5}, {4, -1, -1.5}, {4, -1, -40}, {-4, -1, -40}};
    const float uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    Mesh m;
    m.varying_count = 2;
    for (int k = 0; k < 4; ++k) {
        m.add(cam.projection * glm::vec4(glm::vec3(q[k]), 1.0f));
        m.varyings.push_back(uv[k][0]);
        m.varyings.push_back(uv[k][1]);
    }
    m.triangles = {{0, 1, 2}, {0, 2, 3}};
    Framebuffer fb = Framebuffer::create(W, H, 2);
    tessref::rasterize(fb, m.input(), {});
    std::size_t checked = 0;
    double worst = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const std::size_t i = fb.index(x, y);
            if (fb.triangle_id[i] == tessref::kNoTriangle) continue;
            const Index3& t = m.triangles[fb.triangle_id[i]];
            const glm::dvec3 v[3] = {q[t[0]], q[t[1]], q[t[2]]};
            glm::dvec3 b;
            double depth = 0;
            ASSERT_TRUE(ray_hit(cam.ray(x, y), v, b, depth));
            EXPECT_NEAR(fb.barycentric[i].x, b.x, 2e-4);
            EXPECT_NEAR(fb.barycentric[i].y, b.y, 2e-4);
            EXPECT_NEAR(fb.barycentric[i].z, b.z, 2e-4);
            const double u_exact = b.x * uv[t[0]][0] + b.y * uv[t[1]][0] + b.z * uv[t[2]][0];
            const double v_exact = b.x * uv[t[0]][1] + b.y * uv[t[1]][1] + b.z * uv[t[2]][1];
            worst = std::max({worst, std::abs(fb.varyings[i * 2] - u_exact), std::abs(fb.varyings[i * 2 + 1] - v_exact)});
            // Window depth: the projection's z/w at that view depth, mapped to [0,1].
            const glm::vec4 clip = cam.projection * glm::vec4(0.0f, 0.0f, static_cast<float>(-depth), 1.0f);
            EXPECT_NEAR(fb.depth[i], 0.5 * clip.z / clip.w + 0.5, 1e-5);
            ++checked;
        }
    EXPECT_GT(checked, 2000u);
    EXPECT_LT(worst, 2e-4);
    // Screen-linear interpolation would be far off on this floor: make sure the test can tell.
    EXPECT_GT(std::abs(q[0].z - q[2].z), 10.0);
}

TEST(RasterDepth, LessKeepsTheNearestAndTheFirstOfEquals) {
    constexpr int W = 16, H = 16;
    Mesh m;
    auto quad = [&](float z) {
        const std::uint32_t a = m.add(at_window(0, 0, W, H, z)), b = m.add(at_window(16, 0, W, H, z)),
                            c = m.add(at_window(16, 16, W, H, z)), d = m.add(at_window(0, 16, W, H, z));
        m.triangles.push_back({a, b, c});
        m.triangles.push_back({a, c, d});
    };
    quad(0.5f);   // triangles 0, 1: far
    quad(-0.5f);  // triangles 2, 3: near
    quad(-0.5f);  // triangles 4, 5: as near
    Framebuffer fb = Framebuffer::create(W, H);
    tessref::rasterize(fb, m.input(), {});
    for (std::uint32_t id : fb.triangle_id) EXPECT_TRUE(id == 2u || id == 3u);
    for (float d : fb.depth) EXPECT_FLOAT_EQ(d, 0.25f);
    RasterSettings lequal;
    lequal.depth_func = DepthFunc::lequal;
    fb.clear();
    tessref::rasterize(fb, m.input(), lequal);
    for (std::uint32_t id : fb.triangle_id) EXPECT_TRUE(id == 4u || id == 5u);
    // Reversed submission order: the near quad still wins.
    std::reverse(m.triangles.begin(), m.triangles.end());
    fb.clear();
    tessref::rasterize(fb, m.input(), {});
    for (std::uint32_t id : fb.triangle_id) EXPECT_TRUE(id == 0u || id == 1u);  // the old 4, 5 (first now)
}

TEST(RasterProvenance, IdsPatchAndTessCoordOfTheVisibleSurface) {
    constexpr int W = 32, H = 32;
    const Mesh m = window_triangle({1, 1}, {31, 1}, {1, 31}, W, H);
    const std::vector<std::uint32_t> ids = {4711}, patches = {42};
    const std::vector<glm::vec3> tess = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    RasterInput in = m.input();
    in.triangle_ids = ids;
    in.patch_ids = patches;
    in.tess_coords = tess;
    Framebuffer fb = Framebuffer::create(W, H);
    tessref::rasterize(fb, in, {});
    const std::size_t i = fb.index(5, 7);
    EXPECT_EQ(fb.triangle_id[i], 4711u);
    EXPECT_EQ(fb.patch_id[i], 42u);
    // w = 1: the tess coord is the window-space barycentric of the pixel centre (5.5, 7.5).
    const glm::vec3 expected(1.0f - (4.5f + 6.5f) / 30.0f, 4.5f / 30.0f, 6.5f / 30.0f);
    EXPECT_NEAR(fb.tess_coord[i].x, expected.x, 1e-5);
    EXPECT_NEAR(fb.tess_coord[i].y, expected.y, 1e-5);
    EXPECT_NEAR(fb.tess_coord[i].z, expected.z, 1e-5);
    EXPECT_EQ(fb.triangle_id[fb.index(30, 30)], tessref::kNoTriangle);
    EXPECT_EQ(fb.patch_id[fb.index(30, 30)], tessref::kNoTriangle);
}

TEST(RasterInput, BadInputThrowsTessrefError) {
    Framebuffer fb = Framebuffer::create(8, 8, 2);
    Mesh m;
    m.add({0, 0, 0, 1});
    m.add({1, 0, 0, 1});
    m.add({0, 1, 0, 1});
    m.triangles = {{0, 1, 3}};
    EXPECT_THROW(tessref::rasterize(fb, m.input(), {}), tessref::Error);
    m.triangles = {{0, 1, 2}};
    m.varying_count = 2;
    m.varyings = {1, 2, 3};  // should be 6
    EXPECT_THROW(tessref::rasterize(fb, m.input(), {}), tessref::Error);
    m.varying_count = 3;
    m.varyings.assign(9, 0.0f);  // more varyings than the framebuffer holds
    EXPECT_THROW(tessref::rasterize(fb, m.input(), {}), tessref::Error);
    EXPECT_THROW(Framebuffer::create(0, 8), tessref::Error);
    EXPECT_THROW(Framebuffer::create(8, 8, 17), tessref::Error);
}

// ---------------------------------------------------------------------------------------
// Determinism across thread counts.

Mesh terrain_soup(unsigned seed, int n, int width, int height) {
    // A height field seen in perspective, crossing the near plane and the screen borders.
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> noise(-0.05f, 0.05f);
    const glm::mat4 proj = glm::perspective(glm::radians(55.0f), static_cast<float>(width) / static_cast<float>(height), 0.5f, 400.0f);
    const glm::mat4 view = glm::lookAt(glm::vec3(0.0f, 6.0f, 20.0f), glm::vec3(0.0f, 0.0f, -40.0f), glm::vec3(0, 1, 0));
    Mesh m;
    m.varying_count = 3;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            const float x = -60.0f + 120.0f * static_cast<float>(i) / static_cast<float>(n);
            const float z = 30.0f - 150.0f * static_cast<float>(j) / static_cast<float>(n);
            const float h = 3.0f * std::sin(x * 0.15f) * std::cos(z * 0.11f) + noise(rng);
            m.add(proj * view * glm::vec4(x, h, z, 1.0f));
            m.varyings.insert(m.varyings.end(), {x, h, z});
        }
    auto at = [&](int i, int j) { return static_cast<std::uint32_t>(j * (n + 1) + i); };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            m.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
            m.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
    return m;
}

TEST(RasterDeterminism, ByteIdenticalForOneTwoAndFourThreads) {
    constexpr int W = 320, H = 200;
    const Mesh m = terrain_soup(5u, 260, W, H);  // 135k triangles, several setup batches
    // Let an arena of 4 really get 4 threads on a smaller machine.
    const tbb::global_control allow(tbb::global_control::max_allowed_parallelism, 4);
    for (const PolygonMode mode : {PolygonMode::fill, PolygonMode::line}) {
        std::vector<Framebuffer> results;
        for (int threads : {1, 2, 4}) {
            Framebuffer fb = Framebuffer::create(W, H, 3);
            RasterSettings s;
            s.threads = threads;
            s.polygon_mode = mode;
            s.colour = glm::vec4(0.2f, 0.4f, 0.6f, 1.0f);
            const RasterStats stats = tessref::rasterize(fb, m.input(), s);
            EXPECT_GT(stats.triangles_clipped, 0u);
            EXPECT_GT(stats.fragments_passed, 0u);
            EXPECT_TRUE(all_finite(fb));
            results.push_back(std::move(fb));
        }
        for (std::size_t k = 1; k < results.size(); ++k) {
            const Framebuffer& a = results[0];
            const Framebuffer& b = results[k];
            EXPECT_TRUE(same_bytes(a.depth, b.depth));
            EXPECT_TRUE(same_bytes(a.triangle_id, b.triangle_id));
            EXPECT_TRUE(same_bytes(a.barycentric, b.barycentric));
            EXPECT_TRUE(same_bytes(a.varyings, b.varyings));
            EXPECT_TRUE(same_bytes(a.colour, b.colour));
            EXPECT_TRUE(same_bytes(a.fragment_count, b.fragment_count));
            EXPECT_TRUE(same_bytes(a.front_facing, b.front_facing));
        }
    }
}

// ---------------------------------------------------------------------------------------
// Wireframe.

TEST(RasterWireframe, EdgesThroughPixelCentresFollowTheDiamondExitRule) {
    // Counter-clockwise triangle (2.5,2.5) (12.5,2.5) (2.5,12.5), all vertices at pixel
    // centres; draw's unfilled stage emits v2->v0, v0->v1, v1->v2. GL's diamond-exit rule: a
    // line starting at a pixel centre draws that pixel, one ending at a centre does not. So:
    // v0->v1 row 2, x = 2..11; v1->v2 the diagonal (12,2), (11,3) ... (3,11); v2->v0 column
    // 2, y = 12 down to 3. 30 pixels, each once.
    constexpr int W = 16, H = 16;
    const Mesh m = window_triangle({2.5f, 2.5f}, {12.5f, 2.5f}, {2.5f, 12.5f}, W, H);
    Framebuffer fb = Framebuffer::create(W, H);
    RasterSettings s = counting();
    s.polygon_mode = PolygonMode::line;
    const RasterStats stats = tessref::rasterize(fb, m.input(), s);
    EXPECT_EQ(stats.primitives, 3u);
    std::vector<std::pair<int, int>> expected;
    for (int x = 2; x <= 11; ++x) expected.emplace_back(x, 2);
    for (int k = 0; k < 10; ++k) expected.emplace_back(12 - k, 2 + k);
    for (int y = 3; y <= 12; ++y) expected.emplace_back(2, y);
    std::sort(expected.begin(), expected.end());
    std::vector<std::pair<int, int>> got = covered(fb);
    std::sort(got.begin(), got.end());
    EXPECT_EQ(got, expected);
    for (auto [x, y] : got) EXPECT_EQ(fb.fragment_count[fb.index(x, y)], 1u) << x << "," << y;
}

TEST(RasterWireframe, ClippedTriangleDrawsNoEdgeAlongTheClipPlane) {
    // A triangle half outside the right border: the visible parts of its two crossing edges
    // and its inside edge are drawn, nothing along x = W (column W-1 only where an edge ends).
    constexpr int W = 32, H = 32;
    const Mesh m = window_triangle({4.5f, 4.5f}, {60.5f, 16.5f}, {4.5f, 28.5f}, W, H);
    Framebuffer fb = Framebuffer::create(W, H);
    RasterSettings s = counting();
    s.polygon_mode = PolygonMode::line;
    const RasterStats stats = tessref::rasterize(fb, m.input(), s);
    EXPECT_EQ(stats.triangles_clipped, 1u);
    int in_last_column = 0;
    for (int y = 0; y < H; ++y) in_last_column += fb.fragment_count[fb.index(W - 1, y)] != 0;
    EXPECT_LE(in_last_column, 2);
    for (int y = 5; y <= 28; ++y) EXPECT_EQ(fb.fragment_count[fb.index(4, y)], 1u) << y;  // the inside edge
}

}  // namespace
