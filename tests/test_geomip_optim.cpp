// tests/test_geomip_optim.cpp — the geomorphing article's remaining techniques on a
// geomipmapped terrain: the light map and the material passes (shading model
// geomip_lightmap), frustum culling of patches and the potentially visible set.
//
// Where the expected answers come from:
//  - the light map: the cross product of two neighbour vectors worked out by hand for a map
//    whose neighbouring heights are chosen for it (below, in each test);
//  - the blend: one-texel textures of known values, the alpha blend src * a + dst * (1 - a)
//    and the modulations done by hand;
//  - culling: a camera over the terrain's middle looking along +x cannot see a point with
//    x <= its own x and below it (angle to the view axis > 78 degrees, outside a 45 degree
//    frustum), so the western half of the patches is culled;
//  - the PVS: a plateau of height 10 (a whole column of patches) across a flat map; the
//    occluder is the plateau lowered by 0.01 and eroded by 4 samples at its borders
//    (x in [53, 59]), targets stand 0.01 over their patch's highest sample, and a line of
//    sight from height z at x_s to the ground at x_t passes x = 59 at
//    z (x_t - 59) / (x_t - x_s) + 0.01 (59 - x_s) / (x_t - x_s) (similar triangles);
//    > 10 (similar triangles).
#include <array>
#include <cmath>
#include <memory>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "command_dir_test.h"
#include "scratch_dir.h"
#include "tessref/error.h"
#include "geomip_maps.h"
#include "tessref/geomipmap.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"
#include "tessref/render.h"
#include "tessref/scene.h"
#include "tessref/shading.h"

using namespace tessref;
using namespace tessref::geomip;

namespace {

const tessref::test::ScratchDir& scratch = tessref::test::ScratchDir::add("geomip_optim");
const std::string kScenes = std::string(TESSREF_SOURCE_DIR) + "/data/scenes/";
const std::string kLit = kScenes + "jacksboro-geomipmap-lit.toml";

using tessref::test::flat_map;

std::string replaced(std::string text, const std::string& from, const std::string& to) {
    const std::size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
    return text;
}

std::shared_ptr<const Texture> texel(glm::vec4 v) {
    return std::make_shared<const Texture>(Texture::from_float(1, 1, 4, {v.r, v.g, v.b, v.a}));
}

// The key of the error load_scene_from_string(text) throws ("" when it loads).
Error load_error(const std::string& text, const std::string& path) {
    try {
        load_scene_from_string(text, path);
    } catch (const Error& e) {
        return e;
    }
    return Error("loaded");
}

}  // namespace

// ---- the light map -------------------------------------------------------------------

TEST(GeoMipLightMap, TheTexelIsTheDiffuseLightOfTheCrossProduct) {
    // Sample (0, 0) = 0 with (1, 0) = 0.5 and (0, 1) = 0.25; spacing (2, 1), scale_z 4:
    // a = (2, 0, 2), b = (0, 1, 1), a x b = (0*1 - 2*1, 2*0 - 2*1, 2*1 - 0*0) = (-2, -2, 2),
    // n = (-1, -1, 1) / sqrt(3). Light straight up: dot = 1/sqrt(3); ambient 0.2:
    // 0.2 + 0.8 / sqrt(3).
    HeightSamples map = flat_map(17, 17);
    map.samples[1] = 0.5;
    map.samples[17] = 0.25;
    const glm::dvec3 n = sample_normal(map, {2.0, 1.0}, 4.0, 0, 0);
    EXPECT_NEAR(n.x, -1.0 / std::sqrt(3.0), 1e-15);
    EXPECT_NEAR(n.y, -1.0 / std::sqrt(3.0), 1e-15);
    EXPECT_NEAR(n.z, 1.0 / std::sqrt(3.0), 1e-15);
    const std::vector<double> light = light_map(map, {2.0, 1.0}, 4.0, {{0.0, 0.0, 1.0}, 0.2});
    EXPECT_NEAR(light[0], 0.2 + 0.8 / std::sqrt(3.0), 1e-15);
    // A sample with flat neighbours faces straight up: 0.2 + 0.8 * 1.
    EXPECT_NEAR(light[5 * 17 + 5], 1.0, 1e-15);
    // Facing away from the light: max(dot, 0) leaves the ambient. Light along +x:
    // dot(n, (1, 0, 0)) = -1/sqrt(3) < 0.
    EXPECT_NEAR(light_map(map, {2.0, 1.0}, 4.0, {{1.0, 0.0, 0.0}, 0.2})[0], 0.2, 1e-15);
}

TEST(GeoMipLightMap, TheLastColumnAndRowUseTheNeighbourBehind) {
    // A ramp h = 0.01 x: at the last column the vector from (15, y) to (16, y) is still
    // (dx, 0, 0.01 scale_z), so the normal is the ramp's everywhere: (-0.01 s, 0, dx) / |.|.
    HeightSamples map = flat_map(17, 17);
    for (int y = 0; y < 17; ++y)
        for (int x = 0; x < 17; ++x) map.samples[static_cast<std::size_t>(y) * 17 + x] = 0.01 * x;
    const double s = 10.0, dx = 0.5;
    const glm::dvec3 expected = glm::normalize(glm::dvec3(-0.01 * s * 1.0, 0.0, dx * 1.0));
    for (const glm::ivec2 at : {glm::ivec2(16, 3), glm::ivec2(3, 16), glm::ivec2(16, 16), glm::ivec2(7, 7)}) {
        const glm::dvec3 n = sample_normal(map, {dx, 1.0}, s, at.x, at.y);
        EXPECT_NEAR(glm::length(n - expected), 0.0, 1e-12) << at.x << "," << at.y;
    }
}

TEST(GeoMipLightmapShading, MaterialsBlendByTheirAlphaAndTheCloudsMultiply) {
    // Light 0.5; base (0.2, 0.4, 0.6) -> (0.1, 0.2, 0.3); rock (1, 0, 0) * 0.5 = (0.5, 0, 0)
    // at alpha 0.25 -> (0.1 + 0.25 * 0.4, 0.2 - 0.25 * 0.2, 0.3 - 0.25 * 0.3) =
    // (0.2, 0.15, 0.225); dry (0, 1, 0) * 0.5 = (0, 0.5, 0) at alpha 0.5 -> (0.1, 0.325,
    // 0.1125); clouds 0.8 -> (0.08, 0.26, 0.09).
    GeomipLightmapShading u;
    u.lightMap = texel(glm::vec4(0.5f));
    u.materials.push_back({texel({0.2f, 0.4f, 0.6f, 1.0f}), 7.0f, nullptr});
    u.materials.push_back({texel({1.0f, 0.0f, 0.0f, 1.0f}), 3.0f, texel(glm::vec4(0.25f))});
    u.materials.push_back({texel({0.0f, 1.0f, 0.0f, 1.0f}), 5.0f, texel(glm::vec4(0.5f))});
    FragmentInputs f;
    f.texCoord = {0.3f, 0.7f};
    const glm::vec4 without = geomip_lightmap(f, u);
    EXPECT_NEAR(without.r, 0.1f, 1e-6f);
    EXPECT_NEAR(without.g, 0.325f, 1e-6f);
    EXPECT_NEAR(without.b, 0.1125f, 1e-6f);
    EXPECT_EQ(without.a, 1.0f);
    u.clouds = texel(glm::vec4(0.8f));
    const glm::vec4 with = geomip_lightmap(f, u);
    EXPECT_NEAR(with.r, 0.08f, 1e-6f);
    EXPECT_NEAR(with.g, 0.26f, 1e-6f);
    EXPECT_NEAR(with.b, 0.09f, 1e-6f);
}

TEST(GeoMipLightmapShading, TheShippedSceneReadsItsLightMapTexelAtASample) {
    const Scene scene = load_scene(kLit);
    ASSERT_EQ(scene.shading.model.kind, ShadingKind::geomip_lightmap);
    const GeomipLightmapShading& g = scene.shading.model.geomip;
    ASSERT_EQ(g.materials.size(), 3u);
    EXPECT_FALSE(g.materials[0].alpha);
    EXPECT_EQ(g.materials[0].texture->wrap(), Wrap::repeat);
    // The light map at sample (100, 60) is the cross-product light of that sample, from
    // the height map's own values (spacing 192/256 and 238.08/256, scale_z 16.8).
    const Texture& hm = scene.grid->heightmap->texture;
    const auto h = [&](int x, int y) { return hm.texel_exact(0, x, y) * 16.8; };
    const glm::dvec3 a(0.75, 0.0, h(101, 60) - h(100, 60)), b(0.0, 0.93, h(100, 61) - h(100, 60));
    const double light = 0.3 + 0.7 * std::max(glm::dot(glm::normalize(glm::cross(a, b)),
                                                        glm::normalize(glm::dvec3(-0.5, 0.4, 0.75))),
                                               0.0);
    EXPECT_NEAR(g.lightMap->texel(0, 100, 60), light, 1e-6);
    // Sampled at the sample's uv (100/256, 60/256), the texel centre: the texel itself.
    const glm::vec2 uv(100.0f / 256.0f, 60.0f / 256.0f);
    EXPECT_NEAR(g.lightMap->texture(uv * g.lightMapScale + g.lightMapOffset).r, light, 1e-5);
}

TEST(GeoMipLightmapShading, BadTablesAreRefusedNamingTheKey) {
    const std::string text = tessref::test::read_file(kLit);
    const auto key_of = [&](const std::string& from, const std::string& to) {
        return load_error(replaced(text, from, to), kLit);
    };
    const Error missing_file = key_of("geomip-rock.png", "no-such-rock.png");
    EXPECT_EQ(missing_file.where().key, "shading.materials[1].texture");
    EXPECT_NE(std::string(missing_file.what()).find("no-such-rock.png"), std::string::npos) << missing_file.what();
    EXPECT_EQ(key_of("repeat = 48.0 }", "repeat = 48.0, alpha = \"../alphamaps/jacksboro-257-dry.pgm\" }")
                  .where()
                  .key,
              "shading.materials[0].alpha");
    EXPECT_EQ(key_of(", alpha = \"../alphamaps/jacksboro-257-rock.pgm\"", "").where().key,
              "shading.materials[1].alpha");
    EXPECT_EQ(key_of("../alphamaps/jacksboro-257-rock.pgm", "../heightmaps/canyon.pgm").where().key,
              "shading.materials[1].alpha");  // 512 x 512, not one texel per sample
    EXPECT_EQ(key_of("repeat = 32.0", "repeat = 0.0").where().key, "shading.materials[1].repeat");
    EXPECT_EQ(key_of("ambient = 0.3", "ambient = 1.5").where().key, "shading.ambient");
    EXPECT_EQ(key_of("clouds = {", "cloudz = {").where().key, "shading.cloudz");
    const std::string no_clouds = replaced(text, text.substr(text.find("clouds = {"), text.find('\n', text.find("clouds = {")) - text.find("clouds = {")), "");
    EXPECT_EQ(load_error(no_clouds, kLit).where().key, "shading.time");
    EXPECT_EQ(key_of("light_direction = [-0.5, 0.4, 0.75]", "light_direction = [0, 0, 0]").where().key,
              "shading.light_direction");
    // Another evaluation model has no light map to compute.
    const std::string thesis = tessref::test::read_file(kScenes + "thesis-all-10.toml");
    const Error other = load_error(replaced(thesis, "model = \"thesis_single\"", "model = \"geomip_lightmap\""),
                                   kScenes + "thesis-all-10.toml");
    EXPECT_EQ(other.where().key, "shading.model");
}

// ---- culling -------------------------------------------------------------------------

namespace {

const std::string kPlain = kScenes + "jacksboro-geomipmap.toml";

// jacksboro-geomipmap with its camera over the middle looking east (+x), down 11.8 degrees.
std::string half_view_scene(bool culling) {
    std::string text = tessref::test::read_file(kPlain);
    text = replaced(text, "position = [96.0, -100.0, 110.0]\ntheta = 0.0\nphi = -35.0",
                    "eye = [96.0, 119.0, 20.0]\ncenter = [192.0, 119.0, 0.0]");
    text = replaced(text, "fov_y = 30.0", "fov_y = 45.0");
    if (culling) text = replaced(text, "[evaluation]", "[culling]\nfrustum = true\n\n[evaluation]");
    return text;
}

}  // namespace

TEST(GeoMipCulling, ACameraSeeingHalfTheTerrainCullsTheOtherHalfAndTheImageIsTheSame) {
    const Scene with = load_scene_from_string(half_view_scene(true), kPlain);
    const Scene without = load_scene_from_string(half_view_scene(false), kPlain);
    const PipelineResult culled = run_pipeline(with);
    // Every patch of the western half (x <= 96) is culled; some of the eastern half drawn.
    std::vector<bool> drawn(256, false);
    for (std::uint32_t p : culled.mesh.patch_ids) drawn[p] = true;
    for (int p = 0; p < 256; ++p)
        if (p % 16 < 8) EXPECT_FALSE(drawn[static_cast<std::size_t>(p)]) << "patch " << p;
    EXPECT_GE(culled.culled.frustum(), 128u);
    EXPECT_LT(culled.culled.frustum(), 256u);
    EXPECT_EQ(culled.culled.pvs, 0u);
    // The same levels (a visible patch adapts to a culled neighbour as before).
    EXPECT_EQ(culled.levels.size(), run_pipeline(without).levels.size());

    RenderOptions options;
    options.size = {320, 200};
    const RenderResult a = render_scene(with, options), b = render_scene(without, options);
    EXPECT_LT(a.stats.triangles, b.stats.triangles);
    EXPECT_GT(a.stats.covered_pixels, 1000u);
    EXPECT_EQ(a.stats.covered_pixels, b.stats.covered_pixels);
    EXPECT_EQ(to_rgba8(a), to_rgba8(b));  // culling removes only what is not seen
    EXPECT_EQ(a.colour, b.colour);
    EXPECT_EQ(a.depth, b.depth);
    EXPECT_EQ(a.patch_id, b.patch_id);
    std::printf("[   INFO   ] half view: %zu of 256 patches culled (rectangle %zu, planes %zu), triangles %llu -> "
                "%llu\n",
                culled.culled.total(), culled.culled.ground_rectangle, culled.culled.frustum_planes,
                static_cast<unsigned long long>(b.stats.triangles), static_cast<unsigned long long>(a.stats.triangles));
}

TEST(GeoMipCulling, BoxesOutsideOnePlaneAreCulledAndBoxesAcrossThemAreNot) {
    // Camera at the origin looking down -y... a plain look-at: eye (0, 0, 0), centre (0, 1, 0).
    SceneCamera camera;
    camera.eye = {0.0, 0.0, 0.0};
    camera.center = {0.0, 1.0, 0.0};
    camera.up = {0.0, 0.0, 1.0};
    camera.fov_y_degrees = 90.0;
    camera.viewport = {100, 100};
    camera.near_plane = 1.0;
    camera.far_plane = 100.0;
    const std::vector<Box> boxes{
        {{-1.0, 10.0, -1.0}, {1.0, 12.0, 1.0}},      // straight ahead: visible
        {{-1.0, -12.0, -1.0}, {1.0, -10.0, 1.0}},    // behind: culled
        {{30.0, 10.0, -1.0}, {32.0, 12.0, 1.0}},     // far right of a 45-degree half angle
        {{-1.0, 200.0, -1.0}, {1.0, 202.0, 1.0}},    // beyond the far plane
        {{-50.0, -5.0, -1.0}, {50.0, 5.0, 1.0}},     // across the eye: not wholly outside any
    };
    const std::vector<Cull> c = cull_frustum(boxes, camera.view_projection());
    EXPECT_EQ(c[0], Cull::visible);
    EXPECT_NE(c[1], Cull::visible);
    EXPECT_NE(c[2], Cull::visible);
    EXPECT_NE(c[3], Cull::visible);
    EXPECT_EQ(c[4], Cull::visible);
}

// ---- the PVS -------------------------------------------------------------------------

namespace {

// 113 x 49 samples (7 x 3 patches), flat at 0 but for a plateau of height 1 (10 after
// scale_z) over sample columns 48..64: patch column 3 wholly (its lowest sample 10), the
// border columns of patch columns 2 and 4 (their highest 10, lowest 0); spacing 1.
HeightSamples wall_map() {
    HeightSamples m = flat_map(113, 49);
    for (int y = 0; y < 49; ++y)
        for (int x = 48; x <= 64; ++x) m.samples[static_cast<std::size_t>(y) * 113 + x] = 1.0;
    return m;
}
Settings wall_settings() {
    Settings s;
    s.spacing = {1.0, 1.0};
    s.scale_z = 10.0;
    return s;
}

}  // namespace

TEST(GeoMipPvs, APlateauHidesTheGroundBehindItFromLowCellsOnly) {
    const HeightSamples map = wall_map();
    const Settings settings = wall_settings();
    const Pvs pvs = build_pvs(map, settings);
    ASSERT_EQ(pvs.layers, 32);
    EXPECT_EQ(pvs.z_lo, 0.0);
    EXPECT_EQ(pvs.z_hi, 30.0);  // three times the height
    // The occluder (margin 1e-3 * 10 = 0.01): the plateau at 9.99 on the sample vertices
    // x = 53..59 (a vertex takes the lowest patch within 4 samples: 1 spacing plus
    // d = 4 sqrt(2) / 2 = 2.83, rounded up). From the western column (x_s = 2.67, 8, 13.33)
    // to patch column 6's targets (x_t = 96..112 at 0.01) a descending line is lowest over
    // the plateau at x = 59, and clears it only if z (x_t - 59) / (x_t - x_s)
    // + 0.01 (59 - x_s) / (x_t - x_s) >= 9.99; the best pair (13.33, 112) needs
    // z >= (9.99 - 0.0046) / 0.5372 = 18.59. Layer l's sample points are at
    // z = (l + (k + 0.5) / 3) * 30 / 32: layer 18's highest is 17.66 (hidden), layer 20's
    // 19.53 (seen); layer 19's (18.594) clears by 0.003, too close to test. Patch column 5
    // (x_t = 80..96, ratio at most 37 / 82.67) is hidden up to z = 22.3: layers <= 18 too.
    for (int py = 0; py < 3; ++py)
        for (int l = 0; l < 32; ++l) {
            const std::size_t cell = (static_cast<std::size_t>(l) * 3 + py) * 7 + 0;
            for (int qy = 0; qy < 3; ++qy) {
                const std::size_t east = static_cast<std::size_t>(qy) * 7 + 6;
                if (l <= 18) EXPECT_FALSE(pvs.visible(cell, east)) << "layer " << l << " py " << py << " qy " << qy;
                if (l <= 18) EXPECT_FALSE(pvs.visible(cell, east - 1)) << "layer " << l << " py " << py << " qy " << qy;
                if (l >= 20) EXPECT_TRUE(pvs.visible(cell, east)) << "layer " << l << " py " << py << " qy " << qy;
                // Its own column, the next and the plateau's are always seen.
                for (int qx = 0; qx <= 3; ++qx)
                    EXPECT_TRUE(pvs.visible(cell, static_cast<std::size_t>(qy) * 7 + qx)) << l << " " << qx;
            }
        }
    // A cell with a sample point at or under its patch's highest sample keeps every patch:
    // over the plateau (patch column 3, highest 10), layer 10's lowest point is at 9.53.
    for (std::size_t p = 0; p < pvs.patch_count(); ++p)
        EXPECT_TRUE(pvs.visible((10 * 3 + 1) * 7 + 3, p)) << p;
    // Deterministic whatever the threads: the same bits again.
    EXPECT_EQ(build_pvs(map, settings).bits, pvs.bits);
    // cell_of: the eye at (5, 20, 3) is in patch (0, 1), layer floor(3 / (30 / 32)) = 3.
    EXPECT_EQ(pvs.cell_of({5.0, 20.0, 3.0}, settings), std::optional<std::size_t>((3 * 3 + 1) * 7 + 0));
    EXPECT_EQ(pvs.cell_of({5.0, 20.0, 31.0}, settings), std::nullopt);
    EXPECT_EQ(pvs.cell_of({-1.0, 20.0, 3.0}, settings), std::nullopt);
}

TEST(GeoMipPvs, TheFileRoundTripsAndBadFilesAreRefusedNamingThem) {
    const Pvs pvs = build_pvs(wall_map(), wall_settings(), 4, 8);
    const std::string path = (scratch() / "wall.pvs").string();
    write_pvs(pvs, path);
    const Pvs back = read_pvs(path);
    EXPECT_EQ(back.bits, pvs.bits);
    EXPECT_EQ(back.patches_x, 7);
    EXPECT_EQ(back.layers, 4);
    EXPECT_EQ(back.terrain_id, terrain_identity(wall_map(), wall_settings()));
    EXPECT_EQ(std::filesystem::file_size(path), 64u + (7u * 3u * 4u * 21u + 7u) / 8u);

    std::string bytes = tessref::test::read_file(path);
    const auto refused = [&](const std::string& content, const std::string& what) {
        const std::string bad = (scratch() / "bad.pvs").string();
        std::ofstream(bad, std::ios::binary) << content;
        try {
            read_pvs(bad);
            ADD_FAILURE() << "read: " << what;
        } catch (const Error& e) {
            EXPECT_EQ(e.where().file, bad) << what;
            EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
        }
    };
    refused(bytes.substr(0, bytes.size() - 1), "truncated");
    refused(bytes.substr(0, 20), "truncated");
    refused(bytes + "x", "after the bits");
    std::string flipped = bytes;
    flipped[70] = static_cast<char>(flipped[70] ^ 1);
    refused(flipped, "checksum");
    std::string magic = bytes;
    magic[0] = 'X';
    refused(magic, "magic");
    std::string version = bytes;
    version[8] = 1;  // version 1: the first, non-conservative set
    refused(version, "version");
}

namespace {

// The plateau map as a scene: a 16-bit PGM (plateau 65535) under a geomipmap scene,
// camera low in the western column looking east at the plateau.
std::string wall_scene(const std::string& culling) {
    const std::filesystem::path pgm = scratch() / "plateau.pgm";
    if (!std::filesystem::exists(pgm)) {
        std::ofstream out(pgm, std::ios::binary);
        out << "P5\n113 49\n65535\n";
        for (int y = 0; y < 49; ++y)
            for (int x = 0; x < 113; ++x) {
                const char v = x >= 48 && x <= 64 ? '\xff' : '\0';
                out << v << v;
            }
    }
    return "[scene]\nname = \"wall\"\n[domain]\nplane = \"xy\"\npatches = [7, 3]\nx = [0.0, 112.0]\ny = [0.0, 48.0]\n"
           "heightmap = \"plateau.pgm\"\nscale_z = 10.0\n[camera]\neye = [6.0, 24.0, 3.0]\ncenter = [112.0, 24.0, 2.0]\n"
           "fov_y = 60.0\nviewport = [160, 100]\n[evaluation]\nmodel = \"geomipmap\"\nerror_bound_px = 1.0\n" +
           culling + "[shading]\nmodel = \"depth\"\n";
}

// The covered pixels of render a, and how many of them render b does not show alike (patch,
// colour or depth differs).
std::pair<std::size_t, std::size_t> covered_and_lost(const RenderResult& a, const RenderResult& b) {
    std::size_t covered = 0, lost = 0;
    for (std::size_t i = 0; i < a.patch_id.size(); ++i) {
        if (a.patch_id[i] == kNoPixelId) continue;
        ++covered;
        if (b.patch_id[i] != a.patch_id[i] || b.colour[i] != a.colour[i] || b.depth[i] != a.depth[i]) ++lost;
    }
    return {covered, lost};
}

}  // namespace

TEST(GeoMipPvs, TheRenderDropsTheHiddenPatchesAndNoPixelChanges) {
    const std::string path = (scratch() / "scene.toml").string();
    const Scene plain = load_scene_from_string(wall_scene(""), path);
    const GeomipTerrain terrain = geomip_terrain(plain);
    write_pvs(build_pvs(terrain.map, terrain.settings), (scratch() / "scene.pvs").string());
    const Scene culled = load_scene_from_string(wall_scene("[culling]\nfrustum = false\npvs = \"scene.pvs\"\n"), path);
    const PipelineResult r = run_pipeline(culled);
    EXPECT_TRUE(r.culled.pvs_applied);
    // Patch columns 4 to 6, behind the plateau: from layer 3 (sample points up to 3.59)
    // column 6 and 5 as in APlateauHides...; column 4's targets (x_t = 64..80 at 10.01) by a
    // rising line, lowest over the plateau at x = 53: at most
    // 3.59 + (10.01 - 3.59) (53 - 2.67) / (64 - 2.67) = 8.86 < 9.99.
    EXPECT_EQ(r.culled.pvs, 9u);
    EXPECT_EQ(r.culled.frustum(), 0u);
    const RenderResult a = render_scene(culled), b = render_scene(plain);
    EXPECT_EQ(a.colour, b.colour);
    EXPECT_EQ(a.depth, b.depth);

    // Another terrain's PVS is refused, naming the key and the file.
    write_pvs(build_pvs(wall_map(), Settings{}, 4, 8), (scratch() / "other.pvs").string());
    const Error e = load_error(wall_scene("[culling]\npvs = \"other.pvs\"\n"), path);
    EXPECT_EQ(e.where().key, "culling.pvs");
    EXPECT_NE(std::string(e.what()).find("other.pvs"), std::string::npos) << e.what();
    const Error missing = load_error(wall_scene("[culling]\npvs = \"none.pvs\"\n"), path);
    EXPECT_EQ(missing.where().key, "culling.pvs");
    EXPECT_NE(std::string(missing.what()).find("none.pvs"), std::string::npos) << missing.what();
    // [culling] belongs to a geomipmapped terrain.
    const std::string thesis = tessref::test::read_file(kScenes + "thesis-all-10.toml");
    EXPECT_EQ(load_error(replaced(thesis, "[evaluation]", "[culling]\n\n[evaluation]"), kScenes + "x.toml").where().key,
              "culling");
}

// The contract of the PVS: a camera exactly at one of its cell's sample points loses no
// covered pixel to it. The shipped jacksboro scene (16 x 16 patches, 32 layers, target step
// 4) at 320 x 200 with frustum culling off, from the three eyes where the first PVS lost
// 2685, 10933 and 8 pixels and from more sample points, low over the terrain where lines of
// sight are blocked, each looking at the terrain's middle. Only the eye's row of the set is
// built (PvsBuilder: the same algorithm as build_pvs, cell by cell); the other cells keep
// every patch, which the render never reads.
TEST(GeoMipPvs, ACameraAtACellSamplePointLosesNoPixelOnJacksboro) {
    Scene plain = load_scene(kScenes + "jacksboro-geomipmap.toml");
    const GeomipTerrain terrain = geomip_terrain(plain);
    const PvsBuilder builder(terrain.map, terrain.settings);
    const Pvs& layout = builder.layout();
    ASSERT_EQ(layout.layers, 32);
    // Eyes: the three measured ones (rounded to 0.01 in the report: snapped to the sample
    // point of the eye's cell) and chosen (patch x, patch y, layer, sample x, y, z).
    std::vector<glm::dvec3> eyes{{102.0, 126.48, 5.78}, {54.0, 74.4, 7.3}, {150.0, 200.0, 8.8}};
    const std::vector<std::array<int, 6>> chosen{{2, 3, 2, 0, 2, 1},  {12, 10, 4, 2, 0, 0}, {5, 13, 3, 1, 1, 2},
                                                 {14, 2, 5, 0, 1, 2}, {8, 1, 3, 2, 2, 0},   {1, 8, 6, 1, 0, 1}};
    for (const auto& c : chosen) {
        const std::size_t cell =
            (static_cast<std::size_t>(c[2]) * layout.patches_y + c[1]) * layout.patches_x + static_cast<std::size_t>(c[0]);
        eyes.push_back(pvs_cell_point(layout, terrain.settings, cell, c[3], c[4], c[5]));
    }
    const glm::dvec3 middle(96.0, 119.04, 8.0);
    RenderOptions options;
    options.size = {320, 200};
    std::size_t total_lost = 0;
    for (glm::dvec3 eye : eyes) {
        const auto cell = layout.cell_of(eye, terrain.settings);
        ASSERT_TRUE(cell.has_value()) << eye.x << " " << eye.y << " " << eye.z;
        // The nearest sample point of the eye's cell (the second reported eye's y, 74.4, is
        // a patch border, not a sample point: it becomes 76.88, the nearest).
        glm::dvec3 nearest = pvs_cell_point(layout, terrain.settings, *cell, 0, 0, 0);
        for (int sz = 0; sz < 3; ++sz)
            for (int sy = 0; sy < 3; ++sy)
                for (int sx = 0; sx < 3; ++sx) {
                    const glm::dvec3 q = pvs_cell_point(layout, terrain.settings, *cell, sx, sy, sz);
                    if (glm::length(q - eye) < glm::length(nearest - eye)) nearest = q;
                }
        eye = nearest;
        auto pvs = std::make_shared<Pvs>(layout);
        pvs->bits.assign((pvs->cell_count() * pvs->patch_count() + 7) / 8, 0xff);
        const std::vector<std::uint8_t> row = builder.row(*cell);
        std::size_t hidden = 0;
        for (std::size_t p = 0; p < row.size(); ++p)
            if (!row[p]) {
                const std::size_t b = *cell * pvs->patch_count() + p;
                pvs->bits[b / 8] = static_cast<std::uint8_t>(pvs->bits[b / 8] & ~(1u << (b % 8)));
                ++hidden;
            }
        plain.camera->eye = eye;
        plain.camera->center = middle;
        plain.camera->up = {0.0, 0.0, 1.0};
        plain.culling.reset();
        Scene culled = plain;
        culled.culling = CullingStage{false, "", pvs};
        const RenderResult a = render_scene(plain, options), b = render_scene(culled, options);
        ASSERT_EQ(a.patch_id.size(), b.patch_id.size());
        const auto [covered, lost] = covered_and_lost(a, b);
        total_lost += lost;
        EXPECT_EQ(lost, 0u) << "eye " << eye.x << " " << eye.y << " " << eye.z;
        EXPECT_EQ(b.pipeline->culled.pvs, hidden);
        std::printf("  eye (%.4g, %.4g, %.4g) cell %zu: %zu of %zu patches hidden by the PVS, %zu of %zu covered "
                    "pixels lost\n",
                    eye.x, eye.y, eye.z, *cell, hidden, row.size(), lost, covered);
    }
    EXPECT_EQ(total_lost, 0u);
}

// Where the PVS pays: the canyon (tests/data/geomip/canyon-geomipmap.toml, 16 x 16 patches
// of the middle of lab 4's canyon, floor about 14 to 20, plateau about 130 to 150, 32 layers
// of 11.94 from 13.96). Eyes at cell sample points of layer 1 (27.9 to 35.9 high, over the
// canyon floor) look along the canyon. Patches must be culled: the canyon bends, and between
// the eye and the canyon beyond a bend, and between it and the plateau beyond the rim, stand
// patches whose every sample is on the plateau (over 100 high), whose low blocks stay near
// that height, and a line from a sample point under 38 to a target on the floor beyond or
// low on the plateau passes under them; those patches are in front of the eye, so the frustum
// keeps them and only the PVS culls them (measured: 79, 100, 30 and 5). And no covered
// pixel may change: the eyes are sample points (the contract above).
TEST(GeoMipPvs, InTheCanyonThePvsCullsPatchesAndNoPixelChanges) {
    Scene plain = load_scene(std::string(TESSREF_SOURCE_DIR) + "/tests/data/geomip/canyon-geomipmap.toml");
    const GeomipTerrain terrain = geomip_terrain(plain);
    const PvsBuilder builder(terrain.map, terrain.settings);
    const Pvs& layout = builder.layout();
    ASSERT_EQ(layout.layers, 32);
    EXPECT_NEAR(layout.z_lo, 13.96, 0.01);
    EXPECT_NEAR((layout.z_hi - layout.z_lo) / layout.layers, 11.94, 0.01);
    // (patch x, patch y, layer, sample x, y, z) of the eye, and where it looks (on the floor).
    struct View {
        std::array<int, 6> cell;
        glm::dvec3 center;
    };
    const std::vector<View> views{{{12, 0, 1, 1, 1, 1}, {250.0, 200.0, 20.0}},
                                  {{12, 0, 1, 1, 1, 0}, {400.0, 400.0, 20.0}},
                                  {{3, 13, 1, 1, 1, 1}, {144.0, 256.0, 20.0}},
                                  {{4, 6, 1, 1, 1, 0}, {400.0, 20.0, 20.0}}};
    RenderOptions options;
    options.size = {320, 200};
    for (const View& v : views) {
        const auto& c = v.cell;
        const std::size_t cell =
            (static_cast<std::size_t>(c[2]) * layout.patches_y + c[1]) * layout.patches_x + static_cast<std::size_t>(c[0]);
        const glm::dvec3 eye = pvs_cell_point(layout, terrain.settings, cell, c[3], c[4], c[5]);
        ASSERT_EQ(layout.cell_of(eye, terrain.settings), std::optional<std::size_t>(cell));
        auto pvs = std::make_shared<Pvs>(layout);
        pvs->bits.assign((pvs->cell_count() * pvs->patch_count() + 7) / 8, 0xff);
        const std::vector<std::uint8_t> row = builder.row(cell);
        std::size_t hidden = 0;
        for (std::size_t p = 0; p < row.size(); ++p)
            if (!row[p]) {
                const std::size_t b = cell * pvs->patch_count() + p;
                pvs->bits[b / 8] = static_cast<std::uint8_t>(pvs->bits[b / 8] & ~(1u << (b % 8)));
                ++hidden;
            }
        plain.camera->eye = eye;
        plain.camera->center = v.center;
        plain.camera->up = {0.0, 0.0, 1.0};
        plain.culling = CullingStage{true, "", nullptr};
        Scene culled = plain;
        culled.culling = CullingStage{true, "", pvs};
        const RenderResult a = render_scene(plain, options), b = render_scene(culled, options);
        ASSERT_EQ(a.patch_id.size(), b.patch_id.size());
        const auto [covered, lost] = covered_and_lost(a, b);
        EXPECT_EQ(a.colour, b.colour) << "eye " << eye.x << " " << eye.y << " " << eye.z;
        EXPECT_EQ(lost, 0u) << "eye " << eye.x << " " << eye.y << " " << eye.z;
        EXPECT_GT(covered, 0u);
        EXPECT_TRUE(b.pipeline->culled.pvs_applied);
        EXPECT_GT(b.pipeline->culled.pvs, 0u) << "eye " << eye.x << " " << eye.y << " " << eye.z;
        EXPECT_EQ(b.pipeline->culled.frustum(), a.pipeline->culled.frustum());
        EXPECT_LT(b.pipeline->mesh.triangles.size(), a.pipeline->mesh.triangles.size());
        std::printf("  eye (%.4g, %.4g, %.4g) cell %zu: %zu of %zu patches hidden, frustum culls %zu, the PVS %zu more; "
                    "%zu of %zu covered pixels lost\n",
                    eye.x, eye.y, eye.z, cell, hidden, row.size(), a.pipeline->culled.frustum(), b.pipeline->culled.pvs,
                    lost, covered);
    }
}

class GeoMipOptimCommand : public tessref::test::CommandDirTest {};

TEST_F(GeoMipOptimCommand, RenderPrintsTheCulledPatchesAndPvsWritesAFileOrNothing) {
    // The lit scene with frustum culling, its relative paths made absolute.
    std::string text = tessref::test::read_file(kLit);
    for (std::size_t at = text.find("\"../"); at != std::string::npos; at = text.find("\"../", at + 1))
        text.replace(at + 1, 3, kScenes + "../");
    std::ofstream(path("culled.toml")) << replaced(text, "[shading]", "[culling]\nfrustum = true\n\n[shading]");
    const auto r = run({"render", path("culled.toml"), "--size", "64x40", "-o", path("lit.png")});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("patches culled (frustum "), std::string::npos) << r.out;
    const auto bad = run({"pvs", kScenes + "thesis-all-10.toml", "-o", path("x.pvs")});
    EXPECT_EQ(bad.status, 2) << bad.err;
    const auto step = run({"pvs", kLit, "--target-step", "3", "-o", path("x.pvs")});
    EXPECT_EQ(step.status, 2) << step.err;
    EXPECT_EQ(files(), (std::set<std::string>{"culled.toml", "lit.png"}));
}
