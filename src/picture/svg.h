// src/picture/svg.h — what every SVG (and HTML) tessref writes shares: the escape of text,
// the numbers, the document's opening. The element lists are the pictures' own
// (src/cli/pattern_picture.cpp, src/sweep/plot.cpp): each keeps the element and attribute
// order its files have always had, byte for byte.
#pragma once

#include <string>
#include <string_view>

#include "picture/colour.h"

namespace tessref::picture {

// Text for XML or HTML, element content or a quoted attribute value: & < > " ' escaped.
std::string xml_escape(std::string_view text);

// A coordinate with two decimals, trailing zeros and point dropped ("12.5", "12", "0").
std::string number_trimmed(double x);

// A coordinate with two decimals always ("12.50").
std::string number_fixed(double x);

// `<svg ...>`, `<title>`, and a background rectangle: the opening of a standalone SVG 1.1
// document of width x height pixels (a writer ends it with "</svg>\n").
std::string svg_begin(int width, int height, const std::string& title, Colour background);

}  // namespace tessref::picture
