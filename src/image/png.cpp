// PNG through libpng. Read as OpenImageIO 2.4.7 read it (the values tessref has always
// used): png_set_expand (palette to RGB, grey below 8 bits to 8, tRNS to an alpha channel),
// 16-bit samples as such, no gamma, no premultiplication. Written 8-bit, a Software text
// chunk when asked, no time; for speed (kCompressionLevel).
//
// libpng reports errors by longjmp: every libpng call runs inside a small function that
// sets the jump point and holds no C++ object, and the structures are freed by one owner
// whatever happens, so an error leaks nothing and unwinds no C++ frame.
#include <png.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <vector>

#include "image/codecs.h"
#include "tessref/error.h"

namespace tessref::image::detail {

namespace {

// Ancillary chunks (text, ICC profiles) are allocated whole by libpng; none that tessref
// could meet needs more than this, and a hostile length is refused before it is allocated.
constexpr png_alloc_size_t kChunkMallocMax = 64u << 20;
// Sides beyond this are refused in the header (libpng's own default, said here); the
// pixels' memory is checked by the caller (ReadOptions::check_header) before any is taken.
constexpr png_uint_32 kMaxSide = 1000000;
// Writing favours speed: a render's PNG is written on the hot path. For a 1280 x 800 render
// (bench/scenes/jacksboro-grid-16.toml) zlib level 1 with the Sub filter takes 35 ms and
// 511 KB, where OpenImageIO's level 6 without filters took 159 ms for 365 KB.
constexpr int kCompressionLevel = 1;
constexpr int kFilters = PNG_FILTER_SUB;

struct ErrorText {
    char text[256] = "";
};

void on_error(png_structp png, png_const_charp message) {
    auto* error = static_cast<ErrorText*>(png_get_error_ptr(png));
    std::snprintf(error->text, sizeof error->text, "%s", message ? message : "libpng error");
    png_longjmp(png, 1);
}

void on_warning(png_structp, png_const_charp) {}  // as OpenImageIO: warnings are not errors

// ---- reading ------------------------------------------------------------------------

struct Reader {
    std::FILE* file = nullptr;
    png_structp png = nullptr;
    png_infop info = nullptr;
    ErrorText error;

    ~Reader() {
        if (png != nullptr) png_destroy_read_struct(&png, info ? &info : nullptr, nullptr);
        if (file != nullptr) std::fclose(file);
    }
};

struct PngHeader {
    png_uint_32 width = 0, height = 0;
    int bit_depth = 0, channels = 0;
};

bool read_header(Reader& r, PngHeader& h) {
    if (setjmp(png_jmpbuf(r.png))) return false;
    png_init_io(r.png, r.file);
    png_set_chunk_malloc_max(r.png, kChunkMallocMax);
    png_set_user_limits(r.png, kMaxSide, kMaxSide);
    png_read_info(r.png, r.info);
    png_set_expand(r.png);
#if __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    if (png_get_bit_depth(r.png, r.info) == 16) png_set_swap(r.png);  // PNG is big endian
#endif
    png_set_interlace_handling(r.png);
    png_read_update_info(r.png, r.info);
    h.width = png_get_image_width(r.png, r.info);
    h.height = png_get_image_height(r.png, r.info);
    h.bit_depth = png_get_bit_depth(r.png, r.info);
    h.channels = png_get_channels(r.png, r.info);
    return true;
}

bool read_rows(Reader& r, png_bytepp rows) {
    if (setjmp(png_jmpbuf(r.png))) return false;
    png_read_image(r.png, rows);
    return true;
}

// What follows the pixels is not needed: as OpenImageIO, a fault there is no error.
void read_end(Reader& r) {
    if (setjmp(png_jmpbuf(r.png))) return;
    png_read_end(r.png, nullptr);
}

// libpng allocates a chunk's declared length before reading it, so a 529-byte PNG whose
// tEXt chunk claims 1.7 GB made the reader allocate that much before failing (a fuzzer's
// finding). Every chunk of a PNG is therefore walked first (length, type, data, CRC; the
// lengths alone, nothing decoded) and one that runs past the end of the file is refused.
void check_chunks(const std::string& path, const std::string& kind) {
    std::ifstream in(path, std::ios::binary);
    std::error_code ec;
    const std::uint64_t size = std::filesystem::file_size(path, ec);
    if (ec) return;
    std::uint64_t offset = 8;
    while (offset < size) {
        unsigned char head[8] = {};
        in.seekg(static_cast<std::streamoff>(offset));
        if (!in.read(reinterpret_cast<char*>(head), 8))
            fail(path, kind + " is a truncated PNG: a chunk header is cut at byte " + std::to_string(offset));
        const std::uint64_t length = (std::uint64_t{head[0]} << 24) | (std::uint64_t{head[1]} << 16) |
                                     (std::uint64_t{head[2]} << 8) | std::uint64_t{head[3]};
        std::string type(reinterpret_cast<const char*>(head + 4), 4);
        for (char& c : type)
            if (!std::isprint(static_cast<unsigned char>(c))) c = '?';
        if (length > size - offset - 8 || size - offset - 8 - length < 4)
            fail(path, kind + " is a corrupt PNG: chunk '" + type + "' at byte " + std::to_string(offset) +
                           " declares " + std::to_string(length) + " bytes, more than the file holds (" +
                           std::to_string(size) + " bytes)");
        offset += 12 + length;
        if (type == "IEND") return;
    }
}

// ---- writing ------------------------------------------------------------------------

struct Writer {
    std::FILE* file = nullptr;
    png_structp png = nullptr;
    png_infop info = nullptr;
    ErrorText error;

    ~Writer() {
        if (png != nullptr) png_destroy_write_struct(&png, info ? &info : nullptr);
        if (file != nullptr) std::fclose(file);
    }
};

bool write_all(Writer& w, png_uint_32 width, png_uint_32 height, int color_type, png_textp text, int text_count,
               png_bytepp rows) {
    if (setjmp(png_jmpbuf(w.png))) return false;
    png_init_io(w.png, w.file);
    png_set_compression_level(w.png, kCompressionLevel);
    png_set_filter(w.png, 0, kFilters);
    png_set_IHDR(w.png, w.info, width, height, 8, color_type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    if (text_count > 0) png_set_text(w.png, w.info, text, text_count);
    png_write_info(w.png, w.info);
    png_write_image(w.png, rows);
    png_write_end(w.png, w.info);
    return true;
}

}  // namespace

bool is_png(const std::string& head) {
    return head.size() >= 8 && std::memcmp(head.data(), "\x89PNG\r\n\x1a\n", 8) == 0;
}

Image read_png(const std::string& path, const ReadOptions& options) {
    const std::string& kind = options.kind;
    check_chunks(path, kind);
    Reader r;
    r.file = std::fopen(path.c_str(), "rb");
    if (r.file == nullptr) fail(path, "cannot read " + kind + ": " + std::strerror(errno));
    r.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &r.error, on_error, on_warning);
    if (r.png != nullptr) r.info = png_create_info_struct(r.png);
    if (r.png == nullptr || r.info == nullptr) fail(path, "cannot read " + kind + ": libpng cannot start");
    PngHeader h;
    if (!read_header(r, h)) fail(path, "cannot read " + kind + ": " + r.error.text);

    Image image;
    ImageHeader& header = image.header;
    header.format = "png";
    header.width = static_cast<int>(std::min<png_uint_32>(h.width, INT32_MAX));
    header.height = static_cast<int>(std::min<png_uint_32>(h.height, INT32_MAX));
    header.channels = h.channels;
    header.type = h.bit_depth == 16 ? SampleType::uint16 : SampleType::uint8;
    header.pixel_type = h.bit_depth == 16 ? "uint16" : "uint8";
    header.bits_per_sample = h.bit_depth == 16 ? 16 : 8;
    default_channel_names(header);
    accept_header(path, options, header);

    // libpng decodes every channel; rows are read whole and the kept channels taken.
    const std::size_t sample_bytes = h.bit_depth == 16 ? 2 : 1;
    const std::size_t row_bytes = static_cast<std::size_t>(h.width) * static_cast<std::size_t>(h.channels) * sample_bytes;
    const int keep = std::min(header.channels, options.max_channels);
    image.channels = keep;
    std::vector<png_byte> decoded;
    std::vector<png_bytep> rows(h.height);
    if (keep == header.channels) {
        allocate_samples(image);
        auto* base = header.type == SampleType::uint16 ? reinterpret_cast<png_bytep>(image.u16.data()) : image.u8.data();
        for (png_uint_32 y = 0; y < h.height; ++y) rows[y] = base + y * row_bytes;
    } else {
        decoded.resize(row_bytes * h.height);
        for (png_uint_32 y = 0; y < h.height; ++y) rows[y] = decoded.data() + y * row_bytes;
    }
    if (!read_rows(r, rows.data()))
        fail(path, kind + " is truncated or corrupt: its " + std::to_string(header.width) + " x " +
                       std::to_string(header.height) + " pixels cannot be read (" + r.error.text + ")");
    read_end(r);
    if (keep != header.channels) {
        allocate_samples(image);
        const std::size_t pixels = static_cast<std::size_t>(h.width) * h.height;
        for (std::size_t p = 0; p < pixels; ++p)
            for (int c = 0; c < keep; ++c) {
                const std::size_t from = p * static_cast<std::size_t>(h.channels) + static_cast<std::size_t>(c);
                const std::size_t to = p * static_cast<std::size_t>(keep) + static_cast<std::size_t>(c);
                if (header.type == SampleType::uint16)
                    std::memcpy(&image.u16[to], &decoded[from * 2], 2);
                else
                    image.u8[to] = decoded[from];
            }
    }
    return image;
}

void write_png(const std::string& path, const ImageView& image, const WriteOptions& options) {
    int color_type = 0;
    switch (image.channels) {
        case 1: color_type = PNG_COLOR_TYPE_GRAY; break;
        case 2: color_type = PNG_COLOR_TYPE_GRAY_ALPHA; break;
        case 3: color_type = PNG_COLOR_TYPE_RGB; break;
        case 4: color_type = PNG_COLOR_TYPE_RGB_ALPHA; break;
        default: fail(path, "cannot write the image: PNG holds 1 to 4 channels, not " + std::to_string(image.channels));
    }
    if (image.width < 1 || image.height < 1)
        fail(path, "cannot write the image: a PNG needs at least 1 x 1 pixels, not " + std::to_string(image.width) +
                       " x " + std::to_string(image.height));
    const std::size_t row_samples = static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.channels);
    std::vector<std::uint8_t> codes;
    const std::uint8_t* base = static_cast<const std::uint8_t*>(image.samples);
    if (image.type != SampleType::uint8) {
        if (image.type != SampleType::float32) fail(path, "cannot write the image: PNG is written from 8-bit or float samples");
        const float* f = static_cast<const float*>(image.samples);
        codes.resize(row_samples * static_cast<std::size_t>(image.height));
        for (std::size_t i = 0; i < codes.size(); ++i) codes[i] = float_to_code8(f[i]);
        base = codes.data();
    }
    std::vector<png_bytep> rows(static_cast<std::size_t>(image.height));
    for (std::size_t y = 0; y < rows.size(); ++y) rows[y] = const_cast<png_bytep>(base + y * row_samples);

    std::string software = "tessref " TESSREF_VERSION;
    char key[] = "Software";
    png_text text{};
    text.compression = PNG_TEXT_COMPRESSION_NONE;
    text.key = key;
    text.text = software.data();
    text.text_length = software.size();

    bool ok = false;
    std::string reason;
    {
        Writer w;
        w.file = std::fopen(path.c_str(), "wb");
        if (w.file == nullptr) fail(path, std::string("cannot write the image: ") + std::strerror(errno));
        w.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &w.error, on_error, on_warning);
        if (w.png != nullptr) w.info = png_create_info_struct(w.png);
        if (w.png != nullptr && w.info != nullptr) {
            ok = write_all(w, static_cast<png_uint_32>(image.width), static_cast<png_uint_32>(image.height), color_type,
                           &text, options.software_tag ? 1 : 0, rows.data());
            reason = w.error.text;
        } else {
            reason = "libpng cannot start";
        }
        if (ok && std::fflush(w.file) != 0) {
            ok = false;
            reason = std::strerror(errno);
        }
        if (std::fclose(w.file) != 0 && ok) {
            ok = false;
            reason = std::strerror(errno);
        }
        w.file = nullptr;
    }
    if (!ok) {
        std::error_code ec;
        std::filesystem::remove(path, ec);  // never a partial file
        fail(path, "cannot write the image: " + (reason.empty() ? std::string("unknown error") : reason));
    }
}

}  // namespace tessref::image::detail
