// The geometry stage (tessref/geometry.h): plane normals exact, the thesis's normal-map
// decode (quirk included), lab 4's appendix-A normal on height fields with a known
// gradient, and area-weighted smooth vertex normals on a hand-computed example.
#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "tessref/geometry.h"

namespace {

using namespace tessref;

TEST(FaceNormal, AxisAlignedPlanesAreExact) {
    EXPECT_EQ(face_normal(glm::vec3(0, 0, 0), glm::vec3(1, 0, 0), glm::vec3(0, 1, 0)), glm::vec3(0, 0, 1));
    EXPECT_EQ(face_normal(glm::vec3(0, 0, 0), glm::vec3(0, 1, 0), glm::vec3(1, 0, 0)), glm::vec3(0, 0, -1));
    // y up, counter-clockwise seen from above: +y.
    EXPECT_EQ(face_normal(glm::dvec3(3, 2, 1), glm::dvec3(3, 2, 5), glm::dvec3(7, 2, 1)), glm::dvec3(0, 1, 0));
    // A large, off-origin triangle in the plane x = 5.
    EXPECT_EQ(face_normal(glm::dvec3(5, 100, 200), glm::dvec3(5, 300, 200), glm::dvec3(5, 100, 900)),
              glm::dvec3(1, 0, 0));
}

TEST(FaceNormal, TiltedPlane) {
    // The plane x + y + z = 1 through its axis points: normal (1,1,1)/sqrt(3).
    const glm::dvec3 n = face_normal(glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1));
    const double k = 1 / std::sqrt(3.0);
    EXPECT_NEAR(n.x, k, 1e-15);
    EXPECT_NEAR(n.y, k, 1e-15);
    EXPECT_NEAR(n.z, k, 1e-15);
}

TEST(ThesisGeometry, NormalFromTextureWithNormalMatrix) {
    EXPECT_EQ(thesis_normal_from_texture(glm::vec3(0.5f, 0.5f, 1.0f), glm::mat3(1.0f)), glm::vec3(0, 0, 1));
    // Quirk kept: normalMatrix is applied after normalize, a scale survives.
    EXPECT_EQ(thesis_normal_from_texture(glm::vec3(0.5f, 0.5f, 1.0f), glm::mat3(2.0f)), glm::vec3(0, 0, 2));
    // (0.75, 0.5, 0.6875) - 0.5 = (0.25, 0, 0.1875) -> (0.8, 0, 0.6); a 90-degree turn
    // about z maps it to (0, 0.8, 0.6).
    const glm::dmat3 turn(glm::dvec3(0, 1, 0), glm::dvec3(-1, 0, 0), glm::dvec3(0, 0, 1));
    const glm::dvec3 n = thesis_normal_from_texture(glm::dvec3(0.75, 0.5, 0.6875), turn);
    EXPECT_NEAR(n.x, 0.0, 1e-15);
    EXPECT_NEAR(n.y, 0.8, 1e-15);
    EXPECT_NEAR(n.z, 0.6, 1e-15);
}

// The batch is the scalar function at every texel, bit for bit (alpha ignored), with a
// normal matrix that is not the identity: every unorm8 code triple of a coarse lattice, the
// zero vector (NaN) and values outside [0, 1].
TEST(ThesisGeometry, BatchedNormalsAreTheScalarOnesBitForBit) {
    std::vector<glm::vec4> texels;
    for (int r = 0; r < 256; r += 15)
        for (int g = 0; g < 256; g += 17)
            for (int b = 0; b < 256; b += 13)
                texels.emplace_back(r / 255.0f, g / 255.0f, b / 255.0f, (r + g) / 511.0f);
    texels.emplace_back(0.5f, 0.5f, 0.5f, 1.0f);
    texels.emplace_back(-3.0f, 7.5f, 1e-20f, 0.0f);
    // The same specials among the first (the batch takes four texels at a time, the last one
    // to three alone): a zero vector (0 * inf), infinities, underflowing squares, a huge one.
    const float inf = std::numeric_limits<float>::infinity();
    texels.insert(texels.begin(), {glm::vec4(0.5f, 0.5f, 0.5f, 1.0f), glm::vec4(-3.0f, 7.5f, 1e-20f, 0.0f),
                                   glm::vec4(inf, 0.5f, 0.25f, 0.0f), glm::vec4(0.5f, 0.5f + 1e-7f, 0.5f, 1.0f),
                                   glm::vec4(1e30f, -1e30f, 0.0f, 0.0f), glm::vec4(-inf, inf, 0.5f, 0.0f),
                                   glm::vec4(0.5f, 0.5f, 0.5f - 6e-8f, 1.0f)});
    const glm::mat3 normalMatrix(glm::vec3(0.8f, 0.1f, -0.3f), glm::vec3(-0.2f, 0.9f, 0.05f), glm::vec3(0.3f, 0.0f, 1.1f));
    for (const glm::mat3& matrix : {normalMatrix, glm::mat3(1.0f)}) {
        for (const std::size_t count : std::array<std::size_t, 6>{texels.size(), 0, 1, 3, 4, 7}) {
            std::vector<glm::vec3> normals(count);
            thesis_normals_from_texture<float>(std::span<const glm::vec4>(texels).first(count), matrix, normals);
            for (std::size_t k = 0; k < count; ++k) {
                const glm::vec3 expected = thesis_normal_from_texture(glm::vec3(texels[k]), matrix);
                for (int c = 0; c < 3; ++c)
                    EXPECT_EQ(std::bit_cast<std::uint32_t>(normals[k][c]), std::bit_cast<std::uint32_t>(expected[c]))
                        << k;
            }
        }
    }
}

TEST(ThesisGeometry, OneNormalPerVertexFromTheMap) {
    std::vector<glm::vec2> seen;
    const Sampler2D<float> normalMap = [&](glm::vec2 uv) {
        seen.push_back(uv);
        return uv.x < 0.5f ? glm::vec4(0.5f, 0.5f, 1.0f, 1.0f) : glm::vec4(0.5f, 1.0f, 0.5f, 1.0f);
    };
    const std::array<glm::vec3, 3> normals = thesis_geometry(
        std::array<glm::vec2, 3>{glm::vec2(0.1f, 0.2f), glm::vec2(0.7f, 0.2f), glm::vec2(0.3f, 0.9f)},
        normalMap, glm::mat3(1.0f));
    ASSERT_EQ(seen.size(), 3u);
    EXPECT_EQ(seen[1], glm::vec2(0.7f, 0.2f));
    EXPECT_EQ(normals[0], glm::vec3(0, 0, 1));
    EXPECT_EQ(normals[1], glm::vec3(0, 1, 0));
    EXPECT_EQ(normals[2], glm::vec3(0, 0, 1));
}

TEST(SmoothNormals, AreaWeightingOnAHandExample) {
    // Vertex 0 (the origin) is in two triangles:
    //  T1 (0,0,0) (1,0,0) (0,1,0): cross = (0,0,1), area 0.5, normal +z;
    //  T2 (0,0,0) (0,2,0) (0,0,3): cross = (6,0,0), area 3, normal +x.
    // Area-weighted: normalize(0.5 * 2 * z + 3 * 2 * x) = (6, 0, 1) / sqrt(37).
    const std::vector<glm::dvec3> positions{glm::dvec3(0, 0, 0), glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0),
                                            glm::dvec3(0, 2, 0), glm::dvec3(0, 0, 3)};
    const std::vector<std::array<std::uint32_t, 3>> triangles{{0, 1, 2}, {0, 3, 4}};
    const std::vector<glm::dvec3> normals =
        smooth_vertex_normals<double>(positions, triangles, Weld::by_index);
    ASSERT_EQ(normals.size(), 5u);
    const double k = 1 / std::sqrt(37.0);
    EXPECT_NEAR(normals[0].x, 6 * k, 1e-15);
    EXPECT_EQ(normals[0].y, 0.0);
    EXPECT_NEAR(normals[0].z, k, 1e-15);
    EXPECT_EQ(normals[1], glm::dvec3(0, 0, 1));
    EXPECT_EQ(normals[3], glm::dvec3(1, 0, 0));
    // An unweighted average would give (1, 0, 1) / sqrt(2): the weighting matters here.
    EXPECT_GT(std::abs(normals[0].x - std::sqrt(0.5)), 0.1);
}

TEST(SmoothNormals, WeldByPositionSharesTheSumAcrossCopies) {
    // The same two triangles with the origin emitted twice (as two patches would): by index
    // each copy sees only its own triangle; by position both get the weighted sum.
    const std::vector<glm::vec3> positions{glm::vec3(0, 0, 0), glm::vec3(1, 0, 0), glm::vec3(0, 1, 0),
                                           glm::vec3(0, 0, 0), glm::vec3(0, 2, 0), glm::vec3(0, 0, 3)};
    const std::vector<std::array<std::uint32_t, 3>> triangles{{0, 1, 2}, {3, 4, 5}};
    const std::vector<glm::vec3> by_index = smooth_vertex_normals<float>(positions, triangles, Weld::by_index);
    EXPECT_EQ(by_index[0], glm::vec3(0, 0, 1));
    EXPECT_EQ(by_index[3], glm::vec3(1, 0, 0));
    const std::vector<glm::vec3> by_position = smooth_vertex_normals<float>(positions, triangles);
    EXPECT_EQ(by_position[0], by_position[3]);
    EXPECT_NEAR(by_position[0].x, 6 / std::sqrt(37.0f), 1e-6f);
    // -0 is not +0: welding is by bits, so a copy at (-0, 0, 0) stays apart.
    std::vector<glm::vec3> signed_zero = positions;
    signed_zero[3] = glm::vec3(-0.0f, 0, 0);
    EXPECT_EQ(smooth_vertex_normals<float>(signed_zero, triangles)[3], glm::vec3(1, 0, 0));
}

TEST(SmoothNormals, FlatGridGivesThePlaneNormalExactly) {
    // A 4x4-vertex grid in z = 1.5 with triangles of different areas (uneven spacing).
    const std::array<float, 4> xs{0, 1, 3, 3.5f}, ys{-2, 0, 0.25f, 4};
    std::vector<glm::vec3> positions;
    for (float y : ys) {
        for (float x : xs) positions.emplace_back(x, y, 1.5f);
    }
    std::vector<std::array<std::uint32_t, 3>> triangles;
    for (std::uint32_t j = 0; j < 3; ++j) {
        for (std::uint32_t i = 0; i < 3; ++i) {
            const std::uint32_t a = j * 4 + i, b = a + 1, c = a + 4, d = a + 5;
            triangles.push_back({a, b, d});
            triangles.push_back({a, d, c});
        }
    }
    for (const glm::vec3& n : smooth_vertex_normals<float>(positions, triangles)) EXPECT_EQ(n, glm::vec3(0, 0, 1));
}

TEST(SmoothNormals, UnusedVertexGetsZero) {
    const std::vector<glm::dvec3> positions{glm::dvec3(0), glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(9)};
    const std::vector<std::array<std::uint32_t, 3>> triangles{{0, 1, 2}};
    EXPECT_EQ(smooth_vertex_normals<double>(positions, triangles)[3], glm::dvec3(0));
}

}  // namespace
