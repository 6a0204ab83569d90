// fuzz/fuzz_ply.cpp — `tessref check`'s reader of .ply files (read_mesh_for_check).
#include "fuzz_mesh_check.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    tessref_fuzz::fuzz_check_reader(data, size, "ply");
    return 0;
}
