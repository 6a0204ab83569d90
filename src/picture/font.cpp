// src/picture/font.cpp — see font.h.
#include "picture/font.h"

#include <cctype>
#include <filesystem>
#include <system_error>

namespace tessref::picture {

std::string truetype_font(TextFont font) {
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

namespace {

struct Glyph {
    char c;
    const char* rows;  // 15 cells
};
constexpr Glyph kBitmapFont[] = {
    {' ', "..............."}, {'0', "####.##.##.####"}, {'1', ".#.##..#..#.###"}, {'2', "###..#####..###"},
    {'3', "###..#.##..####"}, {'4', "#.##.####..#..#"}, {'5', "####..###..####"}, {'6', "####..####.####"},
    {'7', "###..#..#.#..#."}, {'8', "####.#####.####"}, {'9', "####.####..####"}, {'A', ".#.#.#####.##.#"},
    {'B', "##.#.###.#.###."}, {'C', ".###..#..#...##"}, {'D', "##.#.##.##.###."}, {'E', "####..##.#..###"},
    {'F', "####..##.#..#.."}, {'G', ".###..#.##.#.##"}, {'H', "#.##.#####.##.#"}, {'I', "###.#..#..#.###"},
    {'J', "..#..#..##.#.#."}, {'K', "#.##.###.#.##.#"}, {'L', "#..#..#..#..###"}, {'M', "#.########.##.#"},
    {'N', "##.#.##.##.##.#"}, {'O', ".#.#.##.##.#.#."}, {'P', "##.#.###.#..#.."}, {'Q', ".#.#.##.###..##"},
    {'R', "##.#.###.#.##.#"}, {'S', ".###...#...###."}, {'T', "###.#..#..#..#."}, {'U', "#.##.##.##.####"},
    {'V', "#.##.##.##.#.#."}, {'W', "#.##.########.#"}, {'X', "#.##.#.#.#.##.#"}, {'Y', "#.##.#.#..#..#."},
    {'Z', "###..#.#.#..###"}, {'.', ".............#."}, {',', "..........#.#.."}, {'-', "......###......"},
    {'+', "....#.###.#...."}, {'_', "............###"}, {'/', "..#..#.#.#..#.."}, {'(', ".#.#..#..#...#."},
    {')', ".#...#..#..#.#."}, {':', "....#.....#...."}, {'=', "...###...###..."}, {'%', "#.#..#.#.#..#.#"},
    {'[', "##.#..#..#..##."}, {']', ".##..#..#..#.##"}, {'\'', ".#..#.........."}, {'?', "###..#.#.....#."},
};

}  // namespace

const char* bitmap_glyph(char c) {
    const char upper = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    for (const Glyph& g : kBitmapFont)
        if (g.c == upper) return g.rows;
    return bitmap_glyph('?');
}

}  // namespace tessref::picture
