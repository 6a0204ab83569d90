// src/cli/pattern_picture.h — a picture of a tessellation pattern in its domain, for
// `tessref tessellate --format svg|png`.
//
// draw_pattern() lays the picture out once as a list of plain shapes (polygons, lines,
// discs, text) in pixel coordinates, y down; picture_to_svg() and write_picture_image()
// are two back-ends of that one list, so the SVG and the PNG show the same thing.
//
// What the picture shows: the domain (unit square for quads and isolines, the unit right
// triangle for triangles), u to the right and v up; every primitive (triangles filled,
// blue when counter-clockwise in (u, v), orange when clockwise, darker where they touch an
// outer edge; isoline segments; point-mode dots); every point dotted (boundary points red);
// point indices and winding arrows when the pattern is small enough to read them; a title
// with domain, spacing and winding, the command that reproduces the picture, and beside it
// the levels as given and as the generator used them, the counts and the gpu-vs-exact
// distance.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <glm/vec2.hpp>

#include "picture/canvas.h"
#include "tessref/tessellator.h"

namespace tessref::cli {

using picture::Anchor;
using picture::Colour;
using picture::TextFont;

struct PicturePolygon {
    std::vector<glm::dvec2> points;  // convex, in pixels
    Colour fill{};
    bool stroked = false;
    Colour stroke{};
    double stroke_width = 1.0;
};

struct PictureLine {
    glm::dvec2 from{}, to{};
    Colour colour{};
    double width = 1.0;
    bool dashed = false;
};

struct PictureDisc {
    glm::dvec2 centre{};
    double radius = 1.0;
    Colour fill{};
};

struct PictureText {
    glm::dvec2 baseline{};  // the anchor point on the baseline
    std::string text;       // UTF-8
    double size = 13.0;     // pixels
    Colour colour{};
    Anchor anchor = Anchor::start;
    TextFont font = TextFont::sans;
};

// Shapes are painted in this order: polygons, lines, discs, texts (each in list order).
struct Picture {
    int width = 0, height = 0;
    Colour background = Colour::from_codes(255, 255, 255);
    std::vector<PicturePolygon> polygons;
    std::vector<PictureLine> lines;
    std::vector<PictureDisc> discs;
    std::vector<PictureText> texts;
    std::string title;  // also the SVG <title>
};

struct PatternPictureInfo {
    double gpu_exact_max_difference = 0.0;
    std::string command_line;  // the command that reproduces the picture (subtitle)
};

Picture draw_pattern(const Pattern& pattern, const PatternPictureInfo& info);

// A standalone SVG 1.1 document (starts with "<svg", ends with "</svg>\n").
std::string picture_to_svg(const Picture& picture);

// Rasterizes the picture on an RGB float picture::Canvas (lines and text by OpenImageIO,
// plain pixel fills for polygons and discs, no antialiasing) and writes it to `path`; the
// codec follows the extension of `path`. Text uses DejaVu Sans; when no font can be loaded
// the picture is still written, without text, and the returned warnings say so.
// Throws tessref::Error when the image cannot be written.
std::vector<std::string> write_picture_image(const Picture& picture, const std::string& path,
                                             const std::string& error_name);

}  // namespace tessref::cli
