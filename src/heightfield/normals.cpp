// Normals from a height field: the thesis's normal map and lab 4's appendix A normal
// (see tessref/heightfield.h for the text they follow and the quirks kept).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "common/parallel.h"
#include "tessref/error.h"
#include "tessref/heightfield.h"

namespace tessref {

std::vector<std::uint8_t> thesis_normal_map_codes(const Texture& height_map, double texel_spacing,
                                                  double height_scale) {
    if (height_map.empty()) throw Error("thesis_normal_map: the height map is empty");
    if (!(texel_spacing > 0.0) || !std::isfinite(texel_spacing) || !std::isfinite(height_scale))
        throw Error("thesis_normal_map: texel spacing must be positive and finite and the height "
                    "scale finite");
    const int width = height_map.width();
    const int height = height_map.height();
    std::vector<std::uint8_t> codes(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3);
    // Blocks of rows in parallel, each texel on its own. A block first reads the scaled
    // heights of its rows and the row on either side once: every texel is read by itself and
    // its four neighbours.
    tessref::parallel_for(tbb::blocked_range<int>(0, height, 16), [&](const tbb::blocked_range<int>& rows) {
        const int first = std::max(rows.begin() - 1, 0), last = std::min(rows.end(), height - 1);
        std::vector<double> z(static_cast<std::size_t>(last - first + 1) * static_cast<std::size_t>(width));
        for (int y = first; y <= last; ++y) {
            const std::span<double> row(z.data() + static_cast<std::size_t>(y - first) * static_cast<std::size_t>(width),
                                        static_cast<std::size_t>(width));
            height_map.row_exact(y, 0, row);
            for (double& v : row) v *= height_scale;
        }
        // The position vector of pixel (x, y), neighbours clamped to the edge.
        auto P = [&](int x, int y) {
            x = std::clamp(x, 0, width - 1);
            y = std::clamp(y, 0, height - 1);
            return glm::dvec3(x * texel_spacing, y * texel_spacing,
                              z[static_cast<std::size_t>(y - first) * static_cast<std::size_t>(width) +
                                static_cast<std::size_t>(x)]);
        };
        for (int y = rows.begin(); y < rows.end(); ++y) {
            for (int x = 0; x < width; ++x) {
                const glm::dvec3 p = P(x, y);
                // "the four vectors (one for each neighbour pixel)"
                const glm::dvec3 right = P(x + 1, y) - p;
                const glm::dvec3 up = P(x, y + 1) - p;
                const glm::dvec3 left = P(x - 1, y) - p;
                const glm::dvec3 down = P(x, y - 1) - p;
                // "2 by 2 vectors are crossed ... 90 degrees of each other ... four normals for
                // the current pixel, these are summed together and normalized"
                const glm::dvec3 sum = glm::cross(right, up) + glm::cross(up, left) +
                                       glm::cross(left, down) + glm::cross(down, right);
                const double length = glm::length(sum);
                // Only a degenerate height map (a single texel) leaves every product zero.
                const glm::dvec3 normal = length > 0.0 ? sum / length : glm::dvec3(0.0, 0.0, 1.0);
                // "Negative goes from 0 to 127, positive goes from 127 to 255."
                const std::size_t base = (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                                          static_cast<std::size_t>(x)) * 3;
                for (int c = 0; c < 3; ++c) {
                    const double encoded = std::clamp((normal[c] * 0.5 + 0.5) * 255.0, 0.0, 255.0);
                    codes[base + static_cast<std::size_t>(c)] = static_cast<std::uint8_t>(encoded);
                }
            }
        }
    });
    return codes;
}

Texture thesis_normal_map(const Texture& height_map, double texel_spacing, double height_scale,
                          MipmapRule rule) {
    return Texture::from_unorm8(height_map.width(), height_map.height(), 3,
                                thesis_normal_map_codes(height_map, texel_spacing, height_scale),
                                rule);
}

glm::vec3 decode_unorm_normal(glm::vec3 rgb) { return rgb * 2.0f - 1.0f; }
glm::dvec3 decode_unorm_normal(glm::dvec3 rgb) { return rgb * 2.0 - 1.0; }

}  // namespace tessref
