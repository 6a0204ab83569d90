// tests/test_picture.cpp — the diagrams' kit (src/picture/): the colour, the SVG basics, the
// canvas's fills and text.
//
// Expected values are derived by hand: 8-bit codes survive the float colour (c / 255 turned
// back by OpenImageIO's conversion), XML's five special characters, the dash pattern of a
// line of known length, the pixel-centre rule on shapes laid on the pixel grid.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "picture/canvas.h"
#include "picture/colour.h"
#include "picture/font.h"
#include "picture/svg.h"

using namespace tessref;
using picture::Colour;

TEST(PictureColour, EveryCodeSurvivesTheFloatColour) {
    for (int code = 0; code <= 255; ++code) {
        const Colour c = Colour::from_codes(code, 255 - code, code / 2);
        const auto codes = c.codes();
        EXPECT_EQ(codes[0], code);
        EXPECT_EQ(codes[1], 255 - code);
        EXPECT_EQ(codes[2], code / 2);
    }
    EXPECT_EQ(picture::hex(Colour::from_codes(34, 119, 255)), "#2277ff");
    // Out of range and NaN clamp as OpenImageIO does.
    EXPECT_EQ(picture::hex(Colour{-1.0f, 2.0f, std::nanf("")}), "#00ff00");
}

TEST(PictureSvg, EscapesTheFiveSpecialCharacters) {
    EXPECT_EQ(picture::xml_escape(R"(a<b & "c" > 'd')"), "a&lt;b &amp; &quot;c&quot; &gt; &#39;d&#39;");
    EXPECT_EQ(picture::xml_escape("plain"), "plain");
}

TEST(PictureSvg, Numbers) {
    EXPECT_EQ(picture::number_fixed(12.5), "12.50");
    EXPECT_EQ(picture::number_trimmed(12.5), "12.5");
    EXPECT_EQ(picture::number_trimmed(12.0), "12");
    EXPECT_EQ(picture::number_trimmed(-0.001), "0");  // "-0.00" is not a coordinate
    EXPECT_EQ(picture::number_trimmed(0.125), "0.12");  // printf's round-half-even of 0.125
}

TEST(PictureSvg, DocumentOpening) {
    EXPECT_EQ(picture::svg_begin(4, 3, "a & b", Colour::from_codes(255, 255, 255)),
              "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"4\" height=\"3\" viewBox=\"0 0 4 "
              "3\">\n<title>a &amp; b</title>\n<rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>\n");
}

TEST(PictureCanvas, DashesOfALineOfKnownLength) {
    // 20 pixels, 5 on and 3 off: [0, 5], [8, 13], [16, 20].
    std::vector<std::pair<double, double>> dashes;
    picture::for_each_dash({0.0, 0.0}, {20.0, 0.0}, 5.0, 3.0,
                           [&](glm::dvec2 a, glm::dvec2 b) { dashes.emplace_back(a.x, b.x); });
    const std::vector<std::pair<double, double>> expected{{0.0, 5.0}, {8.0, 13.0}, {16.0, 20.0}};
    EXPECT_EQ(dashes, expected);
}

TEST(PictureCanvas, EightBitRgbaFillsByPixelCentres) {
    const Colour white = Colour::from_codes(255, 255, 255), red = Colour::from_codes(200, 10, 20);
    picture::Canvas canvas(4, 4, 4, image::SampleType::uint8, white, "test.png");
    // The square [1, 3] x [1, 3] holds the centres of pixels (1..2, 1..2) only.
    const glm::dvec2 square[4] = {{1, 1}, {3, 1}, {3, 3}, {1, 3}};
    canvas.fill_polygon(square, red, 0.0);
    const auto* p = static_cast<const std::uint8_t*>(canvas.view().samples);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) {
            const bool inside = x >= 1 && x <= 2 && y >= 1 && y <= 2;
            const std::uint8_t* q = p + (y * 4 + x) * 4;
            EXPECT_EQ(q[0], inside ? 200 : 255) << x << "," << y;
            EXPECT_EQ(q[1], inside ? 10 : 255) << x << "," << y;
            EXPECT_EQ(q[3], 255) << "opaque";
        }
}

TEST(PictureCanvas, FloatRgbStoresTheColour) {
    const Colour grey = Colour::from_codes(34, 34, 34);
    picture::Canvas canvas(3, 3, 3, image::SampleType::float32, grey, "test.png");
    // A disc of radius 0.5 at the centre pixel's centre holds that one centre.
    canvas.fill_disc({1.5, 1.5}, 0.5, Colour{1.0f, 0.5f, 0.25f});
    const auto* f = static_cast<const float*>(canvas.view().samples);
    EXPECT_EQ(f[(1 * 3 + 1) * 3 + 1], 0.5f);
    EXPECT_EQ(f[0], 34.0f / 255.0f);
    EXPECT_EQ(f[(1 * 3 + 2) * 3 + 0], 34.0f / 255.0f) << "the pixel beside it is 1 away";
}

TEST(PictureCanvas, BitmapTextPaintsTheGlyphsCells) {
    // '1' is ".#." "##." ".#." ".#." "###": 8 cells, each 2 x 2 pixels at scale 2.
    const Colour white = Colour::from_codes(255, 255, 255), ink = Colour::from_codes(0, 0, 0);
    picture::Canvas canvas(8, 12, 4, image::SampleType::uint8, white, "test.png");
    canvas.bitmap_text(0, 10, "1", picture::Anchor::start, ink, 2);
    const auto* p = static_cast<const std::uint8_t*>(canvas.view().samples);
    int painted = 0;
    for (int i = 0; i < 8 * 12; ++i) painted += p[i * 4] == 0;
    EXPECT_EQ(painted, 8 * 4);
    // Top row of the glyph (y 0..1): only the middle cell (x 2..3).
    EXPECT_EQ(p[(0 * 8 + 2) * 4], 0);
    EXPECT_EQ(p[(0 * 8 + 0) * 4], 255);
    EXPECT_STREQ(picture::bitmap_glyph('a'), picture::bitmap_glyph('A')) << "lower case as capitals";
    EXPECT_STREQ(picture::bitmap_glyph('~'), picture::bitmap_glyph('?')) << "no glyph: '?'";
}
