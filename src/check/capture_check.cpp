// Captures as meshes to check, and the shared edges two patches tessellated differently
// (tessref/check.h).
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <unordered_map>
#include <vector>

#include "tessref/capture.h"
#include "tessref/check.h"
#include "tessref/error.h"

namespace tessref {

namespace {

using Bits = std::array<std::uint32_t, 3>;  // a float position, bit for bit

Bits bits_of(const glm::vec3& p) {
    return {std::bit_cast<std::uint32_t>(p.x), std::bit_cast<std::uint32_t>(p.y), std::bit_cast<std::uint32_t>(p.z)};
}

struct BitsHash {
    std::size_t operator()(const Bits& b) const {
        std::uint64_t h = 1469598103934665603ull;
        for (const std::uint32_t v : b) h = (h ^ v) * 1099511628211ull;
        return static_cast<std::size_t>(h);
    }
};

// The patches of a capture as runs of whole triangles (a patch may come back in a later run).
struct Run {
    std::uint32_t patch = 0;
    std::size_t begin = 0, end = 0;  // vertices
};
std::vector<Run> runs_of(const Capture& capture) {
    std::vector<Run> runs;
    for (std::size_t i = 0; i < capture.vertices.size(); i += 3) {
        const std::uint32_t patch = capture.vertices[i].patch_id;
        if (runs.empty() || runs.back().patch != patch) runs.push_back({patch, i, i});
        runs.back().end = i + 3;
    }
    return runs;
}

}  // namespace

IndexedMesh weld_capture(const Capture& capture, double weld_tolerance, const std::string& source) {
    if (!(weld_tolerance >= 0.0) || !std::isfinite(weld_tolerance))
        throw Error("the weld tolerance must be a finite distance >= 0", Where::in_file("--weld-tolerance"));
    IndexedMesh mesh;
    mesh.source = source;
    mesh.format = "capture";
    std::vector<std::uint32_t> ids(capture.vertices.size());
    if (weld_tolerance == 0.0) {
        std::unordered_map<Bits, std::uint32_t, BitsHash> seen;
        seen.reserve(capture.vertices.size());
        for (std::size_t i = 0; i < capture.vertices.size(); ++i) {
            const glm::vec3& p = capture.vertices[i].position;
            const auto [it, added] = seen.try_emplace(bits_of(p), static_cast<std::uint32_t>(mesh.positions.size()));
            if (added) {
                mesh.positions.emplace_back(p);
                mesh.patch_ids.push_back(capture.vertices[i].patch_id);
            }
            ids[i] = it->second;
        }
    } else {
        // Cells of the tolerance's size: a vertex within the tolerance of a kept one lies in
        // its cell or one of the 26 around it.
        const auto cell_of = [&](const glm::dvec3& p) {
            return std::array<long long, 3>{static_cast<long long>(std::floor(p.x / weld_tolerance)),
                                            static_cast<long long>(std::floor(p.y / weld_tolerance)),
                                            static_cast<long long>(std::floor(p.z / weld_tolerance))};
        };
        std::map<std::array<long long, 3>, std::vector<std::uint32_t>> cells;
        for (std::size_t i = 0; i < capture.vertices.size(); ++i) {
            const glm::dvec3 p(capture.vertices[i].position);
            const auto c = cell_of(p);
            std::int64_t found = -1;
            for (long long dx = -1; dx <= 1 && found < 0; ++dx)
                for (long long dy = -1; dy <= 1 && found < 0; ++dy)
                    for (long long dz = -1; dz <= 1 && found < 0; ++dz) {
                        const auto it = cells.find({c[0] + dx, c[1] + dy, c[2] + dz});
                        if (it == cells.end()) continue;
                        for (const std::uint32_t k : it->second)
                            if (glm::length(mesh.positions[k] - p) <= weld_tolerance) {
                                found = k;
                                break;
                            }
                    }
            if (found < 0) {
                found = static_cast<std::int64_t>(mesh.positions.size());
                mesh.positions.push_back(p);
                mesh.patch_ids.push_back(capture.vertices[i].patch_id);
                cells[c].push_back(static_cast<std::uint32_t>(found));
            }
            ids[i] = static_cast<std::uint32_t>(found);
        }
    }
    for (std::size_t i = 0; i + 2 < ids.size(); i += 3) mesh.add_triangle(ids[i], ids[i + 1], ids[i + 2]);
    return mesh;
}

std::vector<SharedEdgeCrack> shared_edge_cracks(const Capture& capture) {
    // Every side of every patch whose two corners the patch emitted: its corners' positions
    // (the key, in a fixed order) and the positions of every vertex on it.
    struct Side {
        std::uint32_t patch = 0;
        int index = 0;
        float level = 0.0f;
        std::set<Bits> points;
        glm::dvec3 from{0.0}, to{0.0};
    };
    std::map<std::pair<Bits, Bits>, std::vector<Side>> sides;
    for (const Run& run : runs_of(capture)) {
        bool triangles = false;
        for (std::size_t i = run.begin; i < run.end; ++i) triangles |= capture.vertices[i].tess_coord.z != 0.0f;
        // Each side: which tess coord component is fixed at which value, and its two corners.
        struct Domain {
            int component;
            float value;
            glm::vec3 a, b;
        };
        static const std::array<Domain, 4> quad{{{0, 0.0f, {0, 0, 0}, {0, 1, 0}},
                                                 {1, 0.0f, {0, 0, 0}, {1, 0, 0}},
                                                 {0, 1.0f, {1, 0, 0}, {1, 1, 0}},
                                                 {1, 1.0f, {0, 1, 0}, {1, 1, 0}}}};
        static const std::array<Domain, 3> tri{{{0, 0.0f, {0, 1, 0}, {0, 0, 1}},
                                                {1, 0.0f, {1, 0, 0}, {0, 0, 1}},
                                                {2, 0.0f, {1, 0, 0}, {0, 1, 0}}}};
        const std::size_t count = triangles ? tri.size() : quad.size();
        for (std::size_t s = 0; s < count; ++s) {
            const Domain& d = triangles ? tri[s] : quad[s];
            Side side;
            side.patch = run.patch;
            side.index = static_cast<int>(s);
            bool have_a = false, have_b = false;
            for (std::size_t i = run.begin; i < run.end; ++i) {
                const CapturedVertex& v = capture.vertices[i];
                side.level = v.levels.outer[s];
                if (v.tess_coord[d.component] != d.value) continue;
                side.points.insert(bits_of(v.position));
                if (v.tess_coord == d.a) {
                    side.from = glm::dvec3(v.position);
                    have_a = true;
                }
                if (v.tess_coord == d.b) {
                    side.to = glm::dvec3(v.position);
                    have_b = true;
                }
            }
            if (!have_a || !have_b) continue;
            Bits ka = bits_of(glm::vec3(side.from)), kb = bits_of(glm::vec3(side.to));
            if (kb < ka) {
                std::swap(ka, kb);
                std::swap(side.from, side.to);
            }
            sides[{ka, kb}].push_back(std::move(side));
        }
    }
    std::vector<SharedEdgeCrack> out;
    for (const auto& [key, list] : sides)
        for (std::size_t i = 0; i < list.size(); ++i)
            for (std::size_t j = i + 1; j < list.size(); ++j) {
                const Side *a = &list[i], *b = &list[j];
                if (a->patch == b->patch || a->points == b->points) continue;
                if (b->patch < a->patch) std::swap(a, b);
                out.push_back({a->patch, b->patch, a->index, b->index, a->level, b->level, a->points.size(),
                               b->points.size(), a->from, a->to});
            }
    std::sort(out.begin(), out.end(), [](const SharedEdgeCrack& x, const SharedEdgeCrack& y) {
        return std::tie(x.patch_a, x.side_a, x.patch_b, x.side_b) < std::tie(y.patch_a, y.side_a, y.patch_b, y.side_b);
    });
    return out;
}

}  // namespace tessref
