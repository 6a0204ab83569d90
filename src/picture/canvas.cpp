// src/picture/canvas.cpp — see canvas.h.
#include "picture/canvas.h"

#include <cstring>

#include "picture/fill.h"

namespace tessref::picture {

Canvas::Canvas(int width, int height, int channels, image::SampleType type, Colour background, std::string name)
    : width_(width), height_(height), channels_(channels), type_(type), name_(std::move(name)) {
    const std::size_t samples = static_cast<std::size_t>(width) * height * channels;
    if (type_ == image::SampleType::float32)
        floats_.resize(samples);
    else
        bytes_.resize(samples);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) put(x, y, background);
}

void Canvas::put(int x, int y, Colour colour) {
    if (x < 0 || y < 0 || x >= width_ || y >= height_) return;
    const std::size_t at = (static_cast<std::size_t>(y) * width_ + x) * channels_;
    if (type_ == image::SampleType::float32) {
        float* p = &floats_[at];
        p[0] = colour.r;
        p[1] = colour.g;
        p[2] = colour.b;
        if (channels_ == 4) p[3] = 1.0f;
    } else {
        const auto codes = colour.codes();
        std::uint8_t* p = &bytes_[at];
        p[0] = codes[0];
        p[1] = codes[1];
        p[2] = codes[2];
        if (channels_ == 4) p[3] = 255;
    }
}

void Canvas::fill_polygon(std::span<const glm::dvec2> points, Colour colour, double edge_margin) {
    flush();
    fill_convex_polygon(points, width_, height_, edge_margin, [&](int x, int y) { put(x, y, colour); });
}

void Canvas::fill_disc(glm::dvec2 centre, double radius, Colour colour) {
    flush();
    const int x0 = static_cast<int>(std::floor(centre.x - radius));
    const int x1 = static_cast<int>(std::ceil(centre.x + radius));
    const int y0 = static_cast<int>(std::floor(centre.y - radius));
    const int y1 = static_cast<int>(std::ceil(centre.y + radius));
    for (int y = y0; y <= y1; ++y) {
        for (int x = x0; x <= x1; ++x) {
            const double dx = x + 0.5 - centre.x, dy = y + 0.5 - centre.y;
            if (dx * dx + dy * dy <= radius * radius) put(x, y, colour);
        }
    }
}

void Canvas::fill_segment(glm::dvec2 from, glm::dvec2 to, double width, Colour colour) {
    const glm::dvec2 d = to - from;
    const double length = std::hypot(d.x, d.y);
    const double half = std::max(width, 1.0) / 2.0;
    if (length == 0.0) return;
    const glm::dvec2 n{-d.y / length * half, d.x / length * half};
    const glm::dvec2 t{d.x / length * 0.5, d.y / length * 0.5};
    const glm::dvec2 quad[4] = {from - t + n, to + t + n, to + t - n, from - t - n};
    fill_polygon(quad, colour, 0.0);
}

void Canvas::pixel_line(glm::dvec2 from, glm::dvec2 to, double width, Colour colour, double dash, double gap) {
    const int copies = std::max(1, static_cast<int>(std::lround(width)));
    const bool mostly_horizontal = std::fabs(to.x - from.x) >= std::fabs(to.y - from.y);
    const auto draw = [&](glm::dvec2 a, glm::dvec2 b) {
        for (int k = 0; k < copies; ++k) {
            const double offset = k - (copies - 1) / 2.0;
            const glm::dvec2 shift = mostly_horizontal ? glm::dvec2{0, offset} : glm::dvec2{offset, 0};
            drawing_.line(static_cast<int>(std::floor(a.x + shift.x)), static_cast<int>(std::floor(a.y + shift.y)),
                          static_cast<int>(std::floor(b.x + shift.x)), static_cast<int>(std::floor(b.y + shift.y)),
                          colour);
        }
    };
    if (dash > 0.0)
        for_each_dash(from, to, dash, gap, draw);
    else
        draw(from, to);
}

void Canvas::truetype_text(glm::dvec2 baseline, const std::string& text, double size, TextFont font, Colour colour,
                           Anchor anchor) {
    const image::TextAlign align = anchor == Anchor::start    ? image::TextAlign::left
                                   : anchor == Anchor::middle ? image::TextAlign::centre
                                                              : image::TextAlign::right;
    drawing_.text(static_cast<int>(std::lround(baseline.x)), static_cast<int>(std::lround(baseline.y)), text,
                  static_cast<int>(std::lround(size)), truetype_font(font), colour, align);
}

bool Canvas::flush(bool stop_at_failure, std::string* reason) {
    void* pixels = type_ == image::SampleType::float32 ? static_cast<void*>(floats_.data()) : bytes_.data();
    return drawing_.paint({pixels, width_, height_, channels_, type_}, stop_at_failure, name_, reason);
}

void Canvas::bitmap_text(double x, double y, const std::string& text, Anchor anchor, Colour colour, int scale) {
    const int advance = (kBitmapGlyphColumns + 1) * scale;  // three cells and a gap
    const int width = static_cast<int>(text.size()) * advance - scale;
    int left = static_cast<int>(std::lround(x));
    if (anchor == Anchor::middle) left -= width / 2;
    if (anchor == Anchor::end) left -= width;
    const int top = static_cast<int>(std::lround(y)) - kBitmapGlyphRows * scale;
    for (const char c : text) {
        const char* rows = bitmap_glyph(c);
        for (int row = 0; row < kBitmapGlyphRows; ++row)
            for (int col = 0; col < kBitmapGlyphColumns; ++col)
                if (rows[row * kBitmapGlyphColumns + col] == '#')
                    for (int dy = 0; dy < scale; ++dy)
                        for (int dx = 0; dx < scale; ++dx) put(left + col * scale + dx, top + row * scale + dy, colour);
        left += advance;
    }
}

image::ImageView Canvas::view() const {
    const void* pixels = type_ == image::SampleType::float32 ? static_cast<const void*>(floats_.data()) : bytes_.data();
    return {width_, height_, channels_, type_, pixels};
}

}  // namespace tessref::picture
