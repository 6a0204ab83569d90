// src/picture/font.h — the faces tessref's diagrams write their text in.
//
// Two, for two kinds of picture: the DejaVu TrueType faces, which OpenImageIO renders
// (src/image/draw.h) into the pattern and defect pictures, and a built-in 3 x 5 bitmap face
// that the sweep report's PNG plots are drawn with, so that they need no font file and their
// bytes do not depend on the machine. SVGs name their font families instead and leave the
// rendering to the viewer.
#pragma once

#include <string>

namespace tessref::picture {

enum class TextFont : unsigned char { sans, sans_bold, mono };

// The DejaVu file of `font` when Debian's fonts-dejavu-core has put it in its place, else its
// name, for OpenImageIO to look up on its font path.
std::string truetype_font(TextFont font);

// The bitmap face: five rows of three cells, top row first, '#' painted. Lower-case letters
// are drawn as capitals; a character without a glyph is drawn as '?'.
const char* bitmap_glyph(char c);
inline constexpr int kBitmapGlyphRows = 5;
inline constexpr int kBitmapGlyphColumns = 3;

}  // namespace tessref::picture
