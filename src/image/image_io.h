// src/image/image_io.h — every image file tessref reads or writes goes through here.
//
// PNG (src/image/png.cpp: libpng reads, zlib compresses) and the PNM family (P1-P6, PFM; src/image/pnm.cpp)
// are read and written in the library itself; every other format (EXR, TIFF, JPEG, HDR, ...)
// and the drawing of lines and text into pictures go through OpenImageIO in the module
// tessref_oiio.so, loaded on first use (src/image/oiio_module.h). A render that reads PGM
// and PNG and writes PNG therefore never loads OpenImageIO (docs/ARCHITECTURE.md, "Image
// files"). Samples are as OpenImageIO 2.4.7 reads them (the values tessref has always
// used): integer files as their codes scaled to the type's full range (a PNM with maxval
// m: min(v, m) * 255 / m or * 65535 / m, truncated), PNG expanded to 8 bits below 8 bits,
// palettes to RGB(A), tRNS to alpha, no gamma applied, colour never premultiplied.
// Errors are tessref::Error at the file (Where::in_file).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace tessref::image {

// The samples as read: a file's own type for 8- and 16-bit integer files, float otherwise.
enum class SampleType { uint8, uint16, float32 };

struct ImageHeader {
    int width = 0;
    int height = 0;
    int depth = 1;       // > 1: a volume (OpenImageIO formats only)
    int channels = 0;    // in the file
    bool deep = false;   // a deep image (OpenEXR): no flat pixels
    bool per_channel_formats = false;
    SampleType type = SampleType::uint8;
    int bits_per_sample = 0;  // as the file says (a PNM with maxval 1023: 10), else the type's
    std::string pixel_type;   // the file's sample type as OpenImageIO names it: "uint8", "half", ...
    std::string format;       // "png", "pnm", or the OpenImageIO reader's name ("openexr", "tiff", ...)
    int alpha_channel = -1;
    std::vector<std::string> channel_names;
};

struct Image {
    ImageHeader header;
    int channels = 0;  // kept: the first min(header.channels, max_channels)
    std::vector<std::uint8_t> u8;   // header.type uint8
    std::vector<std::uint16_t> u16; // header.type uint16
    std::vector<float> f32;         // header.type float32
};

struct ReadOptions {
    // What the file is to the caller, the subject of every message: "height map" gives
    // "height map not found", "cannot read height map: ...".
    std::string kind = "image";
    int max_channels = 1 << 30;
    // Sees the header (after the checks that it has pixels) before any memory is taken for
    // them; throws to refuse the file (a size limit).
    std::function<void(const ImageHeader&)> check_header;
};

// Reads subimage 0, mip level 0, rows top first. Only regular files: a device or FIFO is
// refused before it is opened, as is an empty file.
Image read_image(const std::string& path, const ReadOptions& options = {});

// The header alone (the checks of read_image, no pixels read): for a command that adds up
// what its inputs will cost before it reads any of them.
ImageHeader read_image_header(const std::string& path, const std::string& kind);

// An image to write: height rows of width * channels samples, top row first.
struct ImageView {
    int width = 0;
    int height = 0;
    int channels = 0;
    SampleType type = SampleType::uint8;  // uint8 or float32
    const void* samples = nullptr;
};

struct WriteOptions {
    std::vector<std::string> channel_names;  // empty: the format's defaults
    int alpha_channel = -1;
    int z_channel = -1;
    std::string compression;       // empty: the format's default ("zip" for TIFF and EXR)
    bool software_tag = false;     // write Software = "tessref <version>"
};

// Writes `image` to `path` in the format its extension names: .png by tessref with zlib (8-bit,
// float samples rounded as OpenImageIO converts them), anything else through the
// OpenImageIO module. Never a time stamp. Writes `path` itself: callers give
// a temporary name and rename it into place (cli_util.h AtomicOutput).
void write_image(const std::string& path, const ImageView& image, const WriteOptions& options = {});

// Whether `path`'s extension names a format that can be written, as an error naming
// `what` (a flag such as "--diff") when not; loads the module only for formats it writes.
void require_writable(const std::string& path, const std::string& what);

// Whether images named `path` are written as float (OpenEXR) rather than 8-bit.
bool writes_float(const std::string& path);

// OpenImageIO's conversion of a float to an 8-bit code (ImageBuf::setpixel, a float image
// written as UINT8): clamp(v * 255 + 0.5, 0, 255) truncated.
inline std::uint8_t float_to_code8(float v) {
    const float s = v * 255.0f + 0.5f;
    return static_cast<std::uint8_t>(s >= 0.0f ? (s <= 255.0f ? s : 255.0f) : 0.0f);  // NaN: 0
}

}  // namespace tessref::image
