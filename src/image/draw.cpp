// Drawing through the OpenImageIO module: see draw.h.
#include "image/draw.h"

#include "image/oiio_module.h"

namespace tessref::image {

void Drawing::add(int kind, int x0, int y0, int x1, int y1, const Colour& colour) {
    tessref_oiio_draw op{};
    op.kind = kind;
    op.x0 = x0;
    op.y0 = y0;
    op.x1 = x1;
    op.y1 = y1;
    const auto channels = colour.channels();
    for (int c = 0; c < 3; ++c) op.colour[c] = channels[c];
    op.colour[3] = 1.0f;
    ops_.push_back(op);
}

void Drawing::line(int x0, int y0, int x1, int y1, const Colour& colour) { add(TESSREF_OIIO_LINE, x0, y0, x1, y1, colour); }

void Drawing::point(int x, int y, const Colour& colour) { add(TESSREF_OIIO_POINT, x, y, 0, 0, colour); }

void Drawing::filled_box(int x0, int y0, int x1, int y1, const Colour& colour) {
    add(TESSREF_OIIO_FILLED_BOX, x0, y0, x1, y1, colour);
}

void Drawing::text(int x, int y, const std::string& text, int size, const std::string& font, const Colour& colour,
                   TextAlign align) {
    add(TESSREF_OIIO_TEXT, x, y, align == TextAlign::left ? 0 : align == TextAlign::centre ? 1 : 2, 0, colour);
    ops_.back().size = size;
    ops_.back().text = strings_.emplace_back(text).c_str();
    ops_.back().font = strings_.emplace_back(font).c_str();
}

bool Drawing::paint(const Canvas& canvas, bool stop_at_failure, const std::string& path, std::string* reason) {
    if (ops_.empty()) return true;
    const tessref_oiio_api& oiio = oiio_module("drawing lines and text into " + path, path);
    const tessref_oiio_canvas target{canvas.pixels, canvas.width, canvas.height, canvas.channels,
                                     canvas.type == SampleType::uint8 ? TESSREF_OIIO_UINT8 : TESSREF_OIIO_FLOAT};
    char error[1024] = "";
    std::size_t failed = 0;
    const int result = oiio.draw(&target, ops_.data(), ops_.size(), stop_at_failure ? 1 : 0, &failed, error, sizeof error);
    ops_.clear();
    strings_.clear();
    if (result != 0 && reason != nullptr) *reason = error;
    return result == 0;
}

}  // namespace tessref::image
