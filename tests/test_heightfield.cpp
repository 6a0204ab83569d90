// Height fields and textures (tessref/heightfield.h).
//
// Expectations come from hand derivations (texel centres, midpoints, 2x2 boxes of known
// images, analytic plane normals), from the GL specification's bilinear formula evaluated
// independently here in double, from the files this test writes itself, and from the
// independent peer: Mesa llvmpipe through OSMesa (GlPeer suites), whose glGenerateMipmap
// levels and vertex-shader textureLod results the float path must reproduce bit for bit.
#define GL_GLEXT_PROTOTYPES 1
#include <GL/osmesa.h>
#include <GL/gl.h>
#include <GL/glext.h>

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <OpenImageIO/imageio.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "run_program.h"
#include "tessref/error.h"
#include "tessref/heightfield.h"
#include "tessref/limits.h"

namespace fs = std::filesystem;
using tessref::HeightFieldOptions;
using tessref::MinFilter;
using tessref::MipmapRule;
using tessref::NodataPolicy;
using tessref::TexelFormat;
using tessref::Texture;

namespace {

constexpr MipmapRule kRules[] = {MipmapRule::llvmpipe_blit, MipmapRule::mesa_software_box};

// ---- helpers ------------------------------------------------------------------------------

class TempDir {
public:
    TempDir() {
        std::random_device rd;
        path_ = fs::temp_directory_path() /
                ("tessref_test_heightfield_" + std::to_string(rd()) + "_" + std::to_string(rd()));
        fs::create_directories(path_);
    }
    ~TempDir() {
        std::error_code ec;
        fs::remove_all(path_, ec);
    }
    std::string file(const std::string& name) const { return (path_ / name).string(); }

private:
    fs::path path_;
};

// Writes an image with OpenImageIO; data is row-major, top row first.
void write_image(const std::string& path, int width, int height, int channels, OIIO::TypeDesc type,
                 const void* data) {
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out) << OIIO::geterror();
    OIIO::ImageSpec spec(width, height, channels, type);
    // The PNM writer otherwise writes 8 bits whatever the data type.
    if (type == OIIO::TypeDesc::UINT16) spec.attribute("oiio:BitsPerSample", 16);
    // Colour as given, not taken as premultiplied by alpha.
    spec.attribute("oiio:UnassociatedAlpha", 1);
    ASSERT_TRUE(out->open(path, spec)) << out->geterror();
    ASSERT_TRUE(out->write_image(type, data)) << out->geterror();
    ASSERT_TRUE(out->close());
}

void write_bytes(const std::string& path, const std::string& bytes) {
    std::ofstream f(path, std::ios::binary);
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// The GL specification's bilinear sample of one level (clamp to edge), in double, from the
// texels the texture exposes: the independent expectation for textureLod at integer lods.
double spec_bilinear(const Texture& tex, int lod, double s, double t, int channel, bool exact) {
    const int w = tex.level(lod).width;
    const int h = tex.level(lod).height;
    const double u = s * w - 0.5;
    const double v = t * h - 0.5;
    const int i0 = static_cast<int>(std::floor(u));
    const int j0 = static_cast<int>(std::floor(v));
    const double a = u - std::floor(u);
    const double b = v - std::floor(v);
    auto T = [&](int i, int j) {
        i = std::clamp(i, 0, w - 1);
        j = std::clamp(j, 0, h - 1);
        return exact ? tex.texel_exact(lod, i, j, channel) : static_cast<double>(tex.texel(lod, i, j, channel));
    };
    return (1 - a) * (1 - b) * T(i0, j0) + a * (1 - b) * T(i0 + 1, j0) + (1 - a) * b * T(i0, j0 + 1) +
           a * b * T(i0 + 1, j0 + 1);
}

std::vector<float> random_floats(std::size_t n, unsigned seed, float lo = -1.0f, float hi = 2.0f) {
    std::mt19937 rng(seed);
    std::vector<float> out(n);
    for (auto& v : out) {
        // 24-bit fractions: exactly representable, no denormals.
        const float unit = std::ldexp(static_cast<float>(rng() & 0xffffff), -24);
        v = lo + unit * (hi - lo);
    }
    return out;
}

template <typename T>
std::vector<T> random_codes(std::size_t n, unsigned seed) {
    std::mt19937 rng(seed);
    std::vector<T> out(n);
    for (auto& v : out) v = static_cast<T>(rng() & std::numeric_limits<T>::max());
    return out;
}

template <typename F>
void expect_error(F&& f, const std::string& file, const std::string& fragment) {
    try {
        f();
        ADD_FAILURE() << "no tessref::Error for " << file;
    } catch (const tessref::Error& e) {
        EXPECT_EQ(e.where().file, file) << e.message();
        EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos)
            << "message \"" << e.what() << "\" lacks \"" << fragment << "\"";
    }
}

// ---- sampling -----------------------------------------------------------------------------

TEST(TextureSampling, TexelCentresReturnTexelsExactly) {
    // Power-of-two sizes: (x + 0.5) / w * w - 0.5 is exactly x, so the weight is exactly 0.
    const int w = 8, h = 4, c = 2;
    const Texture tf = Texture::from_float(w, h, c, random_floats(w * h * c, 1));
    const Texture t8 = Texture::from_unorm8(w, h, c, random_codes<std::uint8_t>(w * h * c, 2));
    const Texture t16 = Texture::from_unorm16(w, h, c, random_codes<std::uint16_t>(w * h * c, 3));
    for (const Texture* tex : {&tf, &t8, &t16}) {
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
                const glm::vec2 st((x + 0.5f) / w, (y + 0.5f) / h);
                const glm::vec4 g = tex->texture(st);
                const glm::dvec4 d = tex->texture(glm::dvec2(st));
                for (int k = 0; k < c; ++k) {
                    EXPECT_EQ(g[k], tex->texel(0, x, y, k)) << to_string(tex->format()) << " " << x << "," << y;
                    EXPECT_EQ(d[k], tex->texel_exact(0, x, y, k)) << to_string(tex->format());
                }
            }
        }
    }
    // Other sizes: s * w need not give x + 0.5 exactly in float (nor does it on a GPU); the
    // sample is the texel up to that rounding. The 8-bit path rounds the coordinate to
    // 1/256 of a texel and is exact again.
    const int ow = 37, oh = 23;
    const Texture of = Texture::from_float(ow, oh, 1, random_floats(ow * oh, 4));
    const Texture o8 = Texture::from_unorm8(ow, oh, 1, random_codes<std::uint8_t>(ow * oh, 5));
    for (int y = 0; y < oh; ++y) {
        for (int x = 0; x < ow; ++x) {
            const glm::vec2 st((x + 0.5f) / ow, (y + 0.5f) / oh);
            // s = (x + 0.5f) / 37 is off by up to half an ulp, u = s * 37 - 0.5 by up to ~4e-6
            // of a texel; times a neighbour difference of up to 3.
            EXPECT_NEAR(of.texture(st).r, of.texel(0, x, y), 2e-5);
            EXPECT_NEAR(of.texture(glm::dvec2((x + 0.5) / ow, (y + 0.5) / oh)).r, of.texel(0, x, y), 1e-13);
            EXPECT_EQ(o8.texture(st).r, o8.texel(0, x, y));
        }
    }
}

TEST(TextureSampling, MidpointBetweenTwoTexelsIsTheirAverage) {
    // Texels are multiples of 1/64: their average is exact in float.
    const int w = 8, h = 2;
    std::vector<float> v(w * h);
    for (int i = 0; i < w * h; ++i) v[i] = static_cast<float>((i * 37) % 64) / 64.0f;
    const Texture tex = Texture::from_float(w, h, 1, v);
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x + 1 < w; ++x) {
            const double expected = (v[y * w + x] + v[y * w + x + 1]) / 2.0;
            const glm::vec2 st(static_cast<float>(x + 1) / w, (y + 0.5f) / h);
            EXPECT_EQ(tex.texture(st).r, expected);
            EXPECT_EQ(tex.texture(glm::dvec2(st)).r, expected);
        }
    }
    // Vertically, and at the centre of a 2x2 block: the mean of four.
    const glm::vec2 centre(3.0f / w, 1.0f / h);
    const double four = (v[2] + v[3] + v[w + 2] + v[w + 3]) / 4.0;
    EXPECT_EQ(tex.texture(centre).r, four);
    // 8-bit codes: weight 128/256 and the rounding (d * 128 + 128) >> 8 give the mean
    // rounded half up.
    const Texture t8 = Texture::from_unorm8(2, 1, 1, {10, 21});
    EXPECT_EQ(t8.texture(glm::vec2(0.5f, 0.5f)).r, 16.0f * (1.0f / 255.0f));  // 15.5 -> 16
    EXPECT_DOUBLE_EQ(t8.texture(glm::dvec2(0.5, 0.5)).r, 15.5 / 255.0);
}

TEST(TextureSampling, ClampToEdgeBeyondTheUnitSquare) {
    const int w = 5, h = 3;
    const std::vector<float> v = random_floats(w * h, 7);
    const Texture tex = Texture::from_float(w, h, 1, v);
    auto at = [&](int x, int y) { return v[y * w + x]; };
    for (const float far : {-0.3f, -5.0f, -1e30f}) {
        EXPECT_EQ(tex.texture(glm::vec2(far, far)).r, at(0, 0));
        EXPECT_EQ(tex.texture(glm::vec2(far, (1.5f) / h)).r, at(0, 1));
        EXPECT_EQ(tex.texture(glm::dvec2(far, far)).r, at(0, 0));
    }
    for (const float far : {1.2f, 7.0f, 1e30f}) {
        EXPECT_EQ(tex.texture(glm::vec2(far, far)).r, at(w - 1, h - 1));
        EXPECT_EQ(tex.texture(glm::vec2((2.5f) / w, far)).r, at(2, h - 1));
        EXPECT_EQ(tex.texture(glm::dvec2(far, far)).r, at(w - 1, h - 1));
    }
    // Within half a texel of the border the edge texel is all there is.
    EXPECT_EQ(tex.texture(glm::vec2(0.0f, 0.0f)).r, at(0, 0));
    EXPECT_EQ(tex.texture(glm::vec2(1.0f, 1.0f)).r, at(w - 1, h - 1));
    // A NaN coordinate is defined: it reads the low edge.
    const float nan = std::numeric_limits<float>::quiet_NaN();
    EXPECT_EQ(tex.texture(glm::vec2(nan, nan)).r, at(0, 0));
    const Texture t8 = Texture::from_unorm8(2, 2, 1, {1, 2, 3, 4});
    EXPECT_EQ(t8.texture(glm::vec2(-3.0f, 9.0f)).r, 3.0f * (1.0f / 255.0f));
    EXPECT_EQ(t8.texture(glm::vec2(nan, nan)).r, 1.0f * (1.0f / 255.0f));
}

TEST(TextureSampling, MissingChannelsReadAsGlFillsThem) {
    const Texture r = Texture::from_float(2, 2, 1, {0.5f, 0.5f, 0.5f, 0.5f});
    EXPECT_EQ(r.texture(glm::vec2(0.5f)), glm::vec4(0.5f, 0.0f, 0.0f, 1.0f));
    const Texture rgb = Texture::from_unorm8(1, 1, 3, {255, 0, 51});
    EXPECT_EQ(rgb.texture(glm::vec2(0.5f)), glm::vec4(1.0f, 0.0f, 51.0f * (1.0f / 255.0f), 1.0f));
    EXPECT_EQ(rgb.texture(glm::dvec2(0.5)), glm::dvec4(1.0, 0.0, 0.2, 1.0));
}

// A luminance texture (one channel, Swizzle::luminance) samples exactly as a three-channel
// copy of its image, (r, r, r, 1), on every path: every format, both wraps, lods across the
// pyramid and between levels (odd sizes, so that levels blend unequal texels), the float and
// double textureLod, the scalar and batched texture(); NaN and infinite coordinates too.
// The copy is the image repeated channel by channel here, independently of the sampler.
TEST(TextureSampling, LuminanceSamplesAsItsThreeChannelCopy) {
    std::mt19937 rng(20261128);
    std::uniform_real_distribution<float> coordinate(-0.3f, 1.3f);
    std::uniform_real_distribution<float> lod(-1.0f, 6.0f);
    std::uniform_int_distribution<int> code(0, 65535);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    const int width = 37, height = 23;
    const std::size_t n = static_cast<std::size_t>(width * height);
    const auto three = [](const auto& one) {
        std::decay_t<decltype(one)> rgb(one.size() * 3);
        for (std::size_t i = 0; i < one.size(); ++i) rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = one[i];
        return rgb;
    };
    std::vector<std::uint8_t> codes8(n);
    std::vector<std::uint16_t> codes16(n);
    std::vector<float> values(n);
    for (std::size_t i = 0; i < n; ++i) {
        codes16[i] = static_cast<std::uint16_t>(code(rng));
        codes8[i] = static_cast<std::uint8_t>(codes16[i] >> 8);
        values[i] = static_cast<float>(codes16[i]) / 977.0f - 20.0f;
    }
    for (const TexelFormat format : {TexelFormat::unorm8, TexelFormat::unorm16, TexelFormat::float32}) {
        auto make = [&](int channels) {
            const bool rgb = channels == 3;
            return format == TexelFormat::unorm8    ? Texture::from_unorm8(width, height, channels, rgb ? three(codes8) : codes8)
                   : format == TexelFormat::unorm16 ? Texture::from_unorm16(width, height, channels, rgb ? three(codes16) : codes16)
                                                    : Texture::from_float(width, height, channels, rgb ? three(values) : values);
        };
        Texture luminance = make(1), copy = make(3);
        luminance.set_swizzle(tessref::Swizzle::luminance);
        for (const tessref::Wrap wrap : {tessref::Wrap::clamp_to_edge, tessref::Wrap::repeat}) {
            luminance.set_wrap(wrap);
            copy.set_wrap(wrap);
            std::vector<glm::vec2> st = {glm::vec2(0.0f), glm::vec2(1.0f), glm::vec2(nan, 0.5f), glm::vec2(0.5f, -inf),
                                         glm::vec2(inf, nan)};
            while (st.size() < 400) st.emplace_back(coordinate(rng), coordinate(rng));
            std::vector<glm::vec4> batch(st.size());
            luminance.texture(std::span<const glm::vec2>(st), std::span<glm::vec4>(batch));
            std::vector<float> red(st.size());
            luminance.texture_red(std::span<const glm::vec2>(st), std::span<float>(red));
            for (std::size_t k = 0; k < st.size(); ++k) {
                SCOPED_TRACE(std::string(tessref::to_string(format)) + " coordinate " + std::to_string(k));
                const float l = k < 5 ? static_cast<float>(k) * 1.3f : lod(rng);
                const glm::vec4 expected = copy.textureLod(st[k], l);
                ASSERT_EQ(expected.g, expected.r);  // the copy's own channels agree
                EXPECT_EQ(luminance.textureLod(st[k], l), expected);
                EXPECT_EQ(batch[k], copy.texture(st[k]));
                EXPECT_EQ(red[k], copy.texture(st[k]).r);
                EXPECT_EQ(luminance.texture(st[k]), copy.texture(st[k]));
                const glm::dvec2 sd(st[k]);
                EXPECT_EQ(luminance.textureLod(sd, static_cast<double>(l)), copy.textureLod(sd, static_cast<double>(l)));
                EXPECT_EQ(luminance.texture(sd), copy.texture(sd));
            }
        }
    }
    // Only a one-channel texture reads as luminance.
    Texture rgb = Texture::from_float(1, 1, 3, {0.1f, 0.2f, 0.3f});
    EXPECT_THROW(rgb.set_swizzle(tessref::Swizzle::luminance), tessref::Error);
}

// A sample's bits (equal samples compare equal, NaNs by their bits).
std::array<std::uint32_t, 4> bits(const glm::vec4& v) {
    return {std::bit_cast<std::uint32_t>(v.x), std::bit_cast<std::uint32_t>(v.y), std::bit_cast<std::uint32_t>(v.z),
            std::bit_cast<std::uint32_t>(v.w)};
}

// Random texels of one image in every format (8- and 16-bit codes, floats), and the texture
// of one of them.
struct RandomTexels {
    std::vector<std::uint8_t> codes8;
    std::vector<std::uint16_t> codes16;
    std::vector<float> values;
    RandomTexels(std::size_t n, std::mt19937& rng) : codes8(n), codes16(n), values(n) {
        std::uniform_int_distribution<int> code(0, 255);
        for (std::size_t i = 0; i < n; ++i) {
            codes8[i] = static_cast<std::uint8_t>(code(rng));
            codes16[i] = static_cast<std::uint16_t>(codes8[i] * 257 + code(rng));
            values[i] = static_cast<float>(code(rng)) / 37.0f - 3.0f;
        }
    }
    Texture texture(TexelFormat format, int width, int height, int channels) const {
        return format == TexelFormat::unorm8    ? Texture::from_unorm8(width, height, channels, codes8)
               : format == TexelFormat::unorm16 ? Texture::from_unorm16(width, height, channels, codes16)
                                                : Texture::from_float(width, height, channels, values);
    }
};

// The batched texture() is the scalar one at every coordinate, bit for bit, for every format,
// channel count and wrap mode, and both are textureLod(st, 0) (a separate code path): random
// coordinates in and well outside [0, 1], texel centres and edges, NaN and infinities. The
// batched texture_red() is their red channel, in float and double.
TEST(TextureSampling, BatchedTextureIsTextureAtEachCoordinate) {
    std::mt19937 rng(20261127);
    std::uniform_real_distribution<float> coordinate(-0.6f, 1.6f);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    for (const TexelFormat format : {TexelFormat::unorm8, TexelFormat::unorm16, TexelFormat::float32}) {
        for (int channels = 1; channels <= 4; ++channels) {
            const int width = 7, height = 5;
            Texture texture = RandomTexels(static_cast<std::size_t>(width * height * channels), rng)
                                  .texture(format, width, height, channels);
            for (const tessref::Wrap wrap : {tessref::Wrap::clamp_to_edge, tessref::Wrap::repeat}) {
                texture.set_wrap(wrap);
                std::vector<glm::vec2> st = {glm::vec2(0.0f), glm::vec2(1.0f), glm::vec2(0.5f / width, 1.5f / height),
                                             glm::vec2(nan, 0.5f), glm::vec2(0.5f, -inf), glm::vec2(inf, nan),
                                             glm::vec2(-1e30f, 1e30f)};
                while (st.size() < 300) st.emplace_back(coordinate(rng), coordinate(rng));
                std::vector<glm::vec4> out(st.size());
                texture.texture(std::span<const glm::vec2>(st), std::span<glm::vec4>(out));
                std::vector<float> red(st.size());
                texture.texture_red(std::span<const glm::vec2>(st), std::span<float>(red));
                const std::vector<glm::dvec2> st_double(st.begin(), st.end());
                std::vector<double> red_double(st.size());
                texture.texture_red(std::span<const glm::dvec2>(st_double), std::span<double>(red_double));
                for (std::size_t k = 0; k < st.size(); ++k) {
                    SCOPED_TRACE(std::string(tessref::to_string(format)) + " channels " + std::to_string(channels) +
                                 " coordinate " + std::to_string(k));
                    EXPECT_EQ(bits(out[k]), bits(texture.texture(st[k])));
                    EXPECT_EQ(bits(out[k]), bits(texture.textureLod(st[k], 0.0f)));
                    EXPECT_EQ(std::bit_cast<std::uint32_t>(red[k]), bits(out[k])[0]);
                    EXPECT_EQ(std::bit_cast<std::uint64_t>(red_double[k]),
                              std::bit_cast<std::uint64_t>(texture.texture(st_double[k]).r));
                }
            }
        }
    }
}

// The same at the edges of the batches (four coordinates at a time with SSE2; the unorm8 one
// keeps each axis's texel pair adjacent): levels from 1 x 1 up, coordinates on and next to
// every texel boundary, the two edges and beyond them, the special values, and batches of
// every length up to 9 (the remainders of groups of four); texture_red() likewise.
TEST(TextureSampling, BatchedTextureIsTextureAtTheEdgesOfEverySize) {
    std::mt19937 rng(20260611);
    std::uniform_real_distribution<float> coordinate(-0.6f, 1.6f);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    // Coordinates along an axis of `size` texels: every half texel and its float neighbours,
    // the 8-bit path's rounding boundaries (x.5 / 256 of a texel) next to each texel edge,
    // and the special values.
    const auto along = [&](int size) {
        std::vector<float> s = {nan, -nan, inf, -inf, 0.0f, -0.0f, 1.0f, 1e30f, -1e30f, 3e9f, -3e9f,
                                std::numeric_limits<float>::denorm_min(), std::nextafter(1.0f, 0.0f),
                                std::nextafter(1.0f, 2.0f), 2.0f, -1.0f};
        // (Of a long axis only the texels near its ends.)
        const auto near_end = [size](int i) { return i < 12 || i > size - 12; };
        for (int k = -4; k <= 2 * size + 4; ++k) {
            if (!near_end(k / 2)) continue;
            const float c = static_cast<float>(k) / static_cast<float>(2 * size);
            s.insert(s.end(), {c, std::nextafter(c, -inf), std::nextafter(c, inf)});
        }
        for (int i = -2; i <= size + 2; ++i)
            for (const float f : {-1.5f, -0.5f, 0.5f, 1.5f, 127.5f, 128.5f, 254.5f, 255.5f})
                if (near_end(i))
                    s.push_back((static_cast<float>(i) + f / 256.0f) / static_cast<float>(size));
        return s;
    };
    // (32764 and 32766: the largest sides the unorm8 and float batches take; beyond, the
    // scalar loop.)
    const std::array<std::array<int, 2>, 17> sizes = {{{1, 1}, {1, 2}, {2, 1}, {2, 2}, {3, 2}, {2, 3}, {1, 5}, {6, 1},
                                                       {5, 7}, {64, 3}, {3, 64}, {257, 2}, {32764, 2}, {2, 32764},
                                                       {32765, 3}, {32766, 2}, {2, 32767}}};
    for (const TexelFormat format : {TexelFormat::unorm8, TexelFormat::unorm16, TexelFormat::float32}) {
        for (int channels = 1; channels <= 4; ++channels) {
            for (const auto& [width, height] : sizes) {
                const std::size_t n = static_cast<std::size_t>(width * height * channels);
                RandomTexels texels(n, rng);
                // Extremes next to each other (the lerps' largest differences).
                for (std::size_t i = 0; i < n; i += 2) {
                    texels.codes8[i] = 255;
                    texels.codes16[i] = 65535;
                }
                if (n > 1) texels.codes8[1] = texels.codes16[1] = 0;
                Texture texture = texels.texture(format, width, height, channels);
                const std::vector<float> s = along(width), t = along(height);
                std::vector<glm::vec2> st;
                for (std::size_t i = 0; i < std::max(s.size(), t.size()); ++i) {
                    st.emplace_back(s[i % s.size()], t[(i * 7) % t.size()]);
                    st.emplace_back(s[i % s.size()], coordinate(rng));
                    st.emplace_back(coordinate(rng), t[i % t.size()]);
                }
                for (const tessref::Wrap wrap : {tessref::Wrap::clamp_to_edge, tessref::Wrap::repeat}) {
                    texture.set_wrap(wrap);
                    std::vector<glm::vec4> out(st.size());
                    texture.texture(std::span<const glm::vec2>(st), std::span<glm::vec4>(out));
                    std::vector<float> red(st.size());
                    texture.texture_red(std::span<const glm::vec2>(st), std::span<float>(red));
                    for (std::size_t k = 0; k < st.size(); ++k) {
                        SCOPED_TRACE(std::string(tessref::to_string(format)) + " " + std::to_string(width) + "x" +
                                     std::to_string(height) + "x" + std::to_string(channels) + " coordinate (" +
                                     std::to_string(st[k].x) + ", " + std::to_string(st[k].y) + ")");
                        ASSERT_EQ(bits(out[k]), bits(texture.textureLod(st[k], 0.0f)));
                        ASSERT_EQ(std::bit_cast<std::uint32_t>(red[k]), bits(out[k])[0]);
                    }
                    // Every batch length up to 9, from every start up to 4.
                    for (std::size_t first = 0; first < 4; ++first)
                        for (std::size_t count = 1; count <= 9; ++count) {
                            std::vector<glm::vec4> part(count, glm::vec4(-7.0f));
                            texture.texture(std::span<const glm::vec2>(st).subspan(first, count),
                                            std::span<glm::vec4>(part));
                            for (std::size_t k = 0; k < count; ++k) ASSERT_EQ(bits(part[k]), bits(out[first + k]));
                            std::vector<float> part_red(count, -7.0f);
                            texture.texture_red(std::span<const glm::vec2>(st).subspan(first, count),
                                                std::span<float>(part_red));
                            for (std::size_t k = 0; k < count; ++k)
                                ASSERT_EQ(std::bit_cast<std::uint32_t>(part_red[k]), bits(out[first + k])[0]);
                        }
                }
            }
        }
    }
}

// The double path reads a unorm texel as its code over the format's maximum, exactly,
// for every 8- and 16-bit code (recovered from the stored float by rounding).
TEST(TextureSampling, TexelExactOfEveryUnormCodeIsTheCodeOverItsMaximum) {
    std::vector<std::uint16_t> codes16(65536);
    for (int c = 0; c < 65536; ++c) codes16[static_cast<std::size_t>(c)] = static_cast<std::uint16_t>(c);
    const Texture t16 = Texture::from_unorm16(256, 256, 1, codes16);
    for (int c = 0; c < 65536; ++c) ASSERT_EQ(t16.texel_exact(0, c % 256, c / 256), c / 65535.0) << c;
    std::vector<std::uint8_t> codes8(256);
    for (int c = 0; c < 256; ++c) codes8[static_cast<std::size_t>(c)] = static_cast<std::uint8_t>(c);
    const Texture t8 = Texture::from_unorm8(16, 16, 1, codes8);
    for (int c = 0; c < 256; ++c) ASSERT_EQ(t8.texel_exact(0, c % 16, c / 16), c / 255.0) << c;
}

// row_exact reads a whole row of level 0 as texel_exact reads each of its texels, for every
// format, channel count and channel, and refuses what texel_exact refuses.
TEST(TextureSampling, RowExactIsTexelExactAlongTheRow) {
    std::mt19937 rng(11);
    std::uniform_int_distribution<int> code(0, 65535);
    for (const auto& [w, h] : {std::pair{1, 1}, std::pair{1, 9}, std::pair{13, 1}, std::pair{37, 23}}) {
        for (int channels = 1; channels <= 4; ++channels) {
            const std::size_t n = static_cast<std::size_t>(w) * h * channels;
            std::vector<std::uint16_t> c16(n);
            std::vector<std::uint8_t> c8(n);
            std::vector<float> f(n);
            for (std::size_t i = 0; i < n; ++i) {
                c16[i] = static_cast<std::uint16_t>(code(rng));
                c8[i] = static_cast<std::uint8_t>(code(rng) & 0xFF);
                f[i] = static_cast<float>(code(rng) - 30000) / 77.0f;
            }
            for (const Texture& t : {Texture::from_unorm16(w, h, channels, c16), Texture::from_unorm8(w, h, channels, c8),
                                     Texture::from_float(w, h, channels, f)}) {
                SCOPED_TRACE(std::string(to_string(t.format())) + " " + std::to_string(w) + "x" + std::to_string(h) +
                             "x" + std::to_string(channels));
                std::vector<double> row(static_cast<std::size_t>(w));
                for (int y = 0; y < h; ++y)
                    for (int c = 0; c < channels; ++c) {
                        t.row_exact(y, c, row);
                        for (int x = 0; x < w; ++x) ASSERT_EQ(row[static_cast<std::size_t>(x)], t.texel_exact(0, x, y, c));
                    }
                EXPECT_THROW(t.row_exact(h, 0, row), tessref::Error);
                EXPECT_THROW(t.row_exact(-1, 0, row), tessref::Error);
                EXPECT_THROW(t.row_exact(0, channels, row), tessref::Error);
                std::vector<double> longer(static_cast<std::size_t>(w) + 1);
                EXPECT_THROW(t.row_exact(0, 0, longer), tessref::Error);
            }
        }
    }
}

// ---- mip pyramid --------------------------------------------------------------------------

TEST(Mipmaps, LevelSizesHalveDownToOneByOne) {
    const Texture tex = Texture::from_float(403, 344, 1, std::vector<float>(403 * 344, 0.0f));
    const int expected[][2] = {{403, 344}, {201, 172}, {100, 86}, {50, 43}, {25, 21},
                               {12, 10},   {6, 5},     {3, 2},    {1, 1}};
    ASSERT_EQ(tex.level_count(), 9);
    for (int k = 0; k < 9; ++k) {
        EXPECT_EQ(tex.level(k).width, expected[k][0]);
        EXPECT_EQ(tex.level(k).height, expected[k][1]);
    }
    EXPECT_EQ(Texture::from_float(1, 7, 1, std::vector<float>(7)).level_count(), 3);  // 1x7, 1x3, 1x1
    EXPECT_EQ(Texture::from_float(1, 1, 1, {0.0f}).level_count(), 1);
}

TEST(Mipmaps, ConstantImageGivesConstantLevels) {
    for (const MipmapRule rule : kRules) {
        for (const auto& size : {std::pair{37, 23}, std::pair{64, 64}, std::pair{5, 300}}) {
            const auto [w, h] = size;
            const Texture tf = Texture::from_float(w, h, 1, std::vector<float>(w * h, 0.3f), rule);
            const Texture t8 = Texture::from_unorm8(w, h, 2, std::vector<std::uint8_t>(w * h * 2, 77), rule);
            const Texture t16 = Texture::from_unorm16(w, h, 1, std::vector<std::uint16_t>(w * h, 40000), rule);
            for (const Texture* tex : {&tf, &t8, &t16}) {
                for (int k = 1; k < tex->level_count(); ++k) {
                    const auto& level = tex->level(k);
                    for (float v : level.texels) ASSERT_EQ(v, level.texels[0]) << to_string(rule);
                    for (int y = 0; y < level.height; ++y)
                        for (int x = 0; x < level.width; ++x)
                            for (int c = 0; c < tex->channels(); ++c)
                                ASSERT_EQ(tex->texel_exact(k, x, y, c), tex->texel_exact(0, 0, 0));
                }
                const float last = tex->texel(tex->max_level(), 0, 0);
                if (rule == MipmapRule::llvmpipe_blit || tex->format() != TexelFormat::float32) {
                    EXPECT_EQ(last, tex->texel(0, 0, 0)) << to_string(rule) << " " << to_string(tex->format());
                } else {
                    // ((c + c) + c) + c rounds; the box stays within an ulp of c.
                    EXPECT_NEAR(last, 0.3f, 1e-7) << to_string(rule);
                }
            }
        }
    }
}

// The double path's levels above 0 are computed on their first read, once: many threads
// reading a fresh texture at once (textureLod between two levels, texel_exact above level 0)
// read what one thread reads from another fresh texture of the same image, and a copy made
// before that first read reads the same.
TEST(Mipmaps, DoublePathLevelsComputedOnFirstReadAgreeAcrossThreads) {
    const int w = 61, h = 37;
    std::mt19937 rng(11);
    std::uniform_int_distribution<int> code(0, 255);
    std::vector<std::uint8_t> codes(static_cast<std::size_t>(w) * h * 3);
    for (auto& c : codes) c = static_cast<std::uint8_t>(code(rng));
    for (const MipmapRule rule : kRules) {
        const Texture serial = Texture::from_unorm8(w, h, 3, codes, rule);
        const Texture shared = Texture::from_unorm8(w, h, 3, codes, rule);
        const Texture copy = shared;  // before any double read
        std::vector<glm::dvec2> st(2000);
        std::uniform_real_distribution<double> coordinate(-0.2, 1.2);
        for (auto& p : st) p = glm::dvec2(coordinate(rng), coordinate(rng));
        std::vector<glm::dvec4> expected(st.size()), got(st.size());
        for (std::size_t k = 0; k < st.size(); ++k) expected[k] = serial.textureLod(st[k], 0.25 + (k % 17) * 0.375);
        tbb::parallel_for(std::size_t{0}, st.size(), [&](std::size_t k) {
            got[k] = shared.textureLod(st[k], 0.25 + (k % 17) * 0.375);
        });
        for (std::size_t k = 0; k < st.size(); ++k) ASSERT_EQ(got[k], expected[k]) << to_string(rule) << " " << k;
        for (int lod = 1; lod < serial.level_count(); ++lod)
            EXPECT_EQ(copy.texel_exact(lod, 0, serial.level(lod).height - 1, 2),
                      serial.texel_exact(lod, 0, serial.level(lod).height - 1, 2));
    }
}

TEST(Mipmaps, BoxOfAKnown4x4ByHand) {
    // v(x, y) = (4y + x) / 16. Level 1: the 2x2 means 2.5, 4.5, 10.5, 12.5 (/16); level 2:
    // their mean 7.5 / 16. Every value is a multiple of 1/32: exact for both rules.
    std::vector<float> v(16);
    std::vector<std::uint8_t> codes(16);
    for (int i = 0; i < 16; ++i) {
        v[i] = i / 16.0f;
        codes[i] = static_cast<std::uint8_t>(i * 16);
    }
    const double level1[4] = {2.5 / 16, 4.5 / 16, 10.5 / 16, 12.5 / 16};
    for (const MipmapRule rule : kRules) {
        const Texture tex = Texture::from_float(4, 4, 1, v, rule);
        ASSERT_EQ(tex.level_count(), 3);
        for (int y = 0; y < 2; ++y) {
            for (int x = 0; x < 2; ++x) {
                EXPECT_EQ(tex.texel(1, x, y), level1[y * 2 + x]) << to_string(rule);
                EXPECT_EQ(tex.texel_exact(1, x, y), level1[y * 2 + x]) << to_string(rule);
            }
        }
        EXPECT_EQ(tex.texel(2, 0, 0), 7.5 / 16);
        EXPECT_EQ(tex.texel_exact(2, 0, 0), 7.5 / 16);
        // The same image as 8-bit codes 16 * (4y + x): means 40, 72, 168, 200, then 120.
        const Texture t8 = Texture::from_unorm8(4, 4, 1, codes, rule);
        const int code1[4] = {40, 72, 168, 200};
        for (int i = 0; i < 4; ++i) EXPECT_EQ(t8.level(1).unorm8[i], code1[i]) << to_string(rule);
        EXPECT_EQ(t8.level(2).unorm8[0], 120);
    }
}

TEST(Mipmaps, OddSizesFollowTheirRule) {
    // 3x3 -> 1x1. Mesa's software box (do_row) averages columns/rows 0 and 1 and drops the
    // third; llvmpipe's blit samples the centre (s = t = 0.5), i.e. texel (1, 1).
    const std::vector<float> v = {1, 2, 3, 4, 5, 6, 7, 8, 9};
    EXPECT_EQ(Texture::from_float(3, 3, 1, v, MipmapRule::mesa_software_box).texel(1, 0, 0), (1 + 2 + 4 + 5) / 4.0f);
    EXPECT_EQ(Texture::from_float(3, 3, 1, v, MipmapRule::llvmpipe_blit).texel(1, 0, 0), 5.0f);
    // 5x1 -> 2x1. Box: (t0 + t1) / 2 and (t2 + t3) / 2 (the single row is used twice).
    // Blit: destination texel i samples u = (i + 0.5) * 5 / 2 - 0.5 = 0.75 and 3.25, i.e.
    // t0 + 0.75 (t1 - t0) and t3 + 0.25 (t4 - t3).
    const std::vector<float> row = {0.0f, 1.0f, 0.25f, 0.5f, 0.75f};
    const Texture box = Texture::from_float(5, 1, 1, row, MipmapRule::mesa_software_box);
    EXPECT_EQ(box.texel(1, 0, 0), 0.5f);
    EXPECT_EQ(box.texel(1, 1, 0), 0.375f);
    const Texture blit = Texture::from_float(5, 1, 1, row, MipmapRule::llvmpipe_blit);
    EXPECT_NEAR(blit.texel(1, 0, 0), 0.75, 1e-6);  // the rasterizer may round the coordinate
    EXPECT_NEAR(blit.texel(1, 1, 0), 0.5625, 1e-6);
    EXPECT_EQ(blit.texel_exact(1, 0, 0), 0.75);     // the double path samples the ideal point
    EXPECT_EQ(blit.texel_exact(1, 1, 0), 0.5625);
    // Software box on integers truncates: (1 + 2 + 2 + 2) / 4 = 1.
    const Texture t8 = Texture::from_unorm8(2, 2, 1, {1, 2, 2, 2}, MipmapRule::mesa_software_box);
    EXPECT_EQ(t8.level(1).unorm8[0], 1);
}

TEST(Mipmaps, TextureLodAtIntegerLodsIsThatLevelsBilinearSample) {
    for (const MipmapRule rule : kRules) {
        const int w = 37, h = 23;
        Texture tex = Texture::from_float(w, h, 1, random_floats(w * h, 11), rule);
        std::mt19937 rng(12);
        std::uniform_real_distribution<float> coord(-0.1f, 1.1f);
        for (int n = 0; n < 300; ++n) {
            const glm::vec2 st(coord(rng), coord(rng));
            for (int k = 0; k <= tex.max_level(); ++k) {
                const double expected = spec_bilinear(tex, k, st.x, st.y, 0, false);
                // Float coordinate rounding (~4e-6 texel) times a texel difference of up to 3.
                EXPECT_NEAR(tex.textureLod(st, static_cast<float>(k)).r, expected, 2e-5);
                EXPECT_NEAR(tex.textureLod(glm::dvec2(st), k).r, spec_bilinear(tex, k, st.x, st.y, 0, true), 1e-12);
                if (k < tex.max_level()) {
                    // Halfway between two levels: the mean of their samples.
                    const double mean = (spec_bilinear(tex, k, st.x, st.y, 0, false) +
                                         spec_bilinear(tex, k + 1, st.x, st.y, 0, false)) / 2;
                    EXPECT_NEAR(tex.textureLod(st, k + 0.5f).r, mean, 2e-5);
                    const double mean_exact = (spec_bilinear(tex, k, st.x, st.y, 0, true) +
                                               spec_bilinear(tex, k + 1, st.x, st.y, 0, true)) / 2;
                    EXPECT_NEAR(tex.textureLod(glm::dvec2(st), k + 0.5).r, mean_exact, 1e-12);
                }
            }
            // lod is clamped to [0, max_level]; texture() is textureLod(st, 0), bit for bit.
            EXPECT_EQ(tex.textureLod(st, -3.0f), tex.textureLod(st, 0.0f));
            EXPECT_EQ(tex.textureLod(st, 100.0f), tex.textureLod(st, static_cast<float>(tex.max_level())));
            EXPECT_EQ(tex.texture(st), tex.textureLod(st, 0.0f));
            EXPECT_EQ(tex.textureLod(st, std::numeric_limits<float>::quiet_NaN()), tex.textureLod(st, 0.0f));
            EXPECT_EQ(tex.texture(glm::dvec2(st)), tex.textureLod(glm::dvec2(st), 0.0));
        }
        // GL_LINEAR minification ignores the pyramid.
        tex.set_min_filter(MinFilter::linear);
        EXPECT_EQ(tex.textureLod(glm::vec2(0.3f, 0.6f), 2.7f), tex.textureLod(glm::vec2(0.3f, 0.6f), 0.0f));
        EXPECT_EQ(tex.textureLod(glm::dvec2(0.3, 0.6), 2.7), tex.textureLod(glm::dvec2(0.3, 0.6), 0.0));
    }
}

// ---- loading ------------------------------------------------------------------------------

TEST(Loading, EachFormatRoundTrips) {
    TempDir dir;
    const int w = 5, h = 3;
    const std::vector<std::uint8_t> c8 = {0, 1, 2, 127, 128, 254, 255, 3, 4, 5, 6, 7, 8, 9, 10};
    const std::vector<std::uint16_t> c16 = {0, 1, 65535, 12345, 32768, 40000, 65534, 3, 4, 5, 6, 7, 8, 9, 10};
    const std::vector<float> fv = {-1.5f, 0.0f, 88.25f, 1e-3f, 3.0f, 2.5f, -7.0f, 1.0f, 0.5f, 0.25f,
                                   100.0f, 1234.5f, -0.125f, 9.0f, 10.0f};
    struct Case {
        std::string name;
        OIIO::TypeDesc type;
        const void* data;
        std::string pixel_type;
    };
    const Case cases[] = {
        {"h8.pgm", OIIO::TypeDesc::UINT8, c8.data(), "uint8"},
        // (h16.pgm is written by hand below: OpenImageIO 2.4.7's PNM writer garbles 16-bit data)
        {"h8.png", OIIO::TypeDesc::UINT8, c8.data(), "uint8"},
        {"h16.png", OIIO::TypeDesc::UINT16, c16.data(), "uint16"},
        {"hf.tif", OIIO::TypeDesc::FLOAT, fv.data(), "float"},
        {"hf.exr", OIIO::TypeDesc::FLOAT, fv.data(), "float"},
    };
    // A 16-bit binary PGM as the format defines it: maxval 65535, big-endian samples.
    std::string pgm16 = "P5\n" + std::to_string(w) + " " + std::to_string(h) + "\n65535\n";
    for (std::uint16_t v : c16) {
        pgm16.push_back(static_cast<char>(v >> 8));
        pgm16.push_back(static_cast<char>(v & 0xff));
    }
    write_bytes(dir.file("h16.pgm"), pgm16);
    std::vector<Case> all(std::begin(cases), std::end(cases));
    all.push_back({"h16.pgm", OIIO::TypeDesc::UINT16, nullptr, "uint16"});
    for (const Case& c : all) {
        SCOPED_TRACE(c.name);
        const std::string path = dir.file(c.name);
        if (c.data != nullptr) write_image(path, w, h, 1, c.type, c.data);
        const tessref::HeightField field = tessref::load_height_field(path);
        const Texture& tex = field.texture;
        EXPECT_EQ(field.info.source_path, path);
        EXPECT_EQ(field.info.pixel_type, c.pixel_type);
        EXPECT_EQ(field.info.width, w);
        EXPECT_EQ(field.info.height, h);
        EXPECT_EQ(field.info.missing_texels, 0u);
        ASSERT_EQ(tex.width(), w);
        ASSERT_EQ(tex.height(), h);
        ASSERT_EQ(tex.channels(), 1);
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
                const int i = y * w + x;
                if (c.type == OIIO::TypeDesc::UINT8) {
                    EXPECT_EQ(tex.format(), TexelFormat::unorm8);
                    EXPECT_EQ(tex.texel(0, x, y), static_cast<float>(c8[i]) * (1.0f / 255.0f));
                    EXPECT_EQ(tex.texel_exact(0, x, y), c8[i] / 255.0);
                } else if (c.type == OIIO::TypeDesc::UINT16) {
                    EXPECT_EQ(tex.format(), TexelFormat::unorm16);
                    EXPECT_EQ(tex.texel(0, x, y), static_cast<float>(c16[i]) * (1.0f / 65535.0f));
                    EXPECT_EQ(tex.texel_exact(0, x, y), c16[i] / 65535.0);
                } else {
                    EXPECT_EQ(tex.format(), TexelFormat::float32);
                    EXPECT_EQ(tex.texel(0, x, y), fv[i]);
                }
            }
        }
    }
}

TEST(Loading, Pgm16Above32768) {
    // OpenImageIO 2.4.7's PNM reader scales 16-bit samples as int(v) * 65535 / maxval in
    // int arithmetic, which overflows for v > 32768 when maxval is 65535 and, as Debian's
    // build runs it, returns 32768 for both 32768 and 32769. The loader reads such samples
    // again itself (load.cpp, reread_pnm16): every code must come back exactly.
    TempDir dir;
    const std::vector<std::uint16_t> codes = {0, 1, 32767, 32768, 32769, 40000, 65534, 65535};
    std::string bytes = "P5\n8 2\n65535\n";
    for (int row = 0; row < 2; ++row) {
        for (std::uint16_t v : codes) {
            bytes.push_back(static_cast<char>(v >> 8));
            bytes.push_back(static_cast<char>(v & 0xff));
        }
    }
    const std::string path = dir.file("high.pgm");
    write_bytes(path, bytes);
    const Texture tex = tessref::load_height_field(path).texture;
    for (int x = 0; x < 8; ++x) {
        const int got = static_cast<int>(std::lround(tex.texel(0, x, 0) * 65535.0));
        EXPECT_EQ(got, codes[x]) << "code " << codes[x];
    }
}

TEST(Loading, FirstStoredRowIsTZeroExceptPfmWhichIsStoredBottomUp) {
    TempDir dir;
    // A binary PGM written byte by byte: rows (10 20) then (30 40).
    const std::string pgm = dir.file("rows.pgm");
    write_bytes(pgm, std::string("P5\n2 2\n255\n") + std::string("\x0a\x14\x1e\x28", 4));
    const Texture t = tessref::load_height_field(pgm).texture;
    EXPECT_EQ(t.texel(0, 0, 0), 10.0f * (1.0f / 255.0f));
    EXPECT_EQ(t.texel(0, 1, 1), 40.0f * (1.0f / 255.0f));
    // t = 0 is the first stored row.
    EXPECT_EQ(t.texture(glm::vec2(0.25f, 0.0f)).r, 10.0f * (1.0f / 255.0f));
    // A PFM (OpenImageIO 2.4 reads but cannot write it): stored rows (1 2) then (3 4),
    // bottom to top, so the image's top row, t = 0, is (3 4).
    const std::string pfm = dir.file("rows.pfm");
    const float data[4] = {1.0f, 2.0f, 3.0f, 4.0f};
    std::string bytes = "Pf\n2 2\n-1.0\n";  // negative scale: little-endian
    for (float f : data) {
        const auto bits = std::bit_cast<std::uint32_t>(f);
        for (int k = 0; k < 4; ++k) bytes.push_back(static_cast<char>((bits >> (8 * k)) & 0xff));
    }
    write_bytes(pfm, bytes);
    const tessref::HeightField field = tessref::load_height_field(pfm);
    EXPECT_EQ(field.info.pixel_type, "float");
    EXPECT_EQ(field.texture.format(), TexelFormat::float32);
    EXPECT_EQ(field.texture.texel(0, 0, 0), 3.0f);
    EXPECT_EQ(field.texture.texel(0, 1, 0), 4.0f);
    EXPECT_EQ(field.texture.texel(0, 0, 1), 1.0f);
    EXPECT_EQ(field.texture.texel(0, 1, 1), 2.0f);
}

// Where texture_of_height_field gives a texture it is load_texture's of the same file,
// level for level; where they would differ (a filled texel, channels the height field
// drops, another mipmap rule, a smaller size limit) it gives none and the file is read.
TEST(Loading, TextureOfAHeightFieldIsTheFilesTextureOrNone) {
    auto expect_same = [](const Texture& a, const Texture& b) {
        ASSERT_EQ(a.format(), b.format());
        ASSERT_EQ(a.channels(), b.channels());
        ASSERT_EQ(a.mipmap_rule(), b.mipmap_rule());
        EXPECT_EQ(a.swizzle(), b.swizzle());
        EXPECT_EQ(a.wrap(), b.wrap());
        EXPECT_EQ(a.min_filter(), b.min_filter());
        ASSERT_EQ(a.level_count(), b.level_count());
        for (int lod = 0; lod < a.level_count(); ++lod) {
            EXPECT_EQ(a.level(lod).width, b.level(lod).width);
            EXPECT_EQ(a.level(lod).height, b.level(lod).height);
            EXPECT_TRUE(a.level(lod).texels == b.level(lod).texels) << "lod " << lod;
            EXPECT_TRUE(a.level(lod).unorm8 == b.level(lod).unorm8) << "lod " << lod;
        }
    };
    TempDir dir;
    // uint8, uint16 (PGM), float (TIFF through OpenImageIO).
    for (const std::string path : {std::string(TESSREF_DATA_DIR) + "/heightmaps/thesis-island.pgm",
                                   std::string(TESSREF_DATA_DIR) + "/jacksboro_fault_dem.pgm",
                                   std::string(TESSREF_DATA_DIR) + "/olinda_dem_utm25s.tif"}) {
        SCOPED_TRACE(path);
        const tessref::HeightField field = tessref::load_height_field(path);
        const std::optional<Texture> same = tessref::texture_of_height_field(field);
        ASSERT_TRUE(same.has_value());
        expect_same(*same, tessref::load_texture(path));
        tessref::TextureLoadOptions box;
        box.mipmap_rule = MipmapRule::mesa_software_box;
        EXPECT_FALSE(tessref::texture_of_height_field(field, box).has_value());
        HeightFieldOptions box_field;
        box_field.mipmap_rule = MipmapRule::mesa_software_box;
        const std::optional<Texture> box_same =
            tessref::texture_of_height_field(tessref::load_height_field(path, box_field), box);
        ASSERT_TRUE(box_same.has_value());
        expect_same(*box_same, tessref::load_texture(path, box));
        tessref::TextureLoadOptions small;
        small.max_dimension = std::max(field.info.width, field.info.height) - 1;
        EXPECT_FALSE(tessref::texture_of_height_field(field, small).has_value());
        EXPECT_THROW(tessref::load_texture(path, small), tessref::Error);
    }
    // Colour: the height field keeps the first of three channels.
    const std::string rgb = dir.file("rgb.ppm");
    write_bytes(rgb, std::string("P6\n2 2\n255\n") + std::string("\x01\x02\x03\x04\x05\x06\x07\x08\x09\x0a\x0b\x0c", 12));
    EXPECT_FALSE(tessref::texture_of_height_field(tessref::load_height_field(rgb)).has_value());
    // A nodata texel filled: the height field's texel is not the file's.
    const std::string holes = dir.file("holes.pgm");
    write_bytes(holes, std::string("P5\n3 2\n255\n") + std::string("\x0a\x00\x1e\x28\x32\x3c", 6));
    HeightFieldOptions fill;
    fill.nodata_value = 0.0;
    fill.nodata_policy = NodataPolicy::fill_neighbour_mean;
    const tessref::HeightField filled = tessref::load_height_field(holes, fill);
    ASSERT_EQ(filled.info.missing_texels, 1u);
    EXPECT_FALSE(tessref::texture_of_height_field(filled).has_value());
    const std::optional<Texture> unfilled = tessref::texture_of_height_field(tessref::load_height_field(holes));
    ASSERT_TRUE(unfilled.has_value());
    expect_same(*unfilled, tessref::load_texture(holes));
}

TEST(Loading, HeightUsesTheFirstChannelAndColourTexturesKeepTheirChannels) {
    TempDir dir;
    const int w = 3, h = 2;
    std::vector<std::uint8_t> rgba(w * h * 4);
    for (std::size_t i = 0; i < rgba.size(); ++i) rgba[i] = static_cast<std::uint8_t>(i * 10);
    const std::string png = dir.file("rgba.png");
    write_image(png, w, h, 4, OIIO::TypeDesc::UINT8, rgba.data());
    const tessref::HeightField field = tessref::load_height_field(png);
    EXPECT_EQ(field.info.file_channels, 4);
    EXPECT_EQ(field.texture.channels(), 1);
    EXPECT_EQ(field.texture.texel(0, 2, 1), rgba[(1 * w + 2) * 4] * (1.0f / 255.0f));
    const Texture colour = tessref::load_texture(png);
    EXPECT_EQ(colour.channels(), 4);
    EXPECT_EQ(colour.format(), TexelFormat::unorm8);
    for (int k = 0; k < 4; ++k) EXPECT_EQ(colour.texel(0, 2, 1, k), rgba[(1 * w + 2) * 4 + k] * (1.0f / 255.0f));
    tessref::TextureLoadOptions three;
    three.max_channels = 3;
    EXPECT_EQ(tessref::load_texture(png, three).channels(), 3);
    // JPEG is lossy: its size and channels come through, and a flat colour stays close.
    const std::vector<std::uint8_t> flat(8 * 8 * 3, 200);
    const std::string jpg = dir.file("flat.jpg");
    write_image(jpg, 8, 8, 3, OIIO::TypeDesc::UINT8, flat.data());
    const Texture j = tessref::load_texture(jpg);
    EXPECT_EQ(j.width(), 8);
    EXPECT_EQ(j.channels(), 3);
    EXPECT_NEAR(j.texel(0, 4, 4, 1), 200.0 / 255.0, 3.0 / 255.0);
    // A 1x1 colour texture is fine (not a height field).
    const std::string one = dir.file("one.png");
    write_image(one, 1, 1, 3, OIIO::TypeDesc::UINT8, flat.data());
    EXPECT_EQ(tessref::load_texture(one).level_count(), 1);
}

TEST(Loading, TheRealMapsHaveTheirDocumentedSizesAndRanges) {
    const std::string jacksboro = std::string(TESSREF_DATA_DIR) + "/jacksboro_fault_dem.pgm";
    const tessref::HeightField j = tessref::load_height_field(jacksboro);
    EXPECT_EQ(j.info.width, 403);
    EXPECT_EQ(j.info.height, 344);
    EXPECT_EQ(j.info.pixel_type, "uint16");
    EXPECT_EQ(j.texture.format(), TexelFormat::unorm16);
    EXPECT_EQ(j.texture.level_count(), 9);
    // 236 m .. 1076 m stored as v / 65535 * 840 + 236: the samples run from 0 to 65535.
    EXPECT_EQ(j.info.min_value, 0.0f);
    // The file's largest sample is 65535 (read exactly: see Loading.Pgm16Above32768).
    EXPECT_EQ(j.info.max_value, 1.0f);

    const std::string olinda = std::string(TESSREF_DATA_DIR) + "/olinda_dem_utm25s.tif";
    const tessref::HeightField o = tessref::load_height_field(olinda);
    EXPECT_EQ(o.info.width, 111);
    EXPECT_EQ(o.info.height, 111);
    EXPECT_EQ(o.info.pixel_type, "float");
    EXPECT_EQ(o.texture.format(), TexelFormat::float32);
    EXPECT_EQ(o.texture.level_count(), 7);
    EXPECT_EQ(o.info.min_value, -1.0f);  // metres
    EXPECT_EQ(o.info.max_value, 88.0f);
}

// ---- bad input ----------------------------------------------------------------------------

TEST(BadInput, EachGivesAnErrorNamingTheFile) {
    TempDir dir;
    const std::string missing = dir.file("missing.pgm");
    expect_error([&] { tessref::load_height_field(missing); }, missing, "not found");
    expect_error([&] { tessref::load_texture(missing); }, missing, "not found");

    const std::string garbage = dir.file("garbage.png");
    write_bytes(garbage, "this is not a PNG file, only some words pretending to be one\n");
    expect_error([&] { tessref::load_height_field(garbage); }, garbage, "cannot read");
    expect_error([&] { tessref::load_texture(garbage); }, garbage, "cannot read");

    const std::string empty = dir.file("empty.png");
    write_bytes(empty, "");
    expect_error([&] { tessref::load_height_field(empty); }, empty, "empty");

    const std::string truncated = dir.file("truncated.pgm");
    write_bytes(truncated, "P5\n10 10\n255\nabcde");
    expect_error([&] { tessref::load_height_field(truncated); }, truncated, "truncated or corrupt");

    const std::string zero = dir.file("zero.pgm");
    write_bytes(zero, "P5\n0 0\n255\n");
    expect_error([&] { tessref::load_height_field(zero); }, zero, "");  // zero size or unreadable

    const std::uint8_t one_texel[3] = {1, 2, 3};
    const std::string tiny = dir.file("tiny.png");
    write_image(tiny, 1, 1, 1, OIIO::TypeDesc::UINT8, one_texel);
    expect_error([&] { tessref::load_height_field(tiny); }, tiny, "at least 2x2");
    const std::string thin = dir.file("thin.png");
    write_image(thin, 1, 3, 1, OIIO::TypeDesc::UINT8, one_texel);
    expect_error([&] { tessref::load_height_field(thin); }, thin, "at least 2x2");

    const std::vector<std::uint8_t> big(16 * 4, 9);
    const std::string wide = dir.file("wide.png");
    write_image(wide, 16, 4, 1, OIIO::TypeDesc::UINT8, big.data());
    HeightFieldOptions small;
    small.max_dimension = 8;
    expect_error([&] { tessref::load_height_field(wide, small); }, wide, "larger than the limit");
    tessref::TextureLoadOptions small_texture;
    small_texture.max_dimension = 8;
    expect_error([&] { tessref::load_texture(wide, small_texture); }, wide, "larger than the limit");
    EXPECT_NO_THROW(tessref::load_height_field(wide));
}

// A device or FIFO has no end: OpenImageIO would read /dev/zero forever (a fuzzer's
// finding: a scene naming heightmap = "/dev/zero" hung the loader).
TEST(BadInput, DevicesAndFifosAreRefusedNotRead) {
    for (const std::string device : {"/dev/zero", "/dev/urandom", "/dev/null"}) {
        expect_error([&] { tessref::load_height_field(device); }, device, "not a regular file");
        expect_error([&] { tessref::load_texture(device); }, device, "not a regular file");
    }
    TempDir dir;
    const std::string fifo = dir.file("fifo.pgm");
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    expect_error([&] { tessref::load_height_field(fifo); }, fifo, "not a regular file");
}

// A fuzzer's finding: a 529-byte PNG whose tEXt chunk declares 1785750887 bytes made
// libpng (inside OpenImageIO) allocate 1.7 GB before failing. Chunk lengths are checked
// against the file size before OpenImageIO opens it.
TEST(BadInput, PngChunkLongerThanTheFileIsRefusedBeforeReading) {
    const std::string path = std::string(TESSREF_SOURCE_DIR) + "/tests/data/fuzz/heightmap/png-text-chunk-claims-1.7GB";
    expect_error([&] { tessref::load_height_field(path); }, path, "declares 1785750887 bytes");
    expect_error([&] { tessref::load_texture(path); }, path, "more than the file holds (529 bytes)");
}

TEST(BadInput, NanTexelIsAnErrorByDefault) {
    TempDir dir;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    std::vector<float> v(4 * 3, 1.0f);
    v[1 * 4 + 2] = nan;  // (2, 1): the first in row-major order
    v[2 * 4 + 3] = nan;  // (3, 2)
    const std::string path = dir.file("nan.tif");
    write_image(path, 4, 3, 1, OIIO::TypeDesc::FLOAT, v.data());
    try {
        tessref::load_height_field(path);
        ADD_FAILURE() << "NaN accepted";
    } catch (const tessref::Error& e) {
        EXPECT_EQ(e.where().file, path);
        EXPECT_EQ(e.where().key, "texel(2,1)");
        EXPECT_NE(std::string(e.what()).find("(2, 1)"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("NaN"), std::string::npos) << e.what();
    }
    std::vector<float> w(4 * 3, 1.0f);
    w[5] = inf;
    const std::string infinite = dir.file("inf.exr");
    write_image(infinite, 4, 3, 1, OIIO::TypeDesc::FLOAT, w.data());
    expect_error([&] { tessref::load_height_field(infinite); }, infinite, "(1, 1) is infinite");
    // A user nodata value in an integer file is compared with the raw code.
    std::vector<std::uint16_t> codes(3 * 2, 500);
    codes[4] = 0;
    const std::string nodata = dir.file("nodata.png");
    write_image(nodata, 3, 2, 1, OIIO::TypeDesc::UINT16, codes.data());
    EXPECT_NO_THROW(tessref::load_height_field(nodata));
    HeightFieldOptions with_nodata;
    with_nodata.nodata_value = 0.0;
    expect_error([&] { tessref::load_height_field(nodata, with_nodata); }, nodata, "(1, 1) equals the nodata value 0");
}

TEST(BadInput, FillPoliciesReplaceMissingTexels) {
    TempDir dir;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    // Row 0: 1 NaN NaN 7, row 1: 2 4 6 8. One Jacobi pass fills both: (1, 0) from 1, 2, 4, 6
    // -> 3.25; (2, 0) from 7, 4, 6, 8 -> 6.25 (not from the other's new value).
    const std::vector<float> v = {1, nan, nan, 7, 2, 4, 6, 8};
    const std::string path = dir.file("holes.tif");
    write_image(path, 4, 2, 1, OIIO::TypeDesc::FLOAT, v.data());
    HeightFieldOptions mean;
    mean.nodata_policy = NodataPolicy::fill_neighbour_mean;
    const tessref::HeightField filled = tessref::load_height_field(path, mean);
    EXPECT_EQ(filled.info.missing_texels, 2u);
    EXPECT_EQ(filled.texture.texel(0, 1, 0), 3.25f);
    EXPECT_EQ(filled.texture.texel(0, 2, 0), 6.25f);
    EXPECT_EQ(filled.texture.texel(0, 0, 0), 1.0f);
    // Several passes: only (0, 0) is present, so the value spreads outwards unchanged.
    std::vector<float> spread(3 * 3, nan);
    spread[0] = 8.0f;
    const std::string spread_path = dir.file("spread.exr");
    write_image(spread_path, 3, 3, 1, OIIO::TypeDesc::FLOAT, spread.data());
    const tessref::HeightField s = tessref::load_height_field(spread_path, mean);
    EXPECT_EQ(s.info.missing_texels, 8u);
    for (float t : s.texture.level(0).texels) EXPECT_EQ(t, 8.0f);
    // Constant fill.
    HeightFieldOptions constant;
    constant.nodata_policy = NodataPolicy::fill_constant;
    constant.fill_value = -2.5;
    const tessref::HeightField c = tessref::load_height_field(path, constant);
    EXPECT_EQ(c.texture.texel(0, 1, 0), -2.5f);
    EXPECT_EQ(c.texture.texel(0, 2, 0), -2.5f);
    EXPECT_EQ(c.info.min_value, -2.5f);
    // Integer files: the mean is rounded to a code. Code 0 is nodata; its neighbours are
    // 10, 11, 13 -> 34 / 3 = 11.33 -> 11.
    const std::vector<std::uint8_t> codes = {0, 10, 11, 13};
    const std::string int_path = dir.file("codes.png");
    write_image(int_path, 2, 2, 1, OIIO::TypeDesc::UINT8, codes.data());
    HeightFieldOptions int_mean = mean;
    int_mean.nodata_value = 0.0;
    const tessref::HeightField ic = tessref::load_height_field(int_path, int_mean);
    EXPECT_EQ(ic.texture.format(), TexelFormat::unorm8);
    EXPECT_EQ(ic.texture.texel(0, 0, 0), 11.0f * (1.0f / 255.0f));
    // Nothing to fill from.
    const std::vector<float> all_nan(4, nan);
    const std::string hopeless = dir.file("hopeless.tif");
    write_image(hopeless, 2, 2, 1, OIIO::TypeDesc::FLOAT, all_nan.data());
    expect_error([&] { tessref::load_height_field(hopeless, mean); }, hopeless, "every height map texel is missing");
}

// ---- hostile files (tests/data/heightfield/, made by make_files.py: each file's defect is
// stated there) -----------------------------------------------------------------------------

std::string hostile(const std::string& name) {
    return (fs::path(TESSREF_SOURCE_DIR) / "tests" / "data" / "heightfield" / name).string();
}

// Sets the process memory limit for one scope (tessref/limits.h), restoring the default.
class MemoryLimit {
public:
    explicit MemoryLimit(std::uint64_t bytes) { tessref::set_memory_limit(bytes); }
    ~MemoryLimit() { tessref::set_memory_limit(0); }
    MemoryLimit(const MemoryLimit&) = delete;
    MemoryLimit& operator=(const MemoryLimit&) = delete;
};

// A terrain scene over `heightmap` in `dir`, for running the command on a height map.
std::string terrain_scene(const TempDir& dir, const std::string& heightmap) {
    const std::string path = dir.file("scene.toml");
    write_bytes(path, "[scene]\nname = \"hostile\"\n[domain]\nplane = \"xy\"\npatches = [2, 2]\n"
                      "x = [0.0, 1.0]\ny = [0.0, 1.0]\nheightmap = \"" + heightmap + "\"\n"
                      "scale_xy = 1.0\nscale_z = 1.0\n[generator]\ndomain = \"quads\"\n"
                      "[control]\nmodel = \"constant\"\nlevel = 2.0\n[evaluation]\nmodel = \"thesis\"\n");
    return path;
}

tessref::test::RunResult run_mesh(const TempDir& dir, const std::vector<std::string>& extra) {
    std::vector<std::string> args{"mesh", dir.file("scene.toml"), "-o", dir.file("out.ply")};
    args.insert(args.end(), extra.begin(), extra.end());
    return tessref::test::run_program(TESSREF_EXE, args, fs::path(dir.file("")));
}

TEST(HostileHeader, DeclaredHugeImageIsRefusedBeforeAllocating) {
    // The header says 100000 x 100000 (10^10 samples); the file holds 4 bytes. The loader
    // must refuse from the header, before allocating gigabytes, naming the file and size.
    const std::string huge = hostile("declares_100000x100000.pgm");
    {
        const MemoryLimit limit(std::uint64_t{1} << 30);
        const auto start = std::chrono::steady_clock::now();
        expect_error([&] { tessref::load_height_field(huge); }, huge, "height map of 100000 x 100000 samples needs");
        expect_error([&] { tessref::load_height_field(huge); }, huge, "more than the limit of 1.0 GiB");
        expect_error([&] { tessref::load_texture(huge); }, huge, "texture of 100000 x 100000 texels needs");
        EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
    }
    // The command: exit 2 with that message, quickly, nothing written. With the default
    // limit (3/4 of physical memory) the refusal is the memory one below 140 GB of RAM and
    // the per-side limit (16384) above; either way it names the file and the size.
    TempDir dir;
    terrain_scene(dir, huge);
    const auto start = std::chrono::steady_clock::now();
    const auto limited = run_mesh(dir, {"--max-memory", "1G"});
    EXPECT_EQ(limited.status, 2) << limited.err;
    EXPECT_NE(limited.err.find("height map of 100000 x 100000 samples needs"), std::string::npos) << limited.err;
    EXPECT_NE(limited.err.find(huge), std::string::npos) << limited.err;
    const auto by_default = run_mesh(dir, {});
    EXPECT_EQ(by_default.status, 2) << by_default.err;
    EXPECT_NE(by_default.err.find("100000"), std::string::npos) << by_default.err;
    EXPECT_NE(by_default.err.find(huge), std::string::npos) << by_default.err;
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(20));
    EXPECT_FALSE(fs::exists(dir.file("out.ply")));
}

TEST(HostileHeader, ARaisedLimitGetsAsFarAsTheTruncation) {
    // 3000 x 3000 declared over 4 bytes: about 100 MB with the mip pyramid. Under a 10 MB
    // limit it is refused from the header; under 4 GB it is read and found truncated.
    const std::string file = hostile("declares_3000x3000.pgm");
    {
        const MemoryLimit limit(10 << 20);
        expect_error([&] { tessref::load_height_field(file); }, file, "height map of 3000 x 3000 samples needs");
        expect_error([&] { tessref::load_texture(file); }, file, "texture of 3000 x 3000 texels needs");
    }
    {
        const MemoryLimit limit(std::uint64_t{4} << 30);
        expect_error([&] { tessref::load_height_field(file); }, file, "truncated or corrupt");
        expect_error([&] { tessref::load_texture(file); }, file, "truncated or corrupt");
    }
    TempDir dir;
    terrain_scene(dir, file);
    const auto refused = run_mesh(dir, {"--max-memory", "10M"});
    EXPECT_EQ(refused.status, 2);
    EXPECT_NE(refused.err.find("3000 x 3000 samples needs"), std::string::npos) << refused.err;
    const auto truncated = run_mesh(dir, {"--max-memory", "4G"});
    EXPECT_EQ(truncated.status, 2);
    EXPECT_NE(truncated.err.find("truncated or corrupt"), std::string::npos) << truncated.err;
    EXPECT_NE(truncated.err.find(file), std::string::npos) << truncated.err;
    EXPECT_FALSE(fs::exists(dir.file("out.ply")));
}

TEST(HostileHeader, TheMipChainIsCheckedAgainstTheLimit) {
    // 1024 x 1024 floats (4 MiB, held by the caller); levels 1.. hold about 349525 samples
    // at 12 bytes (float and double), about 4 MiB more: over a 1 MiB limit.
    std::vector<float> texels(1024 * 1024, 0.5f);
    const MemoryLimit limit(1 << 20);
    try {
        Texture::from_float(1024, 1024, 1, std::move(texels));
        ADD_FAILURE() << "mip chain built over the limit";
    } catch (const tessref::Error& e) {
        EXPECT_NE(std::string(e.what()).find("mip chain of a 1024 x 1024 texture"), std::string::npos) << e.what();
    }
    // The figure itself, by hand: levels 1024^2, 512^2, ..., 1^2; level 0 at 4 bytes, the
    // others at 12 (and one more per sample everywhere for unorm8 codes).
    std::uint64_t above = 0;
    for (std::uint64_t side = 512; side >= 1; side /= 2) above += side * side;
    EXPECT_EQ(tessref::texture_memory_bytes(1024, 1024, 1, TexelFormat::float32), 4 * 1024 * 1024 + 12 * above);
    EXPECT_EQ(tessref::texture_memory_bytes(1024, 1024, 1, TexelFormat::unorm8), 5 * 1024 * 1024 + 13 * above);
    // A 4 x 1 RGBA texture: levels 4x1, 2x1, 1x1.
    EXPECT_EQ(tessref::texture_memory_bytes(4, 1, 4, TexelFormat::unorm16), 4 * 4 * 4 + 12 * 4 * (2 + 1));
    EXPECT_GT(tessref::texture_memory_bytes(100000, 100000, 4, TexelFormat::float32), 160'000'000'000u);
    // 2^62 samples of 16 bytes: saturates instead of wrapping around to a small figure.
    const int most = std::numeric_limits<int>::max();
    EXPECT_EQ(tessref::texture_memory_bytes(most, most, 4, TexelFormat::float32),
              std::numeric_limits<std::uint64_t>::max());
}

TEST(HostileHeader, PgmMaxvalMustBeWithinOneTo65535) {
    // netpbm: 0 < maxval < 65536. OpenImageIO 2.4.7 accepts 0 (reading every sample as 1)
    // and 70000 (reading 16-bit samples scaled by 70000).
    const std::string zero = hostile("maxval_0.pgm");
    expect_error([&] { tessref::load_height_field(zero); }, zero, "PGM with maxval 0;");
    expect_error([&] { tessref::load_texture(zero); }, zero, "PGM with maxval 0;");
    const std::string above = hostile("maxval_70000.pgm");
    expect_error([&] { tessref::load_height_field(above); }, above, "PGM with maxval 70000;");
    // 65535 is the largest valid maxval: codes 0, 100, 1000, 30000 read as code / 65535.
    const tessref::HeightField field = tessref::load_height_field(hostile("maxval_65535.pgm"));
    EXPECT_EQ(field.texture.format(), TexelFormat::unorm16);
    EXPECT_EQ(field.info.bits_per_sample, 16);
    const int codes[4] = {0, 100, 1000, 30000};
    for (int i = 0; i < 4; ++i)
        EXPECT_EQ(field.texture.texel_exact(0, i % 2, i / 2), codes[i] / 65535.0) << i;
    // A maxval of 1023 is valid: 10 bits per sample, as heightfield.h says.
    TempDir dir;
    const std::string ten_bits = dir.file("ten.pgm");
    write_bytes(ten_bits, std::string("P5\n2 2\n1023\n") + std::string("\x00\x00\x01\x00\x02\x00\x03\xff", 8));
    EXPECT_EQ(tessref::load_height_field(ten_bits).info.bits_per_sample, 10);
}

TEST(HostileHeader, PfmHeaderLines) {
    const std::string bad_scale = hostile("pfm_bad_scale.pfm");
    expect_error([&] { tessref::load_height_field(bad_scale); }, bad_scale, "PFM whose scale 'abc'");
    // Scale 0 has no sign, so no byte order; OpenImageIO 2.4.7 reads it as big endian.
    const std::string zero_scale = hostile("pfm_zero_scale.pfm");
    expect_error([&] { tessref::load_height_field(zero_scale); }, zero_scale, "PFM whose scale '0'");
    expect_error([&] { tessref::load_texture(zero_scale); }, zero_scale, "PFM whose scale '0'");
    const std::string negative = hostile("pfm_negative_width.pfm");
    expect_error([&] { tessref::load_height_field(negative); }, negative, "has no pixels: its header says -2 x 2");
    expect_error([&] { tessref::load_texture(negative); }, negative, "has no pixels: its header says -2 x 2");
    const std::string zero_width = hostile("pfm_zero_width.pfm");
    expect_error([&] { tessref::load_height_field(zero_width); }, zero_width, "has no pixels: its header says 0 x 2");
}

TEST(HostileHeader, ZeroSizeAndOneByOne) {
    const std::string zero = hostile("zero_size.pgm");
    expect_error([&] { tessref::load_height_field(zero); }, zero, "has no pixels: its header says 0 x 0");
    expect_error([&] { tessref::load_texture(zero); }, zero, "has no pixels: its header says 0 x 0");
    // One sample has no extent as a height field, but is a valid (constant) texture.
    const std::string one = hostile("one_by_one.pgm");
    expect_error([&] { tessref::load_height_field(one); }, one, "at least 2x2");
    const Texture texture = tessref::load_texture(one);
    EXPECT_EQ(texture.width(), 1);
    EXPECT_EQ(texture.level_count(), 1);
    EXPECT_EQ(texture.texel_exact(0, 0, 0), 7.0 / 255.0);
}

TEST(HostileHeader, CorruptPngAndTiff) {
    struct Case {
        const char* name;
        const char* fragment;
    };
    const Case cases[] = {
        {"png_bad_header_crc.png", "cannot read"},            // refused at open (header)
        {"png_bad_pixel_data.png", "truncated or corrupt"},   // refused reading pixels
        {"tiff_bad_ifd_offset.tif", "cannot read"},
        // OpenImageIO 2.4.7 reports success here with its error set: must not pass as zeros.
        {"tiff_strip_past_end.tif", "truncated or corrupt"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        const std::string path = hostile(c.name);
        expect_error([&] { tessref::load_height_field(path); }, path, c.fragment);
        expect_error([&] { tessref::load_texture(path); }, path, c.fragment);
    }
}

TEST(BadInput, NanSampleIsMissingInEveryFloatFormat) {
    // PFM, float TIFF, float and half EXR: the NaN policy sees the samples after
    // OpenImageIO's conversion, whatever the file's type (PGM and PNG hold integers only;
    // their missing samples are the nodata value, tested above).
    const std::string pfm = hostile("nan_sample.pfm");
    try {
        tessref::load_height_field(pfm);
        ADD_FAILURE() << "NaN accepted";
    } catch (const tessref::Error& e) {
        EXPECT_EQ(e.where().key, "texel(1,2)");  // stored bottom row, column 1: see make_files.py
        EXPECT_NE(std::string(e.what()).find("is NaN"), std::string::npos) << e.what();
    }
    HeightFieldOptions mean;
    mean.nodata_policy = NodataPolicy::fill_neighbour_mean;
    EXPECT_EQ(tessref::load_height_field(pfm, mean).texture.texel(0, 1, 2), 1.0f);
    TempDir dir;
    std::vector<float> values(3 * 2, 0.25f);
    values[1 * 3 + 2] = std::numeric_limits<float>::quiet_NaN();  // (2, 1)
    for (const char* name : {"nan.tif", "nan.exr"}) {
        const std::string path = dir.file(name);
        write_image(path, 3, 2, 1, OIIO::TypeDesc::FLOAT, values.data());
        expect_error([&] { tessref::load_height_field(path); }, path, "texel (2, 1) is NaN");
    }
    const std::string half = dir.file("nan_half.exr");
    write_image(half, 3, 2, 1, OIIO::TypeDesc::HALF, std::vector<std::uint16_t>{0x3400, 0x3400, 0x3400, 0x3400,
                                                                               0x3400, 0x7e00}.data());
    expect_error([&] { tessref::load_height_field(half); }, half, "texel (2, 1) is NaN");
}

// The mip pyramid and the thesis normal map are built rows in parallel: every level, every
// format and both mipmap rules hold the same texels, codes and doubles with one thread as
// with all of them (odd and non-power-of-two sizes, a random height field).
TEST(TextureBuild, OneThreadBuildsTheSamePyramidAndNormalMap) {
    const int w = 173, h = 94;
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> code(0, 65535);
    std::vector<std::uint16_t> c16(static_cast<std::size_t>(w) * h);
    for (auto& c : c16) c = static_cast<std::uint16_t>(code(rng));
    std::vector<std::uint8_t> c8(c16.size() * 3);
    for (auto& c : c8) c = static_cast<std::uint8_t>(code(rng) & 0xFF);
    std::vector<float> f(c16.size() * 2);
    for (auto& v : f) v = static_cast<float>(code(rng)) / 65535.0f;
    auto build_all = [&] {
        std::vector<Texture> out;
        for (const MipmapRule rule : {MipmapRule::llvmpipe_blit, MipmapRule::mesa_software_box}) {
            out.push_back(Texture::from_unorm16(w, h, 1, c16, rule));
            out.push_back(Texture::from_unorm8(w, h, 3, c8, rule));
            out.push_back(Texture::from_float(w, h, 2, f, rule));
            out.push_back(tessref::thesis_normal_map(out.front(), 0.7, 13.0, rule));
        }
        return out;
    };
    const std::vector<Texture> many = build_all();
    std::vector<Texture> one;
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
        one = build_all();
    }
    ASSERT_EQ(one.size(), many.size());
    for (std::size_t t = 0; t < one.size(); ++t) {
        SCOPED_TRACE("texture " + std::to_string(t));
        ASSERT_EQ(one[t].level_count(), many[t].level_count());
        ASSERT_GT(one[t].level_count(), 7);
        for (int lod = 0; lod < one[t].level_count(); ++lod) {
            const tessref::TextureLevel& a = one[t].level(lod);
            const tessref::TextureLevel& b = many[t].level(lod);
            EXPECT_TRUE(a.texels == b.texels) << "lod " << lod;  // NaN-free: == is bitwise here
            EXPECT_TRUE(a.unorm8 == b.unorm8) << "lod " << lod;
            // The double path (levels >= 1 computed on this first read).
            bool same_exact = true;
            for (int y = 0; y < a.height; ++y)
                for (int x = 0; x < a.width; ++x)
                    for (int c = 0; c < one[t].channels(); ++c)
                        same_exact = same_exact && one[t].texel_exact(lod, x, y, c) == many[t].texel_exact(lod, x, y, c);
            EXPECT_TRUE(same_exact) << "lod " << lod;
        }
    }
}

// ---- normals ------------------------------------------------------------------------------

TEST(Normals, ThesisNormalMapOfAPlaneIsTheAnalyticNormal) {
    // height(x, y) = 0.5 + a x + b y (texel units). With texel spacing d and height scale k the
    // surface z = k (0.5 + a X/d + b Y/d) has the normal (-k a / d, -k b / d, 1), normalized.
    const int w = 16, h = 12;
    for (const auto& [a, b] : {std::pair{0.01, -0.02}, std::pair{0.0, 0.0}, std::pair{-0.03, 0.015}}) {
        std::vector<float> v(w * h);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) v[y * w + x] = static_cast<float>(0.5 + a * x + b * y);
        const Texture height = Texture::from_float(w, h, 1, v);
        const double d = 0.5, k = 10.0;
        const Texture normals = tessref::thesis_normal_map(height, d, k);
        ASSERT_EQ(normals.channels(), 3);
        ASSERT_EQ(normals.format(), TexelFormat::unorm8);
        // The heights are floats: the plane is exact to about 1e-7 per texel.
        const glm::dvec3 analytic = glm::normalize(glm::dvec3(-k * a / d, -k * b / d, 1.0));
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
                const glm::dvec3 rgb(normals.texel(0, x, y, 0), normals.texel(0, x, y, 1), normals.texel(0, x, y, 2));
                const glm::dvec3 decoded = tessref::decode_unorm_normal(rgb);
                for (int c = 0; c < 3; ++c) {
                    // Truncation to k/255 loses up to 1/255 in rgb, 2/255 in the decoded normal.
                    EXPECT_LE(analytic[c] - decoded[c], 2.0 / 255.0 + 1e-6) << x << "," << y;
                    EXPECT_GE(analytic[c] - decoded[c], -1e-6) << x << "," << y;
                }
            }
        }
    }
    // The thesis's split: a flat texel encodes (127, 127, 255).
    const Texture flat = Texture::from_float(3, 3, 1, std::vector<float>(9, 0.25f));
    const auto codes = tessref::thesis_normal_map_codes(flat, 1.0, 1.0);
    EXPECT_EQ(codes[12], 127);
    EXPECT_EQ(codes[13], 127);
    EXPECT_EQ(codes[14], 255);
}

// The normal map is the thesis's loop, texel by texel as written (section 4.7.4, the
// positions P of the texel and its four edge-clamped neighbours, four cross products summed
// and normalized, each component encoded), code for code: for every size from 1 x 1 up
// (edge columns and rows, odd and even widths), every format, rough and smooth heights.
TEST(Normals, ThesisNormalMapIsTheThesisLoopTexelByTexel) {
    auto reference = [](const Texture& map, double d, double k) {
        const int w = map.width(), h = map.height();
        std::vector<std::uint8_t> codes(static_cast<std::size_t>(w) * h * 3);
        auto P = [&](int x, int y) {
            x = std::clamp(x, 0, w - 1);
            y = std::clamp(y, 0, h - 1);
            return glm::dvec3(x * d, y * d, map.texel_exact(0, x, y) * k);
        };
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const glm::dvec3 p = P(x, y);
                const glm::dvec3 right = P(x + 1, y) - p, up = P(x, y + 1) - p, left = P(x - 1, y) - p,
                                 down = P(x, y - 1) - p;
                const glm::dvec3 sum =
                    glm::cross(right, up) + glm::cross(up, left) + glm::cross(left, down) + glm::cross(down, right);
                const double length = glm::length(sum);
                const glm::dvec3 n = length > 0.0 ? sum / length : glm::dvec3(0.0, 0.0, 1.0);
                for (int c = 0; c < 3; ++c)
                    codes[(static_cast<std::size_t>(y) * w + x) * 3 + c] =
                        static_cast<std::uint8_t>(std::clamp((n[c] * 0.5 + 0.5) * 255.0, 0.0, 255.0));
            }
        return codes;
    };
    std::mt19937 rng(5);
    std::uniform_int_distribution<int> code(0, 65535);
    const std::pair<int, int> sizes[] = {{1, 1}, {1, 6}, {6, 1}, {2, 2}, {3, 3}, {4, 4}, {5, 3},
                                         {7, 2}, {8, 9}, {37, 23}, {64, 40}, {403, 37}};
    for (const auto& [w, h] : sizes) {
        for (const bool smooth : {false, true}) {
            const std::size_t n = static_cast<std::size_t>(w) * h;
            std::vector<std::uint16_t> c16(n);
            std::vector<std::uint8_t> c8(n);
            std::vector<float> f(n);
            for (std::size_t i = 0; i < n; ++i) {
                const int x = static_cast<int>(i % w), y = static_cast<int>(i / w);
                const int v = smooth ? (x * 37 + y * 91 + (x * y) % 7) % 65536 : code(rng);
                c16[i] = static_cast<std::uint16_t>(v);
                c8[i] = static_cast<std::uint8_t>(smooth ? v / 257 : v & 0xFF);
                f[i] = (static_cast<float>(v) - 20000.0f) * 3.7f;
            }
            for (const Texture& map : {Texture::from_unorm16(w, h, 1, c16), Texture::from_unorm8(w, h, 1, c8),
                                       Texture::from_float(w, h, 1, f)}) {
                for (const auto& [d, k] : {std::pair{0.7, 13.0}, std::pair{310.0 / 403, 16.8}, std::pair{2.0, -0.01}}) {
                    SCOPED_TRACE(std::string(to_string(map.format())) + " " + std::to_string(w) + "x" +
                                 std::to_string(h) + (smooth ? " smooth" : " rough") + " d " + std::to_string(d) +
                                 " k " + std::to_string(k));
                    const std::vector<std::uint8_t> got = tessref::thesis_normal_map_codes(map, d, k);
                    const std::vector<std::uint8_t> want = reference(map, d, k);
                    ASSERT_EQ(got.size(), want.size());
                    std::size_t differ = 0, first = 0;
                    for (std::size_t i = got.size(); i-- > 0;)
                        if (got[i] != want[i]) ++differ, first = i;
                    EXPECT_EQ(differ, 0u) << "first at texel " << first / 3 << " channel " << first % 3;
                }
            }
        }
    }
}

// ---- the independent peer: Mesa llvmpipe through OSMesa -----------------------------------

bool cpu_has_fma() {
#if defined(__x86_64__) || defined(__i386__)
    return __builtin_cpu_supports("fma");
#else
    return false;
#endif
}

class GlPeer : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        const int attribs[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                               OSMESA_CONTEXT_MAJOR_VERSION, 4, OSMESA_CONTEXT_MINOR_VERSION, 5, 0};
        context_ = OSMesaCreateContextAttribs(attribs, nullptr);
        if (context_ == nullptr) return;
        framebuffer_.assign(16 * 16 * 4, 0);
        if (!OSMesaMakeCurrent(context_, framebuffer_.data(), GL_UNSIGNED_BYTE, 16, 16)) {
            OSMesaDestroyContext(context_);
            context_ = nullptr;
        }
    }
    static void TearDownTestSuite() {
        if (context_ != nullptr) OSMesaDestroyContext(context_);
        context_ = nullptr;
    }
    void SetUp() override {
        if (context_ == nullptr) GTEST_FAIL() << "no OSMesa OpenGL 4.5 core context";
    }

    static OSMesaContext context_;
    static std::vector<unsigned char> framebuffer_;
};
OSMesaContext GlPeer::context_ = nullptr;
std::vector<unsigned char> GlPeer::framebuffer_;

struct GlFormat {
    GLenum internal_format;
    GLenum format;
    GLenum type;
};

GlFormat gl_format(TexelFormat f, int channels) {
    static const GLenum base[4] = {GL_RED, GL_RG, GL_RGB, GL_RGBA};
    static const GLenum i8[4] = {GL_R8, GL_RG8, GL_RGB8, GL_RGBA8};
    static const GLenum i16[4] = {GL_R16, GL_RG16, GL_RGB16, GL_RGBA16};
    static const GLenum i32f[4] = {GL_R32F, GL_RG32F, GL_RGB32F, GL_RGBA32F};
    const int k = channels - 1;
    switch (f) {
        case TexelFormat::unorm8: return {i8[k], base[k], GL_UNSIGNED_BYTE};
        case TexelFormat::unorm16: return {i16[k], base[k], GL_UNSIGNED_SHORT};
        case TexelFormat::float32: break;
    }
    return {i32f[k], base[k], GL_FLOAT};
}

// Uploads level 0 as the seeds do (rows in order), generates the mip pyramid in GL.
GLuint upload(const Texture& tex, const void* level0) {
    const GlFormat f = gl_format(tex.format(), tex.channels());
    GLuint name = 0;
    glGenTextures(1, &name);
    glBindTexture(GL_TEXTURE_2D, name);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, static_cast<GLint>(f.internal_format), tex.width(), tex.height(), 0, f.format,
                 f.type, level0);
    glGenerateMipmap(GL_TEXTURE_2D);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    return name;
}

// Compares every generated level with GL's, as raw codes (unorm) or float bits (float32).
void expect_same_levels(const Texture& tex, GLuint name, const std::string& label) {
    glBindTexture(GL_TEXTURE_2D, name);
    const GlFormat f = gl_format(tex.format(), tex.channels());
    for (int k = 0; k < tex.level_count(); ++k) {
        GLint w = 0, h = 0;
        glGetTexLevelParameteriv(GL_TEXTURE_2D, k, GL_TEXTURE_WIDTH, &w);
        glGetTexLevelParameteriv(GL_TEXTURE_2D, k, GL_TEXTURE_HEIGHT, &h);
        ASSERT_EQ(w, tex.level(k).width) << label << " level " << k;
        ASSERT_EQ(h, tex.level(k).height) << label << " level " << k;
        const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h) *
                              static_cast<std::size_t>(tex.channels());
        std::size_t mismatches = 0;
        if (tex.format() == TexelFormat::float32) {
            std::vector<float> got(n);
            glGetTexImage(GL_TEXTURE_2D, k, f.format, GL_FLOAT, got.data());
            for (std::size_t i = 0; i < n; ++i)
                mismatches += std::bit_cast<std::uint32_t>(got[i]) != std::bit_cast<std::uint32_t>(tex.level(k).texels[i]);
        } else if (tex.format() == TexelFormat::unorm16) {
            std::vector<std::uint16_t> got(n);
            glGetTexImage(GL_TEXTURE_2D, k, f.format, GL_UNSIGNED_SHORT, got.data());
            for (std::size_t i = 0; i < n; ++i)
                mismatches += static_cast<float>(got[i]) * (1.0f / 65535.0f) != tex.level(k).texels[i];
        } else {
            std::vector<std::uint8_t> got(n);
            glGetTexImage(GL_TEXTURE_2D, k, f.format, GL_UNSIGNED_BYTE, got.data());
            for (std::size_t i = 0; i < n; ++i) mismatches += got[i] != tex.level(k).unorm8[i];
        }
        EXPECT_EQ(mismatches, 0u) << label << ": level " << k << " (" << w << "x" << h << ") differs from llvmpipe's glGenerateMipmap";
    }
    EXPECT_EQ(glGetError(), static_cast<GLenum>(GL_NO_ERROR));
}

GLuint compile_sampling_program() {
    // A vertex shader (no derivatives, like a TES): z < -50 asks for texture(), otherwise
    // textureLod(st, z). Transform feedback returns the vec4.
    const char* source =
        "#version 450 core\n"
        "layout(location = 0) in vec3 st_lod;\n"
        "uniform sampler2D heightMap;\n"
        "out vec4 sampled;\n"
        "void main() {\n"
        "  sampled = st_lod.z < -50.0 ? texture(heightMap, st_lod.xy)\n"
        "                             : textureLod(heightMap, st_lod.xy, st_lod.z);\n"
        "  gl_Position = vec4(0.0);\n"
        "}\n";
    const GLuint shader = glCreateShader(GL_VERTEX_SHADER);
    glShaderSource(shader, 1, &source, nullptr);
    glCompileShader(shader);
    GLint ok = 0;
    glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    EXPECT_TRUE(ok);
    const GLuint program = glCreateProgram();
    glAttachShader(program, shader);
    const char* varyings[] = {"sampled"};
    glTransformFeedbackVaryings(program, 1, varyings, GL_INTERLEAVED_ATTRIBS);
    glLinkProgram(program);
    glGetProgramiv(program, GL_LINK_STATUS, &ok);
    EXPECT_TRUE(ok);
    glDeleteShader(shader);
    return program;
}

std::vector<glm::vec4> gl_sample(GLuint texture, const std::vector<glm::vec3>& queries) {
    static GLuint program = 0;
    if (program == 0) program = compile_sampling_program();
    glUseProgram(program);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, texture);
    glUniform1i(glGetUniformLocation(program, "heightMap"), 0);
    GLuint vao = 0, vbo = 0, tfb = 0;
    glGenVertexArrays(1, &vao);
    glBindVertexArray(vao);
    glGenBuffers(1, &vbo);
    glBindBuffer(GL_ARRAY_BUFFER, vbo);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(queries.size() * sizeof(glm::vec3)), queries.data(), GL_STATIC_DRAW);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
    glEnableVertexAttribArray(0);
    glGenBuffers(1, &tfb);
    glBindBufferBase(GL_TRANSFORM_FEEDBACK_BUFFER, 0, tfb);
    glBufferData(GL_TRANSFORM_FEEDBACK_BUFFER, static_cast<GLsizeiptr>(queries.size() * sizeof(glm::vec4)), nullptr, GL_STATIC_READ);
    glEnable(GL_RASTERIZER_DISCARD);
    glBeginTransformFeedback(GL_POINTS);
    glDrawArrays(GL_POINTS, 0, static_cast<GLsizei>(queries.size()));
    glEndTransformFeedback();
    glDisable(GL_RASTERIZER_DISCARD);
    std::vector<glm::vec4> out(queries.size());
    glGetBufferSubData(GL_TRANSFORM_FEEDBACK_BUFFER, 0, static_cast<GLsizeiptr>(out.size() * sizeof(glm::vec4)), out.data());
    glDeleteBuffers(1, &tfb);
    glDeleteBuffers(1, &vbo);
    glDeleteVertexArrays(1, &vao);
    EXPECT_EQ(glGetError(), static_cast<GLenum>(GL_NO_ERROR));
    return out;
}

std::vector<glm::vec3> sampling_queries(int levels, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> coord(-0.2f, 1.2f);
    std::uniform_real_distribution<float> lod(-1.0f, static_cast<float>(levels) + 0.5f);
    std::vector<glm::vec3> q;
    for (int i = 0; i < 6000; ++i) {
        float l = lod(rng);
        if (i % 4 == 0) l = 0.0f;
        if (i % 4 == 1) l = std::floor(l);
        if (i % 50 == 0) l = -100.0f;  // texture()
        q.emplace_back(coord(rng), coord(rng), l);
    }
    return q;
}

void expect_same_samples(const Texture& tex, GLuint name, const std::string& label) {
    const std::vector<glm::vec3> queries = sampling_queries(tex.level_count(), 99);
    const std::vector<glm::vec4> got = gl_sample(name, queries);
    std::size_t mismatches = 0;
    double worst_exact = 0.0;
    for (std::size_t i = 0; i < queries.size(); ++i) {
        const glm::vec2 st(queries[i].x, queries[i].y);
        const bool implicit = queries[i].z < -50.0f;
        const glm::vec4 ours = implicit ? tex.texture(st) : tex.textureLod(st, queries[i].z);
        const glm::dvec4 exact = implicit ? tex.texture(glm::dvec2(st)) : tex.textureLod(glm::dvec2(st), static_cast<double>(queries[i].z));
        for (int c = 0; c < 4; ++c) {
            if (std::bit_cast<std::uint32_t>(ours[c]) != std::bit_cast<std::uint32_t>(got[i][c])) {
                if (mismatches++ < 5)
                    ADD_FAILURE() << label << ": st (" << st.x << ", " << st.y << ") lod " << queries[i].z << " channel "
                                  << c << ": llvmpipe " << got[i][c] << ", tessref " << ours[c];
            }
            worst_exact = std::max(worst_exact, std::abs(exact[c] - static_cast<double>(got[i][c])) /
                                                    std::max(1.0, std::abs(exact[c])));
        }
    }
    EXPECT_EQ(mismatches, 0u) << label;
    // The accuracy path stays close to llvmpipe: apart from float rounding, GL's unorm mip
    // levels are quantized level after level (8-bit: a few codes by the last level).
    const double bound = tex.format() == TexelFormat::unorm8 ? 6.0 / 255.0 : 1e-4;
    EXPECT_LE(worst_exact, bound) << label;
    std::printf("[   INFO   ] %s: %zu samples x 4 channels bit-exact; double path within %.3g of llvmpipe\n",
                label.c_str(), queries.size(), worst_exact);
}

TEST_F(GlPeer, MipmapsAndSamplesMatchLlvmpipeBitForBit) {
    if (!cpu_has_fma()) GTEST_SKIP() << "llvmpipe rounds the lerp differently without FMA";
    struct Case {
        TexelFormat format;
        int width, height, channels;
    };
    const Case cases[] = {
        {TexelFormat::float32, 37, 23, 1}, {TexelFormat::float32, 64, 32, 1}, {TexelFormat::float32, 13, 7, 4},
        {TexelFormat::float32, 111, 111, 1}, {TexelFormat::unorm16, 37, 23, 1}, {TexelFormat::unorm16, 5, 300, 1},
        {TexelFormat::unorm8, 37, 23, 1},  {TexelFormat::unorm8, 19, 13, 2},  {TexelFormat::unorm8, 21, 17, 3},
        {TexelFormat::unorm8, 64, 48, 4},   {TexelFormat::unorm16, 1, 37, 1},  {TexelFormat::unorm8, 45, 1, 3},
        {TexelFormat::float32, 3, 1, 2},
    };
    unsigned seed = 100;
    for (const Case& c : cases) {
        const std::size_t n = static_cast<std::size_t>(c.width) * c.height * c.channels;
        const std::string label = std::string(to_string(c.format)) + " " + std::to_string(c.width) + "x" +
                                  std::to_string(c.height) + "x" + std::to_string(c.channels);
        SCOPED_TRACE(label);
        Texture tex;
        GLuint name = 0;
        if (c.format == TexelFormat::float32) {
            const auto v = random_floats(n, ++seed);
            tex = Texture::from_float(c.width, c.height, c.channels, v);
            name = upload(tex, v.data());
        } else if (c.format == TexelFormat::unorm16) {
            const auto v = random_codes<std::uint16_t>(n, ++seed);
            tex = Texture::from_unorm16(c.width, c.height, c.channels, v);
            name = upload(tex, v.data());
        } else {
            const auto v = random_codes<std::uint8_t>(n, ++seed);
            tex = Texture::from_unorm8(c.width, c.height, c.channels, v);
            name = upload(tex, v.data());
        }
        expect_same_levels(tex, name, label);
        expect_same_samples(tex, name, label);
        glDeleteTextures(1, &name);
    }
}

TEST_F(GlPeer, TheRealMapsMatchLlvmpipe) {
    if (!cpu_has_fma()) GTEST_SKIP() << "llvmpipe rounds the lerp differently without FMA";
    // jacksboro as GL_R16 (odd width: every level but the last two is an odd blit), olinda as
    // GL_R32F; uploaded from the files' own samples.
    for (const char* name : {"/jacksboro_fault_dem.pgm", "/olinda_dem_utm25s.tif"}) {
        const std::string path = std::string(TESSREF_DATA_DIR) + name;
        SCOPED_TRACE(path);
        const tessref::HeightField field = tessref::load_height_field(path);
        const Texture& tex = field.texture;
        std::vector<std::uint16_t> codes;
        const void* data = tex.level(0).texels.data();
        if (tex.format() == TexelFormat::unorm16) {
            for (float v : tex.level(0).texels) codes.push_back(static_cast<std::uint16_t>(std::lround(v * 65535.0)));
            data = codes.data();
        }
        const GLuint gl_name = upload(tex, data);
        expect_same_levels(tex, gl_name, path);
        expect_same_samples(tex, gl_name, path);
        glDeleteTextures(1, &gl_name);
    }
}

}  // namespace
