// src/sweep/plot.cpp — see plot.h.
#include "sweep/plot.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <span>

#include <glm/vec2.hpp>

#include "image/image_io.h"
#include "picture/svg.h"
#include "tessref/error.h"

namespace tessref::sweep {

namespace {

// ---------------------------------------------------------------------------------------
// Layout (pixels)

constexpr double kPlotLeft = 84.0;
constexpr double kPlotTop = 60.0;
constexpr double kPlotWidth = 640.0;
constexpr double kPlotHeight = 420.0;
constexpr double kBottomMargin = 76.0;
constexpr double kLegendGap = 28.0;
constexpr double kLegendRow = 18.0;
constexpr double kCharWidth = 8.0;  // the PNG font's advance; the SVG's 12 px sans is narrower

constexpr Colour kInk = Colour::from_codes(34, 34, 34);
constexpr Colour kMuted = Colour::from_codes(110, 110, 110);
constexpr Colour kGrid = Colour::from_codes(226, 226, 226);
constexpr Colour kFront = Colour::from_codes(20, 20, 20);
constexpr Colour kWhite = Colour::from_codes(255, 255, 255);
constexpr Colour kBand = Colour::from_codes(222, 240, 222);

std::string fixed(double x, int decimals = 2) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.*f", decimals, x);
    return buffer;
}

std::string decade_label(int k) {
    if (k >= 0 && k <= 5) return fixed(std::pow(10.0, k), 0);
    if (k < 0 && k >= -4) return fixed(std::pow(10.0, k), -k);
    return "1e" + std::to_string(k);
}

// A "nice" step (1, 2, 2.5 or 5 times a power of ten) that cuts [0, top] into about 5.
double nice_step(double top) {
    const double raw = top / 5.0;
    const double power = std::pow(10.0, std::floor(std::log10(raw)));
    for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
        if (m * power >= raw) return m * power;
    return 10.0 * power;
}

std::string tick_label(double value) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.6g", value);
    return buffer;
}

}  // namespace

Colour series_colour(std::size_t i) {
    // Ten strong colours, then their light tints (the 20-colour "tab20" set), so that up to 20
    // series stay apart; beyond that the colours repeat.
    static constexpr std::array<Colour, 20> palette{Colour::from_codes(31, 119, 180),  Colour::from_codes(255, 127, 14),  Colour::from_codes(44, 160, 44),   Colour::from_codes(214, 39, 40),
                                                  Colour::from_codes(148, 103, 189), Colour::from_codes(140, 86, 75),   Colour::from_codes(227, 119, 194), Colour::from_codes(127, 127, 127),
                                                  Colour::from_codes(188, 189, 34),  Colour::from_codes(23, 190, 207),  Colour::from_codes(174, 199, 232), Colour::from_codes(255, 187, 120),
                                                  Colour::from_codes(152, 223, 138), Colour::from_codes(255, 152, 150), Colour::from_codes(197, 176, 213), Colour::from_codes(196, 156, 148),
                                                  Colour::from_codes(247, 182, 210), Colour::from_codes(199, 199, 199), Colour::from_codes(219, 219, 141), Colour::from_codes(158, 218, 229)};
    return palette[i % palette.size()];
}

PlotShapes layout_plot(const PlotSpec& spec) {
    PlotShapes shapes;
    shapes.title = spec.title;
    std::size_t longest = 24;  // the legend's two fixed entries
    for (const PlotSeries& s : spec.series) longest = std::max(longest, s.label.size());
    const double legend_left = kPlotLeft + kPlotWidth + kLegendGap;
    const double legend_width = 32.0 + kCharWidth * static_cast<double>(longest);
    for (const PlotSpec::Band& b : spec.bands) longest = std::max(longest, b.label.size());
    const double legend_height = kLegendRow * static_cast<double>(spec.series.size() + 3 + spec.bands.size());
    shapes.width = static_cast<int>(legend_left + legend_width + 16.0);
    shapes.height = static_cast<int>(std::max(kPlotTop + kPlotHeight + kBottomMargin, kPlotTop + legend_height + 16.0));

    auto line = [&](double x0, double y0, double x1, double y1, Colour colour, double width, bool dashed = false) {
        shapes.lines.push_back({x0, y0, x1, y1, colour, width, dashed});
    };
    auto text = [&](double x, double y, std::string s, Anchor anchor, Colour colour, bool bold = false) {
        shapes.texts.push_back({x, y, std::move(s), anchor, colour, bold});
    };
    text(kPlotLeft, 26.0, spec.title, Anchor::start, kInk, true);
    text(kPlotLeft, kPlotTop - 12.0, spec.y_label, Anchor::start, kMuted);

    // Scales: x in whole decades around the data, y from 0 to a nice step above the data.
    double x_min = 1.0, x_max = 10.0, y_max = 0.0;
    if (!spec.points.empty()) {
        x_min = x_max = spec.points[0].x;
        for (const PlotPoint& p : spec.points) {
            x_min = std::min(x_min, p.x);
            x_max = std::max(x_max, p.x);
            y_max = std::max(y_max, p.y);
        }
    }
    const int decade_lo = static_cast<int>(std::floor(std::log10(x_min)));
    int decade_hi = static_cast<int>(std::ceil(std::log10(x_max)));
    if (decade_hi <= decade_lo) decade_hi = decade_lo + 1;
    for (const PlotSpec::Band& b : spec.bands) y_max = std::max(y_max, b.y1);
    if (!(y_max > 0)) y_max = 1.0 / 255.0;
    const double y_step = nice_step(y_max * 1.04);
    const double y_top = std::ceil(y_max * 1.04 / y_step) * y_step;
    const int y_ticks = static_cast<int>(std::lround(y_top / y_step));
    auto px = [&](double x) {
        return kPlotLeft + kPlotWidth * (std::log10(x) - decade_lo) / static_cast<double>(decade_hi - decade_lo);
    };
    auto py = [&](double y) { return kPlotTop + kPlotHeight * (1.0 - y / y_top); };
    const double bottom = kPlotTop + kPlotHeight;

    // The bands first, under the grid: a thick line is a rectangle in both back-ends.
    for (const PlotSpec::Band& b : spec.bands) {
        const double top = py(std::min(b.y1, y_top)), low = py(std::max(b.y0, 0.0));
        if (!(low > top)) continue;
        line(kPlotLeft, (top + low) / 2.0, kPlotLeft + kPlotWidth, (top + low) / 2.0, kBand, low - top);
    }
    // Grid, ticks and their labels.
    for (int k = decade_lo; k <= decade_hi; ++k) {
        const double x = px(std::pow(10.0, k));
        line(x, kPlotTop, x, bottom, kGrid, 1.0);
        line(x, bottom, x, bottom + 6.0, kInk, 1.0);
        text(x, bottom + 22.0, decade_label(k), Anchor::middle, kInk);
        if (k == decade_hi) break;
        for (int m = 2; m <= 9; ++m) {
            const double xm = px(m * std::pow(10.0, k));
            line(xm, bottom, xm, bottom + 3.0, kInk, 1.0);
        }
    }
    for (int i = 0; i <= y_ticks; ++i) {
        const double value = i * y_step;
        const double y = py(value);
        if (i > 0) line(kPlotLeft, y, kPlotLeft + kPlotWidth, y, kGrid, 1.0);
        line(kPlotLeft - 6.0, y, kPlotLeft, y, kInk, 1.0);
        text(kPlotLeft - 10.0, y + 5.0, tick_label(value), Anchor::end, kInk);
    }
    line(kPlotLeft, kPlotTop, kPlotLeft, bottom, kInk, 1.0);
    line(kPlotLeft, bottom, kPlotLeft + kPlotWidth, bottom, kInk, 1.0);
    text(kPlotLeft + kPlotWidth / 2.0, bottom + 48.0, spec.x_label, Anchor::middle, kMuted);
    if (!spec.note.empty()) text(kPlotLeft, bottom + 68.0, spec.note, Anchor::start, kMuted);
    if (spec.points.empty())
        text(kPlotLeft + kPlotWidth / 2.0, kPlotTop + kPlotHeight / 2.0, "no runs with both values", Anchor::middle,
             kMuted);

    // Each series' uniform levels joined in order; then the fronts; then the marks on top.
    for (std::size_t s = 0; s < spec.series.size(); ++s) {
        const PlotPoint* previous = nullptr;
        for (const PlotPoint& p : spec.points) {
            if (p.series != s || p.own) continue;
            if (previous)
                line(px(previous->x), py(previous->y), px(p.x), py(p.y), spec.series[s].colour, 1.0);
            previous = &p;
        }
    }
    for (const std::vector<PlotPoint>& front : spec.fronts) {
        // A staircase: from each front point right to the next one's x, then down to it.
        for (std::size_t i = 1; i < front.size(); ++i) {
            const double x0 = px(front[i - 1].x), y0 = py(front[i - 1].y);
            const double x1 = px(front[i].x), y1 = py(front[i].y);
            line(x0, y0, x1, y0, kFront, 1.0, true);
            line(x1, y0, x1, y1, kFront, 1.0, true);
        }
    }
    // Dots, then the few diamonds over them (a scene's own levels sit among its uniform ones),
    // then the rings.
    for (const PlotPoint& p : spec.points)
        if (!p.own)
            shapes.markers.push_back({px(p.x), py(p.y), 3.5, PlotShapes::MarkerKind::dot, spec.series[p.series].colour});
    for (const PlotPoint& p : spec.points) {
        if (!p.own) continue;
        shapes.markers.push_back({px(p.x), py(p.y), 7.0, PlotShapes::MarkerKind::diamond, kInk});
        shapes.markers.push_back({px(p.x), py(p.y), 5.0, PlotShapes::MarkerKind::diamond, spec.series[p.series].colour});
    }
    for (const PlotPoint& p : spec.points)
        if (p.pareto) shapes.markers.push_back({px(p.x), py(p.y), 8.0, PlotShapes::MarkerKind::ring, kFront});
    // Labels up and to the right of their marks, clear of the ring, in the series' colour.
    for (const PlotPoint& p : spec.points)
        if (!p.label.empty()) text(px(p.x) + 7.0, py(p.y) - 7.0, p.label, Anchor::start, spec.series[p.series].colour);

    // Legend: one row per series, then the two marks that are not colours.
    double y = kPlotTop;
    for (const PlotSeries& s : spec.series) {
        line(legend_left, y - 4.0, legend_left + 20.0, y - 4.0, s.colour, 1.0);
        shapes.markers.push_back({legend_left + 10.0, y - 4.0, 3.5, PlotShapes::MarkerKind::dot, s.colour});
        text(legend_left + 28.0, y, s.label, Anchor::start, kInk);
        y += kLegendRow;
    }
    y += kLegendRow / 2.0;
    if (spec.pareto) {
        shapes.markers.push_back({legend_left + 10.0, y - 4.0, 7.0, PlotShapes::MarkerKind::diamond, kInk});
        shapes.markers.push_back({legend_left + 10.0, y - 4.0, 5.0, PlotShapes::MarkerKind::diamond, kGrid});
        text(legend_left + 28.0, y, "scene's own levels", Anchor::start, kInk);
        y += kLegendRow;
        shapes.markers.push_back({legend_left + 10.0, y - 4.0, 8.0, PlotShapes::MarkerKind::ring, kFront});
        line(legend_left, y - 4.0, legend_left + 20.0, y - 4.0, kFront, 1.0, true);
        text(legend_left + 28.0, y, "Pareto front per scene", Anchor::start, kInk);
    } else {
        y -= kLegendRow;
    }
    for (const PlotSpec::Band& b : spec.bands) {
        y += kLegendRow;
        line(legend_left, y - 4.0, legend_left + 20.0, y - 4.0, kBand, 10.0);
        text(legend_left + 28.0, y, b.label, Anchor::start, kInk);
    }
    return shapes;
}

// ---------------------------------------------------------------------------------------
// SVG

namespace {

std::string num(double x) { return picture::number_fixed(x); }

std::vector<glm::dvec2> diamond(double x, double y, double r) {
    return {{x, y - r}, {x + r, y}, {x, y + r}, {x - r, y}};
}

}  // namespace

std::string plot_to_svg(const PlotShapes& shapes) {
    std::string svg = picture::svg_begin(shapes.width, shapes.height, shapes.title, kWhite);
    svg += "<g stroke-linecap=\"butt\">\n";
    for (const PlotShapes::Line& l : shapes.lines) {
        svg += "<line x1=\"" + num(l.x0) + "\" y1=\"" + num(l.y0) + "\" x2=\"" + num(l.x1) + "\" y2=\"" +
               num(l.y1) + "\" stroke=\"" + picture::hex(l.colour) + "\" stroke-width=\"" + num(l.width) + "\"";
        if (l.dashed) svg += " stroke-dasharray=\"5 3\"";
        svg += "/>\n";
    }
    svg += "</g>\n<g>\n";
    for (const PlotShapes::Marker& m : shapes.markers) {
        switch (m.kind) {
            case PlotShapes::MarkerKind::dot:
                svg += "<circle cx=\"" + num(m.x) + "\" cy=\"" + num(m.y) + "\" r=\"" + num(m.radius) +
                       "\" fill=\"" + picture::hex(m.colour) + "\"/>\n";
                break;
            case PlotShapes::MarkerKind::ring:
                svg += "<circle cx=\"" + num(m.x) + "\" cy=\"" + num(m.y) + "\" r=\"" + num(m.radius) +
                       "\" fill=\"none\" stroke=\"" + picture::hex(m.colour) + "\" stroke-width=\"1.50\"/>\n";
                break;
            case PlotShapes::MarkerKind::diamond: {
                svg += "<polygon points=\"";
                const std::vector<glm::dvec2> points = diamond(m.x, m.y, m.radius);
                for (std::size_t i = 0; i < points.size(); ++i)
                    svg += (i ? " " : "") + num(points[i].x) + "," + num(points[i].y);
                svg += "\" fill=\"" + picture::hex(m.colour) + "\"/>\n";
                break;
            }
        }
    }
    svg += "</g>\n<g font-family=\"DejaVu Sans, Verdana, Arial, sans-serif\" font-size=\"12\">\n";
    for (const PlotShapes::Text& t : shapes.texts) {
        svg += "<text x=\"" + num(t.x) + "\" y=\"" + num(t.y) + "\" fill=\"" + picture::hex(t.colour) + "\"";
        if (t.anchor == Anchor::middle) svg += " text-anchor=\"middle\"";
        if (t.anchor == Anchor::end) svg += " text-anchor=\"end\"";
        if (t.bold) svg += " font-weight=\"bold\" font-size=\"14\"";
        svg += ">" + picture::xml_escape(t.text) + "</text>\n";
    }
    svg += "</g>\n</svg>\n";
    return svg;
}

// ---------------------------------------------------------------------------------------
// PNG

void write_plot_png(const PlotShapes& shapes, const std::string& path) {
    picture::Canvas canvas(shapes.width, shapes.height, 4, image::SampleType::uint8, kWhite, path);
    for (const PlotShapes::Line& l : shapes.lines) {
        const glm::dvec2 a{l.x0, l.y0}, b{l.x1, l.y1};
        const auto segment = [&](glm::dvec2 p, glm::dvec2 q) { canvas.fill_segment(p, q, l.width, l.colour); };
        if (l.dashed)
            picture::for_each_dash(a, b, 5.0, 3.0, segment);  // the SVG's dash
        else
            segment(a, b);
    }
    for (const PlotShapes::Marker& m : shapes.markers) {
        constexpr int sides = 24;
        std::vector<glm::dvec2> circle;
        for (int i = 0; i < sides; ++i) {
            const double angle = 2.0 * std::numbers::pi * i / sides;
            circle.push_back({m.x + m.radius * std::cos(angle), m.y + m.radius * std::sin(angle)});
        }
        switch (m.kind) {
            case PlotShapes::MarkerKind::dot: canvas.fill_polygon(circle, m.colour, 0.0); break;
            case PlotShapes::MarkerKind::diamond: canvas.fill_polygon(diamond(m.x, m.y, m.radius), m.colour, 0.0); break;
            case PlotShapes::MarkerKind::ring:
                for (int i = 0; i < sides; ++i) canvas.fill_segment(circle[i], circle[(i + 1) % sides], 1.5, m.colour);
                break;
        }
    }
    constexpr int font_scale = 2;  // the bitmap face at twice its size
    for (const PlotShapes::Text& t : shapes.texts) canvas.bitmap_text(t.x, t.y, t.text, t.anchor, t.colour, font_scale);
    image::WriteOptions options;
    options.software_tag = true;  // and no time stamp: the same plot gives the same bytes
    image::write_image(path, canvas.view(), options);
}

}  // namespace tessref::sweep
