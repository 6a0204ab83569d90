// Height maps and colour textures from image files (see tessref/heightfield.h), read
// through src/image/image_io.h.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "image/image_io.h"
#include "tessref/error.h"
#include "tessref/heightfield.h"
#include "tessref/limits.h"

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

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw Error(what, Where::in_file(path)); }

TexelFormat texel_format(image::SampleType type) {
    switch (type) {
        case image::SampleType::uint8: return TexelFormat::unorm8;
        case image::SampleType::uint16: return TexelFormat::unorm16;
        case image::SampleType::float32: break;
    }
    return TexelFormat::float32;
}

RawImage read_raw(const std::string& path, int max_dimension, int max_channels, const char* kind,
                  std::uint64_t extra_bytes_per_texel) {
    const std::string what_kind(kind);
    image::ReadOptions options;
    options.kind = what_kind;
    options.max_channels = max_channels;
    // The header, before anything is allocated for the pixels: the memory they and the
    // texture need, and the size limit.
    options.check_header = [&](const image::ImageHeader& spec) {
        const int channels = std::min(spec.channels, max_channels);
        const TexelFormat format = texel_format(spec.type);
        const std::uint64_t texels = saturating_bytes(static_cast<std::uint64_t>(spec.width),
                                                      static_cast<std::uint64_t>(spec.height));
        const std::uint64_t sample_bytes = format == TexelFormat::unorm8 ? 1 : format == TexelFormat::unorm16 ? 2 : 4;
        const std::uint64_t file_samples = saturating_bytes(texels, static_cast<std::uint64_t>(channels) * sample_bytes);
        const std::uint64_t texture = texture_memory_bytes(spec.width, spec.height, channels, format);
        const std::uint64_t extra = saturating_bytes(texels, extra_bytes_per_texel);
        std::uint64_t needed = file_samples;
        for (const std::uint64_t part : {texture, extra})
            needed = part > UINT64_MAX - needed ? UINT64_MAX : needed + part;
        require_memory(needed,
                       what_kind + " of " + std::to_string(spec.width) + " x " + std::to_string(spec.height) +
                           (what_kind == "texture" ? " texels" : " samples"),
                       Where::in_file(path));
        if (spec.width > max_dimension || spec.height > max_dimension)
            fail(path, what_kind + " is " + std::to_string(spec.width) + "x" + std::to_string(spec.height) +
                           ", larger than the limit of " + std::to_string(max_dimension) + " texels per side");
    };
    image::Image file = image::read_image(path, options);
    RawImage raw;
    raw.width = file.header.width;
    raw.height = file.header.height;
    raw.file_channels = file.header.channels;
    raw.channels = file.channels;
    raw.bits_per_sample = file.header.bits_per_sample;
    raw.pixel_type = file.header.pixel_type;
    raw.format = texel_format(file.header.type);
    raw.u8 = std::move(file.u8);
    raw.u16 = std::move(file.u16);
    raw.f32 = std::move(file.f32);
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
    // Per texel beyond the image: the missing-sample mask, and the doubles of a mean fill.
    const std::uint64_t fill_bytes = 1 + (options.nodata_policy == NodataPolicy::fill_neighbour_mean ? sizeof(double) : 0);
    RawImage raw = read_raw(path, options.max_dimension, 1, "height map", fill_bytes);
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
    // Integer codes are finite: without a nodata value none of them is missing.
    const bool may_miss = raw.format == TexelFormat::float32 || options.nodata_value.has_value();
    for (std::size_t i = 0; may_miss && i < count; ++i) {
        if (!is_missing(i)) continue;
        if (options.nodata_policy == NodataPolicy::error) {
            const int x = static_cast<int>(i % static_cast<std::size_t>(width));
            const int y = static_cast<int>(i / static_cast<std::size_t>(width));
            const double v = raw_value(raw, i);
            const std::string why = std::isnan(v)   ? std::string("is NaN")
                                    : !std::isfinite(v) ? std::string("is infinite")
                                                        : "equals the nodata value " + format_number(v);
            throw Error("height map texel (" + std::to_string(x) + ", " + std::to_string(y) + ") " +
                            why + " (nodata policy: error)",
                        Where::at_key(path, "texel(" + std::to_string(x) + "," + std::to_string(y) + ")"));
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
    RawImage raw = read_raw(path, options.max_dimension, max_channels, "texture", 0);
    return make_texture(raw, options.mipmap_rule);
}

std::optional<Texture> texture_of_height_field(const HeightField& field, const TextureLoadOptions& options) {
    // Both loaders read the file through read_raw and make_texture. A one-channel file keeps
    // its channel in both; with nothing filled, the height field's texture holds the file's
    // samples, and its header passed a memory check that asked for more than load_texture's.
    const HeightFieldInfo& info = field.info;
    if (info.missing_texels != 0 || info.file_channels != 1 || field.texture.mipmap_rule() != options.mipmap_rule ||
        info.width > options.max_dimension || info.height > options.max_dimension)
        return std::nullopt;
    return field.texture;
}

}  // namespace tessref
