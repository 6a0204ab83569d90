// The image layer (src/image/): PNG and PNM without OpenImageIO, everything else through
// the module tessref_oiio.so loaded on first use.
//  - the hot path (tessref --version; a render of a PGM scene to PNG) never loads
//    libOpenImageIO, nor libOSMesa (the dynamic loader's own record, LD_DEBUG=libs);
//  - an EXR output loads the module and is written;
//  - the PNG and PNM readers give exactly the samples OpenImageIO gives (through the
//    module), header included, for every PNG and PNM in the repository and for PNGs of
//    every colour type and bit depth written here with libpng;
//  - without the module, an EXR is a clear error naming the places searched (exit 2),
//    while PNG still works.
#include <png.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "image/image_io.h"
#include "image/oiio_module.h"
#include "run_program.h"
#include "scratch_dir.h"
#include "tessref/error.h"

namespace {

namespace fs = std::filesystem;
using tessref::image::Image;
using tessref::image::SampleType;
using tessref::test::RunResult;
using tessref::test::run_program;

const fs::path kSource = TESSREF_SOURCE_DIR;

// Runs tessref with LD_DEBUG=libs (the loader's list of every library it loads, on stderr).
RunResult run_traced(const fs::path& dir, const std::vector<std::string>& args) {
    std::vector<std::string> env_args = {"LD_DEBUG=libs", TESSREF_EXE};
    env_args.insert(env_args.end(), args.begin(), args.end());
    return run_program("env", env_args, dir);
}

bool loaded(const RunResult& r, const std::string& library) {
    return r.err.find("calling init: ") != std::string::npos &&
           r.err.find("/" + library) != std::string::npos;
}

const tessref::test::ScratchDir& scratch = tessref::test::ScratchDir::add("image_io");

class ImageIo : public ::testing::Test {
protected:
    // A directory of this test's own.
    fs::path dir() const {
        const fs::path d = scratch() / ::testing::UnitTest::GetInstance()->current_test_info()->name();
        fs::create_directories(d);
        return d;
    }
};

TEST_F(ImageIo, VersionAndPgmRenderToPngNeverLoadOpenImageIO) {
    const RunResult version = run_traced(dir(), {"--version"});
    ASSERT_EQ(version.status, 0) << version.err.substr(0, 2000);
    EXPECT_TRUE(loaded(version, "libpng16.so")) << "LD_DEBUG gave no library list";
    EXPECT_FALSE(loaded(version, "libOpenImageIO")) << "tessref --version loaded OpenImageIO";

    // A scene whose height map and texture are PGM, written as PNG.
    const fs::path png = dir() / "grid.png";
    const RunResult render = run_traced(
        dir(), {"render", (kSource / "bench/scenes/jacksboro-grid-16.toml").string(), "--size", "160x100", "-o",
                      png.string()});
    ASSERT_EQ(render.status, 0) << render.err.substr(render.err.size() > 3000 ? render.err.size() - 3000 : 0);
    EXPECT_FALSE(loaded(render, "libOpenImageIO")) << "a PGM-to-PNG render loaded OpenImageIO";
    EXPECT_FALSE(loaded(render, "tessref_oiio.so"));
    // Nor libOSMesa (LLVM): the GL backend loads it on its first context only.
    EXPECT_FALSE(loaded(version, "libOSMesa"));
    EXPECT_FALSE(loaded(render, "libOSMesa"));
    const Image image = tessref::image::read_image(png.string());
    EXPECT_EQ(image.header.width, 160);
    EXPECT_EQ(image.header.height, 100);
    EXPECT_EQ(image.header.channels, 4);
}

TEST_F(ImageIo, ExrOutputLoadsTheModule) {
    const fs::path exr = dir() / "grid.exr";
    const RunResult render = run_traced(
        dir(), {"render", (kSource / "bench/scenes/jacksboro-grid-16.toml").string(), "--size", "40x25", "-o",
                      exr.string(), "--aov", "depth"});
    ASSERT_EQ(render.status, 0) << render.err.substr(render.err.size() > 3000 ? render.err.size() - 3000 : 0);
    EXPECT_TRUE(loaded(render, "tessref_oiio.so"));
    EXPECT_TRUE(loaded(render, "libOpenImageIO"));
    const Image image = tessref::image::read_image(exr.string());
    EXPECT_EQ(image.header.format, "openexr");
    EXPECT_EQ(image.header.type, SampleType::float32);
    EXPECT_EQ(image.header.width, 40);
    ASSERT_EQ(image.header.channels, 5);
    EXPECT_EQ(image.header.channel_names[4], "Z");
}

// ---- the readers against OpenImageIO ---------------------------------------------------

// The file as OpenImageIO reads it, through the module: samples in the file's type
// (uint8, uint16) or float, never premultiplied.
Image read_with_module(const std::string& path) {
    const tessref_oiio_api& oiio = tessref::image::oiio_module("the test", path);
    char error[512] = "";
    tessref_oiio_reader* reader = nullptr;
    tessref_oiio_header h{};
    if (oiio.open_reader(path.c_str(), &reader, &h, error, sizeof error) != 0)
        throw tessref::Error(std::string("OpenImageIO: ") + error);
    Image image;
    image.header.width = h.width;
    image.header.height = h.height;
    image.header.channels = image.channels = h.channels;
    image.header.type = h.type == TESSREF_OIIO_UINT8    ? SampleType::uint8
                        : h.type == TESSREF_OIIO_UINT16 ? SampleType::uint16
                                                        : SampleType::float32;
    image.header.pixel_type = h.pixel_type;
    image.header.alpha_channel = h.alpha_channel;
    for (int c = 0; c < h.channels; ++c) image.header.channel_names.emplace_back(oiio.channel_name(reader, c));
    if (h.width <= 0 || h.height <= 0 || h.channels <= 0 || std::int64_t{h.width} * h.height * h.channels > 100'000'000) {
        oiio.close_reader(reader);
        throw tessref::Error("OpenImageIO: no pixels or too many to compare");
    }
    const std::size_t n = static_cast<std::size_t>(h.width) * h.height * h.channels;
    void* pixels = nullptr;
    switch (image.header.type) {
        case SampleType::uint8: image.u8.resize(n); pixels = image.u8.data(); break;
        case SampleType::uint16: image.u16.resize(n); pixels = image.u16.data(); break;
        case SampleType::float32: image.f32.resize(n); pixels = image.f32.data(); break;
    }
    const int failed = oiio.read_pixels(reader, h.channels, h.type, pixels, error, sizeof error);
    oiio.close_reader(reader);
    if (failed) throw tessref::Error(std::string("OpenImageIO pixels: ") + error);
    return image;
}

// Where tessref reads the file, OpenImageIO reads it too, with the same header and the same
// samples, bit for bit. (The files tessref refuses are hostile ones whose refusal the
// heightfield tests check; OpenImageIO takes seconds to try every plugin on them.)
void expect_same_as_oiio(const fs::path& path, bool refusal_too = true) {
    SCOPED_TRACE(path.string());
    std::string ours_error, theirs_error;
    Image ours, theirs;
    try {
        ours = tessref::image::read_image(path.string());
    } catch (const tessref::Error& e) {
        ours_error = e.what();
    }
    if (!ours_error.empty() && !refusal_too) return;
    try {
        theirs = read_with_module(path.string());
    } catch (const tessref::Error& e) {
        theirs_error = e.what();
    }
    ASSERT_EQ(ours_error.empty(), theirs_error.empty()) << "tessref: " << ours_error << "\nOpenImageIO: " << theirs_error;
    if (!ours_error.empty()) return;
    EXPECT_EQ(ours.header.width, theirs.header.width);
    EXPECT_EQ(ours.header.height, theirs.header.height);
    ASSERT_EQ(ours.header.channels, theirs.header.channels);
    ASSERT_EQ(ours.header.type, theirs.header.type);
    EXPECT_EQ(ours.header.pixel_type, theirs.header.pixel_type);
    EXPECT_EQ(ours.header.alpha_channel, theirs.header.alpha_channel);
    EXPECT_EQ(ours.header.channel_names, theirs.header.channel_names);
    EXPECT_TRUE(ours.u8 == theirs.u8) << "8-bit samples differ";
    EXPECT_TRUE(ours.u16 == theirs.u16) << "16-bit samples differ";
    ASSERT_EQ(ours.f32.size(), theirs.f32.size());
    EXPECT_TRUE(ours.f32.empty() || std::memcmp(ours.f32.data(), theirs.f32.data(), ours.f32.size() * sizeof(float)) == 0)
        << "floats differ";  // bit for bit: NaN payloads and -0 included
}

// A PNG written with libpng as given: every colour type and bit depth tessref may meet.
struct PngSpec {
    const char* name;
    int color_type;
    int bit_depth;
    bool trns = false;
    bool interlaced = false;
    bool gamma = false;
};

void write_test_png(const fs::path& path, const PngSpec& spec) {
    const int w = 13, h = 7;
    std::FILE* file = std::fopen(path.c_str(), "wb");
    ASSERT_NE(file, nullptr);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    png_init_io(png, file);
    png_set_IHDR(png, info, w, h, spec.bit_depth, spec.color_type,
                 spec.interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    if (spec.color_type == PNG_COLOR_TYPE_PALETTE) {
        png_color palette[16];
        for (int i = 0; i < 16; ++i)
            palette[i] = {static_cast<png_byte>(i * 17), static_cast<png_byte>(255 - i * 13), static_cast<png_byte>(i * 7)};
        png_set_PLTE(png, info, palette, 1 << std::min(spec.bit_depth, 4));
        if (spec.trns) {
            png_byte alpha[3] = {0, 128, 200};
            png_set_tRNS(png, info, alpha, 3, nullptr);
        }
    } else if (spec.trns) {
        png_color_16 key{};
        key.gray = 1;
        key.red = 1;
        key.green = 2;
        key.blue = 3;
        png_set_tRNS(png, info, nullptr, 0, &key);
    }
    if (spec.gamma) png_set_gAMA(png, info, 1.0 / 2.2);
    png_write_info(png, info);
    const int channels = spec.color_type == PNG_COLOR_TYPE_GRAY         ? 1
                         : spec.color_type == PNG_COLOR_TYPE_GRAY_ALPHA ? 2
                         : spec.color_type == PNG_COLOR_TYPE_RGB        ? 3
                         : spec.color_type == PNG_COLOR_TYPE_RGB_ALPHA  ? 4
                                                                        : 1;
    const std::size_t row_bytes = (static_cast<std::size_t>(w) * channels * spec.bit_depth + 7) / 8;
    std::vector<png_byte> pixels(row_bytes * h);
    for (std::size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<png_byte>((i * 37 + i / 5) & 0xff);
    if (spec.color_type == PNG_COLOR_TYPE_PALETTE && spec.bit_depth == 8)
        for (png_byte& b : pixels) b &= 15;  // within the palette
    std::vector<png_bytep> rows(h);
    for (int y = 0; y < h; ++y) rows[y] = pixels.data() + y * row_bytes;
    png_write_image(png, rows.data());
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    std::fclose(file);
}

TEST_F(ImageIo, PngOfEveryKindReadsAsOpenImageIOReadsIt) {
    const PngSpec specs[] = {
        {"gray1.png", PNG_COLOR_TYPE_GRAY, 1},
        {"gray2.png", PNG_COLOR_TYPE_GRAY, 2},
        {"gray4.png", PNG_COLOR_TYPE_GRAY, 4},
        {"gray8.png", PNG_COLOR_TYPE_GRAY, 8},
        {"gray8-trns.png", PNG_COLOR_TYPE_GRAY, 8, true},
        {"gray16.png", PNG_COLOR_TYPE_GRAY, 16},
        {"gray16-trns.png", PNG_COLOR_TYPE_GRAY, 16, true},
        {"gray-alpha8.png", PNG_COLOR_TYPE_GRAY_ALPHA, 8},
        {"gray-alpha16.png", PNG_COLOR_TYPE_GRAY_ALPHA, 16},
        {"rgb8.png", PNG_COLOR_TYPE_RGB, 8},
        {"rgb8-trns.png", PNG_COLOR_TYPE_RGB, 8, true},
        {"rgb16.png", PNG_COLOR_TYPE_RGB, 16},
        {"rgba8.png", PNG_COLOR_TYPE_RGB_ALPHA, 8},
        {"rgba16.png", PNG_COLOR_TYPE_RGB_ALPHA, 16},
        {"rgba8-gamma.png", PNG_COLOR_TYPE_RGB_ALPHA, 8, false, false, true},
        {"palette1.png", PNG_COLOR_TYPE_PALETTE, 1},
        {"palette2.png", PNG_COLOR_TYPE_PALETTE, 2},
        {"palette4.png", PNG_COLOR_TYPE_PALETTE, 4},
        {"palette8.png", PNG_COLOR_TYPE_PALETTE, 8},
        {"palette8-trns.png", PNG_COLOR_TYPE_PALETTE, 8, true},
        {"palette4-trns.png", PNG_COLOR_TYPE_PALETTE, 4, true},
        {"rgb8-interlaced.png", PNG_COLOR_TYPE_RGB, 8, false, true},
        {"gray16-interlaced.png", PNG_COLOR_TYPE_GRAY, 16, false, true},
    };
    for (const PngSpec& spec : specs) {
        const fs::path path = dir() / spec.name;
        write_test_png(path, spec);
        expect_same_as_oiio(path);
    }
}

// The writer deflates bands of rows in parallel and joins them into one zlib stream
// (png.cpp). Every channel count, a single pixel, a single row and column, and images of
// many bands (noise, which deflate cannot shrink, and smooth ramps, which it does) must read
// back with their samples through libpng and OpenImageIO alike, which check every chunk's
// CRC and the stream's Adler-32.
TEST_F(ImageIo, WrittenPngsReadBackWithEverySample) {
    struct Size {
        int width, height;
    };
    const Size sizes[] = {{1, 1}, {1, 300}, {700, 1}, {3, 2}, {640, 500}, {1001, 777}};
    std::uint32_t state = 12345;
    auto noise = [&state] {
        state = state * 1664525u + 1013904223u;
        return static_cast<std::uint8_t>(state >> 24);
    };
    int written = 0;
    for (const Size size : sizes) {
        for (int channels = 1; channels <= 4; ++channels) {
            for (const bool smooth : {false, true}) {
                const std::size_t n = static_cast<std::size_t>(size.width) * size.height * channels;
                std::vector<std::uint8_t> samples(n);
                for (std::size_t i = 0; i < n; ++i)
                    samples[i] = smooth ? static_cast<std::uint8_t>((i / channels) % size.width + i % channels * 40) : noise();
                const fs::path path = dir() / ("w" + std::to_string(size.width) + "x" + std::to_string(size.height) + "c" +
                                               std::to_string(channels) + (smooth ? "s" : "n") + ".png");
                tessref::image::WriteOptions options;
                options.software_tag = written % 2 == 0;
                tessref::image::write_image(path.string(), {size.width, size.height, channels, SampleType::uint8, samples.data()},
                                            options);
                ++written;
                SCOPED_TRACE(path.filename().string());
                const Image back = tessref::image::read_image(path.string());
                ASSERT_EQ(back.header.width, size.width);
                ASSERT_EQ(back.header.height, size.height);
                ASSERT_EQ(back.header.channels, channels);
                EXPECT_TRUE(back.u8 == samples) << "the samples read back differ from those written";
                expect_same_as_oiio(path);
            }
        }
    }
}

TEST_F(ImageIo, EveryPngAndPnmOfTheRepositoryReadsAsOpenImageIOReadsIt) {
    int compared = 0;
    for (const char* root : {"data", "tests/data", "golden"}) {
        for (const auto& entry : fs::recursive_directory_iterator(kSource / root)) {
            if (!entry.is_regular_file()) continue;
            const std::string ext = entry.path().extension().string();
            if (ext == ".png") {
                expect_same_as_oiio(entry.path(), false);
                ++compared;
            } else if (ext == ".pgm" || ext == ".ppm" || ext == ".pfm" || ext == ".pbm") {
                // OpenImageIO 2.4.7 takes maxval 0 and above 65535, and misreads 16-bit values
                // above 32768 (see pnm.cpp): those files are compared only where it is right.
                const std::string text = tessref::test::read_file(entry.path()).substr(0, 1024);
                if (text.find("65535") != std::string::npos || text.find("70000") != std::string::npos ||
                    entry.path().filename().string().find("maxval") != std::string::npos ||
                    entry.path().filename().string().find("scale") != std::string::npos)
                    continue;
                expect_same_as_oiio(entry.path(), false);
                ++compared;
            }
        }
    }
    EXPECT_GE(compared, 20);
}

// The binary PNM samples as the format defines them (pnm.cpp): a sample v of maxval m is
// min(v, m) * 255 / m (m up to 255) or min(v, m) * 65535 / m (above), truncated, for every
// maxval kind (1, the full 255 and 65535, others, 16-bit values above 32768) and for all or
// only the first channels kept; the same file cut short anywhere is the error naming the
// file that it always was.
TEST_F(ImageIo, BinaryPnmSamplesAreTheirCodesScaledToTheFullRange) {
    std::uint32_t state = 12345;
    auto next = [&] { return state = state * 1664525u + 1013904223u; };
    int files = 0;
    for (const char magic : {'5', '6'}) {
        const int channels = magic == '5' ? 1 : 3;
        for (const int maxval : {1, 7, 200, 255, 256, 1000, 40000, 65535}) {
            for (const auto& [w, h] : {std::pair{1, 1}, std::pair{1, 6}, std::pair{9, 1}, std::pair{17, 5}}) {
                const bool wide = maxval > 255;
                const std::uint64_t full = wide ? 65535 : 255;
                std::vector<std::uint32_t> values(static_cast<std::size_t>(w) * h * channels);
                std::string bytes = "P" + std::string(1, magic) + "\n# a comment\n" + std::to_string(w) + " " +
                                    std::to_string(h) + "\n" + std::to_string(maxval) + "\n";
                const std::size_t header = bytes.size();
                for (std::uint32_t& v : values) {
                    // Mostly within maxval, sometimes above it (clamped to it) up to the type's top.
                    v = next() % 8 == 0 ? static_cast<std::uint32_t>(full - next() % 3)
                                        : next() % (static_cast<std::uint32_t>(maxval) + 1);
                    if (wide) bytes += static_cast<char>(v >> 8);
                    bytes += static_cast<char>(v & 0xFF);
                }
                const fs::path path = dir() / ("p" + std::string(1, magic) + "m" + std::to_string(maxval) + "w" +
                                               std::to_string(w) + "h" + std::to_string(h) + ".pnm");
                tessref::test::write_file(path, bytes);
                ++files;
                SCOPED_TRACE(path.filename().string());
                for (int keep = 1; keep <= channels; ++keep) {
                    tessref::image::ReadOptions options;
                    options.max_channels = keep;
                    const Image image = tessref::image::read_image(path.string(), options);
                    ASSERT_EQ(image.header.type, wide ? SampleType::uint16 : SampleType::uint8);
                    ASSERT_EQ(image.channels, keep);
                    const std::size_t n = static_cast<std::size_t>(w) * h * keep;
                    ASSERT_EQ(wide ? image.u16.size() : image.u8.size(), n);
                    for (std::size_t i = 0; i < n; ++i) {
                        const std::size_t texel = i / keep, c = i % keep;
                        const std::uint64_t v = values[texel * channels + c];
                        const std::uint64_t expected = std::min<std::uint64_t>(v, maxval) * full / maxval;
                        ASSERT_EQ(wide ? image.u16[i] : image.u8[i], expected) << "sample " << i << " keeping " << keep;
                    }
                }
                for (const std::size_t cut : {std::size_t{2}, header - 1, header, bytes.size() - 1}) {
                    const fs::path short_path = dir() / ("cut" + std::to_string(cut) + path.filename().string());
                    tessref::test::write_file(short_path, bytes.substr(0, cut));
                    try {
                        tessref::image::read_image(short_path.string());
                        ADD_FAILURE() << "a file cut at byte " << cut << " of " << bytes.size() << " was read";
                    } catch (const tessref::Error& e) {
                        EXPECT_EQ(e.where().file, short_path.string());
                        const std::string what = e.what();
                        if (cut >= header)
                            EXPECT_EQ(what, "image is truncated or corrupt: its " + std::to_string(w) + " x " +
                                                std::to_string(h) + " pixels cannot be read (its " +
                                                (wide ? "16" : "8") + "-bit samples end early)");
                        else if (cut == header - 1)
                            EXPECT_EQ(what, std::string("cannot read image: its ") + (magic == '5' ? "PGM" : "PPM") +
                                                " header ends without the whitespace before the samples");
                        else
                            EXPECT_NE(what.find("cannot read image: its "), std::string::npos) << what;
                    }
                }
            }
        }
    }
    EXPECT_EQ(files, 64);
}

// ---- without the module ------------------------------------------------------------------

TEST_F(ImageIo, WithoutTheModuleExrIsAClearErrorAndPngStillWorks) {
    // The executable alone in a directory: no module beside it, none in ../lib/tessref.
    const fs::path bin = dir() / "alone" / "bin";
    fs::create_directories(bin);
    fs::copy_file(TESSREF_EXE, bin / "tessref");
    const std::string scene = (kSource / "bench/scenes/jacksboro-grid-16.toml").string();
    const auto run = [&](const fs::path& out) {
        return run_program("env", {"-u", "TESSREF_OIIO_MODULE", "TESSREF_DATA_DIR=" + (kSource / "data").string(),
                                   (bin / "tessref").string(), "render", scene, "--size", "40x25", "-o", out.string()},
                           dir());
    };
    const RunResult exr = run(dir() / "x.exr");
    EXPECT_EQ(exr.status, 2) << exr.err;
    EXPECT_NE(exr.err.find("tessref: error: "), std::string::npos) << exr.err;
    EXPECT_NE(exr.err.find("tessref_oiio.so"), std::string::npos) << exr.err;
    EXPECT_NE(exr.err.find("searched: TESSREF_OIIO_MODULE (unset), " + (dir() / "alone/lib/tessref/tessref_oiio.so").string() +
                           ", " + (bin / "tessref_oiio.so").string()),
              std::string::npos)
        << exr.err;
    EXPECT_FALSE(fs::exists(dir() / "x.exr"));
    const RunResult png = run(dir() / "x.png");
    EXPECT_EQ(png.status, 0) << png.err;
    EXPECT_TRUE(fs::exists(dir() / "x.png"));

    // TESSREF_OIIO_MODULE names it.
    const RunResult named = run_program(
        "env", {"TESSREF_OIIO_MODULE=" + std::string(TESSREF_OIIO_MODULE_FILE), "TESSREF_DATA_DIR=" + (kSource / "data").string(),
                (bin / "tessref").string(), "render", scene, "--size", "40x25", "-o", (dir() / "y.exr").string()},
        dir());
    EXPECT_EQ(named.status, 0) << named.err;
    EXPECT_TRUE(fs::exists(dir() / "y.exr"));

    // Named wrongly, it is the only place looked at, even beside a module in the build tree.
    const std::string wrong = (dir() / "no-such-module.so").string();
    const RunResult misnamed = run_program(
        "env", {"TESSREF_OIIO_MODULE=" + wrong, TESSREF_EXE, "render", scene, "--size", "40x25", "-o", (dir() / "z.exr").string()},
        dir());
    EXPECT_EQ(misnamed.status, 2) << misnamed.err;
    EXPECT_NE(misnamed.err.find("searched: " + wrong + "; set TESSREF_OIIO_MODULE"), std::string::npos) << misnamed.err;
    EXPECT_FALSE(fs::exists(dir() / "z.exr"));
}

}  // namespace
