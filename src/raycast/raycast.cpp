#include "tessref/raycast.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <embree3/rtcore.h>

#include "common/parallel.h"
#include "tessref/error.h"

namespace tessref {

struct RayScene::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    glm::dvec3 shift{0.0};
    std::size_t triangles = 0;
    // Embree's copies of the geometry (owned by the geometry, alive with the scene).
    const float* vertices = nullptr;
    const unsigned* indices = nullptr;

    double resolution = 0.0;

    std::array<glm::dvec3, 3> corners(std::uint32_t triangle) const {
        const unsigned* t = indices + 3 * std::size_t(triangle);
        std::array<glm::dvec3, 3> out;
        for (int k = 0; k < 3; ++k) out[k] = glm::dvec3(vertices[3 * t[k]], vertices[3 * t[k] + 1], vertices[3 * t[k] + 2]);
        return out;
    }

    // The hit with its side and its distance from the triangle's edges, from Embree's
    // barycentric coordinates (the point is (1-u-v) a + u b + v c): the distance from the
    // edge opposite a corner is that corner's weight times the triangle's height over it.
    RayHit hit(float t, std::uint32_t triangle, float u, float v, const glm::dvec3& direction) const {
        const auto [a, b, c] = corners(triangle);
        const glm::dvec3 normal = glm::cross(b - a, c - a);
        const double d = glm::dot(normal, direction);
        const double twice_area = glm::length(normal);
        const double weights[3] = {std::max(0.0, 1.0 - double(u) - double(v)), std::max(0.0, double(u)),
                                   std::max(0.0, double(v))};
        const double opposite[3] = {glm::distance(b, c), glm::distance(c, a), glm::distance(a, b)};
        double edge_distance = std::numeric_limits<double>::infinity();
        for (int k = 0; k < 3; ++k)
            edge_distance = std::min(edge_distance, opposite[k] > 0.0 ? weights[k] * twice_area / opposite[k] : 0.0);
        return {true, t, triangle, d > 0.0 ? 1 : (d < 0.0 ? -1 : 0), edge_distance};
    }

    ~Impl() {
        if (scene) rtcReleaseScene(scene);
        if (device) rtcReleaseDevice(device);
    }
};

namespace {

// Where Embree's single-precision coordinates are measured from, and the resolution there:
// the centre of the positions' bounding box, and 16 ulps of the largest coordinate after
// the shift (2^-24 is half an ulp at `largest`). Depends on the positions only.
struct Frame {
    glm::dvec3 shift{0.0};
    double resolution = 0.0;
};

// The box in parallel chunks: minima and maxima are exact and ignore a NaN whichever order
// they meet it in, so the chunks' results join into the serial pass's, bit for bit. (A terrain
// probe's scene holds a fifth of a 1.2 M-vertex mesh's triangles but every position: on one
// thread these passes and the copy into Embree's buffer were about a fifth of its build's
// CPU time.)
constexpr std::size_t kPositionChunk = 1 << 15;

Frame frame_of(std::span<const glm::dvec3> positions) {
    Frame f;
    if (positions.empty()) return f;
    struct Box {
        glm::dvec3 lo{std::numeric_limits<double>::infinity()}, hi{-std::numeric_limits<double>::infinity()};
    };
    const Box box = tessref::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, positions.size(), kPositionChunk), Box{},
        [&](const tbb::blocked_range<std::size_t>& r, Box b) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                b.lo = glm::min(b.lo, positions[i]);
                b.hi = glm::max(b.hi, positions[i]);
            }
            return b;
        },
        [](const Box& a, const Box& b) { return Box{glm::min(a.lo, b.lo), glm::max(a.hi, b.hi)}; });
    f.shift = 0.5 * (box.lo + box.hi);
    // The largest |p - shift| over the positions, from the box's corners alone: rounding is
    // monotonic, so on each axis p - shift is largest for the largest p and smallest for the
    // smallest, and its magnitude is largest at one of the two (a NaN, from an infinite
    // coordinate, is never larger, as in a pass over every position).
    double largest = 0.0;
    for (int k = 0; k < 3; ++k)
        for (const double corner : {box.lo[k], box.hi[k]}) largest = std::max(largest, std::abs(corner - f.shift[k]));
    f.resolution = std::ldexp(largest, -20);
    return f;
}

// Under ThreadSanitizer, Embree builds its BVH on the calling thread: its build tasks run on
// oneTBB workers inside the uninstrumented libembree, whose hand-offs TSan cannot see, so
// it reported the caller's stack reused after a build as a race (RenderDeterminism,
// RenderGolden raytrace cases). Hits do not depend on the build's thread count.
#if defined(__SANITIZE_THREAD__)
constexpr const char* kDeviceConfig = "verbose=0,threads=1";
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
constexpr const char* kDeviceConfig = "verbose=0,threads=1";
#else
constexpr const char* kDeviceConfig = "verbose=0";
#endif
#else
constexpr const char* kDeviceConfig = "verbose=0";
#endif

[[noreturn]] void embree_failure(RTCDevice device, const std::string& what) {
    const RTCError code = device ? rtcGetDeviceError(device) : RTC_ERROR_UNKNOWN;
    throw Error("Embree: " + what + " (error " + std::to_string(static_cast<int>(code)) + ")");
}

}  // namespace

RayScene::RayScene(std::span<const glm::dvec3> positions,
                   std::span<const std::array<std::uint32_t, 3>> triangles, Build build)
    : impl_(std::make_unique<Impl>()) {
    impl_->triangles = triangles.size();
    impl_->device = rtcNewDevice(kDeviceConfig);
    if (!impl_->device) embree_failure(nullptr, "cannot create a device");

    const Frame frame = frame_of(positions);
    impl_->shift = frame.shift;
    impl_->resolution = frame.resolution;

    impl_->scene = rtcNewScene(impl_->device);
    if (!impl_->scene) embree_failure(impl_->device, "cannot create a scene");
    // Robust: Embree's watertight (Pluecker) test. Compact (Build::compact): leaves of corner
    // indices, a smaller BVH, which for large meshes also builds faster (fewer pages to fault
    // in); without it (Build::quick), leaves of the corners themselves, which rays read
    // without the indirection. A low build quality for the scene is Embree's two-level build,
    // and the geometry's own quality picks its tree's builder: the SAH builder (medium,
    // Embree's default) or the Morton builder (low).
    const auto flags = RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION |
                       (build == Build::compact ? RTC_SCENE_FLAG_COMPACT : RTC_SCENE_FLAG_NONE);
    rtcSetSceneFlags(impl_->scene, static_cast<RTCSceneFlags>(flags));
    rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_LOW);

    RTCGeometry geometry = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (!geometry) embree_failure(impl_->device, "cannot create a triangle geometry");
    if (build == Build::quick) rtcSetGeometryBuildQuality(geometry, RTC_BUILD_QUALITY_LOW);
    // Embree owns these buffers (it may read 16 bytes past the last vertex; it pads them).
    auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), positions.size()));
    auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), triangles.size()));
    if ((!vertices && !positions.empty()) || (!indices && !triangles.empty())) {
        rtcReleaseGeometry(geometry);
        embree_failure(impl_->device, "cannot allocate geometry buffers");
    }
    const glm::dvec3 shift = impl_->shift;
    tessref::parallel_for(tbb::blocked_range<std::size_t>(0, positions.size(), kPositionChunk), [&](const auto& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
            const glm::dvec3 p = positions[i] - shift;
            vertices[3 * i + 0] = static_cast<float>(p.x);
            vertices[3 * i + 1] = static_cast<float>(p.y);
            vertices[3 * i + 2] = static_cast<float>(p.z);
        }
    });
    tessref::parallel_for(tbb::blocked_range<std::size_t>(0, triangles.size(), kPositionChunk), [&](const auto& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i)
            for (int k = 0; k < 3; ++k) indices[3 * i + k] = triangles[i][k];
    });
    impl_->vertices = vertices;
    impl_->indices = indices;
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(impl_->scene, geometry);
    rtcReleaseGeometry(geometry);
    rtcCommitScene(impl_->scene);
    if (rtcGetDeviceError(impl_->device) != RTC_ERROR_NONE)
        embree_failure(impl_->device, "cannot build the scene");
}

RayScene::~RayScene() = default;
RayScene::RayScene(RayScene&&) noexcept = default;
RayScene& RayScene::operator=(RayScene&&) noexcept = default;

std::size_t RayScene::triangle_count() const { return impl_->triangles; }

double RayScene::resolution() const { return impl_->resolution; }

double RayScene::resolution_of(std::span<const glm::dvec3> positions) { return frame_of(positions).resolution; }

namespace {

struct RawHit {
    float t;
    unsigned triangle;
    float u, v;
    auto operator<=>(const RawHit&) const = default;
};

// The context of an all-hits query: Embree's context first, so the filter can find the rest.
struct CollectingContext {
    RTCIntersectContext context;
    std::vector<RawHit>* hits;
};

// Records each candidate hit and rejects it, so that traversal goes on to the next one.
void collect_hit(const RTCFilterFunctionNArguments* args) {
    auto* context = reinterpret_cast<CollectingContext*>(args->context);
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] == 0) continue;
        context->hits->push_back({RTCRayN_tfar(args->ray, args->N, i), RTCHitN_primID(args->hit, args->N, i),
                                  RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i)});
        args->valid[i] = 0;
    }
}

void set_ray(RTCRay& ray, const glm::dvec3& o, const glm::dvec3& direction, double t_near, double t_far) {
    ray.org_x = static_cast<float>(o.x);
    ray.org_y = static_cast<float>(o.y);
    ray.org_z = static_cast<float>(o.z);
    ray.dir_x = static_cast<float>(direction.x);
    ray.dir_y = static_cast<float>(direction.y);
    ray.dir_z = static_cast<float>(direction.z);
    ray.tnear = static_cast<float>(t_near);
    ray.tfar = t_far == std::numeric_limits<double>::infinity() ? std::numeric_limits<float>::infinity()
                                                                : static_cast<float>(t_far);
    ray.mask = 0xFFFFFFFFu;
    ray.flags = 0;
}

}  // namespace

std::vector<RayHit> RayScene::all_hits(const glm::dvec3& origin, const glm::dvec3& direction, double t_near,
                                       double t_far) const {
    std::vector<RawHit> raw;
    CollectingContext collecting;
    rtcInitIntersectContext(&collecting.context);
    collecting.context.filter = collect_hit;
    collecting.hits = &raw;
    RTCRayHit query{};
    set_ray(query.ray, origin - impl_->shift, direction, t_near, t_far);
    query.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    query.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(impl_->scene, &collecting.context, &query);
    std::sort(raw.begin(), raw.end());
    raw.erase(std::unique(raw.begin(), raw.end(),
                          [](const RawHit& a, const RawHit& b) { return a.t == b.t && a.triangle == b.triangle; }),
              raw.end());  // a leaf may be visited twice
    std::vector<RayHit> hits;
    hits.reserve(raw.size());
    for (const RawHit& h : raw) hits.push_back(impl_->hit(h.t, h.triangle, h.u, h.v, direction));
    return hits;
}

RayHit RayScene::intersect(const glm::dvec3& origin, const glm::dvec3& direction, double t_near,
                           double t_far) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit query{};
    set_ray(query.ray, origin - impl_->shift, direction, t_near, t_far);
    query.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    query.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(impl_->scene, &context, &query);

    if (query.hit.geomID == RTC_INVALID_GEOMETRY_ID) return {};
    return impl_->hit(query.ray.tfar, query.hit.primID, query.hit.u, query.hit.v, direction);
}

bool RayScene::occluded(const glm::dvec3& origin, const glm::dvec3& direction, double t_near, double t_far) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRay ray{};
    set_ray(ray, origin - impl_->shift, direction, t_near, t_far);
    rtcOccluded1(impl_->scene, &context, &ray);
    return ray.tfar < 0.0f;  // Embree sets tfar to -inf when the ray is blocked
}

}  // namespace tessref
