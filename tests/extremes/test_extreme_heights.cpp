// Extremes suite (issue 10): height maps and height scales at their limits — one-code
// steps of 16-bit maps, the smallest and the thinnest maps, NaN samples, a zero and a
// negative scale — and a scene whose levels ask for more triangles than the budget.
//
// Where the expected answers come from:
//  - GL's texture sampling: a unorm16 code c reads c / 65535; clamp-to-edge makes the height
//    constant within half a texel of the border; between texel centres it is bilinear
//    (GL 4.6, 8.14.2), so a vertex's height follows from the codes by hand;
//  - the documented limits (include/tessref/heightfield.h, docs/LIMITS.md "Hostile input and
//    limits"): a height field needs 2 x 2 samples, at most 16384 per side; a NaN sample is an
//    error naming the file and the texel unless a nodata policy fills it; a scene whose
//    estimated triangle count exceeds [limits] max_triangles is refused before tessellating;
//  - arithmetic: height = sample * scale_z, so scale 0 gives 0 and scale -s gives exactly
//    the negation of scale s (float multiplication is sign-symmetric).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include <OpenImageIO/imageio.h>

#include "extremes.h"
#include "tessref/render.h"
#include "tessref/scene.h"

namespace {

namespace fs = std::filesystem;
using tessref::test::RunResult;
using tessref::test::write_file;
using namespace tessref::test::extremes;

// A binary 16-bit PGM (P5, big-endian samples, as the format defines them).
void write_pgm16(const fs::path& path, int width, int height, const std::vector<int>& codes) {
    std::string bytes = "P5\n" + std::to_string(width) + " " + std::to_string(height) + "\n65535\n";
    for (int c : codes) {
        bytes += static_cast<char>(c >> 8);
        bytes += static_cast<char>(c & 255);
    }
    write_file(path, bytes);
}

// An image through OpenImageIO: 16-bit PNG or float TIFF, one channel.
template <typename T>
void write_oiio(const fs::path& path, int width, int height, OIIO::TypeDesc type, const std::vector<T>& samples) {
    auto out = OIIO::ImageOutput::create(path.string());
    ASSERT_TRUE(out) << OIIO::geterror();
    ASSERT_TRUE(out->open(path.string(), OIIO::ImageSpec(width, height, 1, type)));
    ASSERT_TRUE(out->write_image(type, samples.data()));
    out->close();
}

using ExtremeHeights = ExtremesTest;

// ---- 16-bit maps: a step of one code ---------------------------------------------------

// A 4 x 2 map whose left two columns hold code c and right two c + 1, under one patch over
// [0, 8]^2 (scale_xy 8) at level 8 (vertices at u = k/8, s = u). With scale_z = 65535 the
// height is the code itself: c where s <= 3/8 (up to texel 1's centre), c + 1/2 at s = 1/2,
// c + 1 from s = 5/8 (texel 2's centre) on. The one-code step must survive every reader.
std::vector<double> heights_along_u(const tessref::PipelineResult& p) {
    std::vector<double> h(9, std::numeric_limits<double>::quiet_NaN());
    for (std::size_t i = 0; i < p.mesh.positions.size(); ++i) {
        const glm::vec3 tc = p.mesh.tess_coords[i];
        if (tc.y == 0.0f) h[static_cast<std::size_t>(std::lround(tc.x * 8.0f))] = p.mesh.positions[i].z;
    }
    return h;
}
Terrain step_scene(const std::string& file) {
    Terrain t;
    t.nu = t.nv = 1;
    t.heightmap = file;
    t.scale_z = 65535.0;
    t.spacing = "equal";
    t.control = "model = \"constant\"\nlevel = 8.0";
    t.eye = {4.0, -6.0, 1008.0};
    t.center = {4.0, 4.0, 1000.0};
    t.far_plane = 100.0;
    return t;
}
void expect_one_code_step(const tessref::Scene& scene, int c) {
    const std::vector<double> h = heights_along_u(tessref::run_pipeline(scene));
    // float's spacing near 40000 is 2^-8; the height is code / 65535 * 65535 in float.
    const double tolerance = 1.0 / 128.0;
    for (int k = 0; k <= 3; ++k) EXPECT_NEAR(h[k], c, tolerance) << "u = " << k << "/8";
    EXPECT_NEAR(h[4], c + 0.5, tolerance) << "u = 1/2";
    for (int k = 5; k <= 8; ++k) EXPECT_NEAR(h[k], c + 1, tolerance) << "u = " << k << "/8";
    EXPECT_NEAR(h[8] - h[0], 1.0, tolerance) << "the step of one code";
}

TEST_F(ExtremeHeights, SixteenBitStepOfOneCode) {
    for (const int c : {0, 1000, 65534}) {
        SCOPED_TRACE("16-bit PNG, codes " + std::to_string(c) + " and " + std::to_string(c + 1));
        const std::vector<std::uint16_t> codes = {
            static_cast<std::uint16_t>(c), static_cast<std::uint16_t>(c), static_cast<std::uint16_t>(c + 1),
            static_cast<std::uint16_t>(c + 1), static_cast<std::uint16_t>(c), static_cast<std::uint16_t>(c),
            static_cast<std::uint16_t>(c + 1), static_cast<std::uint16_t>(c + 1)};
        write_oiio(dir_ / "step.png", 4, 2, OIIO::TypeDesc::UINT16, codes);
        expect_one_code_step(load(step_scene("step.png")), c);
    }
    SCOPED_TRACE("16-bit PGM, codes 1000 and 1001");
    write_pgm16(dir_ / "step.pgm", 4, 2, {1000, 1000, 1001, 1001, 1000, 1000, 1001, 1001});
    expect_one_code_step(load(step_scene("step.pgm")), 1000);
    // The whole way: the render of the step is llvmpipe's, to one 8-bit code (the terrain
    // stands at z = 1000, where the rounding of the float mvp product decides the last bit
    // of a few depths: see ExtremeCamera.TerrainFarFromTheOriginMatchesLlvmpipe).
    write_scene(step_scene("step.pgm"));
    const RunResult r = run({"gl", "scene.toml", "-o", "gl.png"});
    ASSERT_EQ(r.status, 0) << r.err;
    const tessref::RenderResult image = tessref::render_scene(load(step_scene("step.pgm")));
    EXPECT_GT(image.stats.covered_pixels, 1000u);
    EXPECT_EQ(pixels_differing(read_picture(path("gl.png")), image, 1), 0);
}

// The same step in a 16-bit PGM at codes 32768 and 32769. OpenImageIO 2.4.7's PNM reader
// computes v * 65535 / maxval in int, which overflows above 32768 and reads 32769 as 32768:
// the step would vanish without a word and the terrain come out flat. tessref reads such
// samples itself (src/heightfield/load.cpp, reread_pnm16), so the step must survive
// (this test failed before that reader existed).
TEST_F(ExtremeHeights, SixteenBitPgmStepAbove32768) {
    write_pgm16(dir_ / "step.pgm", 4, 2, {32768, 32768, 32769, 32769, 32768, 32768, 32769, 32769});
    expect_one_code_step(load(step_scene("step.pgm")), 32768);
}

// ---- the smallest and the thinnest maps ------------------------------------------------

// 2 x 2 codes 0, 100 / 200, 60 under one patch at level 2 (vertices at s, t in {0, 1/2, 1}):
// the corners lie in the clamp-to-edge border, so they read their texels exactly; the centre
// reads the mean of the four, 90; an edge midpoint the mean of its two texels. (Each mean is
// a whole code, so the 8-bit filter's rounding does not move it.) scale_z = 2.55 makes the
// height a hundredth of the code.
TEST_F(ExtremeHeights, TwoByTwoMapIsBilinear) {
    write_pgm(dir_ / "two.pgm", 2, 2, 255, {0, 100, 200, 60});
    Terrain t;
    t.nu = t.nv = 1;
    t.heightmap = "two.pgm";
    t.scale_z = 2.55;
    t.spacing = "equal";
    t.control = "model = \"constant\"\nlevel = 2.0";
    const tessref::PipelineResult p = tessref::run_pipeline(load(t));
    std::multiset<long> corners, middles;
    double centre = -1.0;
    for (std::size_t i = 0; i < p.mesh.positions.size(); ++i) {
        const glm::vec3 tc = p.mesh.tess_coords[i];
        const double code = p.mesh.positions[i].z * 100.0;
        EXPECT_NEAR(code, std::round(code), 1e-4) << "tess coord " << tc.x << "," << tc.y;
        const int halves = (tc.x == 0.5f) + (tc.y == 0.5f);
        if (halves == 2) centre = code;
        else (halves == 0 ? corners : middles).insert(std::lround(code));
    }
    // Patches share edges, so count each place once.
    EXPECT_EQ(std::set<long>(corners.begin(), corners.end()), (std::set<long>{0, 100, 200, 60}));
    EXPECT_EQ(std::set<long>(middles.begin(), middles.end()), (std::set<long>{50, 100, 130, 80}));
    EXPECT_NEAR(centre, 90.0, 1e-4);
    // Rendered, llvmpipe's picture.
    write_scene(t);
    const RunResult r = run({"gl", "scene.toml", "-o", "gl.png"});
    ASSERT_EQ(r.status, 0) << r.err;
    const tessref::RenderResult image = tessref::render_scene(load(t));
    EXPECT_GT(image.stats.covered_pixels, 1000u);
    EXPECT_EQ(pixels_differing(read_picture(path("gl.png")), image), 0);
}

// A 1 x 1 map has no extent, a 1 x 65536 map is thinner than a height field can be and
// longer than a side may be: exit 2, the file named, nothing written.
TEST_F(ExtremeHeights, TooSmallAndTooThinMapsAreRefused) {
    write_pgm(dir_ / "one.pgm", 1, 1, 255, {7});
    write_file(dir_ / "tall.pgm", "P5\n1 65536\n255\n" + std::string(65536, '\x40'));
    for (const std::string file : {"one.pgm", "tall.pgm"}) {
        SCOPED_TRACE(file);
        Terrain t;
        t.heightmap = file;
        write_scene(t);
        const std::set<std::string> before = files();
        for (const std::vector<std::string>& args : {std::vector<std::string>{"mesh", "scene.toml", "-o", "out.ply"},
                                                     std::vector<std::string>{"render", "scene.toml", "-o", "out.png"}}) {
            const RunResult r = run(args);
            EXPECT_EQ(r.status, 2) << r.err;
            EXPECT_NE(r.err.find("(" + file + ")"), std::string::npos) << r.err;
            EXPECT_NE(r.err.find("key domain.heightmap"), std::string::npos) << r.err;
            EXPECT_EQ(files(), before);
        }
    }
}

// ---- NaN samples ------------------------------------------------------------------------

// A float map with a NaN (PFM written by hand, and a float TIFF through OpenImageIO) is an
// error naming the file and the texel; with nodata_policy = "fill_constant" it loads and the
// texel reads the fill value.
TEST_F(ExtremeHeights, NanHeightsAreAnErrorNamingFileAndTexel) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    // PFM rows run bottom to top: the NaN, second in the file's first row, is texel (1, 1).
    std::string pfm = "Pf\n2 2\n-1.0\n";
    for (const float v : {0.25f, nan, 0.5f, 0.75f}) pfm.append(reinterpret_cast<const char*>(&v), sizeof v);
    write_file(dir_ / "nan.pfm", pfm);
    write_oiio(dir_ / "nan.tif", 2, 2, OIIO::TypeDesc::FLOAT, std::vector<float>{0.25f, 0.5f, nan, 0.75f});
    for (const std::string file : {"nan.pfm", "nan.tif"}) {
        SCOPED_TRACE(file);
        Terrain t;
        t.heightmap = file;
        write_scene(t);
        const std::set<std::string> before = files();
        const RunResult r = run({"render", "scene.toml", "-o", "out.png"});
        EXPECT_EQ(r.status, 2) << r.err;
        EXPECT_NE(r.err.find(file), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("texel (" + std::string(file == "nan.pfm" ? "1, 1" : "0, 1") + ") is NaN"), std::string::npos)
            << r.err;
        EXPECT_EQ(files(), before);
        // Filled, the map loads and the texel reads the fill value.
        t.domain_keys = "nodata_policy = \"fill_constant\"\nfill_value = 0.125\n";
        const tessref::Scene scene = load(t);
        EXPECT_EQ(scene.grid->heightmap->info.missing_texels, 1u);
        EXPECT_EQ(scene.grid->heightmap->texture.texel(0, file == "nan.pfm" ? 1 : 0, 1), 0.125f);
    }
}

// ---- scale_z 0 and negative ----------------------------------------------------------------

// height = sample * scale_z: 0 puts every vertex on z = 0, -2 mirrors the +2 terrain exactly
// (same x and y, z negated bit for bit). Both render as llvmpipe draws them.
TEST_F(ExtremeHeights, ZeroAndNegativeScale) {
    std::vector<int> codes(8 * 8);
    for (int i = 0; i < 64; ++i) codes[i] = (i * 37) % 256;
    write_pgm(dir_ / "bumps.pgm", 8, 8, 255, codes);
    auto scene_with = [&](double scale) {
        Terrain t;
        t.nu = t.nv = 4;
        t.heightmap = "bumps.pgm";
        t.scale_z = scale;
        t.spacing = "equal";
        t.control = "model = \"constant\"\nlevel = 6.0";
        t.eye = {4.0, -6.0, 12.0};
        t.center = {4.0, 4.0, -1.0};
        return t;
    };
    const tessref::PipelineResult up = tessref::run_pipeline(load(scene_with(2.0)));
    const tessref::PipelineResult flat = tessref::run_pipeline(load(scene_with(0.0)));
    const tessref::PipelineResult down = tessref::run_pipeline(load(scene_with(-2.0)));
    ASSERT_EQ(up.mesh.positions.size(), down.mesh.positions.size());
    ASSERT_EQ(up.mesh.positions.size(), flat.mesh.positions.size());
    std::size_t mirrored = 0, zero = 0, raised = 0;
    for (std::size_t i = 0; i < up.mesh.positions.size(); ++i) {
        const glm::dvec3 a = up.mesh.positions[i], b = down.mesh.positions[i], f = flat.mesh.positions[i];
        mirrored += a.x == b.x && a.y == b.y && a.z == -b.z;
        zero += f.x == a.x && f.y == a.y && f.z == 0.0;
        raised += a.z > 0.0;
    }
    EXPECT_EQ(mirrored, up.mesh.positions.size());
    EXPECT_EQ(zero, up.mesh.positions.size());
    EXPECT_GT(raised, up.mesh.positions.size() / 2);  // the map is not flat
    // The triangles still face up (+z) in both: ccw seen from above whatever the heights.
    EXPECT_EQ(up.mesh.triangles, down.mesh.triangles);
    for (const double scale : {0.0, -2.0}) {
        SCOPED_TRACE("scale_z " + num(scale));
        write_scene(scene_with(scale));
        const RunResult r = run({"gl", "scene.toml", "-o", "gl.png"});
        ASSERT_EQ(r.status, 0) << r.err;
        const tessref::RenderResult image = tessref::render_scene(load(scene_with(scale)));
        EXPECT_GT(image.stats.covered_pixels, 1000u);
        EXPECT_EQ(pixels_differing(read_picture(path("gl.png")), image), 0);
    }
}

// ---- the triangle budget ----------------------------------------------------------------

// Level 64 (equal spacing) on every patch gives 8192 triangles a patch (2(64-2)^2 +
// 4(64-2) + 4 * 64): a 64 x 64 grid is 33 554 432 triangles, a 128 x 128 grid 134 217 728.
// Beyond the budget the scene is refused before anything is tessellated: exit 2 within
// seconds, the message naming limits.max_triangles, no file written. The 64 x 64 grid fits
// the default budget of 50 M (it runs: `render --size 64x40` of the grid at 63, 32.5 M
// triangles, took 4.9 s and 2.4 GB on the 2-core test machine), so it is held to a budget
// one triangle short of its count; the 128 x 128 grid exceeds the default.
TEST_F(ExtremeHeights, LevelSixtyFourEverywhereBeyondTheBudgetIsRefusedFast) {
    write_flat_pgm(dir_ / "flat.pgm");
    struct Case {
        int patches;
        std::string limits;
    };
    for (const Case& c : {Case{64, "[limits]\nmax_triangles = 33554431\n"}, Case{128, ""}}) {
        SCOPED_TRACE(std::to_string(c.patches) + " x " + std::to_string(c.patches) + " patches");
        Terrain t;
        t.nu = t.nv = c.patches;
        t.spacing = "equal";
        t.control = "model = \"constant\"\nlevel = 64.0";
        t.tables = c.limits;
        write_scene(t);
        const std::set<std::string> before = files();
        for (const std::vector<std::string>& args : {std::vector<std::string>{"mesh", "scene.toml", "-o", "out.ply"},
                                                     std::vector<std::string>{"render", "scene.toml", "-o", "out.png"}}) {
            const auto start = std::chrono::steady_clock::now();
            const RunResult r = run(args);
            const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            EXPECT_EQ(r.status, 2) << r.err;
            EXPECT_NE(r.err.find("limits.max_triangles"), std::string::npos) << r.err;
            // The estimate it names is an upper bound of the true count.
            const std::size_t up_to = r.err.find("up to ");
            ASSERT_NE(up_to, std::string::npos) << r.err;
            EXPECT_GE(std::stoull(r.err.substr(up_to + 6)), 8192ull * c.patches * c.patches) << r.err;
            EXPECT_LT(seconds, 5.0) << args[0];
            EXPECT_EQ(files(), before);
        }
    }
}

}  // namespace
