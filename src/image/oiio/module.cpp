// tessref_oiio.so: every use of OpenImageIO in tessref, behind the C interface of
// src/image/oiio_module_abi.h. Built as a CMake MODULE and loaded by libtessref only when
// an image needs it (EXR, TIFF, JPEG, ..., and text drawn into pictures); PNG and PNM are
// read and written without it (src/image/image_io.h).
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>

#include "image/oiio_module_abi.h"

struct tessref_oiio_reader {
    std::unique_ptr<OIIO::ImageInput> input;
};

namespace {

// Writes `text` on one line (trailing newlines dropped, inner ones joined by "; ") into the
// caller's buffer; returns 1 (failed) for `return report(...)`.
int report(std::string text, char* error, std::size_t error_size) {
    while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
    for (std::size_t at = text.find('\n'); at != std::string::npos; at = text.find('\n', at)) text.replace(at, 1, "; ");
    if (error != nullptr && error_size > 0) {
        const std::size_t n = std::min(text.size(), error_size - 1);
        std::memcpy(error, text.data(), n);
        error[n] = '\0';
    }
    return 1;
}

OIIO::TypeDesc type_desc(int type) {
    switch (type) {
        case TESSREF_OIIO_UINT8: return OIIO::TypeDesc::UINT8;
        case TESSREF_OIIO_UINT16: return OIIO::TypeDesc::UINT16;
        default: return OIIO::TypeDesc::FLOAT;
    }
}

void copy_name(char* to, std::size_t size, const char* from) {
    std::snprintf(to, size, "%s", from == nullptr ? "" : from);
}

const char* oiio_version() { return OIIO_VERSION_STRING; }

int open_reader(const char* path, tessref_oiio_reader** reader, tessref_oiio_header* header, char* error,
                std::size_t error_size) {
    try {
        *reader = nullptr;
        // The samples as stored: OpenImageIO would otherwise premultiply colour by alpha.
        OIIO::ImageSpec config;
        config.attribute("oiio:UnassociatedAlpha", 1);
        auto input = OIIO::ImageInput::open(path, &config);
        if (!input) return report(OIIO::geterror(), error, error_size);
        const OIIO::ImageSpec& spec = input->spec();
        *header = tessref_oiio_header{};
        header->width = spec.width;
        header->height = spec.height;
        header->depth = spec.depth;
        header->channels = spec.nchannels;
        header->deep = spec.deep ? 1 : 0;
        header->per_channel_formats = spec.channelformats.empty() ? 0 : 1;
        // Channels of different types are read as float.
        header->type = !spec.channelformats.empty()             ? TESSREF_OIIO_FLOAT
                       : spec.format == OIIO::TypeDesc::UINT8    ? TESSREF_OIIO_UINT8
                       : spec.format == OIIO::TypeDesc::UINT16 ? TESSREF_OIIO_UINT16
                                                               : TESSREF_OIIO_FLOAT;
        header->bits_per_sample = 0;
        if (const OIIO::ParamValue* bits = spec.find_attribute("oiio:BitsPerSample")) {
            const float b = bits->get_float(0.0f);
            if (b >= 1.0f && b <= 64.0f) header->bits_per_sample = static_cast<int>(b);
        }
        header->alpha_channel = spec.alpha_channel;
        copy_name(header->pixel_type, sizeof header->pixel_type, spec.format.c_str());
        copy_name(header->format_name, sizeof header->format_name, input->format_name());
        *reader = new tessref_oiio_reader{std::move(input)};
        return 0;
    } catch (const std::exception& e) {
        return report(e.what(), error, error_size);
    }
}

const char* channel_name(const tessref_oiio_reader* reader, int c) {
    const OIIO::ImageSpec& spec = reader->input->spec();
    return c >= 0 && c < static_cast<int>(spec.channelnames.size()) ? spec.channelnames[c].c_str() : "";
}

int read_pixels(tessref_oiio_reader* reader, int channels, int type, void* pixels, char* error,
                std::size_t error_size) {
    try {
        // OpenImageIO 2.4.7's TIFF reader can report success with its error set (a strip past
        // the end of the file reads as zeros): either one means the pixels are not the file's.
        OIIO::ImageInput& input = *reader->input;
        const bool ok = input.read_image(0, 0, 0, channels, type_desc(type), pixels);
        if (!ok || input.has_error()) {
            report(input.geterror(), error, error_size);
            if (!ok && error != nullptr && error_size > 0 && error[0] == '\0') report("read failed", error, error_size);
            return 1;
        }
        return 0;
    } catch (const std::exception& e) {
        return report(e.what(), error, error_size);
    }
}

void close_reader(tessref_oiio_reader* reader) {
    if (reader == nullptr) return;
    try {
        reader->input->close();
    } catch (...) {
    }
    delete reader;
}

int can_write(const char* path, char* error, std::size_t error_size) {
    try {
        if (OIIO::ImageOutput::create(path)) return 0;
        return report(OIIO::geterror(), error, error_size);
    } catch (const std::exception& e) {
        return report(e.what(), error, error_size);
    }
}

int writes_float(const char* path) {
    try {
        auto output = OIIO::ImageOutput::create(path);
        return output && std::strcmp(output->format_name(), "openexr") == 0 ? 1 : 0;
    } catch (...) {
        return 0;
    }
}

int write_image(const char* path, const tessref_oiio_image* image, char* error, std::size_t error_size) {
    try {
        std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create(path);
        if (!out) return report(OIIO::geterror(), error, error_size);
        OIIO::ImageSpec spec(image->width, image->height, image->channels, type_desc(image->type));
        if (image->channel_names != nullptr) {
            spec.channelnames.clear();
            for (int c = 0; c < image->channels; ++c) spec.channelnames.emplace_back(image->channel_names[c]);
        }
        spec.alpha_channel = image->alpha_channel;
        spec.z_channel = image->z_channel;
        // tessref's colour is never premultiplied by alpha (as in its PNGs): a TIFF says so in
        // its ExtraSamples tag (unassociated alpha), which is also what marks the channel as
        // alpha for a reader (OpenImageIO's TIFF writer otherwise writes associated alpha).
        if (spec.alpha_channel >= 0 && std::strcmp(out->format_name(), "tiff") == 0)
            spec.attribute("oiio:UnassociatedAlpha", 1);
        if (image->compression != nullptr) spec.attribute("compression", image->compression);
        if (image->software != nullptr) spec.attribute("Software", image->software);
        spec.attribute("DateTime", "");  // OpenImageIO stamps TIFF and EXR files with the time unless told
        if (!out->open(path, spec) || !out->write_image(type_desc(image->type), image->pixels) || !out->close()) {
            const std::string reason = out->geterror();
            return report(reason.empty() ? std::string("unknown error") : reason, error, error_size);
        }
        return 0;
    } catch (const std::exception& e) {
        return report(e.what(), error, error_size);
    }
}

int draw(const tessref_oiio_canvas* canvas, const tessref_oiio_draw* ops, std::size_t count, int stop_at_failure,
         std::size_t* failed, char* error, std::size_t error_size) {
    try {
        OIIO::ImageBuf image(OIIO::ImageSpec(canvas->width, canvas->height, canvas->channels, type_desc(canvas->type)),
                             canvas->pixels);
        int result = 0;
        for (std::size_t i = 0; i < count; ++i) {
            const tessref_oiio_draw& op = ops[i];
            const OIIO::cspan<float> colour(op.colour, static_cast<std::size_t>(std::min(canvas->channels, 4)));
            bool ok = true;
            switch (op.kind) {
                case TESSREF_OIIO_LINE:
                    ok = OIIO::ImageBufAlgo::render_line(image, op.x0, op.y0, op.x1, op.y1, colour);
                    break;
                case TESSREF_OIIO_POINT: ok = OIIO::ImageBufAlgo::render_point(image, op.x0, op.y0, colour); break;
                case TESSREF_OIIO_BOX:
                case TESSREF_OIIO_FILLED_BOX:
                    ok = OIIO::ImageBufAlgo::render_box(image, op.x0, op.y0, op.x1, op.y1, colour,
                                                        op.kind == TESSREF_OIIO_FILLED_BOX);
                    break;
                case TESSREF_OIIO_TEXT: {
                    const auto align = op.x1 == 0   ? OIIO::ImageBufAlgo::TextAlignX::Left
                                       : op.x1 == 1 ? OIIO::ImageBufAlgo::TextAlignX::Center
                                                    : OIIO::ImageBufAlgo::TextAlignX::Right;
                    ok = OIIO::ImageBufAlgo::render_text(image, op.x0, op.y0, op.text ? op.text : "", op.size,
                                                         op.font ? op.font : "", colour, align,
                                                         OIIO::ImageBufAlgo::TextAlignY::Baseline);
                    break;
                }
                default: ok = false; image.errorfmt("unknown drawing operation {}", op.kind);
            }
            if (!ok) {
                const std::string reason = image.geterror();
                if (result == 0) {
                    if (failed != nullptr) *failed = i;
                    report(reason, error, error_size);
                    result = 1;
                }
                if (stop_at_failure) break;
            }
        }
        (void)image.geterror();
        return result;
    } catch (const std::exception& e) {
        return report(e.what(), error, error_size);
    }
}

constexpr tessref_oiio_api kApi = {
    TESSREF_OIIO_ABI, oiio_version, open_reader, channel_name, read_pixels, close_reader,
    can_write,        writes_float, write_image, draw,
};

}  // namespace

extern "C" __attribute__((visibility("default"))) const tessref_oiio_api* tessref_oiio_entry(int abi) {
    return abi == TESSREF_OIIO_ABI ? &kApi : nullptr;
}
