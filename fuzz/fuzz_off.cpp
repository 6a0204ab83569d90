// fuzz/fuzz_off.cpp — `tessref check`'s reader of .off files (read_mesh_for_check).
#include "fuzz_mesh_check.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    tessref_fuzz::fuzz_check_reader(data, size, "off");
    return 0;
}
