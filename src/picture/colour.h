// src/picture/colour.h — the one colour of tessref's diagrams (pattern pictures, sweep plots,
// defect pictures): red, green and blue as floats in [0, 1], the renderer's own channels.
//
// Palettes are written as 8-bit codes (`Colour::from_codes(34, 34, 34)`), which is what an SVG
// prints and an 8-bit picture stores: code / 255 as float, and codes() turns it back into the
// very same codes (OpenImageIO's conversion, image::float_to_code8). A float picture stores
// the floats; OpenImageIO's drawing takes them as they are.
#pragma once

#include <array>
#include <cstdint>
#include <string>

namespace tessref::picture {

struct Colour {
    float r = 0.0f, g = 0.0f, b = 0.0f;

    static constexpr Colour from_codes(int red, int green, int blue) {
        return {static_cast<float>(red) / 255.0f, static_cast<float>(green) / 255.0f,
                static_cast<float>(blue) / 255.0f};
    }
    // The 8-bit codes, as OpenImageIO converts a float channel: clamp(v * 255 + 0.5) truncated.
    std::array<std::uint8_t, 3> codes() const;
    std::array<float, 3> channels() const { return {r, g, b}; }
};

// "#rrggbb" of the codes, as SVG and HTML write a colour.
std::string hex(Colour colour);

}  // namespace tessref::picture
