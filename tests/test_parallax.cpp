// Normal mapping, parallax mapping and the self-shadow trace (tessref/parallax.h), with
// values derived by hand from the formulas in that header.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "run_program.h"
#include "scratch_dir.h"
#include "tessref/error.h"
#include "tessref/parallax.h"
#include "tessref/prepare.h"
#include "tessref/scene.h"
#include "tessref/shading.h"

using namespace tessref;

namespace {

constexpr float kPi = 3.14159265358979f;

// A w x h one-channel float texture with texel (x, y) = value(x, y), sampled with zero
// derivatives (level 0, bilinear) in these tests.
template <typename F>
std::shared_ptr<const Texture> grey(int w, int h, F value) {
    std::vector<float> texels;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) texels.push_back(value(x, y));
    return std::make_shared<const Texture>(Texture::from_float(w, h, 1, std::move(texels)));
}
std::shared_ptr<const Texture> constant(float v) {
    return grey(4, 4, [v](int, int) { return v; });
}
std::shared_ptr<const Texture> rgb(float r, float g, float b) {
    std::vector<float> texels;
    for (int i = 0; i < 16; ++i) texels.insert(texels.end(), {r, g, b});
    return std::make_shared<const Texture>(Texture::from_float(4, 4, 3, std::move(texels)));
}

void expect_vec3(glm::vec3 a, glm::vec3 b, float tol = 1e-6f) {
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(a[k], b[k], tol) << "component " << k;
}

const glm::vec2 kZero(0.0f);

// A pom model with a white diffuse texture, a flat normal map and `bump` as its height map.
ShadingModel pom_model(std::shared_ptr<const Texture> bump) {
    ShadingModel m;
    m.kind = ShadingKind::pom;
    m.textures.s2DiffuseTexture = rgb(1, 1, 1);
    m.textures.s2NormalTexture = rgb(0.5f, 0.5f, 1.0f);
    m.textures.s2BumpTexture = std::move(bump);
    return m;
}

namespace fs = std::filesystem;
const test::ScratchDir& scratch_dir = test::ScratchDir::add("parallax");

}  // namespace

// ---- tangent frames -------------------------------------------------------------------------

TEST(TangentFrame, PlaneWithKnownUv) {
    // e1 = (2, 0, 0) with d1 = (1, 0), e2 = (0, 0, -3) with d2 = (0, 1): r = 1, so dP/du = e1
    // and dP/dv = e2.
    const UvDerivatives d = triangle_uv_derivatives({0, 0, 0}, {2, 0, 0}, {0, 0, -3}, {0, 0}, {1, 0}, {0, 1});
    expect_vec3(d.dPdu, {2, 0, 0});
    expect_vec3(d.dPdv, {0, 0, -3});
    // The uv swapped: d1 = (0, 1), d2 = (1, 0), r = -1, so dP/du = e2, dP/dv = e1.
    const UvDerivatives s = triangle_uv_derivatives({0, 0, 0}, {2, 0, 0}, {0, 0, -3}, {0, 0}, {0, 1}, {1, 0});
    expect_vec3(s.dPdu, {0, 0, -3});
    expect_vec3(s.dPdv, {2, 0, 0});
    // Normal +y: t' = x, b' = cross(y, x) = -z, which is dP/dv's side: no flip.
    const TangentFrame f = tangent_frame({0, 5, 0}, d);
    expect_vec3(f.tangent, {1, 0, 0});
    expect_vec3(f.bitangent, {0, 0, -1});
    expect_vec3(f.normal, {0, 1, 0});
}

TEST(TangentFrame, DegenerateUvFallsBackToAnAxis) {
    const UvDerivatives d = triangle_uv_derivatives({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.5f, 0.5f}, {0.5f, 0.5f},
                                                    {0.5f, 0.5f});
    expect_vec3(d.dPdu, {0, 0, 0});
    expect_vec3(d.dPdv, {0, 0, 0});
    const TangentFrame f = tangent_frame({0, 0, 1}, d);
    expect_vec3(f.tangent, {1, 0, 0});
    expect_vec3(f.bitangent, {0, 1, 0});
    const TangentFrame g = tangent_frame({1, 0, 0}, d);  // normal along x: the z axis
    expect_vec3(g.tangent, {0, 0, 1});
}

TEST(TangentFrame, HeightFieldSlope) {
    // A terrain cell of h = 0.5 x with uv = (x, z): dP/du = (1, 0.5, 0), the height field's
    // slope; the plane's normal is (-0.5, 1, 0) / |.|. t' = (1, 0.5, 0) / sqrt(1.25);
    // cross(n, t') = (0, 0, -1) is against dP/dv = (0, 0, 1), so b' is flipped to +z.
    const UvDerivatives d = triangle_uv_derivatives({0, 0, 0}, {1, 0.5f, 0}, {0, 0, 1}, {0, 0}, {1, 0}, {0, 1});
    expect_vec3(d.dPdu, {1, 0.5f, 0});
    expect_vec3(d.dPdv, {0, 0, 1});
    const TangentFrame f = tangent_frame({-0.5f, 1, 0}, d);
    const float s = 1.0f / std::sqrt(1.25f);
    expect_vec3(f.tangent, {s, 0.5f * s, 0});
    expect_vec3(f.bitangent, {0, 0, 1});
    expect_vec3(f.normal, {-0.5f * s, s, 0});
}

TEST(TangentFrame, TangentIsMadePerpendicularToTheInterpolatedNormal) {
    // dP/du = (1, 1, 0) against n = y: t - n (n.t) = (1, 0, 0).
    const TangentFrame f = tangent_frame({0, 1, 0}, {{1, 1, 0}, {0, 0, -1}});
    expect_vec3(f.tangent, {1, 0, 0});
}

// ---- normal maps ----------------------------------------------------------------------------

TEST(NormalMap, FlatTexelKeepsTheNormal) {
    const TangentFrame f = tangent_frame({0, 1, 0}, {{1, 0, 0}, {0, 0, -1}});
    const auto flat = rgb(0.5f, 0.5f, 1.0f);
    expect_vec3(normal_map(f, flat.get(), {0.3f, 0.7f}, kZero, kZero), {0, 1, 0});
}

TEST(NormalMap, TiltedTexelRotatesByItsAngle) {
    // rg = (0.5 + 0.5 sin 30, 0.5) decodes to xy = (0.5, 0), z = sqrt(0.75) = cos 30: the
    // normal turns 30 degrees from n toward t'.
    const TangentFrame f = tangent_frame({0, 1, 0}, {{1, 0, 0}, {0, 0, -1}});
    const glm::vec3 n = normal_map(f, rgb(0.75f, 0.5f, 1.0f).get(), {0.5f, 0.5f}, kZero, kZero);
    expect_vec3(n, {0.5f, std::sqrt(0.75f), 0});
    EXPECT_NEAR(std::acos(glm::dot(n, f.normal)), 30.0f * kPi / 180.0f, 1e-6f);
    // Green tilts toward b' (here -z), by 30 degrees again.
    const glm::vec3 g = normal_map(f, rgb(0.5f, 0.75f, 1.0f).get(), {0.5f, 0.5f}, kZero, kZero);
    expect_vec3(g, {0, std::sqrt(0.75f), -0.5f});
    // The blue channel is not read (the tutorial rebuilds z from x and y).
    expect_vec3(normal_map(f, rgb(0.75f, 0.5f, 0.0f).get(), {0.5f, 0.5f}, kZero, kZero), n);
}

// ---- parallax -------------------------------------------------------------------------------

TEST(Parallax, LayersFollowTheViewAngle) {
    ParallaxParams p;  // 5 .. 15
    EXPECT_EQ(parallax_layers({0, 0, 1}, p), 5.0f);
    EXPECT_EQ(parallax_layers({1, 0, 0}, p), 15.0f);
    EXPECT_EQ(parallax_layers({0, 0, -1}, p), 5.0f);  // abs(v.z)
    // 45 degrees: 15 (1 - 0.7071) + 5 (0.7071) = 7.93 -> 8.
    const float c = std::sqrt(0.5f);
    EXPECT_EQ(parallax_layers({c, 0, c}, p), 8.0f);
    // 0.25: 15 * 0.75 + 5 * 0.25 = 12.5 -> 12 (half to even).
    EXPECT_EQ(parallax_layers({std::sqrt(1.0f - 0.0625f), 0, 0.25f}, p), 12.0f);
}

TEST(Parallax, HeightAtTheSurfaceLeavesUvUnchanged) {
    const auto top = constant(1.0f);
    const float c = std::sqrt(0.5f);
    for (ParallaxMode mode : {ParallaxMode::none, ParallaxMode::parallax, ParallaxMode::steep, ParallaxMode::occlusion}) {
        ParallaxParams p;
        p.mode = mode;
        p.fBumpScale = 0.1f;
        const glm::vec2 uv = parallax_uv({c, 0, c}, {0.5f, 0.5f}, top.get(), kZero, kZero, p);
        EXPECT_EQ(uv, glm::vec2(0.5f, 0.5f)) << to_string(mode);
    }
}

TEST(Parallax, ConstantHeightAtFortyFiveDegrees) {
    // v = (sin 45, 0, cos 45): v.xy / v.z = (1, 0). Height 0.4, scale 0.1: the ray meets the
    // floor 0.6 deep, at a uv offset of -0.1 * 0.6 = -0.06 along u. The one-step parallax and
    // the interpolated search both find it exactly; the steep search stops at the first of
    // its 8 layers at or below 0.4: 1 - k / 8 <= 0.4 at k = 5, offset -5 * 0.1 / 8 = -0.0625.
    const auto floor = constant(0.4f);
    const float c = std::sqrt(0.5f);
    ParallaxParams p;
    p.fBumpScale = 0.1f;
    const glm::vec2 uv0(0.5f, 0.5f);
    p.mode = ParallaxMode::parallax;
    glm::vec2 uv = parallax_uv({c, 0, c}, uv0, floor.get(), kZero, kZero, p);
    EXPECT_NEAR(uv.x, 0.44f, 1e-6f);
    EXPECT_NEAR(uv.y, 0.5f, 1e-6f);
    p.mode = ParallaxMode::occlusion;
    uv = parallax_uv({c, 0, c}, uv0, floor.get(), kZero, kZero, p);
    EXPECT_NEAR(uv.x, 0.44f, 1e-6f);
    EXPECT_NEAR(uv.y, 0.5f, 1e-6f);
    p.mode = ParallaxMode::steep;
    uv = parallax_uv({c, 0, c}, uv0, floor.get(), kZero, kZero, p);
    EXPECT_NEAR(uv.x, 0.5f - 0.0625f, 1e-6f);
    // Along b' (v.y) the shift is in v; seen from straight above there is none.
    p.mode = ParallaxMode::occlusion;
    uv = parallax_uv({0, c, c}, uv0, floor.get(), kZero, kZero, p);
    EXPECT_NEAR(uv.x, 0.5f, 1e-6f);
    EXPECT_NEAR(uv.y, 0.44f, 1e-6f);
    uv = parallax_uv({0, 0, 1}, uv0, floor.get(), kZero, kZero, p);
    EXPECT_NEAR(uv.x, 0.5f, 1e-6f);
    EXPECT_NEAR(uv.y, 0.5f, 1e-6f);
}

TEST(Parallax, SteeperViewShiftsFurther) {
    // At 60 degrees from the normal, v.xy / v.z = tan 60 = sqrt 3: the offset is
    // 0.1 * 0.6 * sqrt 3 = 0.10392.
    const auto floor = constant(0.4f);
    ParallaxParams p;
    p.fBumpScale = 0.1f;
    const glm::vec2 uv = parallax_uv({std::sqrt(0.75f), 0, 0.5f}, {0.5f, 0.5f}, floor.get(), kZero, kZero, p);
    EXPECT_NEAR(uv.x, 0.5f - 0.06f * std::sqrt(3.0f), 2e-6f);
}

// ---- self-shadow ----------------------------------------------------------------------------

TEST(ParallaxShadow, StepEdgeShadowsTheLowSideTowardTheLight) {
    // 16 texels along u: 0.5 below u = 0.5, 1 above (the bilinear ramp spans u in
    // [7.5/16, 8.5/16]). From u = 0.25 (height 0.5) the trace climbs 0.5 and moves
    // 0.8 * 0.5 * l.x / l.z in u: at 45 degrees 0.4, past the edge: shadowed. Away from the
    // edge it stays on the low side: lit.
    const auto step = grey(16, 1, [](int x, int) { return x < 8 ? 0.5f : 1.0f; });
    ParallaxParams p;
    p.fBumpScale = 0.8f;
    const float c = std::sqrt(0.5f);
    EXPECT_EQ(parallax_shadow({c, 0, c}, {0.25f, 0.5f}, step.get(), kZero, kZero, p), 0.0f);
    EXPECT_EQ(parallax_shadow({-c, 0, c}, {0.25f, 0.5f}, step.get(), kZero, kZero, p), 1.0f);
    EXPECT_EQ(parallax_shadow({0, 0, 1}, {0.25f, 0.5f}, step.get(), kZero, kZero, p), 1.0f);
    // A lower light (30 degrees above the plane) with a smaller scale: 0.2 * 0.5 * cot 30 =
    // 0.1732 from u = 0.25 reaches 0.423, short of the ramp: lit; from u = 0.4 it is shadowed.
    p.fBumpScale = 0.2f;
    const glm::vec3 low(std::sqrt(0.75f), 0, 0.5f);
    EXPECT_EQ(parallax_shadow(low, {0.25f, 0.5f}, step.get(), kZero, kZero, p), 1.0f);
    EXPECT_EQ(parallax_shadow(low, {0.4f, 0.5f}, step.get(), kZero, kZero, p), 0.0f);
    // On the plateau nothing is above the ray; a light below the plane shadows everything.
    EXPECT_EQ(parallax_shadow({c, 0, c}, {0.8f, 0.5f}, step.get(), kZero, kZero, p), 1.0f);
    EXPECT_EQ(parallax_shadow({c, 0, -c}, {0.8f, 0.5f}, step.get(), kZero, kZero, p), 0.0f);
}

// ---- the shading model ------------------------------------------------------------------------

TEST(PomShading, FlatMapsShadeAsPnTriangles) {
    // A flat normal map, the height at the surface and a white diffuse texture: the pom model
    // is pn_triangles.frag's light with the same uniforms.
    ShadingModel pom = pom_model(constant(1.0f));
    pom.pom.v3DiffuseColour = glm::vec3(0.8f, 0.8f, 0.85f);
    pom.pom.v3CameraPosition = glm::vec3(1.0f, 3.0f, 2.0f);
    ShadingModel pn;
    pn.kind = ShadingKind::pn;
    pn.pn.v3CameraPosition = pom.pom.v3CameraPosition;
    FragmentInputs f;
    f.worldPosition = glm::vec3(0.2f, 0.0f, -0.1f);
    f.normal = glm::vec3(0.1f, 1.0f, 0.05f);
    f.texCoord = glm::vec2(0.3f, 0.6f);
    f.dPdu = glm::vec3(1, 0, 0);
    f.dPdv = glm::vec3(0, 0, 1);
    EXPECT_TRUE(missing_textures(pom).empty());
    const glm::vec4 a = shade(pom, f), b = shade(pn, f);
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(a[k], b[k], 2e-6f);
}

TEST(PomShading, SelfShadowDarkensToAmbient) {
    // A step edge lit across it: the low side's diffuse and specular are gone, 0.1 of the
    // albedo is left.
    ShadingModel m = pom_model(grey(16, 1, [](int x, int) { return x < 8 ? 0.5f : 1.0f; }));
    m.pom.v3DiffuseColour = glm::vec3(1.0f);
    m.pom.parallax.mode = ParallaxMode::none;
    m.pom.parallax.fBumpScale = 0.8f;
    m.pom.v3LightDirection = glm::vec3(1.0f, 1.0f, 0.0f);  // toward +u at 45 degrees
    FragmentInputs f;
    f.normal = glm::vec3(0, 1, 0);
    f.texCoord = glm::vec2(0.25f, 0.5f);
    f.dPdu = glm::vec3(1, 0, 0);
    f.dPdv = glm::vec3(0, 0, -1);
    m.pom.v3CameraPosition = glm::vec3(0, 10, 0);
    const glm::vec4 shadowed = shade(m, f);
    expect_vec3(glm::vec3(shadowed), glm::vec3(0.1f));
    m.pom.bSelfShadow = false;
    const glm::vec4 lit = shade(m, f);
    EXPECT_GT(lit.r, 0.5f);  // 0.1 + 0.9 cos 45 plus specular
    EXPECT_EQ(sampler_names(ShadingKind::pom).size(), 3u);
    m.textures.s2BumpTexture.reset();
    ASSERT_EQ(missing_textures(m).size(), 1u);
    EXPECT_EQ(missing_textures(m)[0], "s2BumpTexture");
}

// ---- scenes and bad input ---------------------------------------------------------------------

TEST(PomScenes, ShippedScenesLoadWithTheirTextures) {
    for (const char* name : {"pn-pom", "terrain-pom"}) {
        const Scene scene = load_scene((fs::path(TESSREF_DATA_DIR) / "scenes" / (std::string(name) + ".toml")).string());
        const ShadingModel& m = scene.shading.model;
        EXPECT_EQ(m.kind, ShadingKind::pom) << name;
        EXPECT_TRUE(missing_textures(m).empty()) << name;
        EXPECT_EQ(m.textures.s2BumpTexture->wrap(), Wrap::repeat) << name;
        EXPECT_EQ(m.textures.s2NormalTexture->width(), 256) << name;
        EXPECT_EQ(m.pom.parallax.mode, ParallaxMode::occlusion) << name;
        EXPECT_EQ(m.pom.parallax.fBumpScale, 0.04f) << name;
        EXPECT_EQ(m.pom.v3CameraPosition, glm::vec3(scene.camera->eye)) << name;
    }
}

namespace {

// A one-mesh PN scene with `shading` as its [shading] table.
std::string pom_scene(const std::string& shading) {
    return "[scene]\nname = \"bad\"\n\n[[mesh]]\npath = \"" +
           (fs::path(TESSREF_DATA_DIR) / "meshes" / "bump-uv.obj").string() +
           "\"\n\n[camera]\neye = [0.0, -2.0, 1.5]\ncenter = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\n"
           "viewport = [64, 40]\n\n[generator]\ndomain = \"triangles\"\n\n[evaluation]\nmodel = \"pn\"\n\n"
           "[shading]\nmodel = \"pom\"\n" +
           shading;
}

const std::string kConstantTextures =
    "textures = { s2DiffuseTexture = [1, 1, 1], s2NormalTexture = [0.5, 0.5, 1], s2BumpTexture = [1, 1, 1] }\n";

}  // namespace

TEST(PomScenes, BadInputNamesFileAndKey) {
    struct Case {
        std::string table;
        std::string message;
        std::string key;
    };
    const std::vector<Case> cases{
        {"", "samples s2DiffuseTexture, s2NormalTexture, s2BumpTexture", "shading.textures"},
        {"bump_scale = nan\n", "must be finite", "shading.bump_scale"},
        {"bump_scale = -0.1\n", "out of range", "shading.bump_scale"},
        {"min_layers = -3\n", "out of range [1, 256]", "shading.min_layers"},
        {"max_layers = 0\n", "out of range [1, 256]", "shading.max_layers"},
        {"shadow_layers = 2.5\n", "must be an integer", "shading.shadow_layers"},
        {"min_layers = 10\nmax_layers = 5\n", "is above", "shading.min_layers"},
        {"parallax = \"relief\"\n", "\"relief\"", "shading.parallax"},
        {"uv_repeat = 0\n", "out of range", "shading.uv_repeat"},
        {"self_shadow = 1\n", "must be a boolean", "shading.self_shadow"},
        {"bump_scael = 0.1\n", "unknown key shading.bump_scael", "shading.bump_scael"},
        {"light_direction = [0, 0, 0]\n", "cannot be normalized", "shading.light_direction"},
        {"textures = { s2DiffuseTexture = [1, 1, 1], s2NormalTexture = \"nowhere.png\", s2BumpTexture = [1, 1, 1] }\n",
         "cannot load texture", "shading.textures.s2NormalTexture"},
        {"textures = { diffuse = [1, 1, 1] }\n", "has no sampler 'diffuse'", "shading.textures.diffuse"},
    };
    const fs::path path = scratch_dir() / "bad.toml";
    for (const Case& c : cases) {
        test::write_file(path, pom_scene(c.table));
        try {
            load_scene(path.string());
            ADD_FAILURE() << "no error for " << c.table;
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find(c.message), std::string::npos) << c.table << e.what();
            EXPECT_EQ(e.where().key, c.key) << c.table << e.what();
            EXPECT_EQ(e.where().file, path.string()) << c.table;
        }
    }
    test::write_file(path, pom_scene(kConstantTextures));
    EXPECT_NO_THROW(load_scene(path.string()));
}

TEST(PomScenes, RenderRefusesBadInputWithExitTwoAndNoOutput) {
    const fs::path scene = scratch_dir() / "nan.toml", out = scratch_dir() / "nan.png";
    test::write_file(scene, pom_scene("bump_scale = nan\n" + kConstantTextures));
    const test::RunResult r = test::run_program(TESSREF_EXE, {"render", scene.string(), "-o", out.string()}, scratch_dir());
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("shading.bump_scale"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(scene.string()), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
    // The same scene with a good scale renders.
    test::write_file(scene, pom_scene("bump_scale = 0.05\n" + kConstantTextures));
    const test::RunResult ok = test::run_program(TESSREF_EXE, {"render", scene.string(), "-o", out.string()}, scratch_dir());
    EXPECT_EQ(ok.status, 0) << ok.err;
    EXPECT_TRUE(fs::exists(out));
}

// ---- the GLSL twin against llvmpipe -----------------------------------------------------------

namespace {

// `tessref gl` and `tessref render` of `scene` at 320x200, then `tessref compare` with one
// 8-bit code of threshold (1/255 and a margin for the float of code/255, as
// tests/test_gl_backend.cpp) and at most `max_failing` pixels beyond it.
void expect_gl_matches_render(const fs::path& scene, const std::string& max_failing) {
    const std::string name = scene.stem().string();
    const fs::path gl_png = scratch_dir() / (name + "-gl.png"), cpu_png = scratch_dir() / (name + "-cpu.png");
    const test::RunResult gl = test::run_program(
        TESSREF_EXE, {"gl", scene.string(), "-o", gl_png.string(), "--size", "320x200"}, scratch_dir());
    ASSERT_EQ(gl.status, 0) << gl.out << gl.err;
    EXPECT_NE(gl.out.find("every count as predicted"), std::string::npos) << gl.out;
    const test::RunResult cpu = test::run_program(
        TESSREF_EXE, {"render", scene.string(), "-o", cpu_png.string(), "--size", "320x200"}, scratch_dir());
    ASSERT_EQ(cpu.status, 0) << cpu.err;
    const test::RunResult cmp = test::run_program(
        TESSREF_EXE,
        {"compare", cpu_png.string(), gl_png.string(), "--threshold", "0.0040", "--max-failing-pixels", max_failing},
        scratch_dir());
    EXPECT_EQ(cmp.status, 0) << cmp.out << cmp.err;
}

fs::path shipped_scene(const char* name) { return fs::path(TESSREF_DATA_DIR) / "scenes" / (std::string(name) + ".toml"); }

}  // namespace

// pn-pom through data/shaders/pom.frag on llvmpipe (`tessref gl`) against the CPU reference
// (`tessref render`), as tests/test_gl_backend.cpp holds the other scenes: a pixel passes
// within one 8-bit code. The twin takes its tangent frame from llvmpipe's per-quad dFdx/dFdy
// of position and uv where the CPU solves the triangle exactly, so the frames differ in the
// last bits; the layer search and the shadow trace are discontinuous in them (a ray that
// grazes a layer or a brick edge takes the other branch), so a few pixels move by a texel.
// The limit is twice the count measured: 123 of the 19 160 covered pixels at 320x200
// (docs/PARALLAX.md).
TEST(PomScenes, GlTwinMatchesRenderOnLlvmpipe) { expect_gl_matches_render(shipped_scene("pn-pom"), "246"); }

// terrain-pom: the same pom.frag after cosc422_terrain.tese with TERRAIN_NORMALS (the
// height-field normal per vertex, as the CPU's geometry stage computes it). The mechanism
// of the failing pixels is pn-pom's: the same shader, textures and layer counts, a frame
// from llvmpipe's dFdx/dFdy against the CPU's exact solve, a branch of the layer search or
// the shadow trace taken the other way. So the bound is not this scene's own count but
// pn-pom's rate, 123 flips in its 19 160 covered pixels, applied to terrain-pom's 37 540
// covered pixels (`tessref render` prints them), with the same factor two as pn-pom:
// 2 * 37 540 * 123 / 19 160 = 482. (Measured: 135, RMSE 0.0042; a normal one texel off,
// h = 2 texels in cosc422_terrain.tese, fails 29 257 pixels. docs/PARALLAX.md.)
TEST(PomScenes, GlTwinMatchesRenderOnATerrainOnLlvmpipe) {
    expect_gl_matches_render(shipped_scene("terrain-pom"), "482");
}

// terrain-pom's capture (`tessref gl --capture`) against the CPU's (`tessref mesh --capture`)
// under golden verify's capture rule (include/tessref/golden.h): positions bit-identical,
// normals within 3 ulps or 1e-6. The normals are cosc422_terrain.tese's height-field normal
// against the CPU geometry stage's (measured: 2 ulps at most).
TEST(PomScenes, GlTerrainCaptureHasTheCpuHeightFieldNormals) {
    const fs::path scene = shipped_scene("terrain-pom");
    const fs::path gl_txt = scratch_dir() / "terrain-pom-gl.txt", cpu_txt = scratch_dir() / "terrain-pom-cpu.txt";
    const test::RunResult gl = test::run_program(
        TESSREF_EXE,
        {"gl", scene.string(), "-o", (scratch_dir() / "capture.png").string(), "--size", "160x100", "--capture",
         gl_txt.string()},
        scratch_dir());
    ASSERT_EQ(gl.status, 0) << gl.out << gl.err;
    const test::RunResult cpu =
        test::run_program(TESSREF_EXE, {"mesh", scene.string(), "--capture", cpu_txt.string()}, scratch_dir());
    ASSERT_EQ(cpu.status, 0) << cpu.out << cpu.err;
    const test::RunResult cmp = test::run_program(
        TESSREF_EXE,
        {"compare", cpu_txt.string(), gl_txt.string(), "--max-position-ulps", "0", "--max-normal-ulps", "3",
         "--max-normal-abs", "1e-6"},
        scratch_dir());
    EXPECT_EQ(cmp.status, 0) << cmp.out << cmp.err;
}

// The combinations still without a twin: exit 2 naming the key, no image.
TEST(PomScenes, GlRefusesPomWhereItHasNoTwinNamingTheKey) {
    const std::string text = test::with_absolute_data_paths(test::read_file(shipped_scene("terrain-pom")), TESSREF_DATA_DIR);
    const std::string height_field = "normals = \"height_field\"";
    ASSERT_NE(text.find(height_field), std::string::npos);
    const auto with = [&](const std::string& from, const std::string& to) {
        std::string t = text;
        t.replace(t.find(from), from.size(), to);
        return t;
    };
    struct Case {
        std::string scene;
        std::string key;
    };
    const std::vector<Case> cases{
        // cosc422_terrain.geom's GeometryData has no world position.
        {with(height_field, "normals = \"face\""), "shading.model"},
        // Without [geometry] the cosc422 program has no normal at all.
        {with("[geometry]\n" + height_field, ""), "shading.model"},
        // cosc422_terrain.frag reads the geometry stage's block, not the terrain normals'.
        {text.substr(0, text.find("\n[shading]")) + "\n[shading]\nmodel = \"cosc422\"\n", "geometry.normals"},
    };
    const fs::path scene = scratch_dir() / "terrain-pom-bad.toml", out = scratch_dir() / "terrain-pom-bad.png";
    for (const Case& c : cases) {
        test::write_file(scene, c.scene);
        const test::RunResult gl = test::run_program(TESSREF_EXE, {"gl", scene.string(), "-o", out.string()}, scratch_dir());
        EXPECT_EQ(gl.status, 2) << c.key << gl.out << gl.err;
        EXPECT_NE(gl.err.find(c.key), std::string::npos) << gl.err;
        EXPECT_FALSE(fs::exists(out)) << c.key;
    }
}
