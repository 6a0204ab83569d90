// fuzz/fuzz_sweep_dir.cpp — a shard directory as `tessref sweep merge` reads it
// (src/sweep/sweep.cpp read_shard, merge_sweeps, and the report of the merged table).
//
// The input is sweep.json, a NUL byte, then sweep.csv (no NUL: sweep.csv is empty). The
// directory also holds images/s/truth.png, a 2x2 picture, so that a row naming it finds it.
// The merge writes into a fresh output directory, removed after each input.
#include <filesystem>

#include "fuzz_common.h"
#include "sweep/sweep.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace tessref;
    namespace fs = std::filesystem;
    tessref_fuzz::init_limits();
    const std::string_view text = tessref_fuzz::as_text(data, size);
    const std::size_t nul = text.find('\0');
    const std::string_view json = text.substr(0, nul);
    const std::string_view csv = nul == std::string_view::npos ? std::string_view() : text.substr(nul + 1);

    const fs::path shard = tessref_fuzz::scratch_dir() / "shard";
    const fs::path out = tessref_fuzz::scratch_dir() / "merged";
    std::error_code ec;
    fs::remove_all(out, ec);
    fs::create_directories(shard / "images" / "s");
    static const std::uint8_t png[] = {  // a 2x2 grey PNG
        0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44, 0x52, 0x00, 0x00,
        0x00, 0x02, 0x00, 0x00, 0x00, 0x02, 0x08, 0x00, 0x00, 0x00, 0x00, 0x57, 0xdd, 0x52, 0xf8, 0x00, 0x00, 0x00,
        0x0b, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0x60, 0x00, 0x01, 0x00, 0x00, 0x06, 0x00, 0x01, 0xfe, 0x8c,
        0x67, 0xc8, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};
    tessref_fuzz::write_input(png, sizeof png, "shard/images/s/truth.png");
    tessref_fuzz::write_input(reinterpret_cast<const std::uint8_t*>(json.data()), json.size(), "shard/sweep.json");
    tessref_fuzz::write_input(reinterpret_cast<const std::uint8_t*>(csv.data()), csv.size(), "shard/sweep.csv");
    tessref_fuzz::expect_only_tessref_errors([&] { sweep::merge_sweeps({shard.string()}, out.string()); });
    fs::remove_all(out, ec);
    return 0;
}
