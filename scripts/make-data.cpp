// make-data.cpp — regenerates the synthetic data the shipped scenes use.
//
// Build and run with scripts/make-data.sh (it compiles this file against the Debian
// OpenImageIO and OpenMesh packages and writes into data/). Everything here is
// deterministic: a hash-based value noise with a fixed seed, no clock, no random device,
// so running it again reproduces the committed files byte for byte.
//
// What it writes, and why each exists:
//  - data/heightmaps/thesis-island.pgm   8-bit 512x512. Stand-in for the thesis's Sekken
//    height map (not published): an island whose sea is exactly 0 (flat, so only the
//    constant factor tessellates it, as the thesis's Sekken figure shows), a ridge of
//    mountains and rolling hills. 8 bits because the thesis's maps were 0..255 grey.
//  - data/tessmaps/thesis-roads.pgm      8-bit 256x256 tessellation map for the thesis's
//    map factor, drawn as the thesis describes (section 4.7.3): main road white (255),
//    a smaller road grey (160), a town grey (112), everything else black. Roads are wider
//    than a patch of the shipped scenes (one sample per edge midpoint must not miss them).
//  - data/heightmaps/canyon.pgm          16-bit 512x512 canyon for lab 4: a plateau cut
//    by a meandering, stepped canyon. Power-of-two so the mip pyramid halves cleanly.
//  - data/heightmaps/canyon-257.pgm      16-bit 257x257: the middle of canyon.pgm cut out
//    unchanged (16n + 1 samples a side), for geomipmapping where the PVS culls (walls).
//  - data/heightmaps/jacksboro-257.pgm  16-bit 257x257: the middle of the Jacksboro fault
//    DEM (data/jacksboro_fault_dem.pgm), for the geomipmapping scene (16n + 1 samples a side).
//  - data/textures/geomip-grass.png, geomip-rock.png, geomip-dry.png  8-bit RGB 128x128,
//    tileable (periodic value noise): the material textures of the geomorphing article's
//    material passes, repeated over the terrain (jacksboro-geomipmap-lit).
//  - data/textures/geomip-clouds.png  8-bit grey 256x256, tileable: the cloud-shadow layer,
//    1 in the clear sky, down to 0.55 under a cloud (multiplied into the frame).
//  - data/alphamaps/jacksboro-257-rock.pgm, jacksboro-257-dry.pgm  8-bit 257x257, one texel
//    per sample of jacksboro-257.pgm: the alpha maps of the rock and dry-grass passes, from
//    the slope (rock: smoothstep(0.5, 0.9, |grad h|) in the scene's world units) and the
//    height (dry: smoothstep(0.45, 0.7, h) with h the sample over its range).
//  - data/meshes/icosahedron.off, cube.off, bump.off: triangle meshes with averaged
//    vertex normals (NOFF) for PN triangles. The cube's corner normals are the normalized
//    sum of its three face planes, (+-1,+-1,+-1)/sqrt(3); the icosahedron's are radial; the
//    bump is a flat 7x7 grid with a raised middle, so its outer faces are flat (all three
//    normals exactly (0,0,1)) and exercise the "flat patch at level 1" rule.
//  - data/meshes/bump-uv.obj: the same plate with texture coordinates u = (x + 1) / 2,
//    v = (y + 1) / 2, for normal and parallax mapping on PN triangles (pn-pom).
//  - data/textures/pom-bricks-height.png, pom-bricks-normal.png, pom-bricks-diffuse.png:
//    8-bit 256x256, tileable: a brick wall for the PN-triangles tutorial's normal and
//    parallax occlusion mapping (pn-pom, terrain-pom). Height: 1 on the brick faces, 0.25
//    in the mortar, a 10-texel smoothstep bevel between. Normal: the tangent-space
//    normal of the surface z = 0.04 * height over uv (the scenes' bump_scale), by central
//    differences with wrap-around: normalize(-dz/du, -dz/dv, 1) * 0.5 + 0.5, x along the
//    image's columns (u), y along its rows (v, the first row is v = 0). Diffuse: brick red
//    with noise, grey mortar.
#include <OpenImageIO/imageio.h>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>

#include <algorithm>
#include <cctype>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace {

using Mesh = OpenMesh::PolyMesh_ArrayKernelT<>;

// ---- noise -------------------------------------------------------------------------
std::uint32_t hash2(int x, int y, std::uint32_t seed) {
    std::uint32_t h = seed;
    h ^= static_cast<std::uint32_t>(x) * 0x8da6b343u;
    h ^= static_cast<std::uint32_t>(y) * 0xd8163841u;
    h = (h ^ (h >> 13)) * 0x5bd1e995u;
    h ^= h >> 15;
    h *= 0x27d4eb2du;
    h ^= h >> 16;
    return h;
}
double lattice(int x, int y, std::uint32_t seed) { return hash2(x, y, seed) / 4294967295.0; }
double smooth(double t) { return t * t * (3.0 - 2.0 * t); }

double value_noise(double x, double y, std::uint32_t seed) {
    const double fx = std::floor(x), fy = std::floor(y);
    const int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
    const double tx = smooth(x - fx), ty = smooth(y - fy);
    const double a = lattice(ix, iy, seed), b = lattice(ix + 1, iy, seed);
    const double c = lattice(ix, iy + 1, seed), d = lattice(ix + 1, iy + 1, seed);
    return (a + (b - a) * tx) * (1 - ty) + (c + (d - c) * tx) * ty;
}

double fbm(double x, double y, int octaves, std::uint32_t seed) {
    double sum = 0, amplitude = 0.5, norm = 0;
    for (int o = 0; o < octaves; ++o) {
        sum += amplitude * value_noise(x, y, seed + 101u * o);
        norm += amplitude;
        x *= 2.03;
        y *= 2.03;
        amplitude *= 0.5;
    }
    return sum / norm;  // 0..1
}

// Value noise and fbm that repeat every `period` lattice cells (for tileable textures).
double periodic_noise(double x, double y, int period, std::uint32_t seed) {
    const double fx = std::floor(x), fy = std::floor(y);
    const int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
    const double tx = smooth(x - fx), ty = smooth(y - fy);
    const auto at = [&](int i, int j) { return lattice(((i % period) + period) % period, ((j % period) + period) % period, seed); };
    const double a = at(ix, iy), b = at(ix + 1, iy), c = at(ix, iy + 1), d = at(ix + 1, iy + 1);
    return (a + (b - a) * tx) * (1 - ty) + (c + (d - c) * tx) * ty;
}
double periodic_fbm(double u, double v, int period, int octaves, std::uint32_t seed) {
    double sum = 0, amplitude = 0.5, norm = 0;
    for (int o = 0; o < octaves; ++o) {
        sum += amplitude * periodic_noise(u * period, v * period, period, seed + 101u * o);
        norm += amplitude;
        period *= 2;
        amplitude *= 0.5;
    }
    return sum / norm;  // 0..1
}
double smoothstep(double e0, double e1, double x) {
    const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

double distance_to_segment(double px, double py, double ax, double ay, double bx, double by) {
    const double vx = bx - ax, vy = by - ay;
    const double t = std::clamp(((px - ax) * vx + (py - ay) * vy) / (vx * vx + vy * vy), 0.0, 1.0);
    return std::hypot(px - (ax + t * vx), py - (ay + t * vy));
}

double distance_to_polyline(double px, double py, const std::vector<std::array<double, 2>>& line) {
    double best = 1e30;
    for (std::size_t i = 0; i + 1 < line.size(); ++i)
        best = std::min(best, distance_to_segment(px, py, line[i][0], line[i][1], line[i + 1][0],
                                                  line[i + 1][1]));
    return best;
}

// ---- image output through OpenImageIO ---------------------------------------------
template <typename T>
void write_gray(const std::string& path, int size, const std::vector<T>& pixels,
                OIIO::TypeDesc type) {
    auto out = OIIO::ImageOutput::create(path);
    if (!out) {
        std::fprintf(stderr, "make-data: cannot create %s\n", path.c_str());
        std::exit(1);
    }
    OIIO::ImageSpec spec(size, size, 1, type);
    spec.attribute("pnm:binary", 1);
    if (!out->open(path, spec) || !out->write_image(type, pixels.data()) || !out->close()) {
        std::fprintf(stderr, "make-data: cannot write %s: %s\n", path.c_str(),
                     out->geterror().c_str());
        std::exit(1);
    }
    std::printf("wrote %s\n", path.c_str());
}

// OpenImageIO 2.4.7's PNM writer garbles 16-bit samples (and the file comes out with the
// wrong values), so 16-bit PGM files are written here directly: a P5 header and big-endian
// samples, as the netpbm format defines them. Reading stays with OpenImageIO.
void write_pgm16(const std::string& path, int size, const std::vector<std::uint16_t>& pixels) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) {
        std::fprintf(stderr, "make-data: cannot create %s\n", path.c_str());
        std::exit(1);
    }
    std::fprintf(f, "P5\n%d %d\n65535\n", size, size);
    std::vector<unsigned char> bytes(pixels.size() * 2);
    for (std::size_t i = 0; i < pixels.size(); ++i) {
        bytes[2 * i] = static_cast<unsigned char>(pixels[i] >> 8);
        bytes[2 * i + 1] = static_cast<unsigned char>(pixels[i] & 0xff);
    }
    if (std::fwrite(bytes.data(), 1, bytes.size(), f) != bytes.size() || std::fclose(f) != 0) {
        std::fprintf(stderr, "make-data: cannot write %s\n", path.c_str());
        std::exit(1);
    }
    std::printf("wrote %s\n", path.c_str());
}

// The geomipmapping scene's map: the middle 257 x 257 samples (16 x 16 patches of 17 x 17
// samples sharing their borders) of the Jacksboro fault DEM, data/jacksboro_fault_dem.pgm
// (403 x 344, 16-bit), cut out as they are: geomipmapping needs 16n + 1 samples a side.
std::vector<std::uint16_t> make_jacksboro_257(const std::string& dir) {
    const std::string source = dir + "/jacksboro_fault_dem.pgm";
    std::FILE* f = std::fopen(source.c_str(), "rb");
    // The header's four tokens (magic, width, height, maxval), '#' comments skipped, then
    // one whitespace byte before the samples.
    std::array<std::string, 4> token;
    for (std::string& t : token) {
        int c = f ? std::fgetc(f) : EOF;
        while (c != EOF && (std::isspace(c) || c == '#')) {
            if (c == '#')
                while (c != EOF && c != '\n') c = std::fgetc(f);
            c = std::fgetc(f);
        }
        while (c != EOF && !std::isspace(c)) {
            t += static_cast<char>(c);
            c = std::fgetc(f);
        }
    }
    const int width = std::atoi(token[1].c_str()), height = std::atoi(token[2].c_str());
    if (!f || token[0] != "P5" || token[3] != "65535" || width < 257 || height < 257) {
        std::fprintf(stderr, "make-data: cannot read %s as a 16-bit P5 PGM\n", source.c_str());
        std::exit(1);
    }
    std::vector<unsigned char> bytes(static_cast<std::size_t>(width) * height * 2);
    if (std::fread(bytes.data(), 1, bytes.size(), f) != bytes.size()) {
        std::fprintf(stderr, "make-data: %s is truncated\n", source.c_str());
        std::exit(1);
    }
    std::fclose(f);
    const int n = 257, x0 = (width - n) / 2, y0 = (height - n) / 2;
    std::vector<std::uint16_t> pixels(static_cast<std::size_t>(n) * n);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const std::size_t at = (static_cast<std::size_t>(y0 + y) * width + (x0 + x)) * 2;
            pixels[static_cast<std::size_t>(y) * n + x] = static_cast<std::uint16_t>(bytes[at] << 8 | bytes[at + 1]);
        }
    write_pgm16(dir + "/heightmaps/jacksboro-257.pgm", n, pixels);
    return pixels;
}

void write_rgb_png(const std::string& path, int n, int channels, const std::vector<std::uint8_t>& pixels) {
    auto out = OIIO::ImageOutput::create(path);
    OIIO::ImageSpec spec(n, n, channels, OIIO::TypeDesc::UINT8);
    if (!out || !out->open(path, spec) || !out->write_image(OIIO::TypeDesc::UINT8, pixels.data()) || !out->close()) {
        std::fprintf(stderr, "make-data: cannot write %s\n", path.c_str());
        std::exit(1);
    }
    std::printf("wrote %s\n", path.c_str());
}

// The geomorphing article's materials for jacksboro-geomipmap-lit: three tileable material
// textures, a cloud layer, and two alpha maps from the height map's slope and height.
void make_geomip_materials(const std::string& dir, const std::vector<std::uint16_t>& heights) {
    struct Material {
        const char* name;
        double r, g, b;      // the mean colour
        double variation;    // how far the noise moves it
        std::uint32_t seed;
    };
    const Material materials[] = {{"grass", 0.30, 0.48, 0.18, 0.35, 11u},
                                  {"rock", 0.52, 0.48, 0.44, 0.45, 23u},
                                  {"dry", 0.66, 0.58, 0.36, 0.30, 37u}};
    const int m = 128;
    for (const Material& mat : materials) {
        std::vector<std::uint8_t> rgb(static_cast<std::size_t>(m) * m * 3);
        for (int y = 0; y < m; ++y)
            for (int x = 0; x < m; ++x) {
                const double f = periodic_fbm((x + 0.5) / m, (y + 0.5) / m, 8, 4, mat.seed);
                const double k = 1.0 + mat.variation * (2.0 * f - 1.0);
                const double c[3] = {mat.r * k, mat.g * k, mat.b * k};
                for (int ch = 0; ch < 3; ++ch)
                    rgb[(static_cast<std::size_t>(y) * m + x) * 3 + ch] =
                        static_cast<std::uint8_t>(std::lround(std::clamp(c[ch], 0.0, 1.0) * 255.0));
            }
        write_rgb_png(dir + "/textures/geomip-" + mat.name + ".png", m, 3, rgb);
    }
    const int c = 256;
    std::vector<std::uint8_t> clouds(static_cast<std::size_t>(c) * c);
    for (int y = 0; y < c; ++y)
        for (int x = 0; x < c; ++x) {
            const double f = periodic_fbm((x + 0.5) / c, (y + 0.5) / c, 4, 5, 53u);
            clouds[static_cast<std::size_t>(y) * c + x] =
                static_cast<std::uint8_t>(std::lround((1.0 - 0.45 * smoothstep(0.45, 0.7, f)) * 255.0));
        }
    write_rgb_png(dir + "/textures/geomip-clouds.png", c, 1, clouds);

    // Alpha maps: one texel per height sample. World units of jacksboro-geomipmap-lit.toml:
    // samples 0.75 x 0.93 apart, height = sample / 65535 * 16.8.
    const int n = 257;
    const double dx = 0.75, dy = 0.93, scale_z = 16.8;
    const auto h = [&](int x, int y) {
        x = std::clamp(x, 0, n - 1);
        y = std::clamp(y, 0, n - 1);
        return heights[static_cast<std::size_t>(y) * n + x] / 65535.0;
    };
    const auto [lo, hi] = std::minmax_element(heights.begin(), heights.end());
    std::vector<std::uint8_t> rock(static_cast<std::size_t>(n) * n), dry(rock.size());
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const double gx = (h(x + 1, y) - h(x - 1, y)) * scale_z / (2.0 * dx);
            const double gy = (h(x, y + 1) - h(x, y - 1)) * scale_z / (2.0 * dy);
            const double slope = std::sqrt(gx * gx + gy * gy);
            const double height = (heights[static_cast<std::size_t>(y) * n + x] - *lo) / double(*hi - *lo);
            rock[static_cast<std::size_t>(y) * n + x] =
                static_cast<std::uint8_t>(std::lround(smoothstep(0.5, 0.9, slope) * 255.0));
            dry[static_cast<std::size_t>(y) * n + x] =
                static_cast<std::uint8_t>(std::lround(smoothstep(0.45, 0.7, height) * 255.0));
        }
    write_gray(dir + "/alphamaps/jacksboro-257-rock.pgm", n, rock, OIIO::TypeDesc::UINT8);
    write_gray(dir + "/alphamaps/jacksboro-257-dry.pgm", n, dry, OIIO::TypeDesc::UINT8);
}

// ---- height and tessellation maps -------------------------------------------------
// The colour texture of the island scenes (the thesis's own texture is not published): a
// hypsometric tint of the height map — sea, beach, grass, forest, rock, snow — blended
// linearly between bands, 8-bit RGB PNG, the same texel grid as the height map.
void make_island_colour(const std::string& dir, int n, const std::vector<std::uint8_t>& heights) {
    struct Band {
        double height;
        double r, g, b;
    };
    static const Band bands[] = {{0.00, 0.16, 0.32, 0.52}, {0.004, 0.84, 0.78, 0.58}, {0.06, 0.42, 0.62, 0.28},
                                 {0.30, 0.22, 0.44, 0.18}, {0.55, 0.50, 0.44, 0.38}, {0.80, 0.62, 0.60, 0.58},
                                 {0.92, 0.96, 0.96, 0.98}};
    std::vector<std::uint8_t> rgb(static_cast<std::size_t>(n) * n * 3);
    for (std::size_t t = 0; t < heights.size(); ++t) {
        const double h = heights[t] / 255.0;
        std::size_t k = 0;
        while (k + 2 < std::size(bands) && h >= bands[k + 1].height) ++k;
        const Band &a = bands[k], &b = bands[k + 1];
        const double w = std::clamp((h - a.height) / (b.height - a.height), 0.0, 1.0);
        const double c[3] = {a.r + (b.r - a.r) * w, a.g + (b.g - a.g) * w, a.b + (b.b - a.b) * w};
        for (int ch = 0; ch < 3; ++ch) rgb[t * 3 + ch] = static_cast<std::uint8_t>(std::lround(c[ch] * 255.0));
    }
    const std::string path = dir + "/textures/thesis-island-colour.png";
    auto out = OIIO::ImageOutput::create(path);
    OIIO::ImageSpec spec(n, n, 3, OIIO::TypeDesc::UINT8);
    if (!out || !out->open(path, spec) || !out->write_image(OIIO::TypeDesc::UINT8, rgb.data()) || !out->close()) {
        std::fprintf(stderr, "make-data: cannot write %s\n", path.c_str());
        std::exit(1);
    }
    std::printf("wrote %s\n", path.c_str());
}

void make_thesis_island(const std::string& dir) {
    const int n = 512;
    std::vector<std::uint8_t> pixels(n * n);
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const double x = (i + 0.5) / n, y = (j + 0.5) / n;
            // Irregular coastline: radial falloff perturbed by low-frequency noise.
            const double r = std::hypot(x - 0.5, y - 0.5) / 0.42 + 0.35 * (fbm(x * 3, y * 3, 3, 7) - 0.5);
            const double land = std::clamp(1.0 - r, 0.0, 1.0);
            // A mountain ridge running diagonally, plus hills everywhere.
            const double ridge = std::exp(-std::pow(distance_to_segment(x, y, 0.3, 0.35, 0.7, 0.62) / 0.09, 2));
            const double hills = fbm(x * 8, y * 8, 6, 11);
            double h = land > 0 ? std::min(1.0, 1.6 * land) * (0.2 + 0.4 * hills + 0.6 * ridge * hills) : 0.0;
            h = std::clamp(h - 0.04, 0.0, 1.0);  // the sea, and a beach at exactly 0
            pixels[j * n + i] = static_cast<std::uint8_t>(std::lround(h * 255.0));
        }
    write_gray(dir + "/heightmaps/thesis-island.pgm", n, pixels, OIIO::TypeDesc::UINT8);
    make_island_colour(dir, n, pixels);
}

void make_thesis_roads(const std::string& dir) {
    const int n = 256;
    // In texture coordinates (0..1). The main road follows the coast; the smaller road
    // crosses the ridge to a town.
    const std::vector<std::array<double, 2>> main_road = {
        {0.18, 0.30}, {0.30, 0.18}, {0.50, 0.14}, {0.70, 0.20}, {0.82, 0.36}, {0.84, 0.56}, {0.74, 0.76}};
    const std::vector<std::array<double, 2>> small_road = {{0.50, 0.14}, {0.48, 0.40}, {0.56, 0.58}, {0.62, 0.70}};
    const double town_x = 0.62, town_y = 0.70, town_radius = 0.07;
    std::vector<std::uint8_t> pixels(n * n);
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const double x = (i + 0.5) / n, y = (j + 0.5) / n;
            const double px = 1.0 / n;
            // Coverage with a one-texel soft edge.
            auto cover = [&](double d, double half_width) {
                return std::clamp((half_width - d) / px + 0.5, 0.0, 1.0);
            };
            double v = 0;
            v = std::max(v, 112.0 * cover(std::hypot(x - town_x, y - town_y), town_radius));
            v = std::max(v, 160.0 * cover(distance_to_polyline(x, y, small_road), 0.025));
            v = std::max(v, 255.0 * cover(distance_to_polyline(x, y, main_road), 0.04));
            pixels[j * n + i] = static_cast<std::uint8_t>(std::lround(v));
        }
    write_gray(dir + "/tessmaps/thesis-roads.pgm", n, pixels, OIIO::TypeDesc::UINT8);
}

void make_canyon(const std::string& dir) {
    const int n = 512;
    std::vector<std::uint16_t> pixels(n * n);
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const double x = (i + 0.5) / n, y = (j + 0.5) / n;
            // Meandering river centre line x = c(y).
            const double centre = 0.5 + 0.14 * std::sin(y * 2 * M_PI * 1.3) + 0.05 * std::sin(y * 2 * M_PI * 3.7 + 1.0);
            const double d = std::abs(x - centre) + 0.03 * (fbm(x * 8, y * 8, 3, 23) - 0.5);
            // Stepped walls: depth falls off with distance in terraces.
            const double w = std::clamp(d / 0.22, 0.0, 1.0);
            const double steps = 4.0;
            const double terrace = (std::floor(w * steps) + smooth(std::pow(w * steps - std::floor(w * steps), 3))) / steps;
            const double plateau = 0.72 + 0.22 * fbm(x * 4, y * 4, 6, 31);
            const double floor_height = 0.08 + 0.04 * fbm(x * 16, y * 16, 3, 37);
            const double h = floor_height + (plateau - floor_height) * terrace;
            pixels[j * n + i] = static_cast<std::uint16_t>(std::lround(std::clamp(h, 0.0, 1.0) * 65535.0));
        }
    write_pgm16(dir + "/heightmaps/canyon.pgm", n, pixels);
    // The middle 257 x 257 samples, as jacksboro-257.pgm is cut from its DEM.
    const int m = 257, x0 = (n - m) / 2, y0 = (n - m) / 2;
    std::vector<std::uint16_t> middle(static_cast<std::size_t>(m) * m);
    for (int y = 0; y < m; ++y)
        for (int x = 0; x < m; ++x)
            middle[static_cast<std::size_t>(y) * m + x] = pixels[static_cast<std::size_t>(y0 + y) * n + (x0 + x)];
    write_pgm16(dir + "/heightmaps/canyon-257.pgm", m, middle);
}

// ---- meshes through OpenMesh -------------------------------------------------------
void write_mesh(const Mesh& mesh, const std::string& path,
                OpenMesh::IO::Options options = OpenMesh::IO::Options::VertexNormal) {
    if (!OpenMesh::IO::write_mesh(mesh, path, options, 9)) {
        std::fprintf(stderr, "make-data: cannot write %s\n", path.c_str());
        std::exit(1);
    }
    std::printf("wrote %s\n", path.c_str());
}

void make_cube(const std::string& dir) {
    Mesh mesh;
    mesh.request_vertex_normals();
    std::array<Mesh::VertexHandle, 8> v;
    for (int k = 0; k < 8; ++k) {
        const float x = (k & 1) ? 1.f : -1.f, y = (k & 2) ? 1.f : -1.f, z = (k & 4) ? 1.f : -1.f;
        v[k] = mesh.add_vertex(Mesh::Point(x, y, z));
        // The normalized sum of the three face planes meeting at the corner.
        mesh.set_normal(v[k], Mesh::Normal(x, y, z).normalize());
    }
    // Quads listed counter-clockwise seen from outside, each split into two triangles.
    const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& q : quads) {
        mesh.add_face(v[q[0]], v[q[1]], v[q[2]]);
        mesh.add_face(v[q[0]], v[q[2]], v[q[3]]);
    }
    write_mesh(mesh, dir + "/meshes/cube.off");
}

void make_icosahedron(const std::string& dir) {
    Mesh mesh;
    mesh.request_vertex_normals();
    const double t = (1.0 + std::sqrt(5.0)) / 2.0;
    const double raw[12][3] = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                               {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    std::array<Mesh::VertexHandle, 12> v;
    for (int k = 0; k < 12; ++k) {
        const double len = std::sqrt(raw[k][0] * raw[k][0] + raw[k][1] * raw[k][1] + raw[k][2] * raw[k][2]);
        const Mesh::Point p(raw[k][0] / len, raw[k][1] / len, raw[k][2] / len);  // unit sphere
        v[k] = mesh.add_vertex(p);
        mesh.set_normal(v[k], p);  // averaged normal of a regular polyhedron = radial
    }
    const int faces[20][3] = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                              {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
                              {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
    for (const auto& f : faces) mesh.add_face(v[f[0]], v[f[1]], v[f[2]]);
    write_mesh(mesh, dir + "/meshes/icosahedron.off");
}

// The bumped plate: 7x7 vertices on [-1,1]^2, z up, a centre at 0.6 in a ring at 0.2.
// bump.off for the PN scenes; with_uv: bump-uv.obj, the same plate with texture
// coordinates u = (x + 1) / 2, v = (y + 1) / 2 for normal and parallax mapping (the
// PN-triangles tutorial, parts 1 and 2).
void make_bump(const std::string& dir, bool with_uv) {
    Mesh mesh;
    mesh.request_vertex_normals();
    mesh.request_face_normals();
    if (with_uv) mesh.request_vertex_texcoords2D();
    const int n = 7;  // 7x7 vertices on [-1,1]^2, z up
    std::vector<Mesh::VertexHandle> v(n * n);
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const float x = -1.f + 2.f * i / (n - 1), y = -1.f + 2.f * j / (n - 1);
            const int ring = std::max(std::abs(i - n / 2), std::abs(j - n / 2));
            const float z = ring == 0 ? 0.6f : ring == 1 ? 0.2f : 0.f;
            v[j * n + i] = mesh.add_vertex(Mesh::Point(x, y, z));
            if (with_uv) mesh.set_texcoord2D(v[j * n + i], Mesh::TexCoord2D(float(i) / (n - 1), float(j) / (n - 1)));
        }
    for (int j = 0; j + 1 < n; ++j)
        for (int i = 0; i + 1 < n; ++i) {
            const auto a = v[j * n + i], b = v[j * n + i + 1], c = v[(j + 1) * n + i + 1], d = v[(j + 1) * n + i];
            mesh.add_face(a, b, c);  // counter-clockwise seen from +z
            mesh.add_face(a, c, d);
        }
    // Averaged vertex normals: the normalized sum of the incident face normals. Faces in
    // the z = 0 plane have the normal (0,0,1) exactly, so a vertex surrounded only by
    // them gets exactly (0,0,1) and the faces made of such vertices are flat.
    mesh.update_face_normals();
    for (auto vh : mesh.vertices()) {
        Mesh::Normal sum(0, 0, 0);
        for (auto fh : mesh.vf_range(vh)) sum += mesh.normal(fh);
        mesh.set_normal(vh, sum.normalize());
    }
    if (with_uv)
        write_mesh(mesh, dir + "/meshes/bump-uv.obj",
                   OpenMesh::IO::Options::VertexNormal | OpenMesh::IO::Options::VertexTexCoord);
    else
        write_mesh(mesh, dir + "/meshes/bump.off");
}

// ---- normal and parallax mapping (the PN-triangles tutorial, parts 1 and 2) ---------
void make_pom_bricks(const std::string& dir) {
    const int n = 256, brick_w = 128, brick_h = 64, mortar = 4, bevel = 10;
    const double scale = 0.04;  // the scenes' bump_scale (uv units per unit of height)
    std::vector<double> height(n * n);
    std::vector<std::uint8_t> h8(n * n), normal(n * n * 3), diffuse(n * n * 3);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const int row = y / brick_h;
            const int xs = (x + (row % 2) * brick_w / 2) % n;
            // Distance in texels to the nearest mortar line (joints at brick edges).
            const int dx = std::min(xs % brick_w, brick_w - 1 - xs % brick_w);
            const int dy = std::min(y % brick_h, brick_h - 1 - y % brick_h);
            const double d = std::min(dx, dy) - mortar + 0.5;
            const double face = 1.0;  // flat faces at the surface: the trace toward the light starts level
            const double t = std::clamp(d / bevel, 0.0, 1.0);
            const double h = d < 0 ? 0.25 : 0.25 + (face - 0.25) * smooth(t);
            const std::uint8_t code = static_cast<std::uint8_t>(std::lround(std::clamp(h, 0.0, 1.0) * 255.0));
            h8[y * n + x] = code;
            height[y * n + x] = code / 255.0;  // what the sampler reads
            const double noise = periodic_fbm(double(x) / n, double(y) / n, 16, 3, 202u);
            const bool brick = d >= 0;
            const double r = brick ? 0.55 + 0.25 * noise : 0.62 + 0.1 * noise;
            const double g = brick ? 0.22 + 0.12 * noise : 0.60 + 0.1 * noise;
            const double b = brick ? 0.16 + 0.08 * noise : 0.55 + 0.1 * noise;
            const double rgb[3] = {r, g, b};
            for (int c = 0; c < 3; ++c)
                diffuse[(y * n + x) * 3 + c] = static_cast<std::uint8_t>(std::lround(std::clamp(rgb[c], 0.0, 1.0) * 255.0));
        }
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            auto at = [&](int i, int j) { return height[((j + n) % n) * n + (i + n) % n]; };
            // dz/du = scale * dh/du, dh/du = (h(x+1) - h(x-1)) / 2 texels * n texels per uv
            const double dzdu = scale * (at(x + 1, y) - at(x - 1, y)) * 0.5 * n;
            const double dzdv = scale * (at(x, y + 1) - at(x, y - 1)) * 0.5 * n;
            const double len = std::sqrt(dzdu * dzdu + dzdv * dzdv + 1.0);
            const double nv[3] = {-dzdu / len, -dzdv / len, 1.0 / len};
            for (int c = 0; c < 3; ++c)
                normal[(y * n + x) * 3 + c] = static_cast<std::uint8_t>(std::lround((nv[c] * 0.5 + 0.5) * 255.0));
        }
    write_rgb_png(dir + "/textures/pom-bricks-height.png", n, 1, h8);
    write_rgb_png(dir + "/textures/pom-bricks-normal.png", n, 3, normal);
    write_rgb_png(dir + "/textures/pom-bricks-diffuse.png", n, 3, diffuse);
}

}  // namespace

int main(int argc, char** argv) {
    const std::string dir = argc > 1 ? argv[1] : "data";
    make_thesis_island(dir);
    make_thesis_roads(dir);
    make_canyon(dir);
    make_geomip_materials(dir, make_jacksboro_257(dir));
    make_cube(dir);
    make_icosahedron(dir);
    make_bump(dir, false);
    make_bump(dir, true);
    make_pom_bricks(dir);
    return 0;
}
