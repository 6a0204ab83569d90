// fuzz/fuzz_cli.cpp — the number and list parsing of the command line
// (src/cli/cli_util.cpp, parse_byte_size of limits.h, parse_aovs of render.h). Every parser
// sees every input; each result is checked against what its header promises.
#include <cmath>

#include "cli/cli_util.h"
#include "fuzz_common.h"
#include "tessref/render.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace tessref;
    const std::string_view text = tessref_fuzz::as_text(data, size);
    const std::string text_string(text);

    (void)cli::parse_float(text);
    (void)cli::parse_integer(text);
    tessref_fuzz::expect_only_tessref_errors([&] {
        const glm::ivec2 image = cli::parse_image_size(text_string);
        if (image.x < 1 || image.y < 1 || image.x > 16384 || image.y > 16384) std::abort();
    });
    for (const std::size_t count : {1u, 2u, 4u}) {
        tessref_fuzz::expect_only_tessref_errors([&] {
            if (cli::parse_float_list(text, count, "--outer").size() != count) std::abort();
        });
    }
    if (const auto bytes = parse_byte_size(text); bytes && *bytes == 0) std::abort();
    tessref_fuzz::expect_only_tessref_errors([&] { (void)cli::parse_precision_flag(text_string); });
    tessref_fuzz::expect_only_tessref_errors([&] { (void)parse_aovs(text); });
    if (const auto value = cli::parse_float(text)) {
        // format_float is documented to read back as the same float.
        const std::string shown = cli::format_float_short(*value);
        const auto again = cli::parse_float(shown);
        if (!again) std::abort();
        if (!(std::isnan(*value) ? std::isnan(*again) : *again == *value)) std::abort();
    }
    return 0;
}
