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

}  // namespace
