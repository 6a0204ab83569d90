// tessref/geomipmap.h — geomipmapping with geomorphing (de Boer's geo-mipmapping, as the
// "Terrain Geomorphing in the Vertex Shader" article builds it): the terrain LOD that came
// before hardware tessellation, modelled so it can be measured against it.
//
// THE MAP. A height map of (16a + 1) x (16b + 1) samples is cut into a x b patches of
// 17 x 17 samples; neighbouring patches share their border samples (sample column 16 is
// patch 0's right border and patch 1's left border). Patch (px, py) is patch
// py * patches_x + px; its local sample (i, j), 0 <= i, j <= 16, is map sample
// (16 px + i, 16 py + j).
//
// LEVELS. Level k (0..4) keeps every 2^k-th sample of a patch: level 0 is the full
// 2 x 16 x 16 triangles, level 4 one quad of two triangles. Within a level, each cell of
// step s = 2^k is split along the diagonal from its (low i, low j) corner to its
// (high i, high j) corner, and the ring of cells along the border is the zipper described
// under NEIGHBOURS (with every side at the level's own step it covers the same samples).
//
// PRE-PROCESSING (preprocess). Per patch and level, the "maxerror vertex": the sample whose
// true height is farthest from the level's surface (the level's triangles, heights linear
// in between), with its true height and the level's height there.
//
// SELECTION (select_levels). Each patch's maxerror vertices are projected with the camera:
// the screen error of level k is the pixel distance between the true point and the point
// at the level's height. The patch takes the coarsest level k such that levels 0..k all
// have a screen error <= the bound (level 0's is 0). A vertex at or behind the camera's
// near plane has an unbounded screen error, so such a patch stays at the finest level it
// can prove. The fractional level f = k + t adds the tween toward level k + 1: the fraction
// of the way the bound has gone from level k's error to level k + 1's,
// t = (bound - e_k) / (e_{k+1} - e_k) in [0, 1); a fixed tween (a scene key) replaces t on
// every patch below level 4, so that a frame is reproducible.
//
// NEIGHBOURS (patch_mesh). All levels are chosen first; then, where two patches meet, the
// side is built with the step of the coarser one: the finer patch drops the border samples
// the coarser one does not have and fills the ring of cells along its border with
// "adapting triangles" (a zipper between the border and the patch's inner grid), so there
// is no gap and no T-vertex. Without adaptation (adapt = false) every patch builds its
// borders with its own step: T-vertices appear wherever levels differ (tessref check finds
// them).
//
// GEOMORPHING (build_surface). A patch at fractional level f = k + t is drawn with level
// k's triangles, each vertex moved from its true height toward its height on level k + 1's
// surface by t (GLSL mix: h + t * (target - h)). At t = 0 the mesh is level k; as t -> 1
// every vertex reaches level k + 1's surface, so switching to level k + 1 does not pop
// (vertices that level k + 1 keeps never move). The article's five tween factors are the
// patch's own t for its interior and, for each side, the tween of the side's dictating
// patch: of the two patches that share a side, the one with the larger fractional level
// (the coarser) dictates the side's step and tween, so both compute the same border
// vertices and the surface stays closed at every tween. A border vertex that the side's
// next coarser step drops moves toward the middle of its two neighbours on the border.
// The article's tweeningA = (1 - tweeningL) * tweeningI is the weight its vertex shader
// gives a vertex next to a border to blend the border's and the interior's motion; here
// each such vertex reads its own target on level k + 1's surface directly, which is the
// position the article's blend aims at, and tests/test_geomipmap.cpp checks the property
// the factor exists for (no vertex pops when a patch or a neighbour changes level).
//
// LIGHT MAP (light_map; the article's "Building the Mesh" and "Materials"). The mesh changes
// with the levels, so vertex normals would make the light pop; the article lights the
// terrain with one precomputed light map over the whole map instead. Per sample, two vectors
// point from the sample's world position to its neighbours' (+x and +y; at the last column
// or row the vector comes from the neighbour behind, so it still points along +x or +y), and
// their cross product is the normal: with a = (dx, 0, ha) and b = (0, dy, hb) (dx, dy the
// sample spacing, ha, hb the world height differences) n = a x b = (-ha dy, -dx hb, dx dy),
// normalized. The texel is ambient + (1 - ambient) * max(dot(n, l), 0), l the normalized
// direction toward the light.
//
// CULLING (cull_patches; the article's "Optimizations"). Before a frame, patches that cannot
// be seen are not drawn, in the article's steps: (1) the rectangle that covers the view
// frustum's projection onto the ground plane (the xy bounds of its eight corners): a patch
// whose ground rectangle misses it is culled; (2) the patch's bounding box (its samples'
// extent: every level's and every tween's vertices lie between the lowest and the highest
// sample, since they are samples or averages of samples) against the six frustum planes: a
// box wholly outside one plane is culled; (3) a potentially visible set (PVS below). Levels
// are chosen for every patch first, so a visible patch adapts to a culled neighbour exactly
// as without culling, and the surface drawn is the same minus the culled patches.
//
// PVS (build_pvs; the article's "Optimizations", after Airey and Teller). Cells are the
// patches' ground rectangles times `layers` (32) layers of equal height from the lowest
// sample up to three times the terrain's height above it. Patch P is potentially visible
// from cell C when a line of sight from one of C's sample points (3 x 3 x 3 in the cell, at
// the centres of its thirds) to one of P's targets (its box top, the highest sample, at a
// fixed step) meets no triangle of the occluder: the lower bounds of surface_bounds ("the
// low blocks", under every level's and tween's surface), eroded by the targets' spacing
// and lowered by a margin; a cell with a sample point at or under surface_bounds' upper
// bound keeps every patch. Conservative at the sample points: a camera at one loses no
// pixel whatever the levels (docs/GEOMIPMAP.md has the argument); a camera between them may
// see a patch through a gap that no sampled line passes.
//
// OUTPUT. build_surface returns a SurfaceMesh (mesh.h): per patch in patch order, the
// patch's vertices (patch_mesh's order) and triangles, counter-clockwise seen from +z.
// Map sample (x, y) stands at world (origin + (x, y) * spacing, height * scale_z), plane xy
// with z up; uv = map sample / (map size - 1) (the article's one lightmap over the whole
// terrain); tess_coords = (i / 16, j / 16, 0).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace tessref {
struct SurfaceMesh;  // mesh.h: build_surface's result
}  // namespace tessref

namespace tessref::geomip {

constexpr int kPatchCells = 16;  // a patch is 17 x 17 samples
constexpr int kLevels = 5;       // levels 0..4

// Heights of the map, row-major: sample (x, y) at y * width + x.
struct HeightSamples {
    int width = 0;
    int height = 0;
    std::vector<double> samples;
    double at(int x, int y) const { return samples[static_cast<std::size_t>(y) * width + x]; }
    int patches_x() const { return (width - 1) / kPatchCells; }
    int patches_y() const { return (height - 1) / kPatchCells; }
};

// Throws tessref::Error unless width and height are 16a + 1 with a >= 1 and every sample
// is finite.
void validate(const HeightSamples& map);

struct MaxErrorVertex {
    glm::ivec2 sample{0, 0};   // local sample (i, j)
    double true_height = 0.0;
    double level_height = 0.0; // the level's surface there
    double error() const { return true_height > level_height ? true_height - level_height : level_height - true_height; }
};

// Per patch (patch order), per level.
using MaxErrors = std::vector<std::array<MaxErrorVertex, kLevels>>;
MaxErrors preprocess(const HeightSamples& map);

// Sides in counter-clockwise order seen from +z: 0 bottom (j = 0), 1 right (i = 16),
// 2 top (j = 16), 3 left (i = 0).
using SideSteps = std::array<int, 4>;

// One patch's triangulation at `level` with the given border step on each side (each a
// power of two >= 2^level and <= 16). Vertices: the local samples used, row by row
// (j, then i ascending); triangles counter-clockwise seen from +z.
struct PatchMesh {
    std::vector<glm::ivec2> vertices;
    std::vector<std::array<std::uint32_t, 3>> triangles;
};
PatchMesh patch_mesh(int level, const SideSteps& side_steps);

// What a scene chooses ([evaluation] model = "geomipmap": data/scenes/README.md).
struct Params {
    double error_bound_px = 1.0;   // the screen error a level may have
    bool adapt = true;             // adapting triangles toward coarser neighbours
    std::optional<double> tween;   // replaces every patch's tween (in [0, 1])
    // Forces every patch to this level (0..4) instead of selecting by error_bound_px: the
    // uniform level of a geomipmapped terrain (`tessref sweep`'s geomip_level rows). Each
    // patch's fractional level is then level + tween (the fixed tween, 0 without one; 0 at
    // level 4).
    std::optional<int> level;
};

struct Settings {
    glm::dvec2 origin{0.0};        // world x, y of map sample (0, 0)
    glm::dvec2 spacing{1.0};       // world distance between neighbouring samples
    double scale_z = 1.0;
    Params params{};
};

// Fractional level per patch (patch order); with params.level, that level (plus the fixed
// tween) on every patch, whatever the camera. view_projection maps world positions (as
// build_surface places them) to clip space; viewport is the image size in pixels.
std::vector<double> select_levels(const HeightSamples& map, const MaxErrors& max_errors, const Settings& settings,
                                  const glm::dmat4& view_projection, glm::ivec2 viewport);

// The fractional level that dictates side `side` of patch (px, py) (SideSteps order): the
// larger of the patch's and the neighbour's across that side; the patch's own at the map's
// edge or without adaptation. Both patches of a side get the same value, as both patches of
// a tessellated edge compute the same outer level.
double side_level(const std::vector<double>& levels, int patches_x, int patches_y, int px, int py, int side,
                  bool adapt);

// What the geomorphing vertex shader (data/shaders/geomip_terrain.vert) reads of a vertex
// besides its ground position: its true height, its target on the next coarser level's
// surface and the tween that drives it (the patch's own, or its side's dictating one), all
// in map heights (before scale_z). build_surface's z is (height + tween (target - height))
// * scale_z, in double.
struct MorphVertex {
    double height = 0.0;
    double target = 0.0;
    double tween = 0.0;
};

// The mesh of the whole map at the given fractional levels (each in [0, 4]). With `morph`,
// also each vertex's MorphVertex (one per mesh vertex, in mesh order).
SurfaceMesh build_surface(const HeightSamples& map, const std::vector<double>& levels, const Settings& settings,
                          std::vector<MorphVertex>* morph = nullptr);

// The vertex shader's world height in float, as llvmpipe computes it (GLSL mix(x, y, a) is
// x + a * (y - x)): mix(sampleHeight, morphTarget, tween) * scaleZ (geomip_terrain.vert).
// The gpu precision's vertex buffer holds this z.
float morph_height(float sampleHeight, float morphTarget, float tween, float scaleZ);

// Bounds on the drawn surface over each sample square (x, y) to (x + 1, y + 1), row-major,
// (width - 1) x (height - 1), in map heights (before scale_z): whatever the patch's level,
// its sides' steps and all tweens, every point of the drawn surface over the square lies in
// [lo, hi]. From every topology (level, side steps) the triangles' vertices, each at its
// sample height or its tween target (a vertex's height is affine in its one tween, so the
// extremes are at tween 0 or 1); a triangle bounds every square its box meets.
struct SurfaceBounds {
    std::vector<double> lo;
    std::vector<double> hi;
};
SurfaceBounds surface_bounds(const HeightSamples& map);

// ---- the light map -------------------------------------------------------------------

struct LightMapParams {
    glm::dvec3 light_direction{-0.5, 0.4, 0.75};  // toward the light; normalized before use
    double ambient = 0.3;                         // in [0, 1]
};
// The normal at sample (x, y) from the cross product of the two neighbour vectors (LIGHT MAP).
glm::dvec3 sample_normal(const HeightSamples& map, glm::dvec2 spacing, double scale_z, int x, int y);
// One light value per sample, row-major as the map. Throws tessref::Error for a light
// direction that cannot be normalized or an ambient outside [0, 1].
std::vector<double> light_map(const HeightSamples& map, glm::dvec2 spacing, double scale_z,
                              const LightMapParams& params);

// ---- culling -------------------------------------------------------------------------

struct Box {
    glm::dvec3 lo{0.0};
    glm::dvec3 hi{0.0};
};
// Per patch (patch order): the world box of its samples (x, y from its corners, z from its
// lowest and highest sample).
std::vector<Box> patch_bounds(const HeightSamples& map, const Settings& settings);

enum class Cull : std::uint8_t { visible, ground_rectangle, frustum_planes, pvs };
// Steps (1) and (2) of CULLING for the camera whose view-projection (GL clip space) is
// given: per patch, visible or the step that culled it. The tests are conservative by a
// relative margin of 1e-6 (float clip coordinates on the rasterizer's side).
std::vector<Cull> cull_frustum(const std::vector<Box>& boxes, const glm::dmat4& view_projection);

// ---- the potentially visible set -----------------------------------------------------

struct Pvs {
    static constexpr int kDefaultLayers = 32;
    int patches_x = 0;
    int patches_y = 0;
    int layers = 0;
    double z_lo = 0.0;   // the bottom of layer 0 (world height)
    double z_hi = 0.0;   // the top of the last layer
    std::uint64_t terrain_id = 0;  // terrain_identity() of the terrain it was built for
    // One bit per (cell, patch): cell c = (layer * patches_y + py) * patches_x + px, bit
    // c * patch_count + patch, least significant bit first within each byte.
    std::vector<std::uint8_t> bits;

    std::size_t patch_count() const { return static_cast<std::size_t>(patches_x) * patches_y; }
    std::size_t cell_count() const { return patch_count() * static_cast<std::size_t>(layers); }
    bool visible(std::size_t cell, std::size_t patch) const {
        const std::size_t b = cell * patch_count() + patch;
        return (bits[b / 8] >> (b % 8)) & 1u;
    }
    // The cell holding a world point; nullopt outside the cells (no PVS applies there).
    std::optional<std::size_t> cell_of(const glm::dvec3& p, const Settings& settings) const;
};

// A 64-bit FNV-1a digest of what the set depends on: the map's size and samples, and the
// world placement (origin, spacing, scale_z). A PVS of another terrain does not apply.
std::uint64_t terrain_identity(const HeightSamples& map, const Settings& settings);

// The world point of sample (sx, sy, sz) (each 0..2, thirds' centres) of cell `cell`.
glm::dvec3 pvs_cell_point(const Pvs& pvs, const Settings& settings, std::size_t cell, int sx, int sy, int sz);

// Builds the set (PVS above). `target_step` is the step between a patch's target samples (a
// divisor of 16). progress(done cells, all cells) from worker threads, serialized; may be
// empty. Deterministic whatever the thread count.
Pvs build_pvs(const HeightSamples& map, const Settings& settings, int layers = Pvs::kDefaultLayers,
              int target_step = 4, const std::function<void(std::size_t, std::size_t)>& progress = {});

// The set one cell at a time (what build_pvs does for every cell): the occluder and the
// targets are built once by the constructor; row(cell) is thread-safe. Lets a caller (a
// test) check chosen cells without building the whole set.
class PvsBuilder {
public:
    // Throws tessref::Error as build_pvs does for bad arguments.
    PvsBuilder(const HeightSamples& map, const Settings& settings, int layers = Pvs::kDefaultLayers,
               int target_step = 4);
    ~PvsBuilder();
    PvsBuilder(const PvsBuilder&) = delete;
    PvsBuilder& operator=(const PvsBuilder&) = delete;
    // The set's dimensions, layer range and terrain identity; no bits.
    const Pvs& layout() const;
    // One byte per patch (patch order): 1 when the patch is potentially visible from `cell`.
    std::vector<std::uint8_t> row(std::size_t cell) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// The file: a 64-byte little-endian header, then the bits.
//   0  magic "TRPVS\0\r\n" (8 bytes)   8  version (u32) = 1     12 patches_x (u32)
//   16 patches_y (u32)                   20 layers (u32)          24 z_lo (f64)
//   32 z_hi (f64)                        40 terrain_id (u64)      48 bit bytes (u64)
//   56 FNV-1a 64 of the bit bytes (u64)  64 the bits
// write_pvs writes `path` as it is (`tessref pvs` gives it a temporary name and renames it
// into place, never leaving a partial file). read_pvs
// throws tessref::Error naming the file for a bad magic or version, a truncated or longer
// file, a size that does not match the dimensions, or a checksum mismatch.
void write_pvs(const Pvs& pvs, const std::string& path);
Pvs read_pvs(const std::string& path);

}  // namespace tessref::geomip
