// Reading and writing the float pictures of tessref/compare.h through OpenImageIO.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include <OpenImageIO/imageio.h>

#include "tessref/compare.h"
#include "tessref/error.h"
#include "tessref/limits.h"

namespace tessref {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw Error(what, Where::in_file(path)); }

std::string trimmed(std::string text) {
    while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
    return text;
}

// Integer codes to [0, 1] as code / max, rounded once (double to float): OpenImageIO's own
// conversion multiplies by a float reciprocal, which can be an ulp off code/255.
template <typename Code>
void codes_to_float(const std::vector<Code>& codes, double max, std::vector<float>& out) {
    out.resize(codes.size());
    for (std::size_t i = 0; i < codes.size(); ++i) out[i] = static_cast<float>(static_cast<double>(codes[i]) / max);
}

}  // namespace

FloatImage read_float_image(const std::string& path) {
    std::error_code ec;
    const std::filesystem::path fs_path(path);
    if (!std::filesystem::exists(fs_path, ec)) fail(path, "image not found");
    if (std::filesystem::is_directory(fs_path, ec)) fail(path, "is a directory, not an image");
    const auto bytes = std::filesystem::file_size(fs_path, ec);
    if (!ec && bytes == 0) fail(path, "is an empty file (0 bytes), not an image");

    // The samples as stored: OpenImageIO would otherwise premultiply colour by alpha on
    // read, which neither GL's framebuffer nor tessref's writer did.
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto input = OIIO::ImageInput::open(path, &config);
    if (!input) {
        const std::string reason = trimmed(OIIO::geterror());
        fail(path, "cannot read the image: " + (reason.empty() ? std::string("unknown image format") : reason));
    }
    const OIIO::ImageSpec& spec = input->spec();
    if (spec.deep) fail(path, "is a deep image; compare reads flat images only");
    if (spec.width <= 0 || spec.height <= 0 || spec.depth != 1 || spec.nchannels <= 0)
        fail(path, "the image has no pixels to compare (" + std::to_string(spec.width) + "x" +
                       std::to_string(spec.height) + "x" + std::to_string(spec.depth) + ", " +
                       std::to_string(spec.nchannels) + " channels)");

    FloatImage image;
    image.width = spec.width;
    image.height = spec.height;
    image.channels = spec.nchannels;
    image.alpha_channel = spec.alpha_channel;
    image.channel_names.assign(spec.channelnames.begin(), spec.channelnames.end());
    const std::uint64_t count = saturating_bytes(
        saturating_bytes(static_cast<std::uint64_t>(spec.width), static_cast<std::uint64_t>(spec.height)),
        static_cast<std::uint64_t>(spec.nchannels));
    // The floats plus, for an integer file, its codes (at most 2 bytes each) read first.
    const bool integer_file = spec.channelformats.empty() &&
                              (spec.format == OIIO::TypeDesc::UINT8 || spec.format == OIIO::TypeDesc::UINT16);
    require_memory(saturating_bytes(count, integer_file ? 4 + spec.format.size() : 4),
                   "image of " + std::to_string(spec.width) + " x " + std::to_string(spec.height) + " pixels, " +
                       std::to_string(spec.nchannels) + " channels",
                   Where::in_file(path));

    bool ok = false;
    if (integer_file && spec.format == OIIO::TypeDesc::UINT8) {
        std::vector<std::uint8_t> codes(static_cast<std::size_t>(count));
        ok = input->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, codes.data());
        if (ok) codes_to_float(codes, 255.0, image.samples);
    } else if (integer_file) {
        std::vector<std::uint16_t> codes(static_cast<std::size_t>(count));
        ok = input->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT16, codes.data());
        if (ok) codes_to_float(codes, 65535.0, image.samples);
    } else {
        image.samples.resize(static_cast<std::size_t>(count));
        ok = input->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, image.samples.data());
    }
    if (!ok) {
        const std::string reason = trimmed(input->geterror());
        fail(path, "cannot read the pixels of the image: " +
                       (reason.empty() ? std::string("corrupt or truncated file") : reason));
    }
    input->close();
    return image;
}

void write_float_image(const FloatImage& image, const std::string& path) {
    auto output = OIIO::ImageOutput::create(path);
    if (!output) {
        const std::string reason = trimmed(OIIO::geterror());
        fail(path, "no image format for this name: give it an extension OpenImageIO writes, such as .png, .tif or .exr" +
                       (reason.empty() ? std::string() : " (" + reason + ")"));
    }
    const bool float_file = std::string(output->format_name()) == "openexr";
    OIIO::ImageSpec spec(image.width, image.height, image.channels,
                         float_file ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8);
    if (!image.channel_names.empty()) spec.channelnames = image.channel_names;
    spec.alpha_channel = image.alpha_channel;
    bool ok = output->open(path, spec);
    if (ok) {
        if (float_file) {
            ok = output->write_image(OIIO::TypeDesc::FLOAT, image.samples.data());
        } else {
            // round(v * 255) of v clamped to [0, 1], as GL's unorm8 conversion (render.h to_rgba8).
            std::vector<std::uint8_t> codes(image.samples.size());
            for (std::size_t i = 0; i < codes.size(); ++i) {
                const float v = image.samples[i];
                codes[i] = static_cast<std::uint8_t>(std::lrint((std::isnan(v) ? 0.0f : std::clamp(v, 0.0f, 1.0f)) * 255.0f));
            }
            ok = output->write_image(OIIO::TypeDesc::UINT8, codes.data());
        }
    }
    if (ok) ok = output->close();
    if (!ok) {
        const std::string reason = trimmed(output->geterror());
        fail(path, "cannot write the image: " + (reason.empty() ? std::string("unknown error") : reason));
    }
}

}  // namespace tessref
