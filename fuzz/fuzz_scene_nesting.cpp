// fuzz/fuzz_scene_nesting.cpp — the scene loader (src/scene/) on deeply nested TOML, which a
// recursive parser (toml++) turns into a stack overflow unless the nesting is checked
// before parsing.
//
// The first input byte picks a form and the next two a depth 0..65535; the rest of the
// input follows the nested text (at the top level, or inside the innermost table):
//   0 [a.a.a...]          a table header         4 a = [{a = [{...}]}]  arrays of tables, inline
//   1 a.a.a... = 1        a dotted key           5 [[a.a.a...]]         an array of tables
//   2 a = {a = {...}}     inline tables          6 a.a = {a.a = [...]}  dotted keys, tables, arrays
//   3 a = [[[...]]]       arrays                 7 the same nesting, each level a key of its own line
#include <algorithm>
#include <string>

#include "fuzz_common.h"
#include "tessref/prepare.h"
#include "tessref/scene.h"

#ifndef TESSREF_FUZZ_SCENE_ENV
#error "TESSREF_FUZZ_SCENE_ENV must name fuzz/scene_env"
#endif

namespace {

std::string repeat(const std::string& piece, std::size_t n) {
    std::string out;
    out.reserve(piece.size() * n);
    for (std::size_t i = 0; i < n; ++i) out += piece;
    return out;
}

std::string nested(unsigned form, std::size_t depth, const std::string& rest) {
    const std::size_t d = depth == 0 ? 1 : depth;
    switch (form % 8) {
        case 0: return "[" + repeat("a.", d - 1) + "a]\n" + rest;
        case 1: return repeat("a.", d - 1) + "a = 1\n" + rest;
        case 2: return "a = " + repeat("{a = ", d) + "1" + repeat("}", d) + "\n" + rest;
        case 3: return "a = " + repeat("[", d) + "1" + repeat("]", d) + "\n" + rest;
        case 4: return "a = " + repeat("[{a = ", d) + "1" + repeat("}]", d) + "\n" + rest;
        case 5: return "[[" + repeat("a.", d - 1) + "a]]\n" + rest;
        case 6: return "a.a = " + repeat("{a.a = [", d) + "1" + repeat("]}", d) + "\n" + rest;
        default: {
            // Each header repeats the keys above it: quadratic text, so at most 2000 levels.
            const std::size_t d = std::min<std::size_t>(depth == 0 ? 1 : depth, 2000);
            std::string out;
            std::string key;
            for (std::size_t i = 0; i < d; ++i) {
                key += (i ? "." : "") + std::string("k") + std::to_string(i % 10);
                out += "[" + key + "]\nv = 1\n";
            }
            return out + rest;
        }
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace tessref;
    tessref_fuzz::init_limits();
    if (size < 3) return 0;
    const unsigned form = data[0];
    const std::size_t depth = static_cast<std::size_t>(data[1]) << 8 | data[2];
    const std::string text = nested(form, depth, std::string(tessref_fuzz::as_text(data + 3, size - 3)));
    tessref_fuzz::expect_only_tessref_errors([&] {
        const Scene scene = load_scene_from_string(text, TESSREF_FUZZ_SCENE_ENV "/scenes/fuzz.toml");
        (void)scene.patch_count();
    });
    return 0;
}
