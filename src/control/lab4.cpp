// Lab 4's control shader, twin of data/shaders/lab4_terrain.tesc: power-of-two distance
// zones, edge levels consistent with the neighbours, log2 levels for the mip selection.
#include <algorithm>
#include <cmath>
#include <type_traits>

#include "shader/llvmpipe_math.h"
#include "tessref/control.h"

namespace tessref {

template <typename T>
T lab4_zone_level(T distanceToCamera, const Lab4Control<T>& control) {
    // GLSL: lab4_terrain.tesc:39 lab4_zone_level
    T level = control.maxLevel;
    T zoneEnd = control.firstZoneEnd;
    while (distanceToCamera >= zoneEnd && level > control.minLevel) {
        level = level * T(0.5);
        zoneEnd = zoneEnd * control.zoneGrowth;
    }
    return level;
}

namespace {

// GLSL: lab4_terrain.tesc:59 lab4_edge_level
template <typename T>
T lab4_edge_level(const vec3_t<T>& p, const vec3_t<T>& q, const Lab4Control<T>& control) {
    const Edge<T> edge = canonical_edge(p, q);
    const vec3_t<T>& a = edge.a;
    const vec3_t<T>& b = edge.b;
    const vec3_t<T> m = (a + b) * T(0.5);
    const vec3_t<T> r = vec3_t<T>(-(b.z - a.z), T(0), b.x - a.x) * T(0.5);
    // GLSL: lab4_terrain.tesc:66 level1
    const T level1 = lab4_zone_level(glm::distance(m + r, control.cameraPosition), control);
    const T level2 = lab4_zone_level(glm::distance(m - r, control.cameraPosition), control);
    return control.edgeRule == Lab4EdgeRule::lower ? std::min(level1, level2)
                                                   : std::max(level1, level2);
}

}  // namespace

template <typename T>
Lab4ControlOutput<T> lab4_control(const QuadCorners<T>& corners, const Lab4Control<T>& control) {
    // GLSL: lab4_terrain.tesc:71 main
    const vec3_t<T>& c0 = corners[0];
    const vec3_t<T>& c1 = corners[1];
    const vec3_t<T>& c2 = corners[2];
    const vec3_t<T>& c3 = corners[3];

    // GLSL: lab4_terrain.tesc:82 centre
    const vec3_t<T> centre = (c0 + c1 + c2 + c3) * T(0.25);
    const T patchLevel = lab4_zone_level(glm::distance(centre, control.cameraPosition), control);

    Lab4ControlOutput<T> out;
    // GLSL: lab4_terrain.tesc:85 gl_TessLevelOuter
    out.levels.outer[0] = lab4_edge_level(c0, c1, control);
    out.levels.outer[1] = lab4_edge_level(c0, c3, control);
    out.levels.outer[2] = lab4_edge_level(c3, c2, control);
    out.levels.outer[3] = lab4_edge_level(c1, c2, control);
    out.levels.inner[0] = patchLevel;
    out.levels.inner[1] = patchLevel;

    // log2 as the math mode says: the C library's, or llvmpipe's (float only).
    const auto log2 = [&](T x) {
        if constexpr (std::is_same_v<T, float>) {
            if (control.math == MathMode::llvmpipe) return llvmpipe_math::log2(x);
        }
        return std::log2(x);
    };
    // GLSL: lab4_terrain.tesc:92 maxLogTessellationLevel
    out.lod.maxLogTessellationLevel = log2(control.maxLevel);
    for (int i = 0; i < 4; ++i) out.lod.logOuter[i] = log2(out.levels.outer[i]);
    out.lod.logInner = log2(patchLevel);
    for (int i = 0; i < 4; ++i) {
        out.lod.logCorner[i] =
            log2(lab4_zone_level(glm::distance(corners[i], control.cameraPosition), control));
    }
    return out;
}

template float lab4_zone_level(float, const Lab4Control<float>&);
template double lab4_zone_level(double, const Lab4Control<double>&);
template Lab4ControlOutput<float> lab4_control(const QuadCorners<float>&, const Lab4Control<float>&);
template Lab4ControlOutput<double> lab4_control(const QuadCorners<double>&, const Lab4Control<double>&);

}  // namespace tessref
