// Height maps and colour textures through OpenImageIO (see tessref/heightfield.h).
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include <OpenImageIO/imageio.h>

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

// OpenImageIO's error text on one line: trailing newlines dropped, inner ones joined by "; ".
std::string trimmed(std::string text) {
    while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
    for (std::size_t at = text.find('\n'); at != std::string::npos; at = text.find('\n', at))
        text.replace(at, 1, "; ");
    return text;
}

// The first `count` whitespace-separated tokens of a PNM header, comments skipped, as typed.
// Only the first 4 KiB are looked at: a header is a few dozen bytes.
std::vector<std::string> pnm_header_tokens(const std::string& path, std::size_t count) {
    std::ifstream in(path, std::ios::binary);
    std::string head(4096, '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<std::size_t>(std::max<std::streamsize>(0, in.gcount())));
    std::vector<std::string> tokens;
    std::size_t i = 0;
    while (tokens.size() < count && i < head.size()) {
        const unsigned char c = static_cast<unsigned char>(head[i]);
        if (c == '#') {
            while (i < head.size() && head[i] != '\n' && head[i] != '\r') ++i;
        } else if (std::isspace(c)) {
            ++i;
        } else {
            const std::size_t start = i;
            while (i < head.size() && !std::isspace(static_cast<unsigned char>(head[i]))) ++i;
            tokens.push_back(head.substr(start, i - start));
        }
    }
    return tokens;
}

// A header token for a message: as typed, but short.
std::string shown(const std::string& token) {
    return token.size() <= 24 ? token : token.substr(0, 24) + "...";
}

// What OpenImageIO 2.4.7's PNM reader accepts but the format does not allow: a maxval
// outside 1..65535 (maxval 0 makes it divide by zero and read every sample as 1; above
// 65535 it reads 16-bit samples scaled by a maxval they cannot reach) and a PFM scale that
// is 0 or not a number (its sign is the byte order; 0 gives none). OpenImageIO keeps
// neither value, so the header's four tokens are read again here, to check them and to
// name them as the file gives them.
void check_pnm_header(const std::string& path, const std::string& what_kind) {
    const std::vector<std::string> tokens = pnm_header_tokens(path, 4);
    if (tokens.size() < 4) return;  // P1/P4 bitmaps have no fourth token to check
    const std::string& magic = tokens[0];
    if (magic == "Pf" || magic == "PF") {
        const char* begin = tokens[3].c_str();
        char* end = nullptr;
        const double scale = std::strtod(begin, &end);
        if (end == begin || *end != '\0' || !std::isfinite(scale) || scale == 0.0)
            fail(path, what_kind + " is a PFM whose scale '" + shown(tokens[3]) +
                           "' is not a non-zero number (its sign gives the byte order)");
        return;
    }
    if (magic != "P2" && magic != "P3" && magic != "P5" && magic != "P6") return;
    long long maxval = -1;
    const std::string& text = tokens[3];
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), maxval);
    const bool whole = ec == std::errc() && ptr == text.data() + text.size();
    if (!whole || maxval < 1 || maxval > 65535)
        fail(path, what_kind + " is a " + (magic == "P2" || magic == "P5" ? "PGM" : "PPM") +
                       " with maxval " + shown(text) + "; the format allows 1 to 65535");
}

// OpenImageIO 2.4.7 scales a PNM's 16-bit samples as int(v) * 65535 / maxval in int
// arithmetic, which overflows for v > 32768 (Debian's build then returns 32768 for both
// 32768 and 32769: a one-code step of a 16-bit height map silently lost). For maxval above
// 32768 the samples are therefore read again here: binary P5/P6 only (big-endian 16-bit
// words after the header and one whitespace byte), scaled as OpenImageIO means to, in
// 64-bit arithmetic. The plain-text P2/P3 forms with such a maxval are refused instead.
void reread_pnm16(const std::string& path, const std::string& what_kind, std::vector<std::uint16_t>& samples) {
    const std::vector<std::string> tokens = pnm_header_tokens(path, 4);
    if (tokens.size() < 4) return;
    const std::string& magic = tokens[0];
    if (magic != "P2" && magic != "P3" && magic != "P5" && magic != "P6") return;
    const unsigned long maxval = std::strtoul(tokens[3].c_str(), nullptr, 10);  // checked by check_pnm_header
    if (maxval <= 32768) return;
    if (magic == "P2" || magic == "P3")
        fail(path, what_kind + " is a plain-text " + (magic == "P2" ? "PGM" : "PPM") + " with maxval " + tokens[3] +
                       ", which OpenImageIO reads wrongly above 32768; write it as binary (P5/P6)");
    std::ifstream in(path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    // Walk the header again to its end: four tokens, comments skipped, then one whitespace byte.
    std::size_t i = 0;
    for (int token = 0; token < 4; ++token) {
        while (i < bytes.size()) {
            if (bytes[i] == '#')
                while (i < bytes.size() && bytes[i] != '\n' && bytes[i] != '\r') ++i;
            else if (std::isspace(static_cast<unsigned char>(bytes[i])))
                ++i;
            else
                break;
        }
        while (i < bytes.size() && !std::isspace(static_cast<unsigned char>(bytes[i]))) ++i;
    }
    ++i;
    if (i > bytes.size() || (bytes.size() - i) / 2 < samples.size())
        fail(path, what_kind + " is truncated: its 16-bit samples end early");
    for (std::size_t k = 0; k < samples.size(); ++k) {
        const std::uint64_t v = (static_cast<std::uint64_t>(static_cast<unsigned char>(bytes[i + 2 * k])) << 8) |
                                static_cast<unsigned char>(bytes[i + 2 * k + 1]);
        samples[k] = static_cast<std::uint16_t>(std::min<std::uint64_t>(v, maxval) * 65535 / maxval);
    }
}

bool looks_like_pnm(const std::string& path) {
    const std::vector<std::string> tokens = pnm_header_tokens(path, 1);
    if (tokens.empty() || tokens[0].size() != 2 || tokens[0][0] != 'P') return false;
    return std::string_view("123456fF").find(tokens[0][1]) != std::string_view::npos;
}

// libpng allocates a chunk's declared length before reading it, so a 529-byte PNG whose
// tEXt chunk claims 1.7 GB made OpenImageIO allocate that much before failing (a fuzzer's
// finding). Every chunk of a PNG is therefore walked first (length, type, data, CRC; the
// lengths alone, nothing decoded) and one that runs past the end of the file is refused.
void check_png_chunks(const std::string& path, const std::string& what_kind) {
    std::ifstream in(path, std::ios::binary);
    unsigned char signature[8] = {};
    if (!in.read(reinterpret_cast<char*>(signature), 8) ||
        std::memcmp(signature, "\x89PNG\r\n\x1a\n", 8) != 0)
        return;  // not a PNG: OpenImageIO's readers decide
    std::error_code ec;
    const std::uint64_t size = std::filesystem::file_size(path, ec);
    if (ec) return;
    std::uint64_t offset = 8;
    while (offset < size) {
        unsigned char head[8] = {};
        in.seekg(static_cast<std::streamoff>(offset));
        if (!in.read(reinterpret_cast<char*>(head), 8))
            fail(path, what_kind + " is a truncated PNG: a chunk header is cut at byte " + std::to_string(offset));
        const std::uint64_t length = (std::uint64_t{head[0]} << 24) | (std::uint64_t{head[1]} << 16) |
                                     (std::uint64_t{head[2]} << 8) | std::uint64_t{head[3]};
        std::string type(reinterpret_cast<const char*>(head + 4), 4);
        for (char& c : type)
            if (!std::isprint(static_cast<unsigned char>(c))) c = '?';
        if (length > size - offset - 8 || size - offset - 8 - length < 4)
            fail(path, what_kind + " is a corrupt PNG: chunk '" + type + "' at byte " +
                           std::to_string(offset) + " declares " + std::to_string(length) +
                           " bytes, more than the file holds (" + std::to_string(size) + " bytes)");
        offset += 12 + length;
        if (type == "IEND") return;
    }
}

// The file's bits per sample: OpenImageIO's PNM reader stores it as a float, its other
// readers as an int; `fallback` where the reader says nothing.
int bits_per_sample(const OIIO::ImageSpec& spec, int fallback) {
    const OIIO::ParamValue* attribute = spec.find_attribute("oiio:BitsPerSample");
    if (attribute == nullptr) return fallback;
    const float bits = attribute->get_float(static_cast<float>(fallback));
    return std::isfinite(bits) && bits >= 1.0f && bits <= 64.0f ? static_cast<int>(bits) : fallback;
}

RawImage read_raw(const std::string& path, int max_dimension, int max_channels, const char* kind,
                  std::uint64_t extra_bytes_per_texel) {
    const std::string what_kind(kind);
    std::error_code ec;
    const std::filesystem::path fs_path(path);
    if (!std::filesystem::exists(fs_path, ec))
        fail(path, what_kind + " not found");
    if (std::filesystem::is_directory(fs_path, ec))
        fail(path, what_kind + " is a directory, not an image");
    // A device, FIFO or socket has no end to read to (/dev/zero, /dev/urandom would keep
    // OpenImageIO reading forever) and no header to check before reading: only files.
    if (!std::filesystem::is_regular_file(fs_path, ec))
        fail(path, what_kind + " is not a regular file (a device, FIFO or socket), not an image");
    const auto bytes = std::filesystem::file_size(fs_path, ec);
    if (!ec && bytes == 0) fail(path, what_kind + " is an empty file (0 bytes)");

    // Keep colour channels as stored when there is an alpha channel: OpenImageIO would
    // otherwise premultiply them on read, which a GL upload of the file's bytes does not.
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    check_png_chunks(path, what_kind);
    auto input = OIIO::ImageInput::open(path, &config);
    if (!input) {
        const std::string reason = trimmed(OIIO::geterror());
        // OpenImageIO names no cause for a PNM header it rejects ("could not find a format
        // reader"); the header check names the bad value where it is one it knows.
        if (looks_like_pnm(path)) check_pnm_header(path, what_kind);
        fail(path, "cannot read " + what_kind + ": " +
                       (reason.empty() ? std::string("unknown image format") : reason));
    }
    // Everything below checks the header (OpenImageIO has read only that so far) before
    // anything is allocated for the pixels.
    const OIIO::ImageSpec& spec = input->spec();
    RawImage raw;
    raw.width = spec.width;
    raw.height = spec.height;
    raw.file_channels = spec.nchannels;
    raw.pixel_type = spec.format.c_str();
    raw.bits_per_sample = bits_per_sample(spec, static_cast<int>(spec.format.size() * 8));
    if (spec.width <= 0 || spec.height <= 0 || spec.depth > 1 || spec.nchannels <= 0)
        fail(path, what_kind + " has no pixels: its header says " + std::to_string(spec.width) + " x " +
                       std::to_string(spec.height) + ", " + std::to_string(spec.nchannels) + " channel(s)");
    if (std::string_view(input->format_name()) == "pnm") check_pnm_header(path, what_kind);
    raw.channels = std::min(spec.nchannels, max_channels);
    if (spec.format == OIIO::TypeDesc::UINT8)
        raw.format = TexelFormat::unorm8;
    else if (spec.format == OIIO::TypeDesc::UINT16)
        raw.format = TexelFormat::unorm16;
    else
        raw.format = TexelFormat::float32;
    const std::uint64_t texels = saturating_bytes(static_cast<std::uint64_t>(raw.width),
                                                  static_cast<std::uint64_t>(raw.height));
    const std::uint64_t sample_bytes = raw.format == TexelFormat::unorm8    ? 1
                                       : raw.format == TexelFormat::unorm16 ? 2
                                                                            : 4;
    const std::uint64_t file_samples = saturating_bytes(texels, static_cast<std::uint64_t>(raw.channels) * sample_bytes);
    const std::uint64_t texture = texture_memory_bytes(raw.width, raw.height, raw.channels, raw.format);
    const std::uint64_t extra = saturating_bytes(texels, extra_bytes_per_texel);
    std::uint64_t needed = file_samples;
    for (const std::uint64_t part : {texture, extra})
        needed = part > UINT64_MAX - needed ? UINT64_MAX : needed + part;
    require_memory(needed,
                   what_kind + " of " + std::to_string(raw.width) + " x " + std::to_string(raw.height) +
                       (what_kind == "texture" ? " texels" : " samples"),
                   Where::in_file(path));
    if (spec.width > max_dimension || spec.height > max_dimension)
        fail(path, what_kind + " is " + std::to_string(spec.width) + "x" +
                       std::to_string(spec.height) + ", larger than the limit of " +
                       std::to_string(max_dimension) + " texels per side");
    const std::size_t count = static_cast<std::size_t>(raw.width) *
                              static_cast<std::size_t>(raw.height) *
                              static_cast<std::size_t>(raw.channels);
    bool ok = false;
    switch (raw.format) {
        case TexelFormat::unorm8:
            raw.u8.resize(count);
            ok = input->read_image(0, 0, 0, raw.channels, OIIO::TypeDesc::UINT8, raw.u8.data());
            break;
        case TexelFormat::unorm16:
            raw.u16.resize(count);
            ok = input->read_image(0, 0, 0, raw.channels, OIIO::TypeDesc::UINT16, raw.u16.data());
            if (ok && std::string_view(input->format_name()) == "pnm" && raw.channels == raw.file_channels)
                reread_pnm16(path, what_kind, raw.u16);
            break;
        case TexelFormat::float32:
            raw.f32.resize(count);
            ok = input->read_image(0, 0, 0, raw.channels, OIIO::TypeDesc::FLOAT, raw.f32.data());
            break;
    }
    // OpenImageIO 2.4.7's TIFF reader can report success with its error set (a strip past
    // the end of the file reads as zeros): either one means the pixels are not the file's.
    if (!ok || input->has_error()) {
        const std::string reason = trimmed(input->geterror());
        fail(path, what_kind + " is truncated or corrupt: its " + std::to_string(raw.width) + " x " +
                       std::to_string(raw.height) + " pixels cannot be read" +
                       (reason.empty() ? std::string() : " (" + reason + ")"));
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
    for (std::size_t i = 0; i < count; ++i) {
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

}  // namespace tessref
