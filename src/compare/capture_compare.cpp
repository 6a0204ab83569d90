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
    std::uint32_t index = 0;               // triangle index in the capture
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

std::vector<Triangle> sorted_triangles(const Capture& capture, const char* side) {
    const std::vector<CapturedVertex>& v = capture.vertices;
    const Where where = Where::in_file(capture.source);
    const std::string name = capture.source.empty() ? std::string(side) : capture.source;
    if (v.size() % 3 != 0)
        throw Error("the " + std::string(side) + " capture has " + std::to_string(v.size()) +
                        " vertices, not whole triangles",
                    where);
    const std::size_t n = v.size() / 3;
    require_memory(saturating_bytes(n, sizeof(Triangle)), "comparing " + std::to_string(n) + " triangles of " + name,
                   where);
    if (n > 0xffffffffu) throw Error("more triangles than a comparison can number", where);
    std::vector<Triangle> triangles(n);
    for (std::size_t t = 0; t < n; ++t) {
        Triangle& tri = triangles[t];
        tri.patch = v[3 * t].patch_id;
        tri.index = static_cast<std::uint32_t>(t);
        if (v[3 * t + 1].patch_id != tri.patch || v[3 * t + 2].patch_id != tri.patch)
            throw Error("triangle " + std::to_string(t) + " of the " + side + " capture has corners of two patches",
                        Where::at_patch(capture.source, tri.patch));
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
    parallel_sort(triangles.begin(), triangles.end());  // a total order (index last): any thread count, one result
    return triangles;
}

struct PatchRange {
    std::size_t begin = 0, end = 0;
    std::size_t size() const { return end - begin; }
};

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

void add_to(ComponentSummary& s, std::uint64_t ulps, double abs, bool beyond) {
    ++s.compared;
    s.max_ulps = std::max(s.max_ulps, ulps);
    s.max_abs = std::max(s.max_abs, abs);
    s.sum_abs += abs;
    s.beyond += beyond;
}

class Comparison {
public:
    Comparison(const Capture& reference, const Capture& test, const CaptureCompareOptions& options)
        : ref_(reference), test_(test), options_(options),
          ref_tris_(sorted_triangles(reference, "reference")), test_tris_(sorted_triangles(test, "test")) {}

    CaptureCompareResult run() {
        std::size_t i = 0, j = 0;
        while (i < ref_tris_.size() || j < test_tris_.size()) {
            const std::uint32_t rp = i < ref_tris_.size() ? ref_tris_[i].patch : UINT32_MAX;
            const std::uint32_t tp = j < test_tris_.size() ? test_tris_[j].patch : UINT32_MAX;
            const bool in_ref = i < ref_tris_.size() && (j >= test_tris_.size() || rp <= tp);
            const bool in_test = j < test_tris_.size() && (i >= ref_tris_.size() || tp <= rp);
            const std::uint32_t patch = in_ref ? rp : tp;
            PatchRange r{i, i}, t{j, j};
            if (in_ref) r.end = i = patch_end(ref_tris_, i);
            if (in_test) t.end = j = patch_end(test_tris_, j);
            result_.reference_patches += in_ref;
            result_.test_patches += in_test;
            compare_patch(patch, r, t);
        }
        result_.passed = result_.diverging_patches() == 0;
        return std::move(result_);
    }

private:
    static std::size_t patch_end(const std::vector<Triangle>& tris, std::size_t begin) {
        std::size_t end = begin;
        while (end < tris.size() && tris[end].patch == tris[begin].patch) ++end;
        return end;
    }

    const CapturedVertex& ref_vertex(const Triangle& t, int k) const { return ref_.vertices[3 * t.index + t.corner[k]]; }
    const CapturedVertex& test_vertex(const Triangle& t, int k) const {
        return test_.vertices[3 * t.index + t.corner[k]];
    }

    void list(const DivergingPatch& d) {
        if (result_.listed.size() < options_.max_listed) result_.listed.push_back(d);
    }

    void compare_patch(std::uint32_t patch, PatchRange r, PatchRange t) {
        DivergingPatch d;
        d.patch_id = patch;
        d.reference_vertices = 3 * r.size();
        d.test_vertices = 3 * t.size();
        if (r.size() == 0 || t.size() == 0) {
            d.kind = r.size() == 0 ? PatchDivergence::missing_in_reference : PatchDivergence::missing_in_test;
            ++(r.size() == 0 ? result_.missing_in_reference : result_.missing_in_test);
            const Triangle& any = r.size() ? ref_tris_[r.begin] : test_tris_[t.begin];
            d.tess_coord = vec_of(any.keys[0]);
            d.tess_coord_in_reference = r.size() != 0;
            if (r.size() && ref_.has_levels) d.reference_levels = ref_vertex(any, 0).levels;
            if (t.size() && test_.has_levels) d.test_levels = test_vertex(any, 0).levels;
            list(d);
            return;
        }

        // The multisets of tess coords.
        std::vector<Bits> ref_keys, test_keys;
        bool triangles_domain = false;
        for (const auto& [range, tris, keys] :
             {std::tuple{r, &ref_tris_, &ref_keys}, std::tuple{t, &test_tris_, &test_keys}}) {
            keys->reserve(3 * range.size());
            for (std::size_t k = range.begin; k < range.end; ++k)
                for (const Bits& b : (*tris)[k].keys) {
                    keys->push_back(b);
                    triangles_domain = triangles_domain || std::bit_cast<float>(b[2]) != 0.0f;
                }
            std::sort(keys->begin(), keys->end());
        }
        d.levels_known = ref_.has_levels && test_.has_levels;
        d.reference_levels = ref_vertex(ref_tris_[r.begin], 0).levels;
        d.test_levels = test_vertex(test_tris_[t.begin], 0).levels;
        if (d.levels_known) d.level_ulps = level_ulps(d.reference_levels, d.test_levels, triangles_domain);
        if (ref_keys != test_keys) {
            d.kind = PatchDivergence::tess_coords;
            ++result_.tess_coord_divergences;
            if (d.levels_known && d.level_ulps == 0) ++result_.tess_coord_divergences_with_equal_levels;
            // The smallest tess coord one side has more often than the other.
            std::size_t a = 0, b = 0;
            while (a < ref_keys.size() && b < test_keys.size() && ref_keys[a] == test_keys[b]) ++a, ++b;
            d.tess_coord_in_reference = b == test_keys.size() || (a < ref_keys.size() && ref_keys[a] < test_keys[b]);
            d.tess_coord = vec_of(d.tess_coord_in_reference ? ref_keys[a] : test_keys[b]);
            list(d);
            return;
        }

        // The triangles, as sets of tess coords.
        for (std::size_t k = 0; k < r.size(); ++k) {
            const Triangle &a = ref_tris_[r.begin + k], &b = test_tris_[t.begin + k];
            if (a.keys == b.keys) continue;
            d.kind = PatchDivergence::triangles;
            ++result_.triangle_divergences;
            const int c = a.keys[0] != b.keys[0] ? 0 : a.keys[1] != b.keys[1] ? 1 : 2;
            d.tess_coord = vec_of(a.keys[c]);
            list(d);
            return;
        }

        // The way round of each triangle's corners.
        for (std::size_t k = 0; k < r.size(); ++k) {
            const Triangle &a = ref_tris_[r.begin + k], &b = test_tris_[t.begin + k];
            if (a.odd < 0 || a.odd == b.odd) continue;
            if (d.flipped_triangles++ == 0) d.tess_coord = vec_of(a.keys[0]);
        }
        if (d.flipped_triangles) {
            d.kind = PatchDivergence::orientation;
            ++result_.orientation_divergences;
            result_.flipped_triangles += d.flipped_triangles;
            list(d);
            return;
        }

        // Positions and normals, corner by corner.
        ++result_.compared_patches;
        d.kind = PatchDivergence::values;
        for (std::size_t k = 0; k < r.size(); ++k) {
            const Triangle &a = ref_tris_[r.begin + k], &b = test_tris_[t.begin + k];
            for (int c = 0; c < 3; ++c) {
                const CapturedVertex &rv = ref_vertex(a, c), &tv = test_vertex(b, c);
                int position_component = 0, normal_component = 0;
                const std::uint64_t pu = worst_component(rv.position, tv.position, position_component);
                const std::uint64_t nu = worst_component(rv.normal, tv.normal, normal_component);
                ++result_.vertices_compared;
                for (int k = 0; k < 3; ++k)
                    add_to(result_.components[static_cast<std::size_t>(k)], ulp_distance(rv.position[k], tv.position[k]),
                           abs_difference(rv.position[k], tv.position[k]),
                           !component_within(rv.position[k], tv.position[k], options_.max_position_ulps,
                                             options_.max_position_abs));
                double normal_abs = 0.0;
                bool normal_beyond = false;
                for (int k = 0; k < 3; ++k) {
                    normal_abs = std::max(normal_abs, abs_difference(rv.normal[k], tv.normal[k]));
                    normal_beyond |= !component_within(rv.normal[k], tv.normal[k], options_.max_normal_ulps,
                                                       options_.max_normal_abs);
                }
                add_to(result_.components[3], nu, normal_abs, normal_beyond);
                track(result_.worst_position, pu, position_component, rv.position, tv.position, rv);
                track(result_.worst_normal, nu, normal_component, rv.normal, tv.normal, rv);
                if (within(rv.position, tv.position, options_.max_position_ulps, options_.max_position_abs) &&
                    within(rv.normal, tv.normal, options_.max_normal_ulps, options_.max_normal_abs))
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
        if (d.failing_vertices == 0) return;
        ++result_.value_divergences;
        result_.failing_vertices += d.failing_vertices;
        result_.failing_vertices_per_patch.emplace_back(patch, d.failing_vertices);
        list(d);
    }

    static void track(WorstUlps& worst, std::uint64_t ulps, int component, const glm::vec3& reference,
                      const glm::vec3& test, const CapturedVertex& where) {
        if (worst.found && ulps <= worst.ulps) return;
        worst.found = true;
        worst.ulps = ulps;
        worst.patch_id = where.patch_id;
        worst.tess_coord = where.tess_coord;
        worst.component = component;
        worst.reference = reference;
        worst.test = test;
    }

    const Capture& ref_;
    const Capture& test_;
    const CaptureCompareOptions& options_;
    std::vector<Triangle> ref_tris_, test_tris_;
    CaptureCompareResult result_;
};

}  // namespace

CaptureCompareResult compare_captures(const Capture& reference, const Capture& test,
                                      const CaptureCompareOptions& options) {
    return Comparison(reference, test, options).run();
}

}  // namespace tessref
