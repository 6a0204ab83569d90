// PNG read through libpng, as OpenImageIO 2.4.7 read it (the values tessref has always
// used): png_set_expand (palette to RGB, grey below 8 bits to 8, tRNS to an alpha channel),
// 16-bit samples as such, no gamma, no premultiplication. Written 8-bit, a Software text
// chunk when asked, no time, compressed by zlib in parallel (see "writing" below).
//
// libpng reports errors by longjmp: every libpng call runs inside a small function that
// sets the jump point and holds no C++ object, and the structures are freed by one owner
// whatever happens, so an error leaks nothing and unwinds no C++ frame.
#include <png.h>
#include <zlib.h>

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

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "common/parallel.h"
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
// (bench/scenes/jacksboro-grid-16.toml) zlib level 1 with the Sub filter took 35 ms and
// 511 KB on one thread, where OpenImageIO's level 6 without filters took 159 ms for 365 KB.
// With the Average filter and memLevel 6 (below) the same rows take 9 % less time and 11 %
// less space (454 KB); levels 2 and 3 compress 4 and 11 % better in about 20 and 60 % more
// time.
constexpr int kCompressionLevel = 1;
// zlib's memLevel: a hash table of 2^(6 + 7) entries (16 KiB, in the first-level cache) and
// blocks of 4096 symbols, where the default 8 has 2^15 (64 KiB) and 16384: 5 % faster at
// level 1 on rendered rows for 0.4 % more bytes; 9 was 10 % slower, 5 and below larger.
constexpr int kMemoryLevel = 6;

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
// The walk also stops at the first bytes that are no chunk: PNG's first chunk is IHDR, and a
// chunk type is four ASCII letters (PNG 1.2, section 3.3), so a valid signature followed by
// a gigabyte of zeros is refused at byte 8 instead of being walked 12 bytes at a time. The
// file is read in blocks, in order; a chunk's data is skipped by seeking only when it
// reaches past the block in hand.
void check_chunks(const std::string& path, const std::string& kind) {
    std::ifstream in(path, std::ios::binary);
    std::error_code ec;
    const std::uint64_t size = std::filesystem::file_size(path, ec);
    if (ec) return;
    std::vector<unsigned char> block(std::size_t{1} << 16);
    std::uint64_t block_start = 0, block_end = 0;  // file offsets of the bytes in `block`
    std::uint64_t offset = 8;
    while (offset < size) {
        if (offset + 8 > block_end) {  // the header is not (wholly) in the block: refill at it
            in.clear();
            in.seekg(static_cast<std::streamoff>(offset));
            in.read(reinterpret_cast<char*>(block.data()), static_cast<std::streamsize>(block.size()));
            block_start = offset;
            block_end = offset + static_cast<std::uint64_t>(in.gcount());
            if (block_end < offset + 8)
                fail(path, kind + " is a truncated PNG: a chunk header is cut at byte " + std::to_string(offset));
        }
        const unsigned char* head = block.data() + (offset - block_start);
        const std::uint64_t length = (std::uint64_t{head[0]} << 24) | (std::uint64_t{head[1]} << 16) |
                                     (std::uint64_t{head[2]} << 8) | std::uint64_t{head[3]};
        std::string type(reinterpret_cast<const char*>(head + 4), 4);
        const bool letters = std::all_of(type.begin(), type.end(), [](char c) {
            return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z');
        });
        for (char& c : type)
            if (!std::isprint(static_cast<unsigned char>(c))) c = '?';
        if (!letters)
            fail(path, kind + " is a corrupt PNG: the bytes at " + std::to_string(offset) + " ('" + type +
                           "') are no chunk type (four ASCII letters)");
        if (offset == 8 && type != "IHDR")
            fail(path, kind + " is a corrupt PNG: its first chunk is '" + type + "', not IHDR");
        if (length > size - offset - 8 || size - offset - 8 - length < 4)
            fail(path, kind + " is a corrupt PNG: chunk '" + type + "' at byte " + std::to_string(offset) +
                           " declares " + std::to_string(length) + " bytes, more than the file holds (" +
                           std::to_string(size) + " bytes)");
        offset += 12 + length;
        if (type == "IEND") return;
    }
}

// ---- writing ------------------------------------------------------------------------
//
// libpng compresses on one thread, and a render's PNG is written after the render, where
// nothing else runs. So the file is put together here and zlib does the compression, cut
// into bands as pigz cuts a gzip stream: every row is filtered (Average: each byte less the
// mean of the byte one pixel to its left and the byte above it), the filtered rows are split into bands of about kBandBytes,
// and the bands are deflated in parallel, each primed with the 32 KiB of filtered data
// before it (deflateSetDictionary) so that a cut costs almost no compression. A band filters
// its own rows, and again the rows before it that the primer reads, into a buffer of its
// own: no image-sized buffer of filtered rows is cleared and faulted in on one thread, and
// the rows are still in cache when zlib reads them. Every band
// but the last ends on a byte boundary (Z_SYNC_FLUSH), so the bands' raw deflate data
// concatenate into one deflate stream; the zlib stream around them (RFC 1950) takes the
// Adler-32 combined from the bands' (adler32_combine). Each band is one IDAT chunk.

constexpr std::size_t kBandBytes = std::size_t{256} << 10;
constexpr std::size_t kDeflateWindow = std::size_t{32} << 10;

void put32(std::vector<std::uint8_t>& out, std::uint32_t v) {
    for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<std::uint8_t>(v >> shift));
}

// One chunk: length, type, data, CRC-32 of type and data (PNG 1.2, section 5.3).
void put_chunk(std::vector<std::uint8_t>& out, const char (&type)[5], const std::uint8_t* data, std::size_t size) {
    put32(out, static_cast<std::uint32_t>(size));
    const auto* type_bytes = reinterpret_cast<const std::uint8_t*>(type);
    out.insert(out.end(), type_bytes, type_bytes + 4);
    if (size > 0) out.insert(out.end(), data, data + size);
    uLong crc = crc32_z(0, type_bytes, 4);
    if (size > 0) crc = crc32_z(crc, data, size);
    put32(out, static_cast<std::uint32_t>(crc));
}

// One row's Average filter (PNG 1.2, section 6.5): each byte less the mean, rounded down,
// of the byte one pixel (`pixel` bytes) to its left and the byte above it, modulo 256; a
// byte left of the row or above the image counts as 0 (`above` null for the first row).
// Sixteen bytes at a time with SSE2: pavgb rounds the mean up, so the sum's low bit, where
// it is 1, is taken off; the byte subtraction wraps as the filter's does. Of None, Sub, Up,
// Average and Paeth on a rendered image (the level-16 bench image's rows, zlib level 1) it
// compresses best (452 KB; Sub 510, Paeth 466, Up 475) and zlib spends the fewest
// instructions on it (8 % fewer than on Sub).
void average_filter(const std::uint8_t* in, const std::uint8_t* above, std::uint8_t* out, std::size_t row,
                    std::size_t pixel) {
    const auto up = [&](std::size_t i) { return above != nullptr ? above[i] : 0; };
    std::size_t i = 0;
    for (; i < std::min(pixel, row); ++i) out[i] = static_cast<std::uint8_t>(in[i] - (up(i) >> 1));
#if defined(__SSE2__)
    if (above != nullptr) {
        for (; i + 16 <= row; i += 16) {
            const __m128i here = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in + i));
            const __m128i left = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in + i - pixel));
            const __m128i over = _mm_loadu_si128(reinterpret_cast<const __m128i*>(above + i));
            const __m128i odd = _mm_and_si128(_mm_xor_si128(left, over), _mm_set1_epi8(1));
            const __m128i mean = _mm_sub_epi8(_mm_avg_epu8(left, over), odd);
            _mm_storeu_si128(reinterpret_cast<__m128i*>(out + i), _mm_sub_epi8(here, mean));
        }
    }
#endif
    for (; i < row; ++i) out[i] = static_cast<std::uint8_t>(in[i] - ((in[i - pixel] + up(i)) >> 1));
}

// Rows [first, end) of the image, filtered, one after the other: each row's filter-type
// byte, then the filtered row (`row` bytes of `pixel`-byte pixels).
void filter_rows(const std::uint8_t* samples, std::size_t row, std::size_t pixel, std::size_t first, std::size_t end,
                 std::uint8_t* out) {
    for (std::size_t y = first; y < end; ++y, out += row + 1) {
        out[0] = 3;  // the filter type: Average
        average_filter(samples + y * row, y > 0 ? samples + (y - 1) * row : nullptr, out + 1, row, pixel);
    }
}

// The raw deflate data of filtered[begin, end), primed with what precedes it; the last band
// finishes the stream. Empty on a zlib failure.
std::vector<std::uint8_t> deflate_band(const std::vector<std::uint8_t>& filtered, std::size_t begin, std::size_t end,
                                       bool last) {
    z_stream z{};
    if (deflateInit2(&z, kCompressionLevel, Z_DEFLATED, -15, kMemoryLevel, Z_DEFAULT_STRATEGY) != Z_OK) return {};
    std::vector<std::uint8_t> out;
    bool ok = true;
    const std::size_t primer = std::min(begin, kDeflateWindow);
    if (primer > 0)
        ok = deflateSetDictionary(&z, filtered.data() + begin - primer, static_cast<uInt>(primer)) == Z_OK;
    if (ok) {
        // deflateBound covers a finished stream; a sync flush adds an empty stored block.
        out.resize(deflateBound(&z, static_cast<uLong>(end - begin)) + 16);
        z.next_in = const_cast<Bytef*>(filtered.data() + begin);
        z.avail_in = static_cast<uInt>(end - begin);
        z.next_out = out.data();
        z.avail_out = static_cast<uInt>(out.size());
        const int rc = deflate(&z, last ? Z_FINISH : Z_SYNC_FLUSH);
        ok = rc == (last ? Z_STREAM_END : Z_OK) && z.avail_in == 0 && z.avail_out > 0;
        out.resize(z.total_out);
    }
    deflateEnd(&z);
    return ok ? out : std::vector<std::uint8_t>{};
}

// The whole file: signature, IHDR, the Software tEXt when given, the IDATs, IEND. False on a
// zlib failure.
bool encode_png(const std::uint8_t* samples, int width, int height, int channels, std::uint8_t color_type,
                const std::string* software, std::vector<std::uint8_t>& file) {
    const std::size_t pixel = static_cast<std::size_t>(channels);
    const std::size_t row = static_cast<std::size_t>(width) * pixel;
    const std::size_t stride = row + 1;  // a filter-type byte, then the filtered row
    const std::size_t rows = static_cast<std::size_t>(height);
    const std::size_t band_rows = std::max<std::size_t>(1, kBandBytes / stride);
    const std::size_t bands = (rows + band_rows - 1) / band_rows;
    // Band b is rows [first_row(b), first_row(b + 1)); its primer, the rows before it that
    // hold the last kDeflateWindow filtered bytes.
    const auto first_row = [&](std::size_t b) { return std::min(rows, b * band_rows); };
    const std::size_t primer_rows = (kDeflateWindow + stride - 1) / stride;
    std::vector<std::vector<std::uint8_t>> deflated(bands);
    std::vector<uLong> adler(bands);
    tessref::parallel_for(std::size_t{0}, bands, [&](std::size_t b) {
        const std::size_t first = first_row(b), end = first_row(b + 1);
        const std::size_t primed = first - std::min(first, primer_rows);
        std::vector<std::uint8_t> filtered((end - primed) * stride);
        filter_rows(samples, row, pixel, primed, end, filtered.data());
        const std::size_t begin = (first - primed) * stride;
        deflated[b] = deflate_band(filtered, begin, filtered.size(), b + 1 == bands);
        adler[b] = adler32_z(1, filtered.data() + begin, filtered.size() - begin);
    });
    uLong checksum = adler[0];
    for (std::size_t b = 0; b < bands; ++b) {
        if (deflated[b].empty()) return false;
        const std::size_t band_bytes = (first_row(b + 1) - first_row(b)) * stride;
        if (b > 0) checksum = adler32_combine(checksum, adler[b], static_cast<z_off_t>(band_bytes));
    }

    static constexpr std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    file.assign(kSignature, kSignature + 8);
    std::vector<std::uint8_t> data;
    put32(data, static_cast<std::uint32_t>(width));
    put32(data, static_cast<std::uint32_t>(height));
    for (const std::uint8_t b : {std::uint8_t{8}, color_type, std::uint8_t{0}, std::uint8_t{0}, std::uint8_t{0}})
        data.push_back(b);  // bit depth, colour type, deflate, adaptive filtering, no interlace
    put_chunk(file, "IHDR", data.data(), data.size());
    if (software != nullptr) {
        static constexpr char kKey[] = "Software";
        data.assign(kKey, kKey + sizeof kKey);  // the key and its NUL
        data.insert(data.end(), software->begin(), software->end());
        put_chunk(file, "tEXt", data.data(), data.size());
    }
    for (std::size_t b = 0; b < bands; ++b) {
        data.clear();
        if (b == 0) data = {0x78, 0x01};  // zlib header: deflate, 32 KiB window, fastest level
        data.insert(data.end(), deflated[b].begin(), deflated[b].end());
        if (b + 1 == bands) put32(data, static_cast<std::uint32_t>(checksum));
        put_chunk(file, "IDAT", data.data(), data.size());
    }
    put_chunk(file, "IEND", nullptr, 0);
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
    const std::string software = "tessref " TESSREF_VERSION;
    std::vector<std::uint8_t> file;
    if (!encode_png(base, image.width, image.height, image.channels, static_cast<std::uint8_t>(color_type),
                    options.software_tag ? &software : nullptr, file))
        fail(path, "cannot write the image: zlib cannot compress it");
    std::string reason;
    std::FILE* out = std::fopen(path.c_str(), "wb");
    if (out == nullptr) fail(path, std::string("cannot write the image: ") + std::strerror(errno));
    bool ok = std::fwrite(file.data(), 1, file.size(), out) == file.size() && std::fflush(out) == 0;
    if (!ok) reason = std::strerror(errno);
    if (std::fclose(out) != 0 && ok) {
        ok = false;
        reason = std::strerror(errno);
    }
    if (!ok) {
        std::error_code ec;
        std::filesystem::remove(path, ec);  // never a partial file
        fail(path, "cannot write the image: " + reason);
    }
}

}  // namespace tessref::image::detail
