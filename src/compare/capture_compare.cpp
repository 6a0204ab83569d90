// compare_captures (tessref/capture.h): two captures, patch by patch, in ulps.
//
// Each side's triangles are sorted by (patch, the bits of their three tess coords in
// ascending order): both sides' triangles of a patch then line up whatever order the
// generator, transform feedback or a re-orientation put them in, and corners are matched
// by tess coord within a triangle.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <tuple>
#include <vector>

#include "common/parallel.h"
#include "tessref/capture.h"
#include "tessref/error.h"
#include "tessref/limits.h"

namespace tessref {

std::uint64_t ulp_distance(float a, float b) {
    if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b) ? 0 : kInfiniteUlps;
    // Sign and magnitude to a line of integers: -0 and +0 both 0, -x at -bits(x).
    const auto ordered = [](float f) {
        const auto bits = std::bit_cast<std::int32_t>(f);
        return bits < 0 ? -static_cast<std::int64_t>(bits & 0x7fffffff) : static_cast<std::int64_t>(bits);
    };
    const std::int64_t d = ordered(a) - ordered(b);
    return static_cast<std::uint64_t>(d < 0 ? -d : d);
}

const char* to_string(PatchDivergence kind) {
    switch (kind) {
        case PatchDivergence::missing_in_test: return "missing in test";
        case PatchDivergence::missing_in_reference: return "missing in reference";
        case PatchDivergence::tess_coords: return "tess coords";
        case PatchDivergence::triangles: return "triangles";
        case PatchDivergence::orientation: return "orientation";
        case PatchDivergence::values: return "values";
    }
    return "?";
}

namespace {

using Bits = std::array<std::uint32_t, 3>;
Bits bits_of(const glm::vec3& v) {
    return {std::bit_cast<std::uint32_t>(v.x), std::bit_cast<std::uint32_t>(v.y), std::bit_cast<std::uint32_t>(v.z)};
}
glm::vec3 vec_of(const Bits& b) {
    return {std::bit_cast<float>(b[0]), std::bit_cast<float>(b[1]), std::bit_cast<float>(b[2])};
}

// One triangle of a capture, its corners sorted by tess-coord bits.
struct Triangle {
    std::uint32_t patch = 0;
    std::array<Bits, 3> keys{};
    std::uint32_t index = 0;               // triangle index in the vertices it was made from
    std::array<std::uint8_t, 3> corner{};  // the capture's corner of keys[k]
    // The capture's corners run the other way round than the sorted keys (the permutation
    // `corner` is odd); -1 when two keys are equal (a degenerate triangle has no way round).
    int odd = -1;

    bool operator<(const Triangle& o) const {
        if (patch != o.patch) return patch < o.patch;
        if (keys != o.keys) return keys < o.keys;
        return index < o.index;
    }
};

// The triangles of `v` (whole triangles), unsorted; `first_triangle` numbers the first one
// in messages (its place in the whole capture).
std::vector<Triangle> triangles_of(std::span<const CapturedVertex> v, std::size_t first_triangle,
                                   const std::string& source, const char* side) {
    const std::size_t n = v.size() / 3;
    std::vector<Triangle> triangles(n);
    for (std::size_t t = 0; t < n; ++t) {
        Triangle& tri = triangles[t];
        tri.patch = v[3 * t].patch_id;
        tri.index = static_cast<std::uint32_t>(t);
        if (v[3 * t + 1].patch_id != tri.patch || v[3 * t + 2].patch_id != tri.patch)
            throw Error("triangle " + std::to_string(first_triangle + t) + " of the " + side +
                            " capture has corners of two patches",
                        Where::at_patch(source, tri.patch));
        std::array<std::uint8_t, 3> order{0, 1, 2};
        std::array<Bits, 3> keys{bits_of(v[3 * t].tess_coord), bits_of(v[3 * t + 1].tess_coord),
                                 bits_of(v[3 * t + 2].tess_coord)};
        std::sort(order.begin(), order.end(), [&](std::uint8_t a, std::uint8_t b) { return keys[a] < keys[b]; });
        for (int k = 0; k < 3; ++k) {
            tri.keys[k] = keys[order[k]];
            tri.corner[k] = order[k];
        }
        // A permutation of three is even exactly when it is a rotation: 012, 120, 201.
        if (tri.keys[0] != tri.keys[1] && tri.keys[1] != tri.keys[2])
            tri.odd = (order[1] + 3 - order[0]) % 3 == 1 ? 0 : 1;
    }
    return triangles;
}

// A capture's count of vertices must be whole triangles, and its triangles numbered in 32 bits.
void check_whole_triangles(std::size_t vertices, const std::string& source, const char* side) {
    const Where where = Where::in_file(source);
    const std::string name = source.empty() ? std::string(side) : source;
    if (vertices % 3 != 0)
        throw Error("the " + std::string(side) + " capture has " + std::to_string(vertices) +
                        " vertices, not whole triangles",
                    where);
    const std::size_t n = vertices / 3;
    require_memory(saturating_bytes(n, sizeof(Triangle)), "comparing " + std::to_string(n) + " triangles of " + name,
                   where);
    if (n > 0xffffffffu) throw Error("more triangles than a comparison can number", where);
}

std::vector<Triangle> sorted_triangles(const Capture& capture, const char* side) {
    check_whole_triangles(capture.vertices.size(), capture.source, side);
    std::vector<Triangle> triangles = triangles_of(capture.vertices, 0, capture.source, side);
    tessref::parallel_sort(triangles.begin(), triangles.end());  // a total order (index last): any thread count, one result
    return triangles;
}

// The levels a domain uses: triangles when some tess coord has w != 0 (a quad's w is 0).
std::uint64_t level_ulps(const TessLevels& a, const TessLevels& b, bool triangles) {
    std::uint64_t worst = 0;
    for (int i = 0; i < (triangles ? 3 : 4); ++i) worst = std::max(worst, ulp_distance(a.outer[i], b.outer[i]));
    for (int i = 0; i < (triangles ? 1 : 2); ++i) worst = std::max(worst, ulp_distance(a.inner[i], b.inner[i]));
    return worst;
}

std::uint64_t worst_component(const glm::vec3& a, const glm::vec3& b, int& component) {
    std::uint64_t worst = 0;
    component = 0;
    for (int k = 0; k < 3; ++k) {
        const std::uint64_t d = ulp_distance(a[k], b[k]);
        if (d > worst) {
            worst = d;
            component = k;
        }
    }
    return worst;
}

// Every component within max_ulps, or (when max_abs > 0) within max_abs of the other:
// near zero a float's ulp is tiny, so a few ulps say nothing there.
bool within(const glm::vec3& a, const glm::vec3& b, std::uint64_t max_ulps, double max_abs) {
    for (int k = 0; k < 3; ++k) {
        if (ulp_distance(a[k], b[k]) <= max_ulps) continue;
        if (max_abs > 0.0 && std::abs(static_cast<double>(a[k]) - static_cast<double>(b[k])) <= max_abs) continue;
        return false;
    }
    return true;
}

// |a - b| in double; equal values (the same NaN bits, one infinity twice) 0, a NaN against
// anything else +inf.
double abs_difference(float a, float b) {
    if (ulp_distance(a, b) == 0) return 0.0;
    if (std::isnan(a) || std::isnan(b)) return std::numeric_limits<double>::infinity();
    return std::abs(static_cast<double>(a) - static_cast<double>(b));
}

bool component_within(float a, float b, std::uint64_t max_ulps, double max_abs) {
    return ulp_distance(a, b) <= max_ulps || (max_abs > 0.0 && abs_difference(a, b) <= max_abs);
}

// One side of one patch: its triangles, sorted, and the vertices their indices point into.
struct Side {
    std::span<const Triangle> tris;
    std::span<const CapturedVertex> vertices;
    bool has_levels = true;
    const CapturedVertex& vertex(const Triangle& t, int k) const { return vertices[3 * t.index + t.corner[k]]; }
};

// What one patch adds to the result; patches are compared independently (in parallel) and
// added in patch order (accumulate).
struct PatchOutcome {
    bool in_reference = false, in_test = false;
    bool diverges = false;
    DivergingPatch d;
    bool compared = false;              // same tess coords, triangles and orientation
    bool equal_levels = false;          // a tess-coord divergence with bit-identical known levels
    std::size_t vertices_compared = 0;
    WorstUlps worst_position, worst_normal;
    std::array<ComponentSummary, 4> components;
};

void add_to(ComponentSummary& s, std::uint64_t ulps, double abs, bool beyond) {
    ++s.compared;
    s.max_ulps = std::max(s.max_ulps, ulps);
    s.max_abs = std::max(s.max_abs, abs);
    s.sum_abs += abs;
    s.beyond += beyond;
}

void track(WorstUlps& worst, std::uint64_t ulps, int component, const glm::vec3& reference, const glm::vec3& test,
           const CapturedVertex& where) {
    if (worst.found && ulps <= worst.ulps) return;
    worst.found = true;
    worst.ulps = ulps;
    worst.patch_id = where.patch_id;
    worst.tess_coord = where.tess_coord;
    worst.component = component;
    worst.reference = reference;
    worst.test = test;
}

PatchOutcome compare_patch(std::uint32_t patch, const Side& r, const Side& t, const CaptureCompareOptions& options) {
    PatchOutcome o;
    o.in_reference = !r.tris.empty();
    o.in_test = !t.tris.empty();
    DivergingPatch& d = o.d;
    d.patch_id = patch;
    d.reference_vertices = 3 * r.tris.size();
    d.test_vertices = 3 * t.tris.size();
    if (r.tris.empty() || t.tris.empty()) {
        d.kind = r.tris.empty() ? PatchDivergence::missing_in_reference : PatchDivergence::missing_in_test;
        const Triangle& any = r.tris.size() ? r.tris.front() : t.tris.front();
        d.tess_coord = vec_of(any.keys[0]);
        d.tess_coord_in_reference = !r.tris.empty();
        if (r.tris.size() && r.has_levels) d.reference_levels = r.vertex(any, 0).levels;
        if (t.tris.size() && t.has_levels) d.test_levels = t.vertex(any, 0).levels;
        o.diverges = true;
        return o;
    }

    // Both sides' triangles one and the same (the caller found their tess coords equal,
    // vertex for vertex in the same order): the same multisets, triangles and ways round,
    // so no multiset is built (both stay empty, so equal) and only the values below remain
    // to compare.
    const bool same_triangles = r.tris.data() == t.tris.data() && r.tris.size() == t.tris.size();

    // The multisets of tess coords.
    std::vector<Bits> ref_keys, test_keys;
    bool triangles_domain = false;
    for (const auto& [tris, keys] : {std::pair{r.tris, &ref_keys}, std::pair{t.tris, &test_keys}}) {
        if (!same_triangles) keys->reserve(3 * tris.size());
        for (const Triangle& tri : tris)
            for (const Bits& b : tri.keys) {
                if (!same_triangles) keys->push_back(b);
                triangles_domain = triangles_domain || std::bit_cast<float>(b[2]) != 0.0f;
            }
        std::sort(keys->begin(), keys->end());
        if (same_triangles) break;  // the test's triangles are the reference's
    }
    d.levels_known = r.has_levels && t.has_levels;
    d.reference_levels = r.vertex(r.tris.front(), 0).levels;
    d.test_levels = t.vertex(t.tris.front(), 0).levels;
    if (d.levels_known) d.level_ulps = level_ulps(d.reference_levels, d.test_levels, triangles_domain);
    if (ref_keys != test_keys) {
        d.kind = PatchDivergence::tess_coords;
        o.equal_levels = d.levels_known && d.level_ulps == 0;
        // The smallest tess coord one side has more often than the other.
        std::size_t a = 0, b = 0;
        while (a < ref_keys.size() && b < test_keys.size() && ref_keys[a] == test_keys[b]) ++a, ++b;
        d.tess_coord_in_reference = b == test_keys.size() || (a < ref_keys.size() && ref_keys[a] < test_keys[b]);
        d.tess_coord = vec_of(d.tess_coord_in_reference ? ref_keys[a] : test_keys[b]);
        o.diverges = true;
        return o;
    }

    // The triangles, as sets of tess coords.
    for (std::size_t k = 0; k < r.tris.size() && !same_triangles; ++k) {
        const Triangle &a = r.tris[k], &b = t.tris[k];
        if (a.keys == b.keys) continue;
        d.kind = PatchDivergence::triangles;
        const int c = a.keys[0] != b.keys[0] ? 0 : a.keys[1] != b.keys[1] ? 1 : 2;
        d.tess_coord = vec_of(a.keys[c]);
        o.diverges = true;
        return o;
    }

    // The way round of each triangle's corners.
    for (std::size_t k = 0; k < r.tris.size() && !same_triangles; ++k) {
        const Triangle &a = r.tris[k], &b = t.tris[k];
        if (a.odd < 0 || a.odd == b.odd) continue;
        if (d.flipped_triangles++ == 0) d.tess_coord = vec_of(a.keys[0]);
    }
    if (d.flipped_triangles) {
        d.kind = PatchDivergence::orientation;
        o.diverges = true;
        return o;
    }

    // Positions and normals, corner by corner.
    o.compared = true;
    d.kind = PatchDivergence::values;
    for (std::size_t k = 0; k < r.tris.size(); ++k) {
        const Triangle &a = r.tris[k], &b = t.tris[k];
        for (int c = 0; c < 3; ++c) {
            const CapturedVertex &rv = r.vertex(a, c), &tv = t.vertex(b, c);
            int position_component = 0, normal_component = 0;
            const std::uint64_t pu = worst_component(rv.position, tv.position, position_component);
            const std::uint64_t nu = worst_component(rv.normal, tv.normal, normal_component);
            ++o.vertices_compared;
            for (int k = 0; k < 3; ++k)
                add_to(o.components[static_cast<std::size_t>(k)], ulp_distance(rv.position[k], tv.position[k]),
                       abs_difference(rv.position[k], tv.position[k]),
                       !component_within(rv.position[k], tv.position[k], options.max_position_ulps,
                                         options.max_position_abs));
            double normal_abs = 0.0;
            bool normal_beyond = false;
            for (int k = 0; k < 3; ++k) {
                normal_abs = std::max(normal_abs, abs_difference(rv.normal[k], tv.normal[k]));
                normal_beyond |=
                    !component_within(rv.normal[k], tv.normal[k], options.max_normal_ulps, options.max_normal_abs);
            }
            add_to(o.components[3], nu, normal_abs, normal_beyond);
            track(o.worst_position, pu, position_component, rv.position, tv.position, rv);
            track(o.worst_normal, nu, normal_component, rv.normal, tv.normal, rv);
            if (within(rv.position, tv.position, options.max_position_ulps, options.max_position_abs) &&
                within(rv.normal, tv.normal, options.max_normal_ulps, options.max_normal_abs))
                continue;
            if (d.failing_vertices++ == 0) {
                d.tess_coord = rv.tess_coord;
                d.reference_position = rv.position;
                d.test_position = tv.position;
                d.reference_normal = rv.normal;
                d.test_normal = tv.normal;
                d.position_ulps = pu;
                d.normal_ulps = nu;
            }
        }
    }
    o.diverges = d.failing_vertices != 0;
    return o;
}

// Adds one patch's outcome to the result; patches are added in patch order, so that the
// worst places and the listed patches are the first in patch order.
void accumulate(CaptureCompareResult& result, PatchOutcome& o, const CaptureCompareOptions& options) {
    result.reference_patches += o.in_reference;
    result.test_patches += o.in_test;
    result.compared_patches += o.compared;
    result.vertices_compared += o.vertices_compared;
    for (std::size_t k = 0; k < 4; ++k) {
        ComponentSummary& s = result.components[k];
        const ComponentSummary& p = o.components[k];
        s.compared += p.compared;
        s.max_ulps = std::max(s.max_ulps, p.max_ulps);
        s.max_abs = std::max(s.max_abs, p.max_abs);
        s.sum_abs += p.sum_abs;
        s.beyond += p.beyond;
    }
    for (const auto& [worst, patch] :
         {std::pair{&result.worst_position, &o.worst_position}, std::pair{&result.worst_normal, &o.worst_normal}})
        if (patch->found && (!worst->found || patch->ulps > worst->ulps)) *worst = *patch;
    if (!o.diverges) return;
    switch (o.d.kind) {
        case PatchDivergence::missing_in_test: ++result.missing_in_test; break;
        case PatchDivergence::missing_in_reference: ++result.missing_in_reference; break;
        case PatchDivergence::tess_coords:
            ++result.tess_coord_divergences;
            result.tess_coord_divergences_with_equal_levels += o.equal_levels;
            break;
        case PatchDivergence::triangles: ++result.triangle_divergences; break;
        case PatchDivergence::orientation:
            ++result.orientation_divergences;
            result.flipped_triangles += o.d.flipped_triangles;
            break;
        case PatchDivergence::values:
            ++result.value_divergences;
            result.failing_vertices += o.d.failing_vertices;
            result.failing_vertices_per_patch.emplace_back(o.d.patch_id, o.d.failing_vertices);
            break;
    }
    if (result.listed.size() < options.max_listed) result.listed.push_back(std::move(o.d));
}

}  // namespace

CaptureCompareResult compare_captures(const Capture& reference, const Capture& test,
                                      const CaptureCompareOptions& options) {
    const std::vector<Triangle> ref_tris = sorted_triangles(reference, "reference");
    const std::vector<Triangle> test_tris = sorted_triangles(test, "test");
    // The patches present on either side, in patch order, each with its two ranges.
    struct Pair {
        std::uint32_t patch = 0;
        std::span<const Triangle> r, t;
    };
    std::vector<Pair> pairs;
    const auto patch_end = [](const std::vector<Triangle>& tris, std::size_t begin) {
        std::size_t end = begin;
        while (end < tris.size() && tris[end].patch == tris[begin].patch) ++end;
        return end;
    };
    for (std::size_t i = 0, j = 0; i < ref_tris.size() || j < test_tris.size();) {
        const std::uint32_t rp = i < ref_tris.size() ? ref_tris[i].patch : UINT32_MAX;
        const std::uint32_t tp = j < test_tris.size() ? test_tris[j].patch : UINT32_MAX;
        const bool in_ref = i < ref_tris.size() && (j >= test_tris.size() || rp <= tp);
        const bool in_test = j < test_tris.size() && (i >= ref_tris.size() || tp <= rp);
        Pair p{in_ref ? rp : tp, {}, {}};
        if (in_ref) {
            const std::size_t end = patch_end(ref_tris, i);
            p.r = std::span<const Triangle>(ref_tris).subspan(i, end - i);
            i = end;
        }
        if (in_test) {
            const std::size_t end = patch_end(test_tris, j);
            p.t = std::span<const Triangle>(test_tris).subspan(j, end - j);
            j = end;
        }
        pairs.push_back(p);
    }
    std::vector<PatchOutcome> outcomes(pairs.size());
    tessref::parallel_for(std::size_t{0}, pairs.size(), [&](std::size_t k) {
        outcomes[k] = compare_patch(pairs[k].patch, {pairs[k].r, reference.vertices, reference.has_levels},
                                    {pairs[k].t, test.vertices, test.has_levels}, options);
    });
    CaptureCompareResult result;
    for (PatchOutcome& o : outcomes) accumulate(result, o, options);
    result.passed = result.diverging_patches() == 0;
    return result;
}

// ---- streamed --------------------------------------------------------------------------

struct StreamedCaptureComparison::State {
    CaptureCompareOptions options;
    CaptureCompareResult result;
    bool any = false;
    std::uint32_t last_patch = 0;
    std::size_t reference_triangles = 0, test_triangles = 0;
};

StreamedCaptureComparison::StreamedCaptureComparison(const CaptureCompareOptions& options)
    : state_(std::make_unique<State>()) {
    state_->options = options;
}
StreamedCaptureComparison::~StreamedCaptureComparison() = default;

void StreamedCaptureComparison::add(std::span<const PatchPair> patches) {
    State& s = *state_;
    for (const PatchPair& p : patches) {
        if (s.any && p.patch <= s.last_patch)
            throw Error("the streamed capture comparison was given patch " + std::to_string(p.patch) + " after patch " +
                            std::to_string(s.last_patch) + " (patches come in ascending order, each once)",
                        Where::at_patch(p.patch));
        s.any = true;
        s.last_patch = p.patch;
        check_whole_triangles(p.reference.size(), {}, "reference");
        check_whole_triangles(p.test.size(), {}, "test");
    }
    std::vector<PatchOutcome> outcomes(patches.size());
    std::vector<std::size_t> ref_first(patches.size()), test_first(patches.size());
    for (std::size_t k = 0; k < patches.size(); ++k) {
        ref_first[k] = s.reference_triangles;
        test_first[k] = s.test_triangles;
        s.reference_triangles += patches[k].reference.size() / 3;
        s.test_triangles += patches[k].test.size() / 3;
    }
    tessref::parallel_for(std::size_t{0}, patches.size(), [&](std::size_t k) {
        const PatchPair& p = patches[k];
        // The usual case: llvmpipe gave the patch's vertices in the reference's order, with
        // the same tess coords. Then the test's triangles, sorted, are the reference's
        // (triangles_of makes them from the tess coords and the order alone), made and
        // sorted once for both sides.
        const bool same_order = p.reference.size() == p.test.size() &&
                                std::equal(p.reference.begin(), p.reference.end(), p.test.begin(),
                                           [](const CapturedVertex& a, const CapturedVertex& b) {
                                               return a.patch_id == b.patch_id && bits_of(a.tess_coord) == bits_of(b.tess_coord);
                                           });
        std::vector<Triangle> r = triangles_of(p.reference, ref_first[k], {}, "reference");
        std::vector<Triangle> t = same_order ? std::vector<Triangle>{} : triangles_of(p.test, test_first[k], {}, "test");
        for (const auto& [tris, side] : {std::pair{&r, "reference"}, std::pair{&t, "test"}})
            for (const Triangle& tri : *tris)
                if (tri.patch != p.patch)
                    throw Error("a triangle of patch " + std::to_string(tri.patch) + " among the " + side +
                                    " triangles given as patch " + std::to_string(p.patch),
                                Where::at_patch(p.patch));
        std::sort(r.begin(), r.end());
        std::sort(t.begin(), t.end());
        outcomes[k] = compare_patch(p.patch, {r, p.reference, p.reference_has_levels},
                                    {same_order ? r : t, p.test, p.test_has_levels}, s.options);
    });
    for (PatchOutcome& o : outcomes) accumulate(s.result, o, s.options);
}

CaptureCompareResult StreamedCaptureComparison::finish() {
    State& s = *state_;
    s.result.passed = s.result.diverging_patches() == 0;
    return std::move(s.result);
}

}  // namespace tessref
