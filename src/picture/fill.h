// src/picture/fill.h — the polygon filler of tessref's diagrams: the pattern picture
// (`tessref tessellate --format png`), the sweep plots and the defect picture (`tessref check
// --image`), through picture::Canvas or directly.
// Not the GL rasterizer of src/raster/: that one follows GL's fixed-point, top-left rule;
// a diagram wants a shape's every pixel painted, edges included, in plain double.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <span>

#include <glm/vec2.hpp>

namespace tessref {

// Pixels x0..x1, y0..y1 (inclusive) of a width x height image: those whose centres a
// shape's bounding box can hold.
struct PixelBox {
    int x0 = 0, x1 = -1, y0 = 0, y1 = -1;
    bool empty() const { return x0 > x1 || y0 > y1; }
};

// The box of `points` (pixel coordinates, x right, y down), clipped to the image; empty
// when the shape is off the image. Coordinates must be finite and within the int range.
inline PixelBox pixel_box(std::span<const glm::dvec2> points, int width, int height) {
    if (points.empty()) return {};
    double min_x = points[0].x, max_x = min_x, min_y = points[0].y, max_y = min_y;
    for (const glm::dvec2& p : points) {
        min_x = std::min(min_x, p.x);
        max_x = std::max(max_x, p.x);
        min_y = std::min(min_y, p.y);
        max_y = std::max(max_y, p.y);
    }
    return {std::max(0, static_cast<int>(std::floor(min_x))), std::min(width - 1, static_cast<int>(std::ceil(max_x))),
            std::max(0, static_cast<int>(std::floor(min_y))), std::min(height - 1, static_cast<int>(std::ceil(max_y)))};
}

// Calls plot(x, y) for every pixel of a width x height image whose centre (x + 0.5, y + 0.5)
// is inside the convex polygon `points` (either orientation) or on its boundary, where "on"
// means an edge function (twice the signed area of the edge and the centre, pixels squared)
// of at least -edge_margin. A margin lets a centre on an edge that two polygons share be
// painted by both whatever rounding does to either; 0 is the exact test. A polygon with
// fewer than three points or no area paints nothing.
template <class Plot>
void fill_convex_polygon(std::span<const glm::dvec2> points, int width, int height, double edge_margin, Plot&& plot) {
    if (points.size() < 3) return;
    double area = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        const glm::dvec2& a = points[i];
        const glm::dvec2& b = points[(i + 1) % points.size()];
        area += a.x * b.y - b.x * a.y;
    }
    if (area == 0) return;
    const double sign = area > 0 ? 1.0 : -1.0;
    const PixelBox box = pixel_box(points, width, height);
    for (int y = box.y0; y <= box.y1; ++y) {
        for (int x = box.x0; x <= box.x1; ++x) {
            const glm::dvec2 c{x + 0.5, y + 0.5};
            bool inside = true;
            for (std::size_t i = 0; i < points.size() && inside; ++i) {
                const glm::dvec2& a = points[i];
                const glm::dvec2& b = points[(i + 1) % points.size()];
                const double edge = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
                inside = edge * sign >= -edge_margin;
            }
            if (inside) plot(x, y);
        }
    }
}

}  // namespace tessref
