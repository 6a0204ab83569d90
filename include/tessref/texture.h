// tessref/texture.h — textures sampled as a GL 4.5 shader samples them.
//
// Every stage that reads an image (the thesis's heightMap, tessellationMap and normalMap,
// COSC422's height map, lab 4's mip-mapped height map, colour textures for shading) reads a
// tessref::Texture through texture() / textureLod(), the CPU twins of the GLSL calls with the
// sampler state the seeds use: clamp-to-edge on s and t, GL_LINEAR magnification, and
// GL_LINEAR_MIPMAP_LINEAR (default) or GL_LINEAR minification.
//
// Conventions
// - Texel addressing: texel (x, y) covers s in [x, x+1)/width, t in [y, y+1)/height; its centre
//   is at ((x + 0.5)/width, (y + 0.5)/height). Row y = 0 is the image's top row as
//   OpenImageIO reads it (its scanline 0; tessref's own PNG and PNM readers agree), which
//   is the first row stored in the file for PGM,
//   PNG, TIFF, EXR and JPEG: uploaded with glTexImage2D in that order (what the seeds'
//   loaders do), the first stored row is t = 0. PFM is the exception: it stores rows bottom
//   to top and OpenImageIO flips them, so there the LAST stored row is t = 0.
// - Texels are float, channel-interleaved, row-major: texels[(y * width + x) * channels + c].
//   A sample returns (r, g, b, a) with the channels the texture lacks as GL fills them:
//   g = b = 0 and a = 1.
// - Storage formats model GL internal formats: unorm8 (GL_R8 .. GL_RGBA8), unorm16 (GL_R16 ..
//   GL_RGBA16), float32 (GL_R32F .. GL_RGBA32F). An integer-format file becomes a unorm
//   texture, as a GL UNORM texture sees it: code c reads as c * (1.0f / (2^bits - 1)) (the
//   float product, as llvmpipe converts; the exact quotient in the double path). Mip levels
//   of a unorm texture are stored quantized to that format, as the GPU stores them.
// - Mip pyramid: levels 0 .. floor(log2(max(width, height))), level k+1 is
//   max(1, w_k / 2) x max(1, h_k / 2) (integer halving, as GL), down to 1x1.
//
// Two precisions, chosen per call by the argument type:
// - float (glm::vec2 / float lod): GPU-faithful. It reproduces what Mesa 22.3 llvmpipe (the
//   project's OSMesa peer) computes, operation for operation:
//     float32 and unorm16 textures — u = s * width - 0.5f (multiply, then subtract, two
//     roundings), i0 = floor(u), weight a = u - floor(u), clamp i0, i0+1 to the edge; the
//     lerp is fma(a, t1 - t0, t0); the 2D filter lerps along s in both rows, then along t;
//     between mip levels lerp(level0, level1, lod - floor(lod)), again as an fma.
//     unorm8 textures — llvmpipe's 8-bit fixed-point path: x = round_even(s * float(width *
//     256)) - 128, i0 = x >> 8, weight = x & 255 (8 fractional bits), and every lerp on
//     8-bit codes as v0 + ((w * (v1 - v0) + 128) >> 8); the mip weight is
//     trunc(frac(lod) * 256); the result is code * (1.0f / 255).
//   Measured bit-exact (tests/test_heightfield.cpp, GlPeer suite) against Mesa 22.3.6
//   llvmpipe (LLVM 15.0.6, 256-bit, on a CPU with FMA) for R32F, RGBA32F, R16, R8, RG8, RGB8
//   and RGBA8 textures of odd and even sizes and for the two real maps: every
//   glGenerateMipmap level, and texture()/textureLod() in a vertex shader at 6000 random
//   coordinates (in and outside [0, 1]) and lods (negative, integer, fractional, above the
//   last level) per texture, all four channels. llvmpipe on a CPU without FMA would round
//   the lerp's product separately; that case is not reproduced (the test skips). Hardware GPUs were NOT measured: NVIDIA documents (CUDA
//   programming guide, texture fetching) bilinear weights held in 9-bit fixed point with 8
//   fractional bits for every format, so on such hardware float textures differ from this
//   path by up to about 1/512 of the difference between neighbouring texels.
// - double (glm::dvec2 / double lod): accuracy. The GL specification's formulas evaluated in
//   double — mix(t0, t1, a) as t0 + a * (t1 - t0), unquantized weights — on texels held
//   in double: level 0 is the exact texel value (code / (2^bits - 1) for unorm), and every
//   other level is computed in double from level 0 with the same footprint as the chosen
//   mipmap rule, at the ideal sample points, without storage quantization.
//
// glGenerateMipmap (MipmapRule):
// - llvmpipe_blit (default): what Mesa 22.3 on llvmpipe really does. Its state tracker does
//   not average 2x2 boxes: it blits each level into the next with a bilinear filter, drawing
//   the destination as a rectangle of two triangles and sampling the source at the texture
//   coordinate interpolated at each destination texel centre. When a source dimension is
//   even this is exactly the 2x2 box average (lerp of lerps at weight 0.5). When it is odd
//   the destination texel i samples the source at u = (i + 0.5) * src / dst - 0.5, a
//   weighted mix of two texels (never a 3-texel box; a 5-wide level gives texels 0/1 mixed
//   0.25/0.75 and 3/4 mixed 0.75/0.25). The float path reproduces the coordinate as
//   llvmpipe's triangle setup and interpolation round it (both triangles, the fan order,
//   their plane equations, fma per pixel) and stores the filtered value in the texture's
//   format (unorm16: round-half-even of clamp(v, 0, 1) * 65535). Measured bit-exact against
//   llvmpipe, odd sizes included (37x23, 13x7, 19x13, 21x17, 5x300, 111x111, 403x344).
// - mesa_software_box: Mesa's software fallback (src/mesa/main/mipmap.c, do_row), used only by
//   drivers without a blit path: destination texel i averages source columns 2i and 2i+1
//   (rows likewise), so an odd trailing column or row is dropped; float levels are
//   (a + b + c + d) * 0.25f summed left to right, integer levels (a + b + c + d) / 4
//   truncated; a dimension already 1 reuses its single column or row. This follows the
//   source, not a measurement: llvmpipe never takes this path.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <vector>

#include <glm/glm.hpp>

namespace tessref {

enum class TexelFormat : std::uint8_t { unorm8, unorm16, float32 };
enum class MipmapRule : std::uint8_t { llvmpipe_blit, mesa_software_box };
// GL_TEXTURE_MIN_FILTER. With linear, textureLod() samples level 0 whatever the lod (GL).
enum class MinFilter : std::uint8_t { linear_mipmap_linear, linear };
// GL_TEXTURE_WRAP_S and _T together. clamp_to_edge is the seeds' state and the default;
// repeat (the geomorphing article's tiled material and cloud textures) takes fract(s) and
// wraps the filter's texel indices modulo the level's size, so the filter reaches across the
// seam to the opposite edge as GL_REPEAT does (GL 4.5 8.14.2: i mod size). Not measured
// against llvmpipe: no scene with a GLSL twin uses it.
enum class Wrap : std::uint8_t { clamp_to_edge, repeat };
// What a sample returns of the stored channels (GL_TEXTURE_SWIZZLE_RGBA, the two settings
// tessref needs). luminance: a one-channel texture read as (r, r, r, 1), as GL 2's
// GL_LUMINANCE was. The red channel is filtered once and copied to green and blue: every
// channel filters on its own with the same weights, so this is exactly what a three-channel
// copy of the image returns, at a third of the filtering and of the memory.
enum class Swizzle : std::uint8_t { rgba, luminance };

const char* to_string(TexelFormat format);
const char* to_string(MipmapRule rule);

// One level of the mip pyramid.
struct TextureLevel {
    int width = 0;
    int height = 0;
    std::vector<float> texels;          // GPU path: the stored values, as the sampler reads them
    std::vector<std::uint8_t> unorm8;   // unorm8 textures only: the stored 8-bit codes
    // (The double path's values: Texture::texel_exact.)
};

// A 2D texture with its complete mip pyramid, built once at construction (immutable
// afterwards, so concurrent sampling from many threads is safe). The double path's levels
// above 0 are computed on its first read (texel_exact, the double texture / textureLod),
// once, whichever thread reads first: a gpu-precision run never needs them.
class Texture {
public:
    Texture() = default;  // empty; sampling an empty texture throws

    // Throw tessref::Error on width/height < 1, channels outside 1..4 or a size mismatch.
    static Texture from_float(int width, int height, int channels, std::vector<float> texels,
                              MipmapRule rule = MipmapRule::llvmpipe_blit);
    static Texture from_unorm8(int width, int height, int channels,
                               std::vector<std::uint8_t> codes,
                               MipmapRule rule = MipmapRule::llvmpipe_blit);
    static Texture from_unorm16(int width, int height, int channels,
                                std::vector<std::uint16_t> codes,
                                MipmapRule rule = MipmapRule::llvmpipe_blit);

    bool empty() const { return levels_.empty(); }
    int width() const { return empty() ? 0 : levels_[0].width; }
    int height() const { return empty() ? 0 : levels_[0].height; }
    int channels() const { return channels_; }
    TexelFormat format() const { return format_; }
    MipmapRule mipmap_rule() const { return rule_; }
    int level_count() const { return static_cast<int>(levels_.size()); }
    int max_level() const { return level_count() - 1; }
    const TextureLevel& level(int lod) const;

    // The stored texel (GPU path) and its double-path value, before any swizzle. Coordinates
    // are not clamped: out of range throws tessref::Error.
    float texel(int lod, int x, int y, int channel = 0) const;
    double texel_exact(int lod, int x, int y, int channel = 0) const;
    // texel_exact(0, x, y, channel) for every x of row y, into out (width() values): for
    // loops over a whole level, which need not check every texel's coordinates.
    void row_exact(int y, int channel, std::span<double> out) const;

    MinFilter min_filter() const { return min_filter_; }
    void set_min_filter(MinFilter filter) { min_filter_ = filter; }
    Wrap wrap() const { return wrap_; }
    void set_wrap(Wrap wrap) { wrap_ = wrap; }
    Swizzle swizzle() const { return swizzle_; }
    // Throws tessref::Error for luminance on a texture of other than one channel.
    void set_swizzle(Swizzle swizzle);

    // GLSL texture(sampler, st) in a TCS/TES/GS: no derivatives there, so the implicit lod
    // is 0 and this is exactly textureLod(st, 0).
    glm::vec4 texture(glm::vec2 st) const;
    glm::dvec4 texture(glm::dvec2 st) const;
    // texture() at many coordinates: out[k] = texture(st[k]), bit for bit, the format and the
    // channel count dispatched once for all of them. st and out have the same size.
    void texture(std::span<const glm::vec2> st, std::span<glm::vec4> out) const;
    void texture(std::span<const glm::dvec2> st, std::span<glm::dvec4> out) const;
    // texture() at many coordinates, the red channel alone: red[k] = texture(st[k]).r, bit
    // for bit, by the same filter; for callers that read nothing else (a height map's reads),
    // which then store a float where a vec4 was written. st and red have the same size.
    void texture_red(std::span<const glm::vec2> st, std::span<float> red) const;
    void texture_red(std::span<const glm::dvec2> st, std::span<double> red) const;
    // GLSL textureLod(sampler, st, lod): lod clamped to [0, max_level()] (a NaN lod reads as
    // 0), linear between levels floor(lod) and floor(lod) + 1. A NaN coordinate reads as a
    // coordinate below 0 (the edge texel): GL leaves it undefined, tessref keeps it defined.
    glm::vec4 textureLod(glm::vec2 st, float lod) const;
    glm::dvec4 textureLod(glm::dvec2 st, double lod) const;
    // Whether textureLod(st, lod) reads level 0 alone, and so is texture(st) bit for bit: a
    // lod the clamp takes to 0 (at most 0, or NaN), one level only, or GL_LINEAR
    // minification. A magnified fragment's lookups can then go through the many-point
    // texture().
    bool reads_level0_only(float lod) const {
        return min_filter_ == MinFilter::linear || !(lod > 0.0f) || max_level() == 0;
    }

private:
    static Texture build(int width, int height, int channels, TexelFormat format,
                         MipmapRule rule, TextureLevel level0);
    // The double path's levels >= 1 (exact[lod], exact[0] empty: level 0 is derived from
    // its texels), computed on first use; shared by copies, which hold the same levels.
    struct ExactPyramid {
        std::once_flag once;
        std::vector<std::vector<double>> exact;
    };
    const std::vector<std::vector<double>>& exact_levels() const;
    std::vector<TextureLevel> levels_;
    std::shared_ptr<ExactPyramid> exact_;
    int channels_ = 0;
    TexelFormat format_ = TexelFormat::float32;
    MipmapRule rule_ = MipmapRule::llvmpipe_blit;
    MinFilter min_filter_ = MinFilter::linear_mipmap_linear;
    Wrap wrap_ = Wrap::clamp_to_edge;
    Swizzle swizzle_ = Swizzle::rgba;
};

// Bytes a Texture of this size and format holds, its whole mip pyramid included (saturating
// at UINT64_MAX). Building a texture calls require_memory() (tessref/limits.h) for the
// levels above 0 before computing them; the loaders check this figure, plus the file's own
// samples, before reading a single pixel.
std::uint64_t texture_memory_bytes(int width, int height, int channels, TexelFormat format);

}  // namespace tessref
