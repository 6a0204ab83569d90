// The fragment stage (tessref/shading.h).
//
// Contract, two ways:
// - hand-derived values: the thesis's listing 3 (full diffuse along the normal, the
//   unnormalized light "position", abs() lighting back faces, the fixed +z eye of the
//   specular), the multi-texture layer order, lab 4's smoothstep boundaries, weights and
//   per-material Blinn-Phong peak, COSC422, PN, flat and depth modes, the GL lod formula;
// - the fast paths against their references, bit for bit: shade() of many fragments against
//   shade() of each, and texture() standing in for textureLod() where reads_level0_only;
// - a differential check against an independent peer, Mesa llvmpipe through OSMesa: every
//   fragment shader of data/shaders/ runs on a full-screen quad whose varyings are affine in
//   the window position, with random textures uploaded and mip-mapped by GL; the CPU twin
//   shades the same pixel centres. Tolerance 1/255 on the colour as an 8-bit framebuffer
//   stores it (clamped to [0, 1]); the measured maxima are printed.
#define GL_GLEXT_PROTOTYPES 1
#include <GL/osmesa.h>
#include <GL/gl.h>
#include <GL/glext.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tessref/shading.h"
#include "tessref/texture.h"

namespace {

using namespace tessref;

std::shared_ptr<const Texture> constant_texture(std::vector<std::uint8_t> rgba_codes) {
    const int channels = static_cast<int>(rgba_codes.size());
    return std::make_shared<const Texture>(Texture::from_unorm8(1, 1, channels, std::move(rgba_codes)));
}

bool same_bits(const glm::vec4& a, const glm::vec4& b) {
    for (int c = 0; c < 4; ++c)
        if (std::bit_cast<std::uint32_t>(a[c]) != std::bit_cast<std::uint32_t>(b[c])) return false;
    return true;
}

// ---- listing 3 ---------------------------------------------------------------------------

ThesisLight diffuse_only(glm::vec3 lightPosition) {
    ThesisLight u;
    u.lightPosition = lightPosition;
    u.diffuseMaterial = glm::vec3(0.6f, 0.5f, 0.25f);
    u.ambientMaterial = glm::vec3(0.0f);
    u.specularMaterial = glm::vec3(0.0f);
    return u;
}

TEST(ThesisLight, LightAlongTheNormalGivesFullDiffuse) {
    // df = |dot(n, L)| = 1 for n = L = (0, 0, 1): light = ambient + diffuseMaterial.
    const ThesisLight u = diffuse_only({0.0f, 0.0f, 1.0f});
    EXPECT_EQ(thesis_light({0.0f, 0.0f, 1.0f}, glm::vec3(0.0f), u), u.diffuseMaterial);
    EXPECT_EQ(thesis_light({0.0f, 0.0f, 1.0f}, glm::vec3(0.125f), u), u.diffuseMaterial + 0.125f);
    // A tilted unit light along a tilted normal: still full diffuse.
    const glm::vec3 L = glm::normalize(glm::vec3(0.3f, -0.4f, 0.8f));
    const glm::vec3 light = thesis_light(L, glm::vec3(0.0f), diffuse_only(L));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(light[c], u.diffuseMaterial[c], 1e-6f);
    // Perpendicular: no diffuse at all.
    EXPECT_EQ(thesis_light({1.0f, 0.0f, 0.0f}, glm::vec3(0.0f), u), glm::vec3(0.0f));
}

TEST(ThesisLight, LightPositionIsUsedAsAnUnnormalizedDirection) {
    // Quirk kept: df = |dot(n, lightPosition)|, so a "position" twice as far is twice as
    // bright, and a light "at" (5, 0, 0) lights a horizontal surface not at all.
    const glm::vec3 n(0.0f, 0.0f, 1.0f);
    const glm::vec3 one = thesis_light(n, glm::vec3(0.0f), diffuse_only({0.0f, 0.0f, 1.0f}));
    const glm::vec3 two = thesis_light(n, glm::vec3(0.0f), diffuse_only({0.0f, 0.0f, 2.0f}));
    EXPECT_EQ(two, 2.0f * one);
    EXPECT_EQ(thesis_light(n, glm::vec3(0.0f), diffuse_only({5.0f, 0.0f, 0.0f})), glm::vec3(0.0f));
}

TEST(ThesisLight, AbsLightsBackFacingNormalsLikeFrontFacingOnes) {
    ThesisLight u;  // defaults: diffuse, ambient and specular all non-zero
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> d(-1.0f, 1.0f);
    for (int i = 0; i < 1000; ++i) {
        const glm::vec3 n(d(rng), d(rng), d(rng));
        u.lightPosition = glm::vec3(d(rng), d(rng), d(rng) + 1.5f);
        const glm::vec3 front = thesis_light(n, u.ambientMaterial, u);
        const glm::vec3 back = thesis_light(-n, u.ambientMaterial, u);
        ASSERT_EQ(front, back) << "normal " << n.x << " " << n.y << " " << n.z;
    }
    // A normal pointing straight away from the light is at full diffuse too.
    const ThesisLight z = diffuse_only({0.0f, 0.0f, 1.0f});
    EXPECT_EQ(thesis_light({0.0f, 0.0f, -1.0f}, glm::vec3(0.0f), z), z.diffuseMaterial);
}

TEST(ThesisLight, SpecularHalfVectorUsesAFixedEyeAlongPlusZ) {
    // sf = |dot(n, normalize(L + (0,0,1)))|^shininess: 1 when n is that half vector,
    // whatever the camera (the shader has none).
    ThesisLight u;
    u.lightPosition = glm::vec3(0.0f, 0.0f, 1.0f);
    u.diffuseMaterial = glm::vec3(0.0f);
    u.specularMaterial = glm::vec3(0.25f, 0.5f, 0.75f);
    u.shininess = 40.0f;
    EXPECT_EQ(thesis_light({0.0f, 0.0f, 1.0f}, glm::vec3(0.0f), u), u.specularMaterial);
    // Light along +x: the half vector is (1, 0, 1)/sqrt(2).
    u.lightPosition = glm::vec3(1.0f, 0.0f, 0.0f);
    const glm::vec3 at_half = thesis_light(glm::normalize(glm::vec3(1.0f, 0.0f, 1.0f)), glm::vec3(0.0f), u);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(at_half[c], u.specularMaterial[c], 1e-5f);
    // Along +z only: cos 45 degrees to the power 40.
    const glm::vec3 along_z = thesis_light({0.0f, 0.0f, 1.0f}, glm::vec3(0.0f), u);
    const double expected = std::pow(std::sqrt(0.5), 40.0);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(along_z[c], expected * u.specularMaterial[c], 1e-9);
}

TEST(ThesisSingleTexture, TextureTimesLight) {
    ShadingModel model;
    model.kind = ShadingKind::thesis_single;
    model.thesis = diffuse_only({0.0f, 0.0f, 1.0f});
    model.thesis.ambientMaterial = glm::vec3(0.25f);
    model.textures.diffuse = constant_texture({255, 51, 0, 102});  // (1, 0.2, 0, 0.4)
    FragmentInputs f;
    f.normal = glm::vec3(0.0f, 0.0f, -1.0f);  // back-facing: lit all the same
    f.texCoord = glm::vec2(0.3f, 0.7f);
    const glm::vec4 got = shade(model, f);
    // light = 0.25 + 1 * (0.6, 0.5, 0.25); alpha = the texture's (vec4(light, 1)).
    EXPECT_FLOAT_EQ(got.r, 1.0f * 0.85f);
    EXPECT_FLOAT_EQ(got.g, (51.0f / 255.0f) * 0.75f);
    EXPECT_FLOAT_EQ(got.b, 0.0f);
    EXPECT_FLOAT_EQ(got.a, 102.0f / 255.0f);
}

TEST(ThesisSingleTexture, NoTextureReadsAsGlDoesForAnIncompleteTexture) {
    ShadingModel model;
    model.kind = ShadingKind::thesis_single;
    EXPECT_EQ(shade(model, FragmentInputs{}), glm::vec4(0.0f, 0.0f, 0.0f, 1.0f));
    ASSERT_EQ(missing_textures(model).size(), 1u);
    EXPECT_EQ(missing_textures(model)[0], "diffuse");
}

// ---- the multi-texture masks ---------------------------------------------------------------

ShadingModel multi_with_unit_light() {
    ShadingModel model;
    model.kind = ShadingKind::thesis_multi;
    model.thesis = diffuse_only({0.0f, 0.0f, 1.0f});
    model.thesis.diffuseMaterial = glm::vec3(1.0f);
    return model;
}

TEST(ThesisMultiTexture, LayersInTheShadersOrder) {
    // 1x1 textures (every lookup reads the one texel); AmbientOcc null reads 0, the light is
    // df * 1 = 1 for n = L = +z. By hand: diffuse 0 -> mix(0, rock01 = 1, 0.8) = 0.8 ->
    // mix(0.8, rock02 = 0, 0.5) = 0.4 -> Grass_mask 1: grass12 = 0.2 -> mix(0.2, grass09 =
    // 0.6, 1/2) = 0.4 -> Flow_mask 0: 0.4.
    ShadingModel m = multi_with_unit_light();
    m.textures.diffuse = constant_texture({0});
    m.textures.canyon_rock01 = constant_texture({255});
    m.textures.canyon_rock02 = constant_texture({0});
    m.textures.dry_grass12 = constant_texture({51});
    m.textures.dry_grass09 = constant_texture({153});
    m.textures.romanian_sand05 = constant_texture({255});
    m.textures.Grass_mask = constant_texture({255});
    m.textures.Flow_mask = constant_texture({0});
    FragmentInputs f;
    f.texCoord = glm::vec2(0.5f);
    EXPECT_NEAR(shade(m, f).r, 0.4f, 1e-6f);
    // Flow_mask 1: pure sand.
    m.textures.Flow_mask = constant_texture({255});
    EXPECT_NEAR(shade(m, f).r, 1.0f, 1e-6f);
    // Grass_mask 0 and Flow_mask 0: the rocks over the diffuse texture only.
    m.textures.Grass_mask = constant_texture({0});
    m.textures.Flow_mask = constant_texture({0});
    EXPECT_NEAR(shade(m, f).r, 0.4f, 1e-6f);
    // The AmbientOcc texture adds to the light (listing 3 with the texture as ambient).
    m.textures.AmbientOcc = constant_texture({128, 128, 128});
    EXPECT_NEAR(shade(m, f).r, 0.4f * (1.0f + 128.0f / 255.0f), 1e-6f);
    const std::vector<std::string_view> missing = missing_textures(m);  // the two Vert masks
    ASSERT_EQ(missing.size(), 2u);
    EXPECT_EQ(missing[0], "VertRock_0_90_mask");
    EXPECT_EQ(missing[1], "VertDetail_0_90_mask");
}

TEST(ThesisMultiTexture, VertRockMaskChoosesBetweenRotatedAndUnrotatedLookups) {
    // canyon_rock01 is 2x1: texel 0 = 0, texel 1 = 1. At st = (0.01, 0.04):
    //   unrotated st * 20 = (0.2, 0.8): s*2 - 0.5 < 0 -> texel 0 only -> 0;
    //   rotated (t, 1 - s) * 20 = (0.8, 19.8): s*2 - 0.5 = 1.1 -> texel 1 only -> 1.
    // Everything else null (masks read 0): colour = mix(mix(0, rock, 0.8), 0, 0.5) = 0.4 rock.
    ShadingModel m = multi_with_unit_light();
    m.textures.canyon_rock01 = std::make_shared<const Texture>(Texture::from_unorm8(2, 1, 1, {0, 255}));
    FragmentInputs f;
    f.texCoord = glm::vec2(0.01f, 0.04f);
    EXPECT_FLOAT_EQ(shade(m, f).r, 0.4f);  // mask 0 (absent): the rotated lookup
    m.textures.VertRock_0_90_mask = constant_texture({255});
    EXPECT_FLOAT_EQ(shade(m, f).r, 0.0f);  // mask 1: the unrotated lookup
}

TEST(ThesisMultiTexture, DefaultRotationTurnsTextureCoordinatesAboutTheCentre) {
    const glm::mat4 M = thesis_default_rotation_matrix();
    const glm::vec2 r = glm::vec2(glm::vec4(0.25f, 0.125f, 1.0f, 1.0f) * M);
    EXPECT_EQ(r, glm::vec2(0.125f, 0.75f));  // (t, 1 - s)
    const glm::vec2 c = glm::vec2(glm::vec4(0.5f, 0.5f, 1.0f, 1.0f) * M);
    EXPECT_EQ(c, glm::vec2(0.5f, 0.5f));
}

// ---- the level of detail ---------------------------------------------------------------------

TEST(FragmentLod, FastLog2IsPiecewiseLinearBetweenPowersOfTwo) {
    // floor(log2 x) + x / 2^floor(log2 x) - 1
    EXPECT_EQ(fast_log2(1.0f), 0.0f);
    EXPECT_EQ(fast_log2(2.0f), 1.0f);
    EXPECT_EQ(fast_log2(1024.0f), 10.0f);
    EXPECT_EQ(fast_log2(0.25f), -2.0f);
    EXPECT_EQ(fast_log2(3.0f), 1.5f);      // 1 + 3/2 - 1
    EXPECT_EQ(fast_log2(0.75f), -0.5f);    // -1 + 1.5 - 1
    EXPECT_EQ(fast_log2(25.0f), 4.5625f);  // 4 + 25/16 - 1
    EXPECT_EQ(fast_log2(0.0f), -127.0f);
    EXPECT_EQ(fast_log2(INFINITY), 128.0f);
    // Never above log2, at most 0.0861 below (at x = 2^k / ln 2).
    for (float x = 0.01f; x < 300.0f; x *= 1.01f) {
        const double error = std::log2(static_cast<double>(x)) - static_cast<double>(fast_log2(x));
        ASSERT_GE(error, -1e-6) << x;
        ASSERT_LE(error, 0.0861) << x;
    }
}

TEST(FragmentLod, GlFormulaWithLlvmpipesLog2) {
    const Texture tex = Texture::from_float(256, 128, 1, std::vector<float>(256 * 128, 0.5f));
    // One texel per pixel along both axes: lambda = 0.5 * log2(1) = 0.
    EXPECT_EQ(fragment_lod(tex, {1.0f / 256.0f, 0.0f}, {0.0f, 1.0f / 128.0f}), 0.0f);
    // Four texels per pixel in x: 2; the larger of the two directions wins.
    EXPECT_EQ(fragment_lod(tex, {4.0f / 256.0f, 0.0f}, {0.0f, 1.0f / 128.0f}), 2.0f);
    EXPECT_EQ(fragment_lod(tex, {1.0f / 256.0f, 0.0f}, {0.0f, 8.0f / 128.0f}), 3.0f);
    // rho^2 = 8 (a half-integer lod) is exact too: 1.5.
    EXPECT_EQ(fragment_lod(tex, {2.0f / 256.0f, 2.0f / 128.0f}, {0.0f, 0.0f}), 1.5f);
    // A diagonal footprint (3, 4) texels long: rho^2 = 25 -> 0.5 * 4.5625 (GL's exact
    // log2(5) = 2.3219 would be 0.04 higher).
    EXPECT_EQ(fragment_lod(tex, {3.0f / 256.0f, 4.0f / 128.0f}, {0.0f, 0.0f}), 2.28125f);
    // No derivative at all: magnification.
    EXPECT_LT(fragment_lod(tex, {0.0f, 0.0f}, {0.0f, 0.0f}), 0.0f);
}

TEST(FragmentLod, TextureGradIsTextureLodAtTheFormulasLevel) {
    std::vector<std::uint8_t> codes(64 * 32 * 3);
    std::mt19937 rng(3);
    for (auto& c : codes) c = static_cast<std::uint8_t>(rng() & 255u);
    const Texture tex = Texture::from_unorm8(64, 32, 3, codes);
    const glm::vec2 st(0.37f, 0.61f);
    // Two texels per pixel: level 1 exactly.
    EXPECT_TRUE(same_bits(textureGrad(&tex, st, {2.0f / 64.0f, 0.0f}, {0.0f, 0.0f}), tex.textureLod(st, 1.0f)));
    // Magnified (half a texel per pixel): level 0, as texture() outside a fragment shader.
    EXPECT_TRUE(same_bits(textureGrad(&tex, st, {0.5f / 64.0f, 0.0f}, {0.0f, 0.5f / 32.0f}), tex.texture(st)));
    EXPECT_TRUE(same_bits(textureGrad(&tex, st, {}, {}), tex.texture(st)));
    EXPECT_EQ(textureGrad(nullptr, st, {}, {}), glm::vec4(0.0f, 0.0f, 0.0f, 1.0f));
}

// ---- lab 4 -----------------------------------------------------------------------------------

TEST(Lab4, SmoothstepBoundariesGivePureMaterials) {
    const Lab4Shading u;  // sandHeight 50, blendWidth 10
    const glm::vec3 up(0.0f, 1.0f, 0.0f);
    // At and below sandHeight - blendWidth on flat ground: pure sand.
    for (float y : {-100.0f, 0.0f, 40.0f}) {
        const Lab4Weights w = lab4_weights({0.0f, y, 0.0f}, up, u);
        EXPECT_EQ(w.heightWeight, 0.0f);
        EXPECT_EQ(w.slopeWeight, 0.0f);
        EXPECT_EQ(w.rock, 0.0f);
        EXPECT_EQ(w.sand, 1.0f);
    }
    // At and above sandHeight + blendWidth: pure rock.
    for (float y : {60.0f, 61.0f, 1000.0f}) {
        const Lab4Weights w = lab4_weights({0.0f, y, 0.0f}, up, u);
        EXPECT_EQ(w.heightWeight, 1.0f);
        EXPECT_EQ(w.rock, 1.0f);
        EXPECT_EQ(w.sand, 0.0f);
    }
    // Halfway up the blend: smoothstep(0.5) = 0.5.
    EXPECT_EQ(lab4_weights({0.0f, 50.0f, 0.0f}, up, u).rock, 0.5f);
    // Slope: normal y <= 0.6 is pure rock at any height (the slope overrides the height),
    // y >= 0.8 adds no rock.
    const glm::vec3 steep = glm::vec3(0.8f, 0.6f, 0.0f) * 3.0f;  // normalized y = 0.6
    EXPECT_NEAR(lab4_weights({0.0f, 0.0f, 0.0f}, steep, u).rock, 1.0f, 1e-6f);
    EXPECT_EQ(lab4_weights({0.0f, 0.0f, 0.0f}, {1.0f, 0.1f, 0.0f}, u).rock, 1.0f);
    EXPECT_EQ(lab4_weights({0.0f, 0.0f, 0.0f}, {0.6f, 0.9f, 0.0f}, u).slopeWeight, 0.0f);  // y 0.83
    // Pure materials reach the colour unmixed.
    FragmentInputs f;
    f.normal = up;
    Lab4Shading dark = u;
    dark.lightDirection = glm::vec3(1.0f, 0.0f, 0.0f);  // diffuse 0 on flat ground
    dark.cameraPosition = glm::vec3(0.0f, 0.0f, 1000.0f);  // half vector (1, 0, 1): specular 0
    f.worldPosition = glm::vec3(0.0f, 0.0f, 0.0f);
    const glm::vec4 sand = lab4_terrain(f, dark);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(sand[c], 0.15f * u.sandColour[c], 1e-6f);
    f.worldPosition = glm::vec3(0.0f, 100.0f, 0.0f);
    dark.cameraPosition = glm::vec3(0.0f, 100.0f, 1000.0f);
    const glm::vec4 rock = lab4_terrain(f, dark);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(rock[c], 0.15f * u.rockColour[c], 1e-6f);
}

TEST(Lab4, WeightsSumToOneAndMoveTheRightWay) {
    const Lab4Shading u;
    float last_height_weight = -1.0f;
    for (int i = 0; i <= 400; ++i) {
        const float y = -50.0f + 0.5f * static_cast<float>(i);
        float last_slope_weight = 2.0f;
        for (int k = 0; k <= 100; ++k) {
            const float ny = 0.01f * static_cast<float>(k);
            const glm::vec3 n(std::sqrt(std::max(0.0f, 1.0f - ny * ny)), ny, 0.0f);
            const Lab4Weights w = lab4_weights({0.0f, y, 0.0f}, n, u);
            ASSERT_NEAR(w.sand + w.rock, 1.0f, 1e-6f);
            ASSERT_GE(w.rock, 0.0f);
            ASSERT_LE(w.rock, 1.0f);
            ASSERT_EQ(w.rock, std::max(w.heightWeight, w.slopeWeight));
            ASSERT_LE(w.slopeWeight, last_slope_weight + 1e-6f);  // flatter: less rock
            last_slope_weight = w.slopeWeight;
            if (k == 100) {
                ASSERT_GE(w.heightWeight, last_height_weight);  // higher: more rock
                last_height_weight = w.heightWeight;
            }
        }
    }
}

TEST(Lab4, LightAlongTheNormalAndEyeAtTheMirrorGiveFullDiffuseAndSpecularPeak) {
    Lab4Shading u;
    const glm::vec3 l = glm::normalize(u.lightDirection);  // y = 0.94: flat enough for sand
    FragmentInputs f;
    f.worldPosition = glm::vec3(3.0f, 0.0f, -2.0f);
    f.normal = l;
    u.cameraPosition = f.worldPosition + 100.0f * l;  // eye along the normal: h = n
    const glm::vec4 c = lab4_terrain(f, u);
    // albedo * (0.15 + 0.85 * 1) + 1^8 * 0.05 (sand)
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(c[k], u.sandColour[k] + 0.05f, 2e-6f);
    EXPECT_EQ(c.a, 1.0f);
}

// Specular alone: black albedo.
float lab4_specular(const Lab4Shading& base, glm::vec3 position, glm::vec3 normal, glm::vec3 view) {
    Lab4Shading u = base;
    u.sandColour = u.rockColour = glm::vec3(0.0f);
    u.cameraPosition = position + 50.0f * view;
    FragmentInputs f;
    f.worldPosition = position;
    f.normal = normal;
    return lab4_terrain(f, u).r;
}

TEST(Lab4, SpecularPeaksAtTheMirrorDirectionWithPerMaterialStrengthAndGloss) {
    const Lab4Shading u;
    const glm::vec3 n(0.0f, 1.0f, 0.0f);
    const glm::vec3 l = glm::normalize(u.lightDirection);
    const glm::vec3 mirror = 2.0f * glm::dot(n, l) * n - l;
    for (float height : {0.0f, 100.0f}) {  // sand, rock
        const glm::vec3 p(0.0f, height, 0.0f);
        const float strength = height > 50.0f ? 0.3f : 0.05f;  // mix(0.05, 0.3, rock)
        const float exponent = height > 50.0f ? 32.0f : 8.0f;  // mix(8, 32, rock)
        const float peak = lab4_specular(u, p, n, mirror);
        EXPECT_NEAR(peak, strength, 1e-6f);
        // Every other view direction of the upper hemisphere sees less.
        for (int i = 0; i < 60; ++i) {
            for (int j = 1; j < 30; ++j) {
                const float phi = 6.2831853f * static_cast<float>(i) / 60.0f;
                const float theta = 1.5707963f * static_cast<float>(j) / 30.0f;
                const glm::vec3 v(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
                if (glm::dot(v, mirror) > 0.9999f) continue;
                ASSERT_LT(lab4_specular(u, p, n, v), peak) << "phi " << phi << " theta " << theta;
            }
        }
        // Off the mirror the lobe falls as cos(n, h)^exponent: recover the exponent.
        const glm::vec3 v = glm::normalize(mirror + glm::vec3(0.3f, 0.0f, -0.2f));
        const float cos_nh = glm::dot(n, glm::normalize(l + v));
        const float ratio = lab4_specular(u, p, n, v) / strength;
        EXPECT_NEAR(std::log(ratio) / std::log(cos_nh), exponent, 1e-2f);
    }
}

// ---- COSC422, PN, flat, depth ----------------------------------------------------------------

TEST(Cosc422, AmbientPlusDiffuseOverTheHeightAsGrey) {
    ShadingModel m;
    m.kind = ShadingKind::cosc422;
    FragmentInputs f;
    f.normal = glm::vec3(0.0f, 3.0f, 0.0f);  // along the light (normalized in the shader)
    // No height map: texture() reads 0 -> albedo 0.5.
    EXPECT_EQ(shade(m, f), glm::vec4(0.5f, 0.5f, 0.5f, 1.0f));
    m.textures.heightMap = constant_texture({255});
    EXPECT_EQ(shade(m, f), glm::vec4(1.0f, 1.0f, 1.0f, 1.0f));  // (0.2 + 0.8 * 1) * 1
    f.normal = glm::vec3(1.0f, 0.0f, 0.0f);  // perpendicular: ambient only
    EXPECT_EQ(shade(m, f), glm::vec4(0.2f, 0.2f, 0.2f, 1.0f));
    f.normal = glm::vec3(0.0f, -1.0f, 0.0f);  // facing away: no abs() here, ambient only
    EXPECT_EQ(shade(m, f), glm::vec4(0.2f, 0.2f, 0.2f, 1.0f));
}

TEST(PnTriangles, DiffusePlusSpecularAtTheMirror) {
    ShadingModel m;
    m.kind = ShadingKind::pn;
    const glm::vec3 l = glm::normalize(m.pn.v3LightDirection);
    FragmentInputs f;
    f.worldPosition = glm::vec3(1.0f, 2.0f, 3.0f);
    f.normal = l;
    m.pn.v3CameraPosition = f.worldPosition + 10.0f * l;
    const glm::vec4 c = shade(m, f);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(c[k], m.pn.v3DiffuseColour[k] + 0.3f, 2e-6f);
    f.normal = -l;  // facing away: 0.1 ambient, no specular
    const glm::vec4 away = shade(m, f);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(away[k], 0.1f * m.pn.v3DiffuseColour[k], 1e-6f);
}

TEST(NoShading, FlatColourAndDepth) {
    ShadingModel m;
    EXPECT_EQ(m.kind, ShadingKind::flat);
    m.flat.colour = glm::vec4(0.1f, 0.2f, 0.3f, 0.4f);
    FragmentInputs f;
    f.depth = 0.3f;
    EXPECT_EQ(shade(m, f), m.flat.colour);
    m.kind = ShadingKind::depth;
    m.depth.mapping = DepthMapping::window;
    EXPECT_EQ(shade(m, f), glm::vec4(0.3f, 0.3f, 0.3f, 1.0f));
    // Linear: near 1, far 3. Window depth of eye distance z: d = (f + n - 2nf/z)/(2(f - n))
    // + 1/2, so z = 2 -> d = 0.75, and (2 - 1)/(3 - 1) = 0.5.
    m.depth.mapping = DepthMapping::linear;
    m.depth.near_plane = 1.0f;
    m.depth.far_plane = 3.0f;
    f.depth = 0.75f;
    EXPECT_NEAR(shade(m, f).r, 0.5f, 1e-6f);
    f.depth = 0.0f;
    EXPECT_NEAR(shade(m, f).r, 0.0f, 1e-6f);
    f.depth = 1.0f;
    EXPECT_NEAR(shade(m, f).r, 1.0f, 1e-6f);
}

TEST(ShadingModelTest, ASceneThatNamesNoTextureNeedsNone) {
    for (ShadingKind kind : {ShadingKind::flat, ShadingKind::depth, ShadingKind::lab4, ShadingKind::pn}) {
        ShadingModel m;
        m.kind = kind;
        EXPECT_TRUE(sampler_names(kind).empty()) << to_string(kind);
        EXPECT_TRUE(missing_textures(m).empty()) << to_string(kind);
        EXPECT_FALSE(fragment_needs(kind).texCoord_derivatives) << to_string(kind);
        FragmentInputs f;
        f.worldPosition = glm::vec3(0.0f, 10.0f, 0.0f);
        f.normal = glm::vec3(0.0f, 1.0f, 0.0f);
        m.lab4.cameraPosition = m.pn.v3CameraPosition = glm::vec3(5.0f, 50.0f, 5.0f);
        const glm::vec4 c = shade(m, f);
        for (int k = 0; k < 4; ++k) EXPECT_TRUE(std::isfinite(c[k])) << to_string(kind);
    }
    ShadingModel multi;
    multi.kind = ShadingKind::thesis_multi;
    EXPECT_EQ(missing_textures(multi).size(), 11u);
    EXPECT_EQ(sampler_names(ShadingKind::cosc422).size(), 1u);
}

TEST(ShadingModelTest, NamesRoundTripAndSlotsMatchTheSamplers) {
    for (ShadingKind kind : {ShadingKind::flat, ShadingKind::depth, ShadingKind::thesis_single,
                             ShadingKind::thesis_multi, ShadingKind::lab4, ShadingKind::cosc422, ShadingKind::pn}) {
        EXPECT_EQ(shading_kind_from_string(to_string(kind)), kind);
        ShadingTextures t;
        for (std::string_view name : sampler_names(kind)) EXPECT_NE(sampler_slot(t, name), nullptr) << name;
    }
    EXPECT_FALSE(shading_kind_from_string("phong").has_value());
    ShadingTextures t;
    EXPECT_EQ(sampler_slot(t, "normalMap"), nullptr);
    *sampler_slot(t, "Flow_mask") = constant_texture({1});
    EXPECT_NE(t.Flow_mask, nullptr);
}

// ---- determinism -----------------------------------------------------------------------------

ShadingModel model_of(ShadingKind kind) {
    ShadingModel m;
    m.kind = kind;
    std::mt19937 rng(11);
    auto random_texture = [&](int w, int h, int ch) {
        std::vector<std::uint8_t> codes(static_cast<std::size_t>(w * h * ch));
        for (auto& c : codes) c = static_cast<std::uint8_t>(rng() & 255u);
        return std::make_shared<const Texture>(Texture::from_unorm8(w, h, ch, codes));
    };
    for (std::string_view name : sampler_names(kind)) *sampler_slot(m.textures, name) = random_texture(17, 13, 3);
    m.lab4.cameraPosition = m.pn.v3CameraPosition = glm::vec3(10.0f, 80.0f, 20.0f);
    m.depth.near_plane = 0.5f;
    m.depth.far_plane = 500.0f;
    return m;
}

std::vector<glm::vec4> shade_grid(const ShadingModel& m, int begin, int end) {
    std::vector<glm::vec4> out;
    for (int i = begin; i < end; ++i) {
        const float x = static_cast<float>(i % 64) / 63.0f;
        const float y = static_cast<float>(i / 64) / 63.0f;
        FragmentInputs f;
        f.worldPosition = glm::vec3(100.0f * x - 50.0f, 80.0f * y, 10.0f * x * y);
        f.normal = glm::vec3(x - 0.5f, 0.7f + 0.3f * y, 0.2f - x * y);
        f.texCoord = glm::vec2(1.2f * x - 0.1f, 1.2f * y - 0.1f);
        f.texCoord_dx = glm::vec2(0.004f + 0.01f * y, 0.001f);
        f.texCoord_dy = glm::vec2(-0.002f, 0.005f + 0.02f * x);
        f.depth = 0.5f + 0.49f * x;
        out.push_back(shade(m, f));
    }
    return out;
}

TEST(Determinism, SameInputsSameBitsOnAnyThread) {
    for (ShadingKind kind : {ShadingKind::flat, ShadingKind::depth, ShadingKind::thesis_single,
                             ShadingKind::thesis_multi, ShadingKind::lab4, ShadingKind::cosc422, ShadingKind::pn}) {
        const ShadingModel m = model_of(kind);
        const std::vector<glm::vec4> first = shade_grid(m, 0, 4096);
        std::vector<glm::vec4> halves[2];
        std::thread a([&] { halves[0] = shade_grid(m, 0, 2048); });
        std::thread b([&] { halves[1] = shade_grid(m, 2048, 4096); });
        a.join();
        b.join();
        std::vector<glm::vec4> second = halves[0];
        second.insert(second.end(), halves[1].begin(), halves[1].end());
        ASSERT_EQ(first.size(), second.size());
        std::size_t differing = 0;
        for (std::size_t i = 0; i < first.size(); ++i) differing += !same_bits(first[i], second[i]);
        EXPECT_EQ(differing, 0u) << to_string(kind);
    }
}

// ---- many fragments at once ------------------------------------------------------------------

// Textures of every sampling path: unorm8 and unorm16 (luminance) and float, one to four
// channels, clamp and repeat, GL_LINEAR minification, a single level, a one-texel-wide level.
std::vector<std::shared_ptr<Texture>> sampling_textures(std::mt19937& rng) {
    auto codes = [&](int n, unsigned mask) {
        std::vector<std::uint16_t> c(static_cast<std::size_t>(n));
        for (auto& v : c) v = static_cast<std::uint16_t>(rng() & mask);
        return c;
    };
    std::vector<std::shared_ptr<Texture>> textures;
    for (int channels = 1; channels <= 4; ++channels) {
        const auto c8 = codes(37 * 23 * channels, 255u);
        textures.push_back(std::make_shared<Texture>(
            Texture::from_unorm8(37, 23, channels, std::vector<std::uint8_t>(c8.begin(), c8.end()))));
    }
    textures.push_back(std::make_shared<Texture>(Texture::from_unorm16(41, 29, 1, codes(41 * 29, 65535u))));
    textures.back()->set_swizzle(Swizzle::luminance);
    std::vector<float> values(19 * 31 * 2);
    for (float& v : values) v = static_cast<float>(rng() & 65535u) / 4096.0f;
    textures.push_back(std::make_shared<Texture>(Texture::from_float(19, 31, 2, values)));
    const auto one = codes(1 * 9, 255u);
    textures.push_back(
        std::make_shared<Texture>(Texture::from_unorm8(1, 9, 1, std::vector<std::uint8_t>(one.begin(), one.end()))));
    textures.push_back(std::make_shared<Texture>(Texture::from_unorm8(1, 1, 1, {200})));  // one level
    const std::size_t made = textures.size();
    for (std::size_t k = 0; k < made; ++k) {
        auto repeat = std::make_shared<Texture>(*textures[k]);
        repeat->set_wrap(Wrap::repeat);
        auto linear = std::make_shared<Texture>(*textures[k]);
        linear->set_min_filter(MinFilter::linear);
        textures.push_back(repeat);
        textures.push_back(linear);
    }
    return textures;
}

// Lods on both sides of the clamp at 0, and the ones it treats specially.
constexpr float kHostileLods[] = {-std::numeric_limits<float>::infinity(), -100.0f, -1.0f, -0.0f, 0.0f,
                                  std::numeric_limits<float>::denorm_min(), 1e-30f, 0.001f, 0.5f, 1.0f, 3.7f,
                                  100.0f, std::numeric_limits<float>::infinity(),
                                  std::numeric_limits<float>::quiet_NaN()};

TEST(TextureLevel0, ReadsLevel0OnlyWhereTextureLodIsTexture) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> coordinate(-0.5f, 1.5f);
    int level0 = 0, other = 0;
    for (const auto& texture : sampling_textures(rng)) {
        for (const float lod : kHostileLods) {
            (texture->reads_level0_only(lod) ? level0 : other) += 1;
            if (!texture->reads_level0_only(lod)) continue;
            for (int n = 0; n < 200; ++n) {
                glm::vec2 st(coordinate(rng), coordinate(rng));
                if (n == 0) st = glm::vec2(std::numeric_limits<float>::quiet_NaN());
                ASSERT_TRUE(same_bits(texture->textureLod(st, lod), texture->texture(st)))
                    << "lod " << lod << " st " << st.x << " " << st.y << " format " << to_string(texture->format());
            }
        }
    }
    // Both answers were given (the mipmapped textures minify above lod 0).
    EXPECT_GT(level0, 0);
    EXPECT_GT(other, 0);
}

TEST(ShadeMany, EveryFragmentAsShadedAlone) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::uniform_int_distribution<int> exponent(-14, 3);
    const auto textures = sampling_textures(rng);
    std::vector<ShadingModel> models;
    for (ShadingKind kind : {ShadingKind::flat, ShadingKind::depth, ShadingKind::thesis_single,
                             ShadingKind::thesis_multi, ShadingKind::lab4, ShadingKind::cosc422, ShadingKind::pn})
        models.push_back(model_of(kind));
    // The single-texture thesis shader on every sampling path, and with no texture.
    for (const auto& texture : textures) {
        models.push_back(model_of(ShadingKind::thesis_single));
        models.back().textures.diffuse = texture;
    }
    models.push_back(model_of(ShadingKind::thesis_single));
    models.back().textures.diffuse = nullptr;
    for (const ShadingModel& model : models) {
        for (std::size_t count = 0; count <= 9; ++count) {
            std::vector<FragmentInputs> fragments(count);
            for (FragmentInputs& f : fragments) {
                f.worldPosition = 50.0f * glm::vec3(unit(rng), unit(rng), unit(rng));
                f.normal = glm::vec3(unit(rng), unit(rng), unit(rng));
                f.texCoord = 1.5f * glm::vec2(unit(rng), unit(rng));
                // Footprints from a sixteenth of a texel to thousands: magnified and minified
                // fragments side by side; now and then none, or NaN.
                const float scale = std::ldexp(1.0f, exponent(rng));
                f.texCoord_dx = scale * glm::vec2(unit(rng), unit(rng));
                f.texCoord_dy = scale * glm::vec2(unit(rng), unit(rng));
                if (rng() % 8 == 0) f.texCoord_dx = f.texCoord_dy = glm::vec2(0.0f);
                if (rng() % 16 == 0) f.texCoord_dx.x = std::numeric_limits<float>::quiet_NaN();
                f.depth = 0.5f + 0.5f * unit(rng);
            }
            std::vector<glm::vec4> many(count);
            shade(model, fragments, many);
            for (std::size_t k = 0; k < count; ++k)
                ASSERT_TRUE(same_bits(many[k], shade(model, fragments[k])))
                    << to_string(model.kind) << " fragment " << k << " of " << count;
        }
    }
}

// ---- the independent peer: llvmpipe -------------------------------------------------------

constexpr int kWidth = 128;
constexpr int kHeight = 128;

class Llvmpipe : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        const int attribs[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                               OSMESA_CONTEXT_MAJOR_VERSION, 4, OSMESA_CONTEXT_MINOR_VERSION, 5, 0};
        context_ = OSMesaCreateContextAttribs(attribs, nullptr);
        if (context_ == nullptr) return;
        framebuffer_.assign(static_cast<std::size_t>(kWidth * kHeight * 4), 0.0f);
        if (!OSMesaMakeCurrent(context_, framebuffer_.data(), GL_FLOAT, kWidth, kHeight)) {
            OSMesaDestroyContext(context_);
            context_ = nullptr;
        }
    }
    static void TearDownTestSuite() {
        if (context_ != nullptr) OSMesaDestroyContext(context_);
        context_ = nullptr;
    }
    void SetUp() override {
        // The llvmpipe comparison is the contract: no context is a failure, not a skip.
        ASSERT_NE(context_, nullptr) << "no OSMesa OpenGL 4.5 core context";
    }
    static OSMesaContext context_;
    static std::vector<float> framebuffer_;
};
OSMesaContext Llvmpipe::context_ = nullptr;
std::vector<float> Llvmpipe::framebuffer_;

std::string read_shader(const std::string& file) {
    std::ifstream in(std::string(TESSREF_DATA_DIR) + "/shaders/" + file);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

GLuint compile(GLenum stage, const std::string& source, const std::string& label) {
    const GLuint shader = glCreateShader(stage);
    const char* text = source.c_str();
    glShaderSource(shader, 1, &text, nullptr);
    glCompileShader(shader);
    GLint ok = 0;
    glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[4096] = {};
        glGetShaderInfoLog(shader, sizeof log, nullptr, log);
        ADD_FAILURE() << label << " does not compile:\n" << log;
    }
    return shader;
}

// Varyings affine in normalized device coordinates: v(x, y) = c + ax * x + ay * y. A
// full-screen quad interpolates them exactly (up to float rounding), so every pixel's inputs
// are known in closed form, derivatives included.
template <int N>
struct Affine {
    glm::vec<N, float> c{0.0f};
    glm::vec<N, float> ax{0.0f};
    glm::vec<N, float> ay{0.0f};
    glm::vec<N, float> at(float x, float y) const { return c + ax * x + ay * y; }
};

struct GlTexture {
    std::string sampler;
    int binding = 0;
    int width = 0;
    int height = 0;
    int channels = 0;
    bool sixteen_bit = false;
};

struct GlCase {
    std::string name;
    std::string fragment_shader;  // file in data/shaders/
    std::string block;            // the fragment shader's input block, as an output
    std::string assign;           // a0 (vec3), a1 (vec3), a2 (vec2) -> block members
    Affine<3> a0;                 // -> FragmentInputs::normal
    Affine<3> a1;                 // -> FragmentInputs::worldPosition
    Affine<2> a2;                 // -> FragmentInputs::texCoord
    ShadingModel model;
    std::vector<GlTexture> textures;
    std::function<void(GLuint program, const ShadingModel&)> set_uniforms;
};

void uniform3(GLuint program, const char* name, glm::vec3 v) {
    glUniform3f(glGetUniformLocation(program, name), v.x, v.y, v.z);
}
void uniform1(GLuint program, const char* name, float v) { glUniform1f(glGetUniformLocation(program, name), v); }

void set_thesis_uniforms(GLuint program, const ShadingModel& m) {
    uniform3(program, "lightPosition", m.thesis.lightPosition);
    uniform3(program, "diffuseMaterial", m.thesis.diffuseMaterial);
    uniform3(program, "ambientMaterial", m.thesis.ambientMaterial);  // -1 (unused) in the multi shader
    uniform3(program, "specularMaterial", m.thesis.specularMaterial);
    uniform1(program, "shininess", m.thesis.shininess);
    glUniformMatrix4fv(glGetUniformLocation(program, "rotationMatrix"), 1, GL_FALSE, &m.rotationMatrix[0][0]);
}

// Random texels, the same codes given to GL and to tessref::Texture.
void make_textures(GlCase& c, unsigned seed, std::vector<GLuint>& names) {
    std::mt19937 rng(seed);
    static const GLenum base[4] = {GL_RED, GL_RG, GL_RGB, GL_RGBA};
    static const GLenum i8[4] = {GL_R8, GL_RG8, GL_RGB8, GL_RGBA8};
    static const GLenum i16[4] = {GL_R16, GL_RG16, GL_RGB16, GL_RGBA16};
    for (const GlTexture& t : c.textures) {
        const std::size_t n = static_cast<std::size_t>(t.width * t.height * t.channels);
        const int k = t.channels - 1;
        GLuint name = 0;
        glGenTextures(1, &name);
        glActiveTexture(GL_TEXTURE0 + static_cast<GLenum>(t.binding));
        glBindTexture(GL_TEXTURE_2D, name);
        glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
        std::shared_ptr<const Texture> cpu;
        if (t.sixteen_bit) {
            std::vector<std::uint16_t> codes(n);
            for (auto& v : codes) v = static_cast<std::uint16_t>(rng() & 0xFFFFu);
            glTexImage2D(GL_TEXTURE_2D, 0, static_cast<GLint>(i16[k]), t.width, t.height, 0, base[k], GL_UNSIGNED_SHORT,
                         codes.data());
            cpu = std::make_shared<const Texture>(Texture::from_unorm16(t.width, t.height, t.channels, codes));
        } else {
            std::vector<std::uint8_t> codes(n);
            for (auto& v : codes) v = static_cast<std::uint8_t>(rng() & 0xFFu);
            glTexImage2D(GL_TEXTURE_2D, 0, static_cast<GLint>(i8[k]), t.width, t.height, 0, base[k], GL_UNSIGNED_BYTE,
                         codes.data());
            cpu = std::make_shared<const Texture>(Texture::from_unorm8(t.width, t.height, t.channels, codes));
        }
        glGenerateMipmap(GL_TEXTURE_2D);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        *sampler_slot(c.model.textures, t.sampler) = cpu;
        names.push_back(name);
    }
}

struct Difference {
    double max_clamped = 0.0;  // |clamp(ours) - clamp(llvmpipe)|, per channel
    int max_code = 0;          // the same as unorm8 codes
    std::size_t over_tolerance = 0;
    std::size_t samples = 0;
};

// Renders the case on llvmpipe and shades the same pixel centres on the CPU.
Difference run_case(GlCase c, unsigned seed) {
    Difference diff;
    std::vector<GLuint> texture_names;
    make_textures(c, seed, texture_names);

    const std::string vertex_source =
        "#version 450 core\n"
        "layout(location = 0) in vec2 corner;\n"
        "layout(location = 1) in vec3 a0;\n"
        "layout(location = 2) in vec3 a1;\n"
        "layout(location = 3) in vec2 a2;\n"
        "layout(location = 0) out " + c.block + " vsOut;\n"
        "void main() {\n  " + c.assign + "\n  gl_Position = vec4(corner, 0.0, 1.0);\n}\n";
    const GLuint vs = compile(GL_VERTEX_SHADER, vertex_source, c.name + " vertex shader");
    const GLuint fs = compile(GL_FRAGMENT_SHADER, read_shader(c.fragment_shader), c.fragment_shader);
    const GLuint program = glCreateProgram();
    glAttachShader(program, vs);
    glAttachShader(program, fs);
    glLinkProgram(program);
    GLint linked = 0;
    glGetProgramiv(program, GL_LINK_STATUS, &linked);
    if (!linked) {
        char log[4096] = {};
        glGetProgramInfoLog(program, sizeof log, nullptr, log);
        ADD_FAILURE() << c.name << ": link failed:\n" << log;
        return diff;
    }
    glUseProgram(program);
    if (c.set_uniforms) c.set_uniforms(program, c.model);

    // Four corners, each: corner (2), a0 (3), a1 (3), a2 (2).
    std::vector<float> vertices;
    for (const glm::vec2 corner : {glm::vec2(-1, -1), glm::vec2(1, -1), glm::vec2(-1, 1), glm::vec2(1, 1)}) {
        const glm::vec3 v0 = c.a0.at(corner.x, corner.y);
        const glm::vec3 v1 = c.a1.at(corner.x, corner.y);
        const glm::vec2 v2 = c.a2.at(corner.x, corner.y);
        vertices.insert(vertices.end(), {corner.x, corner.y, v0.x, v0.y, v0.z, v1.x, v1.y, v1.z, v2.x, v2.y});
    }
    GLuint vao = 0, vbo = 0;
    glGenVertexArrays(1, &vao);
    glBindVertexArray(vao);
    glGenBuffers(1, &vbo);
    glBindBuffer(GL_ARRAY_BUFFER, vbo);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices.size() * sizeof(float)), vertices.data(), GL_STATIC_DRAW);
    const GLsizei stride = 10 * sizeof(float);
    const int sizes[4] = {2, 3, 3, 2};
    std::size_t offset = 0;
    for (GLuint a = 0; a < 4; ++a) {
        glVertexAttribPointer(a, sizes[a], GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(offset));
        glEnableVertexAttribArray(a);
        offset += static_cast<std::size_t>(sizes[a]) * sizeof(float);
    }
    glViewport(0, 0, kWidth, kHeight);
    glClearColor(0.0f, 0.0f, 0.0f, 0.0f);
    glClear(GL_COLOR_BUFFER_BIT);
    glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
    std::vector<float> pixels(static_cast<std::size_t>(kWidth * kHeight * 4));
    glReadPixels(0, 0, kWidth, kHeight, GL_RGBA, GL_FLOAT, pixels.data());
    EXPECT_EQ(glGetError(), static_cast<GLenum>(GL_NO_ERROR)) << c.name;

    // dFdx/dFdy of a2 in window pixels: d(ndc)/d(pixel) = 2 / size.
    const glm::vec2 da2dx = c.a2.ax * (2.0f / kWidth);
    const glm::vec2 da2dy = c.a2.ay * (2.0f / kHeight);
    int reported = 0;
    for (int py = 0; py < kHeight; ++py) {
        for (int px = 0; px < kWidth; ++px) {
            const float x = (static_cast<float>(px) + 0.5f) * (2.0f / kWidth) - 1.0f;
            const float y = (static_cast<float>(py) + 0.5f) * (2.0f / kHeight) - 1.0f;
            FragmentInputs f;
            f.normal = c.a0.at(x, y);
            f.worldPosition = c.a1.at(x, y);
            f.texCoord = c.a2.at(x, y);
            f.texCoord_dx = da2dx;
            f.texCoord_dy = da2dy;
            const glm::vec4 ours = shade(c.model, f);
            const float* gl = &pixels[static_cast<std::size_t>((py * kWidth + px) * 4)];
            for (int k = 0; k < 4; ++k) {
                const double a = std::clamp(static_cast<double>(ours[k]), 0.0, 1.0);
                const double b = std::clamp(static_cast<double>(gl[k]), 0.0, 1.0);
                const double d = std::abs(a - b);
                const int code = std::abs(static_cast<int>(std::lround(a * 255.0)) - static_cast<int>(std::lround(b * 255.0)));
                diff.max_clamped = std::max(diff.max_clamped, d);
                diff.max_code = std::max(diff.max_code, code);
                ++diff.samples;
                if (d > 1.0 / 255.0) {
                    ++diff.over_tolerance;
                    if (reported++ < 5)
                        ADD_FAILURE() << c.name << ": pixel (" << px << ", " << py << ") channel " << k << ": tessref "
                                      << ours[k] << ", llvmpipe " << gl[k];
                }
            }
        }
    }
    glDeleteBuffers(1, &vbo);
    glDeleteVertexArrays(1, &vao);
    glDeleteProgram(program);
    glDeleteShader(vs);
    glDeleteShader(fs);
    glDeleteTextures(static_cast<GLsizei>(texture_names.size()), texture_names.data());
    return diff;
}

void expect_matches_llvmpipe(const GlCase& c, unsigned seed) {
    const Difference d = run_case(c, seed);
    std::printf("[ llvmpipe ] %-28s max |tessref - llvmpipe| = %.3g (%.3f/255), max unorm8 code difference %d, "
                "%zu samples\n",
                c.name.c_str(), d.max_clamped, d.max_clamped * 255.0, d.max_code, d.samples);
    EXPECT_EQ(d.over_tolerance, 0u) << c.name;
    EXPECT_LE(d.max_code, 1) << c.name;
}

const char* kThesisBlock = "GeometryData { vec3 gNormal; vec2 gTextureCoordinate; }";
const char* kThesisAssign = "vsOut.gNormal = a0; vsOut.gTextureCoordinate = a2;";

GlCase thesis_single_case(const std::string& name, int width, int height) {
    GlCase c;
    c.name = name;
    c.fragment_shader = "thesis_terrain_single.frag";
    c.block = kThesisBlock;
    c.assign = kThesisAssign;
    // Normals of both signs against the light (abs), not unit length (not renormalized).
    c.a0 = {{0.3f, -0.2f, 0.6f}, {0.9f, 0.1f, 0.3f}, {-0.1f, 0.8f, -0.4f}};
    c.a2 = {{0.5f, 0.5f}, {0.6f, 0.15f}, {0.1f, 0.55f}};
    c.model.kind = ShadingKind::thesis_single;
    c.model.thesis.lightPosition = glm::vec3(0.4f, -0.3f, 0.9f);
    c.model.thesis.diffuseMaterial = glm::vec3(0.7f, 0.6f, 0.5f);
    c.model.thesis.ambientMaterial = glm::vec3(0.1f, 0.12f, 0.08f);
    c.model.thesis.specularMaterial = glm::vec3(0.3f, 0.3f, 0.25f);
    c.model.thesis.shininess = 20.0f;
    c.textures = {{"diffuse", 4, width, height, 4, false}};
    c.set_uniforms = set_thesis_uniforms;
    return c;
}

TEST_F(Llvmpipe, ThesisSingleTextureMinified) {
    // 256 x 192 texels under ~1.2 texture units over 128 pixels: lod about 1.3.
    expect_matches_llvmpipe(thesis_single_case("thesis_single minified", 256, 192), 1);
}

TEST_F(Llvmpipe, ThesisSingleTextureMagnified) {
    expect_matches_llvmpipe(thesis_single_case("thesis_single magnified", 23, 17), 2);
}

GlCase thesis_multi_case(const std::string& name) {
    GlCase c;
    c.name = name;
    c.fragment_shader = "thesis_terrain.frag";
    c.block = kThesisBlock;
    c.assign = kThesisAssign;
    c.a0 = {{0.1f, 0.2f, 0.3f}, {0.9f, -0.2f, 0.2f}, {0.1f, 0.6f, -0.3f}};  // dot with L of both signs
    c.model.kind = ShadingKind::thesis_multi;
    c.model.thesis.lightPosition = glm::vec3(0.3f, 0.2f, 0.8f);
    c.model.thesis.diffuseMaterial = glm::vec3(0.6f);
    c.model.thesis.specularMaterial = glm::vec3(0.2f, 0.2f, 0.1f);
    c.model.thesis.shininess = 12.0f;
    c.textures = {{"diffuse", 4, 128, 96, 4, false},        {"canyon_rock01", 5, 32, 32, 3, false},
                  {"canyon_rock02", 6, 24, 40, 3, false},   {"dry_grass09", 7, 16, 16, 3, false},
                  {"dry_grass12", 8, 20, 12, 3, false},     {"romanian_sand05", 9, 32, 16, 3, false},
                  {"VertRock_0_90_mask", 10, 64, 64, 1, false}, {"VertDetail_0_90_mask", 11, 48, 64, 1, false},
                  {"Grass_mask", 12, 64, 32, 1, false},     {"Flow_mask", 13, 40, 40, 1, false},
                  {"AmbientOcc", 14, 40, 30, 3, false}};
    c.set_uniforms = set_thesis_uniforms;
    return c;
}

TEST_F(Llvmpipe, ThesisMultiTextureWholeTerrain) {
    // The terrain's [0, 1] (and a little outside): base textures and masks minified and
    // magnified, detail lookups (x20 .. x100) mostly at the clamped edge.
    GlCase c = thesis_multi_case("thesis_multi whole terrain");
    c.a2 = {{0.5f, 0.5f}, {0.6f, 0.05f}, {-0.04f, 0.55f}};
    expect_matches_llvmpipe(c, 3);
}

TEST_F(Llvmpipe, ThesisMultiTextureDetailScale) {
    // A corner of the terrain, st in about [0, 0.014]: the detail lookups land inside their
    // textures at lods from below 0 to above 2; a rotation about this corner's centre keeps
    // the rotated lookups inside too.
    GlCase c = thesis_multi_case("thesis_multi detail scale");
    c.a2 = {{0.007f, 0.007f}, {0.007f, 0.001f}, {0.0015f, 0.0065f}};
    glm::mat4 M = thesis_default_rotation_matrix();
    M[1] = glm::vec4(-1.0f, 0.0f, 0.0f, 0.014f);  // (s, t) -> (t, 0.014 - s)
    c.model.rotationMatrix = M;
    expect_matches_llvmpipe(c, 4);
}

GlCase lab4_case(const std::string& name) {
    GlCase c;
    c.name = name;
    c.fragment_shader = "lab4_terrain.frag";
    c.block = "EvaluationData { vec3 worldPosition; vec3 normal; vec2 texCoord; }";
    c.assign = "vsOut.worldPosition = a1; vsOut.normal = a0; vsOut.texCoord = a2;";
    // Heights across the blend band (40 .. 60), normals across the slope band (y 0.6 .. 0.8).
    c.a1 = {{0.0f, 50.0f, -20.0f}, {50.0f, 18.0f, 0.0f}, {0.0f, 6.0f, 40.0f}};
    c.a0 = {{0.0f, 1.0f, 0.0f}, {0.9f, 0.0f, 0.1f}, {0.1f, 0.0f, 0.8f}};
    c.model.kind = ShadingKind::lab4;
    c.model.lab4.cameraPosition = glm::vec3(10.0f, 120.0f, 60.0f);
    return c;
}

TEST_F(Llvmpipe, Lab4DefaultsEqualTheShadersInitializers) {
    // Only cameraPosition (no initializer) is set in GL; the rest are the GLSL defaults on
    // one side and the C++ defaults on the other.
    GlCase c = lab4_case("lab4 defaults");
    c.set_uniforms = [](GLuint program, const ShadingModel& m) {
        uniform3(program, "cameraPosition", m.lab4.cameraPosition);
    };
    expect_matches_llvmpipe(c, 5);
}

TEST_F(Llvmpipe, Lab4CustomUniforms) {
    GlCase c = lab4_case("lab4 custom");
    c.model.lab4.lightDirection = glm::vec3(-0.5f, 0.7f, 0.4f);
    c.model.lab4.sandColour = glm::vec3(0.9f, 0.8f, 0.4f);
    c.model.lab4.rockColour = glm::vec3(0.3f, 0.3f, 0.35f);
    c.model.lab4.sandHeight = 45.0f;
    c.model.lab4.blendWidth = 4.0f;
    c.model.lab4.cameraPosition = glm::vec3(-30.0f, 70.0f, 10.0f);
    c.set_uniforms = [](GLuint program, const ShadingModel& m) {
        uniform3(program, "cameraPosition", m.lab4.cameraPosition);
        uniform3(program, "lightDirection", m.lab4.lightDirection);
        uniform3(program, "sandColour", m.lab4.sandColour);
        uniform3(program, "rockColour", m.lab4.rockColour);
        uniform1(program, "sandHeight", m.lab4.sandHeight);
        uniform1(program, "blendWidth", m.lab4.blendWidth);
    };
    expect_matches_llvmpipe(c, 6);
}

TEST_F(Llvmpipe, Cosc422WithA16BitHeightMap) {
    GlCase c;
    c.name = "cosc422 defaults";
    c.fragment_shader = "cosc422_terrain.frag";
    c.block = "GeometryData { vec3 faceNormal; vec2 texCoord; }";
    c.assign = "vsOut.faceNormal = a0; vsOut.texCoord = a2;";
    c.a0 = {{0.1f, 0.6f, 0.0f}, {0.8f, 0.1f, 0.0f}, {0.0f, 0.3f, 0.7f}};
    c.a2 = {{0.5f, 0.5f}, {1.5f, 0.0f}, {0.2f, 1.2f}};  // minified, lod about 0.6
    c.model.kind = ShadingKind::cosc422;
    c.textures = {{"heightMap", 0, 64, 64, 1, true}};
    expect_matches_llvmpipe(c, 7);
}

GlCase pn_case(const std::string& name) {
    GlCase c;
    c.name = name;
    c.fragment_shader = "pn_triangles.frag";
    c.block = "EvaluationData { vec3 v3PositionOut; vec3 v3NormalOut; vec2 v2UVOut; }";
    c.assign = "vsOut.v3PositionOut = a1; vsOut.v3NormalOut = a0; vsOut.v2UVOut = a2;";
    c.a1 = {{0.0f, 0.0f, 0.0f}, {1.0f, 0.0f, 0.2f}, {0.0f, 1.0f, -0.1f}};
    c.a0 = {{0.2f, 0.3f, 0.8f}, {0.9f, 0.0f, 0.1f}, {0.0f, 0.9f, 0.2f}};
    c.model.kind = ShadingKind::pn;
    c.model.pn.v3CameraPosition = glm::vec3(0.5f, 1.0f, 4.0f);
    return c;
}

TEST_F(Llvmpipe, PnDefaultsEqualTheShadersInitializers) {
    GlCase c = pn_case("pn defaults");
    c.set_uniforms = [](GLuint program, const ShadingModel& m) {
        uniform3(program, "v3CameraPosition", m.pn.v3CameraPosition);
    };
    expect_matches_llvmpipe(c, 8);
}

TEST_F(Llvmpipe, PnCustomUniforms) {
    GlCase c = pn_case("pn custom");
    c.model.pn.v3LightDirection = glm::vec3(-0.3f, 0.5f, 0.8f);
    c.model.pn.v3DiffuseColour = glm::vec3(0.2f, 0.7f, 0.4f);
    c.model.pn.fShininess = 90.0f;
    c.set_uniforms = [](GLuint program, const ShadingModel& m) {
        uniform3(program, "v3CameraPosition", m.pn.v3CameraPosition);
        uniform3(program, "v3LightDirection", m.pn.v3LightDirection);
        uniform3(program, "v3DiffuseColour", m.pn.v3DiffuseColour);
        uniform1(program, "fShininess", m.pn.fShininess);
    };
    expect_matches_llvmpipe(c, 9);
}

}  // namespace
