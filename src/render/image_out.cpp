// Images of a render (src/image/image_io.h): 8-bit PNG/TIFF for eyes, float EXR with the
// provenance channels (render.h).
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "image/image_io.h"
#include "picture/canvas.h"
#include "render/render_internal.h"
#include "tessref/error.h"
#include "tessref/render.h"

namespace tessref {

namespace {

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return s;
}

// The level heat map as a picture for eyes (`render --aov level -o FILE.png`): every pixel in
// level_heat_colour() (black: no surface), and below it a band with the colour map's legend,
// a bar over log2(level) 0..6 with the levels 1, 2, 4, ... 64 under their places. Drawn with
// the picture kit's bitmap face, so the bytes do not depend on the machine's fonts.
void write_level_heat_png(const RenderResult& result, const std::string& path) {
    const int w = result.width, h = result.height;
    const int scale = w >= 480 ? 2 : 1;                 // the bitmap face's cell, in pixels
    const int text = picture::kBitmapGlyphRows * scale;  // a line of text's height
    const int bar_top = h + 6, bar_bottom = bar_top + 4 * scale + 4;
    const int labels = bar_bottom + 4 + text, caption = labels + 6 + text;
    picture::Canvas canvas(w, caption + 6, 3, image::SampleType::uint8, picture::Colour{}, path);
    const auto colour = [](glm::vec3 c) { return picture::Colour{c.r, c.g, c.b}; };
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            canvas.put(x, y, colour(level_heat_colour(result.level[static_cast<std::size_t>(y) * w + x])));
    // The bar spans the picture less a margin for the end labels; level L sits at log2(L) / 6.
    const int margin = std::min(4 * 4 * scale, w / 4), x0 = margin, x1 = std::max(x0 + 1, w - 1 - margin);
    const auto at = [&](double level) { return x0 + (x1 - x0) * std::log2(level) / 6.0; };
    for (int x = x0; x <= x1; ++x) {
        const float level = std::exp2(6.0f * static_cast<float>(x - x0) / static_cast<float>(x1 - x0));
        for (int y = bar_top; y < bar_bottom; ++y) canvas.put(x, y, colour(level_heat_colour(level)));
    }
    const picture::Colour white{1.0f, 1.0f, 1.0f};
    for (int level = 1; level <= 64; level *= 2) {
        const int x = static_cast<int>(std::lround(at(level)));
        for (int y = bar_bottom; y < bar_bottom + 3; ++y) canvas.put(x, y, white);
        canvas.bitmap_text(x, labels, std::to_string(level), picture::Anchor::middle, white, scale);
    }
    // The longest caption that fits (a glyph advances four cells).
    for (const char* words : {"TESSELLATION LEVEL, LOG SCALE. BLACK: NO SURFACE", "LEVEL, LOG SCALE. BLACK: NO SURFACE",
                              "LEVEL. BLACK: NONE", "LEVEL"})
        if (x0 + static_cast<int>(std::string(words).size()) * 4 * scale <= w || std::string(words) == "LEVEL") {
            canvas.bitmap_text(x0, caption, words, picture::Anchor::start, white, scale);
            break;
        }
    image::WriteOptions options;
    options.software_tag = true;  // and no time stamp: the same render gives the same bytes
    image::write_image(path, canvas.view(), options);
}

}  // namespace

ImageFormat image_format_from_path(const std::string& path) {
    const std::string extension = lower(std::filesystem::path(path).extension().string());
    if (extension == ".png") return ImageFormat::png;
    if (extension == ".tif" || extension == ".tiff") return ImageFormat::tiff;
    if (extension == ".exr") return ImageFormat::exr;
    throw Error("cannot tell the image format of '" + path + "': the name must end in .png, .exr, .tif or .tiff",
                Where::in_file(path));
}

AovSelection parse_aovs(std::string_view list) {
    AovSelection aovs;
    std::size_t start = 0;
    while (start <= list.size()) {
        const std::size_t comma = std::min(list.find(',', start), list.size());
        std::string item(list.substr(start, comma - start));
        item.erase(0, item.find_first_not_of(" \t"));
        item.erase(item.find_last_not_of(" \t") + 1);
        if (item == "depth") aovs.depth = true;
        else if (item == "patch") aovs.patch = true;
        else if (item == "triangle") aovs.triangle = true;
        else if (item == "tesscoord") aovs.tesscoord = true;
        else if (item == "level") aovs.level = true;
        else
            throw Error("unknown AOV '" + item + "'; expected a comma-separated list of depth, patch, triangle, "
                        "tesscoord, level",
                        Where::at_key("--aov"));
        start = comma + 1;
    }
    return aovs;
}

void write_image(const RenderResult& result, const std::string& path, ImageFormat format, const AovSelection& aovs) {
    if (aovs.any() && format == ImageFormat::png && aovs_as_png(aovs)) {
        write_level_heat_png(result, path);
        return;
    }
    if (aovs.any() && format != ImageFormat::exr)
        throw Error("AOV channels need an EXR file (float channels): name the output *.exr; a PNG takes --aov level "
                    "alone (the level heat map)",
                    Where::in_file(path));
    const int width = result.width, height = result.height;
    const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    image::WriteOptions options;
    options.software_tag = true;  // and no time stamp: the same render gives the same bytes
    if (format != ImageFormat::exr) {
        // A colour8 render's codes as they are; else converted into a buffer not cleared
        // first: every byte is written by to_rgba8, on every thread.
        std::unique_ptr<std::uint8_t[]> converted;
        const auto* codes = reinterpret_cast<const std::uint8_t*>(result.rgba8.data());
        if (result.rgba8.size() != n) {
            converted = std::make_unique_for_overwrite<std::uint8_t[]>(n * 4);
            render_detail::to_rgba8(result, converted.get());
            codes = converted.get();
        }
        if (format == ImageFormat::tiff) options.compression = "zip";
        // Named and marked as the PNG's are, so that a reader (compare --ignore-alpha) knows
        // the fourth channel for alpha.
        options.channel_names = {"R", "G", "B", "A"};
        options.alpha_channel = 3;
        image::write_image(path, {width, height, 4, image::SampleType::uint8, codes}, options);
        return;
    }
    if (result.colour.size() != n)
        throw Error("an EXR holds the float colour, which this render did not keep (RenderOptions::colour8)",
                    Where::in_file(path));

    std::vector<std::string> names{"R", "G", "B", "A"};
    if (aovs.depth) names.push_back("Z");
    if (aovs.patch) names.push_back("patch_id");
    if (aovs.triangle) names.push_back("triangle_id");
    if (aovs.tesscoord) names.insert(names.end(), {"tess_coord.u", "tess_coord.v", "tess_coord.w"});
    if (aovs.level) names.insert(names.end(), {"level", "level_heat.R", "level_heat.G", "level_heat.B"});
    const std::size_t channels = names.size();
    std::vector<float> pixels(n * channels);
    auto id_value = [](std::uint32_t id) { return id == kNoPixelId ? -1.0f : static_cast<float>(id); };
    for (std::size_t i = 0; i < n; ++i) {
        float* p = &pixels[i * channels];
        std::size_t c = 0;
        for (int k = 0; k < 4; ++k) p[c++] = result.colour[i][k];
        if (aovs.depth) p[c++] = result.depth[i];
        if (aovs.patch) p[c++] = id_value(result.patch_id[i]);
        if (aovs.triangle) p[c++] = id_value(result.triangle_id[i]);
        if (aovs.tesscoord)
            for (int k = 0; k < 3; ++k) p[c++] = result.tess_coord[i][k];
        if (aovs.level) {
            p[c++] = result.level[i];
            const glm::vec3 heat = level_heat_colour(result.level[i]);
            for (int k = 0; k < 3; ++k) p[c++] = heat[k];
        }
    }
    options.channel_names = names;
    options.alpha_channel = 3;
    options.z_channel = aovs.depth ? 4 : -1;
    options.compression = "zip";
    image::write_image(path, {width, height, static_cast<int>(channels), image::SampleType::float32, pixels.data()},
                       options);
}

}  // namespace tessref
