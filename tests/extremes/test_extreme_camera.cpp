// Extremes suite (issue 10): what the camera does to a terrain at the edges of what float
// and clipping can take: patches crossing the near plane and lying behind the camera,
// a terrain a million units from the origin, triangles far smaller than a pixel.
//
// Where the expected answers come from:
//  - a flat terrain is the plane z = h: each pixel's view ray meets it (or not) at a point
//    computed in double from the inverse of projection * view (as glm::unProject), not with
//    the renderer's code; GL draws what lies between the near and the far plane (GL 4.6,
//    13.7 primitive clipping), so a pixel is covered exactly when that point lies inside the
//    terrain's extent and between the two planes;
//  - the ray-traced ground truth (render --raytrace, Embree) and llvmpipe (tessref gl) for
//    the same scenes;
//  - translation: the same terrain and camera moved by (1e6, 0, 1e6) show the same picture in
//    exact arithmetic; float's error there is measured and bounded by the arithmetic of
//    float's spacing at 1e6 (2^-4 = 0.0625).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "extremes.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"
#include "tessref/render.h"
#include "tessref/scene.h"
#include "tessref/tessellator.h"

namespace {

using tessref::test::RunResult;
using tessref::test::write_file;
using namespace tessref::test::extremes;

class ExtremeCamera : public ExtremesTest {
protected:
    // llvmpipe's picture of the scene, byte for byte the CPU reference's.
    void expect_llvmpipe_picture(const Terrain& t, const tessref::RenderResult& image) {
        write_scene(t);
        const RunResult r = run({"gl", "scene.toml", "-o", "gl.png"});
        ASSERT_EQ(r.status, 0) << r.err;
        EXPECT_EQ(pixels_differing(read_picture(path("gl.png")), image), 0) << "pixels differ from llvmpipe's picture";
    }
};

// ---- the near plane and what lies behind the camera ------------------------------------

// A flat terrain of 8 x 8 patches over [0, 64]^2 at height 100/255 * 2, with the camera
// standing inside it: the patches around its feet cross the near plane, those behind it have
// w < 0 (unclipped they would project mirrored onto the screen). The picture must be exactly
// the analytic plane between the near and the far plane.
TEST_F(ExtremeCamera, NearPlaneAndBehindTheCameraAreClipped) {
    write_flat_pgm(dir_ / "flat.pgm");
    const double h = 100.0 / 255.0 * 2.0;
    struct View {
        glm::dvec3 eye, center;
        double near_plane;
        const char* what;
    };
    const View views[] = {
        {{32.0, 32.0, 1.5}, {32.0, 40.0, -3.0}, 1.0, "looking down, the ground at the feet inside the near plane"},
        {{32.0, 32.0, 1.5}, {32.0, 40.0, -3.0}, 4.0, "the same with near = 4"},
        {{32.0, 10.0, 0.9}, {32.0, 60.0, 0.9}, 1.0, "eye 0.12 above the ground, looking level"},
        {{-3.0, 32.0, 2.0}, {40.0, 32.0, -20.0}, 1.0, "outside the terrain, looking steeply down at its edge"},
    };
    for (const View& v : views) {
        SCOPED_TRACE(v.what);
        Terrain t;
        t.nu = t.nv = 8;
        t.u1 = t.v1 = 64.0;
        t.scale_xy = 64.0;
        t.eye = v.eye;
        t.center = v.center;
        t.fov_y = 90.0;
        t.width = 320;
        t.height = 200;
        t.near_plane = v.near_plane;
        t.far_plane = 80.0;
        t.control = "model = \"constant\"\nlevel = 5.0";
        const tessref::Scene scene = load(t);
        const tessref::RenderResult image = tessref::render_scene(scene);
        // The ray-traced ground truth must clip at the same planes.
        const tessref::RenderResult truth = tessref::raytrace_scene(scene);
        std::size_t inside = 0, outside = 0, wrong = 0, wrong_truth = 0, compared_depth = 0;
        double worst_depth = 0.0;
        const glm::dvec4 viewport(0, 0, image.width, image.height);
        const PlaneView plane(image.camera, h);
        for (int row = 0; row < image.height; ++row) {
            for (int x = 0; x < image.width; ++x) {
                const std::optional<bool> should = plane.coverage(0.0, 64.0, x, row);
                if (!should) continue;
                const std::size_t i = image.index(x, row);
                const bool is = image.triangle_id[i] != tessref::kNoPixelId;
                (*should ? inside : outside) += 1;
                wrong += is != *should;
                wrong_truth += (truth.triangle_id[i] != tessref::kNoPixelId) != *should;
                if (is && *should) {
                    const PlaneHit hit = plane.hit(x + 0.5, image.height - 1 - row + 0.5);
                    const glm::dvec3 w = glm::project(hit.point, image.camera.view(), image.camera.projection(), viewport);
                    worst_depth = std::max(worst_depth, std::abs(image.depth[i] - w.z));
                    ++compared_depth;
                }
            }
        }
        EXPECT_GT(inside, 3000u);  // the test saw the ground ...
        EXPECT_GT(outside, 5000u);  // ... and the sky or the clipped ground
        EXPECT_EQ(wrong, 0u) << "pixels covered where the plane is not visible, or the reverse";
        // Window depth from float plane equations: a few float ulps of z near 1.
        EXPECT_LT(worst_depth, 1e-5) << compared_depth << " depths compared";
        EXPECT_EQ(wrong_truth, 0u) << "the ray-traced picture disagrees with the analytic plane";
        expect_llvmpipe_picture(t, image);
        // Clipped lines too: the wireframe is llvmpipe's.
        if (v.near_plane == 1.0 && v.eye.z == 1.5) {
            const RunResult r = run({"gl", "scene.toml", "--wireframe", "-o", "wire.png"});
            ASSERT_EQ(r.status, 0) << r.err;
            tessref::RenderOptions wire;
            wire.mode = tessref::RenderMode::wireframe;
            EXPECT_EQ(pixels_differing(read_picture(path("wire.png")), tessref::render_scene(scene, wire)), 0);
        }
    }
}

// ---- a terrain a million units from the origin -------------------------------------------

// The COSC422 evaluation maps the height map over the terrain's own extent, so the same
// 64 x 64 terrain can stand at the origin or at (1e6, 0, 1e6) with the same heights.
Terrain hills(double offset) {
    Terrain t;
    t.plane = "xz";
    t.evaluation = "cosc422";
    t.heightmap = "hills.pgm";
    t.nu = t.nv = 8;
    t.u0 = offset;
    t.u1 = offset + 64.0;
    t.v0 = offset;
    t.v1 = offset - 64.0;
    t.scale_z = 8.0;
    t.eye = {offset + 32.0, 30.0, offset + 20.0};
    t.center = {offset + 32.0, 0.0, offset - 32.0};
    t.up = {0.0, 1.0, 0.0};
    t.fov_y = 60.0;
    t.width = 320;
    t.height = 200;
    t.far_plane = 200.0;
    t.spacing = "equal";
    t.control = "model = \"constant\"\nlevel = 7.0";  // points at k/7: not float-exact at 1e6
    return t;
}

// Hills of 64 x 64 8-bit samples; returns the largest step between neighbouring samples.
int write_hills(const std::filesystem::path& file) {
    std::vector<int> codes(64 * 64);
    for (int j = 0; j < 64; ++j)
        for (int i = 0; i < 64; ++i)
            codes[j * 64 + i] = static_cast<int>(127.0 + 100.0 * std::sin(i * 0.3) * std::cos(j * 0.2));
    int steepest = 0;
    for (int j = 0; j < 64; ++j)
        for (int i = 0; i + 1 < 64; ++i) {
            steepest = std::max(steepest, std::abs(codes[j * 64 + i + 1] - codes[j * 64 + i]));
            steepest = std::max(steepest, std::abs(codes[(i + 1) * 64 + j] - codes[i * 64 + j]));
        }
    write_pgm(file, 64, 64, 255, codes);
    return steepest;
}

// What float does to a terrain 1e6 units from the origin, measured (the test prints the
// numbers) and held to bounds from float's arithmetic, so the error cannot grow unnoticed.
// This is the error without camera-relative evaluation (PipelineOptions::camera_relative),
// which removes it: CameraRelativeEvaluationRemovesTheFarTerrainsFloatError below.
// Measured on this code: x, z of gpu positions 0.0269 from the same terrain at the origin
// moved by 1e6 (bound: half of float's spacing 0.0625 at 1e6); heights 0.0627 (two 8-bit
// codes: the texture coordinate moves by 0.0269 / 64 and llvmpipe's 8-bit filter rounds each
// lerp to a code); picture against the origin's: 129 of 26918 pixels change coverage, window
// depth of pixels showing the same triangle moves by up to 0.00167 (gl_Position = mvp *
// position in float cancels terms of about 1e6 down to about 50). With gl_Position summed in
// the shader's order (see TerrainFarFromTheOriginMatchesLlvmpipe): 141 pixels and 0.00204.
TEST_F(ExtremeCamera, TerrainFarFromTheOriginHasBoundedFloatError) {
    const int steepest = write_hills(dir_ / "hills.pgm");
    const double slope = steepest / 255.0 * 8.0;  // height per world unit (one texel per unit)
    const double code = 8.0 / 255.0;              // one 8-bit code of height
    const double offset = 1e6;
    const double half_spacing = 0.03125;          // float's spacing in [2^19, 2^20) is 2^-4

    const tessref::Scene near_scene = load(hills(0.0)), far_scene = load(hills(offset));
    tessref::PipelineOptions exact_options;
    exact_options.precision = tessref::Precision::exact;
    const tessref::PipelineResult near_gpu = tessref::run_pipeline(near_scene);
    const tessref::PipelineResult far_gpu = tessref::run_pipeline(far_scene);
    const tessref::PipelineResult near_exact = tessref::run_pipeline(near_scene, exact_options);
    const tessref::PipelineResult far_exact = tessref::run_pipeline(far_scene, exact_options);
    // The largest |difference| per axis of corresponding vertices (same topology), b moved by `shift`.
    auto largest = [](const tessref::PipelineResult& a, const tessref::PipelineResult& b, double shift) {
        glm::dvec3 e(0.0);
        EXPECT_EQ(a.mesh.positions.size(), b.mesh.positions.size());
        for (std::size_t i = 0; i < std::min(a.mesh.positions.size(), b.mesh.positions.size()); ++i)
            e = glm::max(e, glm::abs(a.mesh.positions[i] - (b.mesh.positions[i] + glm::dvec3(shift, 0.0, shift))));
        return e;
    };
    const glm::dvec3 far_vs_near = largest(far_gpu, near_gpu, offset);
    const glm::dvec3 far_vs_exact = largest(far_gpu, far_exact, 0.0);
    const glm::dvec3 near_vs_exact = largest(near_gpu, near_exact, 0.0);  // 16.16 tess coords, 8-bit filter

    // The pictures: the far terrain against the same view at the origin, pixel by pixel; depth
    // where both show the same triangle (elsewhere a silhouette moved, not a surface).
    const tessref::RenderResult near_image = tessref::render_scene(near_scene);
    const tessref::RenderResult far_image = tessref::render_scene(far_scene);
    const std::size_t moved = count_different(covered(near_image), covered(far_image));
    double depth_moved = 0.0;
    for (std::size_t i = 0; i < near_image.depth.size(); ++i)
        if (near_image.triangle_id[i] != tessref::kNoPixelId && near_image.triangle_id[i] == far_image.triangle_id[i])
            depth_moved = std::max(depth_moved, static_cast<double>(std::abs(near_image.depth[i] - far_image.depth[i])));
    std::printf("terrain at 1e6: gpu positions against the origin's moved by 1e6: x %.6g y %.6g z %.6g; against exact: "
                "x %.6g y %.6g z %.6g (at the origin %.3g %.3g %.3g); picture against the origin's: %zu of %zu pixels "
                "change coverage, window depth of the same triangle up to %.4g\n",
                far_vs_near.x, far_vs_near.y, far_vs_near.z, far_vs_exact.x, far_vs_exact.y, far_vs_exact.z,
                near_vs_exact.x, near_vs_exact.y, near_vs_exact.z, moved, count(covered(near_image)), depth_moved);

    // x and z: one rounding of an exact value to float's grid at 1e6 (mix() of exactly
    // representable corners with 16.16 tess coords), against the origin's float (exact to
    // 2^-18 below 64).
    EXPECT_GT(far_vs_near.x, 0.01);  // the error is real ...
    EXPECT_LE(far_vs_near.x, half_spacing + 1e-5);  // ... and bounded
    EXPECT_LE(far_vs_near.z, half_spacing + 1e-5);
    // Height: the texture coordinate (x - x0) / 64 inherits x's error, times the slope, plus
    // one 8-bit code of the filter's rounding on either side.
    EXPECT_LE(far_vs_near.y, half_spacing * slope + 2.0 * code) << "steepest step " << steepest << " codes";
    // Against the double pipeline: the same, on top of what separates them at the origin.
    EXPECT_LE(far_vs_exact.x, half_spacing + near_vs_exact.x);
    EXPECT_LE(far_vs_exact.z, half_spacing + near_vs_exact.z);
    EXPECT_LE(far_vs_exact.y, half_spacing * slope + 2.0 * code + near_vs_exact.y);
    // The picture: measured 129 (141) pixels and 0.00167 (0.00204), bounded at about twice that.
    EXPECT_GT(count(covered(near_image)), 20000u);
    EXPECT_LE(moved, 300u) << "of " << count(covered(near_image)) << " covered pixels";
    EXPECT_LT(depth_moved, 0.004);
}

// Far from the origin the CPU reference must still draw what llvmpipe draws, as it does at
// the origin: the world positions are bit-identical there (tessref compare on the two
// captures passes, 0 ulps), so the pictures may differ only by the few one-code pixels they
// differ by at the origin (6 of 64000 at 320 x 200).
// This failed while src/render/render.cpp computed gl_Position with glm's mat4 * vec4, which
// sums the columns pairwise, (c0 x + c1 y) + (c2 z + c3): at 1e6 12440 pixels differed, 636
// of them by more than one code and 26 by more than five (coverage). The shader's product as
// llvmpipe runs it sums them in order, ((c0 x + c1 y) + c2 z) + c3; at the origin the order
// hardly matters, at 1e6 the terms cancel from 1e6 to about 50 and it decides the low bits.
// Summed in order: 3 pixels differ by one code at 1e6, 2 at the origin.
TEST_F(ExtremeCamera, TerrainFarFromTheOriginMatchesLlvmpipe) {
    write_hills(dir_ / "hills.pgm");
    for (const double offset : {0.0, 1e6}) {
        SCOPED_TRACE("offset " + num(offset));
        const Terrain t = hills(offset);
        write_scene(t);
        const RunResult r = run({"gl", "scene.toml", "-o", "gl.png"});
        ASSERT_EQ(r.status, 0) << r.err;
        const Picture gl = read_picture(path("gl.png"));
        const tessref::RenderResult image = tessref::render_scene(load(t));
        EXPECT_EQ(pixels_differing(gl, image, 1), 0);
        EXPECT_LE(pixels_differing(gl, image, 0), 16);
    }
}

// ---- camera-relative evaluation (PipelineOptions::camera_relative) --------------------------

// The largest |difference| per axis of corresponding vertices (same topology), b moved by `shift`.
glm::dvec3 largest_position_difference(const tessref::PipelineResult& a, const tessref::PipelineResult& b,
                                       double shift) {
    glm::dvec3 e(0.0);
    EXPECT_EQ(a.mesh.positions.size(), b.mesh.positions.size());
    for (std::size_t i = 0; i < std::min(a.mesh.positions.size(), b.mesh.positions.size()); ++i)
        e = glm::max(e, glm::abs(a.mesh.positions[i] - (b.mesh.positions[i] + glm::dvec3(shift, 0.0, shift))));
    return e;
}

// Float ulps between two floats of the same sign (texture coordinates are in [0, 1]).
std::int64_t ulps_apart(float a, float b) {
    std::int32_t ia, ib;
    std::memcpy(&ia, &a, sizeof ia);
    std::memcpy(&ib, &b, sizeof ib);
    return std::abs(static_cast<std::int64_t>(ia) - static_cast<std::int64_t>(ib));
}

// With the evaluation relative to the eye, the terrain at 1e6 is the terrain at the origin:
// the eye stands at the same place relative to both, every shift by -eye is exact in double
// (1e6 and the corners, extent and eye are dyadic numbers of fewer than 53 bits), so the
// eye-relative corners, extent and view-projection are the same floats and the evaluation
// computes the same floats, bit for bit; the world positions (eye + eye-relative, in double)
// differ only by double's rounding at 1e6 (2^-33 per addition: 0 here, the sums are exact),
// and the pictures are identical.
// Against the origin's gpu terrain WITHOUT the option: float's error is now that of
// coordinates of the terrain's size around the eye (|x - eye| < 64, spacing at most 2^-18),
// not of 1e6 (2^-4). Here it is even 0: tess coords are 16.16 fixed point, the corners
// multiples of 8 below 64, so corner + t * 8 needs at most 6 + 13 bits and every mix is
// exact in float on both sides; the texture coordinate (x - eye - (x0 - eye)) / 64 is then
// the origin's (x - x0) / 64 exactly, and so is the height. The bounds below are the general
// ones (a few roundings at 64; the height through the slope, plus one 8-bit code on either
// side of the filter's rounding). The pictures: the origin's multiplies world positions by
// the full mvp, the camera-relative one eye-relative positions by the translation-free mvp,
// both rounded in float at clip coordinates of about 50, so an edge moves by about 1e-5
// pixels and only a pixel centre that close to an edge could change: at most a handful.
// Measured: positions and heights 0 (without the option 0.0269, 0.0627), 0 pixels change
// coverage (without: 141 of 26918); the test prints them.
TEST_F(ExtremeCamera, CameraRelativeEvaluationRemovesTheFarTerrainsFloatError) {
    const int steepest = write_hills(dir_ / "hills.pgm");
    const double slope = steepest / 255.0 * 8.0;
    const double code = 8.0 / 255.0;
    const double offset = 1e6;
    const double ulp64 = std::ldexp(1.0, -18);  // float's spacing in [32, 64)
    const tessref::Scene near_scene = load(hills(0.0)), far_scene = load(hills(offset));
    tessref::PipelineOptions relative_options;
    relative_options.camera_relative = true;
    const tessref::PipelineResult near_gpu = tessref::run_pipeline(near_scene);
    const tessref::PipelineResult far_gpu = tessref::run_pipeline(far_scene);
    const tessref::PipelineResult near_rel = tessref::run_pipeline(near_scene, relative_options);
    const tessref::PipelineResult far_rel = tessref::run_pipeline(far_scene, relative_options);

    // The origin: the eye's ground position (y, the up axis, stays absolute).
    EXPECT_EQ(far_rel.origin, glm::dvec3(offset + 32.0, 0.0, offset + 20.0));
    EXPECT_EQ(near_rel.origin, glm::dvec3(32.0, 0.0, 20.0));
    EXPECT_TRUE(far_gpu.relative_positions.empty());
    EXPECT_EQ(far_gpu.origin, glm::dvec3(0.0));
    // The eye-relative floats are the same, bit for bit; and so are the texture coordinates.
    ASSERT_EQ(far_rel.relative_positions.size(), near_rel.relative_positions.size());
    EXPECT_TRUE(far_rel.relative_positions == near_rel.relative_positions);
    EXPECT_TRUE(far_rel.mesh.uvs == near_rel.mesh.uvs);
    // World positions: eye + eye-relative in double.
    for (std::size_t v = 0; v < far_rel.mesh.positions.size(); v += 97)
        EXPECT_EQ(far_rel.mesh.positions[v], far_rel.origin + glm::dvec3(far_rel.relative_positions[v]));
    const glm::dvec3 rel_vs_rel = largest_position_difference(far_rel, near_rel, offset);
    const glm::dvec3 without = largest_position_difference(far_gpu, near_gpu, offset);
    const glm::dvec3 with = largest_position_difference(far_rel, near_gpu, offset);

    const tessref::RenderResult near_image = tessref::render_scene(near_scene);
    const tessref::RenderResult far_image = tessref::render_scene(far_scene);
    tessref::RenderOptions relative_render;
    relative_render.camera_relative = true;
    const tessref::RenderResult near_rel_image = tessref::render_scene(near_scene, relative_render);
    const tessref::RenderResult far_rel_image = tessref::render_scene(far_scene, relative_render);
    const std::size_t moved_without = count_different(covered(near_image), covered(far_image));
    const std::size_t moved_with = count_different(covered(near_image), covered(far_rel_image));
    std::size_t colour_differs = 0;
    for (std::size_t i = 0; i < far_rel_image.colour.size(); ++i) colour_differs += far_rel_image.colour[i] != near_rel_image.colour[i];
    std::printf("terrain at 1e6, gpu positions against the origin's (gpu, no option) moved by 1e6: without "
                "camera_relative x %.6g y %.6g z %.6g, with x %.6g y %.6g z %.6g; camera-relative at 1e6 against "
                "camera-relative at the origin x %.3g y %.3g z %.3g; pixels changing coverage against the origin's "
                "picture: without %zu, with %zu (of %zu); camera-relative pictures at 1e6 and at the origin: %zu "
                "pixels differ\n",
                without.x, without.y, without.z, with.x, with.y, with.z, rel_vs_rel.x, rel_vs_rel.y, rel_vs_rel.z,
                moved_without, moved_with, count(covered(near_image)), colour_differs);

    const double double_rounding = std::ldexp(1.0, -33);  // double's spacing at 1e6, one rounding each side
    EXPECT_LE(rel_vs_rel.x, double_rounding);
    EXPECT_LE(rel_vs_rel.y, 0.0);
    EXPECT_LE(rel_vs_rel.z, double_rounding);
    EXPECT_GT(without.x, 0.01);  // the option is what makes the difference
    EXPECT_LE(with.x, 4.0 * ulp64);
    EXPECT_LE(with.z, 4.0 * ulp64);
    EXPECT_LE(with.y, 4.0 * ulp64 * slope + 2.0 * code);
    EXPECT_EQ(colour_differs, 0u);
    EXPECT_TRUE(far_rel_image.depth == near_rel_image.depth);
    EXPECT_GT(moved_without, 50u);
    EXPECT_LE(moved_with, 8u) << "of " << count(covered(near_image)) << " covered pixels";
}

// The option moves the evaluation, not the control stage: levels are bit-identical with and
// without it (the control stage reads the world corners either way), for every model's
// distance-based control; texture coordinates are the mesh's own for PN (bit-identical) and
// the shifted mapping's for a terrain: NOT bit-identical in general, because every terrain
// model computes them from the evaluated position (thesis xy / scale_xy, COSC422 the extent,
// lab 4 xz / scale + offset) and that position is now eye-relative; near the origin, where
// these scenes lie, they agree to float rounding (far from it they get better: the first test
// above). Exact precision ignores the option.
TEST_F(ExtremeCamera, CameraRelativeEvaluationKeepsLevelsAndTextureCoordinates) {
    const std::filesystem::path scenes = std::filesystem::path(TESSREF_SOURCE_DIR) / "data" / "scenes";
    tessref::PipelineOptions relative_options;
    relative_options.camera_relative = true;
    for (const char* name : {"cosc422-eye.toml", "thesis-distance-4.toml", "lab4-canyon.toml", "pn-triangles.toml",
                             "thesis-normal-2.toml"}) {
        SCOPED_TRACE(name);
        const tessref::Scene scene = tessref::load_scene((scenes / name).string());
        const tessref::PipelineResult off = tessref::run_pipeline(scene);
        const tessref::PipelineResult on = tessref::run_pipeline(scene, relative_options);
        EXPECT_NE(on.origin, glm::dvec3(0.0));
        ASSERT_EQ(off.levels.size(), on.levels.size());
        for (std::size_t p = 0; p < off.levels.size(); ++p) {
            EXPECT_EQ(tessref::level_bits(off.levels[p]), tessref::level_bits(on.levels[p])) << "patch " << p;
            if (HasFailure()) break;
        }
        ASSERT_EQ(off.mesh.uvs.size(), on.mesh.uvs.size());
        std::int64_t worst_ulps = 0;
        double worst_uv = 0.0;
        for (std::size_t v = 0; v < off.mesh.uvs.size(); ++v)
            for (int c = 0; c < 2; ++c) {
                worst_ulps = std::max(worst_ulps, ulps_apart(static_cast<float>(off.mesh.uvs[v][c]),
                                                             static_cast<float>(on.mesh.uvs[v][c])));
                worst_uv = std::max(worst_uv, std::abs(off.mesh.uvs[v][c] - on.mesh.uvs[v][c]));
            }
        const glm::dvec3 moved = largest_position_difference(on, off, 0.0);
        std::printf("%s: camera_relative moves texture coordinates by up to %lld float ulps (%.3g), positions by "
                    "x %.3g y %.3g z %.3g\n",
                    name, static_cast<long long>(worst_ulps), worst_uv, moved.x, moved.y, moved.z);
        // PN: the mesh's attributes. A terrain: its coordinate moves by a rounding at the
        // terrain's size (cosc422-eye: z 7.6e-6 = 2^-17, |z| < 128), over the extent (100) below
        // 2^-23, plus the texture coordinate's own rounding (2^-24 below 1). Measured: 0
        // for the thesis and lab 4 scenes (power-of-two scales, eyes on float-exact
        // positions), 1.19e-7 = 2^-23 for cosc422-eye.
        if (!scene.grid) EXPECT_EQ(worst_ulps, 0);
        else EXPECT_LE(worst_uv, std::ldexp(1.0, -22));
        // Exact precision: the option does nothing.
        tessref::PipelineOptions exact_off, exact_on = relative_options;
        exact_off.precision = exact_on.precision = tessref::Precision::exact;
        const tessref::PipelineResult e_off = tessref::run_pipeline(scene, exact_off);
        const tessref::PipelineResult e_on = tessref::run_pipeline(scene, exact_on);
        EXPECT_EQ(e_on.origin, glm::dvec3(0.0));
        EXPECT_TRUE(e_on.mesh.positions == e_off.mesh.positions);
        EXPECT_TRUE(e_on.mesh.uvs == e_off.mesh.uvs);
    }
}

// `tessref gl` refuses the option (its GLSL twins map world positions to texture
// coordinates); render and mesh take it.
TEST_F(ExtremeCamera, CameraRelativeFlagIsTheCpuReferencesOnly) {
    write_hills(dir_ / "hills.pgm");
    write_scene(hills(1e6));
    const RunResult gl = run({"gl", "scene.toml", "-o", "gl.png", "--camera-relative"});
    EXPECT_EQ(gl.status, 2);
    EXPECT_NE(gl.err.find("--camera-relative"), std::string::npos) << gl.err;
    EXPECT_FALSE(std::filesystem::exists(path("gl.png")));
    const RunResult render = run({"render", "scene.toml", "-o", "cpu.png", "--camera-relative"});
    EXPECT_EQ(render.status, 0) << render.err;
    tessref::RenderOptions relative_render;
    relative_render.camera_relative = true;
    EXPECT_EQ(pixels_differing(read_picture(path("cpu.png")), tessref::render_scene(load(hills(1e6)), relative_render)),
              0);
    const RunResult mesh = run({"mesh", "scene.toml", "-o", "m.ply", "--camera-relative"});
    EXPECT_EQ(mesh.status, 0) << mesh.err;
}

// ---- triangles far smaller than a pixel ----------------------------------------------------

// One 1 x 1 patch seen from 150 units straight above with a 30 degree field of view at
// 320 x 200: it spans about 2.5 pixels, so at level 64 its triangles are about 1/25 pixel
// across. The union of the triangles is the square whatever the level, so the same pixel
// centres are covered as at level 1 and as the projected square's analytic rectangle holds,
// and each covered pixel is drawn exactly once (a triangle that snapping to 1/256 pixel
// turned over would draw a pixel twice).
TEST_F(ExtremeCamera, SubPixelTrianglesCoverTheirPatchOnce) {
    write_flat_pgm(dir_ / "flat.pgm");
    Terrain t;
    t.nu = t.nv = 1;
    t.u1 = t.v1 = 1.0;
    t.scale_xy = 1.0;
    t.scale_z = 1.0;
    t.eye = {0.3, 0.4, 150.0};
    t.center = {0.3, 0.4, 0.0};
    t.up = {0.0, 1.0, 0.0};
    t.fov_y = 30.0;
    t.width = 320;
    t.height = 200;
    t.far_plane = 1000.0;
    t.tables = "[shading]\nmodel = \"flat\"\n";
    const double h = 100.0 / 255.0;

    // The analytic rectangle: the square's corners projected (in double), pixel centres inside.
    const tessref::Scene probe = load(t);
    const tessref::SceneCamera& cam = *probe.camera;
    const glm::dvec4 vp(0, 0, cam.viewport.x, cam.viewport.y);
    const glm::dvec3 a = glm::project(glm::dvec3(0.0, 0.0, h), cam.view(), cam.projection(), vp);
    const glm::dvec3 b = glm::project(glm::dvec3(1.0, 1.0, h), cam.view(), cam.projection(), vp);
    std::vector<bool> analytic(static_cast<std::size_t>(t.width) * t.height, false);
    for (int row = 0; row < t.height; ++row)
        for (int x = 0; x < t.width; ++x) {
            const double wx = x + 0.5, wy = t.height - 1 - row + 0.5;
            analytic[static_cast<std::size_t>(row) * t.width + x] = wx > std::min(a.x, b.x) && wx < std::max(a.x, b.x) &&
                                                                    wy > std::min(a.y, b.y) && wy < std::max(a.y, b.y);
        }
    ASSERT_GE(count(analytic), 4u);

    for (const auto& [level, spacing] : std::vector<std::pair<std::string, std::string>>{
             {"1.0", "equal"}, {"64.0", "equal"}, {"64.0", "fractional_odd"}, {"64.0", "fractional_even"}}) {
        SCOPED_TRACE("level " + level + ", " + spacing);
        t.spacing = spacing;
        t.control = "model = \"constant\"\nlevel = " + level;
        const tessref::RenderResult image = tessref::render_scene(load(t));
        EXPECT_GE(image.stats.triangles, level == "1.0" ? 2u : 7938u);
        EXPECT_EQ(count_different(covered(image), analytic), 0u) << count(covered(image)) << " covered";
        EXPECT_EQ(image.stats.raster.fragments, image.stats.covered_pixels) << "a pixel drawn twice";
        if (level != "1.0") expect_llvmpipe_picture(t, image);
    }
}

}  // namespace
