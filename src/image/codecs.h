// src/image/codecs.h — the readers and writers behind image_io.h (private to src/image/).
#pragma once

#include <string>
#include <string_view>

#include "image/image_io.h"

namespace tessref::image::detail {

[[noreturn]] void fail(const std::string& path, const std::string& what);

// A header with no pixels (a side of 0 or less, no channels) is refused here, as
// "<kind> has no pixels: its header says W x H, C channel(s)"; then options.check_header.
void accept_header(const std::string& path, const ReadOptions& options, const ImageHeader& header);

// "Y" for one channel, "Y", "A" for two, "R", "G", "B"[, "A"] for three and four; the alpha channel.
void default_channel_names(ImageHeader& header);

// Sizes the sample vector of image.header.type for width * height * channels samples.
void allocate_samples(Image& image);

// The first 8 bytes are PNG's signature / the first two a PNM magic number (P1-P6, Pf, PF).
bool is_png(const std::string& head);
bool is_pnm(const std::string& head);
// The format OpenImageIO will be asked to read, told by the first 16 bytes (and, for TGA,
// which has no magic number, by the lower-case extension ".tga"); nullptr for none.
const char* oiio_format_by_magic(std::string_view head, const std::string& extension);

Image read_png(const std::string& path, const ReadOptions& options);
Image read_pnm(const std::string& path, const ReadOptions& options);
void write_png(const std::string& path, const ImageView& image, const WriteOptions& options);

}  // namespace tessref::image::detail
