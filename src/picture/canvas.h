// src/picture/canvas.h — the one raster back-end of tessref's diagrams: a picture in memory
// that shapes are painted into, in order, and that is then written as an image file.
//
// The pattern picture (`tessref tessellate --format png`, an RGB float canvas) and the sweep
// report's plots (RGBA 8-bit) are painted here; the defect picture (`tessref check --image`)
// paints its own grey view and hands its lines and text to image::Drawing, which this
// canvas also queues to. What is painted and how:
//  - fill_polygon(), fill_disc(), fill_segment(): plain pixel fills, no antialiasing, by the
//    pixel-centre rule of picture/fill.h;
//  - pixel_line() and truetype_text(): OpenImageIO's one-pixel lines and TrueType text
//    (image/draw.h, through the module), queued and painted, in order, before the next fill;
//  - bitmap_text(): the 3 x 5 face of picture/font.h, machine-independent.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <glm/vec2.hpp>

#include "image/draw.h"
#include "image/image_io.h"
#include "picture/colour.h"
#include "picture/font.h"

namespace tessref::picture {

// Where a text's anchor point is along its baseline (SVG's text-anchor).
enum class Anchor : std::uint8_t { start, middle, end };

class Canvas {
public:
    // width x height pixels of `channels` (3: RGB; 4: RGBA, alpha always opaque) samples of
    // `type` (uint8 or float32), every pixel `background`. `name` is the picture's file, for
    // the error when OpenImageIO's module cannot be loaded.
    Canvas(int width, int height, int channels, image::SampleType type, Colour background, std::string name);

    int width() const { return width_; }
    int height() const { return height_; }

    // One pixel; outside the picture, nothing.
    void put(int x, int y, Colour colour);

    // Every pixel whose centre is inside the convex polygon or within `edge_margin` of it
    // (picture/fill.h: a margin lets two polygons that share an edge both paint it).
    void fill_polygon(std::span<const glm::dvec2> points, Colour colour, double edge_margin);
    // Every pixel whose centre is within `radius` of `centre`.
    void fill_disc(glm::dvec2 centre, double radius, Colour colour);
    // A segment as a quad of its width (at least one pixel, so thin lines show), reaching half
    // a pixel beyond both ends.
    void fill_segment(glm::dvec2 from, glm::dvec2 to, double width, Colour colour);

    // OpenImageIO's one-pixel line, `width` parallel copies of it across the whole line's
    // minor axis; with `dash` > 0, dashed (for_each_dash).
    void pixel_line(glm::dvec2 from, glm::dvec2 to, double width, Colour colour, double dash = 0.0, double gap = 0.0);
    // TrueType text of `size` pixels, baseline at `baseline`.
    void truetype_text(glm::dvec2 baseline, const std::string& text, double size, TextFont font, Colour colour,
                       Anchor anchor);
    // Paints the queued lines and text (image::Drawing::paint): true when every one succeeded.
    bool flush(bool stop_at_failure = false, std::string* reason = nullptr);

    // Bitmap text, each cell `scale` pixels square, baseline (the glyphs' bottom) at y.
    void bitmap_text(double x, double y, const std::string& text, Anchor anchor, Colour colour, int scale);

    // The pixels, for image::write_image(); queued operations are not in them until flush().
    image::ImageView view() const;

private:
    int width_, height_, channels_;
    image::SampleType type_;
    std::vector<float> floats_;
    std::vector<std::uint8_t> bytes_;
    std::string name_;
    image::Drawing drawing_;
};

// Calls draw(a, b) for each dash of a dashed line from `from` to `to`: `dash` pixels on,
// `gap` off, starting with a dash; the last dash ends at `to`.
template <class Draw>
void for_each_dash(glm::dvec2 from, glm::dvec2 to, double dash, double gap, Draw&& draw) {
    const double length = std::hypot(to.x - from.x, to.y - from.y);
    for (double s = 0.0; s < length; s += dash + gap) {
        const double e = std::min(length, s + dash);
        draw(from + (to - from) * (s / length), from + (to - from) * (e / length));
    }
}

}  // namespace tessref::picture
