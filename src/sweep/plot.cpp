// src/sweep/plot.cpp — see plot.h.
#include "sweep/plot.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <span>

#include <glm/vec2.hpp>

#include "common/fill.h"
#include "image/image_io.h"
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

constexpr Rgb kInk{34, 34, 34};
constexpr Rgb kMuted{110, 110, 110};
constexpr Rgb kGrid{226, 226, 226};
constexpr Rgb kFront{20, 20, 20};

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

Rgb series_color(std::size_t i) {
    // Ten strong colours, then their light tints (the 20-colour "tab20" set), so that up to 20
    // series stay apart; beyond that the colours repeat.
    static constexpr std::array<Rgb, 20> palette{{{31, 119, 180},  {255, 127, 14},  {44, 160, 44},   {214, 39, 40},
                                                  {148, 103, 189}, {140, 86, 75},   {227, 119, 194}, {127, 127, 127},
                                                  {188, 189, 34},  {23, 190, 207},  {174, 199, 232}, {255, 187, 120},
                                                  {152, 223, 138}, {255, 152, 150}, {197, 176, 213}, {196, 156, 148},
                                                  {247, 182, 210}, {199, 199, 199}, {219, 219, 141}, {158, 218, 229}}};
    return palette[i % palette.size()];
}

PlotShapes layout_plot(const PlotSpec& spec) {
    PlotShapes shapes;
    shapes.title = spec.title;
    std::size_t longest = 24;  // the legend's two fixed entries
    for (const PlotSeries& s : spec.series) longest = std::max(longest, s.label.size());
    const double legend_left = kPlotLeft + kPlotWidth + kLegendGap;
    const double legend_width = 32.0 + kCharWidth * static_cast<double>(longest);
    const double legend_height = kLegendRow * static_cast<double>(spec.series.size() + 3);
    shapes.width = static_cast<int>(legend_left + legend_width + 16.0);
    shapes.height = static_cast<int>(std::max(kPlotTop + kPlotHeight + kBottomMargin, kPlotTop + legend_height + 16.0));

    auto line = [&](double x0, double y0, double x1, double y1, Rgb color, double width, bool dashed = false) {
        shapes.lines.push_back({x0, y0, x1, y1, color, width, dashed});
    };
    auto text = [&](double x, double y, std::string s, Anchor anchor, Rgb color, bool bold = false) {
        shapes.texts.push_back({x, y, std::move(s), anchor, color, bold});
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
    if (!(y_max > 0)) y_max = 1.0 / 255.0;
    const double y_step = nice_step(y_max * 1.04);
    const double y_top = std::ceil(y_max * 1.04 / y_step) * y_step;
    const int y_ticks = static_cast<int>(std::lround(y_top / y_step));
    auto px = [&](double x) {
        return kPlotLeft + kPlotWidth * (std::log10(x) - decade_lo) / static_cast<double>(decade_hi - decade_lo);
    };
    auto py = [&](double y) { return kPlotTop + kPlotHeight * (1.0 - y / y_top); };
    const double bottom = kPlotTop + kPlotHeight;

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
                line(px(previous->x), py(previous->y), px(p.x), py(p.y), spec.series[s].color, 1.0);
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
            shapes.markers.push_back({px(p.x), py(p.y), 3.5, PlotShapes::MarkerKind::dot, spec.series[p.series].color});
    for (const PlotPoint& p : spec.points) {
        if (!p.own) continue;
        shapes.markers.push_back({px(p.x), py(p.y), 7.0, PlotShapes::MarkerKind::diamond, kInk});
        shapes.markers.push_back({px(p.x), py(p.y), 5.0, PlotShapes::MarkerKind::diamond, spec.series[p.series].color});
    }
    for (const PlotPoint& p : spec.points)
        if (p.pareto) shapes.markers.push_back({px(p.x), py(p.y), 8.0, PlotShapes::MarkerKind::ring, kFront});

    // Legend: one row per series, then the two marks that are not colours.
    double y = kPlotTop;
    for (const PlotSeries& s : spec.series) {
        line(legend_left, y - 4.0, legend_left + 20.0, y - 4.0, s.color, 1.0);
        shapes.markers.push_back({legend_left + 10.0, y - 4.0, 3.5, PlotShapes::MarkerKind::dot, s.color});
        text(legend_left + 28.0, y, s.label, Anchor::start, kInk);
        y += kLegendRow;
    }
    y += kLegendRow / 2.0;
    shapes.markers.push_back({legend_left + 10.0, y - 4.0, 7.0, PlotShapes::MarkerKind::diamond, kInk});
    shapes.markers.push_back({legend_left + 10.0, y - 4.0, 5.0, PlotShapes::MarkerKind::diamond, kGrid});
    text(legend_left + 28.0, y, "scene's own levels", Anchor::start, kInk);
    y += kLegendRow;
    shapes.markers.push_back({legend_left + 10.0, y - 4.0, 8.0, PlotShapes::MarkerKind::ring, kFront});
    line(legend_left, y - 4.0, legend_left + 20.0, y - 4.0, kFront, 1.0, true);
    text(legend_left + 28.0, y, "Pareto front per scene", Anchor::start, kInk);
    return shapes;
}

std::string xml_escape(const std::string& text) {
    std::string out;
    for (char c : text) {
        switch (c) {
            case '&': out += "&amp;"; break;
            case '<': out += "&lt;"; break;
            case '>': out += "&gt;"; break;
            case '"': out += "&quot;"; break;
            case '\'': out += "&#39;"; break;
            default: out += c;
        }
    }
    return out;
}

// ---------------------------------------------------------------------------------------
// SVG

namespace {

std::string hex(Rgb c) {
    char buffer[8];
    std::snprintf(buffer, sizeof buffer, "#%02x%02x%02x", c.r, c.g, c.b);
    return buffer;
}

std::vector<glm::dvec2> diamond(double x, double y, double r) {
    return {{x, y - r}, {x + r, y}, {x, y + r}, {x - r, y}};
}

}  // namespace

std::string plot_to_svg(const PlotShapes& shapes) {
    std::string svg = "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"" +
                      std::to_string(shapes.width) + "\" height=\"" + std::to_string(shapes.height) +
                      "\" viewBox=\"0 0 " + std::to_string(shapes.width) + " " + std::to_string(shapes.height) +
                      "\">\n";
    svg += "<title>" + xml_escape(shapes.title) + "</title>\n";
    svg += "<rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>\n";
    svg += "<g stroke-linecap=\"butt\">\n";
    for (const PlotShapes::Line& l : shapes.lines) {
        svg += "<line x1=\"" + fixed(l.x0) + "\" y1=\"" + fixed(l.y0) + "\" x2=\"" + fixed(l.x1) + "\" y2=\"" +
               fixed(l.y1) + "\" stroke=\"" + hex(l.color) + "\" stroke-width=\"" + fixed(l.width) + "\"";
        if (l.dashed) svg += " stroke-dasharray=\"5 3\"";
        svg += "/>\n";
    }
    svg += "</g>\n<g>\n";
    for (const PlotShapes::Marker& m : shapes.markers) {
        switch (m.kind) {
            case PlotShapes::MarkerKind::dot:
                svg += "<circle cx=\"" + fixed(m.x) + "\" cy=\"" + fixed(m.y) + "\" r=\"" + fixed(m.radius) +
                       "\" fill=\"" + hex(m.color) + "\"/>\n";
                break;
            case PlotShapes::MarkerKind::ring:
                svg += "<circle cx=\"" + fixed(m.x) + "\" cy=\"" + fixed(m.y) + "\" r=\"" + fixed(m.radius) +
                       "\" fill=\"none\" stroke=\"" + hex(m.color) + "\" stroke-width=\"1.50\"/>\n";
                break;
            case PlotShapes::MarkerKind::diamond: {
                svg += "<polygon points=\"";
                const std::vector<glm::dvec2> points = diamond(m.x, m.y, m.radius);
                for (std::size_t i = 0; i < points.size(); ++i)
                    svg += (i ? " " : "") + fixed(points[i].x) + "," + fixed(points[i].y);
                svg += "\" fill=\"" + hex(m.color) + "\"/>\n";
                break;
            }
        }
    }
    svg += "</g>\n<g font-family=\"DejaVu Sans, Verdana, Arial, sans-serif\" font-size=\"12\">\n";
    for (const PlotShapes::Text& t : shapes.texts) {
        svg += "<text x=\"" + fixed(t.x) + "\" y=\"" + fixed(t.y) + "\" fill=\"" + hex(t.color) + "\"";
        if (t.anchor == Anchor::middle) svg += " text-anchor=\"middle\"";
        if (t.anchor == Anchor::end) svg += " text-anchor=\"end\"";
        if (t.bold) svg += " font-weight=\"bold\" font-size=\"14\"";
        svg += ">" + xml_escape(t.text) + "</text>\n";
    }
    svg += "</g>\n</svg>\n";
    return svg;
}

// ---------------------------------------------------------------------------------------
// PNG

namespace {

// A 3x5 bitmap font, drawn for this report: each glyph is five rows of three cells, top row
// first, '#' painted. Lower-case letters are drawn as capitals; a character without a glyph
// is drawn as '?'.
struct Glyph {
    char c;
    const char* rows;  // 15 cells
};
constexpr Glyph kFont[] = {
    {' ', "..............."}, {'0', "####.##.##.####"}, {'1', ".#.##..#..#.###"}, {'2', "###..#####..###"},
    {'3', "###..#.##..####"}, {'4', "#.##.####..#..#"}, {'5', "####..###..####"}, {'6', "####..####.####"},
    {'7', "###..#..#.#..#."}, {'8', "####.#####.####"}, {'9', "####.####..####"}, {'A', ".#.#.#####.##.#"},
    {'B', "##.#.###.#.###."}, {'C', ".###..#..#...##"}, {'D', "##.#.##.##.###."}, {'E', "####..##.#..###"},
    {'F', "####..##.#..#.."}, {'G', ".###..#.##.#.##"}, {'H', "#.##.#####.##.#"}, {'I', "###.#..#..#.###"},
    {'J', "..#..#..##.#.#."}, {'K', "#.##.###.#.##.#"}, {'L', "#..#..#..#..###"}, {'M', "#.########.##.#"},
    {'N', "##.#.##.##.##.#"}, {'O', ".#.#.##.##.#.#."}, {'P', "##.#.###.#..#.."}, {'Q', ".#.#.##.###..##"},
    {'R', "##.#.###.#.##.#"}, {'S', ".###...#...###."}, {'T', "###.#..#..#..#."}, {'U', "#.##.##.##.####"},
    {'V', "#.##.##.##.#.#."}, {'W', "#.##.########.#"}, {'X', "#.##.#.#.#.##.#"}, {'Y', "#.##.#.#..#..#."},
    {'Z', "###..#.#.#..###"}, {'.', ".............#."}, {',', "..........#.#.."}, {'-', "......###......"},
    {'+', "....#.###.#...."}, {'_', "............###"}, {'/', "..#..#.#.#..#.."}, {'(', ".#.#..#..#...#."},
    {')', ".#...#..#..#.#."}, {':', "....#.....#...."}, {'=', "...###...###..."}, {'%', "#.#..#.#.#..#.#"},
    {'[', "##.#..#..#..##."}, {']', ".##..#..#..#.##"}, {'\'', ".#..#.........."}, {'?', "###..#.#.....#."},
};

const char* glyph_rows(char c) {
    const char upper = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    for (const Glyph& g : kFont)
        if (g.c == upper) return g.rows;
    return glyph_rows('?');
}

constexpr int kFontScale = 2;
constexpr int kGlyphAdvance = 4 * kFontScale;  // three cells and a gap

class Canvas {
public:
    Canvas(int width, int height)
        : width_(width), height_(height), pixels_(static_cast<std::size_t>(width) * height * 4, 255) {}

    std::vector<std::uint8_t> take() { return std::move(pixels_); }

    void set(int x, int y, Rgb c) {
        if (x < 0 || y < 0 || x >= width_ || y >= height_) return;
        std::uint8_t* p = &pixels_[(static_cast<std::size_t>(y) * width_ + x) * 4];
        p[0] = c.r;
        p[1] = c.g;
        p[2] = c.b;
        p[3] = 255;
    }

    void polygon(const std::vector<glm::dvec2>& points, Rgb c) {
        fill_convex_polygon(std::span<const glm::dvec2>(points), width_, height_, 0.0,
                            [&](int x, int y) { set(x, y, c); });
    }

    // A segment as a quad of the line's width (at least one pixel, so thin lines show).
    void segment(glm::dvec2 a, glm::dvec2 b, double width, Rgb c) {
        const glm::dvec2 d = b - a;
        const double length = std::hypot(d.x, d.y);
        const double half = std::max(width, 1.0) / 2.0;
        if (length == 0.0) return;
        const glm::dvec2 n{-d.y / length * half, d.x / length * half};
        const glm::dvec2 t{d.x / length * 0.5, d.y / length * 0.5};
        polygon({a - t + n, b + t + n, b + t - n, a - t - n}, c);
    }

    void line(const PlotShapes::Line& l) {
        const glm::dvec2 a{l.x0, l.y0}, b{l.x1, l.y1};
        if (!l.dashed) {
            segment(a, b, l.width, l.color);
            return;
        }
        const double length = std::hypot(b.x - a.x, b.y - a.y);
        for (double s = 0.0; s < length; s += 8.0)  // the SVG's dash: 5 on, 3 off
            segment(a + (b - a) * (s / length), a + (b - a) * (std::min(s + 5.0, length) / length), l.width,
                    l.color);
    }

    void marker(const PlotShapes::Marker& m) {
        constexpr int sides = 24;
        std::vector<glm::dvec2> circle;
        for (int i = 0; i < sides; ++i) {
            const double angle = 2.0 * std::numbers::pi * i / sides;
            circle.push_back({m.x + m.radius * std::cos(angle), m.y + m.radius * std::sin(angle)});
        }
        switch (m.kind) {
            case PlotShapes::MarkerKind::dot: polygon(circle, m.color); break;
            case PlotShapes::MarkerKind::diamond: polygon(diamond(m.x, m.y, m.radius), m.color); break;
            case PlotShapes::MarkerKind::ring:
                for (int i = 0; i < sides; ++i) segment(circle[i], circle[(i + 1) % sides], 1.5, m.color);
                break;
        }
    }

    void text(const PlotShapes::Text& t) {
        const int width = static_cast<int>(t.text.size()) * kGlyphAdvance - kFontScale;
        int x = static_cast<int>(std::lround(t.x));
        if (t.anchor == Anchor::middle) x -= width / 2;
        if (t.anchor == Anchor::end) x -= width;
        const int top = static_cast<int>(std::lround(t.y)) - 5 * kFontScale;
        for (char c : t.text) {
            const char* rows = glyph_rows(c);
            for (int row = 0; row < 5; ++row)
                for (int col = 0; col < 3; ++col)
                    if (rows[row * 3 + col] == '#')
                        for (int dy = 0; dy < kFontScale; ++dy)
                            for (int dx = 0; dx < kFontScale; ++dx)
                                set(x + col * kFontScale + dx, top + row * kFontScale + dy, t.color);
            x += kGlyphAdvance;
        }
    }

private:
    int width_, height_;
    std::vector<std::uint8_t> pixels_;
};

}  // namespace

std::vector<std::uint8_t> plot_to_rgba(const PlotShapes& shapes) {
    Canvas canvas(shapes.width, shapes.height);
    for (const PlotShapes::Line& l : shapes.lines) canvas.line(l);
    for (const PlotShapes::Marker& m : shapes.markers) canvas.marker(m);
    for (const PlotShapes::Text& t : shapes.texts) canvas.text(t);
    return canvas.take();
}

void write_rgba_png(const std::vector<std::uint8_t>& rgba, int width, int height, const std::string& path) {
    image::WriteOptions options;
    options.software_tag = true;  // and no time stamp: the same plot gives the same bytes
    image::write_image(path, {width, height, 4, image::SampleType::uint8, rgba.data()}, options);
}

}  // namespace tessref::sweep
