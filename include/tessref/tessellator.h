// tessref/tessellator.h — the fixed-function primitive generator.
//
// Given the layout of a tessellation evaluation shader (domain, spacing, winding,
// point mode) and the six levels a control shader wrote (gl_TessLevelOuter[4],
// gl_TessLevelInner[2], GL order), tessellate() returns an immutable Pattern: the
// domain points (gl_TessCoord) and the primitives that connect them.
//
// Two precisions:
//  - Precision::gpu reproduces, bit for bit, the D3D11-style generator that GPUs and
//    Mesa's llvmpipe run: levels rounded to 16.16 fixed point, a reciprocal table,
//    fixed-point lerps. tests/test_gl_differential.cpp holds it to llvmpipe.
//  - Precision::exact has the same topology (same points in the same order, same
//    primitives) but computes every position in double without fixed-point
//    quantization: the triangle centre is exactly 1/3, a level of 3.3 is 3.3.
//
// Point order (documented because users index into it):
//  - quads: the outer ring first, edge by edge: edge 0 (u = 0, v from 1 to 0), edge 1
//    (v = 0, u from 0 to 1), edge 2 (u = 1, v from 0 to 1), edge 3 (v = 1, u from 1 to 0),
//    each edge without its last point (the next edge starts there); then each inner
//    ring, outside in, in the same edge order; then, when the smaller inner axis has
//    even parity, the middle row (v = 0.5, u ascending) or column (u = 0.5, v descending).
//  - triangles: the outer ring, edge 0 (u = 0, v from 1 to 0), edge 1 (v = 0, u from 0
//    to 1), edge 2 (w = 0, u from 1 to 0); then inner rings outside in; then, for even
//    inner parity, the centre (1/3, 1/3, 1/3).
//  - isolines: line by line (v ascending, the v = 1 line is never drawn), each line
//    with u ascending.
//  - the minimal patch (every level exactly 1, equal or fractional_odd spacing): quads
//    (0,0), (1,0), (1,1), (0,1); triangles (0,1,0), (0,0,1), (1,0,0) as (u,v,w).
// Primitives are triangles (3 indices, wound as the winding asks), line segments
// (2 indices) or, in point mode, every point once in generation order.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace tessref {

enum class Domain : std::uint8_t { quads, triangles, isolines };
enum class Spacing : std::uint8_t { equal, fractional_odd, fractional_even };
enum class Winding : std::uint8_t { ccw, cw };
enum class Precision : std::uint8_t { gpu, exact };

// Names as GLSL's layout qualifiers spell them ("quads", "fractional_odd", "ccw");
// Precision as "gpu" / "exact". parse_* return nullopt for an unknown name.
std::string_view to_string(Domain d);
std::string_view to_string(Spacing s);
std::string_view to_string(Winding w);
std::string_view to_string(Precision p);
std::optional<Domain> parse_domain(std::string_view name);
std::optional<Spacing> parse_spacing(std::string_view name);
std::optional<Winding> parse_winding(std::string_view name);
std::optional<Precision> parse_precision(std::string_view name);

// gl_TessLevelOuter / gl_TessLevelInner, GL order. Any float is valid: NaN, infinities
// and negatives are handled exactly as the hardware handles them (cull or clamp).
struct TessLevels {
    std::array<float, 4> outer{1.0f, 1.0f, 1.0f, 1.0f};
    std::array<float, 2> inner{1.0f, 1.0f};
};

// The layout(...) of a tessellation evaluation shader.
struct TessSettings {
    Domain domain = Domain::quads;
    Spacing spacing = Spacing::equal;
    Winding winding = Winding::ccw;
    bool point_mode = false;
};

// gl_TessCoord. w = (1 - u) - v for triangles (computed in the same precision), 0 otherwise.
template <typename T>
struct DomainPoint {
    T u, v, w;
};
using TessCoord = DomainPoint<float>;
using TessCoordExact = DomainPoint<double>;

class Pattern {
public:
    const TessSettings& settings() const { return settings_; }
    const TessLevels& levels() const { return levels_; }  // as given, before any clamping
    Precision precision() const { return precision_; }

    // True when an outer level the domain uses is NaN or <= 0: nothing is emitted.
    bool culled() const { return culled_; }

    // The domain points in the documented order, as floats (what gl_TessCoord holds).
    std::span<const TessCoord> points() const { return points_; }
    // The same points as doubles: for Precision::gpu the floats widened, for
    // Precision::exact the unquantized positions (points() are these rounded to float).
    std::span<const TessCoordExact> points_exact() const { return points_exact_; }

    // 3 for triangles, 2 for isolines, 1 in point mode.
    int vertices_per_primitive() const { return vertices_per_primitive_; }
    std::span<const std::uint32_t> indices() const { return indices_; }
    std::size_t primitive_count() const { return indices_.size() / vertices_per_primitive_; }
    std::span<const std::uint32_t> primitive(std::size_t i) const {
        return std::span<const std::uint32_t>(indices_).subspan(i * vertices_per_primitive_,
                                                                vertices_per_primitive_);
    }

    // The levels after the generator's processing (clamped, rounded for equal spacing,
    // picture-frame rule applied), as floats; for isolines outer[0] is the density.
    const TessLevels& effective_levels() const { return effective_levels_; }

private:
    friend class PatternBuilder;
    TessSettings settings_{};
    TessLevels levels_{};
    TessLevels effective_levels_{};
    Precision precision_ = Precision::gpu;
    bool culled_ = false;
    int vertices_per_primitive_ = 3;
    std::vector<TessCoord> points_;
    std::vector<TessCoordExact> points_exact_;
    std::vector<std::uint32_t> indices_;
};

// Runs the primitive generator. Never throws on any level value; the result depends
// only on the arguments.
Pattern tessellate(const TessSettings& settings, const TessLevels& levels,
                   Precision precision = Precision::gpu);

// The largest |coordinate difference| between corresponding points of two patterns of
// the same inputs (same topology); used to report how far gpu is from exact.
double max_point_difference(const Pattern& a, const Pattern& b);

// ---------------------------------------------------------------------------------------
// Queries on levels and tess coords, answered without tessellating
// ---------------------------------------------------------------------------------------

// The exact bits of the six levels, outer then inner: two level sets give the same pattern
// (for the same settings and precision) exactly when their keys are equal. -0 and +0, or
// two NaNs with different payloads, get different keys; they tessellate alike, so the only
// cost is a pattern made twice.
using LevelBits = std::array<std::uint32_t, 6>;
LevelBits level_bits(const TessLevels& levels);

// Whether a tess coord lies on outer edge `edge` of its patch (gl_TessLevelOuter index;
// quads: u == 0, v == 0, u == 1, v == 1; triangles: u == 0, v == 0, w == 0).
// Inline: the renderer asks it for every visible pixel's triangle.
inline bool on_outer_edge(Domain domain, const TessCoord& c, int edge) {
    switch (edge) {
        case 0: return c.u == 0.0f;
        case 1: return c.v == 0.0f;
        case 2: return domain == Domain::quads ? c.u == 1.0f : c.w == 0.0f;
        case 3: return domain == Domain::quads && c.v == 1.0f;
    }
    return false;
}

// An upper bound on the triangles the primitive generator emits for these levels (0 for a
// culled patch, and for isolines), without tessellating: used to refuse a run beyond its
// budget before any memory is spent on it.
std::uint64_t estimate_triangles(const TessSettings& settings, const TessLevels& levels);

// A thread-safe cache of patterns keyed by the exact bits of their inputs: a terrain of
// thousands of patches that share a few level sets tessellates each set once.
class PatternCache {
public:
    std::shared_ptr<const Pattern> get(const TessSettings& settings, const TessLevels& levels,
                                       Precision precision = Precision::gpu);
    std::size_t size() const;
    std::size_t hits() const;
    std::size_t misses() const;

private:
    struct Key {
        LevelBits level_bits;
        std::uint32_t mode;
        bool operator==(const Key&) const = default;
    };
    struct KeyHash {
        std::size_t operator()(const Key& k) const noexcept;
    };
    mutable std::mutex mutex_;
    std::unordered_map<Key, std::shared_ptr<const Pattern>, KeyHash> map_;
    std::size_t hits_ = 0;
    std::size_t misses_ = 0;
};

}  // namespace tessref
