// src/picture/colour.cpp — see colour.h.
#include "picture/colour.h"

#include <cstdio>

#include "image/image_io.h"

namespace tessref::picture {

std::array<std::uint8_t, 3> Colour::codes() const {
    return {image::float_to_code8(r), image::float_to_code8(g), image::float_to_code8(b)};
}

std::string hex(Colour colour) {
    const auto c = colour.codes();
    char buffer[8];
    std::snprintf(buffer, sizeof buffer, "#%02x%02x%02x", c[0], c[1], c[2]);
    return buffer;
}

}  // namespace tessref::picture
