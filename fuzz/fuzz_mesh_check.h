// fuzz/fuzz_mesh_check.h — the body of the four `check` mesh-reader harnesses (fuzz_ply,
// fuzz_obj, fuzz_off, fuzz_stl): the reader is picked by extension, so each format is
// its own target with its own seeds and dictionary.
#pragma once

#include "fuzz_common.h"
#include "tessref/check.h"

namespace tessref_fuzz {

inline void fuzz_check_reader(const std::uint8_t* data, std::size_t size, const char* extension) {
    init_limits();
    const std::string path = write_input(data, size, std::string("input.") + extension);
    expect_only_tessref_errors([&] {
        const tessref::IndexedMesh mesh = tessref::read_mesh_for_check(path);
        // The reader's promise (check.h): every face refers to a vertex the file has.
        for (const std::uint32_t v : mesh.face_vertices)
            if (v >= mesh.vertex_count()) std::abort();
        if (mesh.face_start.back() != mesh.face_vertices.size()) std::abort();
    });
}

}  // namespace tessref_fuzz
