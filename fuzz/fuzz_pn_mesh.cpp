// fuzz/fuzz_pn_mesh.cpp — the mesh reader of PN-triangle scenes ([[mesh]] in
// src/scene/scene.cpp): a fixed small PN scene whose [[mesh]] path is the fuzzed file.
// The extension follows the file's content (the reader is picked by extension), so the
// seeds are ordinary mesh files.
#include <cstring>

#include "fuzz_common.h"
#include "tessref/prepare.h"
#include "tessref/scene.h"

namespace {

const char* extension_for(std::string_view bytes) {
    if (bytes.starts_with("ply")) return "ply";
    if (bytes.find("OFF") < 8) return "off";  // OFF, COFF, NOFF, STOFF, 4OFF, ...
    if (bytes.starts_with("solid")) return "stl";
    // Binary STL: an 80-byte header, a count, 50 bytes per facet.
    if (bytes.size() >= 84) {
        std::uint32_t facets = 0;
        std::memcpy(&facets, bytes.data() + 80, 4);
        if (84 + 50ull * facets == bytes.size()) return "stl";
    }
    return "obj";
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace tessref;
    tessref_fuzz::init_limits();
    const std::string mesh_name = std::string("mesh.") + extension_for(tessref_fuzz::as_text(data, size));
    tessref_fuzz::write_input(data, size, mesh_name);
    const std::string scene_text =
        "[scene]\nname = \"fuzz\"\n"
        "[[mesh]]\npath = \"" + mesh_name + "\"\nscale = 0.5\n"
        "[camera]\neye = [0.0, 1.2, 3.0]\ncenter = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0]\n"
        "fov_y = 45.0\nviewport = [64, 48]\nnear = 0.1\nfar = 100.0\n"
        "[control]\nmodel = \"pn\"\n"
        "[evaluation]\nmodel = \"pn\"\n";
    tessref_fuzz::expect_only_tessref_errors([&] {
        const Scene scene =
            load_scene_from_string(scene_text, (tessref_fuzz::scratch_dir() / "scene.toml").string());
        // The loader's promise to the pipeline: a normal per vertex, triangles over
        // vertices that exist.
        const TriangleMeshes& meshes = *scene.meshes;
        if (meshes.normals.size() != meshes.positions.size()) std::abort();
        if (!meshes.uvs.empty() && meshes.uvs.size() != meshes.positions.size()) std::abort();
        for (const auto& triangle : meshes.triangles)
            for (const std::uint32_t v : triangle)
                if (v >= meshes.positions.size()) std::abort();
        (void)shared_edges(scene);  // the adjacency the crack checks walk
    });
    return 0;
}
