// Tests of `tessref sweep` (src/sweep/, src/cli/cmd_sweep.cpp, docs/SWEEP.md).
//
// Where the expected values come from:
//  - the geometric error (src/sweep/geometric_error.h) against hand-derived values: a flat
//    height map gives a flat tessellation and a flat truth, so 0 at every level and spacing;
//    one raised texel under a level-1 patch is a hat function of the truth's triangulation,
//    whose maximum and area-weighted RMS follow from the hat's shape (worked out below); a
//    ridge along a tessellation edge over a valley of the truth is largest where the edge
//    crosses a texel grid line, where no vertex of either surface lies;
//  - the pipeline's timings: the same mesh with and without asking for them;
//  - the command: row counts from the definition (scenes x (precisions own rows + spacings
//    x precisions x levels)), row order, sharded runs merged against the unsharded run,
//    refusals (exit 2, nothing written), the SLURM variables.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include "command_dir_test.h"
#include "extremes/extremes.h"
#include "run_program.h"
#include "sweep/geometric_error.h"
#include "sweep/report_data.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"
#include "tessref/scene.h"

namespace fs = std::filesystem;

namespace {

using tessref::test::CommandDirTest;
using tessref::test::read_file;
using tessref::test::RunResult;
using tessref::test::write_file;
using tessref::test::extremes::Terrain;
using tessref::test::extremes::write_pgm;

const fs::path kSource = TESSREF_SOURCE_DIR;

// ---- the geometric error, by hand -----------------------------------------------------------

// A one-patch thesis terrain over [0, 8]^2 (texture coordinate = xy / 8), constant level,
// written with its height map into `dir`.
struct OnePatch {
    fs::path dir;
    int width = 4, height = 4;
    std::vector<int> codes = std::vector<int>(16, 0);
    double scale_z = 2.0;
    double level = 1.0;
    std::string spacing = "fractional_odd";

    tessref::Scene scene() const {
        write_pgm(dir / "map.pgm", width, height, 255, codes);
        Terrain t;
        t.nu = t.nv = 1;
        t.heightmap = "map.pgm";
        t.scale_z = scale_z;
        t.spacing = spacing;
        t.control = "model = \"constant\"\nlevel = " + tessref::test::extremes::num(level);
        const fs::path file = dir / "scene.toml";
        write_file(file, t.toml());
        return tessref::load_scene(file.string());
    }
};

tessref::sweep::GeometricError error_of(const tessref::Scene& scene, tessref::Precision precision,
                                         tessref::PipelineResult* out = nullptr) {
    tessref::PipelineOptions options;
    options.precision = precision;
    tessref::PipelineResult result = tessref::run_pipeline(scene, options);
    const tessref::sweep::TruthSurface truth = tessref::sweep::truth_surface(scene);
    const auto e = tessref::sweep::geometric_error(truth, result.mesh, &*scene.camera);
    if (out) *out = std::move(result);
    return e;
}

class SweepGeometricError : public CommandDirTest {};

// A flat height map: every tessellated vertex and every truth vertex has the same height,
// and both surfaces interpolate linearly between them, so the error is 0 everywhere, at any
// level and spacing. Code 255 reads 1.0 and scale_z 2 gives 2.0, exact in float too, so the
// gpu precision must also give exactly 0; any code in exact precision.
TEST_F(SweepGeometricError, FlatHeightMapIsZeroAtEveryLevel) {
    for (const int code : {255, 100}) {
        for (const std::string spacing : {"equal", "fractional_odd", "fractional_even"}) {
            for (const double level : {1.0, 2.0, 3.0, 5.5, 8.0, 17.0}) {
                OnePatch p{dir_};
                p.width = 5;  // texel centres off the tessellation's vertices
                p.height = 3;
                p.codes.assign(15, code);
                p.spacing = spacing;
                p.level = level;
                const tessref::Scene scene = p.scene();
                for (const auto precision : {tessref::Precision::gpu, tessref::Precision::exact}) {
                    if (code != 255 && precision == tessref::Precision::gpu) continue;
                    const auto e = error_of(scene, precision);
                    EXPECT_EQ(e.max, 0.0) << code << " " << spacing << " " << level;
                    EXPECT_EQ(e.rms, 0.0) << code << " " << spacing << " " << level;
                    EXPECT_EQ(e.max_px, 0.0);
                    EXPECT_NEAR(e.area, 64.0, 1e-9);  // the whole patch is measured
                }
            }
        }
    }
}

// One raised texel at level 1. The 4 x 4 map is 0 except texel (1, 1) = 255 (1.0), scale_z
// 2. The patch's corners read the corner texels (clamp to edge): all 0, so the tessellation
// is the plane z = 0. The truth's vertex lines are the borders 0, 8 and the texel centres
// 1, 3, 5, 7; it is 0 at every vertex but the centre of texel (1, 1), (3, 3) (or its mirror
// image, wherever the loader puts row 1), where it is 2: a hat function of height 2 over
// the six truth triangles that share that vertex (the quads split from low-low to
// high-high corner: both triangles of [1,3]^2 and of [3,5]^2, one of each of the two other
// quads), each of area 2 (half a 2 x 2 quad).
//   max = 2, at the hat's top.
//   integral of G^2 = 6 triangles x (area 2 x (2^2 + 0 + 0 + 0 + 0 + 0) / 6) = 8
//   (a linear function with corner values a, b, c on a triangle of area A integrates its
//   square to A (a^2 + b^2 + c^2 + ab + bc + ca) / 6), over the area 64:
//   rms = sqrt(8 / 64) = sqrt(1/8).
TEST_F(SweepGeometricError, OneRaisedTexelAtLevelOne) {
    OnePatch p{dir_};
    p.codes[1 * 4 + 1] = 255;
    const tessref::Scene scene = p.scene();
    for (const auto precision : {tessref::Precision::gpu, tessref::Precision::exact}) {
        tessref::PipelineResult result;
        const auto e = error_of(scene, precision, &result);
        ASSERT_EQ(result.mesh.triangles.size(), 2u);
        EXPECT_NEAR(e.max, 2.0, 1e-12);
        EXPECT_NEAR(e.rms, std::sqrt(1.0 / 8.0), 1e-12);
        EXPECT_NEAR(e.area, 64.0, 1e-12);
        EXPECT_NEAR(e.max_at.x, 3.0, 1e-12);
        EXPECT_TRUE(std::abs(e.max_at.y - 3.0) < 1e-12 || std::abs(e.max_at.y - 5.0) < 1e-12) << e.max_at.y;
        // The screen size: the segment from the hat's top down to the plane, both ends in
        // view, projected by glm::project with the scene's camera (not the sweep's code).
        const tessref::SceneCamera& c = *scene.camera;
        const glm::dvec4 viewport(0.0, 0.0, c.viewport.x, c.viewport.y);
        const glm::dvec3 top = glm::project(glm::dvec3(3.0, e.max_at.y, 2.0), c.view(), c.projection(), viewport);
        const glm::dvec3 foot = glm::project(glm::dvec3(3.0, e.max_at.y, 0.0), c.view(), c.projection(), viewport);
        EXPECT_NEAR(e.max_px, glm::length(glm::dvec2(top) - glm::dvec2(foot)), 1e-9);
        EXPECT_GT(e.max_px, 1.0);
    }
}

// The error is largest where a tessellation edge crosses a texel grid line, away from every
// vertex of both surfaces. A 4 x 3 map over [0, 8]^2: texel centres at x = 1, 3, 5, 7 and
// y = 4/3, 4, 20/3, so the patch's diagonal y = x (or x + y = 8) passes through none of them.
// Two opposite corner texels are 255 (height H = 2), the rest 0. At level 1 the patch is two
// triangles; the corners on the tessellation's diagonal are the high ones (the map is
// mirrored if the generator splits along the other diagonal), so the tessellation is a
// ridge of height H along that diagonal, falling linearly to 0 at the two other corners:
// T = H (1 - |d| / 8) with d the distance of x from the diagonal along x.
// The truth is 0 in the quads [3, 5] x [4/3, 4] and [3, 5] x [4, 20/3] (all four corners are
// 0-texel centres), which the diagonal runs through: there the error is H, e.g. at (4, 4),
// where the diagonal crosses the grid line y = 4. Sampling only vertices misses it: at the
// tessellation's vertices the truth equals the tessellation (clamped corner texels), and at
// the texel-centre vertices nearest the diagonal, (3, 4) and (5, 4) (|d| = 1), the error is
// H (1 - 1/8) = 7H/8; the others are farther from the ridge or on a raised texel.
TEST_F(SweepGeometricError, MaximumAtATessellationEdgeCrossingAGridLine) {
    const double H = 2.0;
    for (const bool mirrored : {false, true}) {
        OnePatch p{dir_};
        p.width = 4;
        p.height = 3;
        p.codes.assign(12, 0);
        p.codes[mirrored ? 3 : 0] = 255;            // row 0: column 0 (or 3)
        p.codes[2 * 4 + (mirrored ? 0 : 3)] = 255;  // row 2: column 3 (or 0)
        const tessref::Scene scene = p.scene();
        tessref::PipelineResult result;
        const auto e = error_of(scene, tessref::Precision::exact, &result);
        const auto& mesh = result.mesh;
        ASSERT_EQ(mesh.triangles.size(), 2u);
        // The two vertices both triangles share: the tessellation's diagonal.
        std::vector<glm::dvec3> shared;
        for (const auto a : mesh.triangles[0])
            for (const auto b : mesh.triangles[1])
                if (mesh.positions[a] == mesh.positions[b]) shared.push_back(mesh.positions[a]);
        ASSERT_EQ(shared.size(), 2u);
        if (shared[0].z != H || shared[1].z != H) continue;  // this map's high corners are off the diagonal
        EXPECT_NEAR(e.max, H, 1e-12);
        // Vertex-only sampling, done here: |T - G| at the tessellation's vertices and at the
        // truth's vertices (T from the plane of the tessellated triangle holding the point).
        // Its maximum is the hand-derived 7H/8, at (3, 4) and (5, 4), short of H.
        const tessref::sweep::TruthSurface truth = tessref::sweep::truth_surface(scene);
        const auto tessellation_at = [&](double x, double y) {
            for (const auto& tri : mesh.triangles) {
                const glm::dvec3 a = mesh.positions[tri[0]], b = mesh.positions[tri[1]], c = mesh.positions[tri[2]];
                const double det = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
                const double s1 = ((x - a.x) * (c.y - a.y) - (c.x - a.x) * (y - a.y)) / det;
                const double s2 = ((b.x - a.x) * (y - a.y) - (x - a.x) * (b.y - a.y)) / det;
                if (s1 >= -1e-12 && s2 >= -1e-12 && s1 + s2 <= 1.0 + 1e-12) return a.z + s1 * (b.z - a.z) + s2 * (c.z - a.z);
            }
            ADD_FAILURE() << "no triangle holds (" << x << ", " << y << ")";
            return 0.0;
        };
        double vertex_only = 0.0;
        for (std::size_t j = 0; j < truth.vs.size(); ++j)
            for (std::size_t i = 0; i < truth.us.size(); ++i)
                vertex_only = std::max(vertex_only,
                                       std::abs(tessellation_at(truth.us[i], truth.vs[j]) - truth.height(i, j)));
        for (const glm::dvec3& v : mesh.positions) {
            const std::size_t i = static_cast<std::size_t>(std::find(truth.us.begin(), truth.us.end(), v.x) - truth.us.begin());
            const std::size_t j = static_cast<std::size_t>(std::find(truth.vs.begin(), truth.vs.end(), v.y) - truth.vs.begin());
            ASSERT_TRUE(i < truth.us.size() && j < truth.vs.size());  // the patch's corners are truth vertices
            vertex_only = std::max(vertex_only, std::abs(v.z - truth.height(i, j)));
        }
        EXPECT_NEAR(vertex_only, 7.0 * H / 8.0, 1e-12);
        return;
    }
    FAIL() << "neither map put the raised corners on the tessellation's diagonal";
}

// ---- the pipeline's timings change nothing ---------------------------------------------------

// The screen measures by hand, with the identity as view-projection: clip space is world
// space (w = 1), so a point (x, y) lands at ((x + 1) / 2 * 100, (y + 1) / 2 * 100) in a
// 100 x 100 viewport.
TEST(SweepScreenMeasures, VisiblePixelsAndMeanEdgeLengthByHand) {
    using tessref::sweep::visible_pixels;
    const glm::dmat4 identity(1.0);
    const glm::ivec2 viewport(100, 100);
    EXPECT_DOUBLE_EQ(visible_pixels(identity, viewport, {0, 0, 0}, {0.5, 0, 0}), 25.0);
    EXPECT_DOUBLE_EQ(visible_pixels(identity, viewport, {0, 0, 0}, {2, 0, 0}), 50.0);  // clipped at x = 1
    EXPECT_DOUBLE_EQ(visible_pixels(identity, viewport, {2, 0, 0}, {3, 0, 0}), 0.0);   // all off screen
    tessref::SurfaceMesh mesh;
    mesh.positions = {{0, 0, 0}, {0.5, 0, 0}, {0, 0.5, 0}, {2, 2, 0}, {3, 2, 0}, {2, 3, 0}};
    mesh.triangles = {{0, 1, 2}, {3, 4, 5}};  // the second is off screen and counts nowhere
    EXPECT_DOUBLE_EQ(tessref::sweep::mean_edge_pixels(mesh, identity, viewport),
                     (25.0 + 25.0 + std::sqrt(2.0 * 25.0 * 25.0)) / 3.0);
    EXPECT_EQ(tessref::sweep::mean_edge_pixels({}, identity, viewport), 0.0);
}

// mean_edge_pixels() works on chunks of triangles in parallel, with every vertex's clip
// coordinates computed once, then sums the edges serially in triangle order: it must give
// the very number (not a close one) of the plain loop over every edge's visible_pixels(),
// here for a perspective camera, many chunks and a partial last one, vertices shared by
// many triangles, and edges partly, wholly and not at all on screen.
TEST(SweepScreenMeasures, MeanEdgeLengthIsThePlainSerialSumBitForBit) {
    using tessref::sweep::visible_pixels;
    const glm::dmat4 vp = glm::perspective(0.9, 1.6, 0.5, 400.0) *
                          glm::lookAt(glm::dvec3(-30.0, -40.0, 25.0), glm::dvec3(0.0), glm::dvec3(0.0, 0.0, 1.0));
    const glm::ivec2 viewport(320, 200);
    tessref::SurfaceMesh mesh;
    const int n = 301;  // a 301 x 301 vertex grid: 180000 triangles
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
            mesh.positions.push_back({(i - 150) * 0.37, (j - 150) * 0.29, 3.0 * std::sin(i * 0.11) * std::cos(j * 0.07)});
    for (int j = 0; j + 1 < n; ++j)
        for (int i = 0; i + 1 < n; ++i) {
            const auto v = static_cast<std::uint32_t>(j * n + i);
            mesh.triangles.push_back({v, v + 1, v + static_cast<std::uint32_t>(n) + 1});
            mesh.triangles.push_back({v, v + static_cast<std::uint32_t>(n) + 1, v + static_cast<std::uint32_t>(n)});
        }
    double sum = 0.0;
    std::size_t edges = 0, hidden = 0;
    for (const auto& t : mesh.triangles)
        for (int k = 0; k < 3; ++k) {
            const double px = visible_pixels(vp, viewport, mesh.positions[t[k]], mesh.positions[t[(k + 1) % 3]]);
            if (px > 0.0) {
                sum += px;
                ++edges;
            } else {
                ++hidden;
            }
        }
    ASSERT_GT(edges, 1000u);
    ASSERT_GT(hidden, 1000u);  // the camera sees part of the grid only
    EXPECT_EQ(tessref::sweep::mean_edge_pixels(mesh, vp, viewport), sum / static_cast<double>(edges));
}

TEST(SweepPipelineTimings, FilledWithoutChangingTheOutput) {
    const tessref::Scene scene = tessref::load_scene((kSource / "data/scenes/thesis-distance-4.toml").string());
    for (const auto precision : {tessref::Precision::gpu, tessref::Precision::exact}) {
        tessref::PipelineOptions plain;
        plain.precision = precision;
        const tessref::PipelineResult a = tessref::run_pipeline(scene, plain);
        tessref::PipelineTimings timings;
        timings.control = -1.0;
        tessref::PipelineOptions timed = plain;
        timed.timings = &timings;
        const tessref::PipelineResult b = tessref::run_pipeline(scene, timed);
        EXPECT_EQ(a.mesh.positions, b.mesh.positions);
        EXPECT_EQ(a.mesh.normals, b.mesh.normals);
        EXPECT_EQ(a.mesh.triangles, b.mesh.triangles);
        EXPECT_GE(timings.control, 0.0);
        EXPECT_GE(timings.generator, 0.0);
        EXPECT_GT(timings.evaluation, 0.0);
        EXPECT_GE(timings.geometry, 0.0);
    }
}

// ---- the command -----------------------------------------------------------------------------

const std::vector<std::string> kColumns{
    "scene",       "model",      "level",         "spacing",          "precision",     "camera_relative", "patches",
    "triangles",   "points",     "control_ms",    "generator_ms",     "evaluation_ms", "geometry_ms",
    "raster_shading_ms",         "total_ms",      "geo_max",          "geo_rms",       "geo_max_px",
    "mean_edge_px", "triangles_per_px",
    "img_rmse",    "img_psnr",   "img_fail_px",   "gpu_exact_max_pos", "gpu_exact_image_differs",
    "image",       "diff_image", "wire_image",    "truth_image"};

std::vector<std::string> split_csv_line(const std::string& line) {
    std::vector<std::string> fields;
    std::string f;
    for (char c : line) {
        if (c == ',') {
            fields.push_back(f);
            f.clear();
        } else {
            f += c;
        }
    }
    fields.push_back(f);
    return fields;
}

struct Csv {
    std::vector<std::string> header;
    std::vector<std::map<std::string, std::string>> rows;
    std::vector<std::string> lines;  // rows as text
};
Csv read_csv(const fs::path& path) {
    Csv csv;
    std::istringstream in(read_file(path));
    std::string line;
    std::getline(in, line);
    csv.header = split_csv_line(line);
    while (std::getline(in, line)) {
        const auto fields = split_csv_line(line);
        std::map<std::string, std::string> row;
        for (std::size_t k = 0; k < fields.size() && k < csv.header.size(); ++k) row[csv.header[k]] = fields[k];
        csv.rows.push_back(row);
        csv.lines.push_back(line);
    }
    return csv;
}

// The CSV's text with every *_ms field emptied: what must be byte-identical between runs.
std::string without_timings(const fs::path& path) {
    const Csv csv = read_csv(path);
    std::string text;
    for (const std::string& line : csv.lines) {
        const auto fields = split_csv_line(line);
        for (std::size_t k = 0; k < fields.size(); ++k) {
            const std::string& name = csv.header[k];
            const bool timing = name.size() > 3 && name.compare(name.size() - 3, 3, "_ms") == 0;
            text += (k ? "," : "") + (timing ? std::string() : fields[k]);
        }
        text += "\n";
    }
    return text;
}

std::map<std::string, std::string> files_under(const fs::path& dir) {
    std::map<std::string, std::string> files;
    for (const auto& e : fs::recursive_directory_iterator(dir))
        if (e.is_regular_file()) files[fs::relative(e.path(), dir).string()] = read_file(e.path());
    return files;
}

class SweepCommand : public CommandDirTest {
protected:
    // A 2 x 2 patch terrain over [0, 8]^2 on a 5 x 4 map with one raised texel, its own
    // control stage the thesis's distance factor (so its own row differs from a uniform one).
    std::string terrain(const std::string& name = "bump", bool flat = false) {
        std::vector<int> codes(20, flat ? 255 : 40);
        if (!flat) codes[1 * 5 + 2] = 250;
        write_pgm(dir_ / (name + ".pgm"), 5, 4, 255, codes);
        Terrain t;
        t.heightmap = name + ".pgm";
        t.control = "model = \"thesis\"\nfactor = \"distance\"\nlevel = 3.0";
        std::string toml = t.toml();
        toml.replace(toml.find("name = \"extreme\""), 16, "name = \"" + name + "\"");
        write_file(dir_ / (name + ".toml"), toml);
        return name + ".toml";
    }
    // tessref ARGS, run inside the test's directory (relative names are its files).
    RunResult run_here(const std::vector<std::string>& args) {
        return tessref::test::run_program(TESSREF_EXE, args, dir_, dir_);
    }
    RunResult sweep(std::vector<std::string> args) {
        args.insert(args.begin(), "sweep");
        args.push_back("--size");
        args.push_back("64x40");
        return run_here(args);
    }
};

TEST_F(SweepCommand, RowsColumnsAndOrder) {
    const std::string a = terrain("bump"), b = terrain("flat", true);
    const RunResult r = sweep({a, b, "--levels", "1,2..3", "--precision", "gpu,exact", "--spacing",
                               "equal,fractional_odd", "-o", "out"});
    ASSERT_EQ(r.status, 0) << r.err;
    const Csv csv = read_csv(dir_ / "out/sweep.csv");
    EXPECT_EQ(csv.header, kColumns);
    // scenes x (precisions own rows + spacings x precisions x levels) = 2 x (2 + 2 x 2 x 3)
    ASSERT_EQ(csv.rows.size(), 2u * (2u + 2u * 2u * 3u));
    // The order: scene; its own rows first (per precision); then spacing, precision, level.
    std::vector<std::string> order;
    for (const auto& row : csv.rows)
        order.push_back(row.at("scene") + " " + row.at("model") + " " + row.at("spacing") + " " + row.at("precision") +
                        " " + row.at("level"));
    EXPECT_EQ(order[0], "bump thesis fractional_odd gpu ");
    EXPECT_EQ(order[1], "bump thesis fractional_odd exact ");
    EXPECT_EQ(order[2], "bump uniform equal gpu 1");
    EXPECT_EQ(order[4], "bump uniform equal gpu 3");
    EXPECT_EQ(order[5], "bump uniform equal exact 1");
    EXPECT_EQ(order[8], "bump uniform fractional_odd gpu 1");
    EXPECT_EQ(order[13], "bump uniform fractional_odd exact 3");
    EXPECT_EQ(order[14], "flat thesis fractional_odd gpu ");
    for (const auto& row : csv.rows) {
        EXPECT_EQ(row.at("patches"), "4");
        if (row.at("model") == "uniform" && row.at("spacing") == "equal") {
            // equal spacing at level L: (L x L quads) x 2 triangles per patch
            const int level = std::stoi(row.at("level"));
            EXPECT_EQ(row.at("triangles"), std::to_string(4 * 2 * level * level));
        }
        // The flat map (code 255 x scale_z 2.0 = 2.0, exact in float): no geometric error.
        if (row.at("scene") == "flat") EXPECT_EQ(row.at("geo_max"), "0") << row.at("level");
        if (row.at("scene") == "bump") EXPECT_NE(row.at("geo_max"), "0");
        // Both precisions ran: the pair columns are filled.
        EXPECT_FALSE(row.at("gpu_exact_max_pos").empty());
        EXPECT_TRUE(row.at("gpu_exact_image_differs") == "0" || row.at("gpu_exact_image_differs") == "1");
        EXPECT_FALSE(row.at("img_rmse").empty());
        EXPECT_FALSE(row.at("img_fail_px").empty());
        EXPECT_EQ(row.at("truth_image"), "images/" + row.at("scene") + "/truth.png");
        // Pictures at chosen levels: the own row, powers of two (1, 2), the largest level
        // (3): every row here.
        for (const char* column : {"image", "diff_image", "wire_image"}) {
            ASSERT_FALSE(row.at(column).empty()) << column;
            EXPECT_TRUE(fs::is_regular_file(dir_ / "out" / row.at(column))) << row.at(column);
        }
    }
    EXPECT_TRUE(fs::is_regular_file(dir_ / "out/images/bump/truth.png"));
    EXPECT_TRUE(fs::is_regular_file(dir_ / "out/index.html"));
    // The screen measures: on the flat map every level covers the same pixels, so triangles
    // per pixel grow as the triangles (4x from level 1 to 2, equal spacing), and the mean
    // edge about halves (each edge split in two; perspective makes it not exact).
    const auto at = [&](const std::string& level, const char* column) {
        for (const auto& row : csv.rows)
            if (row.at("scene") == "flat" && row.at("model") == "uniform" && row.at("spacing") == "equal" &&
                row.at("precision") == "gpu" && row.at("level") == level)
                return std::stod(row.at(column));
        ADD_FAILURE() << "no flat equal gpu row at level " << level;
        return 0.0;
    };
    EXPECT_NEAR(at("2", "triangles_per_px") / at("1", "triangles_per_px"), 4.0, 1e-6);
    const double halves = at("2", "mean_edge_px") / at("1", "mean_edge_px");
    EXPECT_GT(halves, 0.4);
    EXPECT_LT(halves, 0.6);
    // Not a chosen level: 3 of 1..4 keeps no pictures.
    ASSERT_EQ(sweep({a, "--levels", "1..4", "-o", "four"}).status, 0);
    for (const auto& row : read_csv(dir_ / "four/sweep.csv").rows)
        EXPECT_EQ(row.at("image").empty(), row.at("level") == "3") << row.at("level");
}

// gpu_exact_max_pos is the largest distance between the two precisions' vertices of the
// same index, computed here from the pipeline's own results for the uniform rows: a
// comparison that looked at no vertices (empty or moved-from arrays) would print 0.
TEST_F(SweepCommand, GpuExactMaxPosIsTheLargestVertexDistance) {
    const std::string a = terrain("bump");
    ASSERT_EQ(sweep({a, "--levels", "2,3", "--precision", "gpu,exact", "--spacing", "equal", "-o", "out"}).status, 0);
    tessref::Scene scene = tessref::load_scene((dir_ / a).string());
    scene.generator.spacing = tessref::Spacing::equal;
    int checked = 0;
    for (const auto& row : read_csv(dir_ / "out/sweep.csv").rows) {
        if (row.at("model") != "uniform") continue;
        scene.control->model = tessref::ControlModel::constant;
        scene.control->constant.level = std::stod(row.at("level"));
        tessref::PipelineOptions gpu, exact;
        gpu.precision = tessref::Precision::gpu;
        exact.precision = tessref::Precision::exact;
        const tessref::PipelineResult g = tessref::run_pipeline(scene, gpu), e = tessref::run_pipeline(scene, exact);
        ASSERT_EQ(g.mesh.positions.size(), e.mesh.positions.size());
        double m = 0.0;
        for (std::size_t v = 0; v < g.mesh.positions.size(); ++v)
            m = std::max(m, glm::length(g.mesh.positions[v] - e.mesh.positions[v]));
        ASSERT_GT(m, 0.0);  // float and double heights differ on this map
        char text[40];
        std::snprintf(text, sizeof text, "%.9g", m);
        EXPECT_EQ(row.at("gpu_exact_max_pos"), text) << row.at("level") << " " << row.at("precision");
        ++checked;
    }
    EXPECT_EQ(checked, 4);
}

// --camera-relative off,on runs every row both ways: the off rows of a scene first, then
// the on rows in the same order, told apart by the camera_relative column and by pictures
// whose names end in -cr. Exact precision ignores the option (PipelineOptions), so its on
// rows repeat its off rows' measurements; a bad value is refused.
TEST_F(SweepCommand, CameraRelativeRunsEveryRowBothWays) {
    const std::string a = terrain("bump");
    const RunResult r = sweep({a, "--levels", "1,2", "--precision", "gpu,exact", "--camera-relative", "off,on", "-o", "out"});
    ASSERT_EQ(r.status, 0) << r.err;
    const Csv csv = read_csv(dir_ / "out/sweep.csv");
    ASSERT_EQ(csv.rows.size(), 2u * (2u + 2u * 2u));
    for (std::size_t k = 0; k < csv.rows.size(); ++k) {
        const auto& row = csv.rows[k];
        const bool on = k >= 6;
        EXPECT_EQ(row.at("camera_relative"), on ? "1" : "0") << k;
        if (k < 6) {
            const auto& twin = csv.rows[k + 6];
            EXPECT_EQ(twin.at("model") + twin.at("level") + twin.at("precision"),
                      row.at("model") + row.at("level") + row.at("precision"));
            if (row.at("precision") == "exact")
                for (const char* column : {"triangles", "geo_max", "geo_rms", "img_rmse"})
                    EXPECT_EQ(twin.at(column), row.at(column)) << column;
        }
        EXPECT_EQ(row.at("image").ends_with("-cr.png"), on) << row.at("image");
    }
    EXPECT_EQ(sweep({a, "--camera-relative", "sometimes", "-o", "bad"}).status, 2);
    EXPECT_FALSE(fs::exists(dir_ / "bad"));
}

TEST_F(SweepCommand, ShardsMergeToTheUnshardedRun) {
    const std::string a = terrain("bump"), b = terrain("flat", true);
    const std::vector<std::string> common{a, b, "--levels", "1..3", "--precision", "gpu,exact"};
    auto with = [&](std::vector<std::string> extra) {
        std::vector<std::string> args = common;
        args.insert(args.end(), extra.begin(), extra.end());
        return args;
    };
    ASSERT_EQ(sweep(with({"-o", "whole", "--threads", "1"})).status, 0);
    for (int i = 0; i < 3; ++i) {
        const RunResult r = sweep(with({"-o", "s" + std::to_string(i), "--shard", std::to_string(i) + "/3"}));
        ASSERT_EQ(r.status, 0) << r.err;
    }
    const RunResult m = run_here({"sweep", "merge", "s2", "s0", "s1", "-o", "merged"});
    ASSERT_EQ(m.status, 0) << m.err;
    EXPECT_EQ(without_timings(dir_ / "merged/sweep.csv"), without_timings(dir_ / "whole/sweep.csv"));
    EXPECT_EQ(read_csv(dir_ / "merged/sweep.csv").rows.size(), 2u * (2u + 2u * 3u));
    EXPECT_EQ(read_file(dir_ / "merged/sweep.json"), read_file(dir_ / "whole/sweep.json"));
    // The pictures: the same names, the same bytes.
    std::map<std::string, std::string> whole, merged;
    for (const auto& [name, bytes] : files_under(dir_ / "whole/images")) whole[name] = bytes;
    for (const auto& [name, bytes] : files_under(dir_ / "merged/images")) merged[name] = bytes;
    EXPECT_EQ(whole, merged);
    EXPECT_TRUE(fs::is_regular_file(dir_ / "merged/index.html"));
    // Another thread count changes nothing but the timings.
    ASSERT_EQ(sweep(with({"-o", "two", "--threads", "2"})).status, 0);
    EXPECT_EQ(without_timings(dir_ / "two/sweep.csv"), without_timings(dir_ / "whole/sweep.csv"));
}

// The report recommends levels (the knee; the best under the own levels' triangles) and its
// pictures must be there for them whatever the level: with levels 3, 5, 6, 7 only 7 (the
// largest) is kept by the power-of-two rule, so the knee and the budget's level of each
// series, found from sweep.csv by the report's rules, keep theirs too, and no other level
// does. A sharded sweep merged keeps the same pictures, byte for byte.
TEST_F(SweepCommand, RecommendedLevelsKeepTheirPicturesWholeOrSharded) {
    const std::string a = terrain("bump");
    const std::vector<std::string> args{a, "--levels", "3,5,6,7", "--precision", "gpu,exact"};
    auto with = [&](std::vector<std::string> extra) {
        std::vector<std::string> all = args;
        all.insert(all.end(), extra.begin(), extra.end());
        return all;
    };
    ASSERT_EQ(sweep(with({"-o", "whole"})).status, 0);
    const Csv csv = read_csv(dir_ / "whole/sweep.csv");
    std::set<std::string> recommended;  // "precision level"
    for (const char* precision : {"gpu", "exact"}) {
        std::vector<tessref::sweep::LevelError> curve;
        std::vector<tessref::sweep::LevelRun> runs;
        double budget = 0.0;
        for (const auto& row : csv.rows) {
            if (row.at("precision") != precision) continue;
            if (row.at("model") != "uniform") {
                budget = std::stod(row.at("triangles"));
                continue;
            }
            curve.push_back({std::stod(row.at("level")), std::stod(row.at("img_rmse"))});
            runs.push_back({std::stod(row.at("level")), std::stod(row.at("triangles")), std::stod(row.at("img_rmse"))});
        }
        const auto knee = tessref::sweep::stop_improving_level(curve);
        ASSERT_TRUE(knee);
        recommended.insert(std::string(precision) + " " + std::to_string(static_cast<int>(*knee)));
        if (const auto best = tessref::sweep::best_level_under_budget(runs, budget))
            recommended.insert(std::string(precision) + " " + std::to_string(static_cast<int>(*best)));
    }
    bool beyond_the_rule = false;  // a recommended level the power-of-two rule would not keep
    for (const auto& row : csv.rows) {
        if (row.at("model") != "uniform") continue;
        const bool chosen = recommended.count(row.at("precision") + " " + row.at("level")) > 0;
        beyond_the_rule = beyond_the_rule || (chosen && row.at("level") != "7");
        EXPECT_EQ(row.at("image").empty(), !chosen && row.at("level") != "7") << row.at("precision") << row.at("level");
        if (!row.at("image").empty()) EXPECT_TRUE(fs::is_regular_file(dir_ / "whole" / row.at("image")));
    }
    EXPECT_TRUE(beyond_the_rule) << "the scene no longer tests anything: every recommended level is 7";
    for (int i = 0; i < 2; ++i)
        ASSERT_EQ(sweep(with({"-o", "s" + std::to_string(i), "--shard", std::to_string(i) + "/2"})).status, 0);
    const RunResult m = run_here({"sweep", "merge", "s1", "s0", "-o", "merged"});
    ASSERT_EQ(m.status, 0) << m.err;
    EXPECT_EQ(without_timings(dir_ / "merged/sweep.csv"), without_timings(dir_ / "whole/sweep.csv"));
    EXPECT_EQ(files_under(dir_ / "merged/images"), files_under(dir_ / "whole/images"));
}

TEST_F(SweepCommand, MergeRefusesMismatchedDuplicateMissingAndCorruptShards) {
    const std::string a = terrain("bump");
    for (int i = 0; i < 3; ++i)
        ASSERT_EQ(sweep({a, "--levels", "1,2", "-o", "s" + std::to_string(i), "--shard", std::to_string(i) + "/3"}).status, 0);
    ASSERT_EQ(sweep({a, "--levels", "1,3", "-o", "other", "--shard", "2/3"}).status, 0);
    const auto refused = [&](const std::vector<std::string>& dirs, const std::string& named) {
        std::vector<std::string> args{"sweep", "merge"};
        args.insert(args.end(), dirs.begin(), dirs.end());
        args.push_back("-o");
        args.push_back("merged");
        const RunResult r = run_here(args);
        EXPECT_EQ(r.status, 2) << r.err;
        EXPECT_NE(r.err.find(named), std::string::npos) << r.err;
        EXPECT_FALSE(fs::exists(dir_ / "merged"));
    };
    refused({"s0", "s1", "other"}, "other");                  // another sweep
    refused({"s0", "s1", "s1"}, "s1");                        // a shard twice
    refused({"s0", "s1"}, "shard 2/3 is missing");            // a shard missing
    refused({"s0", "s1", "nowhere"}, "nowhere");              // not a directory
    fs::copy(dir_ / "s1", dir_ / "cut", fs::copy_options::recursive);
    const std::string csv = read_file(dir_ / "cut/sweep.csv");
    write_file(dir_ / "cut/sweep.csv", csv.substr(0, csv.size() - 10));  // a truncated last line
    refused({"s0", "cut", "s2"}, "cut");
    write_file(dir_ / "cut/sweep.csv", csv.substr(0, csv.find('\n') + 1) + "a,b\n");  // a short row
    refused({"s0", "cut", "s2"}, "cut");
    // A cell that is not a number (the merge chooses the pictures by the rows' numbers): the
    // report's strict reading names the column, never a crash or a bare library message.
    std::string bad_level = csv;
    const std::size_t uniform = bad_level.find(",uniform,");
    ASSERT_NE(uniform, std::string::npos);
    bad_level.replace(uniform + 9, bad_level.find(',', uniform + 9) - (uniform + 9), "x");
    write_file(dir_ / "cut/sweep.csv", bad_level);
    refused({"s0", "cut", "s2"}, "column level");
    // Counts and indices of sweep.json that are no whole number in range (2e+82 as a shard
    // count was undefined behaviour in the conversion to int: a fuzzer's finding).
    write_file(dir_ / "cut/sweep.csv", csv);
    const std::string json = read_file(dir_ / "s1/sweep.json");
    for (const auto& [from, to, named] :
         std::vector<std::tuple<std::string, std::string, std::string>>{
             {"\"count\": 3", "\"count\": 2e82", "the shard count is 2e+82, not a whole number"},
             {"\"index\": 1", "\"index\": 1.5", "the shard's index is 1.5, not a whole number"},
             {"\"index\": 1", "\"index\": -1", "the shard's index is -1, not a whole number"}}) {
        std::string edited = json;
        const std::size_t at = edited.find(from);
        ASSERT_NE(at, std::string::npos) << from << " in " << json;
        edited.replace(at, from.size(), to);
        write_file(dir_ / "cut/sweep.json", edited);
        refused({"s0", "cut", "s2"}, named);
    }
}

TEST_F(SweepCommand, BadInputExitsTwoAndWritesNothing) {
    const std::string a = terrain("bump");
    write_file(dir_ / "file", "x");
    const std::set<std::string> before = files();
    const std::vector<std::pair<std::vector<std::string>, std::string>> cases{
        {{"missing.toml", "-o", "out"}, "missing.toml"},
        {{a, "--levels", "0", "-o", "out"}, "--levels"},
        {{a, "--levels", "65", "-o", "out"}, "--levels"},
        {{a, "--levels", "nan", "-o", "out"}, "--levels"},
        {{a, "--levels", "1,x", "-o", "out"}, "--levels"},
        {{a, "--levels", "4..2", "-o", "out"}, "--levels"},
        {{a, "--levels", "1..", "-o", "out"}, "--levels"},
        {{a, "--precision", "gpu,double", "-o", "out"}, "--precision"},
        {{a, "--spacing", "odd", "-o", "out"}, "--spacing"},
        {{a, "--shard", "3/3", "-o", "out"}, "--shard"},
        {{a, "--shard", "x", "-o", "out"}, "--shard"},
        {{a, "--repeat", "0", "-o", "out"}, "--repeat"},
        {{a, "-o", "file"}, "file"},
        {{a, "-o", "no/such/dir"}, "no/such/dir"},
        {{a, "-o", "."}, "."},  // not empty, and not an earlier sweep
        {{a}, "-o"},
    };
    for (const auto& [args, named] : cases) {
        const RunResult r = sweep(args);
        EXPECT_EQ(r.status, 2) << args[0] << " " << args[1] << ": " << r.err;
        EXPECT_NE(r.err.find(named), std::string::npos) << r.err;
        EXPECT_EQ(files(), before) << r.err;
    }
}

TEST_F(SweepCommand, SlurmArrayPicksTheShard) {
    const std::string a = terrain("bump");
    ASSERT_EQ(sweep({a, "--levels", "1..3", "-o", "by-flag", "--shard", "1/3"}).status, 0);
    // An array 4..6: task 5 is the second of three.
    const RunResult r = tessref::test::run_program(
        "env",
        {"SLURM_ARRAY_TASK_ID=5", "SLURM_ARRAY_TASK_MIN=4", "SLURM_ARRAY_TASK_COUNT=3", TESSREF_EXE, "sweep", a,
         "--levels", "1..3", "--size", "64x40", "-o", "by-env"},
        dir_, dir_);
    ASSERT_EQ(r.status, 0) << r.err;
    const auto json = nlohmann::json::parse(read_file(dir_ / "by-env/sweep.json"));
    EXPECT_EQ(json["shard"]["index"], 1);
    EXPECT_EQ(json["shard"]["count"], 3);
    EXPECT_EQ(without_timings(dir_ / "by-env/sweep.csv"), without_timings(dir_ / "by-flag/sweep.csv"));
    // --shard wins over the environment; a task outside the array is bad input.
    const RunResult bad = tessref::test::run_program(
        "env",
        {"SLURM_ARRAY_TASK_ID=9", "SLURM_ARRAY_TASK_COUNT=3", TESSREF_EXE, "sweep", a, "--size", "64x40", "-o", "bad"},
        dir_, dir_);
    EXPECT_EQ(bad.status, 2);
    EXPECT_NE(bad.err.find("SLURM_ARRAY_TASK_ID"), std::string::npos) << bad.err;
    EXPECT_FALSE(fs::exists(dir_ / "bad"));
}

TEST_F(SweepCommand, MeshSceneHasNoGeometricOrImageError) {
    const RunResult r =
        sweep({(kSource / "data/scenes/pn-triangles.toml").string(), "--levels", "1,2", "-o", "out", "--repeat", "3"});
    ASSERT_EQ(r.status, 0) << r.err;
    const Csv csv = read_csv(dir_ / "out/sweep.csv");
    ASSERT_EQ(csv.rows.size(), 3u);
    EXPECT_EQ(csv.rows[0].at("model"), "pn");
    for (const auto& row : csv.rows) {
        for (const char* column : {"geo_max", "geo_rms", "geo_max_px", "img_rmse", "img_psnr", "img_fail_px",
                                   "truth_image", "diff_image", "gpu_exact_max_pos"})
            EXPECT_EQ(row.at(column), "") << column;
        EXPECT_FALSE(row.at("image").empty());
        EXPECT_NE(row.at("triangles"), "0");
    }
}

// ---- geomipmapped scenes ---------------------------------------------------------------------
//
// Where the expected values come from:
//  - rows: per scene and camera_relative value, the own rows (one per precision), then per
//    precision the forced geomip levels (ascending), then per precision the screen-error
//    bounds (ascending) (docs/SWEEP.md, "Geomipmapped scenes");
//  - triangles at a forced level k: every patch keeps every 2^k-th sample of its 17 x 17, so
//    (16 / 2^k)^2 cells of two triangles, and with every patch at one level every side has
//    the level's own step (no zipper cells): 2 (16 / 2^k)^2 per patch;
//  - the truth of a geomipmapped terrain is its level-0 mesh (docs/GEOMIPMAP.md), so level 0
//    has the smallest geometric error, and its image error is the rasterizer against
//    the ray tracer on the same mesh (GeoMipCommand.RaytraceIsTheLevelZeroMesh: below 0.006
//    at 320x200 on the shipped scene). "The same" but for the border ring of each patch:
//    level 0 draws it as the zipper, whose triangulation differs from the truth's in some
//    ring cells, so level 0's geometric error is small, not 0.

// A 2 x 2 patch geomipmapped terrain: 33 x 33 samples of a smooth 8-bit hill-and-valley
// field (no level but 0 is exact anywhere), over [0, 32]^2, heights x 4.
std::string geomip_scene(const fs::path& dir, const std::string& name = "geo", const std::string& extra = "") {
    std::vector<int> codes;
    for (int y = 0; y < 33; ++y)
        for (int x = 0; x < 33; ++x)
            codes.push_back(static_cast<int>(std::lround(128 + 90 * std::sin(x / 3.1) * std::cos(y / 4.3) + 20 * std::sin((x + y) / 1.7))));
    write_pgm(dir / (name + ".pgm"), 33, 33, 255, codes);
    const std::string toml = "[scene]\nname = \"" + name + "\"\n\n[domain]\nplane = \"xy\"\npatches = [2, 2]\n"
                             "x = [0.0, 32.0]\ny = [0.0, 32.0]\nheightmap = \"" + name + ".pgm\"\nscale_z = 4.0\n\n"
                             "[camera]\nposition = [16.0, -18.0, 26.0]\ntheta = 0.0\nphi = -40.0\nfov_y = 45.0\n"
                             "viewport = [320, 200]\n\n[evaluation]\nmodel = \"geomipmap\"\nerror_bound_px = 2.0\n\n"
                             "[geometry]\nnormals = \"smooth\"\n" + extra;
    write_file(dir / (name + ".toml"), toml);
    return name + ".toml";
}

double number(const std::map<std::string, std::string>& row, const char* column) {
    return std::stod(row.at(column));
}

// [evaluation] level forces every patch's level: 2 (16 / 2^k)^2 triangles per patch, every
// vertex at its sample's height (no tween); a level outside 0..4 and a level beside
// error_bound_px are refused naming the key.
TEST_F(SweepCommand, GeomipForcedLevelHasTheHandDerivedTriangles) {
    const std::string file = geomip_scene(dir_);
    const std::string text = read_file(dir_ / file);
    for (int k = 0; k <= 4; ++k) {
        std::string forced = text;
        forced.replace(forced.find("error_bound_px = 2.0"), 20, "level = " + std::to_string(k));
        const tessref::Scene scene = tessref::load_scene_from_string(forced, (dir_ / file).string());
        const tessref::PipelineResult r = tessref::run_pipeline(scene);
        const int cells = 16 >> k;
        EXPECT_EQ(r.mesh.triangles.size(), 4u * 2u * cells * cells) << k;
        for (const auto& l : r.levels) EXPECT_EQ(l.inner[0], static_cast<float>(k));
    }
    const auto refused = [&](const std::string& to, const std::string& key) {
        std::string bad = text;
        bad.replace(bad.find("error_bound_px = 2.0"), 20, to);
        try {
            tessref::load_scene_from_string(bad, (dir_ / file).string());
            ADD_FAILURE() << to;
        } catch (const tessref::Error& e) {
            EXPECT_NE(e.where().str().find(key), std::string::npos) << e.what();
        }
    };
    refused("level = 5", "evaluation.level");
    refused("level = -1", "evaluation.level");
    refused("level = 1.5", "evaluation.level");
    refused("level = 2\nerror_bound_px = 1.0", "evaluation.level");
}

TEST_F(SweepCommand, GeomipRowsOrderTrianglesAndErrors) {
    const std::string g = geomip_scene(dir_), t = terrain("bump");
    const RunResult r = sweep({g, t, "--levels", "1,2", "--precision", "gpu,exact", "-o", "out"});
    ASSERT_EQ(r.status, 0) << r.err;
    const Csv csv = read_csv(dir_ / "out/sweep.csv");
    EXPECT_EQ(csv.header, kColumns);
    // geo: 2 own + 2 x 5 levels + 2 x 6 bounds; bump: 2 own + 1 spacing x 2 x 2 levels.
    ASSERT_EQ(csv.rows.size(), (2u + 2u * 5u + 2u * 6u) + (2u + 2u * 2u));
    std::vector<std::string> order;
    for (const auto& row : csv.rows)
        order.push_back(row.at("scene") + " " + row.at("model") + " " + row.at("spacing") + " " + row.at("precision") +
                        " " + row.at("level"));
    EXPECT_EQ(order[0], "geo geomipmap  gpu ");
    EXPECT_EQ(order[1], "geo geomipmap  exact ");
    EXPECT_EQ(order[2], "geo geomip_level  gpu 0");
    EXPECT_EQ(order[6], "geo geomip_level  gpu 4");
    EXPECT_EQ(order[7], "geo geomip_level  exact 0");
    EXPECT_EQ(order[12], "geo geomip_bound  gpu 0");
    EXPECT_EQ(order[13], "geo geomip_bound  gpu 0.5");
    EXPECT_EQ(order[17], "geo geomip_bound  gpu 8");
    EXPECT_EQ(order[23], "geo geomip_bound  exact 8");
    EXPECT_EQ(order[24], "bump thesis fractional_odd gpu ");
    EXPECT_EQ(order[26], "bump uniform fractional_odd gpu 1");
    std::map<std::string, const std::map<std::string, std::string>*> by;
    for (const auto& row : csv.rows) by[row.at("model") + " " + row.at("precision") + " " + row.at("level")] = &row;
    for (const char* precision : {"gpu", "exact"}) {
        const std::string p = precision;
        double previous = 1e300;
        for (int k = 0; k <= 4; ++k) {
            const auto& row = *by.at("geomip_level " + p + " " + std::to_string(k));
            const int cells = 16 >> k;
            EXPECT_EQ(row.at("triangles"), std::to_string(4 * 2 * cells * cells)) << k;
            EXPECT_EQ(row.at("patches"), "4");
            previous = number(row, "triangles");
        }
        (void)previous;
        previous = 1e300;
        for (const char* bound : {"0", "0.5", "1", "2", "4", "8"}) {
            const auto& row = *by.at("geomip_bound " + p + " " + bound);
            EXPECT_LE(number(row, "triangles"), previous) << bound;  // non-increasing as the bound grows
            previous = number(row, "triangles");
        }
        EXPECT_LT(previous, 4 * 512);  // the coarsest bound coarsens something
        // Bound 0 keeps every patch at level 0 untweened (no level but 0 is exact): the level-0 row.
        const auto& l0 = *by.at("geomip_level " + p + " 0");
        const auto& b0 = *by.at("geomip_bound " + p + " 0");
        for (const char* column : {"triangles", "points", "geo_max", "geo_rms", "img_rmse", "img_fail_px"})
            EXPECT_EQ(l0.at(column), b0.at(column)) << column;
        // The own row is the bound-2 row (the scene's error_bound_px).
        const auto& own = *by.at("geomipmap " + p + " ");
        const auto& b2 = *by.at("geomip_bound " + p + " 2");
        for (const char* column : {"triangles", "geo_max", "img_rmse"}) EXPECT_EQ(own.at(column), b2.at(column)) << column;
        // The geometric error means what it means for a tessellated terrain: vertical distance to
        // the full-resolution truth. Level 0 has every sample at its true height and the truth's
        // diagonal in the inner 14 x 14 cells of a patch, but its border ring is the zipper
        // (geomipmap.h), which splits some ring cells along the other diagonal and spans two
        // cells at the corners: a small error there only (measured: geo_max 0.125, geo_rms
        // 0.0071 here, against 0.074 at level 1), growing with every coarser level.
        double max = 0.0, rms = 0.0;
        for (int k = 0; k <= 4; ++k) {
            const auto& row = *by.at("geomip_level " + p + " " + std::to_string(k));
            EXPECT_GT(number(row, "geo_max"), 0.0) << k;
            EXPECT_GE(number(row, "geo_max"), max) << k;
            EXPECT_GT(number(row, "geo_rms"), rms) << k;
            max = number(row, "geo_max");
            rms = number(row, "geo_rms");
        }
        EXPECT_LT(number(l0, "geo_rms"), 0.01);
    }
    for (const auto& row : csv.rows) {
        if (row.at("scene") != "geo") continue;
        EXPECT_EQ(row.at("spacing"), "");  // no generator
        for (const char* column : {"geo_max", "geo_rms", "geo_max_px", "img_rmse", "img_psnr", "img_fail_px",
                                   "gpu_exact_max_pos", "gpu_exact_image_differs", "image", "diff_image", "wire_image"})
            EXPECT_FALSE(row.at(column).empty()) << column << " " << row.at("model") << " " << row.at("level");
        EXPECT_EQ(row.at("truth_image"), "images/geo/truth.png");
        EXPECT_TRUE(fs::is_regular_file(dir_ / "out" / row.at("image"))) << row.at("image");
    }
    EXPECT_TRUE(fs::is_regular_file(dir_ / "out/images/geo/geomip-L3-exact.png"));
    EXPECT_TRUE(fs::is_regular_file(dir_ / "out/images/geo/geomip-B0.5-gpu-diff.png"));
    // The report reads the rows and says what does not apply.
    const std::string index = read_file(dir_ / "out/index.html");
    EXPECT_NE(index.find("is a geomipmapped terrain"), std::string::npos);
    EXPECT_NE(index.find("geomip L4"), std::string::npos);
    EXPECT_NE(index.find("bound 0.5 px"), std::string::npos);
    const auto json = nlohmann::json::parse(read_file(dir_ / "out/sweep.json"));
    EXPECT_EQ(json["sweep"]["geomip_levels"].size(), 5u);
    EXPECT_EQ(json["sweep"]["error_bounds"].size(), 6u);
}

// Every column but the timings is the same for any thread count, and shards merge to the
// unsharded run.
TEST_F(SweepCommand, GeomipRowsAreTheSameForAnyThreadCountAndShard) {
    const std::string g = geomip_scene(dir_);
    const std::vector<std::string> common{g, "--geomip-levels", "0,2..3", "--error-bounds", "1,0,4", "--precision",
                                          "gpu,exact"};
    auto with = [&](std::vector<std::string> extra) {
        std::vector<std::string> args = common;
        args.insert(args.end(), extra.begin(), extra.end());
        return args;
    };
    ASSERT_EQ(sweep(with({"-o", "one", "--threads", "1"})).status, 0);
    ASSERT_EQ(sweep(with({"-o", "two", "--threads", "2"})).status, 0);
    EXPECT_EQ(read_csv(dir_ / "one/sweep.csv").rows.size(), 2u + 2u * 3u + 2u * 3u);
    EXPECT_EQ(without_timings(dir_ / "two/sweep.csv"), without_timings(dir_ / "one/sweep.csv"));
    for (int i = 0; i < 2; ++i)
        ASSERT_EQ(sweep(with({"-o", "s" + std::to_string(i), "--shard", std::to_string(i) + "/2"})).status, 0);
    ASSERT_EQ(run_here({"sweep", "merge", "s1", "s0", "-o", "merged"}).status, 0);
    EXPECT_EQ(without_timings(dir_ / "merged/sweep.csv"), without_timings(dir_ / "one/sweep.csv"));
    EXPECT_EQ(read_file(dir_ / "merged/sweep.json"), read_file(dir_ / "one/sweep.json"));
}

TEST_F(SweepCommand, GeomipBadFlagsExitTwoAndWriteNothing) {
    const std::string g = geomip_scene(dir_);
    geomip_scene(dir_, "tight", "\n[limits]\nmax_triangles = 1000\n");  // level 0 needs 2048
    const std::set<std::string> before = files();
    const std::vector<std::pair<std::vector<std::string>, std::string>> cases{
        {{g, "--geomip-levels", "5", "-o", "out"}, "--geomip-levels"},
        {{g, "--geomip-levels", "-1", "-o", "out"}, "--geomip-levels"},
        {{g, "--geomip-levels", "1.5", "-o", "out"}, "--geomip-levels"},
        {{g, "--geomip-levels", "3..1", "-o", "out"}, "--geomip-levels"},
        {{g, "--geomip-levels", "0,,1", "-o", "out"}, "--geomip-levels"},
        {{g, "--error-bounds", "-1", "-o", "out"}, "--error-bounds"},
        {{g, "--error-bounds", "nan", "-o", "out"}, "--error-bounds"},
        {{g, "--error-bounds", "inf", "-o", "out"}, "--error-bounds"},
        {{g, "--error-bounds", "1px", "-o", "out"}, "--error-bounds"},
        {{"tight.toml", "-o", "out"}, "limits.max_triangles"},
        // A bad flag is refused before anything runs, whatever comes after it.
        {{g, "--error-bounds", "2", "--levels", "0", "-o", "out"}, "--levels"},
    };
    for (const auto& [args, named] : cases) {
        const RunResult r = sweep(args);
        EXPECT_EQ(r.status, 2) << args[1] << " " << args[2] << ": " << r.err;
        EXPECT_NE(r.err.find("tessref: error: "), std::string::npos) << r.err;
        EXPECT_NE(r.err.find(named), std::string::npos) << r.err;
        EXPECT_EQ(files(), before) << r.err;
    }
    // "none" drops an axis: the own rows only.
    ASSERT_EQ(sweep({g, "--geomip-levels", "none", "--error-bounds", "none", "-o", "own"}).status, 0);
    EXPECT_EQ(read_csv(dir_ / "own/sweep.csv").rows.size(), 1u);
}

// At the finest setting the picture is the level-0 mesh rasterized, and its error against the
// ray-traced truth is what GeoMipCommand.RaytraceIsTheLevelZeroMesh establishes (the shipped
// scene at 320x200: below 0.006); `tessref compare` on the kept pictures prints the same.
TEST_F(SweepCommand, GeomipLevelZeroIsTheRayTracedTruthUpToRasterization) {
    const RunResult r = run_here({"sweep", (kSource / "data/scenes/jacksboro-geomipmap.toml").string(), "--size",
                                  "320x200", "--geomip-levels", "0", "--error-bounds", "0", "-o", "out"});
    ASSERT_EQ(r.status, 0) << r.err;
    const Csv csv = read_csv(dir_ / "out/sweep.csv");
    ASSERT_EQ(csv.rows.size(), 3u);
    const auto& l0 = csv.rows[1];
    const auto& b0 = csv.rows[2];
    ASSERT_EQ(l0.at("model"), "geomip_level");
    ASSERT_EQ(b0.at("model"), "geomip_bound");
    EXPECT_EQ(l0.at("triangles"), "131072");
    EXPECT_EQ(b0.at("triangles"), "131072");
    EXPECT_EQ(l0.at("img_rmse"), b0.at("img_rmse"));
    const double rmse = number(l0, "img_rmse");
    EXPECT_GT(rmse, 0.0);
    EXPECT_LT(rmse, 0.006);
    EXPECT_LT(rmse, number(csv.rows[0], "img_rmse"));  // the own 4 px bound is coarser
    const RunResult cmp = run_here({"compare", "out/" + l0.at("truth_image"), "out/" + l0.at("image")});
    const std::size_t at = cmp.out.find("rmse");
    ASSERT_NE(at, std::string::npos) << cmp.out;
    EXPECT_NEAR(std::stod(cmp.out.substr(at + 4)), rmse, 1e-4) << cmp.out;
}

// A shard whose pictures are gone (copied without images/, or pruned) is refused: the
// merged report would link to nothing.
TEST_F(SweepCommand, MergeRefusesAShardWhosePicturesAreMissing) {
    const std::string a = terrain("bump");
    for (int i = 0; i < 2; ++i)
        ASSERT_EQ(sweep({a, "--levels", "1,2", "-o", "s" + std::to_string(i), "--shard", std::to_string(i) + "/2"}).status, 0);
    ASSERT_EQ(run_here({"sweep", "merge", "s0", "s1", "-o", "merged"}).status, 0);
    fs::remove_all(dir_ / "merged");
    // One picture of shard 1 removed.
    std::vector<fs::path> pictures;
    for (const auto& e : fs::recursive_directory_iterator(dir_ / "s1" / "images"))
        if (e.is_regular_file()) pictures.push_back(e.path());
    ASSERT_FALSE(pictures.empty());
    std::sort(pictures.begin(), pictures.end());
    fs::remove(pictures.back());
    const RunResult r = run_here({"sweep", "merge", "s0", "s1", "-o", "merged"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("missing from the shard"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("s1/sweep.csv"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "merged"));
}

// The names of the temporary directories of a sweep into `out`, beside it.
std::set<std::string> sweep_temporaries(const fs::path& dir) {
    std::set<std::string> names;
    for (const auto& e : fs::directory_iterator(dir))
        if (e.path().filename().string().rfind(".out.tmp-", 0) == 0) names.insert(e.path().filename().string());
    return names;
}

// Killed by SIGTERM, SIGINT, SIGHUP or SIGQUIT while it runs, a sweep leaves no temporary
// directory (it removes it, then dies of the signal).
TEST_F(SweepCommand, ASweepKilledByASignalLeavesNoTemporaryDirectory) {
    const std::string a = terrain("bump");
    for (const int signal_number : {SIGTERM, SIGINT, SIGHUP, SIGQUIT}) {
        const pid_t child = ::fork();
        ASSERT_GE(child, 0);
        if (child == 0) {
            // A sweep long enough to be caught running: every level, five runs a row.
            ::chdir(dir_.c_str());
            const rlimit no_core{0, 0};
            ::setrlimit(RLIMIT_CORE, &no_core);  // SIGQUIT dumps core by default
            ::signal(signal_number, SIG_DFL);
            const int null = ::open("/dev/null", O_WRONLY);
            ::dup2(null, 1);
            ::dup2(null, 2);
            ::execl(TESSREF_EXE, TESSREF_EXE, "sweep", a.c_str(), "--levels", "1..64", "--repeat", "5", "--size",
                    "320x200", "-o", "out", static_cast<char*>(nullptr));
            ::_exit(127);
        }
        // Wait for the temporary directory (at most 60 s), then send the signal.
        for (int i = 0; i < 6000 && sweep_temporaries(dir_).empty(); ++i) ::usleep(10000);
        ASSERT_FALSE(sweep_temporaries(dir_).empty()) << "signal " << signal_number;
        ::usleep(200000);  // into the rows
        ::kill(child, signal_number);
        int status = 0;
        ASSERT_EQ(::waitpid(child, &status, 0), child);
        EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == signal_number) << "signal " << signal_number;
        EXPECT_TRUE(sweep_temporaries(dir_).empty()) << "signal " << signal_number << ": left " << *sweep_temporaries(dir_).begin();
        EXPECT_FALSE(fs::exists(dir_ / "out"));
    }
}

// What a killed run could not remove (SIGKILL) is removed by the next sweep into the same
// directory: its name holds the dead process's id. A live process's is left alone.
TEST_F(SweepCommand, TheNextSweepRemovesTheTemporaryDirectoryOfAKilledOne) {
    const std::string a = terrain("bump");
    const pid_t gone = ::fork();
    ASSERT_GE(gone, 0);
    if (gone == 0) ::_exit(0);
    ASSERT_EQ(::waitpid(gone, nullptr, 0), gone);
    const std::string stale = ".out.tmp-" + std::to_string(gone) + "-AbC123";
    const std::string live = ".out.tmp-" + std::to_string(::getpid()) + "-XyZ789";
    for (const std::string& name : {stale, live}) {
        fs::create_directories(dir_ / name / "images");
        write_file(dir_ / name / "sweep.csv", "left by a killed run\n");
    }
    ASSERT_EQ(sweep({a, "--levels", "1", "-o", "out"}).status, 0);
    EXPECT_FALSE(fs::exists(dir_ / stale));
    EXPECT_TRUE(fs::exists(dir_ / live));
}

}  // namespace
