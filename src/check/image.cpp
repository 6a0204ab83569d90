// The defect picture: a top view of the mesh, drawn lightly (grey, darker where steep),
// with every located defect marked in its class colour, and a legend with a scale bar and
// the axes of the view.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "check/check_internal.h"
#include "image/draw.h"
#include "image/image_io.h"
#include "picture/colour.h"
#include "picture/fill.h"
#include "tessref/error.h"

namespace tessref {

namespace {

using picture::Colour;

Colour class_colour(DefectClass kind) {
    switch (kind) {
        case DefectClass::boundary_loop: return {0.90f, 0.10f, 0.10f};
        case DefectClass::non_manifold_edge: return {0.60f, 0.00f, 0.80f};
        case DefectClass::non_manifold_vertex: return {0.95f, 0.40f, 0.80f};
        case DefectClass::refused_face: return {0.45f, 0.30f, 0.15f};
        case DefectClass::inconsistent_orientation: return {1.00f, 0.55f, 0.00f};
        case DefectClass::inverted_volume: return {0.55f, 0.55f, 0.00f};
        case DefectClass::degenerate_face: return {0.00f, 0.65f, 0.65f};
        case DefectClass::duplicate_face: return {0.00f, 0.35f, 0.80f};
        case DefectClass::coincident_vertices: return {0.10f, 0.70f, 0.10f};
        case DefectClass::near_coincident_vertices: return {0.50f, 0.85f, 0.20f};
        case DefectClass::t_junction: return {0.85f, 0.00f, 0.45f};
        case DefectClass::probe_miss: return {0.05f, 0.05f, 0.05f};
        case DefectClass::probe_odd_parity: return {0.30f, 0.30f, 0.30f};
        case DefectClass::probe_escape: return {0.20f, 0.20f, 0.55f};
        case DefectClass::facing_down: return {0.55f, 0.10f, 0.45f};
    }
    return {0.0f, 0.0f, 0.0f};
}

class TopView {
public:
    TopView(const CheckReport& report, int width) : up_(report.up_axis), u_((up_ + 1) % 3), w_((up_ + 2) % 3) {
        lo_ = {report.bbox_min[u_], report.bbox_min[w_]};
        hi_ = {report.bbox_max[u_], report.bbox_max[w_]};
        glm::dvec2 extent = hi_ - lo_;
        const double side = std::max({extent.x, extent.y, 1e-300});
        // Square-ish frame around the footprint, at least 5% of the larger side each way.
        lo_ -= 0.05 * side;
        hi_ += 0.05 * side;
        extent = hi_ - lo_;
        width_ = std::clamp(width, 64, 8192);
        height_ = std::clamp(static_cast<int>(std::lround(width_ * extent.y / std::max(extent.x, 1e-300))), 64, 8192);
        scale_ = std::min(width_ / extent.x, height_ / extent.y);
    }
    int width() const { return width_; }
    int height() const { return height_; }
    // Pixel coordinates (x right, y down) of a point, looking down the up axis.
    glm::dvec2 pixel(const glm::dvec3& p) const {
        return {(p[u_] - lo_.x) * scale_, height_ - (p[w_] - lo_.y) * scale_};
    }
    // Whether a point lands near enough the picture to be drawn (not NaN, not far off).
    bool drawable(const glm::dvec3& p) const {
        const glm::dvec2 q = pixel(p);
        return std::isfinite(q.x) && std::isfinite(q.y) && std::abs(q.x) < 1e6 && std::abs(q.y) < 1e6;
    }
    int up() const { return up_; }
    int right_axis() const { return u_; }  // the world axis that runs right in the picture
    int top_axis() const { return w_; }    // and the one that runs up
    double pixels_per_unit() const { return scale_; }

private:
    int up_, u_, w_;
    glm::dvec2 lo_, hi_;
    int width_ = 0, height_ = 0;
    double scale_ = 1.0;
};

// Darkens the pixels of a triangle to `value` (the darkest paint wins).
void fill_triangle(std::vector<float>& grey, int width, int height, glm::dvec2 a, glm::dvec2 b, glm::dvec2 c, float value) {
    const auto darken = [&](int x, int y) {
        float& g = grey[std::size_t(y) * width + x];
        g = std::min(g, value);
    };
    const glm::dvec2 corners[3] = {a, b, c};
    if (pixel_box(corners, width, height).empty()) return;
    if (std::abs((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)) < 1.0) {
        // Smaller than a pixel: a dot is what it looks like (and the centres it covers below).
        darken(std::clamp(static_cast<int>((a.x + b.x + c.x) / 3.0), 0, width - 1),
               std::clamp(static_cast<int>((a.y + b.y + c.y) / 3.0), 0, height - 1));
    }
    // A pixel centre on an edge two triangles share belongs to both (a margin a little over
    // rounding): with the exact test it belonged to neither, and a terrain whose rows of
    // vertices fall on pixel centres showed dotted white lines along its patch borders,
    // which look like cracks on a mesh that has none. The darker shade wins there.
    fill_convex_polygon(corners, width, height, 1e-6, darken);
}

const char* axis_name(int axis) { return axis == 0 ? "x" : axis == 1 ? "y" : "z"; }

// The scale bar's length in world units: the largest 1, 2 or 5 times a power of ten that
// spans at most a quarter of the picture's width.
double scale_bar_length(double pixels_per_unit, int width) {
    const double most = 0.25 * width / pixels_per_unit;
    if (!(most > 0.0) || !std::isfinite(most)) return 0.0;
    const double power = std::pow(10.0, std::floor(std::log10(most)));
    for (double m : {5.0, 2.0, 1.0})
        if (m * power <= most) return m * power;
    return power;
}

std::string short_number(double x) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", x);
    return text;
}

}  // namespace

void write_defect_image(const IndexedMesh& mesh, const CheckReport& report, const std::string& path, int width) {
    const TopView view(report, width);
    const int w = view.width(), h = view.height();
    std::vector<float> grey(std::size_t(w) * h, 1.0f);
    const bool draw_edges = mesh.face_count() <= 20000;
    for (std::size_t f = 0; f < mesh.face_count(); ++f) {
        const auto face = mesh.face(f);
        if (face.size() < 3 || !std::all_of(face.begin(), face.end(), [&](std::uint32_t v) { return view.drawable(mesh.positions[v]); }))
            continue;
        const glm::dvec3 a = check_detail::face_vector_area(mesh, f);
        const double len = glm::length(a);
        const float steep = len > 0.0 ? static_cast<float>(std::abs(a[view.up()]) / len) : 0.0f;
        const float value = 0.70f + 0.20f * steep;
        for (std::size_t k = 1; k + 1 < face.size(); ++k)
            fill_triangle(grey, w, h, view.pixel(mesh.positions[face[0]]), view.pixel(mesh.positions[face[k]]),
                          view.pixel(mesh.positions[face[k + 1]]), value);
    }

    // The legend goes in a strip under the view, one row per class found.
    std::vector<std::string> lines;
    std::vector<Colour> swatches;
    for (const DefectReport& d : report.defects) {
        if (d.count == 0) continue;
        lines.push_back(std::string(defect_class_name(d.kind)) + " (" + std::to_string(d.count) + ")");
        swatches.push_back(class_colour(d.kind));
    }
    if (lines.empty()) {
        lines.push_back("no defects");
        swatches.push_back({0.2f, 0.6f, 0.2f});
    }
    const int row = 18, pad = 6, columns = std::max(1, w / 260);
    // One row more: the scale bar and the axes.
    const int legend_rows = (static_cast<int>(lines.size()) + columns - 1) / columns + 1;
    const int legend_height = 2 * pad + row * legend_rows;

    // 8-bit RGB, white; the grey view converted as OpenImageIO's setpixel did; then the
    // lines, rings, swatches and text painted over it by OpenImageIO (image/draw.h).
    const int total_height = h + legend_height;
    std::vector<std::uint8_t> pixels(std::size_t(w) * total_height * 3, 255);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::uint8_t g = image::float_to_code8(grey[std::size_t(y) * w + x]);
            std::uint8_t* p = &pixels[(std::size_t(y) * w + x) * 3];
            p[0] = p[1] = p[2] = g;
        }
    image::Drawing drawing;
    const Colour black = {0.0f, 0.0f, 0.0f};
    if (draw_edges) {
        const Colour edge = {0.55f, 0.55f, 0.55f};
        for (std::size_t f = 0; f < mesh.face_count(); ++f) {
            const auto face = mesh.face(f);
            for (std::size_t k = 0; k < face.size(); ++k) {
                if (!view.drawable(mesh.positions[face[k]]) || !view.drawable(mesh.positions[face[(k + 1) % face.size()]])) continue;
                const glm::dvec2 p = view.pixel(mesh.positions[face[k]]);
                const glm::dvec2 q = view.pixel(mesh.positions[face[(k + 1) % face.size()]]);
                drawing.line(int(p.x), int(p.y), int(q.x), int(q.y), edge);
            }
        }
    }

    // Boundary loops that are defects: traced in the class colour.
    const Colour loop_colour = class_colour(DefectClass::boundary_loop);
    for (const BoundaryLoop& loop : report.boundary_loops) {
        const Colour c = loop.allowed ? Colour{0.35f, 0.35f, 0.35f} : loop_colour;
        for (std::size_t i = 0; i + 1 < loop.vertices.size() + (loop.closed ? 1 : 0); ++i) {
            if (!view.drawable(mesh.positions[loop.vertices[i]]) ||
                !view.drawable(mesh.positions[loop.vertices[(i + 1) % loop.vertices.size()]]))
                continue;
            const glm::dvec2 p = view.pixel(mesh.positions[loop.vertices[i]]);
            const glm::dvec2 q = view.pixel(mesh.positions[loop.vertices[(i + 1) % loop.vertices.size()]]);
            const int thick = loop.allowed ? 0 : 1;
            for (int dx = -thick; dx <= thick; ++dx)
                for (int dy = -thick; dy <= thick; ++dy)
                    drawing.line(int(p.x) + dx, int(p.y) + dy, int(q.x) + dx, int(q.y) + dy, c);
        }
    }
    // Every located defect: a ring in its class colour.
    for (const DefectReport& d : report.defects) {
        const Colour c = class_colour(d.kind);
        const int radius = 7 + static_cast<int>(d.kind) % 4 * 3;  // nested rings stay visible
        for (const Defect& x : d.locations) {
            if (!view.drawable(x.position)) continue;
            const glm::dvec2 p = view.pixel(x.position);
            for (int r = radius; r <= radius + 1; ++r)
                for (int step = 0; step < 8 * r; ++step) {
                    const double angle = step * (2.0 * 3.141592653589793 / (8 * r));
                    drawing.point(int(p.x + r * std::cos(angle)), int(p.y + r * std::sin(angle)), c);
                }
        }
    }

    const std::string font = std::filesystem::exists("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf")
                                 ? "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf"
                                 : "";
    drawing.line(0, h, w - 1, h, black);
    for (std::size_t i = 0; i < lines.size(); ++i) {
        const int x = pad + 260 * (static_cast<int>(i) % columns);
        const int y = h + pad + row * (static_cast<int>(i) / columns);
        drawing.filled_box(x, y + 3, x + 12, y + 15, swatches[i]);
        // Without a font the swatches still tell the classes apart; the text is a bonus.
        drawing.text(x + 20, y + 14, lines[i], 13, font, black, image::TextAlign::left);
    }
    // The scale bar (its length a round number of world units) and the axes the view shows.
    const double bar = scale_bar_length(view.pixels_per_unit(), w);
    const int bar_y = h + pad + row * (legend_rows - 1) + 9;
    const int bar_end = pad + static_cast<int>(std::lround(bar * view.pixels_per_unit()));
    std::string axes = "view down the " + std::string(axis_name(view.up())) + " axis: " + axis_name(view.right_axis()) +
                       " to the right, " + axis_name(view.top_axis()) + " up";
    if (bar > 0.0) {
        for (int t = -1; t <= 1; ++t) drawing.line(pad, bar_y + t, bar_end, bar_y + t, black);
        drawing.line(pad, bar_y - 5, pad, bar_y + 5, black);
        drawing.line(bar_end, bar_y - 5, bar_end, bar_y + 5, black);
        axes = short_number(bar) + " world units; " + axes;
    }
    drawing.text(bar_end + 10, bar_y + 5, axes, 13, font, black, image::TextAlign::left);
    drawing.paint({pixels.data(), w, total_height, 3, image::SampleType::uint8}, false, path);
    image::write_image(path, {w, total_height, 3, image::SampleType::uint8, pixels.data()});
}

}  // namespace tessref
