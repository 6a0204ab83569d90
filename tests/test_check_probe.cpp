// Tests of the Embree crack probe of `tessref check` (src/check/probe.cpp): a ray that grazes
// an edge or a vertex never becomes a defect, and real cracks are still found.
//
// Where the expectations come from:
//  - meshes built here put their vertices exactly on the probe's rays, by the formula
//    include/tessref/check.h states for CheckOptions::probe_offset (evaluated in the same
//    order, so the doubles are bitwise equal): lines then run through vertices and along
//    edges, where single-precision rounding decides which triangles they hit;
//  - a closed solid (a height field closed down to a base) crosses every line an even number
//    of times and lets no ray out, so any probe failure on it is wrong, whatever the
//    resolution;
//  - a slit cut into such a terrain (its vertices on one side of a grid line moved `width`
//    away) is a hole seen from above of width `width`, which vertical lines fall through.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "tessref/check.h"
#include "tessref/raycast.h"
#include "tessref/solid.h"

using tessref::CheckOptions;
using tessref::CheckReport;
using tessref::DefectClass;
using tessref::Expect;
using tessref::SurfaceMesh;

namespace {

constexpr double side = 16.0;  // the terrain covers [0, side]^2
constexpr double top = 8.0;    // its highest vertex; the solid's base is at 0

// Where the probe's ray of cell k runs along an axis of the box [0, extent] (check.h).
double on_ray(int k, double offset, double extent, int resolution) { return (k + offset) * extent / resolution; }

// A rough terrain over an n x n grid whose vertices lie on the probe's rays at `resolution`
// (offsets as in CheckOptions::probe_offset): lines along x run at y on offset.x's grid and
// z on offset.y's; lines along y at z on offset.x's and x on offset.y's. So x is on
// offset.y's grid, y on offset.x's, and the heights alternate between the two, so that both
// families of lines pass exactly through vertices (and, lying in the vertical planes of the
// grid lines, along and across edges). With slit_width > 0 the vertices of column n/2 zigzag
// about x = side/2 (half a unit either way: a slit along one column of rays could fall
// between them), and the faces right of that column use copies of its vertices moved
// slit_width along x, from row n/4 to row n - n/4 (the copies at both ends shared), which
// opens a slit there.
SurfaceMesh aligned_terrain(int resolution, glm::dvec2 offset, int n, double slit_width = 0.0, unsigned seed = 1) {
    std::mt19937 random(seed);
    std::uniform_int_distribution<int> cell(resolution / 8, resolution - resolution / 8 - 1);
    auto coordinate = [&](int p, double grid_offset) {
        if (p == 0) return 0.0;
        if (p == n) return side;
        return on_ray(p * resolution / n, grid_offset, side, resolution);
    };
    SurfaceMesh mesh;
    auto add = [&](glm::dvec3 p) {
        mesh.positions.push_back(p);
        mesh.patch_ids.push_back(0);
        mesh.tess_coords.emplace_back(0.0f);
        return static_cast<std::uint32_t>(mesh.positions.size() - 1);
    };
    std::vector<std::uint32_t> id((n + 1) * (n + 1));
    for (int q = 0; q <= n; ++q)
        for (int p = 0; p <= n; ++p) {
            const double height = p == 0 && q == 0 ? top : on_ray(cell(random), (p + q) % 2 ? offset.x : offset.y, top, resolution);
            const double x = slit_width > 0.0 && p == n / 2 ? side / 2 + (q % 2 ? 0.5 : -0.5) : coordinate(p, offset.y);
            id[q * (n + 1) + p] = add({x, coordinate(q, offset.x), height});
        }
    // The right side's copies of the slit's vertices.
    std::vector<std::uint32_t> right = id;
    const int column = n / 2;
    if (slit_width > 0.0)
        for (int q = n / 4 + 1; q < n - n / 4; ++q) {
            glm::dvec3 p = mesh.positions[id[q * (n + 1) + column]];
            p.x += slit_width;
            right[q * (n + 1) + column] = add(p);
        }
    for (int q = 0; q < n; ++q)
        for (int p = 0; p < n; ++p) {
            const auto& ids = p >= column ? right : id;
            const std::uint32_t a = ids[q * (n + 1) + p], b = ids[q * (n + 1) + p + 1], c = ids[(q + 1) * (n + 1) + p + 1],
                                d = ids[(q + 1) * (n + 1) + p];
            // Alternate the diagonals, so that lines cross both kinds.
            if ((p + q) % 2) {
                mesh.triangles.push_back({a, b, c});
                mesh.triangles.push_back({a, c, d});
            } else {
                mesh.triangles.push_back({a, b, d});
                mesh.triangles.push_back({b, c, d});
            }
        }
    return mesh;
}

const glm::dvec2 default_offset = CheckOptions{}.probe_offset;

CheckReport check(const SurfaceMesh& mesh, int resolution, Expect expect, glm::dvec2 offset = default_offset) {
    CheckOptions options;
    options.expect = expect;
    options.probe_resolution = resolution;
    options.probe_offset = offset;
    return tessref::check_mesh(tessref::indexed_mesh_from(mesh), options);
}

std::string describe(const CheckReport& r) {
    return tessref::report_text(r) + "recast " + std::to_string(r.probe.recast_rays) + ", undecided " +
           std::to_string(r.probe.undecided_rays) + ", dismissed " + std::to_string(r.probe.dismissed_rays) + "\n";
}

// A closed mesh's probe must pass on its own, without the topology's help.
void expect_clean_probe(const CheckReport& r) {
    EXPECT_TRUE(r.passed) << describe(r);
    EXPECT_EQ(r.probe.failed_rays, 0u);
    EXPECT_EQ(r.probe.dismissed_rays, 0u) << describe(r);
}

const int resolutions[] = {256, 511, 512, 513, 1024, 2048};

// A welded (n + 1) x (n + 1) grid over [0, side]^2 with random heights in [0, top) drawn
// from `random` row by row, two triangles a cell, cut along the cell's rising diagonal, or
// along both diagonals in a checkerboard (`both_diagonals`), so that rays along the grid meet
// edges of every direction.
struct RoughTerrain {
    std::vector<glm::dvec3> positions;
    std::vector<std::array<std::uint32_t, 3>> triangles;
};
RoughTerrain rough_terrain(int n, std::mt19937& random, bool both_diagonals) {
    std::uniform_real_distribution<double> height(0.0, top);
    RoughTerrain t;
    const double step = side / n;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) t.positions.emplace_back(i * step, j * step, height(random));
    const auto at = [&](int i, int j) { return static_cast<std::uint32_t>(j * (n + 1) + i); };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            if (!both_diagonals || (i + j) % 2 == 0) {
                t.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
                t.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
            } else {
                t.triangles.push_back({at(i, j), at(i + 1, j), at(i, j + 1)});
                t.triangles.push_back({at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)});
            }
        }
    return t;
}

}  // namespace

// The case: a closed, manifold, consistently oriented solid that fails at some
// resolutions and passes at others. Each resolution gets a solid whose vertices lie on its
// own rays; the solid made for 512 is also checked at every other resolution.
TEST(CheckProbe, GrazingLinesNeverFailAClosedSolid) {
    const SurfaceMesh at512 = tessref::close_terrain_into_solid(aligned_terrain(512, default_offset, 8), 0.0);
    for (int resolution : resolutions) {
        SCOPED_TRACE(resolution);
        const SurfaceMesh solid = tessref::close_terrain_into_solid(aligned_terrain(resolution, default_offset, 8), 0.0);
        const CheckReport aligned = check(solid, resolution, Expect::closed);
        ASSERT_TRUE(aligned.closed && aligned.manifold && aligned.consistently_oriented) << describe(aligned);
        expect_clean_probe(aligned);
        // The lines did run through vertices and edges.
        EXPECT_GT(aligned.probe.recast_rays, 0u);
        EXPECT_LT(aligned.probe.undecided_rays, aligned.probe.recast_rays);
        expect_clean_probe(check(at512, resolution, Expect::closed));
    }
}

// Every line through the middle of its cell, and a vertex in the middle of every cell: all
// lines run through vertices or along edges.
TEST(CheckProbe, EveryLineThroughVerticesAndEdges) {
    const int resolution = 64;
    const glm::dvec2 middle(0.5, 0.5);
    const SurfaceMesh terrain = aligned_terrain(resolution, middle, resolution);
    const SurfaceMesh solid = tessref::close_terrain_into_solid(terrain, 0.0);
    const CheckReport closed = check(solid, resolution, Expect::closed, middle);
    expect_clean_probe(closed);
    EXPECT_GT(closed.probe.recast_rays, closed.probe.rays / 4);
    EXPECT_EQ(closed.probe.undecided_rays, 0u);
    // The terrain alone: every vertical ray falls on a vertex.
    const CheckReport open = check(terrain, resolution, Expect::open, middle);
    EXPECT_EQ(open.probe.mode, "terrain");
    expect_clean_probe(open);
}

// A slit 0.02 wide (1/800 of the terrain's side, under a cell of the probe's grid at every
// resolution here; 8 units long, so about 0.16 / cell^2 of the grid's rays fall into it) is
// found at every resolution, in the terrain and in the solid made of it.
TEST(CheckProbe, NarrowSlitIsFoundAtEveryResolution) {
    const double width = 0.02;
    for (int resolution : {96, 256, 511, 512, 513, 1024}) {
        SCOPED_TRACE(resolution);
        const SurfaceMesh terrain = aligned_terrain(resolution, default_offset, 8, width);
        const CheckReport open = check(terrain, resolution, Expect::open);
        EXPECT_FALSE(open.passed);
        EXPECT_EQ(open.count(DefectClass::boundary_loop), 1u) << describe(open);
        EXPECT_GE(open.count(DefectClass::probe_miss), 1u) << describe(open);
        for (const auto& d : open.of(DefectClass::probe_miss).locations) {
            EXPECT_GE(d.position.x, side / 2 - 0.5);
            EXPECT_LE(d.position.x, side / 2 + 0.5 + width);
        }
        EXPECT_EQ(open.probe.dismissed_rays, 0u);

        const SurfaceMesh solid = tessref::close_terrain_into_solid(terrain, 0.0);
        const CheckReport closed = check(solid, resolution, Expect::closed);
        EXPECT_FALSE(closed.passed);
        EXPECT_EQ(closed.count(DefectClass::boundary_loop), 1u) << describe(closed);
        EXPECT_GE(closed.count(DefectClass::probe_odd_parity), 1u) << describe(closed);
        EXPECT_EQ(closed.probe.dismissed_rays, 0u);
    }
}

// A slab 1e-9 thick at x = 0.75, beside a cube that stretches the box to x = -1: in single
// precision (2^-24 of 0.75 is 4e-8) its two big faces are one plane, and the points the
// probe takes as inside it lie on that plane, so rays from them may leave without a hit.
// The mesh is closed (every edge has two faces), so no ray can get out: what the probe saw
// is rounding, counted as dismissed, never a probe defect. (The slab's thin faces are
// degenerate, which the check reports.)
TEST(CheckProbe, TopologyDismissesWhatRoundingDoes) {
    tessref::IndexedMesh mesh;
    auto box = [&](glm::dvec3 lo, glm::dvec3 hi) {
        const auto base = static_cast<std::uint32_t>(mesh.positions.size());
        for (int k = 0; k < 8; ++k) mesh.positions.emplace_back(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z);
        const std::uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
        for (const auto& q : quads) {
            mesh.add_triangle(base + q[0], base + q[1], base + q[2]);
            mesh.add_triangle(base + q[0], base + q[2], base + q[3]);
        }
    };
    box({-1.0, 0.0, 0.0}, {-0.5, 0.5, 0.5});
    box({0.75, 0.0, 0.0}, {0.75 + 1e-9, 1.0, 1.0});
    CheckOptions options;
    options.expect = Expect::closed;
    options.probe_resolution = 64;
    const CheckReport r = tessref::check_mesh(mesh, options);
    ASSERT_TRUE(r.closed && r.manifold && r.consistently_oriented) << describe(r);
    EXPECT_GT(r.probe.dismissed_rays, 0u) << describe(r);
    EXPECT_EQ(r.probe.failed_rays, 0u);
    for (DefectClass k : {DefectClass::probe_miss, DefectClass::probe_odd_parity, DefectClass::probe_escape})
        EXPECT_EQ(r.count(k), 0u) << describe(r);
}

// A terrain's scene holds only the triangles its vertical rays can reach (probe.cpp,
// run_ray_probe): that must include every triangle the recast of a ray can hit, 16 scene
// resolutions beside it (16 * 2^-20 * 8, about 1.2e-4, for this terrain 16 units wide: the
// recast moves cos(2.4) * 1.2e-4 = -9.0e-5 along the first ground axis and 8.2e-5 along
// the second, the golden angle). The case: a slit 1.4e-4 wide centred on the line of one column
// (or row) of rays, between two strips 0.3 wide that no ray's line crosses. The rays of
// that column fall into the slit and miss; each is cast again beside itself, lands 1e-5
// or more inside a strip beside it, and hits: the probe does not see a slit that narrow, so
// it is no probe defect (the topology still reports its boundary). A strip left out of the
// scene (it holds no ray's line) would turn those recasts into misses. Every up axis,
// slits across either ground axis.
TEST(CheckProbe, RecastRaysHitTrianglesBesideTheirColumn) {
    const int resolution = 16;
    const glm::dvec2 offset = default_offset;
    const double half_width = 7e-5, strip = 0.3;
    for (int up = 0; up < 3; ++up)
        for (int across = 0; across < 2; ++across) {
            SCOPED_TRACE("up axis " + std::to_string(up) + ", slit across ground axis " + std::to_string(across));
            // Along the slit's ground axis the rays run at (k + offset) * side / resolution.
            const double at = on_ray(resolution / 2, across == 0 ? offset.x : offset.y, side, resolution);
            const std::vector<double> cut = {0.0, at - strip, at - half_width, at + half_width, at + strip, side};
            const std::vector<double> along = {0.0, 4.0, 12.0, side};
            tessref::IndexedMesh mesh;
            auto vertex = [&](std::size_t a, std::size_t b) {
                return static_cast<std::uint32_t>(b * cut.size() + a);
            };
            for (double t : along)
                for (double c : cut) {
                    glm::dvec2 ground = across == 0 ? glm::dvec2(c, t) : glm::dvec2(t, c);
                    glm::dvec3 p(0.0);
                    p[(up + 1) % 3] = ground.x;
                    p[(up + 2) % 3] = ground.y;
                    p[up] = 0.01 * (ground.x + ground.y);
                    mesh.positions.push_back(p);
                }
            for (std::size_t b = 0; b + 1 < along.size(); ++b)
                for (std::size_t a = 0; a + 1 < cut.size(); ++a) {
                    if (a == 2 && b == 1) continue;  // the slit
                    const std::uint32_t v00 = vertex(a, b), v10 = vertex(a + 1, b), v11 = vertex(a + 1, b + 1),
                                        v01 = vertex(a, b + 1);
                    if (across == 0) {
                        mesh.add_triangle(v00, v10, v11);
                        mesh.add_triangle(v00, v11, v01);
                    } else {  // the ground axes swapped: the same turn about the up axis
                        mesh.add_triangle(v00, v11, v10);
                        mesh.add_triangle(v00, v01, v11);
                    }
                }
            CheckOptions options;
            options.expect = Expect::open;
            options.probe_resolution = resolution;
            const CheckReport r = tessref::check_mesh(mesh, options);
            ASSERT_TRUE(r.terrain_like) << describe(r);
            ASSERT_EQ(r.up_axis, up);
            EXPECT_EQ(r.probe.mode, "terrain");
            EXPECT_EQ(r.count(DefectClass::boundary_loop), 1u) << describe(r);
            EXPECT_EQ(r.probe.recast_rays, 8u) << describe(r);  // the rows from 4 to 12
            EXPECT_EQ(r.probe.failed_rays, 0u) << describe(r);
            EXPECT_EQ(r.count(DefectClass::probe_miss), 0u) << describe(r);
        }
}

// The probe's scene holds every position of the mesh, so its frame (the centre it shifts to
// and the resolution) and its copy into Embree's buffer are computed in parallel chunks; they
// must be the serial pass's, bit for bit, whatever the chunks. Here 300 000 positions (many
// chunks), NaN among them (ignored: a NaN is never below or above anything), the extremes
// late in the list, and one triangle near the end whose hit needs its copied corners.
TEST(CheckProbe, SceneFrameAndCopyAreTheSerialOnes) {
    std::vector<glm::dvec3> positions;
    std::mt19937 random(7);
    std::uniform_real_distribution<double> coordinate(-3.0, 5.0);
    for (int i = 0; i < 300000; ++i) positions.emplace_back(coordinate(random), coordinate(random), coordinate(random));
    const double nan = std::nan("");
    positions[5] = {nan, 1.0, 2.0};
    positions[123456] = {0.0, nan, nan};
    positions[299990] = {-40.0, 0.0, 0.0};  // the box's lowest x, in the last chunk
    positions[200001] = {0.0, 0.0, 90.0};   // its highest z
    // The serial definition (raycast.h: 16 ulps of the largest coordinate after the shift to
    // the box's centre, 2^-20 of it), written out here.
    glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (const glm::dvec3& p : positions)
        for (int k = 0; k < 3; ++k)
            if (!std::isnan(p[k])) {
                lo[k] = std::min(lo[k], p[k]);
                hi[k] = std::max(hi[k], p[k]);
            }
    const glm::dvec3 centre = 0.5 * (lo + hi);
    double largest = 0.0;
    for (const glm::dvec3& p : positions)
        for (int k = 0; k < 3; ++k)
            if (!std::isnan(p[k])) largest = std::max(largest, std::abs(p[k] - centre[k]));
    // lo about (-40, -3, -3), hi about (5, 5, 90): the planted extremes, not a NaN.
    EXPECT_NEAR(centre.x, -17.5, 1e-3);
    EXPECT_NEAR(centre.z, 43.5, 1e-3);
    const double expected = std::ldexp(largest, -20);
    EXPECT_EQ(tessref::RayScene::resolution_of(positions), expected);

    // A triangle of the last positions, far from the others (z = 60): a vertical ray through
    // it hits at the height a serial copy puts it, in single precision after the shift.
    const std::size_t n = positions.size();
    positions[n - 3] = {0.0, 0.0, 60.0};
    positions[n - 2] = {1.0, 0.0, 60.0};
    positions[n - 1] = {0.0, 1.0, 60.0};
    const std::array<std::uint32_t, 3> triangle{static_cast<std::uint32_t>(n - 3), static_cast<std::uint32_t>(n - 2),
                                               static_cast<std::uint32_t>(n - 1)};
    const tessref::RayScene scene(positions, std::span(&triangle, 1));
    EXPECT_EQ(scene.resolution(), tessref::RayScene::resolution_of(positions));
    const tessref::RayHit hit = scene.intersect({0.25, 0.25, 100.0}, {0.0, 0.0, -1.0});
    ASSERT_TRUE(hit.hit);
    EXPECT_EQ(hit.triangle, 0u);
    EXPECT_NEAR(hit.t, 40.0, 1e-4);  // from z = 100 down to 60, up to float rounding
}

// The terrain probe and the escape rays ask only whether a ray hits, and ask Embree's
// occlusion query: it must answer what the nearest-hit query's `hit` does, also for rays
// exactly through vertices and along edges of a rough terrain's welded grid, where
// single-precision rounding decides which triangles a ray meets, and for rays beside the
// terrain, through its outline, and from below.
TEST(CheckProbe, OcclusionAnswersAsTheNearestHit) {
    const int n = 24;
    std::mt19937 random(3);
    const double step = side / n;
    const RoughTerrain terrain = rough_terrain(n, random, false);
    const auto& [positions, triangles] = terrain;
    const tessref::RayScene scene(positions, triangles);
    std::size_t hits = 0, misses = 0;
    const auto same = [&](const glm::dvec3& origin, const glm::dvec3& direction) {
        const bool hit = scene.intersect(origin, direction).hit;
        EXPECT_EQ(scene.occluded(origin, direction), hit) << origin.x << " " << origin.y << " " << origin.z;
        (hit ? hits : misses) += 1;
    };
    // Through every vertex and the middle of every edge, straight down and from below.
    for (int j = 0; j <= 2 * n; ++j)
        for (int i = 0; i <= 2 * n; ++i) {
            same({i * step / 2, j * step / 2, 2 * top}, {0.0, 0.0, -1.0});
            same({i * step / 2, j * step / 2, -top}, {0.0, 0.0, 1.0});
        }
    // Random vertical rays over and beside the terrain, and slanted ones.
    std::uniform_real_distribution<double> ground(-1.0, side + 1.0);
    for (int k = 0; k < 20000; ++k) {
        same({ground(random), ground(random), 2 * top}, {0.0, 0.0, -1.0});
        same({ground(random), ground(random), 2 * top}, glm::normalize(glm::dvec3(ground(random), ground(random), -side)));
    }
    EXPECT_GT(hits, 10000u);
    EXPECT_GT(misses, 1000u);
}

// The probe builds its scene with RayScene::Build::quick (Embree's Morton builder, corners in
// the leaves) where the render builds Build::compact (the SAH builder, indices in the
// leaves), and the trees do differ in which of the triangles at an edge or a vertex a ray
// exactly through it meets (on this terrain, for about a quarter of such rays). What the
// probe reads must not: occluded() answers alike (the terrain probe); and all_hits() has a
// grazing hit on both or on neither (the closed probe then casts the line again), and else
// lists the same triangles at the same t, crossed from the same side. Rays exactly through
// every vertex and along every edge of a rough welded terrain, where the robust test's
// single-precision rounding decides which triangles a ray meets, down, up and slanted, and
// random rays over, beside and nearly level across it. The test fails when the quick build
// leaves out the robust flag.
TEST(CheckProbe, QuickBuildMeetsWhatTheCompactOneMeets) {
    const int n = 64;
    std::mt19937 random(11);
    const double step = side / n;
    // Both diagonals, so that rays meet edges of every direction.
    const RoughTerrain terrain = rough_terrain(n, random, true);
    const auto& [positions, triangles] = terrain;
    const tessref::RayScene compact(positions, triangles, tessref::RayScene::Build::compact);
    const tessref::RayScene quick(positions, triangles, tessref::RayScene::Build::quick);
    std::size_t hits = 0, misses = 0, grazing = 0;
    // What the probe reads of a ray's hits: whether any hit grazes (the ray is then cast
    // again beside itself) and else every hit, in order (grazes() in probe.cpp).
    const double resolution = compact.resolution();
    ASSERT_EQ(quick.resolution(), resolution);
    struct Seen {
        bool grazes = false;
        struct Crossing {
            double t;
            std::uint32_t triangle;
            int side;
            bool operator==(const Crossing&) const = default;
        };
        std::vector<Crossing> crossings;
        bool operator==(const Seen&) const = default;
    };
    const auto seen = [&](const std::vector<tessref::RayHit>& hits) {
        Seen s;
        for (const tessref::RayHit& h : hits) {
            s.grazes = s.grazes || h.side == 0 || h.edge_distance <= resolution;
            s.crossings.push_back({h.t, h.triangle, h.side});
        }
        if (s.grazes) s.crossings.clear();
        return s;
    };
    const auto same = [&](const glm::dvec3& origin, const glm::dvec3& direction) {
        const std::vector<tessref::RayHit> a = compact.all_hits(origin, direction), b = quick.all_hits(origin, direction);
        const Seen x = seen(a), y = seen(b);
        EXPECT_TRUE(x == y) << origin.x << " " << origin.y << " " << origin.z << ": " << a.size() << " hits against " << b.size();
        const bool occluded = compact.occluded(origin, direction);
        EXPECT_EQ(quick.occluded(origin, direction), occluded) << origin.x << " " << origin.y << " " << origin.z;
        EXPECT_EQ(occluded, !a.empty());
        (a.empty() ? misses : hits) += 1;
        grazing += x.grazes;
    };
    // Through every vertex, every edge's middle and its quarters, down, up and slanted.
    for (int j = 0; j <= 4 * n; ++j)
        for (int i = 0; i <= 4 * n; ++i) {
            const double u = i * step / 4, w = j * step / 4;
            same({u, w, 2 * top}, {0.0, 0.0, -1.0});
            same({u, w, -top}, {0.0, 0.0, 1.0});
            same({u, w, 2 * top}, glm::normalize(glm::dvec3(1.0, 2.0, -40.0)));
        }
    // Random rays over and beside the terrain, and nearly level ones across it.
    std::uniform_real_distribution<double> ground(-1.0, side + 1.0);
    for (int k = 0; k < 20000; ++k) {
        same({ground(random), ground(random), 2 * top}, glm::normalize(glm::dvec3(ground(random), ground(random), -side)));
        same({-1.0, ground(random), 0.5 * top}, glm::normalize(glm::dvec3(1.0, 0.01 * ground(random), 0.0)));
    }
    EXPECT_GT(hits, 100000u);
    EXPECT_GT(misses, 1000u);
    EXPECT_GT(grazing, 10000u);  // through the vertices and edges
}
