// fuzz/fuzz_golden.cpp — the golden digest files of `tessref golden verify`
// (src/cli/golden_files.h): the same text read as capture.txt and as mesh.txt.
#include "fuzz_common.h"
#include "cli/golden_files.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace tessref;
    tessref_fuzz::init_limits();
    const std::string_view text = tessref_fuzz::as_text(data, size);
    tessref_fuzz::expect_only_tessref_errors([&] {
        const cli::GoldenCapture g = cli::parse_golden_capture(text, "capture.txt");
        // The reader's promises: one digest per listed patch (ids may repeat, never exceed),
        // digests of their documented length.
        if (g.patch_sha256.size() > g.patches || g.capture_sha256.size() != 64) std::abort();
        for (const auto& [id, sha] : g.patch_sha256)
            if (sha.size() != cli::kGoldenPatchDigits) std::abort();
    });
    tessref_fuzz::expect_only_tessref_errors([&] {
        const cli::GoldenMesh m = cli::parse_golden_mesh(text, "mesh.txt");
        if (m.sha256.size() != 64) std::abort();
    });
    return 0;
}
