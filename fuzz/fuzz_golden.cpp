// fuzz/fuzz_golden.cpp — the golden digest files of `tessref golden verify`
// (tessref/golden.h): the same text read as capture.txt and as mesh.txt.
#include "fuzz_common.h"
#include "tessref/golden.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace tessref;
    tessref_fuzz::init_limits();
    const std::string_view text = tessref_fuzz::as_text(data, size);
    tessref_fuzz::expect_only_tessref_errors([&] {
        const golden::CaptureDigest g = golden::parse_capture_digest(text, "capture.txt");
        // The reader's promises: digests of their documented length, patch triangles that
        // add up to the capture's.
        if (g.sha256.size() != 64) std::abort();
        std::size_t triangles = 0;
        for (const golden::PatchDigest& p : g.patches) {
            if (p.sha256.size() != golden::kPatchDigits) std::abort();
            triangles += p.triangles;
        }
        if (triangles != g.triangles) std::abort();
    });
    tessref_fuzz::expect_only_tessref_errors([&] {
        const golden::MeshDigest m = golden::parse_mesh_digest(text, "mesh.txt");
        if (m.sha256.size() != 64) std::abort();
    });
    return 0;
}
