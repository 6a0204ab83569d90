// Image files: see image_io.h. The format is told by the file's first bytes when reading
// (PNG signature, PNM magic number; anything else goes to OpenImageIO) and by the name's
// extension when writing.
#include "image/image_io.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "image/codecs.h"
#include "image/oiio_module.h"
#include "common/input_file.h"
#include "tessref/error.h"

namespace tessref::image {

namespace fs = std::filesystem;

namespace detail {

const char* oiio_format_by_magic(std::string_view head, const std::string& extension) {
    auto starts = [&](std::string_view magic) { return head.substr(0, magic.size()) == magic; };
    using namespace std::string_view_literals;
    if (starts("\x76\x2f\x31\x01"sv)) return "openexr";
    if (starts("II*\0"sv) || starts("MM\0*"sv) || starts("II+\0"sv) || starts("MM\0+"sv)) return "tiff";
    if (starts("\xff\xd8\xff"sv)) return "jpeg";
    if (starts("#?RADIANCE"sv) || starts("#?RGBE"sv)) return "hdr";
    if (starts("BM"sv)) return "bmp";
    if (starts("GIF87a"sv) || starts("GIF89a"sv)) return "gif";
    if (starts("8BPS"sv)) return "psd";
    if (starts("SDPX"sv) || starts("XPDS"sv)) return "dpx";
    if (starts("\x80\x2a\x5f\xd7"sv) || starts("\xd7\x5f\x2a\x80"sv)) return "cineon";
    if (starts("\0\0\0\x0cjP  \r\n\x87\n"sv) || starts("\xff\x4f\xff\x51"sv)) return "jpeg2000";
    if (starts("RIFF"sv) && head.size() >= 12 && head.substr(8, 4) == "WEBP"sv) return "webp";
    // TGA has no magic number: its name, and a header whose image type is one TGA defines
    // (a file of zeros has type 0, "no image data").
    if (extension == ".tga" && head.size() >= 3 && static_cast<unsigned char>(head[1]) <= 1) {
        const unsigned char type = static_cast<unsigned char>(head[2]);
        if (type == 1 || type == 2 || type == 3 || type == 9 || type == 10 || type == 11) return "targa";
    }
    return nullptr;
}

void fail(const std::string& path, const std::string& what) { throw Error(what, Where::in_file(path)); }

void accept_header(const std::string& path, const ReadOptions& options, const ImageHeader& header) {
    if (header.width <= 0 || header.height <= 0 || header.depth > 1 || header.channels <= 0)
        fail(path, options.kind + " has no pixels: its header says " + std::to_string(header.width) + " x " +
                       std::to_string(header.height) + ", " + std::to_string(header.channels) + " channel(s)");
    if (options.check_header) options.check_header(header);
}

void default_channel_names(ImageHeader& header) {
    header.channel_names.clear();
    header.alpha_channel = -1;
    if (header.channels == 1) {
        header.channel_names = {"Y"};
    } else if (header.channels == 2) {
        header.channel_names = {"Y", "A"};
        header.alpha_channel = 1;
    } else {
        static const char* const rgba[] = {"R", "G", "B", "A"};
        for (int c = 0; c < header.channels; ++c)
            header.channel_names.push_back(c < 4 ? rgba[c] : "channel" + std::to_string(c));
        if (header.channels >= 4) header.alpha_channel = 3;
    }
}

void allocate_samples(Image& image) {
    const std::size_t count = static_cast<std::size_t>(image.header.width) *
                              static_cast<std::size_t>(image.header.height) * static_cast<std::size_t>(image.channels);
    switch (image.header.type) {
        case SampleType::uint8: image.u8.resize(count); break;
        case SampleType::uint16: image.u16.resize(count); break;
        case SampleType::float32: image.f32.resize(count); break;
    }
}

}  // namespace detail

namespace {

using detail::fail;

std::string lower_extension(const std::string& path) {
    std::string extension = fs::path(path).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return extension;
}

int oiio_type(SampleType type) {
    switch (type) {
        case SampleType::uint8: return TESSREF_OIIO_UINT8;
        case SampleType::uint16: return TESSREF_OIIO_UINT16;
        case SampleType::float32: break;
    }
    return TESSREF_OIIO_FLOAT;
}

// Every other format, through the module.
Image read_with_oiio(const std::string& path, const ReadOptions& options) {
    const tessref_oiio_api& oiio = oiio_module("reading " + options.kind + " " + path, path);
    char error[1024] = "";
    tessref_oiio_reader* raw = nullptr;
    tessref_oiio_header h{};
    if (oiio.open_reader(path.c_str(), &raw, &h, error, sizeof error) != 0)
        fail(path, "cannot read " + options.kind + ": " + (error[0] ? std::string(error) : "unknown image format"));
    struct Closer {
        const tessref_oiio_api& oiio;
        tessref_oiio_reader* reader;
        ~Closer() { oiio.close_reader(reader); }
    } closer{oiio, raw};

    Image image;
    ImageHeader& header = image.header;
    header.width = h.width;
    header.height = h.height;
    header.depth = h.depth;
    header.channels = h.channels;
    header.deep = h.deep != 0;
    header.per_channel_formats = h.per_channel_formats != 0;
    header.type = h.type == TESSREF_OIIO_UINT8    ? SampleType::uint8
                  : h.type == TESSREF_OIIO_UINT16 ? SampleType::uint16
                                                  : SampleType::float32;
    header.pixel_type = h.pixel_type;
    header.format = h.format_name;
    header.alpha_channel = h.alpha_channel;
    // Where the reader names no bit depth, the type's (a half file: 16).
    header.bits_per_sample = h.bits_per_sample;
    for (int c = 0; c < std::max(0, h.channels) && c < 4096; ++c) header.channel_names.emplace_back(oiio.channel_name(raw, c));
    if (header.bits_per_sample == 0) {
        const std::string& t = header.pixel_type;
        header.bits_per_sample = t == "uint8" || t == "int8" ? 8
                                 : t == "uint16" || t == "int16" || t == "half" ? 16
                                 : t == "double" || t == "uint64" || t == "int64" ? 64
                                                                                  : 32;
    }
    detail::accept_header(path, options, header);
    if (header.deep) fail(path, options.kind + " is a deep image; tessref reads flat images only");
    image.channels = std::min(header.channels, options.max_channels);
    detail::allocate_samples(image);
    void* pixels = header.type == SampleType::uint8    ? static_cast<void*>(image.u8.data())
                   : header.type == SampleType::uint16 ? static_cast<void*>(image.u16.data())
                                                       : static_cast<void*>(image.f32.data());
    if (oiio.read_pixels(raw, image.channels, oiio_type(header.type), pixels, error, sizeof error) != 0)
        fail(path, options.kind + " is truncated or corrupt: its " + std::to_string(header.width) + " x " +
                       std::to_string(header.height) + " pixels cannot be read" +
                       (error[0] ? " (" + std::string(error) + ")" : std::string()));
    return image;
}

}  // namespace

Image read_image(const std::string& path, const ReadOptions& options) {
    const std::string& kind = options.kind;
    // A device, FIFO or socket has no end to read to (/dev/zero, /dev/urandom would keep a
    // reader going forever) and no header to check before reading: only regular files.
    std::string head;
    {
        const InputFile file(path, kind);
        if (file.size() == 0) fail(path, kind + " is an empty file (0 bytes)");
        head = file.head(16);
    }
    // The reader is chosen by the file's first bytes, before anything else is read: a file
    // that starts as no format tessref reads (a gigabyte of zeros named .png) is refused at
    // once, where OpenImageIO would have tried every reader it has on the whole file.
    if (detail::is_png(head)) return detail::read_png(path, options);
    if (detail::is_pnm(head)) return detail::read_pnm(path, options);
    if (detail::oiio_format_by_magic(head, lower_extension(path)) != nullptr) return read_with_oiio(path, options);
    fail(path, "cannot read " + kind + ": its first bytes are no image format tessref reads (PNG, PNM, PFM, "
                                       "OpenEXR, TIFF, JPEG, Radiance HDR, BMP, GIF, Photoshop, DPX, Cineon, "
                                       "JPEG 2000, WebP, TGA by its .tga name)");
}

ImageHeader read_image_header(const std::string& path, const std::string& kind) {
    // read_image() stops at check_header, before any pixel is allocated.
    struct HeaderOnly {
        ImageHeader header;
    };
    ReadOptions options;
    options.kind = kind;
    options.check_header = [](const ImageHeader& header) { throw HeaderOnly{header}; };
    try {
        (void)read_image(path, options);
    } catch (const HeaderOnly& h) {
        return h.header;
    }
    fail(path, "cannot read " + kind + ": no header");
}

void write_image(const std::string& path, const ImageView& image, const WriteOptions& options) {
    if (lower_extension(path) == ".png") {
        detail::write_png(path, image, options);
        return;
    }
    const tessref_oiio_api& oiio = oiio_module("writing the image " + path, path);
    std::vector<const char*> names;
    for (const std::string& n : options.channel_names) names.push_back(n.c_str());
    const std::string software = "tessref " TESSREF_VERSION;
    tessref_oiio_image spec{};
    spec.width = image.width;
    spec.height = image.height;
    spec.channels = image.channels;
    spec.type = oiio_type(image.type);
    spec.pixels = image.samples;
    spec.channel_names = names.size() == static_cast<std::size_t>(image.channels) ? names.data() : nullptr;
    spec.alpha_channel = options.alpha_channel;
    spec.z_channel = options.z_channel;
    spec.compression = options.compression.empty() ? nullptr : options.compression.c_str();
    spec.software = options.software_tag ? software.c_str() : nullptr;
    char error[1024] = "";
    errno = 0;
    if (oiio.write_image(path.c_str(), &spec, error, sizeof error) != 0) {
        // Some codecs (OpenEXR: "File output failed.") drop the system's reason. A write that
        // the disk refused leaves it in errno; only those reasons are added, since a codec's
        // own probing (a stat of a missing file) may leave others there.
        const int system_error = errno;
        std::string reason = error[0] ? std::string(error) : std::string("unknown error");
        if (system_error == ENOSPC || system_error == EFBIG || system_error == EDQUOT || system_error == EIO ||
            system_error == EROFS) {
            const std::string words = std::generic_category().message(system_error);
            if (reason.find(words) == std::string::npos) reason += " (" + words + ")";
        }
        std::error_code ec;
        fs::remove(path, ec);  // never a partial file
        fail(path, "cannot write the image: " + reason);
    }
}

void require_writable(const std::string& path, const std::string& what) {
    if (lower_extension(path) == ".png") return;
    const tessref_oiio_api& oiio = oiio_module("writing the image " + path, path);
    char error[1024] = "";
    if (oiio.can_write(path.c_str(), error, sizeof error) != 0)
        throw Error("no image format for '" + path + "': give the name an extension tessref writes, such as .png, .tif or .exr",
                    Where::in_file(what));
}

bool writes_float(const std::string& path) {
    if (lower_extension(path) == ".png") return false;
    return oiio_module("writing the image " + path, path).writes_float(path.c_str()) != 0;
}

}  // namespace tessref::image
