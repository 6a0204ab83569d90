// Tests of `tessref render` / `tessref inspect` and the renderer behind them (render.h).
//
// Where the expected values come from:
//  - the flat height field: a plane z = h seen through the scene's camera, intersected
//    analytically (glm::unProject / glm::project, not the renderer's own ray or depth code):
//    the ray-traced and the rasterized images must both show that plane, with the fragment
//    stage fed the plane's analytic inputs;
//  - the level rule and the heat-map colours: render.h's definitions applied by hand;
//  - determinism: the same render with 1, 2 and 4 threads, compared byte for byte;
//  - the AOV EXR against `tessref inspect`: two commands that must tell the same story;
//  - golden images (golden/render/): regression baselines made by tessref itself
//    (scripts/regenerate-golden.sh), compared exactly; see golden/README.md;
//  - the fast paths against their scalar references, bit for bit: the quad derivatives of
//    two triangles at once (SSE2) against quad_derivatives of each.
#include <gtest/gtest.h>

#include "render/render_internal.h"
#include "run_program.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>
#include <OpenImageIO/imageio.h>
#include <tbb/global_control.h>

#include "tessref/error.h"
#include "tessref/prepare.h"
#include "tessref/render.h"
#include "tessref/pipeline.h"
#include "tessref/shading.h"

namespace fs = std::filesystem;

namespace {

using tessref::test::read_file;
using tessref::test::run_program;
using tessref::test::RunResult;
using tessref::test::shell_quote;
using tessref::test::write_file;

const fs::path kSource = TESSREF_SOURCE_DIR;

// Runs `tessref ARGS` from the repository root, stdout and stderr captured.
RunResult run_tessref(const std::vector<std::string>& args, const fs::path& capture_dir) {
    return run_program(TESSREF_EXE, args, capture_dir, kSource);
}

std::vector<std::string> split_words(const std::string& text) {
    std::istringstream in(text);
    std::vector<std::string> words;
    for (std::string w; in >> w;) words.push_back(w);
    return words;
}

// An image read through OpenImageIO: float pixels and channel names.
struct ImageData {
    int width = 0, height = 0, channels = 0;
    std::vector<std::string> names;
    std::vector<float> pixels;
    std::vector<unsigned char> bytes;  // 8-bit images only
    int channel(const std::string& name) const {
        const auto it = std::find(names.begin(), names.end(), name);
        return it == names.end() ? -1 : static_cast<int>(it - names.begin());
    }
    float at(int x, int y, int c) const {
        return pixels[(static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)) *
                          static_cast<std::size_t>(channels) +
                      static_cast<std::size_t>(c)];
    }
};

ImageData read_image(const fs::path& path, bool as_bytes = false) {
    ImageData d;
    auto in = OIIO::ImageInput::open(path.string());
    if (!in) {
        ADD_FAILURE() << "cannot open " << path << ": " << OIIO::geterror();
        return d;
    }
    const OIIO::ImageSpec& spec = in->spec();
    d.width = spec.width;
    d.height = spec.height;
    d.channels = spec.nchannels;
    d.names = spec.channelnames;
    if (as_bytes) {
        d.bytes.resize(static_cast<std::size_t>(d.width) * static_cast<std::size_t>(d.height) *
                       static_cast<std::size_t>(d.channels));
        EXPECT_TRUE(in->read_image(0, 0, 0, d.channels, OIIO::TypeDesc::UINT8, d.bytes.data()));
    } else {
        d.pixels.resize(static_cast<std::size_t>(d.width) * static_cast<std::size_t>(d.height) *
                        static_cast<std::size_t>(d.channels));
        EXPECT_TRUE(in->read_image(0, 0, 0, d.channels, OIIO::TypeDesc::FLOAT, d.pixels.data()));
    }
    in->close();
    return d;
}

class TempDir {
public:
    TempDir() {
        static int counter = 0;
        path_ = fs::temp_directory_path() /
                ("tessref_test_render_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
        fs::remove_all(path_);
        fs::create_directories(path_);
    }
    ~TempDir() { fs::remove_all(path_); }
    const fs::path& path() const { return path_; }

private:
    fs::path path_;
};

fs::path scene_path(const std::string& name) { return kSource / "data" / "scenes" / (name + ".toml"); }

// Every per-pixel buffer of two renders, bit for bit.
void expect_identical(const tessref::RenderResult& a, const tessref::RenderResult& b, const std::string& what) {
    ASSERT_EQ(a.width, b.width) << what;
    ASSERT_EQ(a.height, b.height) << what;
    EXPECT_EQ(tessref::to_rgba8(a), tessref::to_rgba8(b)) << what;
    EXPECT_EQ(0, std::memcmp(a.colour.data(), b.colour.data(), a.colour.size() * sizeof(glm::vec4))) << what;
    EXPECT_EQ(0, std::memcmp(a.depth.data(), b.depth.data(), a.depth.size() * sizeof(float))) << what;
    EXPECT_EQ(a.patch_id, b.patch_id) << what;
    EXPECT_EQ(a.triangle_id, b.triangle_id) << what;
    EXPECT_EQ(0, std::memcmp(a.tess_coord.data(), b.tess_coord.data(), a.tess_coord.size() * sizeof(glm::vec3))) << what;
    EXPECT_EQ(0, std::memcmp(a.level.data(), b.level.data(), a.level.size() * sizeof(float))) << what;
}

}  // namespace

// ---- the [shading] table, the level rule, the heat map ---------------------------------

TEST(RenderShading, WithoutTableIsLinearDepthWithTheCameraPlanes) {
    const std::string text = read_file(scene_path("thesis-map-4"));
    const tessref::Scene scene =
        tessref::load_scene_from_string(text.substr(0, text.find("[shading]")), scene_path("thesis-map-4").string());
    const tessref::RenderShading& s = scene.shading;
    EXPECT_EQ(s.model.kind, tessref::ShadingKind::depth);
    EXPECT_EQ(s.model.depth.mapping, tessref::DepthMapping::linear);
    EXPECT_EQ(s.model.depth.near_plane, static_cast<float>(scene.camera->near_plane));
    EXPECT_EQ(s.model.depth.far_plane, static_cast<float>(scene.camera->far_plane));
    EXPECT_EQ(s.background, glm::vec4(0.0f));  // glClearColor's default
}

TEST(RenderShading, ShippedScenesNameTheirShaders) {
    const std::map<std::string, tessref::ShadingKind> expected{
        {"thesis-all-10", tessref::ShadingKind::thesis_single}, {"cosc422", tessref::ShadingKind::cosc422},
        {"lab4-canyon", tessref::ShadingKind::lab4},            {"pn-triangles", tessref::ShadingKind::pn},
        {"olinda", tessref::ShadingKind::thesis_single}};
    for (const auto& [name, kind] : expected) {
        const tessref::Scene scene = tessref::load_scene(scene_path(name).string());
        const tessref::RenderShading& s = scene.shading;
        EXPECT_EQ(s.model.kind, kind) << name;
        EXPECT_TRUE(tessref::missing_textures(s.model).empty()) << name;
    }
    // The luminance texture reads (r, r, r, 1) and the camera feeds lab 4's cameraPosition.
    // (jacksboro textures itself with its own height map, grey.)
    const tessref::Scene terrain = tessref::load_scene(scene_path("jacksboro").string());
    const auto diffuse = terrain.shading.model.textures.diffuse;
    ASSERT_TRUE(diffuse);
    EXPECT_EQ(diffuse->channels(), 1);
    EXPECT_EQ(diffuse->swizzle(), tessref::Swizzle::luminance);
    const glm::vec4 texel = diffuse->textureLod(glm::vec2(0.37f, 0.61f), 0.0f);
    const glm::vec4 grey = terrain.grid->heightmap->texture.textureLod(glm::vec2(0.37f, 0.61f), 0.0f);
    EXPECT_EQ(texel, glm::vec4(grey.r, grey.r, grey.r, 1.0f));
    const tessref::Scene lab4 = tessref::load_scene(scene_path("lab4-canyon").string());
    EXPECT_EQ(lab4.shading.model.lab4.cameraPosition, glm::vec3(lab4.camera->eye));
}

TEST(RenderShading, BadTablesNameFileLineAndKey) {
    TempDir dir;
    const std::string base = read_file(scene_path("thesis-map-4"));
    const std::string head = base.substr(0, base.find("[shading]"));
    const int shading_line = static_cast<int>(std::count(head.begin(), head.end(), '\n')) + 1;
    struct Case {
        std::string table;
        std::string message;
        std::string key;
        int line_offset;  // line of the key after the [shading] header
    };
    const std::vector<Case> cases{
        {"[shading]\nmodel = \"phong\"\n", "unknown shading model 'phong'", "shading.model", 1},
        {"[shading]\nmodel = \"lab4\"\nlight_position = [1, 2, 3]\n", "not used by shading model lab4",
         "shading.light_position", 2},
        {"[shading]\nmodel = \"thesis_single\"\n", "samples diffuse", "shading.textures", 1},
        {"[shading]\nmodel = \"flat\"\ncolour = [1, 2]\n", "array of 3 or 4 numbers", "shading.colour", 2},
        {"[shading]\nmodel = \"pn\"\ntextures = { diffuse = [1, 1, 1, 1] }\n", "has no sampler 'diffuse'",
         "shading.textures.diffuse", 2},
        {"[shading]\nmodel = \"thesis_single\"\ntextures = { diffuse = \"missing.png\" }\n", "missing.png",
         "shading.textures.diffuse", 2},
    };
    for (const Case& c : cases) {
        std::string text = head + c.table;
        // The scene refers to data by relative paths: make them absolute for the copy.
        for (const std::string dir_name : {"../heightmaps/", "../tessmaps/"}) {
            for (std::size_t at = text.find(dir_name); at != std::string::npos; at = text.find(dir_name)) {
                text.replace(at, dir_name.size(), (kSource / "data" / dir_name.substr(3)).string());
            }
        }
        const fs::path file = dir.path() / "scene.toml";
        write_file(file, text);
        try {
            tessref::load_scene(file.string());
            ADD_FAILURE() << "no error for\n" << c.table;
        } catch (const tessref::Error& e) {
            EXPECT_NE(std::string(e.what()).find(c.message), std::string::npos) << e.what();
            EXPECT_EQ(e.where().key, c.key) << e.what();
            EXPECT_EQ(e.where().file, file.string());
            EXPECT_EQ(e.where().line, shading_line + c.line_offset) << e.message();
        }
    }
}

TEST(RenderLevel, EdgeStripsReadTheirOuterLevelTheInteriorTheLargerInner) {
    // One quad patch, hand-placed vertices: the rule of render.h (LEVEL) applied by hand.
    tessref::PipelineResult p;
    p.levels = {tessref::TessLevels{{2.0f, 3.0f, 4.0f, 5.0f}, {6.0f, 7.0f}}};
    auto add = [&](glm::vec3 tc) {
        p.mesh.positions.emplace_back(tc);
        p.mesh.patch_ids.push_back(0);
        p.mesh.tess_coords.push_back(tc);
        return static_cast<std::uint32_t>(p.mesh.positions.size() - 1);
    };
    const auto corner = add({0, 0, 0}), u0 = add({0, 0.5f, 0}), inner_a = add({0.25f, 0.25f, 0}),
               inner_b = add({0.75f, 0.25f, 0}), inner_c = add({0.5f, 0.75f, 0}), v1 = add({0.5f, 1, 0}),
               u1 = add({1, 0.5f, 0}), v0 = add({0.5f, 0, 0});
    p.mesh.triangles = {
        {corner, inner_a, u0},         // two vertices on u == 0 (outer[0]), one also on v == 0
        {inner_a, inner_b, inner_c},   // interior: max(inner) = 7
        {inner_c, inner_b, v1},        // one vertex on v == 1: outer[3]
        {v0, u1, inner_b},             // one on v == 0 (outer[1]), one on u == 1 (outer[2]): tie -> lower edge
    };
    std::string source;
    EXPECT_EQ(tessref::triangle_level(p, tessref::Domain::quads, 0, &source), 2.0f);
    EXPECT_EQ(source, "outer[0]");
    EXPECT_EQ(tessref::triangle_level(p, tessref::Domain::quads, 1, &source), 7.0f);
    EXPECT_EQ(source, "inner");
    EXPECT_EQ(tessref::triangle_level(p, tessref::Domain::quads, 2, &source), 5.0f);
    EXPECT_EQ(source, "outer[3]");
    EXPECT_EQ(tessref::triangle_level(p, tessref::Domain::quads, 3, &source), 3.0f);
    EXPECT_EQ(source, "outer[1]");
}

TEST(RenderLevel, HeatColoursFollowLog2Level) {
    EXPECT_EQ(tessref::level_heat_colour(1.0f), glm::vec3(0, 0, 1));    // log2 = 0
    EXPECT_EQ(tessref::level_heat_colour(0.5f), glm::vec3(0, 0, 1));    // below 1 reads blue
    EXPECT_EQ(tessref::level_heat_colour(8.0f), glm::vec3(0, 1, 0));    // log2 = 3: the middle stop
    EXPECT_EQ(tessref::level_heat_colour(64.0f), glm::vec3(1, 0, 0));   // log2 = 6
    EXPECT_EQ(tessref::level_heat_colour(1000.0f), glm::vec3(1, 0, 0));
    const glm::vec3 l2 = tessref::level_heat_colour(2.0f);              // t = 1/6: 2/3 of blue -> cyan
    EXPECT_NEAR(l2.g, 2.0f / 3.0f, 1e-6f);
    EXPECT_EQ(tessref::level_heat_colour(std::nanf("")), glm::vec3(0.0f));
}

// to_rgba8 is GL's unorm8 conversion of a colour: NaN as 0, clamped to [0, 1], times 255 in
// float, rounded to nearest (ties to even, as lrint does under the default rounding mode).
// Every code's neighbourhood: k/255 and the midpoints (k + 0.5)/255 a float step either side.
TEST(RenderImage, Rgba8IsTheUnorm8ConversionOfEveryChannel) {
    std::vector<float> values = {std::nanf(""), -std::numeric_limits<float>::infinity(),
                                 std::numeric_limits<float>::infinity(), -0.0f, -1e-30f, 1.0f + 1e-7f, 2.0f, 1e30f};
    for (int k = 0; k <= 255; ++k) {
        for (const float centre : {static_cast<float>(k) / 255.0f, (static_cast<float>(k) + 0.5f) / 255.0f}) {
            float v = centre;
            for (int step = 0; step < 3; ++step) v = std::nextafter(v, -1.0f);
            for (int step = 0; step < 7; ++step, v = std::nextafter(v, 2.0f)) values.push_back(v);
        }
    }
    while (values.size() % 4 != 0) values.push_back(0.5f);
    tessref::RenderResult image;
    image.width = static_cast<int>(values.size() / 4);
    image.height = 1;
    for (std::size_t i = 0; i < values.size(); i += 4)
        image.colour.emplace_back(values[i], values[i + 1], values[i + 2], values[i + 3]);
    const std::vector<std::uint8_t> codes = tessref::to_rgba8(image);
    ASSERT_EQ(codes.size(), values.size());
    for (std::size_t i = 0; i < values.size(); ++i) {
        const float v = values[i];
        const float clamped = std::isnan(v) ? 0.0f : std::min(std::max(v, 0.0f), 1.0f);
        EXPECT_EQ(codes[i], static_cast<std::uint8_t>(std::lrint(clamped * 255.0f))) << "value " << v;
    }
}

// ---- the flat height field: an analytic plane --------------------------------------------

namespace {

// A flat terrain: an 8x8 height map of code 100 (height 100/255 * scale_z), a 2x2 float
// colour texture, the thesis's pipeline with normals from the (generated) normal map.
struct FlatScene {
    TempDir dir;
    fs::path file;
    static constexpr double kExtent = 8.0;
    static constexpr double kScaleZ = 2.0;
    double height = 100.0 / 255.0 * kScaleZ;

    FlatScene() {
        std::string pgm = "P5\n8 8\n255\n" + std::string(64, static_cast<char>(100));
        write_file(dir.path() / "flat.pgm", pgm);
        // A 2x2 float texture (always magnified here: lod <= 0, bilinear on level 0).
        const float texels[2 * 2 * 3] = {0.9f, 0.2f, 0.1f, 0.1f, 0.8f, 0.2f, 0.2f, 0.3f, 0.9f, 0.7f, 0.7f, 0.7f};
        auto out = OIIO::ImageOutput::create((dir.path() / "albedo.exr").string());
        OIIO::ImageSpec spec(2, 2, 3, OIIO::TypeDesc::FLOAT);
        EXPECT_TRUE(out->open((dir.path() / "albedo.exr").string(), spec));
        EXPECT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, texels));
        out->close();
        file = dir.path() / "flat.toml";
        write_file(file, R"([scene]
name = "flat"
[domain]
plane = "xy"
patches = [4, 4]
x = [0.0, 8.0]
y = [0.0, 8.0]
heightmap = "flat.pgm"
scale_xy = 8.0
scale_z = 2.0
[camera]
eye = [4.0, -6.0, 8.0]
center = [4.0, 4.0, 0.0]
up = [0.0, 0.0, 1.0]
fov_y = 45.0
viewport = [160, 100]
[control]
model = "constant"
level = 3.0
[evaluation]
model = "thesis"
[geometry]
normals = "normal_map"
[shading]
model = "thesis_single"
textures = { diffuse = "albedo.exr" }
)");
    }
};

// The analytic view of the plane through pixel (x, row): glm::unProject of the pixel centre at
// the near and far planes, the line intersected with z = h, glm::project for the depth.
struct PlaneHit {
    bool hit = false;
    glm::dvec3 point{0.0};
    double depth = 1.0;
};
PlaneHit analytic_plane(const tessref::SceneCamera& camera, double h, int x, int row) {
    const glm::dvec4 viewport(0, 0, camera.viewport.x, camera.viewport.y);
    const glm::dvec3 window(x + 0.5, camera.viewport.y - 1 - row + 0.5, 0.0);
    const glm::dvec3 a = glm::unProject(window, camera.view(), camera.projection(), viewport);
    const glm::dvec3 b = glm::unProject(glm::dvec3(window.x, window.y, 1.0), camera.view(), camera.projection(), viewport);
    PlaneHit r;
    const double t = (h - a.z) / (b.z - a.z);
    if (!(t >= 0.0 && t <= 1.0)) return r;
    r.hit = true;
    r.point = a + t * (b - a);
    r.depth = glm::project(r.point, camera.view(), camera.projection(), viewport).z;
    return r;
}

// Compares a render of the flat scene with the analytic plane; pixels within `margin` world
// units of the terrain's border are skipped (coverage there is a matter of edge rounding).
void expect_plane(const tessref::RenderResult& image, const FlatScene& flat, double depth_tolerance,
                  float colour_tolerance, const std::string& what) {
    const double margin = 0.05;
    int inside = 0, outside = 0;
    for (int row = 0; row < image.height; ++row) {
        for (int x = 0; x < image.width; ++x) {
            const PlaneHit hit = analytic_plane(image.camera, flat.height, x, row);
            const std::size_t i = image.index(x, row);
            const bool covered = image.triangle_id[i] != tessref::kNoPixelId;
            const double lo = std::min(hit.point.x, hit.point.y), hi = std::max(hit.point.x, hit.point.y);
            if (!hit.hit || lo < -margin || hi > FlatScene::kExtent + margin) {
                EXPECT_FALSE(covered) << what << " pixel " << x << "," << row;
                ++outside;
                continue;
            }
            if (lo < margin || hi > FlatScene::kExtent - margin) continue;
            ++inside;
            ASSERT_TRUE(covered) << what << " pixel " << x << "," << row;
            EXPECT_NEAR(image.depth[i], hit.depth, depth_tolerance) << what << " pixel " << x << "," << row;
            // The fragment stage on the plane's analytic inputs: the flat normal map's texel
            // (127, 127, 255), the texture coordinate xy / scaleXY, magnification.
            tessref::FragmentInputs f;
            f.texCoord = glm::vec2(glm::dvec2(hit.point) / FlatScene::kExtent);
            f.worldPosition = glm::vec3(hit.point);
            f.normal = glm::normalize(glm::vec3(127.0f / 255.0f, 127.0f / 255.0f, 1.0f) - 0.5f);
            f.depth = static_cast<float>(hit.depth);
            const glm::vec4 expected = tessref::shade(image.shading.model, f);
            for (int c = 0; c < 4; ++c)
                EXPECT_NEAR(image.colour[i][c], expected[c], colour_tolerance)
                    << what << " pixel " << x << "," << row << " channel " << c;
        }
    }
    EXPECT_GT(inside, 2500) << what;  // the test saw the plane
    EXPECT_GT(outside, 500) << what;  // and the sky
}

}  // namespace

TEST(RenderGroundTruth, RaytracedFlatHeightFieldIsTheAnalyticPlane) {
    const FlatScene flat;
    const tessref::Scene scene = tessref::load_scene(flat.file.string());
    tessref::RaytraceStats stats;
    const tessref::RenderResult image = tessref::raytrace_scene(scene, {}, &stats);
    // Vertex lines: the two borders and the 8 texel centres, each way.
    EXPECT_EQ(stats.grid_columns, 10);
    EXPECT_EQ(stats.grid_rows, 10);
    EXPECT_EQ(stats.triangles, 2u * 9u * 9u);
    expect_plane(image, flat, 1e-6, 2e-5f, "raytrace");
}

TEST(RenderGroundTruth, RasterizedFlatTerrainIsTheAnalyticPlaneToo) {
    const FlatScene flat;
    const tessref::Scene scene = tessref::load_scene(flat.file.string());
    const tessref::RenderResult image = tessref::render_scene(scene);
    // Float interpolation over the screen: depth and the texture coordinate carry float
    // rounding of the plane equations (a few ulps of window z near 1).
    expect_plane(image, flat, 5e-6, 2e-4f, "raster");
    // Provenance: the world position of a pixel is the plane's point under it.
    const tessref::PixelProvenance p = tessref::pixel_provenance(image, 80, 70);
    const PlaneHit hit = analytic_plane(image.camera, flat.height, 80, 70);
    ASSERT_TRUE(p.covered && hit.hit);
    EXPECT_NEAR(p.world_position.x, hit.point.x, 1e-3);
    EXPECT_NEAR(p.world_position.y, hit.point.y, 1e-3);
    EXPECT_NEAR(p.world_position.z, flat.height, 1e-6);
    EXPECT_EQ(p.patch_levels.outer[0], 3.0f);
    EXPECT_EQ(p.level, 3.0f);
}

TEST(RenderGroundTruth, MeshScenesHaveNoHeightField) {
    const tessref::Scene scene = tessref::load_scene(scene_path("pn-triangles").string());
    tessref::RenderOptions options;
    options.size = {32, 20};
    EXPECT_THROW(tessref::raytrace_scene(scene, options), tessref::Error);
}

// ---- determinism --------------------------------------------------------------------------

namespace {

namespace rd = tessref::render_detail;

// The bits of a result: NaNs (edge-on planes) compare too.
std::array<std::uint32_t, 4> bits_of(const rd::Derivatives& d) {
    return {std::bit_cast<std::uint32_t>(d.dx.x), std::bit_cast<std::uint32_t>(d.dx.y),
            std::bit_cast<std::uint32_t>(d.dy.x), std::bit_cast<std::uint32_t>(d.dy.y)};
}

// Triangles of two kinds: a terrain's (corners in front of the eye, w of either sign and
// near 0 too, over many magnitudes) and small integers (exact products, so differences of
// +0 and -0, weights summing to 0: inf and NaN; mostly zero texture coordinates, so that a
// zero result keeps the sign of zero its weights had). A third of either kind has corners
// shared by two or three vertices (degenerate planes, cross products of 0).
rd::QuadTriangle random_quad_triangle(std::mt19937& rng) {
    std::uniform_int_distribution<int> small(-2, 2), exponent(-30, 30);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    rd::QuadTriangle t;
    const bool integers = rng() % 2;
    for (std::size_t i = 0; i < 3; ++i) {
        if (integers) {
            t.clip[i] = glm::vec4(small(rng), small(rng), small(rng), small(rng));
            t.uv[i] = rng() % 4 ? glm::vec2(0.0f) : glm::vec2(small(rng), small(rng));
        } else {
            const float scale = std::ldexp(1.0f, exponent(rng));
            t.clip[i] = glm::vec4(unit(rng), unit(rng), unit(rng), unit(rng) + 1.5f * unit(rng)) * scale;
            t.uv[i] = glm::vec2(unit(rng), unit(rng)) * std::ldexp(1.0f, exponent(rng) / 3);
        }
    }
    if (rng() % 3 == 0) {
        t.clip[2] = t.clip[rng() % 2];
        if (rng() % 2) t.clip[1] = t.clip[0];
    }
    return t;
}

}  // namespace

TEST(RenderQuadDerivatives, TwoAtOnceAreEachTrianglesOwnBitForBit) {
    std::mt19937 rng(20240611u);
    std::uniform_int_distribution<int> size(1, 16384);
    int checked = 0;
    for (int n = 0; n < 200000; ++n) {
        const int width = size(rng), height = size(rng);
        const int x0 = 2 * static_cast<int>(rng() % static_cast<unsigned>((width + 1) / 2));
        const int row0 = 2 * static_cast<int>(rng() % static_cast<unsigned>((height + 1) / 2));
        const rd::QuadNdc ndc{rd::pixel_ndc(x0, row0, width, height), rd::pixel_ndc(x0 + 1, row0 + 1, width, height)};
        // Up to four triangles, as a quad shows: every count's pairs and odd last one.
        const int count = 1 + n % 4;
        rd::QuadTriangle triangles[4];
        for (int k = 0; k < count; ++k) triangles[k] = random_quad_triangle(rng);
        rd::Derivatives out[4];
        rd::quad_derivatives(triangles, count, ndc, out);
        for (int k = 0; k < count; ++k) {
            const rd::Derivatives expected = rd::quad_derivatives(triangles[k], ndc);
            ASSERT_EQ(bits_of(out[k]), bits_of(expected)) << "case " << n << " triangle " << k << " of " << count;
            ++checked;
        }
    }
    EXPECT_EQ(checked, 500000);
}

TEST(RenderDeterminism, ByteIdenticalWithOneTwoAndFourThreads) {
    struct Case {
        std::string scene;
        tessref::RenderMode mode;
        bool raytrace;
    };
    const std::vector<Case> cases{{"thesis-all-10", tessref::RenderMode::fill, false},
                                  {"lab4-canyon", tessref::RenderMode::fill_with_wireframe, false},
                                  {"pn-triangles", tessref::RenderMode::wireframe, false},
                                  {"jacksboro", tessref::RenderMode::fill, true}};
    for (const Case& c : cases) {
        const tessref::Scene scene = tessref::load_scene(scene_path(c.scene).string());
        tessref::RenderOptions options;
        options.size = {200, 125};
        options.mode = c.mode;
        std::vector<tessref::RenderResult> images;
        for (const std::size_t threads : {1u, 2u, 4u}) {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
            images.push_back(c.raytrace ? tessref::raytrace_scene(scene, options) : tessref::render_scene(scene, options));
        }
        EXPECT_GT(images[0].stats.covered_pixels, 0u) << c.scene;
        expect_identical(images[0], images[1], c.scene + " 1 vs 2 threads");
        expect_identical(images[0], images[2], c.scene + " 1 vs 4 threads");
    }
}

TEST(RenderDeterminism, CommandWritesTheSameFilesWhateverTheThreads) {
    TempDir dir;
    std::vector<std::string> exr, png;
    for (const std::string threads : {"1", "2", "4"}) {
        const fs::path e = dir.path() / ("t" + threads + ".exr"), p = dir.path() / ("t" + threads + ".png");
        const RunResult with_aovs =
            run_tessref({"render", "data/scenes/thesis-map-18.toml", "-o", e.string(), "--size", "160x100", "--aov",
                         "depth,patch,triangle,tesscoord,level", "--threads", threads},
                        dir.path());
        ASSERT_EQ(with_aovs.status, 0) << with_aovs.err;
        const RunResult plain = run_tessref(
            {"render", "data/scenes/thesis-map-18.toml", "-o", p.string(), "--size", "160x100", "--threads", threads},
            dir.path());
        ASSERT_EQ(plain.status, 0) << plain.err;
        exr.push_back(read_file(e));
        png.push_back(read_file(p));
    }
    EXPECT_FALSE(exr[0].empty());
    EXPECT_EQ(exr[0], exr[1]);
    EXPECT_EQ(exr[0], exr[2]);
    EXPECT_EQ(png[0], png[1]);
    EXPECT_EQ(png[0], png[2]);
}

// ---- modes ----------------------------------------------------------------------------------

TEST(RenderModes, WireframeDiffersFromFillAndOverlayOnlyAddsLines) {
    const tessref::Scene scene = tessref::load_scene(scene_path("thesis-map-4").string());
    tessref::RenderOptions options;
    options.size = {160, 100};
    const tessref::RenderResult fill = tessref::render_scene(scene, options);
    options.mode = tessref::RenderMode::wireframe;
    const tessref::RenderResult lines = tessref::render_scene(scene, options);
    options.mode = tessref::RenderMode::fill_with_wireframe;
    const tessref::RenderResult overlay = tessref::render_scene(scene, options);

    EXPECT_NE(tessref::to_rgba8(fill), tessref::to_rgba8(lines));
    EXPECT_GT(lines.stats.covered_pixels, 0u);
    EXPECT_LT(lines.stats.covered_pixels, fill.stats.covered_pixels);  // lines leave gaps
    std::size_t line_pixels = 0;
    for (std::size_t i = 0; i < fill.colour.size(); ++i) {
        // The overlay is the fill image except where a line is drawn, in the wireframe colour,
        // and only where the wireframe image has a line.
        if (overlay.colour[i] != fill.colour[i]) {
            ++line_pixels;
            EXPECT_EQ(overlay.colour[i], overlay.shading.wireframe_colour) << i;
            EXPECT_NE(lines.triangle_id[i], tessref::kNoPixelId) << i;
        }
        EXPECT_EQ(overlay.triangle_id[i], fill.triangle_id[i]);  // the AOVs are the fill's
    }
    EXPECT_GT(line_pixels, 500u);
    // Hidden lines stay hidden: fewer line pixels than the wireframe image has.
    EXPECT_LT(line_pixels, lines.stats.covered_pixels);
}

// ---- the command: AOVs and inspect -----------------------------------------------------------

TEST(RenderCommand, AovChannelsAgreeWithInspect) {
    TempDir dir;
    const fs::path exr = dir.path() / "aov.exr";
    const RunResult r = run_tessref({"render", "data/scenes/lab4-canyon.toml", "-o", exr.string(), "--size", "160x100",
                                     "--aov", "depth,patch,triangle,tesscoord,level"},
                                    dir.path());
    ASSERT_EQ(r.status, 0) << r.err;
    const ImageData image = read_image(exr);
    ASSERT_EQ(image.width, 160);
    ASSERT_EQ(image.height, 100);
    for (const std::string name : {"R", "G", "B", "A", "Z", "patch_id", "triangle_id", "tess_coord.u", "tess_coord.v",
                                   "tess_coord.w", "level", "level_heat.R", "level_heat.G", "level_heat.B"})
        EXPECT_GE(image.channel(name), 0) << "missing channel " << name;
    ASSERT_EQ(image.channels, 14);

    // A background pixel (the sky, top row) and covered ones lower down.
    for (const auto& [x, y] : std::vector<std::pair<int, int>>{{80, 0}, {80, 70}, {20, 90}, {141, 55}}) {
        const RunResult i = run_tessref({"inspect", "data/scenes/lab4-canyon.toml", "--size", "160x100", "--pixel",
                                         std::to_string(x) + "," + std::to_string(y), "--json"},
                                        dir.path());
        ASSERT_EQ(i.status, 0) << i.err;
        const nlohmann::json j = nlohmann::json::parse(i.out);
        const bool covered = j.at("covered").get<bool>();
        EXPECT_EQ(covered, image.at(x, y, image.channel("patch_id")) >= 0.0f) << x << "," << y;
        EXPECT_EQ(j.at("depth").get<float>(), image.at(x, y, image.channel("Z")));
        for (int c = 0; c < 4; ++c)
            EXPECT_EQ(j.at("colour")[static_cast<std::size_t>(c)].get<float>(), image.at(x, y, c));
        if (!covered) continue;
        EXPECT_EQ(static_cast<float>(j.at("patch_id").get<std::uint32_t>()), image.at(x, y, image.channel("patch_id")));
        EXPECT_EQ(static_cast<float>(j.at("triangle_id").get<std::uint32_t>()),
                  image.at(x, y, image.channel("triangle_id")));
        EXPECT_EQ(j.at("tess_coord")[0].get<float>(), image.at(x, y, image.channel("tess_coord.u")));
        EXPECT_EQ(j.at("tess_coord")[1].get<float>(), image.at(x, y, image.channel("tess_coord.v")));
        EXPECT_EQ(j.at("level").get<float>(), image.at(x, y, image.channel("level")));
        const glm::vec3 heat = tessref::level_heat_colour(j.at("level").get<float>());
        EXPECT_EQ(heat.r, image.at(x, y, image.channel("level_heat.R")));
    }
}

// `--aov level` to a PNG: the heat map for eyes. Its picture rows are the EXR's level_heat
// channels as 8-bit codes (the same colour map, pixel for pixel), and below them a legend
// band whose bar runs from level 1's colour (blue) at its left end to level 64's (red) at its
// right. Any other AOV in a PNG is still refused (BadInputExitsTwoAndWritesNothing).
TEST(RenderCommand, LevelHeatMapAsAPngWithItsLegend) {
    TempDir dir;
    const fs::path exr = dir.path() / "level.exr", png = dir.path() / "level.png";
    for (const fs::path& out : {exr, png}) {
        const RunResult r = run_tessref({"render", "data/scenes/thesis-all-10.toml", "-o", out.string(), "--size",
                                         "160x100", "--aov", "level"},
                                        dir.path());
        ASSERT_EQ(r.status, 0) << r.err;
    }
    const ImageData floats = read_image(exr), heat = read_image(png);
    ASSERT_EQ(heat.width, 160);
    ASSERT_GT(heat.height, 100 + 16);  // the legend's band
    ASSERT_EQ(heat.channels, 3);
    const auto code = [](float v) { return std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f); };
    std::size_t differ = 0, surface = 0;
    for (int y = 0; y < 100; ++y)
        for (int x = 0; x < 160; ++x) {
            surface += std::isnan(floats.at(x, y, floats.channel("level"))) ? 0 : 1;
            for (int c = 0; c < 3; ++c) {
                const char* name[] = {"level_heat.R", "level_heat.G", "level_heat.B"};
                differ += code(floats.at(x, y, floats.channel(name[c]))) != code(heat.at(x, y, c)) ? 1 : 0;
            }
        }
    EXPECT_EQ(differ, 0u);
    EXPECT_GT(surface, 1000u);
    // The bar: find the row of the band with the most blue-to-red, and read its two ends.
    bool blue_then_red = false;
    for (int y = 100; y < heat.height && !blue_then_red; ++y) {
        int first = -1, last = -1;
        for (int x = 0; x < 160; ++x)
            if (heat.at(x, y, 0) + heat.at(x, y, 1) + heat.at(x, y, 2) > 0.0f && heat.at(x, y, 0) + heat.at(x, y, 1) +
                                                                                      heat.at(x, y, 2) < 2.9f) {
                if (first < 0) first = x;
                last = x;
            }
        if (first < 0 || last - first < 100) continue;
        blue_then_red = code(heat.at(first, y, 2)) == 255 && code(heat.at(first, y, 0)) == 0 &&
                        code(heat.at(last, y, 0)) == 255 && code(heat.at(last, y, 2)) == 0;
    }
    EXPECT_TRUE(blue_then_red);
}

// inspect --pixel --capture: the capture's values for the pixel's patch and its triangle's
// tess coords beside the reference's. The CPU's own capture (`mesh --capture`, the same
// pipeline) agrees everywhere; the same capture with one corner's z raised by 1 and the
// patch's outer[0] changed says so for that corner and the levels, with the difference.
TEST(RenderCommand, InspectPixelBesideACapture) {
    TempDir dir;
    const std::string scene = "data/scenes/thesis-map-4.toml";  // its levels do not depend on the viewport
    const fs::path capture = dir.path() / "cpu.txt", edited = dir.path() / "edited.txt";
    ASSERT_EQ(run_tessref({"mesh", scene, "--capture", capture.string()}, dir.path()).status, 0);
    const std::vector<std::string> inspect{"inspect", scene, "--size", "160x100", "--pixel", "80,60", "--capture"};
    auto with = [&](const fs::path& file, bool json) {
        std::vector<std::string> args = inspect;
        args.push_back(file.string());
        if (json) args.push_back("--json");
        return run_tessref(args, dir.path());
    };
    const RunResult same = with(capture, true);
    ASSERT_EQ(same.status, 0) << same.err;
    const nlohmann::json j = nlohmann::json::parse(same.out);
    ASSERT_TRUE(j.at("covered").get<bool>());
    const nlohmann::json& c = j.at("capture");
    EXPECT_TRUE(c.at("patch_levels_equal").get<bool>());
    ASSERT_EQ(c.at("corners").size(), 3u);
    for (const auto& corner : c.at("corners")) {
        ASSERT_TRUE(corner.at("found").get<bool>());
        EXPECT_EQ(corner.at("position"), corner.at("reference_position"));
        EXPECT_EQ(corner.at("position_ulps").get<int>(), 0);
    }
    const RunResult text = with(capture, false);
    EXPECT_NE(text.out.find("capture " + capture.string() + ": "), std::string::npos) << text.out;
    EXPECT_NE(text.out.find("levels: outer"), std::string::npos);
    EXPECT_EQ(text.out.find("the reference "), std::string::npos) << text.out;  // nothing differs

    // Raise corner 0 (every copy of its domain point in the patch) by 1 and change outer[0].
    const std::string patch = std::to_string(j.at("patch_id").get<std::uint32_t>());
    std::array<float, 3> t{};
    for (int k = 0; k < 3; ++k) t[static_cast<std::size_t>(k)] = c.at("corners")[0].at("tess_coord")[k].get<float>();
    std::istringstream in(read_file(capture));
    std::string out, line;
    float z = 0.0f;
    while (std::getline(in, line)) {
        std::vector<std::string> w = split_words(line);
        if (w.size() == 9 && w[0] == "patch" && w[1] == patch && w[2] == "levels") {
            w[3] = "7.25";
        } else if (w.size() == 10 && w[0] == patch && std::stof(w[1]) == t[0] && std::stof(w[2]) == t[1] &&
                   std::stof(w[3]) == t[2]) {
            z = std::stof(w[6]);
            char raised[32];
            std::snprintf(raised, sizeof raised, "%.9g", static_cast<double>(z + 1.0f));
            w[6] = raised;
        } else {
            out += line + "\n";
            continue;
        }
        for (std::size_t k = 0; k < w.size(); ++k) out += (k ? " " : "") + w[k];
        out += "\n";
    }
    write_file(edited, out);
    const RunResult changed = with(edited, true);
    ASSERT_EQ(changed.status, 0) << changed.err;
    const nlohmann::json e = nlohmann::json::parse(changed.out).at("capture");
    EXPECT_FALSE(e.at("patch_levels_equal").get<bool>());
    EXPECT_EQ(e.at("patch_levels").at("outer")[0].get<float>(), 7.25f);
    EXPECT_EQ(e.at("corners")[0].at("position_difference")[2].get<float>(), (z + 1.0f) - z);
    EXPECT_GT(e.at("corners")[0].at("position_ulps").get<int>(), 0);
    EXPECT_EQ(e.at("corners")[1].at("position_ulps").get<int>(), 0);
    const RunResult changed_text = with(edited, false);
    EXPECT_NE(changed_text.out.find("(the reference: outer"), std::string::npos) << changed_text.out;
    EXPECT_NE(changed_text.out.find("corner 0 at tess coord"), std::string::npos);
    EXPECT_NE(changed_text.out.find("ulps at most)"), std::string::npos) << changed_text.out;
    // A capture that is not one is refused before the render.
    write_file(dir.path() / "bad.txt", "not a capture\n");
    EXPECT_EQ(with(dir.path() / "bad.txt", false).status, 2);
}

TEST(RenderCommand, InspectTextNamesThePixelsOrigin) {
    TempDir dir;
    const RunResult r =
        run_tessref({"inspect", "data/scenes/thesis-map-4.toml", "--size", "160x100", "--pixel", "80,60"}, dir.path());
    ASSERT_EQ(r.status, 0) << r.err;
    for (const std::string field : {"pixel 80,60 (GL window 80,39)", "covered: yes", "patch: ", "triangle: ",
                                    "tess coord: ", "level: ", "world position: ", "depth: ", "colour: "})
        EXPECT_NE(r.out.find(field), std::string::npos) << field << " in\n" << r.out;
}

TEST(RenderCommand, BadInputExitsTwoAndWritesNothing) {
    TempDir dir;
    const fs::path out = dir.path() / "out.png";
    write_file(out, "sentinel");  // an existing file must survive a failed run untouched
    const fs::path exr = dir.path() / "out.exr";
    struct Case {
        std::vector<std::string> args;
        std::string message;
    };
    const std::vector<Case> cases{
        {{"render", "data/scenes/no-such-scene.toml", "-o", out.string()}, "no-such-scene"},
        {{"render", "data/scenes/thesis-map-4.toml", "-o", exr.string(), "--aov", "depth,normals"}, "unknown AOV"},
        {{"render", "data/scenes/thesis-map-4.toml", "-o", out.string(), "--aov", "depth"}, "exr"},
        {{"render", "data/scenes/thesis-map-4.toml", "-o", out.string(), "--size", "0x200"}, "--size"},
        {{"render", "data/scenes/thesis-map-4.toml", "-o", out.string(), "--size", "320"}, "--size"},
        {{"render", "data/scenes/thesis-map-4.toml", "-o", out.string(), "--size", "20000x10"}, "--size"},
        {{"render", "data/scenes/thesis-map-4.toml", "-o", out.string(), "--size", "axb"}, "--size"},
        {{"render", "data/scenes/thesis-map-4.toml", "-o", (dir.path() / "out.jpg").string()}, ".png"},
        {{"render", "data/scenes/thesis-map-4.toml", "-o", out.string(), "--precision", "half"}, "precision"},
        {{"render", "data/scenes/thesis-map-4.toml", "-o", out.string(), "--threads", "-2"}, "--threads"},
        {{"render", "data/scenes/thesis-map-4.toml", "-o", out.string(), "--wireframe", "--overlay-wireframe"},
         "exclude"},
        {{"render", "data/scenes/pn-triangles.toml", "-o", out.string(), "--raytrace", "--size", "32x20"},
         "terrain"},
        {{"render", "data/scenes/thesis-map-4.toml", "-o", (dir.path() / "no-dir" / "x.png").string()}, "no-dir"},
        {{"inspect", "data/scenes/thesis-map-4.toml", "--size", "32x20", "--pixel", "32,0"}, "outside"},
        {{"inspect", "data/scenes/thesis-map-4.toml", "--size", "32x20", "--pixel", "-1,3"}, "--pixel"},
        {{"inspect", "data/scenes/thesis-map-4.toml", "--pixel", "3;4"}, "--pixel"},
        {{"inspect", "data/scenes/no-such-scene.toml", "--pixel", "3,4"}, "no-such-scene"},
    };
    for (const Case& c : cases) {
        const RunResult r = run_tessref(c.args, dir.path());
        std::string line;
        for (const std::string& a : c.args) line += a + " ";
        EXPECT_EQ(r.status, 2) << line << "\n" << r.err;
        EXPECT_EQ(r.err.rfind("tessref: error: ", 0), 0u) << line << "\n" << r.err;
        EXPECT_NE(r.err.find(c.message), std::string::npos) << line << "\n" << r.err;
        EXPECT_TRUE(r.out.empty()) << line;
    }
    EXPECT_EQ(read_file(out), "sentinel");
    for (const auto& entry : fs::directory_iterator(dir.path())) {
        const std::string name = entry.path().filename().string();
        EXPECT_TRUE(name == "out.png" || name.rfind("captured.", 0) == 0) << "left behind: " << name;
    }
}

// ---- golden images -----------------------------------------------------------------------------

namespace {

struct GoldenCase {
    std::string image;
    std::vector<std::string> args;
};

std::vector<GoldenCase> golden_cases() {
    std::vector<GoldenCase> cases;
    std::istringstream in(read_file(kSource / "golden" / "render" / "cases.txt"));
    for (std::string line; std::getline(in, line);) {
        if (line.empty() || line[0] == '#') continue;
        std::vector<std::string> words = split_words(line);
        if (words.empty()) continue;
        GoldenCase c;
        c.image = words.front();
        c.args.assign(words.begin() + 1, words.end());
        cases.push_back(c);
    }
    return cases;
}

}  // namespace

TEST(RenderGolden, CasesAreListedInTheReadme) {
    const std::vector<GoldenCase> cases = golden_cases();
    ASSERT_GE(cases.size(), 6u);  // the plain renders are golden/<scene>/image.png (golden verify)
    const std::string readme = read_file(kSource / "golden" / "README.md");
    for (const GoldenCase& c : cases) {
        std::string command = "tessref render";
        for (const std::string& a : c.args) command += " " + a;
        command += " -o golden/render/" + c.image;
        EXPECT_NE(readme.find(command), std::string::npos) << "golden/README.md lacks: " << command;
        EXPECT_TRUE(fs::exists(kSource / "golden" / "render" / c.image)) << c.image;
    }
}

TEST(RenderGolden, EveryImageRendersAgainPixelForPixel) {
    TempDir dir;
    for (const GoldenCase& c : golden_cases()) {
        const fs::path out = dir.path() / c.image;
        std::vector<std::string> args{"render"};
        args.insert(args.end(), c.args.begin(), c.args.end());
        args.insert(args.end(), {"-o", out.string()});
        const RunResult r = run_tessref(args, dir.path());
        ASSERT_EQ(r.status, 0) << c.image << ": " << r.err;
        const ImageData golden = read_image(kSource / "golden" / "render" / c.image, true);
        const ImageData now = read_image(out, true);
        ASSERT_EQ(golden.width, now.width) << c.image;
        ASSERT_EQ(golden.height, now.height) << c.image;
        ASSERT_EQ(golden.channels, now.channels) << c.image;
        std::size_t differing = 0, first = golden.bytes.size();
        for (std::size_t i = 0; i < golden.bytes.size(); ++i) {
            if (golden.bytes[i] != now.bytes[i]) {
                ++differing;
                first = std::min(first, i);
            }
        }
        EXPECT_EQ(differing, 0u) << c.image << ": " << differing << " bytes differ, the first at pixel "
                                 << (first / 4) % static_cast<std::size_t>(golden.width) << ","
                                 << (first / 4) / static_cast<std::size_t>(golden.width)
                                 << " (regenerate with scripts/regenerate-golden.sh only if the change is intended)";
    }
}
