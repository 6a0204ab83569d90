// tests/extremes/extremes.h — what the extremes suite (issue 10, tests/extremes/) shares: a
// scratch directory per test (CommandDirTest), terrain scenes written as TOML text, small
// height maps written in the test, pictures and captures read back, and the analytic view of
// a flat terrain that several cases hold the renderer to.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>
#include <OpenImageIO/imageio.h>

#include "command_dir_test.h"
#include "tessref/capture.h"
#include "tessref/prepare.h"
#include "tessref/render.h"
#include "tessref/scene.h"

namespace tessref::test::extremes {

// A number as TOML reads it back to the same double.
inline std::string num(double v) {
    char text[64];
    std::snprintf(text, sizeof text, "%.17g", v);
    std::string s = text;
    if (s.find_first_of(".en") == std::string::npos) s += ".0";  // an integer would be a TOML integer
    return s;
}
inline std::string vec3(glm::dvec3 v) { return "[" + num(v.x) + ", " + num(v.y) + ", " + num(v.z) + "]"; }

// A terrain scene: a grid of quad patches over a height map, a look-at camera, and the
// stages given as text. Defaults: 2 x 2 patches over [0, 8]^2 of a flat height map, seen
// obliquely from the south, constant level 1.
struct Terrain {
    std::string plane = "xy";
    int nu = 2, nv = 2;
    double u0 = 0.0, u1 = 8.0;  // x
    double v0 = 0.0, v1 = 8.0;  // y (plane xy) or z (plane xz)
    std::string heightmap = "flat.pgm";
    double scale_xy = 8.0;      // thesis and lab 4 only (cosc422 maps the extent)
    double scale_z = 2.0;
    std::string domain_keys;    // further [domain] lines, e.g. "nodata_policy = ..."
    glm::dvec3 eye{4.0, -6.0, 8.0};
    glm::dvec3 center{4.0, 4.0, 0.0};
    glm::dvec3 up{0.0, 0.0, 1.0};
    double fov_y = 45.0;
    int width = 160, height = 100;
    double near_plane = 1.0, far_plane = 100.0;
    std::string spacing = "fractional_odd";
    std::string control = "model = \"constant\"\nlevel = 1.0";  // the body of [control]
    std::string evaluation = "thesis";
    std::string tables;  // further tables, e.g. "[shading]\nmodel = \"flat\"\n"

    std::string toml() const {
        const bool xy = plane == "xy";
        std::string t = "[scene]\nname = \"extreme\"\n[domain]\nplane = \"" + plane + "\"\n";
        t += "patches = [" + std::to_string(nu) + ", " + std::to_string(nv) + "]\n";
        t += "x = [" + num(u0) + ", " + num(u1) + "]\n";
        t += std::string(xy ? "y" : "z") + " = [" + num(v0) + ", " + num(v1) + "]\n";
        t += "heightmap = \"" + heightmap + "\"\n";
        if (evaluation != "cosc422") t += "scale_xy = " + num(scale_xy) + "\n";
        t += "scale_z = " + num(scale_z) + "\n" + domain_keys;
        t += "[camera]\neye = " + vec3(eye) + "\ncenter = " + vec3(center) + "\nup = " + vec3(up) + "\n";
        t += "fov_y = " + num(fov_y) + "\nviewport = [" + std::to_string(width) + ", " + std::to_string(height) +
             "]\nnear = " + num(near_plane) + "\nfar = " + num(far_plane) + "\n";
        t += "[generator]\ndomain = \"quads\"\nspacing = \"" + spacing + "\"\n";
        t += "[control]\n" + control + "\n";
        t += "[evaluation]\nmodel = \"" + evaluation + "\"\n";
        return t + tables;
    }
};

// A plain PGM (P2): one code per sample, row 0 first. maxval 255 gives an 8-bit map, 65535 a
// 16-bit one (codes up to 32768 only: OpenImageIO 2.4.7 reads larger 16-bit PNM codes one low,
// docs/LIMITS.md, "Known limits of the dependencies").
inline void write_pgm(const std::filesystem::path& path, int width, int height, int maxval,
                      const std::vector<int>& codes) {
    std::string text = "P2\n" + std::to_string(width) + " " + std::to_string(height) + "\n" + std::to_string(maxval) + "\n";
    for (std::size_t i = 0; i < codes.size(); ++i) text += std::to_string(codes[i]) + ((i + 1) % width ? " " : "\n");
    write_file(path, text);
}
inline void write_flat_pgm(const std::filesystem::path& path, int code = 100) {
    write_pgm(path, 4, 4, 255, std::vector<int>(16, code));
}

// A picture read through OpenImageIO as float RGBA (row 0 on top).
struct Picture {
    int width = 0, height = 0, channels = 0;
    std::vector<float> pixels;
    float at(int x, int y, int c) const {
        return pixels[(static_cast<std::size_t>(y) * width + x) * channels + c];
    }
    // Covered: the fragment stage wrote the pixel (its alpha is 1; the background is
    // GL's default clear colour, transparent black).
    std::vector<bool> mask() const {
        std::vector<bool> m(static_cast<std::size_t>(width) * height);
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x) m[static_cast<std::size_t>(y) * width + x] = at(x, y, channels - 1) > 0.0f;
        return m;
    }
};
inline Picture read_picture(const std::filesystem::path& path) {
    Picture p;
    auto in = OIIO::ImageInput::open(path.string());
    if (!in) {
        ADD_FAILURE() << "cannot open " << path << ": " << OIIO::geterror();
        return p;
    }
    p.width = in->spec().width;
    p.height = in->spec().height;
    p.channels = in->spec().nchannels;
    p.pixels.resize(static_cast<std::size_t>(p.width) * p.height * p.channels);
    EXPECT_TRUE(in->read_image(0, 0, 0, p.channels, OIIO::TypeDesc::FLOAT, p.pixels.data()));
    in->close();
    return p;
}

// Pixels where a CPU render, as its 8-bit file would hold it (to_rgba8), and a picture file
// differ by more than `codes` in some channel; -1 when the sizes differ.
inline long pixels_differing(const Picture& file, const tessref::RenderResult& image, int codes = 0) {
    const std::vector<std::uint8_t> rgba = tessref::to_rgba8(image);
    if (file.channels != 4 || file.pixels.size() != rgba.size()) return -1;
    long n = 0;
    for (std::size_t i = 0; i < rgba.size(); i += 4) {
        bool differs = false;
        for (std::size_t c = 0; c < 4; ++c) differs |= std::abs(std::lround(file.pixels[i + c] * 255.0f) - rgba[i + c]) > codes;
        n += differs;
    }
    return n;
}

// Pixels with a visible surface in a render (rasterized or ray-traced).
inline std::vector<bool> covered(const tessref::RenderResult& r) {
    std::vector<bool> m(r.triangle_id.size());
    for (std::size_t i = 0; i < m.size(); ++i) m[i] = r.triangle_id[i] != tessref::kNoPixelId;
    return m;
}
inline std::size_t count(const std::vector<bool>& m) {
    std::size_t n = 0;
    for (bool b : m) n += b;
    return n;
}
inline std::size_t count_different(const std::vector<bool>& a, const std::vector<bool>& b) {
    EXPECT_EQ(a.size(), b.size());
    std::size_t n = 0;
    for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i) n += a[i] != b[i];
    return n;
}

// Triangles per patch id of a capture (mesh --capture, gl --capture).
inline std::map<std::uint32_t, std::size_t> triangles_per_patch(const tessref::Capture& c) {
    std::map<std::uint32_t, std::size_t> n;
    for (std::size_t i = 0; i < c.vertices.size(); i += 3) ++n[c.vertices[i].patch_id];
    return n;
}

// The analytic view of the plane z = h (plane xy) through a camera: the segment between a
// window point's places on the near and on the far plane (the inverse of the camera's
// projection * view in double, as glm::unProject, not the renderer's code) meets the plane,
// or not. Window coordinates are GL's (y up).
struct PlaneHit {
    bool hit = false;  // between the near and the far plane
    glm::dvec3 point{0.0};
    double t = 0.0;    // 0 on the near plane, 1 on the far plane
};
class PlaneView {
public:
    PlaneView(const tessref::SceneCamera& camera, double h)
        : camera_(camera), h_(h), inverse_(glm::inverse(camera.projection() * camera.view())) {}

    PlaneHit hit(double wx, double wy) const {
        const glm::dvec3 a = unproject(wx, wy, -1.0), b = unproject(wx, wy, 1.0);
        PlaneHit r;
        r.t = (h_ - a.z) / (b.z - a.z);
        r.hit = r.t >= 0.0 && r.t <= 1.0;
        r.point = a + r.t * (b - a);
        return r;
    }
    // Whether GL draws pixel (x, row) (row 0 on top) of the square terrain [lo, hi]^2 flat at
    // height h: its centre sees the plane between the near and far planes inside the square.
    // std::nullopt when points 1/16 pixel away from the centre disagree: the pixel lies on an
    // edge of the visible region, where snapping and float rounding decide.
    std::optional<bool> coverage(double lo, double hi, int x, int row) const {
        const double wx = x + 0.5, wy = camera_.viewport.y - 1 - row + 0.5;
        std::optional<bool> answer;
        for (const glm::dvec2 d : {glm::dvec2(0, 0), glm::dvec2(-1, 0), glm::dvec2(1, 0), glm::dvec2(0, -1), glm::dvec2(0, 1)}) {
            const PlaneHit p = hit(wx + d.x / 16.0, wy + d.y / 16.0);
            const bool in = p.hit && p.point.x > lo && p.point.x < hi && p.point.y > lo && p.point.y < hi;
            if (answer && *answer != in) return std::nullopt;
            answer = in;
        }
        return answer;
    }

private:
    glm::dvec3 unproject(double wx, double wy, double ndc_z) const {
        const glm::dvec4 p = inverse_ * glm::dvec4(2.0 * wx / camera_.viewport.x - 1.0, 2.0 * wy / camera_.viewport.y - 1.0,
                                                   ndc_z, 1.0);
        return glm::dvec3(p) / p.w;
    }
    tessref::SceneCamera camera_;
    double h_;
    glm::dmat4 inverse_;
};

// The fixture of the suite: a fresh directory per test (CommandDirTest) holding the scene
// (scene.toml) and its files, tessref run inside it so scenes name their files relatively.
class ExtremesTest : public CommandDirTest {
protected:
    RunResult run(const std::vector<std::string>& args) { return run_program(TESSREF_EXE, args, dir_, dir_); }
    void write_scene(const Terrain& t) { write_file(dir_ / "scene.toml", t.toml()); }
    // The same scene parsed in this process (the file need not exist: paths resolve from it).
    tessref::Scene load(const Terrain& t) { return tessref::load_scene_from_string(t.toml(), path("scene.toml")); }
};

}  // namespace tessref::test::extremes
