// The netpbm family: P1-P6 (PBM, PGM, PPM, plain and binary, 8 and 16 bit) and PFM (Pf
// grey, PF colour). Values as OpenImageIO 2.4.7's PNM reader gives them, which tessref
// used before it read PNM itself: a sample v of maxval m becomes min(v, m) * 255 / m
// (maxval up to 255) or min(v, m) * 65535 / m (above), truncated, here in 64-bit integers
// (OpenImageIO's int product overflowed above 32768); bitmaps 1 -> 0 (black) and 0 ->
// 255; PFM samples times |scale|, little endian for a negative scale, rows stored bottom
// to top. Stricter than OpenImageIO where netpbm is: maxval 1..65535, a PFM scale that is
// a non-zero number, no negative plain-text samples.
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "image/codecs.h"
#include "tessref/error.h"

namespace tessref::image::detail {

namespace {

// A header token for a message: as typed, but short.
std::string shown(const std::string& token) { return token.size() <= 24 ? token : token.substr(0, 24) + "..."; }

// Reading position in the file's bytes: whitespace and # comments skipped between tokens.
struct Cursor {
    const std::string& bytes;
    std::size_t at = 0;

    void skip_space_and_comments() {
        while (at < bytes.size()) {
            const unsigned char c = static_cast<unsigned char>(bytes[at]);
            if (c == '#') {
                while (at < bytes.size() && bytes[at] != '\n' && bytes[at] != '\r') ++at;
            } else if (std::isspace(c)) {
                ++at;
            } else {
                return;
            }
        }
    }

    // The next whitespace-separated token ("" at the end).
    std::string token() {
        skip_space_and_comments();
        const std::size_t start = at;
        while (at < bytes.size() && !std::isspace(static_cast<unsigned char>(bytes[at]))) ++at;
        return bytes.substr(start, at - start);
    }

    // The next sample of a plain-text file: a whole non-negative number, else false.
    bool number(long long& value) {
        skip_space_and_comments();
        const char* begin = bytes.data() + at;
        const char* end = bytes.data() + bytes.size();
        const auto [ptr, ec] = std::from_chars(begin, end, value);
        if (ec != std::errc() || ptr == begin) return false;
        at += static_cast<std::size_t>(ptr - begin);
        return value >= 0;
    }
};

// A header (magic, width, height, maxval or scale, comments between them) longer than
// this is no PNM a program wrote; only this much is read before the header is checked, so
// a gigabyte behind a "P5" is refused without being read.
constexpr std::size_t kHeaderBytes = std::size_t{64} << 10;

// Appends up to `count` more bytes of the stream to `bytes`, read in large blocks (a
// stream iterator costs tens of instructions a byte).
void append_bytes(std::ifstream& in, std::string& bytes, std::uint64_t count) {
    char block[1 << 16];
    while (count > 0) {
        in.read(block, static_cast<std::streamsize>(std::min<std::uint64_t>(count, sizeof block)));
        const auto got = static_cast<std::size_t>(in.gcount());
        if (got == 0) return;
        bytes.append(block, got);
        count -= got;
    }
}

bool whole_int(const std::string& text, long long& value) {
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    return ec == std::errc() && ptr == text.data() + text.size() && !text.empty();
}

}  // namespace

bool is_pnm(const std::string& head) {
    return head.size() >= 2 && head[0] == 'P' && std::strchr("123456fF", head[1]) != nullptr && head[1] != '\0';
}

Image read_pnm(const std::string& path, const ReadOptions& options) {
    const std::string& kind = options.kind;
    std::ifstream in(path, std::ios::binary);
    std::string bytes;
    append_bytes(in, bytes, kHeaderBytes);
    if (!in.good() && !in.eof()) fail(path, "cannot read " + kind + ": the file cannot be read");
    if (!is_pnm(bytes)) fail(path, "cannot read " + kind + ": not a PNM file");
    const bool more = bytes.size() == kHeaderBytes && in.peek() != std::ifstream::traits_type::eof();
    const char magic = bytes[1];
    const bool pfm = magic == 'f' || magic == 'F';
    const bool bitmap = magic == '1' || magic == '4';
    const bool plain = magic == '1' || magic == '2' || magic == '3';
    const std::string format_name = pfm ? "PFM" : bitmap ? "PBM" : (magic == '2' || magic == '5') ? "PGM" : "PPM";

    Cursor cursor{bytes, 2};
    const std::string width_token = cursor.token();
    const std::string height_token = cursor.token();
    const std::string last_token = bitmap ? std::string("1") : cursor.token();
    if (more && cursor.at >= bytes.size())
        fail(path, "cannot read " + kind + ": its " + format_name + " header does not end within its first " +
                       std::to_string(kHeaderBytes >> 10) + " KiB");
    long long width = 0, height = 0;
    if (!whole_int(width_token, width) || !whole_int(height_token, height) || last_token.empty())
        fail(path, "cannot read " + kind + ": its " + format_name + " header is not 'P" + magic +
                       " width height" + (bitmap ? "" : pfm ? " scale" : " maxval") + "'");
    // One whitespace byte ends the header (the last token has been read up to it).
    if (cursor.at >= bytes.size() || !std::isspace(static_cast<unsigned char>(bytes[cursor.at])))
        fail(path, "cannot read " + kind + ": its " + format_name + " header ends without the whitespace before the samples");
    ++cursor.at;

    Image image;
    ImageHeader& header = image.header;
    header.format = "pnm";
    header.width = static_cast<int>(std::clamp<long long>(width, INT32_MIN, INT32_MAX));
    header.height = static_cast<int>(std::clamp<long long>(height, INT32_MIN, INT32_MAX));
    header.channels = (magic == '3' || magic == '6' || magic == 'F') ? 3 : 1;
    if (header.width <= 0 || header.height <= 0) accept_header(path, options, header);  // refuses it

    long long maxval = 1;
    double scale = 1.0;
    if (pfm) {
        const char* begin = last_token.c_str();
        char* end = nullptr;
        scale = std::strtod(begin, &end);
        if (end == begin || *end != '\0' || !std::isfinite(scale) || scale == 0.0)
            fail(path, kind + " is a PFM whose scale '" + shown(last_token) +
                           "' is not a non-zero number (its sign gives the byte order)");
        header.type = SampleType::float32;
        header.pixel_type = "float";
        header.bits_per_sample = 32;
    } else {
        if (!bitmap && (!whole_int(last_token, maxval) || maxval < 1 || maxval > 65535))
            fail(path, kind + " is a " + format_name + " with maxval " + shown(last_token) +
                           "; the format allows 1 to 65535");
        header.type = maxval > 255 ? SampleType::uint16 : SampleType::uint8;
        header.pixel_type = maxval > 255 ? "uint16" : "uint8";
        // As OpenImageIO computes oiio:BitsPerSample, float logarithms included.
        header.bits_per_sample = static_cast<int>(std::ceil(std::log(static_cast<float>(maxval + 1)) / std::log(2.0f)));
    }
    default_channel_names(header);
    accept_header(path, options, header);

    const int keep = std::min(header.channels, options.max_channels);
    image.channels = keep;
    allocate_samples(image);
    const std::size_t w = static_cast<std::size_t>(header.width), h = static_cast<std::size_t>(header.height);
    const std::size_t nc = static_cast<std::size_t>(header.channels);
    // The samples, now that the header has been accepted: a binary file's are read up to
    // what its header says they take (anything after them is not read), a plain file's to
    // its end.
    if (more) {
        const std::uint64_t sample_bytes = pfm ? 4 : bitmap ? 0 : header.type == SampleType::uint8 ? 1 : 2;
        const std::uint64_t needed = plain ? UINT64_MAX
                                     : magic == '4' ? std::uint64_t{(w + 7) / 8} * h
                                                    : std::uint64_t{w} * h * nc * sample_bytes;
        const std::uint64_t have = bytes.size() - cursor.at;
        if (plain) {
            // A plain sample is at most 5 digits; 32 bytes each leaves room for any
            // whitespace a writer puts between them.
            const std::uint64_t cap = std::uint64_t{w} * h * nc * 32 + (std::uint64_t{1} << 20);
            std::error_code ec;
            const std::uint64_t size = std::filesystem::file_size(path, ec);
            if (!ec && size - cursor.at > cap)
                fail(path, kind + " is a plain " + format_name + " of " + std::to_string(size) + " bytes; its " +
                               std::to_string(header.width) + " x " + std::to_string(header.height) +
                               " samples take at most " + std::to_string(cap) + " as text");
        }
        append_bytes(in, bytes, needed > have ? needed - have : 0);
        if (in.bad()) fail(path, "cannot read " + kind + ": the file cannot be read");
    }
    const std::string truncated = kind + " is truncated or corrupt: its " + std::to_string(header.width) + " x " +
                                  std::to_string(header.height) + " pixels cannot be read";
    const std::size_t available = bytes.size() - std::min(bytes.size(), cursor.at);
    auto store = [&](std::size_t sample, std::uint64_t value) {  // sample index in the file's order
        const std::size_t c = sample % nc;
        if (static_cast<int>(c) >= keep) return;
        const std::size_t out = sample / nc * static_cast<std::size_t>(keep) + c;
        if (header.type == SampleType::uint8)
            image.u8[out] = static_cast<std::uint8_t>(value);
        else
            image.u16[out] = static_cast<std::uint16_t>(value);
    };
    const std::uint64_t full = header.type == SampleType::uint8 ? 255 : 65535;
    const auto m = static_cast<std::uint64_t>(maxval);
    const std::size_t count = w * h * nc;

    if (pfm) {
        if (available / 4 / nc / w < h) fail(path, truncated + " (its float samples end early)");
        const bool little = scale < 0;
        const float factor = static_cast<float>(std::fabs(scale));
        for (std::size_t row = 0; row < h; ++row) {
            const std::size_t file_row = h - 1 - row;  // stored bottom to top
            for (std::size_t x = 0; x < w; ++x) {
                for (std::size_t c = 0; c < nc; ++c) {
                    const unsigned char* p = reinterpret_cast<const unsigned char*>(bytes.data()) + cursor.at +
                                             ((file_row * w + x) * nc + c) * 4;
                    const std::uint32_t bits = little ? (std::uint32_t{p[0]} | std::uint32_t{p[1]} << 8 |
                                                         std::uint32_t{p[2]} << 16 | std::uint32_t{p[3]} << 24)
                                                      : (std::uint32_t{p[3]} | std::uint32_t{p[2]} << 8 |
                                                         std::uint32_t{p[1]} << 16 | std::uint32_t{p[0]} << 24);
                    float v;
                    std::memcpy(&v, &bits, 4);
                    if (static_cast<int>(c) < keep) image.f32[(row * w + x) * static_cast<std::size_t>(keep) + c] = factor * v;
                }
            }
        }
    } else if (magic == '4') {
        const std::size_t row_bytes = (w + 7) / 8;
        if (available / row_bytes < h) fail(path, truncated + " (its bit rows end early)");
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const unsigned char byte = static_cast<unsigned char>(bytes[cursor.at + y * row_bytes + x / 8]);
                store(y * w + x, (byte >> (7 - x % 8)) & 1 ? 0 : 255);
            }
    } else if (plain) {
        for (std::size_t i = 0; i < count; ++i) {
            long long v = 0;
            if (!cursor.number(v)) fail(path, truncated + " (sample " + std::to_string(i) + " is missing or not a number)");
            const std::uint64_t code = std::min<std::uint64_t>(static_cast<std::uint64_t>(v), m) * full / m;
            store(i, bitmap ? 255 - code : code);
        }
    } else {
        const std::size_t sample_bytes = header.type == SampleType::uint8 ? 1 : 2;
        if (available / sample_bytes / nc / w < h)
            fail(path, truncated + " (its " + std::to_string(8 * sample_bytes) + "-bit samples end early)");
        const unsigned char* p = reinterpret_cast<const unsigned char*>(bytes.data()) + cursor.at;
        if (m == full && keep == header.channels) {
            // Every sample kept, as stored: a maxval of 255 or 65535 scales by 1, and no
            // sample exceeds it.
            if (sample_bytes == 1) {
                std::memcpy(image.u8.data(), p, count);
            } else {
                std::size_t i = 0;
#if defined(__SSE2__)
                // Eight big-endian samples at a time, their bytes swapped.
                for (; i + 8 <= count; i += 8) {
                    const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p + 2 * i));
                    _mm_storeu_si128(reinterpret_cast<__m128i*>(image.u16.data() + i),
                                     _mm_or_si128(_mm_slli_epi16(v, 8), _mm_srli_epi16(v, 8)));
                }
#endif
                for (; i < count; ++i) image.u16[i] = static_cast<std::uint16_t>(p[2 * i] << 8 | p[2 * i + 1]);
            }
        } else {
            for (std::size_t i = 0; i < count; ++i) {
                const std::uint64_t v = sample_bytes == 1 ? p[i] : (std::uint64_t{p[2 * i]} << 8 | p[2 * i + 1]);
                store(i, std::min(v, m) * full / m);
            }
        }
    }
    return image;
}

}  // namespace tessref::image::detail
