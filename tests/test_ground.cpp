// tests/test_ground.cpp — lab 4's camera collision question (render.h ground_height,
// `tessref inspect --ground`): the height map and the tessellated surface under a point.
//
// Where the expected answers come from: a 2 x 2 map (codes 0, 100 / 200, 60, scale_z 2.55
// so a height is a hundredth of its code) under one patch over [0, 8]^2 with scale_xy 8: the
// texel centres sit at 2 and 6, clamp-to-edge makes the corners read their texels exactly,
// and the centre (4, 4) reads the mean of the four, 0.9 (GL 4.6, 8.14.2). At level 1 the
// patch is two triangles split along one diagonal, so the tessellated centre is the mean of
// that diagonal's corners: (0 + 0.6) / 2 = 0.3 or (1 + 2) / 2 = 1.5, never 0.9. At level 2 a
// vertex stands at the centre and both surfaces agree there.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "extremes/extremes.h"
#include "tessref/error.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"
#include "tessref/render.h"

using namespace tessref::test;
using namespace tessref::test::extremes;

namespace {

class Ground : public ExtremesTest {
protected:
    Terrain two_by_two(double level) {
        write_pgm(dir_ / "two.pgm", 2, 2, 255, {0, 100, 200, 60});
        Terrain t;
        t.nu = t.nv = 1;
        t.heightmap = "two.pgm";
        t.scale_z = 2.55;
        t.spacing = "equal";
        t.control = "model = \"constant\"\nlevel = " + num(level);
        return t;
    }
};

TEST_F(Ground, LevelOneCutsTheCentreAlongADiagonal) {
    const tessref::Scene scene = load(two_by_two(1.0));
    tessref::PipelineOptions exact;
    exact.precision = tessref::Precision::exact;
    const tessref::PipelineResult p = tessref::run_pipeline(scene, exact);
    const tessref::GroundHeight centre = tessref::ground_height(scene, p, {4.0, 4.0});
    EXPECT_NEAR(centre.height_map, 0.9, 1e-12);
    ASSERT_TRUE(centre.on_surface);
    EXPECT_TRUE(std::abs(centre.tessellated - 0.3) < 1e-12 || std::abs(centre.tessellated - 1.5) < 1e-12)
        << centre.tessellated;
    EXPECT_GT(std::abs(centre.difference()), 0.5);
    EXPECT_EQ(centre.patch_id, 0u);
    // At a corner both read the texel.
    const tessref::GroundHeight corner = tessref::ground_height(scene, p, {0.0, 0.0});
    EXPECT_EQ(corner.height_map, 0.0);
    EXPECT_EQ(corner.tessellated, 0.0);
}

TEST_F(Ground, AVertexAtThePointAgreesWithTheHeightMap) {
    const tessref::Scene scene = load(two_by_two(2.0));
    tessref::PipelineOptions exact;
    exact.precision = tessref::Precision::exact;
    const tessref::GroundHeight centre = tessref::ground_height(scene, tessref::run_pipeline(scene, exact), {4.0, 4.0});
    ASSERT_TRUE(centre.on_surface);
    EXPECT_NEAR(centre.tessellated, 0.9, 1e-12);
    EXPECT_NEAR(centre.difference(), 0.0, 1e-12);
}

TEST_F(Ground, InspectPrintsBothAndTheCameraClearance) {
    write_scene(two_by_two(1.0));
    const RunResult r = run({"inspect", "scene.toml", "--ground", "4,4", "--precision", "exact"});
    ASSERT_EQ(r.status, 0) << r.err;
    for (const char* line : {"height map: 0.", "tessellated: ", "difference: "})
        EXPECT_NE(r.out.find(line), std::string::npos) << r.out;
    const RunResult rj = run({"inspect", "scene.toml", "--ground", "4,4", "--precision", "exact", "--json"});
    ASSERT_EQ(rj.status, 0) << rj.err;
    const nlohmann::json centre = nlohmann::json::parse(rj.out);
    EXPECT_NEAR(centre.at("height_map").get<double>(), 0.9, 1e-12);
    EXPECT_NEAR(centre.at("difference").get<double>(),
                centre.at("tessellated").get<double>() - centre.at("height_map").get<double>(), 1e-15);
    // The camera of extremes.h stands at (4, -6, 8): outside the terrain, refused clearly.
    const RunResult cam = run({"inspect", "scene.toml", "--ground", "camera"});
    EXPECT_EQ(cam.status, 2);
    EXPECT_NE(cam.err.find("outside the terrain"), std::string::npos) << cam.err;
    // A camera over the terrain: its clearance above both surfaces.
    Terrain above = two_by_two(1.0);
    above.eye = {4.0, 4.0, 8.0};
    above.center = {4.0, 5.0, 0.0};
    write_scene(above);
    const RunResult over = run({"inspect", "scene.toml", "--ground", "camera", "--json", "--precision", "exact"});
    ASSERT_EQ(over.status, 0) << over.err;
    const nlohmann::json j = nlohmann::json::parse(over.out);
    EXPECT_TRUE(j.at("under_camera").get<bool>());
    EXPECT_NEAR(j.at("clearance_height_map").get<double>(), 8.0 - 0.9, 1e-12);
    EXPECT_NEAR(j.at("clearance_tessellated").get<double>(), 8.0 - j.at("tessellated").get<double>(), 1e-12);
    // Bad input: both flags, neither, a malformed point.
    EXPECT_EQ(run({"inspect", "scene.toml", "--ground", "4,4", "--pixel", "1,1"}).status, 2);
    EXPECT_EQ(run({"inspect", "scene.toml"}).status, 2);
    EXPECT_EQ(run({"inspect", "scene.toml", "--ground", "4,nan"}).status, 2);
    EXPECT_EQ(run({"inspect", "scene.toml", "--ground", "99,4"}).status, 2);
}

// ---- camera collision: [camera] ground_clearance = d -----------------------------------
//
// The loader lifts the eye to (the tessellated surface's height under it) + d, moving the
// center with it. On a flat map of code 255 with scale_z 2 every surface is at height 2
// exactly (the texel reads 1.0, times 2, in float as in double), so d = 0.5 puts the eye at
// z = 2.5 exactly and the center, 8 below the eye as given, at 2.5 - 8 = -5.5.

std::string with_clearance(const Terrain& t, const std::string& value) {
    std::string text = t.toml();
    text.insert(text.find("[generator]"), "ground_clearance = " + value + "\n");
    return text;
}

TEST_F(Ground, ClearanceOverAFlatTerrainPutsTheEyeExactlyDAboveIt) {
    write_pgm(dir_ / "flat2.pgm", 2, 2, 255, {255, 255, 255, 255});
    Terrain t;
    t.heightmap = "flat2.pgm";
    t.scale_z = 2.0;
    t.eye = {4.0, 4.0, 8.0};
    t.center = {4.0, 5.0, 0.0};
    const tessref::Scene scene = tessref::load_scene_from_string(with_clearance(t, "0.5"), path("scene.toml"));
    ASSERT_TRUE(scene.camera);
    EXPECT_EQ(scene.camera->eye, glm::dvec3(4.0, 4.0, 2.5));
    EXPECT_EQ(scene.camera->center, glm::dvec3(4.0, 5.0, -5.5));
    // Clearance 0: the eye on the surface.
    const tessref::Scene on = tessref::load_scene_from_string(with_clearance(t, "0"), path("scene.toml"));
    EXPECT_EQ(on.camera->eye.z, 2.0);
    // Lab 4's plane (xz, y up): the up coordinate is y.
    Terrain xz = t;
    xz.plane = "xz";
    xz.evaluation = "lab4";
    xz.control = "model = \"lab4\"";
    xz.eye = {4.0, 8.0, 4.0};
    xz.center = {4.0, 0.0, 5.0};
    xz.up = {0.0, 1.0, 0.0};
    const tessref::Scene lab4 = tessref::load_scene_from_string(with_clearance(xz, "1.25"), path("scene.toml"));
    EXPECT_EQ(lab4.camera->eye, glm::dvec3(4.0, 3.25, 4.0));
    EXPECT_EQ(lab4.camera->center, glm::dvec3(4.0, -4.75, 5.0));
}

// Over the 2 x 2 map at level 1 the surface under (4, 4) is a diagonal's mean (0.3 or 1.5),
// not the height map's 0.9: the eye follows the tessellated surface.
TEST_F(Ground, ClearanceFollowsTheTessellatedSurfaceNotTheHeightMap) {
    Terrain t = two_by_two(1.0);
    t.eye = {4.0, 4.0, 8.0};
    t.center = {4.0, 5.0, 0.0};
    const tessref::Scene scene = tessref::load_scene_from_string(with_clearance(t, "0.25"), path("scene.toml"));
    const tessref::GroundHeight under = tessref::ground_height(scene, tessref::run_pipeline(scene), {4.0, 4.0});
    ASSERT_TRUE(under.on_surface);
    EXPECT_EQ(scene.camera->eye.z, under.tessellated + 0.25);
    EXPECT_TRUE(std::abs(scene.camera->eye.z - 0.55) < 1e-6 || std::abs(scene.camera->eye.z - 1.75) < 1e-6)
        << scene.camera->eye.z;
}

TEST_F(Ground, BadClearanceIsExit2NamingTheKeyAndWritesNothing) {
    Terrain t = two_by_two(1.0);
    t.eye = {4.0, 4.0, 8.0};
    t.center = {4.0, 5.0, 0.0};
    struct Case {
        std::string value;
        glm::dvec3 eye;
        const char* says;
    };
    for (const Case& c : {Case{"-1.0", t.eye, "camera.ground_clearance"}, Case{"\"high\"", t.eye, "camera.ground_clearance"},
                          Case{"nan", t.eye, "camera.ground_clearance"},
                          Case{"0.5", glm::dvec3(4.0, -6.0, 8.0), "outside the terrain"}}) {
        Terrain bad = t;
        bad.eye = c.eye;
        write_file(dir_ / "scene.toml", with_clearance(bad, c.value));
        const RunResult r = run({"render", "scene.toml", "-o", "out.png", "--size", "16x10"});
        EXPECT_EQ(r.status, 2) << c.value << ": " << r.err;
        EXPECT_NE(r.err.find(c.says), std::string::npos) << c.value << ": " << r.err;
        EXPECT_NE(r.err.find("ground_clearance"), std::string::npos) << c.value << ": " << r.err;
        EXPECT_NE(r.err.find("scene.toml"), std::string::npos) << c.value << ": " << r.err;
        EXPECT_FALSE(std::filesystem::exists(dir_ / "out.png")) << c.value;
    }
}

}  // namespace

namespace {

// A geomipmapped terrain (the geomorphing article's), 17 x 17 samples of code 255 with
// scale_z 2: every level's surface is at height 2 exactly, so ground_clearance 0.75 puts the
// eye at z = 2.75 exactly and the ground under any point reads 2 on both surfaces.
TEST_F(Ground, ClearanceOverAGeomipmappedTerrain) {
    write_pgm(dir_ / "flat17.pgm", 17, 17, 255, std::vector<int>(17 * 17, 255));
    const std::string text =
        "[scene]\nname = \"g\"\n[domain]\nplane = \"xy\"\npatches = [1, 1]\nx = [0.0, 16.0]\ny = [0.0, 16.0]\n"
        "heightmap = \"flat17.pgm\"\nscale_z = 2.0\n[camera]\neye = [8.0, 8.0, 9.0]\ncenter = [8.0, 9.0, 0.0]\n"
        "viewport = [160, 100]\nground_clearance = 0.75\n[evaluation]\nmodel = \"geomipmap\"\n";
    const tessref::Scene scene = tessref::load_scene_from_string(text, path("scene.toml"));
    EXPECT_EQ(scene.camera->eye, glm::dvec3(8.0, 8.0, 2.75));
    EXPECT_EQ(scene.camera->center, glm::dvec3(8.0, 9.0, -6.25));
    const tessref::GroundHeight under = tessref::ground_height(scene, tessref::run_pipeline(scene), {3.3, 12.1});
    ASSERT_TRUE(under.on_surface);
    EXPECT_EQ(under.height_map, 2.0);
    EXPECT_EQ(under.tessellated, 2.0);
}

}  // namespace
