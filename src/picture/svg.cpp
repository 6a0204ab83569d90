// src/picture/svg.cpp — see svg.h.
#include "picture/svg.h"

#include <cstdio>

namespace tessref::picture {

std::string xml_escape(std::string_view text) {
    std::string out;
    out.reserve(text.size());
    for (const char c : text) {
        switch (c) {
            case '&': out += "&amp;"; break;
            case '<': out += "&lt;"; break;
            case '>': out += "&gt;"; break;
            case '"': out += "&quot;"; break;
            case '\'': out += "&#39;"; break;
            default: out += c;
        }
    }
    return out;
}

std::string number_trimmed(double x) {
    std::string s = number_fixed(x);
    while (!s.empty() && s.back() == '0') s.pop_back();
    if (!s.empty() && s.back() == '.') s.pop_back();
    if (s == "-0") s = "0";
    return s;
}

std::string number_fixed(double x) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.2f", x);
    return buffer;
}

std::string svg_begin(int width, int height, const std::string& title, Colour background) {
    const std::string w = std::to_string(width), h = std::to_string(height);
    return "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"" + w + "\" height=\"" + h +
           "\" viewBox=\"0 0 " + w + " " + h + "\">\n<title>" + xml_escape(title) +
           "</title>\n<rect width=\"100%\" height=\"100%\" fill=\"" + hex(background) + "\"/>\n";
}

}  // namespace tessref::picture
