// tessref/heightfield.h — height fields and colour textures read from image files, and the
// normals computed from a height field. The textures are sampled as tessref/texture.h says.
//
// Height fields: load_height_field() reads 8/16-bit PGM and PNG, float TIFF, PFM, EXR (PNG
// and the PNM family by tessref itself, every other format OpenImageIO reads through it),
// first channel only: integer files as unorm (0..1, as a GL UNORM texture sees them), float
// files as raw values. A PGM whose maxval is neither 255 nor 65535 is rescaled to the full
// range as OpenImageIO does, min(v, maxval) * 65535 / maxval (or * 255), truncating; 16-bit
// samples are exact (OpenImageIO 2.4.7's own PNM reader is not above 32768). Colour
// channels are read as stored, not premultiplied by alpha.
// Hostile files: what the header declares is checked before any pixel is read or memory
// is allocated for it. The image and its mip pyramid must fit the process memory limit
// (require_memory, tessref/limits.h; "height map of W x H samples needs ..."), so a
// 100-byte file declaring 100000 x 100000 is refused at once. PNM headers are also checked
// strictly: maxval must be 1..65535 and a PFM's scale a non-zero number; a PNG chunk may not
// declare more bytes than the file holds. A file with fewer or damaged pixels than its
// header declares is "truncated or corrupt", also when OpenImageIO reports the read as
// successful with its error set (a TIFF strip past the end of the file).
// NaN and infinite samples, and samples equal to an optional nodata value (compared with the
// file's raw value: the integer code for integer files), are "missing"; NodataPolicy says
// what happens to them (default: an error naming the file and the first missing texel).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/texture.h"

namespace tessref {

// ---- Loading -----------------------------------------------------------------------------

// What a missing sample (NaN, +-inf, or equal to HeightFieldOptions::nodata_value) does.
enum class NodataPolicy : std::uint8_t {
    error,           // throw tessref::Error naming the file and the first missing texel (x, y)
                     // in row-major order (key "texel(x,y)")
    fill_neighbour_mean,  // repeat until none is missing: every missing texel with at least
                     // one present 8-neighbour takes the mean of the present 8-neighbours as
                     // they were at the start of the pass (a Jacobi sweep: order-independent,
                     // deterministic); the mean is taken in double on the raw values and, for
                     // an integer file, rounded to the nearest code. All missing: an error.
    fill_constant,   // every missing texel takes HeightFieldOptions::fill_value
};

struct HeightFieldOptions {
    NodataPolicy nodata_policy = NodataPolicy::error;
    std::optional<double> nodata_value;  // raw file value meaning "no data" (e.g. -32768)
    double fill_value = 0.0;             // fill_constant: raw value (a code for integer files)
    int max_dimension = 16384;           // width or height above this is refused
    MipmapRule mipmap_rule = MipmapRule::llvmpipe_blit;
};

struct HeightFieldInfo {
    std::string source_path;
    std::string pixel_type;   // the file's sample type as OpenImageIO names it: "uint8",
                              // "uint16", "half", "float", ...
    int bits_per_sample = 0;  // oiio:BitsPerSample (a PGM of maxval 1023 says 10)
    int width = 0;
    int height = 0;
    int file_channels = 0;    // channels in the file; only the first is the height
    std::size_t missing_texels = 0;  // how many the nodata policy replaced
    float min_value = 0.0f;   // of level 0 after filling, in texel units
    float max_value = 0.0f;
};

struct HeightField {
    Texture texture;  // one channel: texture(st).r is the height sample
    HeightFieldInfo info;
};

// Loads a height map. Throws tessref::Error (Where::file = path) when the file is missing,
// empty (0 bytes), unreadable, truncated or corrupt, has no pixels (a width or height of 0
// or below in its header), a PNM maxval outside 1..65535 or a PFM scale of 0, is smaller
// than 2x2 (a height field needs two samples along each axis — a 1x1 map has no extent),
// would need more memory than the process limit, is larger than max_dimension along either
// axis, or has missing samples under NodataPolicy::error.
// Samples are not checked against the scene's scale: a finite sample so large that the
// evaluated height overflows is refused after evaluation by run_pipeline (scene.h), which
// names the patch, tess coord and texel, and a double beyond the float range by
// write_mesh (mesh.h).
// uint8 files become unorm8 textures, uint16 files unorm16, every other sample type
// float32 (other integer types, through OpenImageIO, normalized to 0..1).
HeightField load_height_field(const std::string& path, const HeightFieldOptions& options = {});

struct TextureLoadOptions {
    int max_dimension = 16384;
    int max_channels = 4;  // the first min(file channels, max_channels) channels are kept
    MipmapRule mipmap_rule = MipmapRule::llvmpipe_blit;
};

// Loads a colour texture (RGB/RGBA 8-bit PNG or JPEG, 16-bit PNG, float EXR, ...): uint8
// files become unorm8, uint16 unorm16, others float32. A 1x1 texture is allowed. Throws
// tessref::Error naming the file on a missing, empty, unreadable, zero-sized or too large
// image, and with the height map's header checks (memory limit, PNM maxval, PFM scale,
// truncation). NaN samples are kept (a colour texture has no nodata policy).
Texture load_texture(const std::string& path, const TextureLoadOptions& options = {});

// What load_texture(field.info.source_path, options) returns, taken from the height field as
// load_height_field returned it instead of decoding the file again (a terrain shaded by its
// own height map), where the two are certain to be the same: no texel was missing, the file
// has one channel, the same mipmap rule, within options.max_dimension. Otherwise nullopt:
// the file must be read.
std::optional<Texture> texture_of_height_field(const HeightField& field, const TextureLoadOptions& options = {});

// ---- Normals from a height field -------------------------------------------------------

// The thesis's normal map (section 4.7.4): "A for-loop goes through every pixel from the
// height map and calculates the four vectors (one for each neighbour pixel) ... Then 2 by 2
// vectors are crossed. These have to be in 90 degrees of each other. This makes four normals
// for the current pixel, these are summed together and normalized ... The normal is given the
// colour value. Negative goes from 0 to 127, positive goes from 127 to 255."
// For texel (x, y), with P(x, y) = (x * texel_spacing, y * texel_spacing,
// height(x, y) * height_scale) where height is channel 0 of level 0 (its exact value), and
// neighbours clamped to the edge: r = P(x+1,y) - P, u = P(x,y+1) - P, l = P(x-1,y) - P,
// d = P(x,y-1) - P, n = normalize(cross(r,u) + cross(u,l) + cross(l,d) + cross(d,r)), in
// double. x grows with s, y with t (the thesis maps world xy to texture coordinates by
// xy / scaleXY), z is up. Interpretations and quirks, kept:
// - the four cross products are summed unnormalized (the text normalizes only the sum); at
//   an edge the clamped neighbour gives a zero vector, so the products using it vanish;
// - encoding: code = trunc((n * 0.5 + 0.5) * 255), which is the text's split exactly
//   (n < 0 -> 0..127, n >= 0 -> 127..255), so a flat texel (0, 0, 1) encodes (127, 127, 255)
//   and NormalFromTexture (rgb - 0.5, control.h / geometry.h) reads it back tilted by
//   about 0.0039 in x and y: the thesis's own bias, not corrected here.
// The result is an RGB unorm8 Texture (texels are code * (1/255), as the GPU sees an 8-bit
// normal map); thesis_normal_map_codes() gives the same codes, row-major, e.g. for a PNG.
Texture thesis_normal_map(const Texture& height_map, double texel_spacing, double height_scale,
                          MipmapRule rule = MipmapRule::llvmpipe_blit);
std::vector<std::uint8_t> thesis_normal_map_codes(const Texture& height_map,
                                                  double texel_spacing, double height_scale);
// The unorm decode n = rgb * 2 - 1 (not normalized).
glm::vec3 decode_unorm_normal(glm::vec3 rgb);
glm::dvec3 decode_unorm_normal(glm::dvec3 rgb);

}  // namespace tessref
