// tests/test_scene.cpp — scenes (TOML) and the pipeline that runs them (tessref/scene.h).
//
// The contract checked here:
//  - every shipped scene in data/scenes/ loads and runs, in both precisions, and its mesh
//    is consistent (array lengths, indices in range, provenance of every vertex);
//  - crack freedom on every scene: for every edge shared by two patches, the outer level
//    each patch wrote for it is bitwise equal, and the positions the two patches emit on it
//    are bitwise equal as sets;
//  - every triangle faces up (terrain) or out (meshes), whatever the winding the scene asks
//    the generator for;
//  - the output is byte-identical with 1 and with 2 worker threads;
//  - a stage the scene does not name does not run;
//  - expected values with an independent reason: counts of uniform patterns (2 n^2
//    triangles for an n x n quad), the COSC422 ramp by hand, grid corners where the
//    scene's extent puts them, the PN flat-patch rule on the patches whose three normals
//    are equal, the budget estimate never below the real count;
//  - bad input throws tessref::Error whose where() names the scene file and the line,
//    column and key (malformed TOML, unknown key, unknown stage, wrong type, missing and
//    1x1 height maps, a quad mesh, a request beyond the triangle budget, a wrong [shading]
//    table or texture, found when the scene loads).
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <unistd.h>
#include <vector>

#include <OpenImageIO/imageio.h>
#include <tbb/global_control.h>

#include "tessref/error.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"

namespace fs = std::filesystem;
using namespace tessref;

namespace {

const fs::path kScenes = fs::path(TESSREF_DATA_DIR) / "scenes";

// The shipped scenes the C++ models compute: a scene with a [shaders] table (pn-culling)
// runs GLSL of its own through the interpreter, in gpu precision only and culling patches
// by design, and is held to llvmpipe instead (tests/test_user_shaders.cpp).
bool has_shaders_table(const fs::path& path) {
    std::ifstream in(path);
    for (std::string line; std::getline(in, line);)
        if (line.rfind("[shaders]", 0) == 0) return true;
    return false;
}

std::vector<std::string> shipped_scenes() {
    std::vector<std::string> out;
    for (const auto& entry : fs::directory_iterator(kScenes))
        if (entry.path().extension() == ".toml" && !has_shaders_table(entry.path())) out.push_back(entry.path().string());
    std::sort(out.begin(), out.end());
    return out;
}

std::string scene_name(const std::string& path) { return fs::path(path).stem().string(); }

// Loading and running every scene once per precision, shared by the tests below.
struct Ran {
    Scene scene;
    PipelineResult gpu;
    PipelineResult exact;
};
const Ran& ran(const std::string& path) {
    static std::map<std::string, Ran> cache;
    auto it = cache.find(path);
    if (it == cache.end()) {
        Ran r{load_scene(path), {}, {}};
        r.gpu = run_pipeline(r.scene, {Precision::gpu, {}, nullptr});
        r.exact = run_pipeline(r.scene, {Precision::exact, {}, nullptr});
        it = cache.emplace(path, std::move(r)).first;
    }
    return it->second;
}

std::array<std::uint64_t, 3> bits(const glm::dvec3& p) {
    return {std::bit_cast<std::uint64_t>(p.x), std::bit_cast<std::uint64_t>(p.y), std::bit_cast<std::uint64_t>(p.z)};
}

// A fresh directory for files a test writes, removed afterwards.
class TempDir {
public:
    TempDir() {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = fs::temp_directory_path() / ("tessref-test-scene-" + std::to_string(::getpid()) + "-" + info->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    ~TempDir() { fs::remove_all(dir_); }
    std::string write(const std::string& name, const std::string& text) const {
        const fs::path p = dir_ / name;
        std::ofstream(p, std::ios::binary) << text;
        return p.string();
    }
    std::string path(const std::string& name) const { return (dir_ / name).string(); }

private:
    fs::path dir_;
};

void write_gray_image(const std::string& path, int width, int height) {
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out);
    OIIO::ImageSpec spec(width, height, 1, OIIO::TypeDesc::UINT8);
    std::vector<std::uint8_t> pixels(static_cast<std::size_t>(width) * height, 128);
    ASSERT_TRUE(out->open(path, spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, pixels.data()));
    ASSERT_TRUE(out->close());
}

void write_rgb_image(const std::string& path, int width, int height) {
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out);
    OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
    std::vector<std::uint8_t> pixels(static_cast<std::size_t>(width) * height * 3, 64);
    ASSERT_TRUE(out->open(path, spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, pixels.data()));
    ASSERT_TRUE(out->close());
}

// A small valid terrain scene; tests replace parts of it.
std::string terrain_scene(const std::string& heightmap, const std::string& extra = "",
                          const std::string& geometry = "[geometry]\nnormals = \"smooth\"\n") {
    return "[scene]\nname = \"t\"\n\n"
           "[domain]\nplane = \"xy\"\npatches = [4, 3]\nx = [0.0, 8.0]\ny = [0.0, 6.0]\n"
           "heightmap = \"" + heightmap + "\"\nscale_xy = 8.0\nscale_z = 2.0\n\n"
           "[control]\nmodel = \"constant\"\nlevel = 3.0\n\n"
           "[evaluation]\nmodel = \"thesis\"\n\n" + geometry + extra;
}

// Expects load_scene(path) (or run) to throw an Error whose where() names `path` and,
// when given, the line and the key.
template <typename F>
Error expect_error(F&& f) {
    try {
        f();
    } catch (const Error& e) {
        return e;
    } catch (const std::exception& e) {
        ADD_FAILURE() << "not a tessref::Error: " << e.what();
        return Error("wrong type");
    }
    ADD_FAILURE() << "no error";
    return Error("none");
}

}  // namespace

// ---------------------------------------------------------------------------------------
// Shipped scenes
// ---------------------------------------------------------------------------------------

TEST(ShippedScenes, TheListedScenesExist) {
    std::set<std::string> names;
    for (const auto& p : shipped_scenes()) names.insert(scene_name(p));
    for (const char* expected :
         {"thesis-constant-1", "thesis-constant-64", "thesis-distance-4", "thesis-map-4", "thesis-map-18",
          "thesis-normal-2", "thesis-all-10", "thesis-all-16", "cosc422", "cosc422-eye", "lab4-canyon",
          "pn-triangles", "jacksboro", "olinda"})
        EXPECT_TRUE(names.count(expected)) << expected;
}

TEST(ShippedScenes, LoadRunAndAreConsistent) {
    for (const auto& path : shipped_scenes()) {
        SCOPED_TRACE(path);
        const Ran& r = ran(path);
        EXPECT_EQ(r.scene.name, scene_name(path));
        for (const PipelineResult* res : {&r.gpu, &r.exact}) {
            const SurfaceMesh& m = res->mesh;
            const std::size_t n = m.positions.size();
            EXPECT_GT(m.triangles.size(), 0u);
            EXPECT_EQ(m.patch_ids.size(), n);
            EXPECT_EQ(m.tess_coords.size(), n);
            EXPECT_TRUE(m.normals.empty() || m.normals.size() == n);
            EXPECT_TRUE(m.uvs.empty() || m.uvs.size() == n);
            EXPECT_EQ(res->levels.size(), r.scene.patch_count());
            EXPECT_LE(m.triangles.size(), res->estimated_triangles);
            for (const auto& t : m.triangles)
                for (auto v : t) ASSERT_LT(v, n);
            for (std::size_t v = 0; v < n; ++v) {
                ASSERT_LT(m.patch_ids[v], r.scene.patch_count());
                ASSERT_TRUE(std::isfinite(m.positions[v].x) && std::isfinite(m.positions[v].y) &&
                            std::isfinite(m.positions[v].z));
                if (v > 0) ASSERT_LE(m.patch_ids[v - 1], m.patch_ids[v]);  // patch order
            }
        }
        std::printf("  %-20s %6zu patches %9zu vertices %9zu triangles %6zu patterns\n", r.scene.name.c_str(),
                    r.scene.patch_count(), r.gpu.mesh.positions.size(), r.gpu.mesh.triangles.size(),
                    r.gpu.distinct_patterns);
    }
}

bool culled(const TessLevels& l, Domain domain) {
    const int n = domain == Domain::quads ? 4 : 3;
    for (int i = 0; i < n; ++i)
        if (!(l.outer[i] > 0.0f)) return true;
    return false;
}

// Crack freedom: shared edges get bitwise-equal levels and bitwise-equal vertex sets. A
// culled patch (a level NaN or <= 0) emits nothing: its edges are holes, not cracks, and
// are counted by NoPatchIsCulled instead.
void expect_crack_free(const std::string& path, const Scene& scene, const PipelineResult& res) {
    const auto edges = shared_edges(scene);
    ASSERT_FALSE(edges.empty()) << path;
    const Domain domain = scene.generator.domain;
    const int edges_per_patch = domain == Domain::quads ? 4 : 3;
    const SurfaceMesh& m = res.mesh;
    std::vector<std::vector<std::array<std::uint64_t, 3>>> on_edge(scene.patch_count() * edges_per_patch);
    for (std::size_t v = 0; v < m.positions.size(); ++v)
        for (int e = 0; e < edges_per_patch; ++e)
            if (on_outer_edge(domain, tessref::TessCoord{m.tess_coords[v].x, m.tess_coords[v].y, m.tess_coords[v].z}, e))
                on_edge[m.patch_ids[v] * edges_per_patch + e].push_back(bits(m.positions[v]));
    for (auto& list : on_edge) std::sort(list.begin(), list.end());
    std::size_t bad_levels = 0, bad_vertices = 0, checked = 0;
    for (const SharedEdge& s : edges) {
        const float la = res.levels[s.patch_a].outer[s.edge_a];
        const float lb = res.levels[s.patch_b].outer[s.edge_b];
        if (std::bit_cast<std::uint32_t>(la) != std::bit_cast<std::uint32_t>(lb) && bad_levels++ < 3)
            ADD_FAILURE() << "levels differ: patch " << s.patch_a << " edge " << s.edge_a << " = " << la << ", patch "
                          << s.patch_b << " edge " << s.edge_b << " = " << lb;
        if (culled(res.levels[s.patch_a], domain) || culled(res.levels[s.patch_b], domain)) continue;
        const auto& va = on_edge[s.patch_a * edges_per_patch + s.edge_a];
        const auto& vb = on_edge[s.patch_b * edges_per_patch + s.edge_b];
        if (va != vb && bad_vertices++ < 3)
            ADD_FAILURE() << "vertices differ on the edge between patch " << s.patch_a << " (edge " << s.edge_a << ", "
                          << va.size() << " vertices) and patch " << s.patch_b << " (edge " << s.edge_b << ", "
                          << vb.size() << " vertices)";
        checked += va.size();
    }
    EXPECT_EQ(bad_levels, 0u);
    EXPECT_EQ(bad_vertices, 0u);
    EXPECT_GT(checked, 0u);
}

TEST(ShippedScenes, SharedEdgesAreBitwiseEqualInGpuPrecision) {
    for (const auto& path : shipped_scenes()) {
        SCOPED_TRACE(path);
        const Ran& r = ran(path);
        expect_crack_free(path, r.scene, r.gpu);
    }
}

TEST(ShippedScenes, SharedEdgesAreBitwiseEqualInExactPrecision) {
    for (const auto& path : shipped_scenes()) {
        SCOPED_TRACE(path);
        const Ran& r = ran(path);
        expect_crack_free(path, r.scene, r.exact);
    }
}

// A culled patch leaves a hole in the terrain. The shipped scenes place their cameras so
// that no level model culls (COSC422's unclamped ramp would beyond eye-space z = -111).
TEST(ShippedScenes, NoPatchIsCulled) {
    for (const auto& path : shipped_scenes()) {
        const Ran& r = ran(path);
        // A geomipmapped terrain's levels are geomipmap levels (0 the finest), which no
        // primitive generator reads: nothing there is culled by a level.
        if (r.scene.evaluation.model == tessref::EvaluationModel::geomipmap) continue;
        for (const PipelineResult* res : {&r.gpu, &r.exact}) {
            std::size_t count = 0, nan_edges = 0;
            for (const auto& l : res->levels) {
                count += culled(l, r.scene.generator.domain);
                for (float f : l.outer) nan_edges += std::isnan(f);
            }
            EXPECT_EQ(count, 0u) << path << (res == &r.gpu ? " gpu: " : " exact: ") << count << " of "
                                 << res->levels.size() << " patches culled, " << nan_edges << " outer levels NaN";
        }
    }
}

// Every triangle is counter-clockwise seen from above (terrain) or outside (meshes).
TEST(ShippedScenes, TrianglesFaceUpOrOut) {
    for (const auto& path : shipped_scenes()) {
        SCOPED_TRACE(path);
        const Ran& r = ran(path);
        const SurfaceMesh& m = r.exact.mesh;
        std::size_t wrong = 0, degenerate = 0;
        for (const auto& t : m.triangles) {
            const glm::dvec3 a = m.positions[t[0]], b = m.positions[t[1]], c = m.positions[t[2]];
            const glm::dvec3 n = glm::cross(b - a, c - a);
            glm::dvec3 reference;
            if (r.scene.grid) {
                reference = r.scene.grid->plane == GroundPlane::xy ? glm::dvec3(0, 0, 1) : glm::dvec3(0, 1, 0);
            } else {
                // The flat patch the triangle came from (its file face is ccw seen from outside).
                const auto& tri = r.scene.meshes->triangles[m.patch_ids[t[0]]];
                const auto& P = r.scene.meshes->positions;
                reference = glm::cross(P[tri[1]] - P[tri[0]], P[tri[2]] - P[tri[0]]);
            }
            const double d = glm::dot(n, reference);
            if (d == 0.0) ++degenerate;
            if (d < 0.0) ++wrong;
        }
        EXPECT_EQ(wrong, 0u);
        EXPECT_LT(degenerate, m.triangles.size() / 100 + 1);
    }
}

TEST(ShippedScenes, SameBytesWithOneAndTwoThreads) {
    for (const auto& path : shipped_scenes()) {
        SCOPED_TRACE(path);
        const Scene scene = load_scene(path);
        PipelineResult one, two;
        {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
            one = run_pipeline(scene);
        }
        {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
            two = run_pipeline(scene);
        }
        auto same = [](const auto& a, const auto& b) {
            return a.size() == b.size() &&
                   (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0);
        };
        EXPECT_TRUE(same(one.mesh.positions, two.mesh.positions));
        EXPECT_TRUE(same(one.mesh.normals, two.mesh.normals));
        EXPECT_TRUE(same(one.mesh.uvs, two.mesh.uvs));
        EXPECT_TRUE(same(one.mesh.patch_ids, two.mesh.patch_ids));
        EXPECT_TRUE(same(one.mesh.tess_coords, two.mesh.tess_coords));
        EXPECT_TRUE(same(one.mesh.triangles, two.mesh.triangles));
        EXPECT_TRUE(same(one.face_normals, two.face_normals));
        EXPECT_TRUE(same(one.levels, two.levels));
    }
}

// ---------------------------------------------------------------------------------------
// Expected values with an independent reason
// ---------------------------------------------------------------------------------------

// Level 1 leaves the patch as the vertex shader made it: 2 triangles and the 4 corners,
// which sit on the grid the extent [0, 128]^2 / 16 patches defines (multiples of 8).
TEST(Pipeline, ConstantOneEmitsTheGrid) {
    const Ran& r = ran((kScenes / "thesis-constant-1.toml").string());
    const SurfaceMesh& m = r.gpu.mesh;
    ASSERT_EQ(m.triangles.size(), 16u * 16u * 2u);
    ASSERT_EQ(m.positions.size(), 16u * 16u * 4u);
    for (std::size_t v = 0; v < m.positions.size(); ++v) {
        const std::uint32_t p = m.patch_ids[v];
        const double x = 8.0 * (p % 16 + m.tess_coords[v].x), y = 8.0 * (p / 16 + m.tess_coords[v].y);
        EXPECT_EQ(m.positions[v].x, x);
        EXPECT_EQ(m.positions[v].y, y);
        EXPECT_GE(m.positions[v].z, 0.0);
        EXPECT_LE(m.positions[v].z, 24.0);  // sample in [0, 1] times scale_z
    }
}

// Level 64 under fractional_odd spacing is clamped to 63 (an odd integer: uniform cuts),
// so every patch is a 63 x 63 grid: 2 * 63^2 triangles and 64^2 points.
TEST(Pipeline, ConstantSixtyFourIsSixtyThreeUnderFractionalOdd) {
    const Ran& r = ran((kScenes / "thesis-constant-64.toml").string());
    EXPECT_EQ(r.gpu.mesh.triangles.size(), 256u * 2u * 63u * 63u);
    EXPECT_EQ(r.gpu.mesh.positions.size(), 256u * 64u * 64u);
    EXPECT_EQ(r.gpu.distinct_patterns, 1u);  // every patch shares one pattern
}

// The COSC422 ramp by hand: patch 0's v = 0 edge lies at z = 0 in world space, so its
// level is (0 + 100) * 18 / 100 + 2 = 20; the last row's far edge lies at z = -100: 2.
TEST(Pipeline, Cosc422WorldRampByHand) {
    const Ran& r = ran((kScenes / "cosc422.toml").string());
    const TerrainGrid& g = *r.scene.grid;
    EXPECT_EQ(g.patches_u, 9);
    EXPECT_EQ(g.patches_v, 9);
    EXPECT_EQ(r.gpu.levels[0].outer[1], 20.0f);
    EXPECT_EQ(r.gpu.levels[r.scene.patch_count() - 1].outer[3], 2.0f);
    // Every vertex's height is the sample times 10: within [0, 10].
    for (const auto& p : r.gpu.mesh.positions) {
        EXPECT_GE(p.y, 0.0);
        EXPECT_LE(p.y, 10.0);
    }
}

// Lab 4's levels are powers of two (equal spacing); its grid sits on multiples of the
// patch size around the camera.
TEST(Pipeline, Lab4LevelsArePowersOfTwoAndTheGridIsSnapped) {
    const Ran& r = ran((kScenes / "lab4-canyon.toml").string());
    for (const auto& l : r.gpu.levels)
        for (float f : {l.outer[0], l.outer[1], l.outer[2], l.outer[3], l.inner[0], l.inner[1]}) {
            int e = 0;
            EXPECT_EQ(std::frexp(f, &e), 0.5f) << f;
        }
    const TerrainGrid& g = *r.scene.grid;
    for (double u : g.u_coords) EXPECT_EQ(std::fmod(u, g.patch_size), 0.0);
    for (double v : g.v_coords) EXPECT_EQ(std::fmod(v, g.patch_size), 0.0);
    const glm::dvec3 eye = r.scene.camera->eye;
    EXPECT_LE(g.u_coords.front(), eye.x);
    EXPECT_GE(g.u_coords.back(), eye.x);
    EXPECT_GE(g.v_coords.front(), eye.z);  // z descending
    EXPECT_LE(g.v_coords.back(), eye.z);
}

// The tutorial's extra 36: a patch whose three normals are equal is flat and gets level 1
// everywhere; the bump mesh has such patches (its flat margin).
TEST(Pipeline, PnFlatPatchesAtLevelOne) {
    const Ran& r = ran((kScenes / "pn-triangles.toml").string());
    const TriangleMeshes& m = *r.scene.meshes;
    std::size_t flat = 0;
    for (std::size_t p = 0; p < m.triangles.size(); ++p) {
        const auto& t = m.triangles[p];
        if (m.normals[t[0]] == m.normals[t[1]] && m.normals[t[1]] == m.normals[t[2]]) {
            ++flat;
            const TessLevels& l = r.gpu.levels[p];
            EXPECT_EQ(l.outer[0], 1.0f);
            EXPECT_EQ(l.outer[1], 1.0f);
            EXPECT_EQ(l.outer[2], 1.0f);
            EXPECT_EQ(l.inner[0], 1.0f);
        }
    }
    EXPECT_GT(flat, 0u);
    // And the evaluation's normals reach the mesh (no [geometry] in this scene).
    EXPECT_EQ(r.gpu.mesh.normals.size(), r.gpu.mesh.positions.size());
}

// The budget estimate is an upper bound of what the generator emits.
TEST(Pipeline, EstimateIsAnUpperBound) {
    PatternCache cache;
    for (Domain domain : {Domain::quads, Domain::triangles})
        for (Spacing spacing : {Spacing::equal, Spacing::fractional_odd, Spacing::fractional_even})
            for (float a : {0.5f, 1.0f, 1.5f, 2.0f, 3.3f, 7.0f, 16.9f, 33.0f, 64.0f, 80.0f})
                for (float b : {1.0f, 2.5f, 9.0f, 63.5f}) {
                    TessSettings s{domain, spacing, Winding::ccw, false};
                    TessLevels l;
                    l.outer = {a, b, a, b};
                    l.inner = {b, a};
                    const auto pattern = cache.get(s, l);
                    EXPECT_GE(estimate_triangles(s, l), pattern->primitive_count())
                        << to_string(domain) << " " << to_string(spacing) << " " << a << " " << b;
                }
    TessLevels culled;
    culled.outer[2] = 0.0f;
    EXPECT_EQ(estimate_triangles({Domain::quads, Spacing::equal, Winding::ccw, false}, culled), 0u);
}

// A cw winding is undone by the pipeline: the same triangles, still facing up.
TEST(Pipeline, ClockwiseWindingStillFacesUp) {
    const std::string path = (kScenes / "thesis-all-10.toml").string();
    std::ifstream in(path);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto at = text.find("winding = \"ccw\"");
    ASSERT_NE(at, std::string::npos);
    text.replace(at, 15, "winding = \"cw\" ");
    const Scene cw = load_scene_from_string(text, path);
    EXPECT_EQ(cw.generator.winding, Winding::cw);
    const PipelineResult a = run_pipeline(cw);
    const PipelineResult& b = ran(path).gpu;
    ASSERT_EQ(a.mesh.positions, b.mesh.positions);
    ASSERT_EQ(a.mesh.triangles.size(), b.mesh.triangles.size());
    auto canonical = [](std::array<std::uint32_t, 3> t) {  // rotate the smallest index first
        while (t[0] != std::min({t[0], t[1], t[2]})) t = {t[1], t[2], t[0]};
        return t;
    };
    std::vector<std::array<std::uint32_t, 3>> ta, tb;
    for (const auto& t : a.mesh.triangles) ta.push_back(canonical(t));
    for (const auto& t : b.mesh.triangles) tb.push_back(canonical(t));
    std::sort(ta.begin(), ta.end());
    std::sort(tb.begin(), tb.end());
    EXPECT_EQ(ta, tb);
}

TEST(Pipeline, ProgressReachesTheTotal) {
    const Scene scene = load_scene((kScenes / "cosc422.toml").string());
    std::size_t last = 0, calls = 0, total_seen = 0;
    bool monotonic = true;
    PipelineOptions options;
    options.progress = [&](std::size_t done, std::size_t total) {
        monotonic = monotonic && done >= last;
        last = done;
        total_seen = total;
        ++calls;
    };
    run_pipeline(scene, options);
    EXPECT_TRUE(monotonic);
    EXPECT_EQ(last, scene.patch_count());
    EXPECT_EQ(total_seen, scene.patch_count());
    EXPECT_EQ(calls, scene.patch_count());
}

// ---------------------------------------------------------------------------------------
// A stage the scene does not name does not run
// ---------------------------------------------------------------------------------------

TEST(Stages, WithoutGeometryThereAreNoNormals) {
    TempDir dir;
    write_gray_image(dir.path("h.pgm"), 8, 8);
    const Scene with = load_scene(dir.write("with.toml", terrain_scene("h.pgm")));
    const Scene without = load_scene(dir.write("without.toml", terrain_scene("h.pgm", "", "")));
    const PipelineResult a = run_pipeline(with), b = run_pipeline(without);
    EXPECT_TRUE(a.stages.geometry);
    EXPECT_EQ(a.mesh.normals.size(), a.mesh.positions.size());
    EXPECT_FALSE(b.stages.geometry);
    EXPECT_TRUE(b.mesh.normals.empty());
    EXPECT_TRUE(b.face_normals.empty());
    EXPECT_EQ(a.mesh.positions, b.mesh.positions);
}

TEST(Stages, WithoutControlEveryLevelIsOne) {
    TempDir dir;
    write_gray_image(dir.path("h.pgm"), 8, 8);
    std::string text = terrain_scene("h.pgm");
    text.replace(text.find("[control]"), std::string("[control]\nmodel = \"constant\"\nlevel = 3.0\n").size(), "");
    const Scene scene = load_scene(dir.write("s.toml", text));
    EXPECT_FALSE(scene.control.has_value());
    const PipelineResult r = run_pipeline(scene);
    EXPECT_FALSE(r.stages.control);
    for (const auto& l : r.levels) {
        for (float f : l.outer) EXPECT_EQ(f, 1.0f);
        for (float f : l.inner) EXPECT_EQ(f, 1.0f);
    }
    EXPECT_EQ(r.mesh.triangles.size(), 2u * scene.patch_count());
}

// The thesis's normal map is made only when a stage reads it.
TEST(Stages, NoNormalMapUnlessAStageReadsIt) {
    TempDir dir;
    write_gray_image(dir.path("h.pgm"), 8, 8);
    const Scene smooth = load_scene(dir.write("a.toml", terrain_scene("h.pgm")));
    EXPECT_EQ(smooth.grid->normal_map, nullptr);
    const Scene mapped =
        load_scene(dir.write("b.toml", terrain_scene("h.pgm", "", "[geometry]\nnormals = \"normal_map\"\n")));
    ASSERT_NE(mapped.grid->normal_map, nullptr);
    EXPECT_EQ(mapped.grid->normal_map->channels(), 3);
}

// ---------------------------------------------------------------------------------------
// Bad input
// ---------------------------------------------------------------------------------------

class BadScene : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = std::make_unique<TempDir>();
        write_gray_image(dir_->path("h.pgm"), 8, 8);
    }
    // Loads `text` as a scene file and returns the error it throws.
    Error load_error(const std::string& text) {
        const std::string path = dir_->write("bad.toml", text);
        path_ = path;
        return expect_error([&] { load_scene(path); });
    }
    std::unique_ptr<TempDir> dir_;
    std::string path_;
};

TEST_F(BadScene, MalformedToml) {
    const Error e = load_error("[scene]\nname = \"x\"\n\n[domain\nplane = \"xy\"\n");
    EXPECT_EQ(e.where().file, path_);
    EXPECT_EQ(e.where().line, 4);
    EXPECT_GT(e.where().column, 0);
    EXPECT_NE(std::string(e.what()).find("malformed TOML"), std::string::npos) << e.what();
}

// The gpu precision computes in float: a value beyond float's range (scale_z = 1e39 gave an
// empty mesh and picture) or nonzero below its normal range (scale_xy = 1e-45 gave infinite
// texture coordinates) is refused, naming the key and the file. 0 and float's extremes stay
// accepted where the key's own range allows them.
TEST_F(BadScene, ValuesOutsideFloatsRangeAreRefused) {
    struct Case {
        std::string from, to, key;
    };
    for (const Case& c : std::vector<Case>{{"scale_z = 2.0", "scale_z = 1e39", "domain.scale_z"},
                                           {"scale_z = 2.0", "scale_z = -1e39", "domain.scale_z"},
                                           {"scale_xy = 8.0", "scale_xy = 1e-45", "domain.scale_xy"},
                                           {"scale_z = 2.0", "scale_z = 1e-40", "domain.scale_z"},
                                           {"x = [0.0, 8.0]", "x = [0.0, 1e300]", "domain.x[1]"}}) {
        std::string text = terrain_scene("h.pgm");
        text.replace(text.find(c.from), c.from.size(), c.to);
        const Error e = load_error(text);
        EXPECT_EQ(e.where().file, path_) << c.to;
        EXPECT_EQ(e.where().key, c.key) << c.to << ": " << e.what();
        EXPECT_NE(std::string(e.what()).find("float"), std::string::npos) << e.what();
    }
    for (const std::string value : {"0.0", "3.4e38", "-3.4e38", "1.2e-38"}) {
        std::string text = terrain_scene(dir_->path("h.pgm"));
        text.replace(text.find("scale_z = 2.0"), 13, "scale_z = " + value);
        const std::string path = dir_->write("ok.toml", text);
        EXPECT_NO_THROW(load_scene(path)) << value;
    }
}

TEST_F(BadScene, UnknownKey) {
    std::string text = terrain_scene("h.pgm");
    text.replace(text.find("level = 3.0"), 11, "levle = 3.0");
    const Error e = load_error(text);
    EXPECT_EQ(e.where().file, path_);
    EXPECT_EQ(e.where().key, "control.levle");
    EXPECT_GT(e.where().line, 0);
    EXPECT_GT(e.where().column, 0);
}

TEST_F(BadScene, KeyNotUsedByTheModel) {
    // A COSC422 key on the constant model: known, but not used by it.
    std::string text = terrain_scene("h.pgm");
    text.replace(text.find("level = 3.0"), 11, "level = 3.0\nspace = \"eye\"");
    const Error e = load_error(text);
    EXPECT_EQ(e.where().key, "control.space");
    EXPECT_GT(e.where().line, 0);
    EXPECT_NE(std::string(e.what()).find("not used by control model constant"), std::string::npos) << e.what();
}

TEST_F(BadScene, UnknownStage) {
    const Error e = load_error(terrain_scene("h.pgm", "\n[rasterizer]\nmode = \"fill\"\n"));
    EXPECT_EQ(e.where().file, path_);
    EXPECT_EQ(e.where().key, "rasterizer");
    EXPECT_GT(e.where().line, 0);
    EXPECT_NE(std::string(e.what()).find("unknown stage"), std::string::npos) << e.what();
}

// ---- [shading]: read with the rest of the scene, its textures loaded -------------------

TEST_F(BadScene, ShadingTableIsReadWithTheScene) {
    write_gray_image(dir_->path("grey.png"), 4, 4);
    const std::string path = dir_->write(
        "ok.toml", terrain_scene("h.pgm", "\n[shading]\nmodel = \"thesis_single\"\nbackground = [0.25, 0.5, 0.75]\n"
                                          "shininess = 8\ntextures = { diffuse = { path = \"grey.png\", luminance = true } }\n"));
    const Scene scene = load_scene(path);
    EXPECT_EQ(scene.shading.model.kind, ShadingKind::thesis_single);
    EXPECT_EQ(scene.shading.background, glm::vec4(0.25f, 0.5f, 0.75f, 1.0f));  // alpha 1 when left out
    EXPECT_EQ(scene.shading.model.thesis.shininess, 8.0f);
    EXPECT_EQ(scene.shading.model.thesis.lightPosition, ThesisLight{}.lightPosition);  // not given: the default
    ASSERT_TRUE(scene.shading.model.textures.diffuse);
    EXPECT_EQ(scene.shading.model.textures.diffuse->channels(), 1);  // luminance: read as (r, r, r, 1)
    EXPECT_EQ(scene.shading.model.textures.diffuse->swizzle(), Swizzle::luminance);

    // Without [shading]: depth, linear mapping (no camera here: its default planes).
    const Scene plain = load_scene(dir_->write("plain.toml", terrain_scene("h.pgm")));
    EXPECT_EQ(plain.shading.model.kind, ShadingKind::depth);
    EXPECT_EQ(plain.shading.model.depth.mapping, DepthMapping::linear);
    EXPECT_EQ(plain.shading.model.depth.far_plane, static_cast<float>(SceneCamera{}.far_plane));
}

TEST_F(BadScene, ShadingTableErrorsAtLoadNameLineAndKey) {
    write_rgb_image(dir_->path("rgb.png"), 4, 4);
    const std::string head = terrain_scene("h.pgm") + "\n[shading]\n";
    const int header_line = static_cast<int>(std::count(head.begin(), head.end(), '\n'));
    struct Case {
        std::string table;
        std::vector<std::string> message;  // substrings of what()
        std::string key;
        int line_offset;  // line of the key after the [shading] header
    };
    const std::vector<Case> cases{
        {"model = \"phong\"\n", {"unknown shading model 'phong'"}, "shading.model", 1},
        {"model = 3\n", {"shading.model must be a string"}, "shading.model", 1},
        {"modle = \"flat\"\n", {"unknown key shading.modle"}, "shading.modle", 1},
        {"model = \"depth\"\nshininess = 3\n", {"not used by shading model depth"}, "shading.shininess", 2},
        {"model = \"depth\"\nmapping = \"log\"\n", {"\"log\"", "linear"}, "shading.mapping", 2},
        {"model = \"flat\"\ncolour = [1, 2]\n", {"array of 3 or 4 numbers"}, "shading.colour", 2},
        {"model = \"flat\"\ncolour = [1, 2, \"a\"]\n", {"must be a number"}, "shading.colour[2]", 2},
        {"background = 1\n", {"array of 3 or 4 numbers"}, "shading.background", 1},
        // GLSL leaves pow(0, y <= 0), smoothstep(e0, e1, x) with e0 >= e1 and normalize(0)
        // undefined: such uniforms have no reference image.
        {"model = \"pn\"\nshininess = 0\n", {"out of range (0, "}, "shading.shininess", 2},
        {"model = \"lab4\"\nblend_width = -1\n", {"out of range (0, "}, "shading.blend_width", 2},
        {"model = \"lab4\"\nsand_height = 1e9\nblend_width = 1\n", {"smoothstep"}, "shading.blend_width", 3},
        {"model = \"cosc422\"\nlight_direction = [0, 0, 0]\n", {"cannot be normalized"},
         "shading.light_direction", 2},
        {"model = \"thesis_single\"\nlight_position = [0, 0, -1]\ntextures = { diffuse = [1, 1, 1] }\n",
         {"light_position + (0, 0, 1)"}, "shading.light_position", 2},
        // Textures.
        {"model = \"thesis_single\"\n", {"samples diffuse", "shading.textures"}, "shading.textures", 1},
        {"model = \"thesis_single\"\ntextures = 3\n", {"must be a table"}, "shading.textures", 2},
        {"model = \"pn\"\ntextures = { diffuse = [1, 1, 1, 1] }\n", {"has no sampler 'diffuse'"},
         "shading.textures.diffuse", 2},
        {"model = \"thesis_single\"\ntextures = { diffuse = 3 }\n", {"must be a path"}, "shading.textures.diffuse", 2},
        {"model = \"thesis_single\"\ntextures = { diffuse = [1, 1] }\n", {"array of 3 or 4 numbers"},
         "shading.textures.diffuse", 2},
        {"model = \"thesis_single\"\ntextures = { diffuse = \"nowhere.png\" }\n",
         {"cannot load texture", dir_->path("nowhere.png")}, "shading.textures.diffuse", 2},
        {"model = \"thesis_single\"\ntextures = { diffuse = \"\" }\n", {"must name an image"},
         "shading.textures.diffuse", 2},
        {"model = \"thesis_single\"\ntextures = { diffuse = { luminance = true } }\n",
         {"missing key shading.textures.diffuse.path"}, "shading.textures.diffuse.path", 2},
        {"model = \"thesis_single\"\ntextures = { diffuse = { path = \"h.pgm\", luminance = 1 } }\n",
         {"must be a boolean"}, "shading.textures.diffuse.luminance", 2},
        {"model = \"thesis_single\"\ntextures = { diffuse = { path = \"h.pgm\", swizzle = 1 } }\n",
         {"unknown key shading.textures.diffuse.swizzle"}, "shading.textures.diffuse.swizzle", 2},
        {"model = \"thesis_single\"\ntextures = { diffuse = { path = \"rgb.png\", luminance = true } }\n",
         {"one-channel", "has 3"}, "shading.textures.diffuse.luminance", 2},
    };
    for (const Case& c : cases) {
        const Error e = load_error(head + c.table);
        for (const std::string& part : c.message)
            EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << c.table << e.message();
        EXPECT_EQ(e.where().key, c.key) << c.table << e.message();
        EXPECT_EQ(e.where().file, path_);
        EXPECT_EQ(e.where().line, header_line + c.line_offset) << c.table << e.message();
        EXPECT_GT(e.where().column, 0) << c.table << e.message();
    }
}

TEST_F(BadScene, ShadingErrorsOfATextNotOnDiskHaveTheirPlace) {
    // The table is read from the text given: its place is known though no file holds it.
    const std::string text =
        terrain_scene(dir_->path("h.pgm"), "\n[shading]\nmodel = \"flat\"\ncolour = [1, 0, 0, 1, 0]\n");
    const std::string path = dir_->path("not-on-disk.toml");
    const Error e = expect_error([&] { load_scene_from_string(text, path); });
    EXPECT_EQ(e.where().file, path);
    EXPECT_EQ(e.where().key, "shading.colour");
    EXPECT_EQ(e.where().line, static_cast<int>(std::count(text.begin(), text.end(), '\n')));
    EXPECT_EQ(e.where().column, 10);
}

TEST_F(BadScene, WrongType) {
    std::string text = terrain_scene("h.pgm");
    text.replace(text.find("level = 3.0"), 11, "level = \"3\"");
    const Error e = load_error(text);
    EXPECT_EQ(e.where().file, path_);
    EXPECT_EQ(e.where().key, "control.level");
    EXPECT_GT(e.where().line, 0);
    EXPECT_NE(std::string(e.what()).find("must be a number"), std::string::npos) << e.what();
}

TEST_F(BadScene, OutOfRange) {
    std::string text = terrain_scene("h.pgm");
    text.replace(text.find("patches = [4, 3]"), 16, "patches = [4, 0]");
    const Error e = load_error(text);
    EXPECT_EQ(e.where().file, path_);
    EXPECT_EQ(e.where().key, "domain.patches[1]");
    EXPECT_GT(e.where().line, 0);
}

TEST_F(BadScene, MissingHeightMap) {
    const Error e = load_error(terrain_scene("nowhere.pgm"));
    EXPECT_EQ(e.where().file, path_);
    EXPECT_EQ(e.where().key, "domain.heightmap");
    EXPECT_GT(e.where().line, 0);
    EXPECT_NE(std::string(e.what()).find("nowhere.pgm"), std::string::npos) << e.what();
}

TEST_F(BadScene, OneByOneHeightMap) {
    write_gray_image(dir_->path("tiny.pgm"), 1, 1);
    const Error e = load_error(terrain_scene("tiny.pgm"));
    EXPECT_EQ(e.where().file, path_);
    EXPECT_EQ(e.where().key, "domain.heightmap");
    EXPECT_GT(e.where().line, 0);
    EXPECT_NE(std::string(e.what()).find("tiny.pgm"), std::string::npos) << e.what();
}

TEST_F(BadScene, MeshWithAQuadFace) {
    dir_->write("quad.off", "OFF\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 0.5 1\n4 0 1 2 3\n3 1 0 4\n");
    const Error e = load_error(
        "[scene]\nname = \"q\"\n[mesh]\npath = \"quad.off\"\n[evaluation]\nmodel = \"pn\"\n");
    EXPECT_EQ(e.where().file, path_);
    EXPECT_EQ(e.where().key, "mesh.path");
    EXPECT_EQ(e.where().line, 4);
    EXPECT_NE(std::string(e.what()).find("4 vertices"), std::string::npos) << e.what();
}

TEST_F(BadScene, GridBeyondTheBudget) {
    std::string text = terrain_scene("h.pgm", "\n[limits]\nmax_triangles = 10\n");
    const Error e = load_error(text);  // 12 patches: at least 24 triangles
    EXPECT_EQ(e.where().file, path_);
    EXPECT_EQ(e.where().key, "domain.patches");
    EXPECT_GT(e.where().line, 0);
}

TEST_F(BadScene, LevelsBeyondTheBudget) {
    // 12 patches at level 3: 12 * 18 = 216 triangles; the estimate is at least that.
    const std::string path = dir_->write("big.toml", terrain_scene("h.pgm", "\n[limits]\nmax_triangles = 100\n"));
    const Scene scene = load_scene(path);  // the grid alone fits
    const Error e = expect_error([&] { run_pipeline(scene); });
    EXPECT_EQ(e.where().file, path);
    EXPECT_EQ(e.where().key, "limits.max_triangles");
    EXPECT_GT(e.where().line, 0);
    EXPECT_NE(std::string(e.what()).find("max_triangles"), std::string::npos) << e.what();
}

TEST_F(BadScene, MissingSceneFile) {
    const std::string path = dir_->path("absent.toml");
    const Error e = expect_error([&] { load_scene(path); });
    EXPECT_EQ(e.where().file, path);
}

TEST_F(BadScene, ModelsThatDoNotFit) {
    // The lab 4 evaluation reads the lab 4 control stage's mip levels.
    std::string text = terrain_scene("h.pgm");
    text.replace(text.find("plane = \"xy\""), 12, "plane = \"xz\"");
    text.replace(text.find("y = [0.0, 6.0]"), 14, "z = [0.0, -6.0]");
    text.replace(text.find("model = \"thesis\""), 16, "model = \"lab4\"");
    const Error e = load_error(text);
    EXPECT_EQ(e.where().key, "evaluation.model");
    EXPECT_GT(e.where().line, 0);
}
