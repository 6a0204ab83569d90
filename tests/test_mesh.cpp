// tests/test_mesh.cpp — export of a SurfaceMesh (include/tessref/mesh.h): PLY by tessref's
// writer, which must write byte for byte what OpenMesh's PLY writer writes; OBJ, OFF, STL
// through OpenMesh.
//
// The contract checked here:
//  - welding merges exactly the bitwise-equal positions (one ulp apart stays apart), and
//    the merged vertex takes its attributes from the copy with the lowest patch id;
//  - every format reads back through OpenMesh's own readers (an independent parser of the
//    file) with the positions we wrote: bitwise in binary; in ASCII the numbers carry 9
//    significant digits, which is enough for any float to read back bitwise
//    (FLT_DECIMAL_DIG = 9), so float-exact positions read back bitwise too;
//  - normals and uv come back where the format carries them; PLY carries patch_id and
//    tess_u/v/w as extra vertex properties, listed in its header;
//  - a terrain exported from the shipped scenes has one boundary loop, the outline, and no
//    T-junction (checked with a small edge map written here, independent of `check`).
#include <gtest/gtest.h>

#include "run_program.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <span>
#include <set>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>

#include "mesh/openmesh.h"
#include "tessref/error.h"
#include "tessref/mesh.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"

namespace fs = std::filesystem;
using tessref::MeshFormat;
using tessref::MeshWriteOptions;
using tessref::SurfaceMesh;

namespace {

using ReadMesh = OpenMesh::TriMesh_ArrayKernelT<>;

// A fresh directory per test, removed afterwards.
class MeshExport : public ::testing::Test {
protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = fs::temp_directory_path() /
               ("tessref-test-mesh-" + std::to_string(::getpid()) + "-" + info->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }
    fs::path path(const std::string& name) const { return dir_ / name; }

    fs::path write(const SurfaceMesh& mesh, const std::string& name, bool binary) const {
        const fs::path file = path(name);
        MeshWriteOptions options;
        options.format = tessref::mesh_format_from_path(file.string());
        options.binary = binary;
        std::ofstream out(file, std::ios::binary);
        tessref::write_mesh(mesh, out, options);
        out.close();
        EXPECT_TRUE(out) << file;
        return file;
    }

    fs::path dir_;
};

std::string read_text(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

// The PLY header (up to and including end_header).
std::string ply_header(const fs::path& file) {
    const std::string text = read_text(file);
    const std::size_t end = text.find("end_header");
    return end == std::string::npos ? text : text.substr(0, end + 10);
}

glm::vec3 as_float(const glm::dvec3& p) { return glm::vec3(p); }

bool bitwise_equal(float a, float b) { return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b); }

bool bitwise_equal(const OpenMesh::Vec3f& a, const glm::vec3& b) {
    return bitwise_equal(a[0], b.x) && bitwise_equal(a[1], b.y) && bitwise_equal(a[2], b.z);
}

// A small terrain-like mesh: two patches side by side, each emitting its own copies of
// the vertices of a 2x2-quad grid (9 vertices, 8 triangles), sharing the edge x = 1.
// Coordinates are floats with long decimal expansions so that the 9-digit ASCII path is
// really exercised; every vertex has a normal, a uv, a patch id and a tess coord.
SurfaceMesh two_patch_mesh() {
    SurfaceMesh mesh;
    const float heights[3][5] = {{0.1f, 1.0f / 3.0f, -2.71828183f, 1234.5678f, 7e-8f},
                                 {-0.2f, 2.0f / 3.0f, 3.14159274f, -98765.4f, 1e-30f},
                                 {0.3f, 5.0f / 7.0f, -1.41421354f, 0.0f, 123456792.0f}};
    for (std::uint32_t patch = 0; patch < 2; ++patch) {
        const std::uint32_t base = static_cast<std::uint32_t>(mesh.positions.size());
        for (int j = 0; j <= 2; ++j) {
            for (int i = 0; i <= 2; ++i) {
                const float u = static_cast<float>(i) / 2.0f;
                const float v = static_cast<float>(j) / 2.0f;
                const int column = static_cast<int>(patch) * 2 + i;  // 0..4, shared at 2
                const float x = 0.7f * static_cast<float>(column);
                const float y = 0.9f * static_cast<float>(j);
                mesh.positions.emplace_back(x, y, heights[j][column]);
                mesh.normals.push_back(glm::normalize(glm::dvec3(glm::vec3(0.1f * column, -0.2f * j, 1.0f))));
                mesh.uvs.emplace_back(static_cast<float>(column) / 4.0f, static_cast<float>(j) / 2.0f);
                mesh.patch_ids.push_back(patch);
                mesh.tess_coords.emplace_back(u, v, 0.0f);
            }
        }
        for (std::uint32_t j = 0; j < 2; ++j) {
            for (std::uint32_t i = 0; i < 2; ++i) {
                const std::uint32_t a = base + j * 3 + i, b = a + 1, c = a + 4, d = a + 3;
                mesh.triangles.push_back({a, b, c});
                mesh.triangles.push_back({a, c, d});
            }
        }
    }
    return mesh;
}

// The same shape with double positions that no float holds (an `exact` run).
SurfaceMesh two_patch_mesh_double() {
    SurfaceMesh mesh = two_patch_mesh();
    for (glm::dvec3& p : mesh.positions) p = p * (1.0 + 1e-12) + glm::dvec3(0.0, 0.0, 1.0 / 3.0);
    return mesh;
}

// ---------------------------------------------------------------------------------------
// The edge map: boundary loops, T-junctions, non-manifold and mis-oriented edges of a
// welded mesh. Written for this test, independent of the `check` command.

struct EdgeReport {
    std::size_t boundary_edges = 0;
    std::size_t boundary_loops = 0;
    std::size_t nonmanifold_edges = 0;    // used by 3+ triangles
    std::size_t misoriented_edges = 0;    // two triangles traverse it the same way
    std::size_t pinched_vertices = 0;     // 2+ boundary edges leave it
    std::size_t t_junctions = 0;          // a vertex inside a boundary edge
    std::size_t off_outline_vertices = 0; // boundary vertices not on the outline (see below)
    std::vector<std::string> examples;    // a few located defects, for failure messages
};

std::ostream& operator<<(std::ostream& out, const EdgeReport& r) {
    out << r.boundary_edges << " boundary edges in " << r.boundary_loops << " loops, "
        << r.off_outline_vertices << " boundary vertices off the outline, " << r.t_junctions
        << " T-junctions, " << r.pinched_vertices << " pinched vertices, " << r.nonmanifold_edges
        << " non-manifold and " << r.misoriented_edges << " mis-oriented edges";
    for (const std::string& example : r.examples) out << "\n  " << example;
    return out;
}

std::string describe(const SurfaceMesh& mesh, std::uint32_t v) {
    char text[256];
    const glm::dvec3& p = mesh.positions[v];
    std::snprintf(text, sizeof text, "vertex %u (%.17g, %.17g, %.17g)", v, p.x, p.y, p.z);
    std::string out = text;
    if (!mesh.patch_ids.empty()) {
        const glm::vec3 tc = mesh.tess_coords.empty() ? glm::vec3(-1) : mesh.tess_coords[v];
        std::snprintf(text, sizeof text, " of patch %u at tess coord (%.9g, %.9g)", mesh.patch_ids[v], tc.x, tc.y);
        out += text;
    }
    return out;
}

// An edge map over the vertex indices: each undirected edge with the directions in which
// triangles traverse it. A boundary edge has one triangle. A T-junction (a vertex of one
// triangle lying inside another triangle's edge) can only sit on a boundary edge: the long
// edge has triangles on one side only, because the other side is cut into shorter edges.
// So the T-junction search tests every boundary vertex against every boundary edge.
// The outline: a terrain is a height field over a rectangle in two of the three axes, so
// its outline lies on that rectangle's sides; boundary vertices elsewhere belong to a hole.
EdgeReport analyse_edges(const SurfaceMesh& welded) {
    EdgeReport report;
    // Every triangle side as (lo << 32 | hi) << 1 | forward, sorted: equal edges are
    // neighbours (a sorted vector rather than a map: terrains have millions of edges).
    std::vector<std::uint64_t> sides;
    sides.reserve(welded.triangles.size() * 3);
    for (const auto& t : welded.triangles) {
        for (int k = 0; k < 3; ++k) {
            const std::uint64_t a = t[k], b = t[(k + 1) % 3];
            sides.push_back(((std::min(a, b) << 32 | std::max(a, b)) << 1) | (a < b ? 1u : 0u));
        }
    }
    std::sort(sides.begin(), sides.end());
    std::map<std::uint32_t, std::vector<std::uint32_t>> next;  // boundary: a -> b as traversed
    std::vector<std::pair<std::uint32_t, std::uint32_t>> boundary;
    for (std::size_t i = 0; i < sides.size();) {
        std::size_t j = i;
        while (j < sides.size() && (sides[j] >> 1) == (sides[i] >> 1)) ++j;
        const std::size_t uses = j - i;
        if (uses == 1) {
            const auto lo = static_cast<std::uint32_t>(sides[i] >> 33);
            const auto hi = static_cast<std::uint32_t>((sides[i] >> 1) & 0xffffffffu);
            const bool forward = (sides[i] & 1u) != 0;
            const std::uint32_t a = forward ? lo : hi, b = forward ? hi : lo;
            next[a].push_back(b);
            boundary.emplace_back(a, b);
        } else if (uses == 2) {
            if ((sides[i] & 1u) == (sides[i + 1] & 1u)) ++report.misoriented_edges;
        } else {
            ++report.nonmanifold_edges;
        }
        i = j;
    }
    report.boundary_edges = boundary.size();
    for (const auto& [a, outs] : next) {
        if (outs.size() > 1) ++report.pinched_vertices;
    }
    // Loops: follow next[] from each unvisited boundary edge.
    std::map<std::uint32_t, std::size_t> used;  // vertex -> outgoing edges consumed
    for (const auto& [start, outs] : next) {
        while (used[start] < outs.size()) {
            ++report.boundary_loops;
            std::uint32_t v = start;
            do {
                const auto& candidates = next[v];
                if (used[v] >= candidates.size()) break;  // open chain: counted, stop
                v = candidates[used[v]++];
            } while (v != start);
        }
    }
    // Outline: each boundary vertex on a side of the bounding rectangle, for one choice of
    // the two horizontal axes (the pair that fits best). "On" within 1e-9 of the extent:
    // the evaluation's bilinear mix of two equal coordinates, a*(1-t) + a*t, can miss a by
    // an ulp or two, the same way on both sides of a seam (so it welds) and along the
    // outline; a hole's boundary lies at least one tessellated segment inside.
    glm::dvec3 lo(INFINITY), hi(-INFINITY);
    for (const auto& p : welded.positions) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    std::vector<std::uint32_t> boundary_vertices;
    for (const auto& [a, b] : boundary) boundary_vertices.push_back(a);
    std::sort(boundary_vertices.begin(), boundary_vertices.end());
    boundary_vertices.erase(std::unique(boundary_vertices.begin(), boundary_vertices.end()),
                            boundary_vertices.end());
    std::vector<std::uint32_t> best_off = boundary_vertices;
    for (const auto& [i, j] : {std::pair{0, 1}, std::pair{0, 2}, std::pair{1, 2}}) {
        std::vector<std::uint32_t> off;
        const double ti = 1e-9 * (hi[i] - lo[i]), tj = 1e-9 * (hi[j] - lo[j]);
        for (const std::uint32_t v : boundary_vertices) {
            const glm::dvec3& p = welded.positions[v];
            const bool on_side = std::abs(p[i] - lo[i]) <= ti || std::abs(p[i] - hi[i]) <= ti ||
                                 std::abs(p[j] - lo[j]) <= tj || std::abs(p[j] - hi[j]) <= tj;
            if (!on_side) off.push_back(v);
        }
        if (off.size() < best_off.size()) best_off = std::move(off);
    }
    report.off_outline_vertices = best_off.size();
    for (std::size_t k = 0; k < best_off.size() && k < 3; ++k)
        report.examples.push_back("off the outline: " + describe(welded, best_off[k]));
    // T-junctions: a boundary vertex strictly inside a boundary edge (collinear to a
    // relative 1e-9 of the edge's length, parameter away from both ends). Vertices sorted
    // by x so each edge looks only at those within its x extent.
    std::vector<std::uint32_t> by_x = boundary_vertices;
    std::sort(by_x.begin(), by_x.end(), [&](std::uint32_t a, std::uint32_t b) {
        return welded.positions[a].x < welded.positions[b].x;
    });
    for (const auto& [a, b] : boundary) {
        const glm::dvec3 pa = welded.positions[a], pb = welded.positions[b];
        const glm::dvec3 d = pb - pa;
        const double length2 = glm::dot(d, d);
        if (!(length2 > 0.0)) continue;
        const double tolerance = 1e-9 * std::sqrt(length2);
        const double x0 = std::min(pa.x, pb.x) - tolerance, x1 = std::max(pa.x, pb.x) + tolerance;
        auto it = std::lower_bound(by_x.begin(), by_x.end(), x0, [&](std::uint32_t v, double x) {
            return welded.positions[v].x < x;
        });
        for (; it != by_x.end() && welded.positions[*it].x <= x1; ++it) {
            if (*it == a || *it == b) continue;
            const glm::dvec3 pv = welded.positions[*it];
            const double t = glm::dot(pv - pa, d) / length2;
            if (t <= 1e-9 || t >= 1.0 - 1e-9) continue;
            if (glm::length(pv - (pa + t * d)) <= tolerance) {
                if (++report.t_junctions <= 5) {
                    report.examples.push_back("T-junction: " + describe(welded, *it) + " inside the edge from " +
                                              describe(welded, a) + " to " + describe(welded, b));
                }
            }
        }
    }
    return report;
}

// A grid of nx x ny unit patches, each emitting its own (level+1)^2 vertex copies with
// z = f(x, y) (bilinear), as the pipeline does; levels[py][px] per patch (power of two, so every x
// and y is an exact binary fraction and shared edges are bitwise equal).
SurfaceMesh grid_terrain(const std::vector<std::vector<int>>& levels) {
    SurfaceMesh mesh;
    // Bilinear, so a vertex at an edge's midpoint lies exactly on that edge of the neighbour
    // (a mismatch of levels is then a T-junction in the strict, geometric sense).
    const auto height = [](double x, double y) { return 0.25 * x - 0.125 * x * y + 0.5 * y; };
    std::uint32_t patch = 0;
    for (std::size_t py = 0; py < levels.size(); ++py) {
        for (std::size_t px = 0; px < levels[py].size(); ++px, ++patch) {
            const int level = levels[py][px];
            const std::uint32_t base = static_cast<std::uint32_t>(mesh.positions.size());
            for (int j = 0; j <= level; ++j) {
                for (int i = 0; i <= level; ++i) {
                    const double u = static_cast<double>(i) / level, v = static_cast<double>(j) / level;
                    const double x = static_cast<double>(px) + u, y = static_cast<double>(py) + v;
                    mesh.positions.emplace_back(x, y, height(x, y));
                    mesh.patch_ids.push_back(patch);
                    mesh.tess_coords.emplace_back(static_cast<float>(u), static_cast<float>(v), 0.0f);
                }
            }
            const std::uint32_t row = static_cast<std::uint32_t>(level) + 1;
            for (std::uint32_t j = 0; j < static_cast<std::uint32_t>(level); ++j) {
                for (std::uint32_t i = 0; i < static_cast<std::uint32_t>(level); ++i) {
                    const std::uint32_t a = base + j * row + i;
                    mesh.triangles.push_back({a, a + 1, a + row + 1});
                    mesh.triangles.push_back({a, a + row + 1, a + row});
                }
            }
        }
    }
    return mesh;
}

// ---------------------------------------------------------------------------------------
// Welding

TEST(Weld, TwoTrianglesSharingAnEdgeWeldToFourVertices) {
    // Two triangles emitted separately (6 vertices), sharing the edge (1,0,0)-(0,1,0).
    SurfaceMesh mesh;
    mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    mesh.triangles = {{0, 1, 2}, {3, 4, 5}};
    const tessref::WeldedMesh welded = tessref::weld_bitwise(mesh);
    EXPECT_EQ(welded.mesh.positions.size(), 4u);
    ASSERT_EQ(welded.mesh.triangles.size(), 2u);
    EXPECT_EQ(welded.vertex_map, (std::vector<std::uint32_t>{0, 1, 2, 1, 3, 2}));
    // The shared edge is now one edge: traversed 1->2 by the first, 2->1 by the second.
    const EdgeReport edges = analyse_edges(welded.mesh);
    EXPECT_EQ(edges.boundary_edges, 4u);
    EXPECT_EQ(edges.boundary_loops, 1u);
}

TEST(Weld, OneUlpApartDoesNotWeld) {
    SurfaceMesh mesh;
    mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    mesh.triangles = {{0, 1, 2}, {3, 4, 5}};
    for (int axis = 0; axis < 3; ++axis) {
        SurfaceMesh cracked = mesh;
        cracked.positions[5][axis] = std::nextafter(cracked.positions[5][axis], 2.0);
        const tessref::WeldedMesh welded = tessref::weld_bitwise(cracked);
        EXPECT_EQ(welded.mesh.positions.size(), 5u) << "axis " << axis;
        // The crack stays a hole: one boundary of 6 edges instead of 4.
        EXPECT_EQ(analyse_edges(welded.mesh).boundary_edges, 6u) << "axis " << axis;
    }
    // Also one float ulp on a float-exact coordinate (what a gpu-precision crack is).
    SurfaceMesh cracked = mesh;
    cracked.positions[3].x = std::nextafter(1.0f, 2.0f);
    EXPECT_EQ(tessref::weld_bitwise(cracked).mesh.positions.size(), 5u);
}

TEST(Weld, SignOfZeroIsIgnored) {
    SurfaceMesh mesh;
    mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, -0.0, 0}, {1, 1, 0}, {-0.0, 1, -0.0}};
    mesh.triangles = {{0, 1, 2}, {3, 4, 5}};
    EXPECT_EQ(tessref::weld_bitwise(mesh).mesh.positions.size(), 4u);
}

TEST(Weld, NanPositionsWeldOnlyWithTheSameBits) {
    SurfaceMesh mesh;
    const double nan = std::nan("");
    mesh.positions = {{nan, 0, 0}, {nan, 0, 0}, {-nan, 0, 0}};
    EXPECT_EQ(tessref::weld_bitwise(mesh).mesh.positions.size(), 2u);
}

TEST(Weld, MergedVertexTakesTheAttributesOfTheLowestPatchId) {
    // Three copies of one position from patches 7, 3, 3 (in that order), with different
    // attributes: the welded vertex is patch 3's first copy, whole (not a mix).
    SurfaceMesh mesh;
    mesh.positions = {{1, 2, 3}, {1, 2, 3}, {1, 2, 3}, {0, 0, 0}};
    mesh.normals = {{0, 0, 1}, {0, 1, 0}, {1, 0, 0}, {0, 0, 1}};
    mesh.uvs = {{0.7, 0.7}, {0.3, 0.3}, {0.9, 0.9}, {0, 0}};
    mesh.patch_ids = {7, 3, 3, 0};
    mesh.tess_coords = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 0}};
    const tessref::WeldedMesh welded = tessref::weld_bitwise(mesh);
    ASSERT_EQ(welded.mesh.positions.size(), 2u);
    EXPECT_EQ(welded.mesh.patch_ids[0], 3u);
    EXPECT_EQ(welded.mesh.normals[0], glm::dvec3(0, 1, 0));
    EXPECT_EQ(welded.mesh.uvs[0], glm::dvec2(0.3, 0.3));
    EXPECT_EQ(welded.mesh.tess_coords[0], glm::vec3(0, 1, 0));
    // Numbered by first emitted copy: the (1,2,3) vertex first, though its source is #1.
    EXPECT_EQ(welded.mesh.positions[1], glm::dvec3(0, 0, 0));
}

TEST(Weld, DegenerateTrianglesAreLeftOutAndCounted) {
    SurfaceMesh mesh;
    mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}};
    mesh.triangles = {{0, 1, 2}, {0, 1, 3}};  // 1 and 3 weld: the second has two corners
    const tessref::WeldedMesh welded = tessref::weld_bitwise(mesh);
    EXPECT_EQ(welded.mesh.triangles.size(), 1u);
    EXPECT_EQ(welded.degenerate_triangles, 1u);
}

TEST(Weld, InconsistentMeshesAreErrors) {
    SurfaceMesh mesh;
    mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    mesh.patch_ids = {0, 0, 0};
    mesh.triangles = {{0, 1, 3}};
    EXPECT_THROW(tessref::weld_bitwise(mesh), tessref::Error);
    mesh.triangles = {{0, 1, 2}};
    mesh.normals = {{0, 0, 1}};
    EXPECT_THROW(tessref::weld_bitwise(mesh), tessref::Error);
}

// ---------------------------------------------------------------------------------------
// The edge map itself (so the scene tests below can trust it)

TEST(EdgeMap, ConformingGridHasOneOutlineLoopAndNoTJunction) {
    const SurfaceMesh welded = tessref::weld_bitwise(grid_terrain({{2, 2, 2}, {2, 2, 2}})).mesh;
    const EdgeReport edges = analyse_edges(welded);
    EXPECT_EQ(edges.boundary_loops, 1u);
    EXPECT_EQ(edges.boundary_edges, 2u * (6 + 4));  // 6 x 4 segments around the outline
    EXPECT_EQ(edges.t_junctions, 0u);
    EXPECT_EQ(edges.off_outline_vertices, 0u);
    EXPECT_EQ(edges.nonmanifold_edges + edges.misoriented_edges + edges.pinched_vertices, 0u);
}

TEST(EdgeMap, FindsTheTJunctionsOfMismatchedLevels) {
    // Patch (0,0) at level 2 beside (1,0) at level 1: the midpoint of the shared edge is a
    // vertex of the left patch inside the right patch's edge. The hole is a sliver whose
    // ends are on the outline, so the boundary pinches there (two boundary edges leave
    // each end).
    {
        const EdgeReport edges = analyse_edges(tessref::weld_bitwise(grid_terrain({{2, 1}})).mesh);
        EXPECT_EQ(edges.t_junctions, 1u);
        EXPECT_EQ(edges.off_outline_vertices, 1u);
        EXPECT_EQ(edges.pinched_vertices, 2u);
    }
    // A level-2 patch inside level-1 neighbours: one T-junction on each of its four edges,
    // the slivers a hole inside the terrain, apart from the outline.
    {
        const EdgeReport edges =
            analyse_edges(tessref::weld_bitwise(grid_terrain({{1, 1, 1}, {1, 2, 1}, {1, 1, 1}})).mesh);
        EXPECT_EQ(edges.t_junctions, 4u);
        EXPECT_EQ(edges.off_outline_vertices, 8u);  // 4 midpoints + 4 corners of the patch
        EXPECT_GE(edges.boundary_loops, 2u);
    }
}

TEST(EdgeMap, FindsACrack) {
    SurfaceMesh mesh = grid_terrain({{2, 2}, {2, 2}});
    // Move the centre vertex of the whole grid by one ulp in patch 3's copy only.
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
        if (mesh.patch_ids[v] == 3 && mesh.positions[v] == glm::dvec3(1, 1, mesh.positions[v].z))
            mesh.positions[v].z = std::nextafter(mesh.positions[v].z, 10.0);
    }
    const EdgeReport edges = analyse_edges(tessref::weld_bitwise(mesh).mesh);
    EXPECT_EQ(edges.boundary_loops, 2u);
    EXPECT_GT(edges.off_outline_vertices, 0u);
}

// ---------------------------------------------------------------------------------------
// Formats and errors

TEST(MeshFormat, FromPath) {
    EXPECT_EQ(tessref::mesh_format_from_path("a/b.ply"), MeshFormat::ply);
    EXPECT_EQ(tessref::mesh_format_from_path("T.OBJ"), MeshFormat::obj);
    EXPECT_EQ(tessref::mesh_format_from_path("x.off"), MeshFormat::off);
    EXPECT_EQ(tessref::mesh_format_from_path("x.Stl"), MeshFormat::stl);
    EXPECT_THROW(tessref::mesh_format_from_path("x.vtk"), tessref::Error);
    EXPECT_THROW(tessref::mesh_format_from_path("x"), tessref::Error);
    EXPECT_THROW(tessref::mesh_format_from_path("x.ply.tmp"), tessref::Error);
}

TEST(MeshFormat, ObjHasNoBinaryForm) {
    std::ostringstream out;
    MeshWriteOptions options;
    options.format = MeshFormat::obj;
    options.binary = true;
    EXPECT_THROW(tessref::write_mesh(two_patch_mesh(), out, options), tessref::Error);
    EXPECT_TRUE(out.str().empty());
}

TEST(MeshFormat, WritingIsDeterministic) {
    for (MeshFormat format : {MeshFormat::ply, MeshFormat::obj, MeshFormat::off, MeshFormat::stl}) {
        for (bool binary : {false, true}) {
            if (binary && !tessref::mesh_format_has_binary(format)) continue;
            MeshWriteOptions options;
            options.format = format;
            options.binary = binary;
            std::ostringstream a, b;
            tessref::write_mesh(two_patch_mesh(), a, options);
            tessref::write_mesh(two_patch_mesh(), b, options);
            EXPECT_FALSE(a.str().empty());
            EXPECT_EQ(a.str(), b.str()) << tessref::to_string(format) << (binary ? " binary" : "");
        }
    }
}

// ---------------------------------------------------------------------------------------
// tessref's PLY writer against OpenMesh's: the same bytes

// write_mesh() (tessref's PLY writer) and OpenMesh's PLY writer on one mesh and options.
void expect_ply_as_openmesh_writes_it(const SurfaceMesh& mesh, MeshWriteOptions options, const std::string& what) {
    options.format = MeshFormat::ply;
    std::ostringstream ours, reference;
    const tessref::MeshWriteReport a = tessref::write_mesh(mesh, ours, options);
    const tessref::MeshWriteReport b = tessref::mesh_detail::write_mesh_through_openmesh(mesh, reference, options);
    const std::string label = what + (options.binary ? " binary" : " ascii") + " digits " +
                              std::to_string(options.ascii_digits) + (options.weld ? "" : " unwelded");
    EXPECT_FALSE(ours.str().empty()) << label;
    EXPECT_TRUE(ours.str() == reference.str())
        << label << ": " << ours.str().size() << " bytes against OpenMesh's " << reference.str().size()
        << "; first difference at byte "
        << (std::mismatch(ours.str().begin(), ours.str().end(), reference.str().begin(), reference.str().end()).first -
            ours.str().begin());
    EXPECT_EQ(a.vertices, b.vertices) << label;
    EXPECT_EQ(a.triangles, b.triangles) << label;
    EXPECT_EQ(a.degenerate_triangles, b.degenerate_triangles) << label;
    EXPECT_EQ(a.float_distinct_vertices, b.float_distinct_vertices) << label;
    EXPECT_EQ(a.float_degenerate_triangles, b.float_degenerate_triangles) << label;
}

void expect_ply_as_openmesh_writes_it(const SurfaceMesh& mesh, const std::string& what) {
    for (const bool binary : {false, true}) {
        for (const bool weld : {true, false}) {
            for (const int digits : {9, 4, 17}) {
                if (binary && digits != 9) continue;  // binary has no digits
                MeshWriteOptions options;
                options.binary = binary;
                options.weld = weld;
                options.ascii_digits = digits;
                expect_ply_as_openmesh_writes_it(mesh, options, what);
            }
        }
    }
}

TEST(PlyWriter, WritesWhatOpenMeshWritesForEveryAttributeCombination) {
    for (int dropped = 0; dropped < 16; ++dropped) {
        for (const bool exact : {false, true}) {
            SurfaceMesh mesh = exact ? two_patch_mesh_double() : two_patch_mesh();
            std::string what = exact ? "double positions" : "float positions";
            if (dropped & 1) mesh.normals.clear(), what += ", no normals";
            if (dropped & 2) mesh.uvs.clear(), what += ", no uvs";
            if (dropped & 4) mesh.patch_ids.clear(), what += ", no patch ids";
            if (dropped & 8) mesh.tess_coords.clear(), what += ", no tess coords";
            expect_ply_as_openmesh_writes_it(mesh, what);
        }
    }
}

TEST(PlyWriter, WritesWhatOpenMeshWritesForOddMeshes) {
    // Negative zeros, huge and tiny numbers, a degenerate triangle, patch ids beyond 2^31
    // (written as PLY's int, wrapped as OpenMesh's int property wraps them), no triangle.
    SurfaceMesh mesh = two_patch_mesh();
    mesh.positions[0] = {-0.0, 3.4e38, -1e-45};
    mesh.normals[1] = {-0.0, 0.0, -1.0};
    mesh.uvs[2] = {-1e30, 1e-30};
    mesh.patch_ids[3] = 0x80000005u;
    mesh.tess_coords[4] = {-0.0f, 1e-40f, 0.5f};
    mesh.triangles.push_back({0, 0, 1});
    expect_ply_as_openmesh_writes_it(mesh, "odd values");
    SurfaceMesh no_triangles = two_patch_mesh();
    no_triangles.triangles.clear();
    expect_ply_as_openmesh_writes_it(no_triangles, "no triangles");
    SurfaceMesh positions_only;
    positions_only.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
    positions_only.triangles = {{0, 1, 2}, {1, 3, 2}};
    expect_ply_as_openmesh_writes_it(positions_only, "positions only");
}

TEST(PlyWriter, WritesWhatOpenMeshWritesForShippedScenes) {
    // A terrain with normals and uvs (thesis), one with face normals' scenes, the PN
    // triangle mesh (a closed mesh from a file), in both precisions.
    for (const char* name : {"thesis-map-4", "jacksboro", "pn-triangles", "cosc422", "olinda"}) {
        const fs::path path = fs::path(TESSREF_DATA_DIR) / "scenes" / (std::string(name) + ".toml");
        const tessref::Scene scene = tessref::load_scene(path.string());
        for (const tessref::Precision precision : {tessref::Precision::gpu, tessref::Precision::exact}) {
            tessref::PipelineOptions options;
            options.precision = precision;
            const tessref::PipelineResult result = tessref::run_pipeline(scene, options);
            for (const bool binary : {false, true}) {
                MeshWriteOptions write_options;
                write_options.binary = binary;
                expect_ply_as_openmesh_writes_it(result.mesh, write_options,
                                                 std::string(name) + " " + std::string(tessref::to_string(precision)));
            }
        }
    }
}

TEST(PlyWriter, WritesWhatOpenMeshWritesForAMeshOfManyBlocks) {
    // The writer formats blocks of records in parallel, several rounds of them here (over
    // 200,000 records): the bytes must still be OpenMesh's serial ones.
    SurfaceMesh mesh = grid_terrain(std::vector<std::vector<int>>(8, std::vector<int>(8, 32)));
    for (const glm::dvec3& p : mesh.positions) {
        mesh.normals.push_back(glm::normalize(glm::dvec3(-p.y, 0.5 * p.x, 1.0 + p.z)));
        mesh.uvs.emplace_back(p.x / 8.0 + 1.0 / 3.0, p.y / 8.0);
    }
    for (const bool binary : {false, true}) {
        for (const bool weld : {true, false}) {
            MeshWriteOptions options;
            options.binary = binary;
            options.weld = weld;
            expect_ply_as_openmesh_writes_it(mesh, options, "8 x 8 patches at level 32");
        }
    }
}

// ---------------------------------------------------------------------------------------
// The streamed export of `tessref mesh`: SurfaceWelder and run_pipeline_welded give what
// weld_bitwise gives for the whole surface, and the same file

// `mesh` cut into pieces of `patches` whole patches each (the patches' vertices and
// triangles are contiguous, as the pipeline emits them), triangles indexing each piece.
std::vector<SurfaceMesh> cut_into_pieces(const SurfaceMesh& mesh, std::size_t patches) {
    std::vector<SurfaceMesh> pieces;
    std::size_t first = 0, t = 0;
    while (first < mesh.positions.size()) {
        std::size_t last = first + 1, seen = 1;
        for (; last < mesh.positions.size(); ++last)
            if (mesh.patch_ids[last] != mesh.patch_ids[last - 1] && ++seen > patches) break;
        SurfaceMesh piece;
        const auto slice = [&](const auto& from, auto& to) {
            if (!from.empty()) to.assign(from.begin() + first, from.begin() + last);
        };
        slice(mesh.positions, piece.positions);
        slice(mesh.normals, piece.normals);
        slice(mesh.uvs, piece.uvs);
        slice(mesh.patch_ids, piece.patch_ids);
        slice(mesh.tess_coords, piece.tess_coords);
        for (; t < mesh.triangles.size() && mesh.triangles[t][0] < last; ++t) {
            const auto& tri = mesh.triangles[t];
            piece.triangles.push_back({static_cast<std::uint32_t>(tri[0] - first),
                                       static_cast<std::uint32_t>(tri[1] - first),
                                       static_cast<std::uint32_t>(tri[2] - first)});
        }
        pieces.push_back(std::move(piece));
        first = last;
    }
    return pieces;
}

template <typename T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

void expect_same_welded_mesh(const tessref::WeldedMesh& a, const tessref::WeldedMesh& b, const std::string& what) {
    EXPECT_TRUE(same_bits(a.mesh.positions, b.mesh.positions)) << what;
    EXPECT_TRUE(same_bits(a.mesh.normals, b.mesh.normals)) << what;
    EXPECT_TRUE(same_bits(a.mesh.uvs, b.mesh.uvs)) << what;
    EXPECT_TRUE(same_bits(a.mesh.patch_ids, b.mesh.patch_ids)) << what;
    EXPECT_TRUE(same_bits(a.mesh.tess_coords, b.mesh.tess_coords)) << what;
    EXPECT_EQ(a.mesh.triangles, b.mesh.triangles) << what;
    EXPECT_EQ(a.emitted_vertices, b.emitted_vertices) << what;
    EXPECT_EQ(a.degenerate_triangles, b.degenerate_triangles) << what;
}

TEST(SurfaceWelder, WeldsPiecesAsWeldBitwiseWeldsTheWhole) {
    SurfaceMesh grid = grid_terrain({{2, 4, 2}, {4, 2, 4}, {2, 2, 2}});
    SurfaceMesh odd = two_patch_mesh();
    odd.positions[6] = {0.0, -0.0, odd.positions[6].z};  // a zero of either sign welds
    odd.positions[9] = {-0.0, 0.0, odd.positions[9].z};
    odd.positions[6].z = odd.positions[9].z;
    odd.triangles.insert(odd.triangles.begin(), {0, 0, 1});  // degenerate: left out and counted
    // Patch ids falling along the emission: a later piece's copy has the lower id and wins.
    SurfaceMesh falling = grid;
    for (std::uint32_t& id : falling.patch_ids) id = 100 - id;
    SurfaceMesh no_ids = grid;
    no_ids.patch_ids.clear();
    for (const auto& [mesh, what] : {std::pair{grid, "grid"}, std::pair{odd, "two patches, signed zeros"},
                                     std::pair{falling, "falling patch ids"}}) {
        const tessref::WeldedMesh whole = tessref::weld_bitwise(mesh);
        for (const std::size_t patches : {1, 2, 5, 100}) {
            for (const std::size_t expected : {std::size_t{0}, mesh.positions.size()}) {
                tessref::SurfaceWelder welder(expected, expected);
                welder.add(SurfaceMesh{});  // an empty piece changes nothing
                for (const SurfaceMesh& piece : cut_into_pieces(mesh, patches)) welder.add(piece);
                const tessref::WeldedMesh pieces = welder.take();
                EXPECT_TRUE(pieces.vertex_map.empty());
                expect_same_welded_mesh(pieces, whole,
                                        std::string(what) + ", " + std::to_string(patches) + " patches a piece, " +
                                            std::to_string(expected) + " expected");
            }
        }
    }
    // Without patch ids (cut where the grid's patches end).
    tessref::SurfaceWelder welder;
    for (const SurfaceMesh& piece : cut_into_pieces(grid, 2)) {
        SurfaceMesh copy = piece;
        copy.patch_ids.clear();
        welder.add(copy);
    }
    expect_same_welded_mesh(welder.take(), tessref::weld_bitwise(no_ids), "no patch ids");
}

TEST(SurfaceWelder, RefusesInconsistentPieces) {
    const std::vector<SurfaceMesh> pieces = cut_into_pieces(two_patch_mesh(), 1);
    ASSERT_EQ(pieces.size(), 2u);
    for (int dropped = 0; dropped < 4; ++dropped) {
        SurfaceMesh second = pieces[1];
        if (dropped == 0) second.normals.clear();
        if (dropped == 1) second.uvs.clear();
        if (dropped == 2) second.patch_ids.clear();
        if (dropped == 3) second.tess_coords.clear();
        tessref::SurfaceWelder welder;
        welder.add(pieces[0]);
        EXPECT_THROW(welder.add(second), tessref::Error) << dropped;
    }
    SurfaceMesh bad = pieces[0];
    bad.triangles.push_back({0, 1, 9});  // names a vertex the piece does not have
    tessref::SurfaceWelder welder;
    EXPECT_THROW(welder.add(bad), tessref::Error);
}

TEST(StreamedExport, RunPipelineWeldedIsTheWeldOfRunPipeline) {
    // Terrains of every model, the PN mesh, a geomipmapped terrain and smooth normals (both
    // welded whole), in both precisions and camera-relative; then the file from either is
    // the same.
    struct Case {
        const char* name;
        bool smooth = false;
    };
    for (const Case c : {Case{"thesis-map-4"}, Case{"jacksboro"}, Case{"pn-triangles"}, Case{"cosc422"},
                         Case{"lab4-canyon"}, Case{"terrain-pom"}, Case{"jacksboro-geomipmap"},
                         Case{"thesis-constant-1", true}}) {
        const fs::path path = fs::path(TESSREF_DATA_DIR) / "scenes" / (std::string(c.name) + ".toml");
        tessref::Scene scene = tessref::load_scene(path.string());
        if (c.smooth) {
            scene.geometry = scene.geometry.value_or(tessref::GeometryStage{});
            scene.geometry->normals = tessref::GeometryNormals::smooth;
            EXPECT_FALSE(tessref::surface_streams(scene));
        }
        for (const tessref::Precision precision : {tessref::Precision::gpu, tessref::Precision::exact}) {
            for (const bool relative : {false, true}) {
                const std::string what = std::string(c.name) + (c.smooth ? " smooth" : "") + " " +
                                         std::string(tessref::to_string(precision)) + (relative ? " relative" : "");
                tessref::PipelineOptions options;
                options.precision = precision;
                options.camera_relative = relative;
                const tessref::PipelineResult result = tessref::run_pipeline(scene, options);
                std::size_t last_progress = 0;
                options.progress = [&](std::size_t done, std::size_t total) {
                    EXPECT_GE(done, last_progress);
                    EXPECT_LE(done, total);
                    last_progress = done;
                };
                const tessref::WeldedMesh streamed = tessref::run_pipeline_welded(scene, options);
                EXPECT_EQ(last_progress, scene.patch_count()) << what;
                expect_same_welded_mesh(streamed, tessref::weld_bitwise(result.mesh), what);
                for (const MeshFormat format : {MeshFormat::ply, MeshFormat::obj}) {
                    for (const bool binary : {false, true}) {
                        if (binary && format == MeshFormat::obj) continue;
                        MeshWriteOptions write_options;
                        write_options.format = format;
                        write_options.binary = binary;
                        std::ostringstream whole, pieces;
                        const tessref::MeshWriteReport a = tessref::write_mesh(result.mesh, whole, write_options);
                        const tessref::MeshWriteReport b = tessref::write_mesh(streamed, pieces, write_options);
                        EXPECT_TRUE(whole.str() == pieces.str()) << what << " " << tessref::to_string(format);
                        EXPECT_EQ(a.emitted_vertices, b.emitted_vertices) << what;
                        EXPECT_EQ(a.vertices, b.vertices) << what;
                        EXPECT_EQ(a.triangles, b.triangles) << what;
                        EXPECT_EQ(a.float_distinct_vertices, b.float_distinct_vertices) << what;
                    }
                }
            }
        }
    }
}

TEST(StreamedExport, StreamedPlyIsTheWholeSurfacesFile) {
    // write_pipeline_ply() streams a float terrain's PLY (every model), and gives up (nullopt)
    // on everything else: PN triangles (curved patches whose boxes overlap), a geomipmapped
    // terrain, smooth normals, exact precision and camera-relative evaluation. Where it
    // streams, the file and the report are write_mesh()'s of the whole surface.
    struct Case {
        const char* name;
        bool streams;
        bool smooth = false;
    };
    for (const Case c : {Case{"thesis-map-4", true}, Case{"jacksboro", true}, Case{"cosc422", true},
                         Case{"lab4-canyon", true}, Case{"terrain-pom", true}, Case{"pn-triangles", false},
                         Case{"jacksboro-geomipmap", false}, Case{"thesis-constant-1", false, true}}) {
        const fs::path path = fs::path(TESSREF_DATA_DIR) / "scenes" / (std::string(c.name) + ".toml");
        tessref::Scene scene = tessref::load_scene(path.string());
        if (c.smooth) {
            scene.geometry = scene.geometry.value_or(tessref::GeometryStage{});
            scene.geometry->normals = tessref::GeometryNormals::smooth;
        }
        for (const tessref::Precision precision : {tessref::Precision::gpu, tessref::Precision::exact}) {
            for (const bool relative : {false, true}) {
                tessref::PipelineOptions options;
                options.precision = precision;
                options.camera_relative = relative;
                const tessref::PipelineResult result = tessref::run_pipeline(scene, options);
                for (const bool binary : {false, true}) {
                    const std::string what = std::string(c.name) + " " + std::string(tessref::to_string(precision)) +
                                             (relative ? " relative" : "") + (binary ? " binary" : " ascii");
                    MeshWriteOptions write_options;
                    write_options.binary = binary;
                    std::ostringstream whole;
                    std::stringstream streamed;
                    const tessref::MeshWriteReport a = tessref::write_mesh(result.mesh, whole, write_options);
                    const std::optional<tessref::MeshWriteReport> b =
                        tessref::write_pipeline_ply(scene, options, write_options, streamed);
                    const bool expected = c.streams && precision == tessref::Precision::gpu && !relative;
                    ASSERT_EQ(b.has_value(), expected) << what;
                    if (!b) continue;
                    EXPECT_TRUE(whole.str() == streamed.str()) << what;
                    EXPECT_EQ(a.emitted_vertices, b->emitted_vertices) << what;
                    EXPECT_EQ(a.vertices, b->vertices) << what;
                    EXPECT_EQ(a.triangles, b->triangles) << what;
                    EXPECT_EQ(a.degenerate_triangles, b->degenerate_triangles) << what;
                    EXPECT_EQ(a.float_distinct_vertices, b->float_distinct_vertices) << what;
                    EXPECT_EQ(a.float_degenerate_triangles, b->float_degenerate_triangles) << what;
                    EXPECT_EQ(a.largest_coordinate, b->largest_coordinate) << what;
                    EXPECT_EQ(a.float_spacing, b->float_spacing) << what;
                }
            }
        }
    }
}

namespace {

// Patch `patch` as a 3 x 3 grid of points from `corner`, one unit apart in x and y (its
// middle point the one interior point), at height z; its 8 triangles.
SurfaceMesh grid_patch(std::uint32_t patch, glm::dvec2 corner, double z = 0.0) {
    SurfaceMesh m;
    for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i) {
            m.positions.emplace_back(corner.x + i, corner.y + j, z + 0.25 * ((i + j) % 2));
            m.normals.emplace_back(0.0, 0.0, 1.0 + patch);
            m.patch_ids.push_back(patch);
            m.tess_coords.emplace_back(0.5f * float(i), 0.5f * float(j), 0.0f);
        }
    for (std::uint32_t j = 0; j < 2; ++j)
        for (std::uint32_t i = 0; i < 2; ++i) {
            const std::uint32_t v = 3 * j + i;
            m.triangles.push_back({v, v + 1, v + 4});
            m.triangles.push_back({v, v + 4, v + 3});
        }
    return m;
}

// The pieces concatenated: the whole surface that write_mesh() welds.
SurfaceMesh concatenated(const std::vector<SurfaceMesh>& pieces) {
    SurfaceMesh whole;
    for (const SurfaceMesh& piece : pieces) {
        const auto base = static_cast<std::uint32_t>(whole.positions.size());
        whole.positions.insert(whole.positions.end(), piece.positions.begin(), piece.positions.end());
        whole.normals.insert(whole.normals.end(), piece.normals.begin(), piece.normals.end());
        whole.patch_ids.insert(whole.patch_ids.end(), piece.patch_ids.begin(), piece.patch_ids.end());
        whole.tess_coords.insert(whole.tess_coords.end(), piece.tess_coords.begin(), piece.tess_coords.end());
        for (const auto& t : piece.triangles) whole.triangles.push_back({base + t[0], base + t[1], base + t[2]});
    }
    return whole;
}

// The pieces through a StreamedPlyWriter (nullopt: it gave up), and write_mesh()'s file of
// their concatenation in `expected`.
std::optional<std::string> stream_pieces(const std::vector<SurfaceMesh>& pieces, std::string& expected,
                                         bool binary = true) {
    const SurfaceMesh whole = concatenated(pieces);
    MeshWriteOptions options;
    options.binary = binary;
    std::ostringstream reference;
    tessref::write_mesh(whole, reference, options);
    expected = reference.str();
    std::stringstream out;
    tessref::StreamedPlyWriter writer(out, options, whole.positions.size(), whole.triangles.size());
    for (const SurfaceMesh& piece : pieces)
        if (!writer.add(piece)) return std::nullopt;
    const auto report = writer.finish([&whole](std::size_t first, std::span<std::array<std::uint32_t, 3>> out) {
        std::copy_n(whole.triangles.begin() + static_cast<std::ptrdiff_t>(first), out.size(), out.begin());
    });
    if (!report) return std::nullopt;
    return out.str();
}

}  // namespace

TEST(StreamedPlyWriter, NeighboursShareTheirEdgeAcrossPieces) {
    // Four patches in two pieces of two, a 2 x 2 grid: the edges they share are welded across
    // the pieces (the vertices on each patch box's surface are kept for later pieces).
    std::vector<SurfaceMesh> pieces(2);
    for (std::uint32_t p = 0; p < 4; ++p) {
        const SurfaceMesh patch = grid_patch(p, {2.0 * (p % 2), 2.0 * (p / 2)});
        pieces[p / 2] = concatenated({pieces[p / 2], patch});
    }
    std::string expected;
    const std::optional<std::string> file = stream_pieces(pieces, expected);
    ASSERT_TRUE(file.has_value());
    EXPECT_TRUE(*file == expected);
    EXPECT_NE(expected.find("element vertex 25\n"), std::string::npos);  // 36 copies, 25 points
    std::string ascii;
    const std::optional<std::string> ascii_file = stream_pieces(pieces, ascii, false);
    ASSERT_TRUE(ascii_file.has_value());
    EXPECT_TRUE(*ascii_file == ascii);
}

TEST(StreamedPlyWriter, AnInteriorPointALaterPatchMeetsIsNotStreamed) {
    // Patch 1, in a later piece, repeats patch 0's interior point (1, 1, 0.25): the streamed
    // weld no longer holds that point, so the writer must give up rather than write it twice.
    std::string expected;
    const SurfaceMesh later = grid_patch(1, {1.0, 1.0});  // its corner (1, 1, 0) ...
    SurfaceMesh first = grid_patch(0, {0.0, 0.0});
    first.positions[4] = {1.0, 1.0, 0.0};  // ... is patch 0's interior point (heights vary around it)
    first.positions[1].z = -1.0;
    first.positions[7].z = 1.0;
    EXPECT_FALSE(stream_pieces({first, later}, expected).has_value());
    // The other way round: an interior point of a later piece's patch repeats an earlier
    // patch's corner, which the streamed weld holds but an interior point does not look up.
    SurfaceMesh inner = first;
    for (std::uint32_t& patch : inner.patch_ids) patch = 1;
    EXPECT_FALSE(stream_pieces({grid_patch(0, {1.0, 1.0}), inner}, expected).has_value());
    // Within one piece the weld holds every point: the same patches stream, welded.
    const std::optional<std::string> one_piece = stream_pieces({concatenated({first, later})}, expected);
    ASSERT_TRUE(one_piece.has_value());
    EXPECT_TRUE(*one_piece == expected);
    // Apart, they stream (their boxes meet at patch 1's edge, not at patch 0's interior).
    const std::optional<std::string> apart = stream_pieces({first, grid_patch(1, {2.0, 0.0})}, expected);
    ASSERT_TRUE(apart.has_value());
    EXPECT_TRUE(*apart == expected);
}

TEST(StreamedPlyWriter, FewerDigitsThanTheBoundsAreNotStreamed) {
    // Two neighbours, 9 + 9 copies, weld into 15 vertices: the header's "element vertex 18"
    // became "15", of the same length, and the file streams. Two patches on the same 9
    // points (in one piece, where the weld holds every point) weld 18 copies into 9
    // vertices, a header shorter than the one the records were written after: the writer
    // gives up.
    std::string expected;
    const SurfaceMesh single = grid_patch(0, {0.0, 0.0});
    const SurfaceMesh twin = grid_patch(1, {0.0, 0.0});
    EXPECT_FALSE(stream_pieces({concatenated({single, twin})}, expected).has_value());
    EXPECT_NE(expected.find("element vertex 9\n"), std::string::npos);
    const std::optional<std::string> apart = stream_pieces({single, grid_patch(1, {2.0, 0.0})}, expected);
    ASSERT_TRUE(apart.has_value());
    EXPECT_TRUE(*apart == expected);
}

TEST(StreamedPlyWriter, PositionsThatAreNotFloatsAreNotStreamed) {
    std::string expected;
    SurfaceMesh patch = grid_patch(0, {0.0, 0.0});
    patch.positions[4].z = 0.1;  // not a float value: what float storage loses is measured over the whole
    EXPECT_FALSE(stream_pieces({patch}, expected).has_value());
    // Beyond float's range (write_mesh() refuses it, naming the vertex): not converted to
    // float to find out, which would be undefined.
    patch.positions[4].z = 1e300;
    std::stringstream out;
    tessref::StreamedPlyWriter writer(out, MeshWriteOptions{}, patch.positions.size(), patch.triangles.size());
    EXPECT_FALSE(writer.add(patch));
}

// A stream that takes `room` bytes and then fails, as a full disk does.
class FullAfter : public std::streambuf {
public:
    explicit FullAfter(std::size_t room) : room_(room) {}
    std::string taken;

protected:
    std::streamsize xsputn(const char* s, std::streamsize n) override {
        const auto fits = static_cast<std::streamsize>(std::min<std::size_t>(room_ - taken.size(), static_cast<std::size_t>(n)));
        taken.append(s, static_cast<std::size_t>(fits));
        return fits;
    }
    int_type overflow(int_type c) override {
        if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
        if (taken.size() >= room_) return traits_type::eof();
        taken.push_back(traits_type::to_char_type(c));
        return c;
    }
    pos_type seekoff(off_type, std::ios_base::seekdir, std::ios_base::openmode) override { return pos_type(off_type(-1)); }
    pos_type seekpos(pos_type, std::ios_base::openmode) override { return pos_type(off_type(-1)); }

private:
    std::size_t room_;
};

// The records are written on a thread of their own while the next pieces are welded: a
// write that fails there is the same Error as a failed write on the caller's thread, from
// the next add() or from finish(), whatever the moment of the failure; the file that
// fits streams as before. 200 patches, apart (no two share a point: the header written
// first has the final counts), so that most failures come while pieces are added.
TEST(StreamedPlyWriter, AWriteThatFailsIsAnErrorFromAddOrFinish) {
    std::vector<SurfaceMesh> pieces;
    for (std::uint32_t p = 0; p < 200; ++p) pieces.push_back(grid_patch(p, {3.0 * (p % 20), 3.0 * (p / 20)}));
    const SurfaceMesh whole = concatenated(pieces);
    MeshWriteOptions options;
    options.binary = true;
    std::ostringstream reference;
    tessref::write_mesh(whole, reference, options);
    const std::string expected = reference.str();
    const auto triangles = [&whole](std::size_t first, std::span<std::array<std::uint32_t, 3>> out) {
        std::copy_n(whole.triangles.begin() + static_cast<std::ptrdiff_t>(first), out.size(), out.begin());
    };
    ASSERT_NE(expected.find("element vertex 1800\n"), std::string::npos);
    for (const std::size_t room : {std::size_t(600), expected.size() / 3, expected.size() - 10}) {
        FullAfter full(room);
        std::ostream out(&full);
        tessref::StreamedPlyWriter writer(out, options, whole.positions.size(), whole.triangles.size());
        try {
            for (const SurfaceMesh& piece : pieces) ASSERT_TRUE(writer.add(piece));
            (void)writer.finish(triangles);
            ADD_FAILURE() << "no error with room for " << room << " of " << expected.size() << " bytes";
        } catch (const tessref::Error& e) {
            EXPECT_NE(std::string(e.what()).find("cannot write the mesh"), std::string::npos) << e.what();
        }
        EXPECT_TRUE(full.taken == expected.substr(0, room)) << room;  // in order, up to the failure
    }
}

TEST(StreamedExport, NonFiniteVertexIsTheSameErrorAsRunPipelines) {
    // tests/data/heightfield/huge_sample.toml: one texel that scale_z carries past the float range.
    const tessref::Scene scene =
        tessref::load_scene((fs::path(TESSREF_SOURCE_DIR) / "tests" / "data" / "heightfield" / "huge_sample.toml").string());
    ASSERT_TRUE(tessref::surface_streams(scene));
    std::string expected;
    try {
        tessref::run_pipeline(scene);
    } catch (const tessref::Error& e) {
        expected = e.what();
    }
    ASSERT_FALSE(expected.empty());
    try {
        tessref::run_pipeline_welded(scene);
        ADD_FAILURE() << "no error";
    } catch (const tessref::Error& e) {
        EXPECT_EQ(std::string(e.what()), expected);
    }
}

// ---------------------------------------------------------------------------------------
// Round trips through OpenMesh's readers

TEST_F(MeshExport, PlyHeaderListsTheExtraProperties) {
    for (bool binary : {false, true}) {
        const std::string header = ply_header(write(two_patch_mesh(), "m.ply", binary));
        EXPECT_NE(header.find(binary ? "format binary_little_endian 1.0" : "format ascii 1.0"),
                  std::string::npos);
        for (const char* line : {"element vertex 15\n", "property float x\n", "property float nx\n",
                                 "property float u\n", "property float v\n",
                                 "property int patch_id\n", "property float tess_u\n",
                                 "property float tess_v\n", "property float tess_w\n",
                                 "element face 16\n"}) {
            EXPECT_NE(header.find(line), std::string::npos) << line << " in\n" << header;
        }
    }
}

TEST_F(MeshExport, AsciiNumbersHaveNineSignificantDigits) {
    // float(1/3) = 0.333333343267..., float(0.1) = 0.100000001490..., float(1234.5678) =
    // 1234.56775: to 9 significant digits 0.333333343, 0.100000001, 1234.56775.
    const std::string ply = read_text(write(two_patch_mesh(), "m.ply", false));
    const std::string obj = read_text(write(two_patch_mesh(), "m.obj", false));
    const std::string off = read_text(write(two_patch_mesh(), "m.off", false));
    for (const std::string* text : {&ply, &obj, &off}) {
        EXPECT_NE(text->find(" 0.333333343"), std::string::npos);
        EXPECT_NE(text->find(" 0.100000001"), std::string::npos);
        EXPECT_NE(text->find(" 1234.56775"), std::string::npos);
        EXPECT_EQ(text->find("0.3333333433"), std::string::npos);  // not 10 digits
    }
}

// Reads `file` back with OpenMesh and checks vertices, faces and every attribute the
// format carries against the welded mesh. Positions (and normals, uvs) must come back as
// the nearest floats of what we wrote, bitwise, in ASCII as in binary.
void expect_round_trip(const SurfaceMesh& mesh, const fs::path& file, MeshFormat format, bool binary) {
    SCOPED_TRACE(file.string() + (binary ? " (binary)" : " (ascii)"));
    const tessref::WeldedMesh welded = tessref::weld_bitwise(mesh);
    const SurfaceMesh& w = welded.mesh;
    ReadMesh read;
    read.request_vertex_normals();
    read.request_vertex_texcoords2D();
    OpenMesh::IO::Options options = OpenMesh::IO::Options::VertexNormal | OpenMesh::IO::Options::VertexTexCoord |
                                    OpenMesh::IO::Options::Custom;
    if (binary) options += OpenMesh::IO::Options::Binary;
    ASSERT_TRUE(OpenMesh::IO::read_mesh(read, file.string(), options));
    ASSERT_EQ(read.n_faces(), w.triangles.size());
    ASSERT_EQ(read.n_vertices(), w.positions.size());

    if (format == MeshFormat::stl) {
        // STL stores corners per facet; OpenMesh's reader merges equal positions, in its own
        // order. Compare facet by facet, in order, by position.
        std::size_t f = 0;
        for (const auto fh : read.faces()) {
            std::vector<OpenMesh::Vec3f> corners;
            for (const auto vh : read.fv_range(fh)) corners.push_back(read.point(vh));
            ASSERT_EQ(corners.size(), 3u);
            // OpenMesh may start the face at another corner; rotate to match corner 0.
            const auto& t = w.triangles[f++];
            int start = -1;
            for (int k = 0; k < 3; ++k)
                if (bitwise_equal(corners[k], as_float(w.positions[t[0]]))) start = k;
            ASSERT_GE(start, 0);
            for (int k = 0; k < 3; ++k)
                EXPECT_TRUE(bitwise_equal(corners[(start + k) % 3], as_float(w.positions[t[k]])));
        }
        return;
    }

    for (std::size_t v = 0; v < w.positions.size(); ++v) {
        const ReadMesh::VertexHandle vh(static_cast<int>(v));
        EXPECT_TRUE(bitwise_equal(read.point(vh), as_float(w.positions[v]))) << "vertex " << v;
        EXPECT_TRUE(bitwise_equal(read.normal(vh), glm::vec3(w.normals[v]))) << "normal " << v;
        const auto uv = read.texcoord2D(vh);
        EXPECT_TRUE(bitwise_equal(uv[0], static_cast<float>(w.uvs[v].x)) &&
                    bitwise_equal(uv[1], static_cast<float>(w.uvs[v].y)))
            << "uv " << v << ": " << uv[0] << " " << uv[1];
    }
    std::size_t f = 0;
    for (const auto fh : read.faces()) {
        std::vector<std::uint32_t> corners;
        for (const auto vh : read.fv_range(fh)) corners.push_back(static_cast<std::uint32_t>(vh.idx()));
        const auto& t = w.triangles[f++];
        // Same triangle, same orientation (a rotation of the corners at most).
        const bool same = (corners == std::vector<std::uint32_t>{t[0], t[1], t[2]}) ||
                          (corners == std::vector<std::uint32_t>{t[1], t[2], t[0]}) ||
                          (corners == std::vector<std::uint32_t>{t[2], t[0], t[1]});
        EXPECT_TRUE(same) << "face " << f - 1;
    }
    if (format == MeshFormat::ply) {
        OpenMesh::VPropHandleT<int> patch_id;
        OpenMesh::VPropHandleT<float> tess_u, tess_v, tess_w;
        ASSERT_TRUE(read.get_property_handle(patch_id, "patch_id"));
        ASSERT_TRUE(read.get_property_handle(tess_u, "tess_u"));
        ASSERT_TRUE(read.get_property_handle(tess_v, "tess_v"));
        ASSERT_TRUE(read.get_property_handle(tess_w, "tess_w"));
        for (std::size_t v = 0; v < w.positions.size(); ++v) {
            const ReadMesh::VertexHandle vh(static_cast<int>(v));
            EXPECT_EQ(read.property(patch_id, vh), static_cast<int>(w.patch_ids[v]));
            EXPECT_TRUE(bitwise_equal(read.property(tess_u, vh), w.tess_coords[v].x));
            EXPECT_TRUE(bitwise_equal(read.property(tess_v, vh), w.tess_coords[v].y));
            EXPECT_TRUE(bitwise_equal(read.property(tess_w, vh), w.tess_coords[v].z));
        }
    }
}

TEST_F(MeshExport, RoundTripEveryFormat) {
    const SurfaceMesh mesh = two_patch_mesh();
    ASSERT_EQ(tessref::weld_bitwise(mesh).mesh.positions.size(), 15u);  // 18 - 3 shared
    for (MeshFormat format : {MeshFormat::ply, MeshFormat::obj, MeshFormat::off, MeshFormat::stl}) {
        for (bool binary : {false, true}) {
            if (binary && !tessref::mesh_format_has_binary(format)) continue;
            const std::string name = std::string(binary ? "b." : "a.") + std::string(tessref::to_string(format));
            expect_round_trip(mesh, write(mesh, name, binary), format, binary);
        }
    }
}

TEST_F(MeshExport, FloatExactPositionsReadBackBitwise) {
    // The gpu path: every position is a float, so the file holds it exactly.
    const SurfaceMesh mesh = two_patch_mesh();
    for (const char* name : {"a.ply", "a.obj", "a.off"}) {
        ReadMesh read;
        ASSERT_TRUE(OpenMesh::IO::read_mesh(read, write(mesh, name, false).string()));
        const SurfaceMesh& w = tessref::weld_bitwise(mesh).mesh;
        for (std::size_t v = 0; v < w.positions.size(); ++v) {
            const auto p = read.point(ReadMesh::VertexHandle(static_cast<int>(v)));
            EXPECT_EQ(glm::dvec3(p[0], p[1], p[2]), w.positions[v]) << name << " vertex " << v;
        }
    }
}

TEST_F(MeshExport, DoublePositionsAreWrittenAsTheirNearestFloats) {
    // The exact path through OpenMesh 9's float writers (documented in mesh.h).
    const SurfaceMesh mesh = two_patch_mesh_double();
    for (MeshFormat format : {MeshFormat::ply, MeshFormat::off, MeshFormat::stl}) {
        for (bool binary : {false, true}) {
            const std::string name = std::string(binary ? "b." : "a.") + std::string(tessref::to_string(format));
            expect_round_trip(mesh, write(mesh, name, binary), format, binary);
        }
    }
}

TEST_F(MeshExport, NonManifoldTrianglesAreWrittenAsTheyAre) {
    // Three triangles on one edge (a fin), which a half-edge mesh cannot hold: the file
    // still lists 5 vertices and the 3 triangles over them, as given.
    SurfaceMesh mesh;
    mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, {0.5, -1, 0}, {0.5, 0, 1}};
    mesh.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
    const fs::path file = path("fin.ply");
    {
        std::ofstream out(file, std::ios::binary);
        const tessref::MeshWriteReport report = tessref::write_mesh(mesh, out, MeshWriteOptions{});
        EXPECT_EQ(report.triangles, 3u);
        EXPECT_EQ(report.vertices, 5u);
    }
    const std::string text = read_text(file);
    EXPECT_NE(text.find("element vertex 5\n"), std::string::npos);
    EXPECT_NE(text.find("element face 3\n"), std::string::npos);
    const std::string faces = text.substr(text.size() - std::string("3 0 1 2\n3 1 0 3\n3 0 1 4\n").size());
    EXPECT_EQ(faces, "3 0 1 2\n3 1 0 3\n3 0 1 4\n");
}

TEST_F(MeshExport, MeshWithoutOptionalAttributes) {
    SurfaceMesh mesh;
    mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    mesh.triangles = {{0, 1, 2}};
    const std::string header = ply_header(write(mesh, "m.ply", false));
    EXPECT_EQ(header.find("nx"), std::string::npos);
    EXPECT_EQ(header.find("patch_id"), std::string::npos);
    ReadMesh read;
    ASSERT_TRUE(OpenMesh::IO::read_mesh(read, write(mesh, "m.obj", false).string()));
    EXPECT_EQ(read.n_faces(), 1u);
}

TEST_F(MeshExport, FloatStorageLossIsMeasured) {
    // Two quads' worth of double vertices at y = 9.1e6, where floats are 1 apart
    // (2^23 <= 9.1e6 < 2^24): y + 0.25 rounds back to y, so the four distinct vertices fall
    // on two float points and both triangles lose their area in the file.
    SurfaceMesh far;
    far.positions = {{0, 9.1e6, 0}, {1, 9.1e6, 0}, {0, 9.1e6 + 0.25, 0}, {1, 9.1e6 + 0.25, 0}};
    far.triangles = {{0, 1, 2}, {1, 3, 2}};
    std::ostringstream out;
    const tessref::MeshWriteReport report = tessref::write_mesh(far, out, MeshWriteOptions{});
    EXPECT_EQ(report.vertices, 4u);
    EXPECT_EQ(report.float_distinct_vertices, 2u);
    EXPECT_EQ(report.float_degenerate_triangles, 2u);
    EXPECT_EQ(report.largest_coordinate, 9.1e6 + 0.25);
    EXPECT_EQ(report.float_spacing, 1.0);
    const std::string warning = report.precision_warning();
    EXPECT_EQ(warning.find('\n'), std::string::npos);
    EXPECT_NE(warning.find("the 4 distinct vertices fall on 2 points"), std::string::npos) << warning;
    EXPECT_NE(warning.find("2 of 2 triangles"), std::string::npos) << warning;
    EXPECT_NE(warning.find("largest coordinate 9100000.25, float spacing there 1)"), std::string::npos) << warning;

    // Collinear in float though no two corners coincide: (0, Y), (1, Y + 0.25), (2, Y) with
    // Y = 9.1e6 flattens to one line.
    SurfaceMesh sliver;
    sliver.positions = {{0, 9.1e6, 0}, {2, 9.1e6, 0}, {1, 9.1e6 + 0.25, 0}};
    sliver.triangles = {{0, 1, 2}};
    const tessref::MeshWriteReport flat = tessref::write_mesh(sliver, out, MeshWriteOptions{});
    EXPECT_EQ(flat.float_distinct_vertices, 3u);
    EXPECT_EQ(flat.float_degenerate_triangles, 1u);
    EXPECT_FALSE(flat.precision_warning().empty());

    // Float-exact positions (what gpu precision produces) lose nothing: no warning.
    const tessref::MeshWriteReport exact = tessref::write_mesh(two_patch_mesh(), out, MeshWriteOptions{});
    EXPECT_EQ(exact.float_distinct_vertices, exact.vertices);
    EXPECT_EQ(exact.float_degenerate_triangles, 0u);
    EXPECT_EQ(exact.precision_warning(), "");
    // Nor do doubles near the origin whose float roundings stay apart and keep their area.
    EXPECT_EQ(tessref::write_mesh(two_patch_mesh_double(), out, MeshWriteOptions{}).precision_warning(), "");
}

TEST_F(MeshExport, PositionsAFileCannotHoldAreErrors) {
    // Files store 32-bit floats: 1e39 would be written as inf, NaN as nan.
    for (const double bad : {1e39, -1e39, std::numeric_limits<double>::infinity(), std::nan("")}) {
        SCOPED_TRACE(bad);
        SurfaceMesh mesh;
        mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, bad}};
        mesh.triangles = {{0, 1, 2}};
        mesh.patch_ids = {3, 3, 3};
        mesh.tess_coords = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
        std::ostringstream out;
        try {
            tessref::write_mesh(mesh, out, MeshWriteOptions{});
            ADD_FAILURE() << "written";
        } catch (const tessref::Error& e) {
            const std::string what = e.what();
            EXPECT_EQ(e.where().patch_id, 3);
            EXPECT_NE(what.find("at tess coord (0, 1, 0)"), std::string::npos) << what;
            EXPECT_NE(what.find(std::isfinite(bad) ? "beyond the 32-bit float range" : "is not finite"),
                      std::string::npos) << what;
        }
    }
}

// ---------------------------------------------------------------------------------------
// Every shipped terrain scene: one boundary loop, the outline; no T-junction

std::vector<std::string> shipped_scenes() {
    std::vector<std::string> names;
    const fs::path dir = fs::path(TESSREF_DATA_DIR) / "scenes";
    if (!fs::is_directory(dir)) return names;
    for (const auto& entry : fs::directory_iterator(dir)) {
        // Terrains only: the outline property means nothing for closed PN meshes.
        if (entry.path().extension() == ".toml" && tessref::load_scene(entry.path().string()).grid)
            names.push_back(entry.path().stem().string());
    }
    std::sort(names.begin(), names.end());
    return names;
}

class ShippedScene : public ::testing::TestWithParam<std::string> {};

TEST_P(ShippedScene, TerrainExportHasOneBoundaryLoopTheOutlineAndNoTJunction) {
    const fs::path path = fs::path(TESSREF_DATA_DIR) / "scenes" / (GetParam() + ".toml");
    const tessref::Scene scene = tessref::load_scene(path.string());
    ASSERT_TRUE(scene.grid) << GetParam() << " is not a terrain";
    for (const tessref::Precision precision : {tessref::Precision::gpu, tessref::Precision::exact}) {
        SCOPED_TRACE(std::string(tessref::to_string(precision)) + " precision");
        tessref::PipelineOptions options;
        options.precision = precision;
        const tessref::PipelineResult result = tessref::run_pipeline(scene, options);
        ASSERT_FALSE(result.mesh.triangles.empty());
        const tessref::WeldedMesh welded = tessref::weld_bitwise(result.mesh);
        EXPECT_EQ(welded.degenerate_triangles, 0u);
        const EdgeReport edges = analyse_edges(welded.mesh);
        SCOPED_TRACE(::testing::PrintToString(edges));
        // A patch the control stage culls (an outer level NaN or <= 0, which GL discards)
        // leaves a hole: say so, since it is the likeliest cause of a second loop.
        std::size_t culled = 0;
        std::string culled_example;
        for (std::size_t p = 0; p < result.levels.size(); ++p) {
            const auto& outer = result.levels[p].outer;
            if (std::none_of(outer.begin(), outer.end(), [](float level) { return !(level > 0.0f); })) continue;
            if (culled++ == 0) {
                culled_example = "e.g. patch " + std::to_string(p) + ": outer " + std::to_string(outer[0]) +
                                 " " + std::to_string(outer[1]) + " " + std::to_string(outer[2]) + " " +
                                 std::to_string(outer[3]);
            }
        }
        SCOPED_TRACE(std::to_string(culled) + " of " + std::to_string(result.levels.size()) +
                     " patches culled by their levels " + culled_example);
        EXPECT_EQ(edges.boundary_loops, 1u);
        EXPECT_EQ(edges.off_outline_vertices, 0u);
        EXPECT_EQ(edges.t_junctions, 0u);
        EXPECT_EQ(edges.pinched_vertices, 0u);
        EXPECT_EQ(edges.nonmanifold_edges, 0u);
        EXPECT_EQ(edges.misoriented_edges, 0u);
        // The export writes exactly that mesh; the shipped scenes lie near the origin, so an
        // exact run's floats keep every vertex and every triangle's area (no warning).
        std::ostringstream out;
        MeshWriteOptions write_options;
        write_options.binary = true;
        const tessref::MeshWriteReport report = tessref::write_mesh(result.mesh, out, write_options);
        EXPECT_EQ(report.triangles, welded.mesh.triangles.size());
        EXPECT_EQ(report.vertices, welded.mesh.positions.size());
        EXPECT_EQ(report.precision_warning(), "");
    }
}

INSTANTIATE_TEST_SUITE_P(Data, ShippedScene, ::testing::ValuesIn(shipped_scenes()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                             std::string name = info.param;
                             for (char& c : name)
                                 if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                             return name;
                         });

// The parameterized test above must not pass vacuously: every shipped terrain is in it.
TEST(ShippedScenes, EveryTerrainSceneIsExercised) { EXPECT_GE(shipped_scenes().size(), 13u); }

// ---------------------------------------------------------------------------------------
// The command: tessref mesh

using tessref::test::run_program;
using tessref::test::RunResult;
using tessref::test::shell_quote;

class MeshCommand : public MeshExport {
protected:
    // Runs `tessref mesh ARGS`; the output is captured outside dir_, which files() lists.
    RunResult run(const std::vector<std::string>& args) const {
        std::vector<std::string> command{"mesh"};
        command.insert(command.end(), args.begin(), args.end());
        const fs::path capture = fs::temp_directory_path() / ("tessref-test-mesh-captured-" + std::to_string(::getpid()));
        fs::create_directories(capture);
        RunResult result = run_program(TESSREF_EXE, command, capture);
        fs::remove_all(capture);
        return result;
    }
    std::set<std::string> files() const {
        std::set<std::string> names;
        for (const auto& entry : fs::directory_iterator(dir_)) names.insert(entry.path().filename().string());
        return names;
    }
    static std::string scene(const std::string& name) {
        return (fs::path(TESSREF_DATA_DIR) / "scenes" / (name + ".toml")).string();
    }
};

TEST_F(MeshCommand, WritesTheSceneInEveryFormat) {
    // thesis-constant-1: 16 x 16 patches at level 1, two triangles each, on a 17 x 17 grid
    // of corners: 289 welded vertices, 512 triangles.
    for (const char* name : {"t.ply", "t.obj", "t.off", "t.stl"}) {
        for (bool binary : {false, true}) {
            if (binary && std::string(name) == "t.obj") continue;
            std::vector<std::string> args{scene("thesis-constant-1"), "-o", path(name).string()};
            if (binary) args.push_back("--binary");
            const RunResult result = run(args);
            ASSERT_EQ(result.status, 0) << result.err;
            EXPECT_EQ(files(), std::set<std::string>{name});
            ReadMesh read;
            ASSERT_TRUE(OpenMesh::IO::read_mesh(read, path(name).string()));
            EXPECT_EQ(read.n_vertices(), 289u) << name;
            EXPECT_EQ(read.n_faces(), 512u) << name;
            fs::remove(path(name));
        }
    }
}

TEST_F(MeshCommand, PrecisionsAgreeOnTopology) {
    ASSERT_EQ(run({scene("thesis-constant-1"), "-o", path("g.ply").string(), "--binary"}).status, 0);
    ASSERT_EQ(run({scene("thesis-constant-1"), "-o", path("e.ply").string(), "--binary",
                   "--precision", "exact", "--threads", "1"}).status, 0);
    ReadMesh gpu, exact;
    ASSERT_TRUE(OpenMesh::IO::read_mesh(gpu, path("g.ply").string()));
    ASSERT_TRUE(OpenMesh::IO::read_mesh(exact, path("e.ply").string()));
    EXPECT_EQ(gpu.n_vertices(), exact.n_vertices());
    EXPECT_EQ(gpu.n_faces(), exact.n_faces());
}

TEST_F(MeshCommand, OutputIsTheSameWhateverTheThreadCount) {
    for (const char* precision : {"gpu", "exact"}) {
        ASSERT_EQ(run({scene("cosc422"), "-o", path("one.ply").string(), "--threads", "1", "--precision", precision}).status, 0);
        ASSERT_EQ(run({scene("cosc422"), "-o", path("many.ply").string(), "--threads", "4", "--precision", precision}).status, 0);
        const std::string one = read_text(path("one.ply"));
        EXPECT_FALSE(one.empty());
        EXPECT_EQ(one, read_text(path("many.ply"))) << precision;
    }
}

// --math llvmpipe: the summary says which math ran; exact, the default, adds nothing to it.
TEST_F(MeshCommand, MathModeIsNamedInTheSummaryWhenItIsLlvmpipe) {
    const RunResult exact = run({scene("thesis-all-10"), "-o", path("e.ply").string()});
    ASSERT_EQ(exact.status, 0) << exact.err;
    EXPECT_NE(exact.out.find(": ply ascii, gpu precision, 256 patches"), std::string::npos) << exact.out;
    const RunResult llvmpipe = run({scene("thesis-all-10"), "-o", path("l.ply").string(), "--math", "llvmpipe"});
    ASSERT_EQ(llvmpipe.status, 0) << llvmpipe.err;
    EXPECT_NE(llvmpipe.out.find(": ply ascii, gpu precision, llvmpipe math, 256 patches"), std::string::npos)
        << llvmpipe.out;
    // The acos of the normal factor moves some levels, and with them the surface.
    EXPECT_NE(read_text(path("e.ply")), read_text(path("l.ply")));
}

TEST_F(MeshCommand, BadOutputIsAnErrorBeforeAnythingIsWritten) {
    const std::string good = scene("thesis-constant-1");
    struct Case {
        std::vector<std::string> args;
        const char* message;
    };
    const std::vector<Case> cases{
        {{good, "-o", path("t.vtk").string()}, "unknown mesh format"},
        {{good, "-o", path("t").string()}, "no extension"},
        {{good, "-o", (dir_ / "missing" / "t.ply").string()}, "cannot create output file"},
        {{good, "-o", path("t.obj").string(), "--binary"}, "no binary form"},
        {{good, "-o", path("t.ply").string(), "--precision", "half"}, "unknown precision"},
        {{good, "-o", path("t.ply").string(), "--math", "fast"}, "unknown math mode 'fast'; expected exact or llvmpipe (--math)"},
        {{(dir_ / "missing.toml").string(), "-o", path("t.ply").string()}, ""},
    };
    for (const Case& c : cases) {
        const RunResult result = run(c.args);
        EXPECT_EQ(result.status, 2) << c.args[2];
        EXPECT_EQ(result.err.rfind("tessref: error: ", 0), 0u) << result.err;
        EXPECT_NE(result.err.find(c.message), std::string::npos) << result.err;
        EXPECT_TRUE(files().empty()) << c.args[2];  // no output, no temporary file
    }
}

std::string heightfield_data(const std::string& name) {
    return (fs::path(TESSREF_SOURCE_DIR) / "tests" / "data" / "heightfield" / name).string();
}

std::size_t count_lines(const std::string& text, const std::string& prefix) {
    std::size_t n = 0;
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);) n += line.rfind(prefix, 0) == 0;
    return n;
}

TEST_F(MeshCommand, ExactRunFarFromTheOriginWarnsWhatFloatStorageLoses) {
    // tests/data/heightfield/far_from_origin.toml: 16 x 16 quads of 0.25 at y = 9100000 +
    // 0.25 j (j = 0..16), where floats are 1 apart. Rounded to nearest-even the 17 rows land
    // on 5 float rows (j 0-2, 3-5, 6-10, 11-13, 14-16): 5 x 17 = 85 points; only the bands
    // j = 2-3, 5-6, 10-11, 13-14 keep their area, 4 x 32 of the 512 triangles.
    const std::string far = heightfield_data("far_from_origin.toml");
    const RunResult exact = run({far, "-o", path("e.ply").string(), "--precision", "exact"});
    ASSERT_EQ(exact.status, 0) << exact.err;
    EXPECT_EQ(count_lines(exact.err, "tessref: warning: "), 1u) << exact.err;
    EXPECT_NE(exact.err.find("the 289 distinct vertices fall on 85 points and 384 of 512 triangles"),
              std::string::npos) << exact.err;
    EXPECT_NE(exact.err.find("largest coordinate 9100004, float spacing there 1)"), std::string::npos) << exact.err;
    // gpu precision computes in float: the collapse happens in the pipeline, and the export
    // says so by leaving out the triangles whose corners weld (nothing is lost in storage).
    const RunResult gpu = run({far, "-o", path("g.ply").string()});
    ASSERT_EQ(gpu.status, 0) << gpu.err;
    EXPECT_EQ(gpu.err.find("32-bit floats"), std::string::npos) << gpu.err;
    EXPECT_NE(gpu.err.find("384 triangles whose corners weld together"), std::string::npos) << gpu.err;
}

TEST_F(MeshCommand, NonFiniteHeightIsAnErrorNamingPatchTessCoordAndTexel) {
    // tests/data/heightfield/huge_sample.toml: one texel of 3e38, scale_z = 10. The PFM's
    // stored row 1 (from the bottom) of 4 is texel row 2 top-first: texel (1, 2).
    const std::string scene_file = heightfield_data("huge_sample.toml");
    const RunResult gpu = run({scene_file, "-o", path("g.ply").string()});
    EXPECT_EQ(gpu.status, 2);
    EXPECT_EQ(gpu.err.rfind("tessref: error: patch ", 0), 0u) << gpu.err;
    for (const char* part : {"non-finite vertex", "inf)", "at tess coord (", "gpu (float) precision",
                             "texels up to (1, 2) = 3.00000001e+38", "huge_sample.pfm", "domain.scale_z = 10",
                             "key domain.heightmap, patch "})
        EXPECT_NE(gpu.err.find(part), std::string::npos) << part << " in " << gpu.err;
    // Exact precision holds 7.5e38 in double, which no mesh file (32-bit floats) can.
    const RunResult exact = run({scene_file, "-o", path("e.ply").string(), "--precision", "exact"});
    EXPECT_EQ(exact.status, 2);
    EXPECT_NE(exact.err.find("beyond the 32-bit float range"), std::string::npos) << exact.err;
    EXPECT_NE(exact.err.find("at tess coord ("), std::string::npos) << exact.err;
    EXPECT_TRUE(files().empty());
    // The pipeline itself refuses (so render and check get no infinite vertex either).
    const tessref::Scene scene = tessref::load_scene(scene_file);
    try {
        tessref::run_pipeline(scene);
        ADD_FAILURE() << "no error";
    } catch (const tessref::Error& e) {
        EXPECT_GE(e.where().patch_id, 0);
        EXPECT_EQ(e.where().key, "domain.heightmap");
    }
}

TEST_F(MeshCommand, StreamedAndWholeSurfaceFilesAreTheSame) {
    // Without --capture the surface is welded as it is evaluated (run_pipeline_welded); with
    // it, the pipeline's whole surface is kept for the capture and welded at export.
    for (const char* name : {"jacksboro", "pn-triangles"}) {
        for (const bool binary : {false, true}) {
            std::vector<std::string> streamed{scene(name), "-o", path("s.ply").string()};
            std::vector<std::string> whole{scene(name), "-o", path("w.ply").string(), "--capture",
                                           path("c.txt").string()};
            if (binary) streamed.push_back("--binary"), whole.push_back("--binary");
            const RunResult a = run(streamed), b = run(whole);
            ASSERT_EQ(a.status, 0) << a.err;
            ASSERT_EQ(b.status, 0) << b.err;
            const std::string s = read_text(path("s.ply"));
            EXPECT_FALSE(s.empty());
            EXPECT_TRUE(s == read_text(path("w.ply"))) << name << (binary ? " binary" : " ascii");
            EXPECT_EQ(files(), (std::set<std::string>{"c.txt", "s.ply", "w.ply"}));
            for (const char* file : {"s.ply", "w.ply", "c.txt"}) fs::remove(path(file));
        }
    }
}

TEST_F(MeshCommand, AFailedRunLeavesAnExistingOutputAsItWas) {
    {
        std::ofstream old(path("t.ply"));
        old << "old";
    }
    const RunResult result = run({(dir_ / "missing.toml").string(), "-o", path("t.ply").string()});
    EXPECT_EQ(result.status, 2);
    EXPECT_EQ(read_text(path("t.ply")), "old");
    EXPECT_EQ(files(), std::set<std::string>{"t.ply"});
}

}  // namespace

// `tessref mesh --solid`: every shipped terrain closes into a watertight solid that
// `tessref check --expect closed` passes; independently of check, the file is a closed
// genus-0 triangle surface, so Euler's formula gives F = 2V - 4.
TEST_F(MeshCommand, SolidOfEveryShippedTerrainIsClosed) {
    for (const std::string& name : shipped_scenes()) {
        SCOPED_TRACE(name);
        const fs::path out = path(name + "-solid.ply");
        const RunResult made = run({scene(name), "--solid", "--binary", "-o", out.string()});
        ASSERT_EQ(made.status, 0) << made.err;
        ReadMesh read;
        ASSERT_TRUE(OpenMesh::IO::read_mesh(read, out.string()));
        EXPECT_EQ(read.n_faces(), 2 * read.n_vertices() - 4);
        const std::string check = shell_quote(TESSREF_EXE) + " check " + shell_quote(out.string()) +
                                  " --expect closed >/dev/null 2>&1";
        const int raw = std::system(check.c_str());
        EXPECT_TRUE(WIFEXITED(raw) && WEXITSTATUS(raw) == 0) << "tessref check --expect closed failed";
        fs::remove(out);
    }
}

TEST_F(MeshCommand, SolidRefusesMeshScenesAndABaseAboveTheTerrain) {
    const RunResult pn = run({scene("pn-triangles"), "--solid", "-o", path("pn.ply").string()});
    EXPECT_EQ(pn.status, 2);
    EXPECT_NE(pn.err.find("tessref: error:"), std::string::npos);
    const RunResult high = run({scene("thesis-constant-1"), "--solid", "--base", "1e9", "-o", path("h.ply").string()});
    EXPECT_EQ(high.status, 2);
    EXPECT_NE(high.err.find("--base"), std::string::npos);
    EXPECT_TRUE(files().empty());
}
