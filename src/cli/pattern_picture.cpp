#include "cli/pattern_picture.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>

#include "cli/cli_util.h"
#include "image/image_io.h"
#include "picture/svg.h"
#include "tessref/error.h"

namespace tessref::cli {

namespace {

// ---------------------------------------------------------------------------------------
// Layout (pixels)

constexpr int kPictureWidth = 920;
constexpr int kPictureHeight = 720;
constexpr double kDomainLeft = 96.0;
constexpr double kDomainTop = 118.0;
constexpr double kDomainSize = 500.0;
constexpr double kPanelLeft = 690.0;

// Palette. Triangles: blue family when counter-clockwise in (u right, v up), orange when
// clockwise; the darker tone marks triangles that touch an outer edge (the outer ring).
constexpr Colour kInk = Colour::from_codes(34, 34, 34);
constexpr Colour kMuted = Colour::from_codes(110, 110, 110);
constexpr Colour kFaint = Colour::from_codes(170, 170, 170);
constexpr Colour kDomainFill = Colour::from_codes(246, 246, 246);
constexpr Colour kDomainOutline = Colour::from_codes(60, 60, 60);
constexpr Colour kCcwOuter = Colour::from_codes(190, 214, 238);
constexpr Colour kCcwInner = Colour::from_codes(228, 238, 249);
constexpr Colour kCcwEdge = Colour::from_codes(79, 112, 148);
constexpr Colour kCcwArrow = Colour::from_codes(36, 78, 128);
constexpr Colour kCwOuter = Colour::from_codes(246, 206, 168);
constexpr Colour kCwInner = Colour::from_codes(252, 234, 216);
constexpr Colour kCwEdge = Colour::from_codes(156, 104, 60);
constexpr Colour kCwArrow = Colour::from_codes(150, 72, 14);
constexpr Colour kBoundaryPoint = Colour::from_codes(178, 40, 36);
constexpr Colour kInteriorPoint = Colour::from_codes(28, 58, 104);
constexpr Colour kIsolineColours[2] = {Colour::from_codes(31, 96, 170), Colour::from_codes(24, 140, 90)};

std::string display_number(float x) {
    if (std::isnan(x)) return "nan";
    if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.6g", static_cast<double>(x));
    return buffer;
}

std::string display_distance(double x) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.3g", x);
    return buffer;
}

// How many outer / inner levels a domain reads (GL: the rest are ignored).
int outer_used(Domain domain) {
    switch (domain) {
        case Domain::quads: return 4;
        case Domain::triangles: return 3;
        case Domain::isolines: return 2;
    }
    return 4;
}
int inner_used(Domain domain) {
    switch (domain) {
        case Domain::quads: return 2;
        case Domain::triangles: return 1;
        case Domain::isolines: return 0;
    }
    return 2;
}

class Painter {
public:
    explicit Painter(Picture& picture) : picture_(picture) {}

    // (u, v) in the domain -> pixels: u to the right, v up.
    static glm::dvec2 at(double u, double v) {
        return {kDomainLeft + u * kDomainSize, kDomainTop + (1.0 - v) * kDomainSize};
    }

    void polygon(std::vector<glm::dvec2> points, Colour fill) {
        picture_.polygons.push_back({std::move(points), fill, false, {}, 1.0});
    }
    void polygon(std::vector<glm::dvec2> points, Colour fill, Colour stroke, double width) {
        picture_.polygons.push_back({std::move(points), fill, true, stroke, width});
    }
    void line(glm::dvec2 a, glm::dvec2 b, Colour colour, double width, bool dashed = false) {
        picture_.lines.push_back({a, b, colour, width, dashed});
    }
    void disc(glm::dvec2 centre, double radius, Colour fill) {
        picture_.discs.push_back({centre, radius, fill});
    }
    void text(glm::dvec2 baseline, std::string text, double size, Colour colour,
              Anchor anchor = Anchor::start, TextFont font = TextFont::sans) {
        picture_.texts.push_back({baseline, std::move(text), size, colour, anchor, font});
    }
    // An arrow head whose tip is at `tip`, pointing along `direction`.
    void arrow_head(glm::dvec2 tip, glm::dvec2 direction, double length, Colour colour) {
        const double norm = std::hypot(direction.x, direction.y);
        if (norm == 0.0) return;
        const glm::dvec2 d = direction / norm;
        const glm::dvec2 side{-d.y, d.x};
        const glm::dvec2 base = tip - d * length;
        polygon({tip, base + side * (length * 0.45), base - side * (length * 0.45)}, colour);
    }

private:
    Picture& picture_;
};

std::string primitive_noun(const Pattern& pattern, std::size_t count) {
    const bool one = count == 1;
    if (pattern.settings().point_mode) return one ? "point primitive" : "point primitives";
    if (pattern.settings().domain == Domain::isolines) return one ? "segment" : "segments";
    return one ? "triangle" : "triangles";
}

// Whether a point lies on the domain's outer edge (isolines have none: their v = 1 line is
// never emitted, and the u edges are segment ends).
bool on_outer_edge(Domain domain, const TessCoord& p) {
    constexpr float eps = 1e-6f;
    if (domain == Domain::triangles) return p.u <= eps || p.v <= eps || std::fabs(p.w) <= eps;
    if (domain == Domain::isolines) return false;
    return p.u <= eps || p.v <= eps || p.u >= 1 - eps || p.v >= 1 - eps;
}

// The title, and under it the command that reproduces the picture, wrapped at a space when
// it would run off the picture.
void draw_title(Painter& paint, Picture& picture, const Pattern& pattern, const std::string& command_line) {
    const TessSettings& settings = pattern.settings();
    std::string title = std::string(to_string(settings.domain)) + ", " + std::string(to_string(settings.spacing)) +
                        ", " + std::string(to_string(settings.winding));
    if (settings.point_mode) title += ", point mode";
    title += " (" + std::string(to_string(pattern.precision())) + " precision)";
    picture.title = "tessref tessellate: " + title;
    paint.text({32, 44}, title, 24, kInk, Anchor::start, TextFont::sans_bold);
    constexpr std::size_t max_chars = 118;
    std::string rest = command_line;
    double line_y = 68;
    while (!rest.empty()) {
        std::size_t cut = rest.size();
        if (cut > max_chars) {
            cut = rest.rfind(' ', max_chars);
            if (cut == std::string::npos || cut == 0) cut = max_chars;
        }
        paint.text({32, line_y}, rest.substr(0, cut), 12, kMuted, Anchor::start, TextFont::mono);
        rest = cut < rest.size() ? "    " + rest.substr(rest[cut] == ' ' ? cut + 1 : cut) : "";
        line_y += 15;
    }
}

// Which windings the triangles showed, and whether they carry arrows: the legend explains
// only what is drawn.
struct Windings {
    bool any_ccw = false, any_cw = false, arrows = false;
};

// The vertex order as a small bent arrow inside the triangle: a -> b -> c.
void draw_winding_arrow(Painter& paint, glm::dvec2 pa, glm::dvec2 pb, glm::dvec2 pc, Colour colour) {
    const glm::dvec2 centre = (pa + pb + pc) / 3.0;
    // At most ~40 px across, so that big triangles get a glyph, not a banner.
    const double extent = std::max({std::hypot(pa.x - centre.x, pa.y - centre.y),
                                    std::hypot(pb.x - centre.x, pb.y - centre.y),
                                    std::hypot(pc.x - centre.x, pc.y - centre.y)});
    const double factor = std::min(0.3, 24.0 / extent);
    const auto inset = [&](glm::dvec2 p) { return centre + (p - centre) * factor; };
    const glm::dvec2 ia = inset(pa), ib = inset(pb), ic = inset(pc);
    const double size = std::min({std::hypot(ib.x - ia.x, ib.y - ia.y), std::hypot(ic.x - ib.x, ic.y - ib.y)});
    if (size < 8.0) return;
    const double head = std::min(7.0, size * 0.45);
    const glm::dvec2 d = (ic - ib) / std::hypot(ic.x - ib.x, ic.y - ib.y);
    paint.line(ia, ib, colour, 1.0);
    paint.line(ib, ic - d * head * 0.8, colour, 1.0);
    paint.arrow_head(ic, ic - ib, head, colour);
}

// Every triangle filled by its winding in (u, v), darker where it touches an outer edge.
Windings draw_triangles(Painter& paint, const Pattern& pattern) {
    const auto points = pattern.points();
    const std::size_t count = pattern.primitive_count();
    const double edge_width = count <= 2000 ? 1.0 : 0.6;
    const auto outer_edge = [&](const TessCoord& p) { return on_outer_edge(pattern.settings().domain, p); };
    const auto pixel = [&](std::uint32_t index) { return Painter::at(points[index].u, points[index].v); };
    Windings windings;
    windings.arrows = count <= 128;
    for (std::size_t i = 0; i < count; ++i) {
        const auto tri = pattern.primitive(i);
        const TessCoord& a = points[tri[0]];
        const TessCoord& b = points[tri[1]];
        const TessCoord& c = points[tri[2]];
        // Signed area in (u, v), v up: positive is counter-clockwise.
        const double area = (static_cast<double>(b.u) - a.u) * (static_cast<double>(c.v) - a.v) -
                            (static_cast<double>(c.u) - a.u) * (static_cast<double>(b.v) - a.v);
        const bool ccw = area >= 0;
        (ccw ? windings.any_ccw : windings.any_cw) = true;
        const bool outer = outer_edge(a) || outer_edge(b) || outer_edge(c);
        const Colour fill = ccw ? (outer ? kCcwOuter : kCcwInner) : (outer ? kCwOuter : kCwInner);
        paint.polygon({pixel(tri[0]), pixel(tri[1]), pixel(tri[2])}, fill, ccw ? kCcwEdge : kCwEdge, edge_width);
        if (windings.arrows)
            draw_winding_arrow(paint, pixel(tri[0]), pixel(tri[1]), pixel(tri[2]), ccw ? kCcwArrow : kCwArrow);
    }
    return windings;
}

// The isoline segments; the colour alternates line by line (a line is a run of segments at
// one v), so that close lines stay apart.
void draw_isolines(Painter& paint, const Pattern& pattern) {
    const auto points = pattern.points();
    int line_index = 0;
    for (std::size_t i = 0; i < pattern.primitive_count(); ++i) {
        const auto seg = pattern.primitive(i);
        if (i > 0 && points[seg[0]].v != points[pattern.primitive(i - 1)[0]].v) ++line_index;
        paint.line(Painter::at(points[seg[0]].u, points[seg[0]].v), Painter::at(points[seg[1]].u, points[seg[1]].v),
                   kIsolineColours[line_index % 2], 2.0);
    }
}

// Every point dotted (in point mode they are the primitives), numbered when few.
void draw_points(Painter& paint, const Pattern& pattern) {
    const auto points = pattern.points();
    // Dots shrink with the point spacing so that a level-64 pattern stays readable.
    const double typical_spacing =
        kDomainSize / std::sqrt(std::max<double>(1.0, static_cast<double>(points.size())));
    const double dot_radius = std::clamp(0.18 * typical_spacing, 1.2, 4.0);
    const double radius = pattern.settings().point_mode ? dot_radius + 1.0 : dot_radius;
    for (const TessCoord& p : points) {
        paint.disc(Painter::at(p.u, p.v), radius,
                   on_outer_edge(pattern.settings().domain, p) ? kBoundaryPoint : kInteriorPoint);
    }
    if (points.size() <= 40) {
        for (std::size_t i = 0; i < points.size(); ++i) {
            const glm::dvec2 p = Painter::at(points[i].u, points[i].v);
            paint.text({p.x + 5, p.y - 5}, std::to_string(i), 11, kMuted);
        }
    }
}

// The corners' coordinates, the outer edges' names, and the u and v axes.
void draw_domain_labels(Painter& paint, Domain domain) {
    const glm::dvec2 c00 = Painter::at(0, 0), c10 = Painter::at(1, 0), c11 = Painter::at(1, 1),
                     c01 = Painter::at(0, 1);
    const Colour label = kMuted;
    if (domain == Domain::triangles) {
        paint.text({c00.x, c00.y + 22}, "(u,v,w) = (0,0,1)", 12, label, Anchor::start);
        paint.text({c10.x, c10.y + 22}, "(1,0,0)", 12, label, Anchor::end);
        paint.text({c01.x - 10, c01.y + 4}, "(0,1,0)", 12, label, Anchor::end);
        paint.text({c00.x - 24, (c00.y + c01.y) / 2 + 5}, "outer[0]", 13, kInk, Anchor::end);
        paint.text({(c00.x + c10.x) / 2, c00.y + 40}, "outer[1]", 13, kInk, Anchor::middle);
        const glm::dvec2 mid = (c10 + c01) / 2.0;
        paint.text({mid.x + 26, mid.y - 20}, "outer[2]", 13, kInk, Anchor::start);
    } else {
        paint.text({c00.x, c00.y + 22}, "(u,v) = (0,0)", 12, label, Anchor::start);
        paint.text({c10.x, c10.y + 22}, "(1,0)", 12, label, Anchor::end);
        paint.text({c11.x + 10, c11.y + 4}, "(1,1)", 12, label, Anchor::start);
        paint.text({c01.x - 10, c01.y + 4}, "(0,1)", 12, label, Anchor::end);
        if (domain == Domain::isolines) {
            paint.text({c00.x - 12, (c00.y + c01.y) / 2 - 8}, "density", 13, kInk, Anchor::end);
            paint.text({c00.x - 12, (c00.y + c01.y) / 2 + 10}, "outer[0]", 12, kMuted, Anchor::end);
            paint.text({(c00.x + c10.x) / 2, c00.y + 40}, "detail  outer[1]", 13, kInk, Anchor::middle);
        } else {
            paint.text({c00.x - 24, (c00.y + c01.y) / 2 + 5}, "outer[0]", 13, kInk, Anchor::end);
            paint.text({(c00.x + c10.x) / 2, c00.y + 40}, "outer[1]", 13, kInk, Anchor::middle);
            paint.text({c10.x + 24, (c10.y + c11.y) / 2 + 5}, "outer[2]", 13, kInk, Anchor::start);
            paint.text({(c01.x + c11.x) / 2, c01.y - 22}, "outer[3]", 13, kInk, Anchor::middle);
        }
    }
    // Axes: u to the right, v up (drawn, not typed: the raster text has no arrow glyphs).
    const glm::dvec2 origin{c00.x - 58, c00.y + 34};
    paint.line(origin, origin + glm::dvec2{34, 0}, kMuted, 1.4);
    paint.arrow_head(origin + glm::dvec2{40, 0}, {1, 0}, 8, kMuted);
    paint.line(origin, origin + glm::dvec2{0, -34}, kMuted, 1.4);
    paint.arrow_head(origin + glm::dvec2{0, -40}, {0, -1}, 8, kMuted);
    paint.text(origin + glm::dvec2{44, 5}, "u", 13, kMuted);
    paint.text(origin + glm::dvec2{-4, -46}, "v", 13, kMuted);
}

// The panel beside the domain: the levels as given and as the generator used them, the
// counts, the precision; returns the height where the legend starts.
double draw_panel(Painter& paint, const Pattern& pattern, const PatternPictureInfo& info) {
    const Domain domain = pattern.settings().domain;
    const std::size_t point_count = pattern.points().size();
    const std::size_t primitive_count = pattern.primitive_count();
    double y = kDomainTop + 4;
    const double col_given = kPanelLeft + 76, col_effective = kPanelLeft + 150;
    paint.text({kPanelLeft, y}, "levels", 16, kInk, Anchor::start, TextFont::sans_bold);
    y += 24;
    paint.text({col_given, y}, "given", 12, kMuted);
    paint.text({col_effective, y}, "effective", 12, kMuted);
    y += 6;
    paint.line({kPanelLeft, y}, {kPictureWidth - 16.0, y}, kFaint, 1.0);
    y += 20;
    const TessLevels& given = pattern.levels();
    const TessLevels& effective = pattern.effective_levels();
    const auto level_row = [&](const std::string& name, float given_value, float effective_value, bool used) {
        const Colour colour = used ? kInk : kFaint;
        paint.text({kPanelLeft, y}, name, 13, colour, Anchor::start, TextFont::mono);
        paint.text({col_given, y}, display_number(given_value), 13, colour, Anchor::start, TextFont::mono);
        paint.text({col_effective, y}, used ? display_number(effective_value) : "unused", 13, colour,
                   Anchor::start, used ? TextFont::mono : TextFont::sans);
        y += 20;
    };
    for (int i = 0; i < 4; ++i) {
        level_row("outer[" + std::to_string(i) + "]", given.outer[i], effective.outer[i], i < outer_used(domain));
    }
    for (int i = 0; i < 2; ++i) {
        level_row("inner[" + std::to_string(i) + "]", given.inner[i], effective.inner[i], i < inner_used(domain));
    }

    y += 14;
    paint.text({kPanelLeft, y}, "counts", 16, kInk, Anchor::start, TextFont::sans_bold);
    y += 24;
    paint.text({kPanelLeft, y}, std::to_string(point_count) + (point_count == 1 ? " point" : " points"), 13, kInk);
    y += 20;
    paint.text({kPanelLeft, y}, std::to_string(primitive_count) + " " + primitive_noun(pattern, primitive_count),
               13, kInk);
    y += 20;
    if (pattern.culled()) {
        paint.text({kPanelLeft, y}, "patch culled", 13, kBoundaryPoint, Anchor::start, TextFont::sans_bold);
        y += 20;
    }
    y += 14;
    paint.text({kPanelLeft, y}, "precision", 16, kInk, Anchor::start, TextFont::sans_bold);
    y += 24;
    paint.text({kPanelLeft, y}, "points from: " + std::string(to_string(pattern.precision())), 13, kInk);
    y += 20;
    paint.text({kPanelLeft, y}, "max |gpu - exact| = " + display_distance(info.gpu_exact_max_difference), 13, kInk);
    return y + 34;
}

// The legend, from height y: what the fills, lines and dots drawn mean.
void draw_legend(Painter& paint, const Pattern& pattern, const Windings& windings, double y) {
    const TessSettings& settings = pattern.settings();
    const std::size_t point_count = pattern.points().size();
    paint.text({kPanelLeft, y}, "legend", 16, kInk, Anchor::start, TextFont::sans_bold);
    y += 22;
    const auto swatch = [&](Colour fill, Colour stroke, const std::string& text) {
        paint.polygon({{kPanelLeft, y - 11}, {kPanelLeft + 16, y - 11}, {kPanelLeft + 16, y + 3}, {kPanelLeft, y + 3}},
                      fill, stroke, 1.0);
        paint.text({kPanelLeft + 24, y}, text, 12, kInk);
        y += 20;
    };
    const auto dot = [&](Colour fill, const std::string& text) {
        paint.disc({kPanelLeft + 8, y - 4}, 4, fill);
        paint.text({kPanelLeft + 24, y}, text, 12, kInk);
        y += 20;
    };
    if (!settings.point_mode && pattern.vertices_per_primitive() == 3) {
        const bool show_ccw = windings.any_ccw || !windings.any_cw;
        if (show_ccw) {
            swatch(kCcwOuter, kCcwEdge, "ccw, touches an outer edge");
            swatch(kCcwInner, kCcwEdge, "ccw, interior");
        }
        if (windings.any_cw) {
            swatch(kCwOuter, kCwEdge, "cw, touches an outer edge");
            swatch(kCwInner, kCwEdge, "cw, interior");
        }
        paint.text({kPanelLeft, y}, "ccw/cw: vertex order in (u, v),", 11, kMuted);
        y += 15;
        paint.text({kPanelLeft, y}, windings.arrows ? "u right, v up; arrows run a, b, c" : "u right, v up", 11,
                   kMuted);
        y += 22;
    } else if (!settings.point_mode) {
        paint.line({kPanelLeft, y - 4}, {kPanelLeft + 16, y - 4}, kIsolineColours[0], 2.0);
        paint.text({kPanelLeft + 24, y}, "isoline segment", 12, kInk);
        y += 20;
    }
    if (settings.domain == Domain::isolines) {
        dot(kInteriorPoint, "point");
    } else {
        dot(kBoundaryPoint, "point on an outer edge");
        dot(kInteriorPoint, "interior point");
    }
    if (point_count <= 40 && point_count > 0) {
        paint.text({kPanelLeft, y}, "numbers: point index", 11, kMuted);
    }
}

}  // namespace

Picture draw_pattern(const Pattern& pattern, const PatternPictureInfo& info) {
    Picture picture;
    picture.width = kPictureWidth;
    picture.height = kPictureHeight;
    Painter paint(picture);
    const TessSettings& settings = pattern.settings();
    draw_title(paint, picture, pattern, info.command_line);

    // The domain, and its outline: dashed and under everything when the pattern does not
    // draw it (culled, isolines, whose v = 1 line is never emitted, point mode); otherwise
    // solid, over the triangle fills.
    const glm::dvec2 c00 = Painter::at(0, 0), c10 = Painter::at(1, 0), c11 = Painter::at(1, 1),
                     c01 = Painter::at(0, 1);
    const std::vector<glm::dvec2> outline = settings.domain == Domain::triangles
                                                ? std::vector<glm::dvec2>{c00, c10, c01}
                                                : std::vector<glm::dvec2>{c00, c10, c11, c01};
    paint.polygon(outline, kDomainFill);
    const bool dashed_outline = pattern.culled() || settings.domain == Domain::isolines || settings.point_mode;
    const auto draw_outline = [&] {
        for (std::size_t i = 0; i < outline.size(); ++i) {
            paint.line(outline[i], outline[(i + 1) % outline.size()], dashed_outline ? kFaint : kDomainOutline,
                       dashed_outline ? 1.0 : 1.6, dashed_outline);
        }
    };
    if (dashed_outline) draw_outline();

    Windings windings;
    if (!settings.point_mode && pattern.vertices_per_primitive() == 3)
        windings = draw_triangles(paint, pattern);
    else if (!settings.point_mode && pattern.vertices_per_primitive() == 2)
        draw_isolines(paint, pattern);
    if (!dashed_outline) draw_outline();

    draw_points(paint, pattern);
    draw_domain_labels(paint, settings.domain);
    if (pattern.culled()) {
        const glm::dvec2 centre =
            settings.domain == Domain::triangles ? Painter::at(1.0 / 3, 1.0 / 3) : Painter::at(0.5, 0.5);
        paint.text({centre.x, centre.y}, "culled", 30, kBoundaryPoint, Anchor::middle, TextFont::sans_bold);
        paint.text({centre.x, centre.y + 26}, "an outer level it uses is NaN or <= 0", 14, kMuted, Anchor::middle);
    }
    const double legend_y = draw_panel(paint, pattern, info);
    // Nothing to explain on a culled patch.
    if (!pattern.culled()) draw_legend(paint, pattern, windings, legend_y);
    return picture;
}

// ---------------------------------------------------------------------------------------
// SVG

namespace {

std::string num(double x) { return picture::number_trimmed(x); }

}  // namespace

std::string picture_to_svg(const Picture& picture) {
    std::string svg;
    svg.reserve(1024 + picture.polygons.size() * 120 + picture.discs.size() * 60);
    svg += picture::svg_begin(picture.width, picture.height, picture.title, picture.background);
    svg += "<g stroke-linejoin=\"round\" stroke-linecap=\"round\">\n";
    for (const PicturePolygon& polygon : picture.polygons) {
        svg += "<polygon points=\"";
        for (std::size_t i = 0; i < polygon.points.size(); ++i) {
            if (i) svg += ' ';
            svg += num(polygon.points[i].x) + "," + num(polygon.points[i].y);
        }
        svg += "\" fill=\"" + picture::hex(polygon.fill) + "\"";
        if (polygon.stroked) {
            svg += " stroke=\"" + picture::hex(polygon.stroke) + "\" stroke-width=\"" + num(polygon.stroke_width) + "\"";
        }
        svg += "/>\n";
    }
    for (const PictureLine& line : picture.lines) {
        svg += "<line x1=\"" + num(line.from.x) + "\" y1=\"" + num(line.from.y) + "\" x2=\"" + num(line.to.x) +
               "\" y2=\"" + num(line.to.y) + "\" stroke=\"" + picture::hex(line.colour) + "\" stroke-width=\"" +
               num(line.width) + "\"";
        if (line.dashed) svg += " stroke-dasharray=\"6 4\"";
        svg += "/>\n";
    }
    for (const PictureDisc& disc : picture.discs) {
        svg += "<circle cx=\"" + num(disc.centre.x) + "\" cy=\"" + num(disc.centre.y) + "\" r=\"" +
               num(disc.radius) + "\" fill=\"" + picture::hex(disc.fill) + "\"/>\n";
    }
    svg += "</g>\n";
    for (const PictureText& text : picture.texts) {
        const char* anchor = text.anchor == Anchor::start ? "start"
                             : text.anchor == Anchor::middle ? "middle"
                                                                 : "end";
        const char* family = text.font == TextFont::mono ? "DejaVu Sans Mono, Menlo, Consolas, monospace"
                                                         : "DejaVu Sans, Helvetica, Arial, sans-serif";
        svg += "<text x=\"" + num(text.baseline.x) + "\" y=\"" + num(text.baseline.y) + "\" font-family=\"" +
               family + "\" font-size=\"" + num(text.size) + "\" fill=\"" + picture::hex(text.colour) + "\"";
        if (text.anchor != Anchor::start) svg += std::string(" text-anchor=\"") + anchor + "\"";
        if (text.font == TextFont::sans_bold) svg += " font-weight=\"bold\"";
        svg += ">" + picture::xml_escape(text.text) + "</text>\n";
    }
    svg += "</svg>\n";
    return svg;
}

// ---------------------------------------------------------------------------------------
// Raster image (src/image/: lines and text drawn by OpenImageIO, the file written as PNG)

std::vector<std::string> write_picture_image(const Picture& picture, const std::string& path,
                                             const std::string& error_name) {
    std::vector<std::string> warnings;
    picture::Canvas canvas(picture.width, picture.height, 3, image::SampleType::float32, picture.background, error_name);
    // Adjacent triangles of a pattern share edges: both paint the pixels on them (a margin).
    constexpr double shared_edge_margin = 1e-9;
    for (const PicturePolygon& polygon : picture.polygons) {
        canvas.fill_polygon(polygon.points, polygon.fill, shared_edge_margin);
        if (polygon.stroked) {
            for (std::size_t i = 0; i < polygon.points.size(); ++i) {
                canvas.pixel_line(polygon.points[i], polygon.points[(i + 1) % polygon.points.size()], polygon.stroke_width,
                                  polygon.stroke);
            }
        }
    }
    for (const PictureLine& line : picture.lines)
        canvas.pixel_line(line.from, line.to, line.width, line.colour, line.dashed ? 6.0 : 0.0, 4.0);
    for (const PictureDisc& disc : picture.discs) canvas.fill_disc(disc.centre, disc.radius, disc.fill);

    // Text last, so a failure (no font) leaves the rest of the picture drawn.
    canvas.flush();
    for (const PictureText& text : picture.texts)
        canvas.truetype_text(text.baseline, text.text, text.size, text.font, text.colour, text.anchor);
    std::string reason;
    if (!canvas.flush(true, &reason))
        warnings.push_back("could not render text (" + (reason.empty() ? std::string("no font") : reason) +
                           "); the picture has no labels");

    // 8 bits per channel is what PNG viewers expect: the floats converted as OpenImageIO did.
    try {
        image::write_image(path, {picture.width, picture.height, 3, image::SampleType::float32, canvas.view().samples});
    } catch (const Error& e) {
        throw Error(e.message(), Where::in_file(error_name));  // `path` may be a temporary name
    }
    return warnings;
}

}  // namespace tessref::cli
