// Height maps and colour textures through OpenImageIO (see tessref/heightfield.h).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>
#include <system_error>
#include <vector>

#include <OpenImageIO/imageio.h>

#include "tessref/error.h"
#include "tessref/heightfield.h"

namespace tessref {

namespace {

// What an image file holds, read in its own integer type where that type maps to a GL UNORM
// format, and as float otherwise.
struct RawImage {
    int width = 0;
    int height = 0;
    int file_channels = 0;
    int channels = 0;  // kept
    int bits_per_sample = 0;
    std::string pixel_type;
    TexelFormat format = TexelFormat::float32;
    std::vector<std::uint8_t> u8;
    std::vector<std::uint16_t> u16;
    std::vector<float> f32;
};

[[noreturn]] void fail(const std::string& path, const std::string& what) {
    Where where;
    where.file = path;
    throw Error(what, where);
}

std::string trimmed(std::string text) {
    while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
    return text;
}

RawImage read_raw(const std::string& path, int max_dimension, int max_channels,
                  const char* kind) {
    const std::string what_kind(kind);
    std::error_code ec;
    const std::filesystem::path fs_path(path);
    if (!std::filesystem::exists(fs_path, ec))
        fail(path, what_kind + " not found");
    if (std::filesystem::is_directory(fs_path, ec))
        fail(path, what_kind + " is a directory, not an image");
    const auto bytes = std::filesystem::file_size(fs_path, ec);
    if (!ec && bytes == 0) fail(path, what_kind + " is an empty file (0 bytes)");

    // Keep colour channels as stored when there is an alpha channel: OpenImageIO would
    // otherwise premultiply them on read, which a GL upload of the file's bytes does not.
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto input = OIIO::ImageInput::open(path, &config);
    if (!input) {
        const std::string reason = trimmed(OIIO::geterror());
        fail(path, "cannot read " + what_kind + ": " +
                       (reason.empty() ? std::string("unknown image format") : reason));
    }
    const OIIO::ImageSpec& spec = input->spec();
    RawImage raw;
    raw.width = spec.width;
    raw.height = spec.height;
    raw.file_channels = spec.nchannels;
    raw.pixel_type = spec.format.c_str();
    raw.bits_per_sample = spec.get_int_attribute("oiio:BitsPerSample",
                                                 static_cast<int>(spec.format.size() * 8));
    if (spec.width <= 0 || spec.height <= 0 || spec.depth > 1 || spec.nchannels <= 0)
        fail(path, what_kind + " has zero size (" + std::to_string(spec.width) + "x" +
                       std::to_string(spec.height) + ", " + std::to_string(spec.nchannels) +
                       " channels)");
    if (spec.width > max_dimension || spec.height > max_dimension)
        fail(path, what_kind + " is " + std::to_string(spec.width) + "x" +
                       std::to_string(spec.height) + ", larger than the limit of " +
                       std::to_string(max_dimension) + " texels per side");
    raw.channels = std::min(spec.nchannels, max_channels);
    const std::size_t count = static_cast<std::size_t>(raw.width) *
                              static_cast<std::size_t>(raw.height) *
                              static_cast<std::size_t>(raw.channels);
    bool ok = false;
    if (spec.format == OIIO::TypeDesc::UINT8) {
        raw.format = TexelFormat::unorm8;
        raw.u8.resize(count);
        ok = input->read_image(0, 0, 0, raw.channels, OIIO::TypeDesc::UINT8, raw.u8.data());
    } else if (spec.format == OIIO::TypeDesc::UINT16) {
        raw.format = TexelFormat::unorm16;
        raw.u16.resize(count);
        ok = input->read_image(0, 0, 0, raw.channels, OIIO::TypeDesc::UINT16, raw.u16.data());
    } else {
        raw.format = TexelFormat::float32;
        raw.f32.resize(count);
        ok = input->read_image(0, 0, 0, raw.channels, OIIO::TypeDesc::FLOAT, raw.f32.data());
    }
    if (!ok) {
        std::string reason = trimmed(input->geterror());
        fail(path, "cannot read the pixels of " + what_kind + ": " +
                       (reason.empty() ? std::string("corrupt or truncated file") : reason));
    }
    input->close();
    return raw;
}

// The raw value of sample i (a code for integer files).
double raw_value(const RawImage& raw, std::size_t i) {
    switch (raw.format) {
        case TexelFormat::unorm8: return raw.u8[i];
        case TexelFormat::unorm16: return raw.u16[i];
        case TexelFormat::float32: return raw.f32[i];
    }
    return 0.0;
}

void set_raw_value(RawImage& raw, std::size_t i, double value) {
    switch (raw.format) {
        case TexelFormat::unorm8:
            raw.u8[i] = static_cast<std::uint8_t>(std::clamp(std::nearbyint(value), 0.0, 255.0));
            break;
        case TexelFormat::unorm16:
            raw.u16[i] = static_cast<std::uint16_t>(std::clamp(std::nearbyint(value), 0.0, 65535.0));
            break;
        case TexelFormat::float32: raw.f32[i] = static_cast<float>(value); break;
    }
}

std::string format_number(double v) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.9g", v);
    return buffer;
}

Texture make_texture(RawImage& raw, MipmapRule rule) {
    switch (raw.format) {
        case TexelFormat::unorm8:
            return Texture::from_unorm8(raw.width, raw.height, raw.channels, std::move(raw.u8), rule);
        case TexelFormat::unorm16:
            return Texture::from_unorm16(raw.width, raw.height, raw.channels, std::move(raw.u16), rule);
        case TexelFormat::float32: break;
    }
    return Texture::from_float(raw.width, raw.height, raw.channels, std::move(raw.f32), rule);
}

}  // namespace

HeightField load_height_field(const std::string& path, const HeightFieldOptions& options) {
    RawImage raw = read_raw(path, options.max_dimension, 1, "height map");
    if (raw.width < 2 || raw.height < 2)
        fail(path, "height map is " + std::to_string(raw.width) + "x" + std::to_string(raw.height) +
                       ": a height field needs at least 2x2 samples");

    const int width = raw.width;
    const int height = raw.height;
    const std::size_t count = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    auto is_missing = [&](std::size_t i) {
        const double v = raw_value(raw, i);
        if (!std::isfinite(v)) return true;
        return options.nodata_value.has_value() && v == *options.nodata_value;
    };
    std::vector<std::uint8_t> missing(count, 0);
    std::size_t missing_count = 0;
    for (std::size_t i = 0; i < count; ++i) {
        if (!is_missing(i)) continue;
        if (options.nodata_policy == NodataPolicy::error) {
            const int x = static_cast<int>(i % static_cast<std::size_t>(width));
            const int y = static_cast<int>(i / static_cast<std::size_t>(width));
            const double v = raw_value(raw, i);
            const std::string why = std::isnan(v)   ? std::string("is NaN")
                                    : !std::isfinite(v) ? std::string("is infinite")
                                                        : "equals the nodata value " + format_number(v);
            Where where;
            where.file = path;
            where.key = "texel(" + std::to_string(x) + "," + std::to_string(y) + ")";
            throw Error("height map texel (" + std::to_string(x) + ", " + std::to_string(y) + ") " +
                            why + " (nodata policy: error)",
                        where);
        }
        missing[i] = 1;
        ++missing_count;
    }

    if (missing_count > 0 && options.nodata_policy == NodataPolicy::fill_constant) {
        if (!std::isfinite(options.fill_value))
            fail(path, "height map fill value " + format_number(options.fill_value) + " is not finite");
        for (std::size_t i = 0; i < count; ++i)
            if (missing[i]) set_raw_value(raw, i, options.fill_value);
    } else if (missing_count > 0) {
        if (missing_count == count)
            fail(path, "every height map texel is missing (NaN or nodata): nothing to fill from");
        // Jacobi sweeps: each pass fills the missing texels that have a present 8-neighbour,
        // from the values present at the start of the pass.
        std::vector<double> value(count);
        for (std::size_t i = 0; i < count; ++i) value[i] = missing[i] ? 0.0 : raw_value(raw, i);
        std::vector<std::size_t> frontier;
        std::vector<double> frontier_value;
        std::size_t remaining = missing_count;
        while (remaining > 0) {
            frontier.clear();
            frontier_value.clear();
            for (int y = 0; y < height; ++y) {
                for (int x = 0; x < width; ++x) {
                    const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                                          static_cast<std::size_t>(x);
                    if (!missing[i]) continue;
                    double sum = 0.0;
                    int present = 0;
                    for (int dy = -1; dy <= 1; ++dy) {
                        for (int dx = -1; dx <= 1; ++dx) {
                            if (dx == 0 && dy == 0) continue;
                            const int nx = x + dx;
                            const int ny = y + dy;
                            if (nx < 0 || ny < 0 || nx >= width || ny >= height) continue;
                            const std::size_t n = static_cast<std::size_t>(ny) * static_cast<std::size_t>(width) +
                                                  static_cast<std::size_t>(nx);
                            if (missing[n]) continue;
                            sum += value[n];
                            ++present;
                        }
                    }
                    if (present == 0) continue;
                    frontier.push_back(i);
                    frontier_value.push_back(sum / present);
                }
            }
            for (std::size_t k = 0; k < frontier.size(); ++k) {
                const std::size_t i = frontier[k];
                set_raw_value(raw, i, frontier_value[k]);
                value[i] = raw_value(raw, i);  // as stored (rounded to a code for integers)
                missing[i] = 0;
            }
            remaining -= frontier.size();
        }
    }

    HeightField field;
    field.info.source_path = path;
    field.info.pixel_type = raw.pixel_type;
    field.info.bits_per_sample = raw.bits_per_sample;
    field.info.width = width;
    field.info.height = height;
    field.info.file_channels = raw.file_channels;
    field.info.missing_texels = missing_count;
    field.texture = make_texture(raw, options.mipmap_rule);
    const auto& texels = field.texture.level(0).texels;
    const auto [lo, hi] = std::minmax_element(texels.begin(), texels.end());
    field.info.min_value = *lo;
    field.info.max_value = *hi;
    return field;
}

Texture load_texture(const std::string& path, const TextureLoadOptions& options) {
    const int max_channels = std::clamp(options.max_channels, 1, 4);
    RawImage raw = read_raw(path, options.max_dimension, max_channels, "texture");
    return make_texture(raw, options.mipmap_rule);
}

}  // namespace tessref
