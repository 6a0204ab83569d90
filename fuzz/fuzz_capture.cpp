// fuzz/fuzz_capture.cpp — the capture reader (tessref/capture.h, src/capture/): the text
// form and the PLY form, chosen by the input's first byte (even: .txt, odd: .ply; the byte
// itself is dropped), then the comparison of the capture with itself, as `tessref compare`
// would run it on two copies of one file.
#include "fuzz_common.h"
#include "tessref/capture.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace tessref;
    tessref_fuzz::init_limits();
    if (size == 0) return 0;
    const bool ply = (data[0] & 1) != 0;
    const std::string path = tessref_fuzz::write_input(data + 1, size - 1, ply ? "capture.ply" : "capture.txt");
    tessref_fuzz::expect_only_tessref_errors([&] {
        const Capture capture = read_capture(path);
        // A capture the reader accepts is whole triangles of one patch each (its header's
        // promise), so comparing it with itself must pass.
        const CaptureCompareResult result = compare_captures(capture, capture, {});
        if (!result.passed) std::abort();
    });
    return 0;
}
