// Reading and writing the float pictures of tessref/compare.h (src/image/image_io.h).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "common/unorm8.h"
#include "image/image_io.h"
#include "tessref/compare.h"
#include "tessref/error.h"
#include "tessref/limits.h"

namespace tessref {

namespace {

// Integer codes to [0, 1] as code / max, rounded once (double to float): OpenImageIO's own
// conversion multiplies by a float reciprocal, which can be an ulp off code/255.
template <typename Code>
void codes_to_float(const std::vector<Code>& codes, double max, std::vector<float>& out) {
    out.resize(codes.size());
    for (std::size_t i = 0; i < codes.size(); ++i) out[i] = static_cast<float>(static_cast<double>(codes[i]) / max);
}

// The bytes of a float picture read from a file with this header: the floats plus, for an
// integer file, its codes (at most 2 bytes each) read first.
std::uint64_t bytes_of(const image::ImageHeader& spec) {
    const std::uint64_t count = saturating_bytes(
        saturating_bytes(static_cast<std::uint64_t>(spec.width), static_cast<std::uint64_t>(spec.height)),
        static_cast<std::uint64_t>(spec.channels));
    const std::uint64_t code_bytes = spec.type == image::SampleType::uint8    ? 1
                                     : spec.type == image::SampleType::uint16 ? 2
                                                                              : 0;
    return saturating_bytes(count, 4 + code_bytes);
}

}  // namespace

std::uint64_t float_image_memory(const std::string& path, int* width, int* height) {
    const image::ImageHeader spec = image::read_image_header(path, "image");
    if (width) *width = spec.width;
    if (height) *height = spec.height;
    return bytes_of(spec);
}

FloatImage read_float_image(const std::string& path) {
    image::ReadOptions options;
    options.kind = "image";
    options.check_header = [&](const image::ImageHeader& spec) {
        require_memory(bytes_of(spec),
                       "image of " + std::to_string(spec.width) + " x " + std::to_string(spec.height) + " pixels, " +
                           std::to_string(spec.channels) + " channels",
                       Where::in_file(path));
    };
    image::Image file = image::read_image(path, options);

    FloatImage picture;
    picture.width = file.header.width;
    picture.height = file.header.height;
    picture.channels = file.header.channels;
    picture.alpha_channel = file.header.alpha_channel;
    picture.channel_names = file.header.channel_names;
    // A file whose channels have different types is read as float (OpenImageIO converts).
    switch (file.header.type) {
        case image::SampleType::uint8: codes_to_float(file.u8, 255.0, picture.samples); break;
        case image::SampleType::uint16: codes_to_float(file.u16, 65535.0, picture.samples); break;
        case image::SampleType::float32: picture.samples = std::move(file.f32); break;
    }
    return picture;
}

void write_float_image(const FloatImage& picture, const std::string& path) {
    image::WriteOptions options;
    options.channel_names = picture.channel_names;
    options.alpha_channel = picture.alpha_channel;
    image::ImageView view{picture.width, picture.height, picture.channels, image::SampleType::float32,
                          picture.samples.data()};
    if (image::writes_float(path)) {
        image::write_image(path, view, options);
        return;
    }
    // round(v * 255) of v clamped to [0, 1], as GL's unorm8 conversion (render.h to_rgba8).
    std::vector<std::uint8_t> codes(picture.samples.size());
    for (std::size_t i = 0; i < codes.size(); ++i) codes[i] = unorm8(picture.samples[i]);
    view.type = image::SampleType::uint8;
    view.samples = codes.data();
    image::write_image(path, view, options);
}

}  // namespace tessref
