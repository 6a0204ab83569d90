// fuzz/fuzz_heightmap.cpp — the height-map and texture loaders (src/heightfield/load.cpp):
// PGM 8/16-bit, PFM and PNG through tessref's readers (src/image/), TIFF through the
// OpenImageIO module, with every nodata policy.
//
// Each input is loaded five ways (as a colour texture, and as a height field under each
// NodataPolicy, with and without a nodata value), so every seed exercises every path and
// no selector byte makes the seed files differ from real images. The extension follows
// the file's magic number, as a user's file would be named.
#include <cmath>

#include "fuzz_common.h"
#include "tessref/heightfield.h"

namespace {

const char* extension_for(std::string_view bytes) {
    if (bytes.starts_with("Pf") || bytes.starts_with("PF")) return "pfm";
    if (bytes.size() >= 2 && bytes[0] == 'P' && bytes[1] >= '1' && bytes[1] <= '6') return "pgm";
    if (bytes.starts_with("\x89PNG")) return "png";
    if (bytes.starts_with("II") || bytes.starts_with("MM")) return "tif";
    return "pgm";
}

void check_height_field(const tessref::HeightField& field) {
    // load_height_field's promise: at least 2x2, one channel, and no missing sample left
    // once a policy has filled them.
    if (field.texture.width() < 2 || field.texture.height() < 2) std::abort();
    if (field.texture.channels() != 1) std::abort();
    for (float v : field.texture.level(0).texels)
        if (!std::isfinite(v)) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace tessref;
    tessref_fuzz::init_limits();
    const std::string path = tessref_fuzz::write_input(
        data, size, std::string("input.") + extension_for(tessref_fuzz::as_text(data, size)));

    tessref_fuzz::expect_only_tessref_errors([&] {
        TextureLoadOptions options;
        options.max_dimension = 4096;
        const Texture texture = load_texture(path, options);
        if (texture.width() < 1 || texture.height() < 1) std::abort();
    });

    HeightFieldOptions options;
    options.max_dimension = 4096;
    tessref_fuzz::expect_only_tessref_errors([&] { check_height_field(load_height_field(path, options)); });
    options.nodata_policy = NodataPolicy::fill_neighbour_mean;
    options.nodata_value = 0.0;
    tessref_fuzz::expect_only_tessref_errors([&] { check_height_field(load_height_field(path, options)); });
    options.nodata_policy = NodataPolicy::fill_constant;
    options.fill_value = 1.0;
    tessref_fuzz::expect_only_tessref_errors([&] { check_height_field(load_height_field(path, options)); });
    options.mipmap_rule = MipmapRule::mesa_software_box;
    options.nodata_value.reset();
    tessref_fuzz::expect_only_tessref_errors([&] { check_height_field(load_height_field(path, options)); });
    return 0;
}
