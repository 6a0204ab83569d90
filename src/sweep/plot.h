// src/sweep/plot.h — the scatter plots of the sweep report: image error (y, linear from 0)
// against a cost (x, log10: time or triangles), or a screen measure against the level with
// shaded bands, one colour per series, a series' uniform
// levels joined in level order, the scene's own levels as diamonds, the Pareto front ringed
// and joined by a dashed staircase per scene, each point labelled (its level) beside it.
//
// layout_plot() lays the plot out once as plain shapes in pixels (y down); plot_to_svg() and
// plot_to_rgba() are two back-ends of that one list, so the SVG and the PNG show the same
// marks. The SVG carries every label as <text>; the PNG writes the same labels in the
// diagrams' bitmap face (src/picture/font.h) at twice its size, so it needs no font file and
// its bytes do not depend on the machine.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "picture/canvas.h"

namespace tessref::sweep {

using picture::Anchor;
using picture::Colour;

struct PlotSeries {
    std::string label;
    Colour colour{};
};

struct PlotPoint {
    double x = 0.0;      // > 0 (log scale)
    double y = 0.0;      // >= 0
    std::size_t series = 0;
    bool own = false;    // the scene's own levels (a diamond), not a uniform level (a dot)
    bool pareto = false; // on its scene's Pareto front (ringed)
    std::string label;   // written beside the mark (the report: the point's level); empty: none
};

struct PlotSpec {
    std::string title;
    std::string x_label;  // e.g. "total time (ms), log scale"
    std::string y_label;
    std::string note;     // under the x axis, e.g. how many runs could not be placed
    std::vector<PlotSeries> series;
    std::vector<PlotPoint> points;  // a series' uniform points in level order (they are joined)
    // Each scene's Pareto front, points sorted by x: drawn as a dashed staircase.
    std::vector<std::vector<PlotPoint>> fronts;
    // Horizontal bands of y values practitioners aim for (screen error <= 1 px, triangle
    // edges of 3-6 px), shaded under everything else and named in the legend.
    struct Band {
        double y0 = 0.0, y1 = 0.0;
        std::string label;
    };
    std::vector<Band> bands;
    bool pareto = true;  // the fronts' and the own levels' legend entries (a plot against level has neither)
};

// The i-th colour of the report's palette (cycles).
Colour series_colour(std::size_t i);

// The plot as shapes (pixels, y down), painted in this order: lines, markers, texts.
struct PlotShapes {
    struct Line {
        double x0, y0, x1, y1;
        Colour colour;
        double width;
        bool dashed;
    };
    enum class MarkerKind : std::uint8_t { dot, diamond, ring };
    struct Marker {
        double x, y, radius;
        MarkerKind kind;
        Colour colour;  // fill (dot, diamond) or stroke (ring)
    };
    struct Text {
        double x, y;  // baseline anchor point
        std::string text;
        Anchor anchor;
        Colour colour;
        bool bold;
    };
    int width = 0, height = 0;
    std::string title;
    std::vector<Line> lines;
    std::vector<Marker> markers;
    std::vector<Text> texts;
};

PlotShapes layout_plot(const PlotSpec& spec);

// A standalone SVG 1.1 document: starts with "<svg", ends with "</svg>\n"; numbers printed
// with fixed formats, so the same spec gives the same bytes.
std::string plot_to_svg(const PlotShapes& shapes);

// The same shapes painted as an RGBA 8-bit PNG (opaque, no antialiasing, no time stamp) at
// `path`. Throws tessref::Error.
void write_plot_png(const PlotShapes& shapes, const std::string& path);

}  // namespace tessref::sweep
