// src/image/draw.h — lines, points, boxes and text painted into a caller's picture by
// OpenImageIO's ImageBufAlgo (render_line, render_point, render_box, render_text), in the
// module tessref_oiio.so (src/image/oiio_module.h): the pictures of `tessref check
// --image` and, through the diagrams' canvas (src/picture/canvas.h), `tessref tessellate -o
// x.png`. The pixels stay the caller's; operations are queued and painted, in order, by
// paint(). Colours are the diagrams' one colour type (src/picture/colour.h).
#pragma once

#include <deque>
#include <string>
#include <vector>

#include "image/image_io.h"
#include "image/oiio_module_abi.h"
#include "picture/colour.h"

namespace tessref::image {

// A picture in memory that the operations paint into: height rows of width * channels
// samples, uint8 or float32, top row first.
struct Canvas {
    void* pixels = nullptr;
    int width = 0;
    int height = 0;
    int channels = 0;
    SampleType type = SampleType::float32;
};

enum class TextAlign { left, centre, right };

class Drawing {
public:
    using Colour = picture::Colour;

    void line(int x0, int y0, int x1, int y1, const Colour& colour);
    void point(int x, int y, const Colour& colour);
    void filled_box(int x0, int y0, int x1, int y1, const Colour& colour);
    // Baseline at (x, y); `font`: a font file, or a name OpenImageIO looks up.
    void text(int x, int y, const std::string& text, int size, const std::string& font, const Colour& colour,
              TextAlign align);

    bool empty() const { return ops_.empty(); }

    // Paints the queued operations into `canvas` and forgets them; true when every one
    // succeeded. One that fails (text without a font) is skipped, and with stop_at_failure
    // everything after it; the first failure's reason goes to *reason (may be empty).
    // `path` is the picture's file, for the error when the module cannot be loaded.
    bool paint(const Canvas& canvas, bool stop_at_failure, const std::string& path, std::string* reason = nullptr);

private:
    void add(int kind, int x0, int y0, int x1, int y1, const Colour& colour);

    std::vector<tessref_oiio_draw> ops_;
    std::deque<std::string> strings_;  // the texts and fonts the operations point to
};

}  // namespace tessref::image
