// Tests of `tessref check` and the check library (include/tessref/check.h, solid.h).
//
// The contract, and where each expectation comes from:
//  - the corpus tests/data/check/ (made by make_corpus.py, each file's defect stated in
//    that script): every defect is found in its class, at the place the script put it;
//    clean meshes pass;
//  - meshes built here by code: a grid terrain (counts of an N x N vertex grid: V = N^2,
//    F = 2 (N-1)^2, E = 3 (N-1)^2 + 2 (N-1), 4 (N-1) boundary edges, Euler characteristic
//    1), an icosphere (V - E + F = 2, E = 3F/2, its volume between the balls it contains
//    and is contained in), two patches with mismatched outer levels (the T-junctions sit
//    where the finer patch has vertices the coarser lacks; the crack's width is a
//    point-to-line distance worked out by hand);
//  - solids closed from terrains: their volume is the sum of the prisms under the
//    terrain's triangles (area seen from above times mean height above the base), a
//    formula the check does not use;
//  - admesh, an independent STL checker (Debian package), reads every corpus STL and must
//    agree on the facet count, on closed versus open, and on whether there is a defect;
//  - the command: exit 0 / 1 / 2, `tessref: error:` naming the file, JSON, the picture.
#include <gtest/gtest.h>

#include "run_program.h"
#include "scratch_dir.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

#include <OpenImageIO/imagebuf.h>
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include "check/check_internal.h"
#include "tessref/check.h"
#include "tessref/error.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"
#include "tessref/solid.h"

namespace fs = std::filesystem;
using tessref::CheckOptions;
using tessref::CheckReport;
using tessref::DefectClass;
using tessref::Expect;
using tessref::IndexedMesh;
using tessref::SurfaceMesh;

namespace {

const fs::path corpus_dir = fs::path(TESSREF_SOURCE_DIR) / "tests" / "data" / "check";

fs::path corpus(const std::string& name) { return corpus_dir / name; }

CheckOptions quick(Expect expect = Expect::automatic) {
    CheckOptions options;
    options.expect = expect;
    options.probe_resolution = 96;
    return options;
}

CheckReport check_file(const std::string& name, CheckOptions options = quick()) {
    return tessref::check_mesh(tessref::read_mesh_for_check(corpus(name).string()), options);
}

bool near(const glm::dvec3& a, const glm::dvec3& b, double eps = 1e-6) { return glm::distance(a, b) <= eps; }

std::set<std::uint32_t> as_set(const std::vector<std::uint32_t>& ids) { return {ids.begin(), ids.end()}; }

// The classes with a nonzero count.
std::set<DefectClass> failing_classes(const CheckReport& r) {
    std::set<DefectClass> out;
    for (const auto& d : r.defects)
        if (d.count > 0) out.insert(d.kind);
    return out;
}

bool is_probe(DefectClass k) {
    return k == DefectClass::probe_miss || k == DefectClass::probe_odd_parity || k == DefectClass::probe_escape;
}

// The id of the vertex at position p (the corpus welds positions, so there is one).
std::uint32_t vertex_at(const IndexedMesh& mesh, const glm::dvec3& p) {
    for (std::uint32_t v = 0; v < mesh.vertex_count(); ++v)
        if (near(mesh.positions[v], p, 1e-9)) return v;
    ADD_FAILURE() << "no vertex at " << p.x << " " << p.y << " " << p.z;
    return 0;
}

// ---------------------------------------------------------------------------------------
// Meshes made by code

// A terrain of patches x patches patches, each cells x cells quads, emitted patch by patch
// with every patch's own copy of its border vertices (as the pipeline emits them); the
// copies are computed from the same global grid index, so they are bitwise equal.
SurfaceMesh grid_terrain(int patches, int cells, double (*height)(double, double), int up_axis = 2) {
    SurfaceMesh mesh;
    const int n = patches * cells;
    const int u = (up_axis + 1) % 3, w = (up_axis + 2) % 3;
    for (int pj = 0; pj < patches; ++pj)
        for (int pi = 0; pi < patches; ++pi) {
            const auto base = static_cast<std::uint32_t>(mesh.positions.size());
            for (int j = 0; j <= cells; ++j)
                for (int i = 0; i <= cells; ++i) {
                    const double x = 10.0 * (pi * cells + i) / n, y = 10.0 * (pj * cells + j) / n;
                    glm::dvec3 p(0.0);
                    p[u] = x;
                    p[w] = y;
                    p[up_axis] = height(x, y);
                    mesh.positions.push_back(p);
                    mesh.patch_ids.push_back(static_cast<std::uint32_t>(pj * patches + pi));
                    mesh.tess_coords.emplace_back(float(i) / cells, float(j) / cells, 0.0f);
                }
            for (int j = 0; j < cells; ++j)
                for (int i = 0; i < cells; ++i) {
                    const std::uint32_t a = base + j * (cells + 1) + i, b = a + 1, c = b + cells + 1, d = a + cells + 1;
                    mesh.triangles.push_back({a, b, c});
                    mesh.triangles.push_back({a, c, d});
                }
        }
    return mesh;
}

double hills(double x, double y) { return 1.0 + 0.4 * std::sin(0.8 * x) * std::cos(0.6 * y) + 0.05 * x; }
double flat(double, double) { return 0.0; }

// Two patches side by side, [0,1]^2 and [1,2] x [0,1], with `left_segments` and
// `right_segments` quads along y (each one quad wide along x), on z = height(x, y).
SurfaceMesh two_patches(int left_segments, int right_segments, double (*height)(double, double)) {
    SurfaceMesh mesh;
    for (int patch = 0; patch < 2; ++patch) {
        const int segments = patch == 0 ? left_segments : right_segments;
        const auto base = static_cast<std::uint32_t>(mesh.positions.size());
        for (int j = 0; j <= segments; ++j)
            for (int i = 0; i <= 1; ++i) {
                const double x = patch + i, y = double(j) / segments;
                mesh.positions.emplace_back(x, y, height(x, y));
                mesh.patch_ids.push_back(static_cast<std::uint32_t>(patch));
            }
        for (int j = 0; j < segments; ++j) {
            const std::uint32_t a = base + 2 * j, b = a + 1, c = a + 3, d = a + 2;
            mesh.triangles.push_back({a, b, c});
            mesh.triangles.push_back({a, c, d});
        }
    }
    return mesh;
}

double bowl(double, double y) { return 0.2 * y * y; }

// An icosphere: the icosahedron, each triangle split in four `levels` times, pushed onto
// the unit sphere.
IndexedMesh icosphere(int levels) {
    const double t = (1.0 + std::sqrt(5.0)) / 2.0;
    std::vector<glm::dvec3> p = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                                 {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    for (auto& v : p) v = glm::normalize(v);
    std::vector<std::array<std::uint32_t, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                                   {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                                   {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                                   {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    for (int l = 0; l < levels; ++l) {
        std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> middle;
        auto mid = [&](std::uint32_t a, std::uint32_t b) {
            const auto key = std::minmax(a, b);
            auto [it, inserted] = middle.try_emplace({key.first, key.second}, static_cast<std::uint32_t>(p.size()));
            if (inserted) p.push_back(glm::normalize(p[a] + p[b]));
            return it->second;
        };
        std::vector<std::array<std::uint32_t, 3>> next;
        for (const auto& tri : f) {
            const std::uint32_t ab = mid(tri[0], tri[1]), bc = mid(tri[1], tri[2]), ca = mid(tri[2], tri[0]);
            next.push_back({tri[0], ab, ca});
            next.push_back({tri[1], bc, ab});
            next.push_back({tri[2], ca, bc});
            next.push_back({ab, bc, ca});
        }
        f = std::move(next);
    }
    IndexedMesh mesh;
    mesh.positions = p;
    for (const auto& tri : f) mesh.add_triangle(tri[0], tri[1], tri[2]);
    return mesh;
}

// Volume under a terrain's triangles down to the plane `base` along up: the sum of the
// prisms (area seen from above times mean height above the base), exact for flat triangles.
double prism_volume(const SurfaceMesh& terrain, double base, int up_axis) {
    const int u = (up_axis + 1) % 3, w = (up_axis + 2) % 3;
    double volume = 0.0;
    for (const auto& t : terrain.triangles) {
        const glm::dvec3 &a = terrain.positions[t[0]], &b = terrain.positions[t[1]], &c = terrain.positions[t[2]];
        const double area = 0.5 * ((b[u] - a[u]) * (c[w] - a[w]) - (b[w] - a[w]) * (c[u] - a[u]));
        volume += area * ((a[up_axis] + b[up_axis] + c[up_axis]) / 3.0 - base);
    }
    return volume;
}

// ---------------------------------------------------------------------------------------
// Running programs

using tessref::test::read_file;
using tessref::test::run_program;
using tessref::test::RunResult;
using tessref::test::shell_quote;

const tessref::test::ScratchDir& scratch_dir = tessref::test::ScratchDir::add("check");

RunResult run(const std::string& program, const std::vector<std::string>& args) {
    return run_program(program, args, scratch_dir());
}

RunResult tessref_check(std::vector<std::string> args) {
    args.insert(args.begin(), "check");
    return run(TESSREF_EXE, args);
}

}  // namespace

// ---------------------------------------------------------------------------------------
// Clean meshes pass

TEST(CheckClean, CubeInEveryFormatPasses) {
    for (const char* name : {"cube.off", "cube.obj", "cube.ply", "cube_binary.ply", "cube.stl", "cube_binary.stl"}) {
        SCOPED_TRACE(name);
        const CheckReport r = check_file(name);
        EXPECT_TRUE(r.passed) << tessref::report_text(r);
        EXPECT_EQ(r.vertex_count, 8u);
        EXPECT_EQ(r.face_count, 12u);
        EXPECT_EQ(r.edge_count, 18u);
        EXPECT_TRUE(r.closed);
        EXPECT_TRUE(r.manifold);
        EXPECT_EQ(r.euler_characteristic, 2);
        EXPECT_NEAR(r.signed_volume, 1.0, 1e-12);  // the unit cube
        EXPECT_NEAR(r.surface_area, 6.0, 1e-12);
        EXPECT_EQ(r.judged_as, "closed");
        EXPECT_EQ(r.probe.mode, "closed");
        EXPECT_GT(r.probe.rays, 0u);
        EXPECT_EQ(r.probe.failed_rays, 0u);
    }
}

TEST(CheckClean, CubeOfQuadsPasses) {
    const CheckReport r = check_file("cube_quads.obj");
    EXPECT_TRUE(r.passed) << tessref::report_text(r);
    EXPECT_EQ(r.face_count, 6u);
    EXPECT_EQ(r.triangle_count, 12u);
    EXPECT_EQ(r.edge_count, 12u);  // a cube's edges: the quads have no diagonals
    EXPECT_EQ(r.euler_characteristic, 2);
    EXPECT_NEAR(r.signed_volume, 1.0, 1e-12);
}

TEST(CheckClean, IcospherePasses) {
    const IndexedMesh sphere = icosphere(3);
    const CheckReport r = tessref::check_mesh(sphere, quick());
    EXPECT_TRUE(r.passed) << tessref::report_text(r);
    EXPECT_EQ(r.face_count, 1280u);
    EXPECT_EQ(r.edge_count, 1920u);  // 3F/2
    EXPECT_EQ(r.vertex_count, 642u);
    EXPECT_EQ(r.euler_characteristic, 2);
    // Inscribed in the unit sphere, and containing the ball of its smallest face distance.
    double inner = 1.0;
    for (std::size_t f = 0; f < sphere.face_count(); ++f) {
        const auto t = sphere.face(f);
        const glm::dvec3 a = sphere.positions[t[0]], b = sphere.positions[t[1]], c = sphere.positions[t[2]];
        inner = std::min(inner, std::abs(glm::dot(glm::normalize(glm::cross(b - a, c - a)), a)));
    }
    const double ball = 4.0 / 3.0 * M_PI;
    EXPECT_LT(r.signed_volume, ball);
    EXPECT_GT(r.signed_volume, ball * inner * inner * inner);
}

TEST(CheckClean, TerrainFromPatchesPassesAsOpen) {
    const SurfaceMesh terrain = grid_terrain(4, 5, hills);
    const CheckReport r = tessref::check_mesh(tessref::indexed_mesh_from(terrain), quick());
    EXPECT_TRUE(r.passed) << tessref::report_text(r);
    const std::size_t n = 4 * 5 + 1;  // vertices per side
    EXPECT_EQ(r.vertex_count, n * n);
    EXPECT_EQ(r.face_count, 2 * (n - 1) * (n - 1));
    EXPECT_EQ(r.edge_count, 3 * (n - 1) * (n - 1) + 2 * (n - 1));
    EXPECT_EQ(r.boundary_edge_count, 4 * (n - 1));
    EXPECT_EQ(r.euler_characteristic, 1);
    EXPECT_TRUE(r.terrain_like);
    EXPECT_EQ(r.up_axis, 2);
    EXPECT_EQ(r.judged_as, "open");
    ASSERT_EQ(r.boundary_loops.size(), 1u);
    EXPECT_TRUE(r.boundary_loops[0].allowed);
    EXPECT_EQ(r.probe.mode, "terrain");
    EXPECT_EQ(r.probe.failed_rays, 0u);
    // The same terrain is not a closed mesh.
    const CheckReport closed = tessref::check_mesh(tessref::indexed_mesh_from(terrain), quick(Expect::closed));
    EXPECT_FALSE(closed.passed);
    EXPECT_EQ(failing_classes(closed), std::set<DefectClass>{DefectClass::boundary_loop});
}

TEST(CheckClean, TerrainFileAndExpectations) {
    EXPECT_TRUE(check_file("terrain.obj").passed);
    EXPECT_TRUE(check_file("terrain.obj", quick(Expect::open)).passed);
    const CheckReport closed = check_file("terrain.obj", quick(Expect::closed));
    EXPECT_FALSE(closed.passed);
    ASSERT_EQ(closed.count(DefectClass::boundary_loop), 1u);
    // The outline of the 6 x 6 grid: 24 edges.
    EXPECT_EQ(closed.of(DefectClass::boundary_loop).locations[0].vertices.size(), 24u);
    // A closed cube is not an open terrain: --expect open still passes it (no boundary at
    // all is allowed too), and finds nothing else.
    EXPECT_TRUE(check_file("cube.off", quick(Expect::open)).passed);
}

// ---------------------------------------------------------------------------------------
// The defect corpus: each defect in its class, at its place

// A closed sphere standing on an open plate (the PN triangles scene's layout): automatic
// judgement takes the plate, a component seen from one side, for an open sheet and allows
// its outline, and holds the rest to the closed rules. A hole in the plate and a hole in
// the sphere are each still a boundary loop.
IndexedMesh sphere_on_plate(bool hole_in_plate, bool hole_in_sphere) {
    IndexedMesh mesh = icosphere(2);
    for (glm::dvec3& p : mesh.positions) p += glm::dvec3(5.0, 5.0, 2.0);
    if (hole_in_sphere) {
        IndexedMesh holed;
        holed.positions = mesh.positions;
        for (std::size_t f = 1; f < mesh.face_count(); ++f) holed.add_face(mesh.face(f));
        mesh = std::move(holed);
    }
    const SurfaceMesh plate = grid_terrain(1, 4, flat);  // 10 x 10, 4 x 4 quads
    const auto base = static_cast<std::uint32_t>(mesh.positions.size());
    mesh.positions.insert(mesh.positions.end(), plate.positions.begin(), plate.positions.end());
    for (std::size_t t = 0; t < plate.triangles.size(); ++t) {
        if (hole_in_plate && (t == 10 || t == 11)) continue;  // quad (1, 1): x in [2.5, 5], y in [2.5, 5]
        const std::array<std::uint32_t, 3> f{base + plate.triangles[t][0], base + plate.triangles[t][1],
                                             base + plate.triangles[t][2]};
        mesh.add_face(f);
    }
    return mesh;
}

TEST(CheckCorpus, OpenSheetBesideAClosedMeshIsJudgedPerComponent) {
    const CheckReport clean = tessref::check_mesh(sphere_on_plate(false, false), quick());
    EXPECT_TRUE(clean.passed) << tessref::report_text(clean);
    EXPECT_EQ(clean.judged_as, "closed");
    EXPECT_EQ(clean.open_sheets, 1u);
    EXPECT_EQ(clean.probe.mode, "closed");
    EXPECT_NE(tessref::report_text(clean).find("but for 1 open sheet"), std::string::npos);
    // Expect closed still refuses the plate's outline.
    EXPECT_EQ(tessref::check_mesh(sphere_on_plate(false, false), quick(Expect::closed)).count(DefectClass::boundary_loop),
              1u);

    const CheckReport plate = tessref::check_mesh(sphere_on_plate(true, false), quick());
    ASSERT_EQ(plate.count(DefectClass::boundary_loop), 1u) << tessref::report_text(plate);
    const auto& hole = plate.of(DefectClass::boundary_loop).locations[0];
    EXPECT_NEAR(hole.position.x, 3.75, 1e-9);
    EXPECT_NEAR(hole.position.y, 3.75, 1e-9);

    const CheckReport sphere = tessref::check_mesh(sphere_on_plate(false, true), quick());
    EXPECT_EQ(sphere.open_sheets, 1u);
    ASSERT_EQ(sphere.count(DefectClass::boundary_loop), 1u) << tessref::report_text(sphere);
    EXPECT_GT(sphere.of(DefectClass::boundary_loop).locations[0].position.z, 1.0);  // on the sphere
}

TEST(CheckCorpus, HoleIsABoundaryLoopAroundTheMissingFace) {
    for (const char* name : {"hole.off", "hole.stl"}) {
        SCOPED_TRACE(name);
        const IndexedMesh mesh = tessref::read_mesh_for_check(corpus(name).string());
        const CheckReport r = tessref::check_mesh(mesh, quick());
        ASSERT_EQ(r.count(DefectClass::boundary_loop), 1u);
        const auto& loop = r.of(DefectClass::boundary_loop).locations[0];
        // The missing face (4,5,6): corners (0,0,1), (1,0,1), (1,1,1).
        const std::set<std::uint32_t> corners = {vertex_at(mesh, {0, 0, 1}), vertex_at(mesh, {1, 0, 1}), vertex_at(mesh, {1, 1, 1})};
        EXPECT_EQ(as_set(loop.vertices), corners);
        EXPECT_NEAR(loop.measure, 2.0 + std::sqrt(2.0), 1e-9);  // its perimeter
        EXPECT_TRUE(near(loop.position, {2.0 / 3.0, 1.0 / 3.0, 1.0}));
        for (DefectClass k : failing_classes(r))
            EXPECT_TRUE(k == DefectClass::boundary_loop || is_probe(k)) << tessref::defect_class_name(k);
        // The probe sees the leak too, and points at the hole.
        EXPECT_GT(r.probe.failed_rays, 0u);
        for (DefectClass k : {DefectClass::probe_odd_parity, DefectClass::probe_escape})
            for (const auto& d : r.of(k).locations) EXPECT_EQ(d.position.z, 1.0);
    }
}

TEST(CheckCorpus, FlippedFaceIsFoundByItsThreeEdges) {
    for (const char* name : {"flipped_face.obj", "flipped_face.stl"}) {
        SCOPED_TRACE(name);
        const CheckReport r = check_file(name);
        EXPECT_EQ(r.count(DefectClass::inconsistent_orientation), 3u);
        for (const auto& d : r.of(DefectClass::inconsistent_orientation).locations) {
            EXPECT_TRUE(as_set(d.faces).count(0)) << d.detail;
            EXPECT_EQ(d.position.z, 0.0);  // face 0 lies in the bottom face of the cube
        }
        EXPECT_EQ(r.flipped_faces, std::vector<std::uint32_t>{0});
        EXPECT_TRUE(r.closed);
        EXPECT_EQ(r.count(DefectClass::inverted_volume), 0u);
        // OpenMesh's kernel cannot hold it and refuses some face, but only because of the
        // flip: one defect, one report (it was reported as a refused face too).
        EXPECT_FALSE(r.refused_for_flips.empty());
        EXPECT_EQ(r.count(DefectClass::refused_face), 0u);
    }
}

TEST(CheckCorpus, InsideOutCubeHasANegativeVolume) {
    for (const char* name : {"inverted.off", "inverted.stl"}) {
        SCOPED_TRACE(name);
        const CheckReport r = check_file(name);
        EXPECT_EQ(failing_classes(r), std::set<DefectClass>{DefectClass::inverted_volume});
        EXPECT_NEAR(r.signed_volume, -1.0, 1e-12);
        EXPECT_NEAR(r.of(DefectClass::inverted_volume).locations.at(0).measure, -1.0, 1e-12);
    }
}

TEST(CheckCorpus, DuplicateFaceIsFoundAndSetAside) {
    for (const char* name : {"duplicate_face.off", "duplicate_face.stl"}) {
        SCOPED_TRACE(name);
        const CheckReport r = check_file(name);
        ASSERT_EQ(r.count(DefectClass::duplicate_face), 1u);
        EXPECT_EQ(r.of(DefectClass::duplicate_face).locations[0].faces, (std::vector<std::uint32_t>{3, 12}));
        // Without the copy the cube is whole.
        EXPECT_TRUE(r.closed);
        EXPECT_TRUE(r.manifold);
        EXPECT_EQ(r.topology_excluded_faces, 1u);
        for (DefectClass k : failing_classes(r))
            EXPECT_TRUE(k == DefectClass::duplicate_face || k == DefectClass::refused_face) << tessref::defect_class_name(k);
    }
}

TEST(CheckCorpus, UnweldedVertexIsFoundWithTheCrackItOpens) {
    for (const char* name : {"duplicate_vertex.off", "duplicate_vertex.ply"}) {
        SCOPED_TRACE(name);
        const CheckReport r = check_file(name);
        ASSERT_EQ(r.count(DefectClass::coincident_vertices), 1u);
        const auto& d = r.of(DefectClass::coincident_vertices).locations[0];
        EXPECT_EQ(d.vertices, (std::vector<std::uint32_t>{6, 8}));
        EXPECT_TRUE(near(d.position, {1, 1, 1}));
        EXPECT_EQ(r.count(DefectClass::near_coincident_vertices), 0u);
        // The top faces are cut loose along the two edges at the copy.
        ASSERT_EQ(r.count(DefectClass::boundary_loop), 1u);
        const auto loop = as_set(r.of(DefectClass::boundary_loop).locations[0].vertices);
        EXPECT_TRUE(loop.count(6) && loop.count(8));
    }
}

TEST(CheckCorpus, NearlyCoincidentVertexAndTheTolerance) {
    const CheckReport r = check_file("near_vertex.off");
    ASSERT_EQ(r.count(DefectClass::near_coincident_vertices), 1u);
    EXPECT_EQ(r.of(DefectClass::near_coincident_vertices).locations[0].vertices, (std::vector<std::uint32_t>{6, 8}));
    EXPECT_EQ(r.count(DefectClass::coincident_vertices), 0u);
    // 1e-7 apart (as float: 1.19e-7): within 1e-6, not within 1e-8.
    CheckOptions loose = quick(), tight = quick();
    loose.tolerance = 1e-6;
    tight.tolerance = 1e-8;
    EXPECT_EQ(check_file("near_vertex.off", loose).count(DefectClass::near_coincident_vertices), 1u);
    EXPECT_EQ(check_file("near_vertex.off", tight).count(DefectClass::near_coincident_vertices), 0u);
}

TEST(CheckCorpus, NonManifoldEdge) {
    for (const char* name : {"nonmanifold_edge.off", "nonmanifold_edge.stl"}) {
        SCOPED_TRACE(name);
        const IndexedMesh mesh = tessref::read_mesh_for_check(corpus(name).string());
        const CheckReport r = tessref::check_mesh(mesh, quick());
        ASSERT_EQ(r.count(DefectClass::non_manifold_edge), 1u);
        const auto& d = r.of(DefectClass::non_manifold_edge).locations[0];
        EXPECT_EQ(as_set(d.vertices), (std::set<std::uint32_t>{vertex_at(mesh, {1, 1, 0}), vertex_at(mesh, {1, 1, 1})}));
        EXPECT_TRUE(near(d.position, {1, 1, 0.5}));
        EXPECT_EQ(d.faces.size(), 4u);  // two faces of each cube
        EXPECT_TRUE(r.closed);
        EXPECT_EQ(r.count(DefectClass::non_manifold_vertex), 0u);
        EXPECT_NEAR(r.signed_volume, 2.0, 1e-12);
        for (DefectClass k : failing_classes(r))
            EXPECT_TRUE(k == DefectClass::non_manifold_edge || k == DefectClass::refused_face) << tessref::defect_class_name(k);
    }
}

TEST(CheckCorpus, NonManifoldVertexJoiningTwoFans) {
    for (const char* name : {"nonmanifold_vertex.off", "nonmanifold_vertex.stl"}) {
        SCOPED_TRACE(name);
        const IndexedMesh mesh = tessref::read_mesh_for_check(corpus(name).string());
        const CheckReport r = tessref::check_mesh(mesh, quick());
        ASSERT_EQ(r.count(DefectClass::non_manifold_vertex), 1u);
        const auto& d = r.of(DefectClass::non_manifold_vertex).locations[0];
        EXPECT_EQ(d.vertices, std::vector<std::uint32_t>{vertex_at(mesh, {1, 1, 1})});
        EXPECT_EQ(d.measure, 2.0);  // two fans
        std::size_t around = 0;  // faces of the file at that corner
        for (std::size_t f = 0; f < mesh.face_count(); ++f)
            for (std::uint32_t v : mesh.face(f)) around += v == d.vertices[0];
        EXPECT_EQ(d.faces.size(), around);
        EXPECT_TRUE(r.closed);
        EXPECT_EQ(r.count(DefectClass::non_manifold_edge), 0u);
        for (DefectClass k : failing_classes(r))
            EXPECT_TRUE(k == DefectClass::non_manifold_vertex || k == DefectClass::refused_face) << tessref::defect_class_name(k);
    }
}

// Fans around a vertex with few faces and with many (the fan search sorts a vertex's
// neighbours by insertion up to 32 entries, two a face, and by std::sort above): two cones
// of `faces` triangles each meeting at their tips are one non-manifold vertex of two fans,
// whose faces are listed in face order (the first 32); one cone alone is one fan.
TEST(CheckCorpus, PinchedVertexOfFewOrManyFaces) {
    for (std::uint32_t faces : {3u, 8u, 16u, 17u, 40u}) {
        SCOPED_TRACE(faces);
        IndexedMesh mesh;
        mesh.positions.push_back({0, 0, 0});  // the shared tip
        for (int cone = 0; cone < 2; ++cone) {
            const double dz = cone == 0 ? 1.0 : -1.0;
            const auto first = static_cast<std::uint32_t>(mesh.positions.size());
            for (std::uint32_t k = 0; k < faces; ++k) {
                const double a = 2.0 * M_PI * k / faces;
                mesh.positions.push_back({std::cos(a), std::sin(a), dz});
            }
            for (std::uint32_t k = 0; k < faces; ++k) {
                const std::uint32_t b = first + k, c = first + (k + 1) % faces;
                if (cone == 0) mesh.add_triangle(0, c, b);
                else mesh.add_triangle(0, b, c);
            }
        }
        const CheckReport both = tessref::check_mesh(mesh, quick());
        ASSERT_EQ(both.count(DefectClass::non_manifold_vertex), 1u);
        const auto& d = both.of(DefectClass::non_manifold_vertex).locations[0];
        EXPECT_EQ(d.vertices, std::vector<std::uint32_t>{0});
        EXPECT_EQ(d.measure, 2.0);
        std::vector<std::uint32_t> listed(std::min<std::uint32_t>(2 * faces, 32));
        std::iota(listed.begin(), listed.end(), 0u);
        EXPECT_EQ(d.faces, listed);
        // The first cone alone: one fan, a boundary loop around its base.
        IndexedMesh cone;
        cone.positions.assign(mesh.positions.begin(), mesh.positions.begin() + 1 + faces);
        for (std::size_t f = 0; f < faces; ++f) cone.add_face(mesh.face(f));
        const CheckReport one = tessref::check_mesh(cone, quick());
        EXPECT_EQ(one.count(DefectClass::non_manifold_vertex), 0u);
        EXPECT_EQ(one.boundary_loop_count, 1u);
    }
}

// Duplicate faces are the faces over an earlier face's vertex set, in any corner order;
// a triangle sharing two of its vertices (an edge) with another, or a quad holding all
// three, is no duplicate.
TEST(CheckCorpus, DuplicateTrianglesInAnyCornerOrderOnly) {
    IndexedMesh mesh;
    mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0, -1, 0}, {0.5, 0.5, 1}};
    mesh.add_triangle(0, 1, 2);          // 0: the original
    mesh.add_triangle(1, 0, 4);          // 1: shares edge 0-1 only
    mesh.add_triangle(2, 0, 1);          // 2: a rotation of 0
    mesh.add_triangle(1, 0, 2);          // 3: 0 reversed
    const std::uint32_t quad[] = {0, 1, 3, 2};
    mesh.add_face(quad);                 // 4: holds 0, 1, 2 and 3
    mesh.add_triangle(0, 1, 5);          // 5: shares edge 0-1 again
    mesh.add_triangle(4, 1, 0);          // 6: a rotation of 1
    const CheckReport r = tessref::check_mesh(mesh, quick(Expect::open));
    ASSERT_EQ(r.count(DefectClass::duplicate_face), 3u);
    const auto& found = r.of(DefectClass::duplicate_face).locations;
    EXPECT_EQ(found[0].faces, (std::vector<std::uint32_t>{0, 2}));
    EXPECT_EQ(found[1].faces, (std::vector<std::uint32_t>{0, 3}));
    EXPECT_EQ(found[2].faces, (std::vector<std::uint32_t>{1, 6}));
    EXPECT_EQ(found[0].detail, "face 2 repeats face 0 (same vertices, other order)");
    EXPECT_EQ(r.topology_excluded_faces, 3u);
}

TEST(CheckCorpus, TJunctionOnTheCube) {
    for (const char* name : {"t_junction.off", "t_junction.stl"}) {
        SCOPED_TRACE(name);
        const IndexedMesh mesh = tessref::read_mesh_for_check(corpus(name).string());
        const CheckReport r = tessref::check_mesh(mesh, quick());
        ASSERT_EQ(r.count(DefectClass::t_junction), 1u);
        const auto& d = r.of(DefectClass::t_junction).locations[0];
        const std::uint32_t m = vertex_at(mesh, {0.5, 0, 0}), a = vertex_at(mesh, {0, 0, 0}), b = vertex_at(mesh, {1, 0, 0});
        EXPECT_EQ(d.vertices[0], m);
        EXPECT_EQ(as_set({d.vertices[1], d.vertices[2]}), (std::set<std::uint32_t>{a, b}));
        EXPECT_TRUE(near(d.position, {0.5, 0, 0}));
        EXPECT_EQ(d.measure, 0.0);
        // The face (0,1,5) whose edge 0-1 has the vertex on it: face 4 of the file.
        if (std::string(name).ends_with(".off")) EXPECT_EQ(d.faces, std::vector<std::uint32_t>{4});
        // The crack is a loop of three edges: 0.5 + 0.5 + 1.
        ASSERT_EQ(r.count(DefectClass::boundary_loop), 1u);
        EXPECT_NEAR(r.of(DefectClass::boundary_loop).locations[0].measure, 2.0, 1e-12);
        EXPECT_EQ(failing_classes(r), (std::set<DefectClass>{DefectClass::boundary_loop, DefectClass::t_junction}));
    }
}

TEST(CheckCorpus, SliverIsDegenerate) {
    for (const char* name : {"sliver.off", "sliver.stl"}) {
        SCOPED_TRACE(name);
        const CheckReport r = check_file(name);
        EXPECT_EQ(failing_classes(r), std::set<DefectClass>{DefectClass::degenerate_face});
        ASSERT_EQ(r.count(DefectClass::degenerate_face), 1u);
        const auto& d = r.of(DefectClass::degenerate_face).locations[0];
        EXPECT_EQ(d.faces, std::vector<std::uint32_t>{13});
        EXPECT_EQ(d.measure, 0.0);  // collinear corners: no height at all
        EXPECT_TRUE(near(d.position, {0.5, 0, 0}));
        EXPECT_TRUE(r.closed);
    }
}

TEST(CheckCorpus, RepeatedVertexIsDegenerateAndNeverDropped) {
    for (const char* name : {"repeated_vertex.off", "repeated_vertex.obj", "repeated_vertex.stl"}) {
        SCOPED_TRACE(name);
        const IndexedMesh mesh = tessref::read_mesh_for_check(corpus(name).string());
        // OpenMesh's OBJ and STL readers drop this face; it is here all the same.
        ASSERT_EQ(mesh.face_count(), 13u);
        const CheckReport r = tessref::check_mesh(mesh, quick());
        ASSERT_EQ(r.count(DefectClass::degenerate_face), 1u);
        EXPECT_EQ(r.of(DefectClass::degenerate_face).locations[0].faces, std::vector<std::uint32_t>{12});
        EXPECT_NE(r.of(DefectClass::degenerate_face).locations[0].detail.find("repeats a vertex"), std::string::npos);
        ASSERT_EQ(r.count(DefectClass::refused_face), 1u);
        EXPECT_EQ(r.of(DefectClass::refused_face).locations[0].faces, std::vector<std::uint32_t>{12});
        EXPECT_TRUE(r.closed);
        EXPECT_EQ(failing_classes(r), (std::set<DefectClass>{DefectClass::degenerate_face, DefectClass::refused_face}));
    }
}

TEST(CheckCorpus, HoleInATerrain) {
    const CheckReport r = check_file("terrain_hole.obj");
    EXPECT_EQ(r.judged_as, "open");
    ASSERT_EQ(r.count(DefectClass::boundary_loop), 1u);  // the outline is allowed, the hole not
    const auto& hole = r.of(DefectClass::boundary_loop).locations[0];
    EXPECT_EQ(hole.vertices.size(), 4u);
    EXPECT_NEAR(hole.measure, 4.0, 0.1);  // a unit square, a little longer on the slope
    EXPECT_NEAR(hole.position.x, 2.5, 1e-9);
    EXPECT_NEAR(hole.position.y, 3.5, 1e-9);
    // Vertical rays fall through it, and only there.
    ASSERT_GE(r.count(DefectClass::probe_miss), 1u);
    for (const auto& d : r.of(DefectClass::probe_miss).locations) {
        EXPECT_GT(d.position.x, 2.0);
        EXPECT_LT(d.position.x, 3.0);
        EXPECT_GT(d.position.y, 3.0);
        EXPECT_LT(d.position.y, 4.0);
    }
    // 96 x 96 rays over 6 x 6 units: a unit square holds about 96^2 / 36 of them.
    EXPECT_NEAR(double(r.probe.failed_rays), 96.0 * 96.0 / 36.0, 30.0);
}

TEST(CheckCorpus, PatchesWithMismatchedOuterLevels) {
    const IndexedMesh mesh = tessref::read_mesh_for_check(corpus("patches_mismatched.obj").string());
    const CheckReport r = tessref::check_mesh(mesh, quick());
    ASSERT_EQ(r.count(DefectClass::t_junction), 1u);
    const auto& d = r.of(DefectClass::t_junction).locations[0];
    EXPECT_EQ(d.vertices[0], vertex_at(mesh, {1, 0.5, 0.05}));
    // Seen from above it lies on the right patch's edge (1,0,0)-(1,1,0.2); in 3D it is
    // |(0,0.5,0.05) x (0,1,0.2)| / |(0,1,0.2)| = 0.05 / sqrt(1.04) below it.
    EXPECT_NEAR(d.measure, 0.05 / std::sqrt(1.04), 1e-7);
    EXPECT_FALSE(r.passed);
    // The two patches touch only at the ends of the shared edge: pinched there.
    EXPECT_EQ(r.count(DefectClass::non_manifold_vertex), 2u);
}

TEST(CheckCorpus, MismatchedLevelsMadeByCode) {
    // Levels 4 and 2 along the shared edge: the finer patch's vertices at y = 1/4 and 3/4
    // lie on the coarser patch's edges; the one at y = 1/2 welds with the coarser one's.
    for (auto height : {flat, bowl}) {
        const CheckReport r = tessref::check_mesh(tessref::indexed_mesh_from(two_patches(4, 2, height)), quick());
        ASSERT_EQ(r.count(DefectClass::t_junction), 2u) << tessref::report_text(r);
        std::set<double> ys;
        for (const auto& d : r.of(DefectClass::t_junction).locations) {
            EXPECT_EQ(d.position.x, 1.0);
            ys.insert(d.position.y);
        }
        EXPECT_EQ(ys, (std::set<double>{0.25, 0.75}));
        EXPECT_FALSE(r.passed);
    }
    // Matching levels: no crack at all.
    EXPECT_TRUE(tessref::check_mesh(tessref::indexed_mesh_from(two_patches(3, 3, bowl)), quick()).passed);
}

// A 3 x 3 patch terrain (2 x 2 quads a patch) whose centre patch is re-tessellated as a
// fan from its centre with 4 segments on its left edge, where its left neighbour keeps 2:
// a crack inside the terrain, away from the outline.
SurfaceMesh terrain_with_inner_crack() {
    SurfaceMesh mesh = grid_terrain(3, 2, hills);
    // Drop the centre patch (patch 4) and add its fan.
    const std::size_t per_patch = 8;  // triangles
    mesh.triangles.erase(mesh.triangles.begin() + 4 * per_patch, mesh.triangles.begin() + 5 * per_patch);
    const double n = 6.0;  // quads per side of the whole terrain
    auto point = [&](double gi, double gj) {  // global grid coordinates, as grid_terrain computes them
        const double x = 10.0 * gi / n, y = 10.0 * gj / n;
        mesh.positions.emplace_back(x, y, hills(x, y));
        mesh.patch_ids.push_back(4);
        mesh.tess_coords.emplace_back(0.0f, 0.0f, 0.0f);
        return static_cast<std::uint32_t>(mesh.positions.size() - 1);
    };
    // The centre patch spans gi, gj in [2, 4]; its outline counter-clockwise from (2, 2).
    std::vector<std::uint32_t> ring;
    for (double gi : {2.0, 3.0}) ring.push_back(point(gi, 2.0));
    for (double gj : {2.0, 3.0}) ring.push_back(point(4.0, gj));
    for (double gi : {4.0, 3.0}) ring.push_back(point(gi, 4.0));
    for (double gj : {4.0, 3.5, 3.0, 2.5}) ring.push_back(point(2.0, gj));  // the finer left edge
    const std::uint32_t centre = point(3.0, 3.0);
    for (std::size_t i = 0; i < ring.size(); ++i) mesh.triangles.push_back({centre, ring[i], ring[(i + 1) % ring.size()]});
    return mesh;
}

TEST(CheckCorpus, CrackInsideATerrain) {
    const CheckReport r = tessref::check_mesh(tessref::indexed_mesh_from(terrain_with_inner_crack()), quick());
    EXPECT_EQ(r.judged_as, "open");
    // The finer edge's vertices at y = 2.5 and 3.5 units of the grid (x = 10/3) lie on the
    // coarser patch's edges; the surface is curved there, so the crack opens vertically.
    ASSERT_EQ(r.count(DefectClass::t_junction), 2u) << tessref::report_text(r);
    std::set<double> ys;
    for (const auto& d : r.of(DefectClass::t_junction).locations) {
        EXPECT_NEAR(d.position.x, 10.0 / 3.0, 1e-12);
        ys.insert(d.position.y);
        EXPECT_GT(d.measure, 0.0);
    }
    EXPECT_EQ(ys, (std::set<double>{10.0 * 2.5 / 6.0, 10.0 * 3.5 / 6.0}));
    // The outline stays the one allowed loop (6 quads a side); the crack is one loop inside
    // of 2 + 4 edges, passing twice through the vertex both patches share in the middle of
    // the edge, where the surface is pinched.
    ASSERT_EQ(r.boundary_loops.size(), 2u);
    EXPECT_TRUE(r.boundary_loops[0].allowed);
    EXPECT_EQ(r.boundary_loops[0].edge_count, 4u * 6u);
    ASSERT_EQ(r.count(DefectClass::boundary_loop), 1u);
    EXPECT_EQ(r.boundary_loops[1].edge_count, 6u);
    EXPECT_NEAR(r.of(DefectClass::boundary_loop).locations[0].position.x, 10.0 / 3.0, 1e-9);
    ASSERT_EQ(r.count(DefectClass::non_manifold_vertex), 1u);
    EXPECT_EQ(r.of(DefectClass::non_manifold_vertex).locations[0].position.y, 5.0);
    // Closed into a solid, it still leaks.
    const SurfaceMesh solid = tessref::close_terrain_into_solid(terrain_with_inner_crack(), 0.0);
    EXPECT_FALSE(tessref::check_mesh(tessref::indexed_mesh_from(solid), quick(Expect::closed)).passed);
}

// ---------------------------------------------------------------------------------------
// Solids closed from terrains

TEST(CheckSolid, ClosedTerrainPassesExpectClosed) {
    for (int up : {2, 1}) {
        SCOPED_TRACE(up);
        const SurfaceMesh terrain = grid_terrain(3, 4, hills, up);
        const double base = -0.5;
        const SurfaceMesh solid = tessref::close_terrain_into_solid(terrain, base, up);
        const CheckReport r = tessref::check_mesh(tessref::indexed_mesh_from(solid), quick(Expect::closed));
        EXPECT_TRUE(r.passed) << tessref::report_text(r);
        EXPECT_TRUE(r.closed);
        EXPECT_EQ(r.euler_characteristic, 2);
        EXPECT_EQ(r.component_count, 1u);
        EXPECT_NEAR(r.signed_volume, prism_volume(terrain, base, up), 1e-9 * prism_volume(terrain, base, up));
        // Attributes follow the positions.
        EXPECT_EQ(solid.patch_ids.size(), solid.positions.size());
        EXPECT_EQ(solid.tess_coords.size(), solid.positions.size());
    }
}

TEST(CheckSolid, CrackedTerrainStaysCracked) {
    const SurfaceMesh solid = tessref::close_terrain_into_solid(two_patches(4, 2, bowl), -1.0);
    const CheckReport r = tessref::check_mesh(tessref::indexed_mesh_from(solid), quick(Expect::closed));
    EXPECT_FALSE(r.passed);
    // Seen in 3D the crack is an open gap (0.0125 wide at y = 1/4): a boundary loop along
    // the shared edge, which the probe's lines leak through.
    ASSERT_EQ(r.count(DefectClass::boundary_loop), 1u);
    EXPECT_EQ(r.of(DefectClass::boundary_loop).locations[0].position.x, 1.0);
    EXPECT_GE(r.count(DefectClass::probe_odd_parity), 1u);
}

TEST(CheckSolid, RejectsABaseAboveTheTerrain) {
    const SurfaceMesh terrain = grid_terrain(1, 2, hills);
    double lowest = std::numeric_limits<double>::infinity();
    for (const auto& p : terrain.positions) lowest = std::min(lowest, p.z);
    EXPECT_THROW(tessref::close_terrain_into_solid(terrain, lowest), tessref::Error);
    EXPECT_THROW(tessref::close_terrain_into_solid(terrain, lowest + 0.01), tessref::Error);
    EXPECT_NO_THROW(tessref::close_terrain_into_solid(terrain, lowest - 0.01));
    EXPECT_THROW(tessref::close_terrain_into_solid(SurfaceMesh{}, 0.0), tessref::Error);
}

// ---------------------------------------------------------------------------------------
// Every shipped scene's export passes

TEST(CheckScenes, EveryShippedSceneExportPasses) {
    std::vector<fs::path> scenes;
    for (const auto& entry : fs::directory_iterator(fs::path(TESSREF_SOURCE_DIR) / "data" / "scenes"))
        if (entry.path().extension() == ".toml") scenes.push_back(entry.path());
    std::sort(scenes.begin(), scenes.end());
    ASSERT_FALSE(scenes.empty());
    for (const fs::path& path : scenes) {
        SCOPED_TRACE(path.filename().string());
        const tessref::Scene scene = tessref::load_scene(path.string());
        // pn-culling discards the patches the camera cannot see, by design: its holes are
        // its point (held to llvmpipe in tests/test_user_shaders.cpp).
        if (!scene.shaders.empty()) continue;
        const tessref::PipelineResult result = tessref::run_pipeline(scene);
        // Terrains are open; the PN scene holds an open plate beside closed meshes: every
        // scene's export passes with the default, automatic judgement.
        const CheckReport r = tessref::check_mesh(tessref::indexed_mesh_from(result.mesh), quick());
        EXPECT_TRUE(r.passed) << tessref::report_text(r);
        if (!scene.grid) continue;
        const int up = scene.grid->plane == tessref::GroundPlane::xy ? 2 : 1;
        EXPECT_EQ(r.up_axis, up);
        double lowest = std::numeric_limits<double>::infinity();
        for (const auto& p : result.mesh.positions) lowest = std::min(lowest, p[up]);
        const SurfaceMesh solid = tessref::close_terrain_into_solid(result.mesh, lowest - 1.0, up);
        const CheckReport closed = tessref::check_mesh(tessref::indexed_mesh_from(solid), quick(Expect::closed));
        EXPECT_TRUE(closed.passed) << tessref::report_text(closed);
        EXPECT_GT(closed.signed_volume, 0.0);
    }
}

// ---------------------------------------------------------------------------------------
// Reports

TEST(CheckReport, SameReportWhateverTheThreadCount) {
    const IndexedMesh mesh = tessref::indexed_mesh_from(grid_terrain(6, 12, hills));
    std::string one, many;
    {
        tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
        one = tessref::report_json(tessref::check_mesh(mesh, quick()));
    }
    many = tessref::report_json(tessref::check_mesh(mesh, quick()));
    EXPECT_EQ(one, many);
    const IndexedMesh broken = tessref::read_mesh_for_check(corpus("flipped_face.obj").string());
    {
        tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
        one = tessref::report_json(tessref::check_mesh(broken, quick()));
    }
    EXPECT_EQ(one, tessref::report_json(tessref::check_mesh(broken, quick())));
}

// Every corpus file and a terrain with holes, flipped and repeated faces, shuffled: the
// same report, defects in the same order, on one thread and on two.
TEST(CheckReport, SameDefectsInTheSameOrderOnOneThreadAndTwo) {
    std::vector<IndexedMesh> meshes;
    for (const auto& entry : fs::directory_iterator(corpus_dir)) {
        const std::string ext = entry.path().extension().string();
        if (ext == ".ply" || ext == ".obj" || ext == ".off" || ext == ".stl")
            meshes.push_back(tessref::read_mesh_for_check(entry.path().string()));
    }
    const IndexedMesh terrain = tessref::indexed_mesh_from(grid_terrain(6, 12, hills));
    IndexedMesh broken;
    broken.positions = terrain.positions;
    std::uint64_t random = 99;
    const auto next = [&random](std::uint64_t n) {
        random = random * 6364136223846793005ULL + 1442695040888963407ULL;
        return static_cast<std::size_t>((random >> 33) % n);
    };
    std::vector<std::size_t> order;
    for (std::size_t f = 0; f < terrain.face_count(); ++f)
        if (next(50) != 0) order.push_back(f);  // holes
    for (int k = 0; k < 20; ++k) order.push_back(order[next(order.size())]);  // duplicates
    for (std::size_t i = order.size(); i > 1; --i) std::swap(order[i - 1], order[next(i)]);
    for (std::size_t f : order) {
        std::vector<std::uint32_t> face(terrain.face(f).begin(), terrain.face(f).end());
        if (next(40) == 0) std::reverse(face.begin(), face.end());  // flipped
        broken.add_face(face);
    }
    meshes.push_back(std::move(broken));
    for (const IndexedMesh& mesh : meshes) {
        SCOPED_TRACE(mesh.source.empty() ? "broken terrain" : mesh.source);
        std::string reports[2];
        for (int threads : {1, 2}) {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
            reports[threads - 1] = tessref::report_json(tessref::check_mesh(mesh, quick()));
        }
        EXPECT_EQ(reports[0], reports[1]);
    }
    const CheckReport r = tessref::check_mesh(meshes.back(), quick());
    EXPECT_GT(r.count(DefectClass::boundary_loop), 0u);
    EXPECT_GT(r.count(DefectClass::duplicate_face), 0u);
    EXPECT_GT(r.count(DefectClass::inconsistent_orientation), 0u);
}

// read_and_check_mesh() (the command's path, OpenMesh's import skipped where the topology
// proves it refuses nothing) against read_mesh_for_check() then check_mesh(): the same mesh,
// refused faces included, and the same report.
void expect_read_and_check_as_before(const fs::path& file, const CheckOptions& options) {
    SCOPED_TRACE(file.string());
    const IndexedMesh before = tessref::read_mesh_for_check(file.string());
    const std::string before_report = tessref::report_json(tessref::check_mesh(before, options));
    const tessref::CheckedMesh after = tessref::read_and_check_mesh(file.string(), options);
    EXPECT_EQ(after.mesh.kernel_refused_faces, before.kernel_refused_faces);
    EXPECT_EQ(after.mesh.positions, before.positions);
    EXPECT_EQ(after.mesh.face_vertices, before.face_vertices);
    EXPECT_EQ(tessref::report_json(after.report), before_report);
}

// An OFF file of `mesh`'s triangles in the order `order` gives (indices into its triangles).
void write_off(const fs::path& file, const IndexedMesh& mesh, const std::vector<std::size_t>& order) {
    std::ofstream out(file);
    out.precision(17);
    out << "OFF\n" << mesh.vertex_count() << " " << order.size() << " 0\n";
    for (const glm::dvec3& p : mesh.positions) out << p.x << " " << p.y << " " << p.z << "\n";
    for (const std::size_t f : order) {
        const auto face = mesh.face(f);
        out << face.size();
        for (const std::uint32_t v : face) out << " " << v;
        out << "\n";
    }
}

TEST(CheckReadAndCheck, SameMeshAndReportForEveryCorpusFile) {
    for (const auto& entry : fs::directory_iterator(corpus_dir)) {
        const std::string ext = entry.path().extension().string();
        if (ext != ".ply" && ext != ".obj" && ext != ".off" && ext != ".stl") continue;
        expect_read_and_check_as_before(entry.path(), quick());
    }
    for (const auto& entry : fs::directory_iterator(fs::path(TESSREF_DATA_DIR) / "meshes"))
        expect_read_and_check_as_before(entry.path(), quick());
}

TEST(CheckReadAndCheck, SameRefusedFacesWhateverTheFaceOrder) {
    // OpenMesh's kernel adds faces one by one, re-linking the fans that meet at a vertex;
    // the order decides how it links them. Terrains with faces shuffled, with random faces
    // left out (holes, pinched vertices between them), some flipped, some repeated: where the
    // fast path applies it must agree with the kernel, whatever the order.
    const IndexedMesh shapes[] = {
        tessref::indexed_mesh_from(grid_terrain(3, 4, hills)),
        tessref::read_mesh_file((fs::path(TESSREF_DATA_DIR) / "meshes" / "icosahedron.off").string()),
        tessref::read_mesh_file((fs::path(TESSREF_DATA_DIR) / "meshes" / "bump.off").string())};
    std::uint64_t random = 12345;
    const auto next = [&random](std::uint64_t n) {
        random = random * 6364136223846793005ULL + 1442695040888963407ULL;
        return static_cast<std::size_t>((random >> 33) % n);
    };
    const fs::path dir = scratch_dir();
    for (int trial = 0; trial < 60; ++trial) {
        const IndexedMesh& terrain = shapes[trial % 3];
        std::vector<std::size_t> order;
        for (std::size_t f = 0; f < terrain.face_count(); ++f)
            if (trial % 4 == 0 || next(10) != 0) order.push_back(f);  // one trial in four keeps all
        for (std::size_t i = order.size(); i > 1; --i) std::swap(order[i - 1], order[next(i)]);
        IndexedMesh mesh = terrain;
        if (trial % 5 == 3) {  // one face flipped
            const std::size_t f = order[next(order.size())];
            std::swap(mesh.face_vertices[mesh.face_start[f]], mesh.face_vertices[mesh.face_start[f] + 1]);
        }
        if (trial % 7 == 5) order.push_back(order[next(order.size())]);  // a duplicate face
        const fs::path file = dir / ("shuffled-" + std::to_string(trial) + ".off");
        write_off(file, mesh, order);
        expect_read_and_check_as_before(file, quick());
    }
}

// A terrain of 3 x 3 unit patches whose middle patch splits its bottom edge (shared with the
// patch below, which does not) at a vertex 0.05 above it: a thin crack loop of 3 edges
// between the two patches, and its largest gap is that step, 0.05 from the vertex to the edge
// it should lie on (it used to be a loop with no width).
TEST(CheckReport, ALoopCarriesItsLargestGap) {
    IndexedMesh mesh;
    for (int y = 0; y <= 3; ++y)
        for (int x = 0; x <= 3; ++x) mesh.positions.push_back({double(x), double(y), 0.0});
    const auto at = [](int x, int y) { return static_cast<std::uint32_t>(4 * y + x); };
    mesh.positions.push_back({1.5, 1.0, 0.05});  // 16
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 3; ++x) {
            if (x == 1 && y == 1) {  // corners a b c d, the split vertex m on a-b
                const std::uint32_t a = at(1, 1), b = at(2, 1), c = at(2, 2), d = at(1, 2), m = 16;
                mesh.add_triangle(a, m, d);
                mesh.add_triangle(m, c, d);
                mesh.add_triangle(m, b, c);
                continue;
            }
            mesh.add_triangle(at(x, y), at(x + 1, y), at(x + 1, y + 1));
            mesh.add_triangle(at(x, y), at(x + 1, y + 1), at(x, y + 1));
        }
    const CheckReport r = tessref::check_mesh(mesh, quick());
    ASSERT_EQ(r.count(DefectClass::boundary_loop), 1u) << tessref::report_text(r);
    const auto& loop = r.of(DefectClass::boundary_loop).locations.at(0);
    EXPECT_NE(loop.detail.find("boundary loop of 3 edges"), std::string::npos) << loop.detail;
    EXPECT_NE(loop.detail.find("largest gap 0.05"), std::string::npos) << loop.detail;
    bool found = false;
    for (const tessref::BoundaryLoop& l : r.boundary_loops)
        if (!l.allowed) {
            EXPECT_NEAR(l.gap, 0.05, 1e-9);
            found = true;
        }
    EXPECT_TRUE(found);
}

TEST(CheckReport, LocationsAreCappedCountsAreNot) {
    CheckOptions options = quick();
    options.max_locations = 1;
    const CheckReport r = check_file("flipped_face.obj", options);
    EXPECT_EQ(r.count(DefectClass::inconsistent_orientation), 3u);
    EXPECT_EQ(r.of(DefectClass::inconsistent_orientation).locations.size(), 1u);
}

// ---------------------------------------------------------------------------------------
// admesh, an independent peer, on every corpus STL

namespace {

struct AdmeshVerdict {
    long facets = -1, disconnected = -1, parts = -1, degenerate = -1, reversed = -1;
    double volume = 0.0;
};

std::optional<AdmeshVerdict> run_admesh(const fs::path& stl) {
    // -e -d: match facets by exact edges and check normal directions; nothing else, so
    // the "Original" statistics describe the file as it is.
    const RunResult r = run("admesh", {"-e", "-d", stl.string()});
    if (r.status != 0) return std::nullopt;
    AdmeshVerdict v;
    auto number = [&](const std::string& label) -> double {
        const std::regex pattern(label + R"(\s*:\s*(-?[0-9.]+))");
        std::smatch m;
        return std::regex_search(r.out, m, pattern) ? std::stod(m[1]) : -1.0;
    };
    v.facets = long(number("Number of facets"));
    v.disconnected = long(number("Total disconnected facets"));
    v.parts = long(number("Number of parts"));
    v.degenerate = long(number("Degenerate facets"));
    v.reversed = long(number("Facets reversed"));
    v.volume = number("Volume");
    return v;
}

}  // namespace

TEST(CheckAdmesh, AgreesOnEveryCorpusStl) {
    // admesh is the independent peer: without it the comparison fails rather than skips.
    ASSERT_EQ(std::system("command -v admesh >/dev/null 2>&1"), 0) << "admesh not installed (scripts/install-deps.sh)";
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(corpus_dir))
        if (entry.path().extension() == ".stl") files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    ASSERT_GE(files.size(), 12u);
    for (const fs::path& file : files) {
        const std::string name = file.filename().string();
        SCOPED_TRACE(name);
        const auto peer = run_admesh(file);
        ASSERT_TRUE(peer) << "admesh failed on " << name;
        const CheckReport r = tessref::check_mesh(tessref::read_mesh_for_check(file.string()), quick());

        // Both read every facet of the file.
        EXPECT_EQ(peer->facets, long(r.face_count));
        // Degenerate facets, in admesh's sense: two equal corners.
        long repeated = 0;
        for (const auto& d : r.of(DefectClass::degenerate_face).locations)
            repeated += d.detail.find("repeats a vertex") != std::string::npos;
        EXPECT_EQ(peer->degenerate, repeated);
        // Closed or open. admesh pairs facets edge by edge, so a duplicated facet finds no
        // free partner and counts as disconnected; tessref sets duplicates aside and
        // reports them as such.
        const bool peer_open = peer->disconnected > 0;
        EXPECT_EQ(peer_open, !r.closed || r.count(DefectClass::duplicate_face) > 0)
            << "admesh: " << peer->disconnected << " disconnected facets";
        // admesh's volume (after it turned facets to agree, -d) against tessref's.
        if (r.closed && r.count(DefectClass::duplicate_face) == 0 && r.count(DefectClass::inconsistent_orientation) == 0)
            EXPECT_NEAR(peer->volume, r.signed_volume, 1e-5 * std::max(1.0, std::abs(r.signed_volume)));

        // A defect or not. admesh's signs: disconnected facets, degenerate facets, facets
        // it had to reverse, a negative volume, or more parts (joined by edges) than
        // tessref's components (joined by vertices): pieces that touch only at a vertex
        // or along a non-manifold edge.
        if (name == "terrain.stl") {
            EXPECT_TRUE(r.passed);  // open by design: a terrain
            continue;
        }
        const bool peer_defect = peer->disconnected > 0 || peer->degenerate > 0 || peer->reversed > 0 ||
                                 (peer_open ? false : peer->volume < 0.0) || peer->parts > long(r.component_count);
        if (name == "sliver.stl") {
            // admesh does not measure facet areas: a zero-area facet with three distinct
            // corners is invisible to it.
            EXPECT_FALSE(peer_defect);
            EXPECT_FALSE(r.passed);
            continue;
        }
        EXPECT_EQ(peer_defect, !r.passed) << tessref::report_text(r);
    }
}

// ---------------------------------------------------------------------------------------
// The command

TEST(CheckCommand, ExitStatusAndSummary) {
    RunResult r = tessref_check({corpus("cube.off").string()});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("PASS"), std::string::npos);
    r = tessref_check({corpus("t_junction.off").string()});
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_NE(r.out.find("t_junction: 1"), std::string::npos) << r.out;
    EXPECT_EQ(tessref_check({corpus("terrain.obj").string(), "--expect", "open"}).status, 0);
    EXPECT_EQ(tessref_check({corpus("terrain.obj").string(), "--expect", "closed"}).status, 1);
    EXPECT_EQ(tessref_check({corpus("near_vertex.off").string(), "--tolerance", "1e-8"}).status, 1);  // still the crack
    EXPECT_EQ(tessref_check({corpus("cube.off").string(), "--expect", "sideways"}).status, 2);
}

// The shipped PN triangles scene, exported as `tessref mesh` writes it, passes `check` by
// default (its plate is an open sheet); held to closed rules, the plate's outline is a
// boundary loop whose location names the patches of its vertices, as the PLY's patch_id
// property gives them (read here through the mesh reader).
TEST(CheckCommand, ShippedPnMeshPassesAndLocationsNameTheirPatches) {
    const fs::path ply = scratch_dir() / "pn.ply";
    const RunResult mesh = run(TESSREF_EXE, {"mesh", (fs::path(TESSREF_SOURCE_DIR) / "data/scenes/pn-triangles.toml").string(),
                                             "-o", ply.string()});
    ASSERT_EQ(mesh.status, 0) << mesh.err;
    const RunResult pass = tessref_check({ply.string()});
    EXPECT_EQ(pass.status, 0) << pass.out;
    const RunResult closed = tessref_check({ply.string(), "--expect", "closed", "--json"});
    ASSERT_EQ(closed.status, 1) << closed.out;
    const nlohmann::json j = nlohmann::json::parse(closed.out);
    const auto& location = j["defects"]["boundary_loop"]["locations"][0];
    tessref::MeshFileOptions options;
    options.provenance = true;
    const IndexedMesh file = tessref::read_mesh_file(ply.string(), options);
    ASSERT_EQ(file.patch_ids.size(), file.vertex_count());
    std::set<std::uint32_t> expected;
    for (const auto& v : location["vertices"]) expected.insert(file.patch_ids[v.get<std::uint32_t>()]);
    for (const auto& f : location["faces"])
        for (std::uint32_t v : file.face(f.get<std::size_t>())) expected.insert(file.patch_ids[v]);
    ASSERT_FALSE(expected.empty());
    EXPECT_EQ(location["patches"].get<std::set<std::uint32_t>>(), expected);
    const RunResult text = tessref_check({ply.string(), "--expect", "closed"});
    EXPECT_NE(text.out.find("; patch"), std::string::npos) << text.out;
}

TEST(CheckCommand, JsonHoldsTheWholeReport) {
    const RunResult r = tessref_check({corpus("nonmanifold_edge.off").string(), "--json"});
    EXPECT_EQ(r.status, 1);
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["passed"], false);
    EXPECT_EQ(j["counts"]["faces"], 24);
    EXPECT_EQ(j["closed"], true);
    EXPECT_EQ(j["defects"]["non_manifold_edge"]["count"], 1);
    const auto& location = j["defects"]["non_manifold_edge"]["locations"][0];
    EXPECT_EQ(location["position"], nlohmann::json::array({1.0, 1.0, 0.5}));
    EXPECT_EQ(location["faces"].size(), 4u);
    EXPECT_EQ(j["defects"].size(), std::size_t(tessref::kDefectClassCount));
}

TEST(CheckCommand, UnreadableInputExitsTwoNamingTheFile) {
    const fs::path dir = scratch_dir();
    std::vector<fs::path> bad;
    bad.push_back(dir / "missing.stl");
    {
        // A binary STL cut short: 200 of its 684 bytes.
        const std::string whole = read_file(corpus("cube_binary.stl"));
        ASSERT_EQ(whole.size(), 84u + 50u * 12u);
        std::ofstream(dir / "truncated.stl", std::ios::binary) << whole.substr(0, 200);
        bad.push_back(dir / "truncated.stl");
    }
    std::ofstream(dir / "garbage.ply", std::ios::binary) << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nxx \x01\x02\x03";
    bad.push_back(dir / "garbage.ply");
    std::ofstream(dir / "noise.ply", std::ios::binary) << "\x7f\x45\x4c\x46 not a mesh at all";
    bad.push_back(dir / "noise.ply");
    std::ofstream(dir / "out_of_range.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n";
    bad.push_back(dir / "out_of_range.obj");
    std::ofstream(dir / "out_of_range.off") << "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 7\n";
    bad.push_back(dir / "out_of_range.off");
    std::ofstream(dir / "short.ply") << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                        "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                        "end_header\n0 0 0\n1 0 0\n";
    bad.push_back(dir / "short.ply");
    std::ofstream(dir / "empty.off");
    bad.push_back(dir / "empty.off");
    std::ofstream(dir / "mesh.xyz") << "1 2 3\n";
    bad.push_back(dir / "mesh.xyz");
    for (const fs::path& path : bad) {
        SCOPED_TRACE(path.filename().string());
        const RunResult r = tessref_check({path.string()});
        EXPECT_EQ(r.status, 2) << r.out << r.err;
        EXPECT_EQ(r.err.rfind("tessref: error: ", 0), 0u) << r.err;
        EXPECT_NE(r.err.find(path.string()), std::string::npos) << r.err;
        EXPECT_TRUE(r.out.empty()) << r.out;
        EXPECT_THROW(tessref::read_mesh_for_check(path.string()), tessref::Error);
    }
}

// A passing terrain's picture must not look cracked: the jacksboro export (576 patches,
// slivers along the patch borders) has no white pixel inside its footprint, where on main
// rows of pinholes along the patch borders showed. Under the view, a scale bar whose length
// is a round number (1, 2 or 5 times a power of ten) of world units at the picture's own
// scale, measured here from the footprint's width in pixels against the mesh's extent.
TEST(CheckCommand, PassingTerrainPictureHasNoPinholesAndAScaleBar) {
    const fs::path dir = scratch_dir();
    const fs::path ply = dir / "jacksboro.ply", png = dir / "jacksboro.png";
    ASSERT_EQ(run(TESSREF_EXE, {"mesh", (fs::path(TESSREF_SOURCE_DIR) / "data/scenes/jacksboro.toml").string(), "-o",
                                ply.string()})
                  .status,
              0);
    const RunResult r = tessref_check({ply.string(), "--image", png.string(), "--json"});
    ASSERT_EQ(r.status, 0) << r.out;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    const double extent_x = j["bbox"]["max"][0].get<double>() - j["bbox"]["min"][0].get<double>();
    OIIO::ImageBuf image(png.string());
    ASSERT_TRUE(image.read()) << image.geterror();
    const int w = image.spec().width, total = image.spec().height;
    const auto code = [&](int x, int y) {
        float rgb[3];
        image.getpixel(x, y, rgb);
        return std::array<int, 3>{int(std::lround(rgb[0] * 255)), int(std::lround(rgb[1] * 255)), int(std::lround(rgb[2] * 255))};
    };
    const auto black = [&](int x, int y) { return code(x, y) == std::array<int, 3>{0, 0, 0}; };
    // The view ends at the legend's black rule across the whole width.
    int h = -1;
    for (int y = 0; y < total && h < 0; ++y) {
        bool rule = true;
        for (int x = 0; x < w && rule; x += 7) rule = black(x, y);
        if (rule) h = y;
    }
    ASSERT_GT(h, 0);
    // The footprint: the box of the pixels that are not white.
    int x0 = w, x1 = -1, y0 = h, y1 = -1;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            if (code(x, y) != std::array<int, 3>{255, 255, 255}) {
                x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
            }
    ASSERT_GT(x1 - x0, 100);
    std::size_t white = 0;
    for (int y = y0 + 2; y <= y1 - 2; ++y)
        for (int x = x0 + 2; x <= x1 - 2; ++x) white += code(x, y) == std::array<int, 3>{255, 255, 255};
    EXPECT_EQ(white, 0u);
    // The scale bar: the longest run of black pixels under the rule.
    int longest = 0;
    for (int y = h + 1; y < total; ++y)
        for (int x = 0, run = 0; x < w; ++x) {
            run = black(x, y) ? run + 1 : 0;
            longest = std::max(longest, run);
        }
    // A round length at most a quarter of the width is more than a tenth of it (1, 2, 5 steps).
    EXPECT_GE(longest, w / 10 - 2);
    EXPECT_LE(longest, w / 4 + 2);
    const double pixels_per_unit = (x1 - x0 + 1) / extent_x;
    const double units = longest / pixels_per_unit;
    const double power = std::pow(10.0, std::floor(std::log10(units) + 1e-9));
    const double mantissa = units / power;
    EXPECT_TRUE(std::abs(mantissa - 1.0) < 0.03 || std::abs(mantissa - 2.0) < 0.06 || std::abs(mantissa - 5.0) < 0.15 ||
                std::abs(mantissa - 10.0) < 0.3)
        << longest << " px = " << units << " units";
}

TEST(CheckCommand, PictureMarksTheDefects) {
    // A directory of its own: the suite's scratch directory holds other tests' pictures when
    // the tests run in one process.
    const fs::path dir = scratch_dir() / "picture_marks_the_defects";
    fs::remove_all(dir);
    fs::create_directories(dir);
    const fs::path png = dir / "defects.png";
    const RunResult r = tessref_check({corpus("terrain_hole.obj").string(), "--image", png.string()});
    EXPECT_EQ(r.status, 1) << r.err;
    OIIO::ImageBuf image(png.string());
    ASSERT_TRUE(image.read()) << image.geterror();
    ASSERT_EQ(image.nchannels(), 3);
    // The hole is ringed in red (the boundary loop class colour) around its centre.
    const int w = image.spec().width, h = image.spec().height;
    EXPECT_EQ(w, 1024);
    std::size_t red = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float rgb[3];
            image.getpixel(x, y, rgb);
            red += rgb[0] > 0.8f && rgb[1] < 0.2f && rgb[2] < 0.2f;
        }
    EXPECT_GT(red, 20u);
    // Nothing is left behind but the picture.
    std::size_t files = 0;
    for (const auto& entry : fs::directory_iterator(dir)) files += entry.path().extension() == ".png";
    EXPECT_EQ(files, 1u);
}

// ---------------------------------------------------------------------------------------
// The check's tables

// 0 .. count - 1 in an order of their own (a Fisher-Yates shuffle by a 64-bit LCG from
// `seed`): vertex numbers that follow no grid or face order.
namespace {
std::vector<std::uint32_t> shuffled_ids(std::uint32_t count, std::uint64_t seed) {
    std::vector<std::uint32_t> ids(count);
    std::iota(ids.begin(), ids.end(), 0u);
    std::uint64_t random = seed;
    for (std::size_t i = ids.size(); i > 1; --i) {
        random = random * 6364136223846793005ULL + 1442695040888963407ULL;
        std::swap(ids[i - 1], ids[(random >> 33) % i]);
    }
    return ids;
}

// An n x n grid of vertices at (x, y, 0) whose numbers are shuffled_ids(n * n, seed), cut
// into two triangles a cell in grid order: the first triangle of cell (x, y) is face
// 2 (y (n - 1) + x). `shuffled` receives the numbers (the vertex at (x, y) is shuffled[y n + x]).
IndexedMesh shuffled_grid(std::uint32_t n, std::uint64_t seed, std::vector<std::uint32_t>& shuffled) {
    shuffled = shuffled_ids(n * n, seed);
    IndexedMesh mesh;
    mesh.positions.resize(shuffled.size());
    for (std::uint32_t i = 0; i < shuffled.size(); ++i) mesh.positions[shuffled[i]] = glm::dvec3(i % n, i / n, 0.0);
    const auto at = [&](std::uint32_t x, std::uint32_t y) { return shuffled[y * n + x]; };
    for (std::uint32_t y = 0; y + 1 < n; ++y)
        for (std::uint32_t x = 0; x + 1 < n; ++x) {
            mesh.add_triangle(at(x, y), at(x + 1, y), at(x + 1, y + 1));
            mesh.add_triangle(at(x, y), at(x + 1, y + 1), at(x, y + 1));
        }
    return mesh;
}
}  // namespace

// The corner table, made by parts of the faces in parallel, and the half-edges made from it
// (VertexStar), against the serial way: every kept face in face order, each entry
// appended to its vertex, the half-edge groups then sorted by (other vertex, face << 1 |
// forward). On a grid whose vertices are shuffled (each face's vertices far apart in the
// list), with a non-manifold edge, duplicate faces (same and other corner order), isolated
// vertices, a quad and a pentagon, faces left out (a repeated vertex, two vertices) and a
// fan of 64 faces, on 1, 2, 3 and 4 threads (1 to 4 parts; more than one part needs more
// faces than a chunk).
TEST(CheckTables, CornerAndHalfEdgeTablesAreTheSerialOnes) {
    using namespace tessref::check_detail;
    constexpr std::uint32_t n = 200;  // n x n vertices
    const std::vector<std::uint32_t> shuffled = shuffled_ids(n * n + 40, 7);
    IndexedMesh mesh;
    mesh.positions.resize(shuffled.size());
    for (std::uint32_t i = 0; i < shuffled.size(); ++i) mesh.positions[shuffled[i]] = glm::dvec3(i % n, i / n, 0.0);
    const auto at = [&](std::uint32_t x, std::uint32_t y) { return shuffled[y * n + x]; };
    const auto add = [&](std::vector<std::uint32_t> face) { mesh.add_face(face); };
    for (std::uint32_t y = 0; y + 1 < n; ++y)
        for (std::uint32_t x = 0; x + 1 < n; ++x) {
            if (x == 5 && y == 5) {
                add({at(x, y), at(x + 1, y), at(x + 1, y + 1), at(x, y + 1)});  // a quad
                continue;
            }
            add({at(x, y), at(x + 1, y), at(x + 1, y + 1)});
            add({at(x, y), at(x + 1, y + 1), at(x, y + 1)});
        }
    add({at(0, 0), at(1, 0), shuffled[n * n]});                               // a third face on edge (0,0)-(1,0)
    add({at(7, 7), at(8, 8), at(8, 7)});                                      // a duplicate, other order
    add({at(9, 9), at(10, 9), at(10, 10)});                                   // a duplicate, same order
    add({at(20, 20), at(20, 20), at(21, 20)});                                // a repeated vertex: left out
    add({at(30, 30), at(31, 30)});                                            // two vertices: left out
    add({shuffled[n * n + 1], shuffled[n * n + 2], shuffled[n * n + 3], shuffled[n * n + 4], shuffled[n * n + 5]});
    for (std::uint32_t k = 0; k < 64; ++k)  // a fan of 64 faces around vertex 0 (its 128 half-edges filed there)
        add({0u, at(40 + k % 50, 100 + k / 50), at(41 + k % 50, 100 + k / 50)});
    ASSERT_GT(mesh.face_count(), std::size_t(4) << 14);

    std::vector<std::uint8_t> status(mesh.face_count(), face_kept);
    status[mesh.face_count() - 66] = face_too_few_vertices;
    status[mesh.face_count() - 67] = face_repeated_vertex;

    // The serial tables.
    std::vector<std::vector<std::uint32_t>> corners(mesh.vertex_count());
    std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> groups(mesh.vertex_count());
    for (std::uint32_t f = 0; f < mesh.face_count(); ++f) {
        if (status[f] != face_kept) continue;
        const auto face = mesh.face(f);
        for (std::size_t k = 0; k < face.size(); ++k) {
            const std::uint32_t a = face[k], b = face[(k + 1) % face.size()];
            corners[a].push_back(f);
            groups[std::min(a, b)].emplace_back(std::max(a, b), f << 1 | (a < b ? 1u : 0u));
        }
    }
    for (auto& group : groups) std::sort(group.begin(), group.end());

    for (int threads : {1, 2, 3, 4}) {
        SCOPED_TRACE(threads);
        tbb::task_arena arena(threads);
        tessref::execute(arena, [&] {
            CheckReport report;
            CheckOptions options;
            CheckState state{mesh, options, report};
            state.face_status = status;
            build_corner_table(state);
            ASSERT_EQ(state.corner_start.size(), mesh.vertex_count() + 1);
            std::size_t corner_mismatches = 0, group_mismatches = 0;
            VertexStar star;
            for (std::uint32_t v = 0; v < mesh.vertex_count(); ++v) {
                const std::vector<std::uint32_t> corner(state.corner_faces.begin() + state.corner_start[v],
                                                        state.corner_faces.begin() + state.corner_start[v + 1]);
                corner_mismatches += corner != corners[v];
                star.make(state, v);
                std::vector<std::pair<std::uint32_t, std::uint32_t>> group;
                for (const HalfEdgeEntry& h : star.half_edges) group.emplace_back(h.other, h.face_and_direction);
                group_mismatches += group != groups[v];
            }
            EXPECT_EQ(corner_mismatches, 0u);
            EXPECT_EQ(group_mismatches, 0u);
            EXPECT_EQ(state.corner_start[mesh.vertex_count()], state.corner_faces.size());
        });
    }
}

// classify_edges finds the duplicate faces in its own pass, and leaves out of each edge the
// face that repeats an earlier one, not the earlier one: a square of two triangles whose
// first is listed again the other way round is consistently oriented (face 2, reversed, is
// the duplicate; were face 0 left out instead, the diagonal would run 0 -> 2 in both faces).
TEST(CheckTables, AnEdgeKeepsTheOriginalOfADuplicate) {
    IndexedMesh mesh;
    mesh.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    for (std::vector<std::uint32_t> face : {std::vector<std::uint32_t>{0, 1, 2}, {0, 2, 3}, {2, 1, 0}}) mesh.add_face(face);
    const CheckReport r = tessref::check_mesh(mesh, quick());
    ASSERT_EQ(r.count(DefectClass::duplicate_face), 1u);
    EXPECT_EQ(r.of(DefectClass::duplicate_face).locations[0].faces, (std::vector<std::uint32_t>{0, 2}));
    EXPECT_EQ(r.count(DefectClass::inconsistent_orientation), 0u);
    EXPECT_EQ(r.edge_count, 5u);
    EXPECT_EQ(r.boundary_edge_count, 4u);
    EXPECT_TRUE(r.manifold);
}

// The vertices' fans are found in the edges' pass, of the faces the corner table holds,
// which include the duplicates that pass is finding: where it finds any, the fans are found
// again without them. Two squares touching at vertex 0 (two fans there), the first square's
// first triangle listed again: the pinched vertex names its four faces, not the copy.
TEST(CheckTables, APinchedVertexNamesNoDuplicate) {
    IndexedMesh mesh;
    mesh.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {-1, 0, 0}, {-1, -1, 0}, {0, -1, 0}};
    for (std::vector<std::uint32_t> face :
         {std::vector<std::uint32_t>{0, 1, 2}, {0, 2, 3}, {0, 4, 5}, {0, 5, 6}, {0, 1, 2}})
        mesh.add_face(face);
    const CheckReport r = tessref::check_mesh(mesh, quick());
    ASSERT_EQ(r.count(DefectClass::duplicate_face), 1u);
    ASSERT_EQ(r.count(DefectClass::non_manifold_vertex), 1u);
    const tessref::Defect& pinch = r.of(DefectClass::non_manifold_vertex).locations[0];
    EXPECT_EQ(pinch.vertices, (std::vector<std::uint32_t>{0}));
    EXPECT_EQ(pinch.faces, (std::vector<std::uint32_t>{0, 1, 2, 3}));
    EXPECT_EQ(pinch.measure, 2.0);
}

// A duplicate face is found on each of its edges, filed under the edges' smaller vertices,
// so on a shuffled grid (40 000 vertices, three chunks) in several chunks: each is reported
// once, in face order, naming the earliest face over its vertex set, also when a face is
// listed four times (every copy names the first, not the copy before it).
TEST(CheckTables, DuplicatesNameTheirEarliestFaceAcrossChunks) {
    constexpr std::uint32_t n = 200;
    std::vector<std::uint32_t> shuffled;
    IndexedMesh mesh = shuffled_grid(n, 13, shuffled);
    const auto first_of = [&](std::uint32_t x, std::uint32_t y) { return 2 * (y * (n - 1) + x); };
    std::vector<std::vector<std::uint32_t>> expected;  // {original, copy} in copy order
    const auto copy = [&](std::uint32_t x, std::uint32_t y, int turn) {
        const std::uint32_t original = first_of(x, y);
        const auto f = mesh.face(original);
        const std::uint32_t a = f[0], b = f[1], c = f[2];
        const std::uint32_t copy_id = static_cast<std::uint32_t>(mesh.face_count());
        if (turn == 0) mesh.add_triangle(b, c, a);
        else if (turn == 1) mesh.add_triangle(c, a, b);
        else mesh.add_triangle(a, c, b);  // the other way round
        expected.push_back({original, copy_id});
    };
    copy(3, 3, 0);
    copy(150, 20, 2);
    copy(3, 3, 1);
    copy(60, 190, 0);
    copy(3, 3, 2);
    copy(198, 198, 1);
    const CheckReport r = tessref::check_mesh(mesh, quick(Expect::open));
    ASSERT_EQ(r.count(DefectClass::duplicate_face), expected.size());
    const auto& found = r.of(DefectClass::duplicate_face).locations;
    ASSERT_EQ(found.size(), expected.size());
    for (std::size_t k = 0; k < expected.size(); ++k) EXPECT_EQ(found[k].faces, expected[k]) << k;
    EXPECT_EQ(r.topology_excluded_faces, expected.size());
    EXPECT_TRUE(r.manifold);
    EXPECT_EQ(r.count(DefectClass::inconsistent_orientation), 0u);
}

// Components are numbered by their smallest vertex, chunk by chunk of the vertices in
// parallel: 5000 inside-out tetrahedra whose vertices are shuffled (20000 vertices, two
// chunks and more) each report their own number and first face, as the numbering in vertex
// order gives them.
TEST(CheckTables, ComponentsAreNumberedByTheirSmallestVertex) {
    constexpr std::uint32_t tetrahedra = 5000;
    const std::vector<std::uint32_t> shuffled = shuffled_ids(4 * tetrahedra, 11);
    IndexedMesh mesh;
    mesh.positions.resize(shuffled.size());
    const glm::dvec3 corner[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    std::vector<std::pair<std::uint32_t, std::uint32_t>> smallest;  // (smallest vertex, tetrahedron)
    for (std::uint32_t t = 0; t < tetrahedra; ++t) {
        const std::uint32_t* v = &shuffled[4 * t];
        for (int k = 0; k < 4; ++k) mesh.positions[v[k]] = corner[k] + glm::dvec3(3.0 * (t % 100), 3.0 * (t / 100), 0.0);
        // Wound inward: the outward faces (0 2 1), (0 1 3), (0 3 2), (1 2 3) reversed.
        for (const auto& f : {std::array<int, 3>{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}}) {
            const std::vector<std::uint32_t> face{v[f[0]], v[f[1]], v[f[2]]};
            mesh.add_face(face);
        }
        smallest.emplace_back(*std::min_element(v, v + 4), t);
    }
    std::sort(smallest.begin(), smallest.end());
    CheckOptions options = quick();
    options.ray_probe = false;
    options.max_locations = tetrahedra;
    const CheckReport r = tessref::check_mesh(mesh, options);
    EXPECT_EQ(r.component_count, tetrahedra);
    ASSERT_EQ(r.count(DefectClass::inverted_volume), tetrahedra);
    const auto& locations = r.of(DefectClass::inverted_volume).locations;
    ASSERT_EQ(locations.size(), tetrahedra);
    std::size_t wrong = 0;
    for (std::uint32_t c = 0; c < tetrahedra; ++c)
        wrong += locations[c].detail.find("closed component " + std::to_string(c) + " (4 faces, starting at face " +
                                          std::to_string(4 * smallest[c].second) + ")") == std::string::npos;
    EXPECT_EQ(wrong, 0u) << locations[0].detail;
}

// The coincident-vertex grid files the vertices a face uses, at finite positions, in
// parallel chunks (a vertex left out is filed under a code past every cell's and cut off),
// and a vertex near a face of its cell looks into the cell beyond: on a shuffled grid of 40 000 vertices (three chunks), separate triangles whose corners
// copy grid vertices exactly (each copy and its original one defect) or 1e-6 away (near
// ones), and vertices no face uses that copy grid vertices and each other (none of them
// reported, not even the two at one position, nor joined to the groups of the copies).
// With a tolerance of 1/64 (cells 32 times as wide: 0.5, from the box's corner at 0) a
// triangle copied 1e-3 below its originals in x is near too, each copy in the cell below
// its original's.
TEST(CheckTables, CoincidentVerticesAreTheFacesVerticesOnly) {
    constexpr std::uint32_t n = 200;
    std::vector<std::uint32_t> shuffled;
    IndexedMesh mesh = shuffled_grid(n, 17, shuffled);
    const auto at = [&](std::uint32_t x, std::uint32_t y) { return shuffled[y * n + x]; };
    const auto add_vertex = [&](glm::dvec3 p) {
        mesh.positions.push_back(p);
        return static_cast<std::uint32_t>(mesh.positions.size() - 1);
    };
    std::set<std::vector<std::uint32_t>> exact, near;  // each group's vertices, sorted
    std::set<std::vector<std::uint32_t>> across;  // near with the wider tolerance only
    const auto copy_triangle = [&](std::uint32_t x, std::uint32_t y, glm::dvec3 offset,
                                   std::set<std::vector<std::uint32_t>>& groups) {
        std::uint32_t copies[3];
        const std::uint32_t originals[3] = {at(x, y), at(x + 1, y), at(x, y + 1)};
        for (int k = 0; k < 3; ++k) {
            copies[k] = add_vertex(mesh.positions[originals[k]] + offset);
            groups.insert({std::min(originals[k], copies[k]), std::max(originals[k], copies[k])});
        }
        mesh.add_triangle(copies[0], copies[1], copies[2]);
    };
    copy_triangle(10, 10, glm::dvec3(0.0), exact);
    copy_triangle(150, 3, glm::dvec3(0.0), exact);
    copy_triangle(77, 190, glm::dvec3(0.0), exact);
    copy_triangle(120, 120, {0.0, 0.0, 1e-6}, near);
    copy_triangle(60, 61, {-1e-3, 0.0, 0.0}, across);
    // Vertices no face uses: copies of grid vertices (one of them a vertex copied above too)
    // and two at one position of their own.
    for (std::uint32_t k = 0; k < 50; ++k) add_vertex(mesh.positions[at(3 * k + 1, 2 * k + 5)]);
    add_vertex(mesh.positions[at(10, 10)]);
    add_vertex({500.0, 500.0, 7.0});
    add_vertex({500.0, 500.0, 7.0});
    CheckOptions options = quick(Expect::open);
    options.ray_probe = false;
    const auto groups = [&](const CheckReport& r, DefectClass kind) {
        std::set<std::vector<std::uint32_t>> found;
        for (const auto& d : r.of(kind).locations) found.insert(d.vertices);
        EXPECT_EQ(found.size(), r.count(kind));
        return found;
    };
    const CheckReport r = tessref::check_mesh(mesh, options);
    EXPECT_EQ(r.unreferenced_vertices, 53u);
    EXPECT_EQ(groups(r, DefectClass::coincident_vertices), exact);
    EXPECT_EQ(groups(r, DefectClass::near_coincident_vertices), near);
    options.tolerance = 1.0 / 64;
    const CheckReport wide = tessref::check_mesh(mesh, options);
    ASSERT_EQ(wide.bbox_min, glm::dvec3(0.0));
    EXPECT_EQ(groups(wide, DefectClass::coincident_vertices), exact);
    near.insert(across.begin(), across.end());
    EXPECT_EQ(groups(wide, DefectClass::near_coincident_vertices), near);
}
