// pvs.cpp — the potentially visible set of a geomipmapped terrain (tessref/geomipmap.h, PVS;
// the geomorphing article, "Optimizations": cells over the patches in layers, line of sight
// from each cell to each patch, one bit per cell and patch).
#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <mutex>
#include <optional>
#include <sstream>

#include "common/input_file.h"
#include "common/parallel.h"
#include "tessref/error.h"
#include "tessref/geomipmap.h"
#include "tessref/raycast.h"

namespace tessref::geomip {

namespace {

constexpr int N = kPatchCells;
constexpr char kMagic[8] = {'T', 'R', 'P', 'V', 'S', '\0', '\r', '\n'};
constexpr std::uint32_t kVersion = 2;  // 2: the conservative set (1: full-resolution lines, not conservative)
constexpr std::size_t kHeaderBytes = 64;
constexpr int kCellSamples = 3;  // per axis: the centres of the cell's thirds

struct Fnv {
    std::uint64_t h = 1469598103934665603ull;
    void bytes(const void* data, std::size_t n) {
        const auto* p = static_cast<const unsigned char*>(data);
        for (std::size_t i = 0; i < n; ++i) {
            h ^= p[i];
            h *= 1099511628211ull;
        }
    }
    void u64(std::uint64_t v) {
        for (int i = 0; i < 8; ++i) {
            const unsigned char b = static_cast<unsigned char>(v >> (8 * i));
            bytes(&b, 1);
        }
    }
    void f64(double v) { u64(std::bit_cast<std::uint64_t>(v)); }
};

void put_u32(unsigned char* p, std::uint32_t v) {
    for (int i = 0; i < 4; ++i) p[i] = static_cast<unsigned char>(v >> (8 * i));
}
void put_u64(unsigned char* p, std::uint64_t v) {
    for (int i = 0; i < 8; ++i) p[i] = static_cast<unsigned char>(v >> (8 * i));
}
std::uint32_t get_u32(const unsigned char* p) {
    std::uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = v << 8 | p[i];
    return v;
}
std::uint64_t get_u64(const unsigned char* p) {
    std::uint64_t v = 0;
    for (int i = 7; i >= 0; --i) v = v << 8 | p[i];
    return v;
}

std::uint64_t checksum(const std::vector<std::uint8_t>& bits) {
    Fnv f;
    f.bytes(bits.data(), bits.size());
    return f.h;
}

}  // namespace

std::uint64_t terrain_identity(const HeightSamples& map, const Settings& settings) {
    Fnv f;
    f.u64(static_cast<std::uint64_t>(map.width));
    f.u64(static_cast<std::uint64_t>(map.height));
    for (double s : map.samples) f.f64(s);
    f.f64(settings.origin.x);
    f.f64(settings.origin.y);
    f.f64(settings.spacing.x);
    f.f64(settings.spacing.y);
    f.f64(settings.scale_z);
    return f.h;
}

std::optional<std::size_t> Pvs::cell_of(const glm::dvec3& p, const Settings& settings) const {
    const double fx = (p.x - settings.origin.x) / (settings.spacing.x * N);
    const double fy = (p.y - settings.origin.y) / (settings.spacing.y * N);
    const double fz = (p.z - z_lo) / (z_hi - z_lo) * layers;
    if (!(fx >= 0.0 && fx < patches_x && fy >= 0.0 && fy < patches_y && fz >= 0.0 && fz < layers)) return std::nullopt;
    const auto px = static_cast<std::size_t>(fx), py = static_cast<std::size_t>(fy), l = static_cast<std::size_t>(fz);
    return (l * static_cast<std::size_t>(patches_y) + py) * static_cast<std::size_t>(patches_x) + px;
}

glm::dvec3 pvs_cell_point(const Pvs& pvs, const Settings& settings, std::size_t cell, int sx, int sy, int sz) {
    const std::size_t px = cell % static_cast<std::size_t>(pvs.patches_x);
    const std::size_t py = cell / static_cast<std::size_t>(pvs.patches_x) % static_cast<std::size_t>(pvs.patches_y);
    const std::size_t l = cell / pvs.patch_count();
    const double third = 1.0 / kCellSamples;
    const double gx = (static_cast<double>(px) + (sx + 0.5) * third) * N;
    const double gy = (static_cast<double>(py) + (sy + 0.5) * third) * N;
    const double layer_height = (pvs.z_hi - pvs.z_lo) / pvs.layers;
    return {settings.origin.x + gx * settings.spacing.x, settings.origin.y + gy * settings.spacing.y,
            pvs.z_lo + (static_cast<double>(l) + (sz + 0.5) * third) * layer_height};
}

// The conservative construction (geomipmap.h, PVS; docs/GEOMIPMAP.md has the argument).
// Whatever the levels and tweens, every vertex of patch R is a sample of R or a convex
// combination of R's samples, so the drawn surface over R lies between R's lowest and
// highest sample (R's box, patch_bounds), and over each sample square between the bounds
// surface_bounds gives (lo <= box lo, hi <= box hi). Hence:
//  - targets: P's box top (its highest sample, raised by the margin) at every target_step
//    samples: a line of sight to any drawn point of P can be raised to the top over the
//    same ground point, and is then within d (half the diagonal of a target_step cell) of
//    a line to a target;
//  - occluder: over each sample square its lower bound ("the low blocks", which the drawn
//    surface never goes under), eroded by d (a vertex takes the lowest square within d
//    plus one sample spacing) and lowered by the margin, on a mesh of one vertex per
//    sample whose every vertex is at most the eroded blocks over its cells;
//  - sources: a sample point at or under the upper bound of the square under it (plus the
//    margin) may be under the drawn surface: its cell keeps every patch.
struct PvsBuilder::Impl {
    Pvs layout;
    Settings settings;
    std::vector<Box> boxes;          // per patch (patch_bounds)
    std::vector<double> square_hi;   // per sample square, world: surface_bounds' upper bound
    int squares_x = 0, squares_y = 0;
    double margin = 0.0;             // world height: targets up, occluder down, sources up
    std::optional<RayScene> rays;    // the lowered, eroded low blocks
    std::vector<glm::dvec3> targets; // per patch, per_patch of them
    std::size_t per_patch = 0;
};

PvsBuilder::PvsBuilder(const HeightSamples& map, const Settings& settings, int layers, int target_step)
    : impl_(std::make_unique<Impl>()) {
    validate(map);
    if (layers < 1 || layers > 4096) throw Error("pvs: the layer count must lie in [1, 4096]");
    if (target_step < 1 || target_step > N || N % target_step != 0)
        throw Error("pvs: the target step must divide " + std::to_string(N));
    Impl& m = *impl_;
    m.settings = settings;
    Pvs& pvs = m.layout;
    pvs.patches_x = map.patches_x();
    pvs.patches_y = map.patches_y();
    pvs.layers = layers;
    pvs.terrain_id = terrain_identity(map, settings);
    const auto [lo_it, hi_it] = std::minmax_element(map.samples.begin(), map.samples.end());
    const double a = *lo_it * settings.scale_z, b = *hi_it * settings.scale_z;
    const double lo = std::min(a, b), height = std::max(a, b) - lo;
    // "32 layers in a range of three times the height of the landscape" (the article).
    pvs.z_lo = lo;
    pvs.z_hi = lo + 3.0 * (height > 0.0 ? height : 1.0);

    m.boxes = patch_bounds(map, settings);
    // Far above float rounding of the drawn vertices, of the rasterizer and of Embree.
    m.margin = 1e-3 * (height > 0.0 ? height : 1.0);
    const double sx = std::abs(settings.spacing.x), sy = std::abs(settings.spacing.y);
    const double d = 0.5 * target_step * std::sqrt(sx * sx + sy * sy);
    // A vertex's value serves every point of its cells (within one spacing per axis) and
    // every point within d of those: the squares meeting the window of +-r samples.
    const int rx = static_cast<int>(std::ceil((sx + d) / sx)), ry = static_cast<int>(std::ceil((sy + d) / sy));
    const SurfaceBounds bounds = surface_bounds(map);
    const int w = map.width - 1, h = map.height - 1;
    m.squares_x = w;
    m.squares_y = h;
    std::vector<double> square_lo(bounds.lo.size());
    m.square_hi.resize(bounds.hi.size());
    for (std::size_t q = 0; q < bounds.lo.size(); ++q) {
        const double u = bounds.lo[q] * settings.scale_z, v = bounds.hi[q] * settings.scale_z;
        square_lo[q] = std::min(u, v);
        m.square_hi[q] = std::max(u, v);
    }
    std::vector<glm::dvec3> positions(static_cast<std::size_t>(map.width) * map.height);
    for (int y = 0; y < map.height; ++y) {
        const int j0 = std::max(0, y - ry - 1), j1 = std::min(h - 1, y + ry);
        for (int x = 0; x < map.width; ++x) {
            const int i0 = std::max(0, x - rx - 1), i1 = std::min(w - 1, x + rx);
            double z = std::numeric_limits<double>::infinity();
            for (int j = j0; j <= j1; ++j)
                for (int i = i0; i <= i1; ++i) z = std::min(z, square_lo[static_cast<std::size_t>(j) * w + i]);
            positions[static_cast<std::size_t>(y) * map.width + x] = {
                settings.origin.x + x * settings.spacing.x, settings.origin.y + y * settings.spacing.y, z - m.margin};
        }
    }
    std::vector<std::array<std::uint32_t, 3>> triangles;
    triangles.reserve(2 * static_cast<std::size_t>(map.width - 1) * (map.height - 1));
    for (int y = 0; y + 1 < map.height; ++y)
        for (int x = 0; x + 1 < map.width; ++x) {
            const auto v = [&](int i, int j) { return static_cast<std::uint32_t>((y + j) * map.width + x + i); };
            triangles.push_back({v(0, 0), v(1, 0), v(1, 1)});
            triangles.push_back({v(0, 0), v(1, 1), v(0, 1)});
        }
    m.rays.emplace(positions, triangles);

    // Targets: each patch's box top at every target_step samples.
    const int per_side = N / target_step + 1;
    m.per_patch = static_cast<std::size_t>(per_side * per_side);
    m.targets.resize(pvs.patch_count() * m.per_patch);
    for (std::size_t p = 0; p < pvs.patch_count(); ++p) {
        const int ox = static_cast<int>(p % pvs.patches_x) * N, oy = static_cast<int>(p / pvs.patches_x) * N;
        for (int j = 0; j < per_side; ++j)
            for (int i = 0; i < per_side; ++i) {
                const int x = ox + i * target_step, y = oy + j * target_step;
                m.targets[p * m.per_patch + static_cast<std::size_t>(j * per_side + i)] = {
                    settings.origin.x + x * settings.spacing.x, settings.origin.y + y * settings.spacing.y,
                    m.boxes[p].hi.z + m.margin};
            }
    }
}

PvsBuilder::~PvsBuilder() = default;

const Pvs& PvsBuilder::layout() const { return impl_->layout; }

std::vector<std::uint8_t> PvsBuilder::row(std::size_t cell) const {
    const Impl& m = *impl_;
    const Pvs& pvs = m.layout;
    if (cell >= pvs.cell_count()) throw Error("pvs: cell " + std::to_string(cell) + " out of range");
    const RayScene& rays = *m.rays;
    const std::size_t patches = pvs.patch_count();
    std::vector<std::uint8_t> row(patches, 1);
    // The highest the drawn surface can be under a point: the squares whose closed
    // rectangle holds it, with a tolerance (a sample point can lie on a sample line, as the
    // middle third's centre does, and its division by the spacing round either way).
    const auto top = [&](const glm::dvec3& s) {
        constexpr double kTolerance = 1e-6;  // in samples
        const double u = (s.x - m.settings.origin.x) / m.settings.spacing.x;
        const double v = (s.y - m.settings.origin.y) / m.settings.spacing.y;
        const int i0 = std::max(0, static_cast<int>(std::ceil(u - kTolerance)) - 1);
        const int i1 = std::min(m.squares_x - 1, static_cast<int>(std::floor(u + kTolerance)));
        const int j0 = std::max(0, static_cast<int>(std::ceil(v - kTolerance)) - 1);
        const int j1 = std::min(m.squares_y - 1, static_cast<int>(std::floor(v + kTolerance)));
        double z = -std::numeric_limits<double>::infinity();
        for (int j = j0; j <= j1; ++j)
            for (int i = i0; i <= i1; ++i) z = std::max(z, m.square_hi[static_cast<std::size_t>(j) * m.squares_x + i]);
        return z + m.margin;
    };
    std::vector<glm::dvec3> sources;
    for (int sz = 0; sz < kCellSamples; ++sz)
        for (int sy = 0; sy < kCellSamples; ++sy)
            for (int sx = 0; sx < kCellSamples; ++sx) {
                const glm::dvec3 s = pvs_cell_point(pvs, m.settings, cell, sx, sy, sz);
                if (!(s.z > top(s))) return row;  // may be under the drawn surface: keep every patch
                sources.push_back(s);
            }
    for (std::size_t p = 0; p < patches; ++p) {
        bool visible = false;
        for (std::size_t t = 0; t < m.per_patch && !visible; ++t) {
            const glm::dvec3& target = m.targets[p * m.per_patch + t];
            for (const glm::dvec3& s : sources) {
                const glm::dvec3 dir = target - s;
                const double length = glm::length(dir);
                // The target stands 2 margins above the occluder under it: the whole segment.
                if (length == 0.0 || !rays.occluded(s, dir / length, 0.0, length)) {
                    visible = true;
                    break;
                }
            }
        }
        row[p] = visible ? 1 : 0;
    }
    return row;
}

Pvs build_pvs(const HeightSamples& map, const Settings& settings, int layers, int target_step,
              const std::function<void(std::size_t, std::size_t)>& progress) {
    const PvsBuilder builder(map, settings, layers, target_step);
    Pvs pvs = builder.layout();
    const std::size_t cells = pvs.cell_count(), patches = pvs.patch_count();
    pvs.bits.assign((cells * patches + 7) / 8, 0);
    std::vector<std::uint8_t> seen(cells * patches, 0);  // one byte per bit: cells write their own slots
    std::atomic<std::size_t> done{0};
    std::mutex progress_mutex;
    tessref::parallel_for(std::size_t{0}, cells, [&](std::size_t cell) {
        const std::vector<std::uint8_t> row = builder.row(cell);
        std::copy(row.begin(), row.end(), seen.begin() + static_cast<std::ptrdiff_t>(cell * patches));
        const std::size_t n = done.fetch_add(1) + 1;
        if (progress) {
            const std::lock_guard<std::mutex> lock(progress_mutex);
            progress(n, cells);
        }
    });
    for (std::size_t b = 0; b < seen.size(); ++b)
        if (seen[b]) pvs.bits[b / 8] = static_cast<std::uint8_t>(pvs.bits[b / 8] | (1u << (b % 8)));
    return pvs;
}

void write_pvs(const Pvs& pvs, const std::string& path) {
    unsigned char header[kHeaderBytes] = {};
    std::memcpy(header, kMagic, 8);
    put_u32(header + 8, kVersion);
    put_u32(header + 12, static_cast<std::uint32_t>(pvs.patches_x));
    put_u32(header + 16, static_cast<std::uint32_t>(pvs.patches_y));
    put_u32(header + 20, static_cast<std::uint32_t>(pvs.layers));
    put_u64(header + 24, std::bit_cast<std::uint64_t>(pvs.z_lo));
    put_u64(header + 32, std::bit_cast<std::uint64_t>(pvs.z_hi));
    put_u64(header + 40, pvs.terrain_id);
    put_u64(header + 48, pvs.bits.size());
    put_u64(header + 56, checksum(pvs.bits));
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(header), kHeaderBytes);
    out.write(reinterpret_cast<const char*>(pvs.bits.data()), static_cast<std::streamsize>(pvs.bits.size()));
    out.close();
    if (!out) throw Error("cannot write the PVS file", Where::in_file(path));
}

Pvs read_pvs(const std::string& path) {
    // Parsed from memory: the bits are the file's bulk, held to the memory budget on reading.
    std::istringstream in(read_input_file(path, "PVS file", kNoCap));
    unsigned char header[kHeaderBytes];
    in.read(reinterpret_cast<char*>(header), kHeaderBytes);
    if (in.gcount() != static_cast<std::streamsize>(kHeaderBytes))
        throw Error("not a PVS file: shorter than its 64-byte header (truncated?)", Where::in_file(path));
    if (std::memcmp(header, kMagic, 8) != 0) throw Error("not a PVS file (bad magic)", Where::in_file(path));
    if (get_u32(header + 8) != kVersion)
        throw Error("PVS file version " + std::to_string(get_u32(header + 8)) + " (this tessref reads version " +
                        std::to_string(kVersion) + ")",
                    Where::in_file(path));
    Pvs pvs;
    const std::uint32_t nx = get_u32(header + 12), ny = get_u32(header + 16), nl = get_u32(header + 20);
    if (nx < 1 || ny < 1 || nl < 1 || nx > 65536 || ny > 65536 || nl > 4096)
        throw Error("corrupt PVS file: dimensions " + std::to_string(nx) + " x " + std::to_string(ny) + " x " +
                        std::to_string(nl) + " out of range",
                    Where::in_file(path));
    pvs.patches_x = static_cast<int>(nx);
    pvs.patches_y = static_cast<int>(ny);
    pvs.layers = static_cast<int>(nl);
    pvs.z_lo = std::bit_cast<double>(get_u64(header + 24));
    pvs.z_hi = std::bit_cast<double>(get_u64(header + 32));
    pvs.terrain_id = get_u64(header + 40);
    const std::uint64_t bytes = get_u64(header + 48);
    const long double expected_bits = static_cast<long double>(pvs.cell_count()) * pvs.patch_count();
    if (static_cast<long double>(bytes) != std::ceil(expected_bits / 8.0L))
        throw Error("corrupt PVS file: " + std::to_string(bytes) + " bytes of bits do not fit its dimensions",
                    Where::in_file(path));
    if (!(std::isfinite(pvs.z_lo) && std::isfinite(pvs.z_hi) && pvs.z_lo < pvs.z_hi))
        throw Error("corrupt PVS file: bad layer range", Where::in_file(path));
    pvs.bits.resize(bytes);
    in.read(reinterpret_cast<char*>(pvs.bits.data()), static_cast<std::streamsize>(bytes));
    if (static_cast<std::uint64_t>(in.gcount()) != bytes)
        throw Error("truncated PVS file: " + std::to_string(in.gcount()) + " of " + std::to_string(bytes) +
                        " bytes of bits",
                    Where::in_file(path));
    if (in.peek() != std::char_traits<char>::eof())
        throw Error("corrupt PVS file: bytes after the bits", Where::in_file(path));
    if (checksum(pvs.bits) != get_u64(header + 56))
        throw Error("corrupt PVS file: the bits' checksum does not match", Where::in_file(path));
    return pvs;
}

}  // namespace tessref::geomip
