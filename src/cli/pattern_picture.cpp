#include "cli/pattern_picture.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>


#include "cli/cli_util.h"
#include "common/fill.h"
#include "image/draw.h"
#include "image/image_io.h"
#include "tessref/error.h"

namespace tessref::cli {

namespace {

// ---------------------------------------------------------------------------------------
// Layout (pixels)

constexpr int picture_width = 920;
constexpr int picture_height = 720;
constexpr double domain_left = 96.0;
constexpr double domain_top = 118.0;
constexpr double domain_size = 500.0;
constexpr double panel_left = 690.0;

// Palette. Triangles: blue family when counter-clockwise in (u right, v up), orange when
// clockwise; the darker tone marks triangles that touch an outer edge (the outer ring).
constexpr Color ink{34, 34, 34};
constexpr Color muted{110, 110, 110};
constexpr Color faint{170, 170, 170};
constexpr Color domain_fill{246, 246, 246};
constexpr Color domain_outline{60, 60, 60};
constexpr Color ccw_outer{190, 214, 238};
constexpr Color ccw_inner{228, 238, 249};
constexpr Color ccw_edge{79, 112, 148};
constexpr Color ccw_arrow{36, 78, 128};
constexpr Color cw_outer{246, 206, 168};
constexpr Color cw_inner{252, 234, 216};
constexpr Color cw_edge{156, 104, 60};
constexpr Color cw_arrow{150, 72, 14};
constexpr Color boundary_point{178, 40, 36};
constexpr Color interior_point{28, 58, 104};
constexpr Color isoline_colors[2] = {{31, 96, 170}, {24, 140, 90}};

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
        return {domain_left + u * domain_size, domain_top + (1.0 - v) * domain_size};
    }

    void polygon(std::vector<glm::dvec2> points, Color fill) {
        picture_.polygons.push_back({std::move(points), fill, false, {}, 1.0});
    }
    void polygon(std::vector<glm::dvec2> points, Color fill, Color stroke, double width) {
        picture_.polygons.push_back({std::move(points), fill, true, stroke, width});
    }
    void line(glm::dvec2 a, glm::dvec2 b, Color color, double width, bool dashed = false) {
        picture_.lines.push_back({a, b, color, width, dashed});
    }
    void disc(glm::dvec2 centre, double radius, Color fill) {
        picture_.discs.push_back({centre, radius, fill});
    }
    void text(glm::dvec2 baseline, std::string text, double size, Color color,
              TextAnchor anchor = TextAnchor::start, TextFont font = TextFont::sans) {
        picture_.texts.push_back({baseline, std::move(text), size, color, anchor, font});
    }
    // An arrow head whose tip is at `tip`, pointing along `direction`.
    void arrow_head(glm::dvec2 tip, glm::dvec2 direction, double length, Color color) {
        const double norm = std::hypot(direction.x, direction.y);
        if (norm == 0.0) return;
        const glm::dvec2 d = direction / norm;
        const glm::dvec2 side{-d.y, d.x};
        const glm::dvec2 base = tip - d * length;
        polygon({tip, base + side * (length * 0.45), base - side * (length * 0.45)}, color);
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

}  // namespace

Picture draw_pattern(const Pattern& pattern, const PatternPictureInfo& info) {
    Picture picture;
    picture.width = picture_width;
    picture.height = picture_height;
    Painter paint(picture);

    const TessSettings& settings = pattern.settings();
    const Domain domain = settings.domain;
    const bool triangles = domain == Domain::triangles;
    const bool isolines = domain == Domain::isolines;
    const auto points = pattern.points();
    const std::size_t primitive_count = pattern.primitive_count();

    // Title and the command that reproduces the picture.
    std::string title = std::string(to_string(domain)) + ", " + std::string(to_string(settings.spacing)) +
                        ", " + std::string(to_string(settings.winding));
    if (settings.point_mode) title += ", point mode";
    title += " (" + std::string(to_string(pattern.precision())) + " precision)";
    picture.title = "tessref tessellate: " + title;
    paint.text({32, 44}, title, 24, ink, TextAnchor::start, TextFont::sans_bold);
    {
        // The reproducing command, wrapped at a space when it would run off the picture.
        constexpr std::size_t max_chars = 118;
        std::string rest = info.command_line;
        double line_y = 68;
        while (!rest.empty()) {
            std::size_t cut = rest.size();
            if (cut > max_chars) {
                cut = rest.rfind(' ', max_chars);
                if (cut == std::string::npos || cut == 0) cut = max_chars;
            }
            paint.text({32, line_y}, rest.substr(0, cut), 12, muted, TextAnchor::start, TextFont::mono);
            rest = cut < rest.size() ? "    " + rest.substr(rest[cut] == ' ' ? cut + 1 : cut) : "";
            line_y += 15;
        }
    }

    // The domain.
    const glm::dvec2 c00 = Painter::at(0, 0), c10 = Painter::at(1, 0), c11 = Painter::at(1, 1),
                     c01 = Painter::at(0, 1);
    std::vector<glm::dvec2> outline =
        triangles ? std::vector<glm::dvec2>{c00, c10, c01} : std::vector<glm::dvec2>{c00, c10, c11, c01};
    paint.polygon(outline, domain_fill);

    // The domain outline: dashed and under everything when it is not drawn by the pattern
    // (culled, isolines, whose v = 1 line is never emitted, point mode); otherwise solid,
    // over the triangle fills.
    const bool dashed_outline = pattern.culled() || isolines || settings.point_mode;
    const auto draw_outline = [&] {
        for (std::size_t i = 0; i < outline.size(); ++i) {
            paint.line(outline[i], outline[(i + 1) % outline.size()], dashed_outline ? faint : domain_outline,
                       dashed_outline ? 1.0 : 1.6, dashed_outline);
        }
    };
    if (dashed_outline) draw_outline();

    // Primitives.
    const std::size_t point_count = points.size();
    // Dots shrink with the point spacing so that a level-64 pattern stays readable.
    const double typical_spacing = domain_size / std::sqrt(std::max<double>(1.0, static_cast<double>(point_count)));
    const double dot_radius = std::clamp(0.18 * typical_spacing, 1.2, 4.0);
    const double edge_width = primitive_count <= 2000 ? 1.0 : 0.6;
    const auto on_boundary = [&](const TessCoord& p) {
        constexpr float eps = 1e-6f;
        if (triangles) return p.u <= eps || p.v <= eps || std::fabs(p.w) <= eps;
        if (isolines) return false;
        return p.u <= eps || p.v <= eps || p.u >= 1 - eps || p.v >= 1 - eps;
    };
    const auto pixel = [&](std::uint32_t index) { return Painter::at(points[index].u, points[index].v); };

    bool any_ccw = false, any_cw = false, arrows = false;
    if (!settings.point_mode && pattern.vertices_per_primitive() == 3) {
        arrows = primitive_count <= 128;
        for (std::size_t i = 0; i < primitive_count; ++i) {
            const auto tri = pattern.primitive(i);
            const TessCoord& a = points[tri[0]];
            const TessCoord& b = points[tri[1]];
            const TessCoord& c = points[tri[2]];
            // Signed area in (u, v), v up: positive is counter-clockwise.
            const double area = (static_cast<double>(b.u) - a.u) * (static_cast<double>(c.v) - a.v) -
                                (static_cast<double>(c.u) - a.u) * (static_cast<double>(b.v) - a.v);
            const bool ccw = area >= 0;
            (ccw ? any_ccw : any_cw) = true;
            const bool outer = on_boundary(a) || on_boundary(b) || on_boundary(c);
            const Color fill = ccw ? (outer ? ccw_outer : ccw_inner) : (outer ? cw_outer : cw_inner);
            paint.polygon({pixel(tri[0]), pixel(tri[1]), pixel(tri[2])}, fill, ccw ? ccw_edge : cw_edge,
                          edge_width);
            if (arrows) {
                // The vertex order as a small bent arrow inside the triangle: a -> b -> c.
                const glm::dvec2 pa = pixel(tri[0]), pb = pixel(tri[1]), pc = pixel(tri[2]);
                const glm::dvec2 centre = (pa + pb + pc) / 3.0;
                // At most ~40 px across, so that big triangles get a glyph, not a banner.
                const double extent = std::max({std::hypot(pa.x - centre.x, pa.y - centre.y),
                                                std::hypot(pb.x - centre.x, pb.y - centre.y),
                                                std::hypot(pc.x - centre.x, pc.y - centre.y)});
                const double factor = std::min(0.3, 24.0 / extent);
                const auto inset = [&](glm::dvec2 p) { return centre + (p - centre) * factor; };
                const glm::dvec2 ia = inset(pa), ib = inset(pb), ic = inset(pc);
                const double size = std::min({std::hypot(ib.x - ia.x, ib.y - ia.y),
                                              std::hypot(ic.x - ib.x, ic.y - ib.y)});
                if (size >= 8.0) {
                    const Color color = ccw ? ccw_arrow : cw_arrow;
                    const double head = std::min(7.0, size * 0.45);
                    const glm::dvec2 d = (ic - ib) / std::hypot(ic.x - ib.x, ic.y - ib.y);
                    paint.line(ia, ib, color, 1.0);
                    paint.line(ib, ic - d * head * 0.8, color, 1.0);
                    paint.arrow_head(ic, ic - ib, head, color);
                }
            }
        }
    } else if (!settings.point_mode && pattern.vertices_per_primitive() == 2) {
        // Colour alternates line by line (a line is a run of segments at one v), so that
        // close lines stay apart.
        int line_index = 0;
        for (std::size_t i = 0; i < primitive_count; ++i) {
            const auto seg = pattern.primitive(i);
            if (i > 0 && points[seg[0]].v != points[pattern.primitive(i - 1)[0]].v) ++line_index;
            paint.line(pixel(seg[0]), pixel(seg[1]), isoline_colors[line_index % 2], 2.0);
        }
    }


    if (!dashed_outline) draw_outline();

    // Points (in point mode they are the primitives).
    const double radius = settings.point_mode ? dot_radius + 1.0 : dot_radius;
    for (const TessCoord& p : points) {
        paint.disc(Painter::at(p.u, p.v), radius, on_boundary(p) ? boundary_point : interior_point);
    }
    if (point_count <= 40) {
        for (std::size_t i = 0; i < point_count; ++i) {
            const glm::dvec2 p = Painter::at(points[i].u, points[i].v);
            paint.text({p.x + 5, p.y - 5}, std::to_string(i), 11, muted);
        }
    }

    // Corner and edge labels.
    const Color label = muted;
    if (triangles) {
        paint.text({c00.x, c00.y + 22}, "(u,v,w) = (0,0,1)", 12, label, TextAnchor::start);
        paint.text({c10.x, c10.y + 22}, "(1,0,0)", 12, label, TextAnchor::end);
        paint.text({c01.x - 10, c01.y + 4}, "(0,1,0)", 12, label, TextAnchor::end);
        paint.text({c00.x - 24, (c00.y + c01.y) / 2 + 5}, "outer[0]", 13, ink, TextAnchor::end);
        paint.text({(c00.x + c10.x) / 2, c00.y + 40}, "outer[1]", 13, ink, TextAnchor::middle);
        const glm::dvec2 mid = (c10 + c01) / 2.0;
        paint.text({mid.x + 26, mid.y - 20}, "outer[2]", 13, ink, TextAnchor::start);
    } else {
        paint.text({c00.x, c00.y + 22}, "(u,v) = (0,0)", 12, label, TextAnchor::start);
        paint.text({c10.x, c10.y + 22}, "(1,0)", 12, label, TextAnchor::end);
        paint.text({c11.x + 10, c11.y + 4}, "(1,1)", 12, label, TextAnchor::start);
        paint.text({c01.x - 10, c01.y + 4}, "(0,1)", 12, label, TextAnchor::end);
        if (isolines) {
            paint.text({c00.x - 12, (c00.y + c01.y) / 2 - 8}, "density", 13, ink, TextAnchor::end);
            paint.text({c00.x - 12, (c00.y + c01.y) / 2 + 10}, "outer[0]", 12, muted, TextAnchor::end);
            paint.text({(c00.x + c10.x) / 2, c00.y + 40}, "detail  outer[1]", 13, ink, TextAnchor::middle);
        } else {
            paint.text({c00.x - 24, (c00.y + c01.y) / 2 + 5}, "outer[0]", 13, ink, TextAnchor::end);
            paint.text({(c00.x + c10.x) / 2, c00.y + 40}, "outer[1]", 13, ink, TextAnchor::middle);
            paint.text({c10.x + 24, (c10.y + c11.y) / 2 + 5}, "outer[2]", 13, ink, TextAnchor::start);
            paint.text({(c01.x + c11.x) / 2, c01.y - 22}, "outer[3]", 13, ink, TextAnchor::middle);
        }
    }
    // Axes: u to the right, v up (drawn, not typed: the raster text has no arrow glyphs).
    {
        const glm::dvec2 origin{c00.x - 58, c00.y + 34};
        paint.line(origin, origin + glm::dvec2{34, 0}, muted, 1.4);
        paint.arrow_head(origin + glm::dvec2{40, 0}, {1, 0}, 8, muted);
        paint.line(origin, origin + glm::dvec2{0, -34}, muted, 1.4);
        paint.arrow_head(origin + glm::dvec2{0, -40}, {0, -1}, 8, muted);
        paint.text(origin + glm::dvec2{44, 5}, "u", 13, muted);
        paint.text(origin + glm::dvec2{-4, -46}, "v", 13, muted);
    }

    if (pattern.culled()) {
        const glm::dvec2 centre = triangles ? Painter::at(1.0 / 3, 1.0 / 3) : Painter::at(0.5, 0.5);
        paint.text({centre.x, centre.y}, "culled", 30, boundary_point, TextAnchor::middle, TextFont::sans_bold);
        paint.text({centre.x, centre.y + 26}, "an outer level it uses is NaN or <= 0", 14, muted,
                   TextAnchor::middle);
    }

    // The panel: levels, counts, precision, legend.
    double y = domain_top + 4;
    const double col_given = panel_left + 76, col_effective = panel_left + 150;
    paint.text({panel_left, y}, "levels", 16, ink, TextAnchor::start, TextFont::sans_bold);
    y += 24;
    paint.text({col_given, y}, "given", 12, muted);
    paint.text({col_effective, y}, "effective", 12, muted);
    y += 6;
    paint.line({panel_left, y}, {picture_width - 16.0, y}, faint, 1.0);
    y += 20;
    const TessLevels& given = pattern.levels();
    const TessLevels& effective = pattern.effective_levels();
    const auto level_row = [&](const std::string& name, float given_value, float effective_value, bool used) {
        const Color color = used ? ink : faint;
        paint.text({panel_left, y}, name, 13, color, TextAnchor::start, TextFont::mono);
        paint.text({col_given, y}, display_number(given_value), 13, color, TextAnchor::start, TextFont::mono);
        paint.text({col_effective, y}, used ? display_number(effective_value) : "unused", 13, color,
                   TextAnchor::start, used ? TextFont::mono : TextFont::sans);
        y += 20;
    };
    for (int i = 0; i < 4; ++i) {
        level_row("outer[" + std::to_string(i) + "]", given.outer[i], effective.outer[i], i < outer_used(domain));
    }
    for (int i = 0; i < 2; ++i) {
        level_row("inner[" + std::to_string(i) + "]", given.inner[i], effective.inner[i], i < inner_used(domain));
    }

    y += 14;
    paint.text({panel_left, y}, "counts", 16, ink, TextAnchor::start, TextFont::sans_bold);
    y += 24;
    paint.text({panel_left, y}, std::to_string(point_count) + (point_count == 1 ? " point" : " points"), 13, ink);
    y += 20;
    paint.text({panel_left, y}, std::to_string(primitive_count) + " " + primitive_noun(pattern, primitive_count),
               13, ink);
    y += 20;
    if (pattern.culled()) {
        paint.text({panel_left, y}, "patch culled", 13, boundary_point, TextAnchor::start, TextFont::sans_bold);
        y += 20;
    }
    y += 14;
    paint.text({panel_left, y}, "precision", 16, ink, TextAnchor::start, TextFont::sans_bold);
    y += 24;
    paint.text({panel_left, y}, "points from: " + std::string(to_string(pattern.precision())), 13, ink);
    y += 20;
    paint.text({panel_left, y}, "max |gpu - exact| = " + display_distance(info.gpu_exact_max_difference), 13, ink);
    y += 34;

    // Legend (nothing to explain on a culled patch).
    if (pattern.culled()) return picture;
    paint.text({panel_left, y}, "legend", 16, ink, TextAnchor::start, TextFont::sans_bold);
    y += 22;
    const auto swatch = [&](Color fill, Color stroke, const std::string& text) {
        paint.polygon({{panel_left, y - 11}, {panel_left + 16, y - 11}, {panel_left + 16, y + 3}, {panel_left, y + 3}},
                      fill, stroke, 1.0);
        paint.text({panel_left + 24, y}, text, 12, ink);
        y += 20;
    };
    const auto dot = [&](Color fill, const std::string& text) {
        paint.disc({panel_left + 8, y - 4}, 4, fill);
        paint.text({panel_left + 24, y}, text, 12, ink);
        y += 20;
    };
    if (!settings.point_mode && pattern.vertices_per_primitive() == 3) {
        const bool show_ccw = any_ccw || !any_cw;
        if (show_ccw) {
            swatch(ccw_outer, ccw_edge, "ccw, touches an outer edge");
            swatch(ccw_inner, ccw_edge, "ccw, interior");
        }
        if (any_cw) {
            swatch(cw_outer, cw_edge, "cw, touches an outer edge");
            swatch(cw_inner, cw_edge, "cw, interior");
        }
        paint.text({panel_left, y}, "ccw/cw: vertex order in (u, v),", 11, muted);
        y += 15;
        paint.text({panel_left, y}, arrows ? "u right, v up; arrows run a, b, c" : "u right, v up", 11, muted);
        y += 22;
    } else if (!settings.point_mode) {
        paint.line({panel_left, y - 4}, {panel_left + 16, y - 4}, isoline_colors[0], 2.0);
        paint.text({panel_left + 24, y}, "isoline segment", 12, ink);
        y += 20;
    }
    if (!triangles && isolines) {
        dot(interior_point, "point");
    } else {
        dot(boundary_point, "point on an outer edge");
        dot(interior_point, "interior point");
    }
    if (point_count <= 40 && point_count > 0) {
        paint.text({panel_left, y}, "numbers: point index", 11, muted);
    }
    return picture;
}

// ---------------------------------------------------------------------------------------
// SVG

namespace {

std::string hex(Color c) {
    char buffer[8];
    std::snprintf(buffer, sizeof buffer, "#%02x%02x%02x", c.r, c.g, c.b);
    return buffer;
}

std::string num(double x) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.2f", x);
    std::string s = buffer;
    // "12.50" -> "12.5", "12.00" -> "12"
    while (!s.empty() && s.back() == '0') s.pop_back();
    if (!s.empty() && s.back() == '.') s.pop_back();
    if (s == "-0") s = "0";
    return s;
}

std::string xml_escape(const std::string& text) {
    std::string out;
    out.reserve(text.size());
    for (const char c : text) {
        switch (c) {
            case '&': out += "&amp;"; break;
            case '<': out += "&lt;"; break;
            case '>': out += "&gt;"; break;
            case '"': out += "&quot;"; break;
            default: out += c;
        }
    }
    return out;
}

}  // namespace

std::string picture_to_svg(const Picture& picture) {
    std::string svg;
    svg.reserve(1024 + picture.polygons.size() * 120 + picture.discs.size() * 60);
    svg += "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"" + std::to_string(picture.width) +
           "\" height=\"" + std::to_string(picture.height) + "\" viewBox=\"0 0 " + std::to_string(picture.width) +
           " " + std::to_string(picture.height) + "\">\n";
    svg += "<title>" + xml_escape(picture.title) + "</title>\n";
    svg += "<rect width=\"100%\" height=\"100%\" fill=\"" + hex(picture.background) + "\"/>\n";
    svg += "<g stroke-linejoin=\"round\" stroke-linecap=\"round\">\n";
    for (const PicturePolygon& polygon : picture.polygons) {
        svg += "<polygon points=\"";
        for (std::size_t i = 0; i < polygon.points.size(); ++i) {
            if (i) svg += ' ';
            svg += num(polygon.points[i].x) + "," + num(polygon.points[i].y);
        }
        svg += "\" fill=\"" + hex(polygon.fill) + "\"";
        if (polygon.stroked) {
            svg += " stroke=\"" + hex(polygon.stroke) + "\" stroke-width=\"" + num(polygon.stroke_width) + "\"";
        }
        svg += "/>\n";
    }
    for (const PictureLine& line : picture.lines) {
        svg += "<line x1=\"" + num(line.from.x) + "\" y1=\"" + num(line.from.y) + "\" x2=\"" + num(line.to.x) +
               "\" y2=\"" + num(line.to.y) + "\" stroke=\"" + hex(line.color) + "\" stroke-width=\"" +
               num(line.width) + "\"";
        if (line.dashed) svg += " stroke-dasharray=\"6 4\"";
        svg += "/>\n";
    }
    for (const PictureDisc& disc : picture.discs) {
        svg += "<circle cx=\"" + num(disc.centre.x) + "\" cy=\"" + num(disc.centre.y) + "\" r=\"" +
               num(disc.radius) + "\" fill=\"" + hex(disc.fill) + "\"/>\n";
    }
    svg += "</g>\n";
    for (const PictureText& text : picture.texts) {
        const char* anchor = text.anchor == TextAnchor::start ? "start"
                             : text.anchor == TextAnchor::middle ? "middle"
                                                                 : "end";
        const char* family = text.font == TextFont::mono ? "DejaVu Sans Mono, Menlo, Consolas, monospace"
                                                         : "DejaVu Sans, Helvetica, Arial, sans-serif";
        svg += "<text x=\"" + num(text.baseline.x) + "\" y=\"" + num(text.baseline.y) + "\" font-family=\"" +
               family + "\" font-size=\"" + num(text.size) + "\" fill=\"" + hex(text.color) + "\"";
        if (text.anchor != TextAnchor::start) svg += std::string(" text-anchor=\"") + anchor + "\"";
        if (text.font == TextFont::sans_bold) svg += " font-weight=\"bold\"";
        svg += ">" + xml_escape(text.text) + "</text>\n";
    }
    svg += "</svg>\n";
    return svg;
}

// ---------------------------------------------------------------------------------------
// Raster image (src/image/: lines and text drawn by OpenImageIO, the file written as PNG)

namespace {

// The canvas: an RGB float image that our own fills and OpenImageIO's lines and text
// (image::Drawing) paint into, in order: queued lines are painted before the next fill.
class Canvas {
public:
    Canvas(int width, int height, Color background, std::string path)
        : width_(width), height_(height), pixels_(static_cast<std::size_t>(width) * height * 3), path_(std::move(path)) {
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x) put(x, y, background);
    }

    image::Canvas target() { return {pixels_.data(), width_, height_, 3, image::SampleType::float32}; }
    image::Drawing& drawing() { return drawing_; }
    const std::vector<float>& pixels() const { return pixels_; }

    // Paints the queued lines and text; see image::Drawing::paint.
    bool flush(bool stop_at_failure = false, std::string* reason = nullptr) {
        return drawing_.paint(target(), stop_at_failure, path_, reason);
    }

    static std::array<float, 3> rgb(Color c) { return {c.r / 255.0f, c.g / 255.0f, c.b / 255.0f}; }

    void put(int x, int y, Color c) {
        if (x < 0 || y < 0 || x >= width_ || y >= height_) return;
        float* p = &pixels_[(static_cast<std::size_t>(y) * width_ + x) * 3];
        const auto v = rgb(c);
        p[0] = v[0];
        p[1] = v[1];
        p[2] = v[2];
    }

    // Adjacent triangles of a pattern share edges: both paint the pixels on them.
    void fill_polygon(const std::vector<glm::dvec2>& points, Color color) {
        flush();
        fill_convex_polygon(points, width_, height_, 1e-9, [&](int x, int y) { put(x, y, color); });
    }

    void fill_disc(glm::dvec2 centre, double radius, Color color) {
        flush();
        const int x0 = static_cast<int>(std::floor(centre.x - radius));
        const int x1 = static_cast<int>(std::ceil(centre.x + radius));
        const int y0 = static_cast<int>(std::floor(centre.y - radius));
        const int y1 = static_cast<int>(std::ceil(centre.y + radius));
        for (int y = y0; y <= y1; ++y) {
            for (int x = x0; x <= x1; ++x) {
                const double dx = x + 0.5 - centre.x, dy = y + 0.5 - centre.y;
                if (dx * dx + dy * dy <= radius * radius) put(x, y, color);
            }
        }
    }

    // OpenImageIO's render_line is one pixel wide; wider lines are parallel copies offset
    // across the line's minor axis.
    void line(glm::dvec2 from, glm::dvec2 to, Color color, double width, bool dashed) {
        const auto v = rgb(color);
        const int copies = std::max(1, static_cast<int>(std::lround(width)));
        const bool mostly_horizontal = std::fabs(to.x - from.x) >= std::fabs(to.y - from.y);
        const auto draw = [&](glm::dvec2 a, glm::dvec2 b) {
            for (int k = 0; k < copies; ++k) {
                const double offset = k - (copies - 1) / 2.0;
                const glm::dvec2 shift = mostly_horizontal ? glm::dvec2{0, offset} : glm::dvec2{offset, 0};
                drawing_.line(static_cast<int>(std::floor(a.x + shift.x)), static_cast<int>(std::floor(a.y + shift.y)),
                              static_cast<int>(std::floor(b.x + shift.x)), static_cast<int>(std::floor(b.y + shift.y)),
                              v);
            }
        };
        if (!dashed) {
            draw(from, to);
            return;
        }
        const double length = std::hypot(to.x - from.x, to.y - from.y);
        constexpr double dash = 6.0, gap = 4.0;
        for (double s = 0; s < length; s += dash + gap) {
            const double e = std::min(length, s + dash);
            draw(from + (to - from) * (s / length), from + (to - from) * (e / length));
        }
    }

private:
    int width_, height_;
    std::vector<float> pixels_;
    std::string path_;
    image::Drawing drawing_;
};

std::string font_for(TextFont font) {
    const char* dir = "/usr/share/fonts/truetype/dejavu/";
    const char* file = font == TextFont::sans_bold ? "DejaVuSans-Bold.ttf"
                       : font == TextFont::mono    ? "DejaVuSansMono.ttf"
                                                   : "DejaVuSans.ttf";
    const std::string path = std::string(dir) + file;
    std::error_code error;
    if (std::filesystem::exists(path, error)) return path;
    // Let OpenImageIO search its font path by name.
    return font == TextFont::sans_bold ? "DejaVuSans-Bold" : font == TextFont::mono ? "DejaVuSansMono" : "DejaVuSans";
}

}  // namespace

std::vector<std::string> write_picture_image(const Picture& picture, const std::string& path,
                                             const std::string& error_name) {
    std::vector<std::string> warnings;
    Canvas canvas(picture.width, picture.height, picture.background, error_name);
    for (const PicturePolygon& polygon : picture.polygons) {
        canvas.fill_polygon(polygon.points, polygon.fill);
        if (polygon.stroked) {
            for (std::size_t i = 0; i < polygon.points.size(); ++i) {
                canvas.line(polygon.points[i], polygon.points[(i + 1) % polygon.points.size()], polygon.stroke,
                            polygon.stroke_width, false);
            }
        }
    }
    for (const PictureLine& line : picture.lines) canvas.line(line.from, line.to, line.color, line.width, line.dashed);
    for (const PictureDisc& disc : picture.discs) canvas.fill_disc(disc.centre, disc.radius, disc.fill);

    // Text last, so a failure (no font) leaves the rest of the picture drawn.
    canvas.flush();
    for (const PictureText& text : picture.texts) {
        const image::TextAlign align = text.anchor == TextAnchor::start    ? image::TextAlign::left
                                       : text.anchor == TextAnchor::middle ? image::TextAlign::centre
                                                                           : image::TextAlign::right;
        canvas.drawing().text(static_cast<int>(std::lround(text.baseline.x)), static_cast<int>(std::lround(text.baseline.y)),
                              text.text, static_cast<int>(std::lround(text.size)), font_for(text.font),
                              Canvas::rgb(text.color), align);
    }
    std::string reason;
    if (!canvas.flush(true, &reason))
        warnings.push_back("could not render text (" + (reason.empty() ? std::string("no font") : reason) +
                           "); the picture has no labels");

    // 8 bits per channel is what PNG viewers expect: the floats converted as OpenImageIO did.
    try {
        image::write_image(path, {picture.width, picture.height, 3, image::SampleType::float32, canvas.pixels().data()});
    } catch (const Error& e) {
        throw Error(e.message(), Where::in_file(error_name));  // `path` may be a temporary name
    }
    return warnings;
}

}  // namespace tessref::cli
