// tessref/raycast.h — ray casting against a triangle mesh with Embree 3.
//
// RayScene builds an Embree BVH over a triangle list once; intersect() may then be called
// from many threads at once. The scene is built in robust (watertight) mode, so a ray
// through a shared edge of two welded triangles never slips between them: a miss means a
// real gap. Coordinates are shifted to the centre of the mesh's bounding box before Embree
// sees them in single precision, so meshes placed at large world coordinates (UTM terrain)
// keep their resolution.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

namespace tessref {

struct RayHit {
    bool hit = false;
    double t = 0.0;              // origin + t * direction is the hit point
    std::uint32_t triangle = 0;  // index into the triangle list given to the scene
    // +1 when the ray leaves through the triangle's counter-clockwise side (the direction
    // is along its normal), -1 when it enters through it, 0 for a ray in its plane.
    int side = 0;
    // How far the hit point lies from the nearest edge of its triangle. Under
    // RayScene::resolution() the ray may as well have hit the neighbour across that edge,
    // both, or (at a ridge) neither: the hit says nothing about which side it went.
    double edge_distance = 0.0;
};

class RayScene {
public:
    // How Embree builds the BVH. Both run Embree's robust (watertight) test, so a ray never
    // slips between two welded triangles; and a ray that passes no edge or vertex within
    // single-precision rounding meets the same triangles at the same t in both. Which of the
    // triangles at an edge or a vertex a ray through it meets (one or several) depends on the
    // tree and its leaves, so all_hits() of such a grazing ray, and which triangle
    // intersect() reports for a tie, may differ between the two.
    enum class Build {
        // The SAH builder, with the corners' indices in the leaves: the least memory and the
        // fastest rays, for scenes many rays cross (the render's ray tracer).
        compact,
        // The Morton builder, with the corners themselves in the leaves: about twice as fast
        // to build, for a scene built for one pass of rays (the check's probe).
        quick,
    };

    // Throws tessref::Error when Embree cannot build the scene.
    RayScene(std::span<const glm::dvec3> positions,
             std::span<const std::array<std::uint32_t, 3>> triangles, Build build = Build::compact);
    ~RayScene();
    RayScene(RayScene&&) noexcept;
    RayScene& operator=(RayScene&&) noexcept;
    RayScene(const RayScene&) = delete;
    RayScene& operator=(const RayScene&) = delete;

    // The nearest hit with t in [t_near, t_far]. Thread-safe.
    RayHit intersect(const glm::dvec3& origin, const glm::dvec3& direction, double t_near = 0.0,
                     double t_far = std::numeric_limits<double>::infinity()) const;

    // Every hit along the ray with t in [t_near, t_far], sorted by t (then triangle). A ray
    // through a shared edge or vertex hits each triangle there. Thread-safe.
    std::vector<RayHit> all_hits(const glm::dvec3& origin, const glm::dvec3& direction, double t_near = 0.0,
                                 double t_far = std::numeric_limits<double>::infinity()) const;

    // Whether any triangle meets the ray with t in [t_near, t_far] (Embree's occlusion query:
    // the first hit found ends the search). Thread-safe.
    bool occluded(const glm::dvec3& origin, const glm::dvec3& direction, double t_near = 0.0,
                  double t_far = std::numeric_limits<double>::infinity()) const;
    std::size_t triangle_count() const;

    // The distance under which Embree's single-precision arithmetic cannot tell on which
    // side of an edge a ray passes: 16 units in the last place of the scene's largest
    // coordinate (after the shift to its centre).
    double resolution() const;
    // The resolution() of a scene built on `positions`, whichever triangles it holds: a
    // caller that builds its scene from the triangles its rays can reach learns the
    // rounding it must allow for before the build.
    static double resolution_of(std::span<const glm::dvec3> positions);

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace tessref
