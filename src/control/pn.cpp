// The PN triangles tutorial's control shader, twin of data/shaders/pn_triangles.tesc.
#include <algorithm>
#include <type_traits>

#include "shader/llvmpipe_math.h"
#include "tessref/control.h"

namespace tessref {

template <typename T>
vec3_t<T> project_to_plane(const vec3_t<T>& v3Point, const vec3_t<T>& v3PlanePoint,
                           const vec3_t<T>& v3PlaneNormal) {
    // GLSL: pn_triangles.tesc:37 project_to_plane
    const T fD = glm::dot(v3Point - v3PlanePoint, v3PlaneNormal);
    const vec3_t<T> v3D = fD * v3PlaneNormal;
    return v3Point - v3D;
}

template <typename T>
T pn_tess_level(const vec3_t<T>& v3Point1, const vec3_t<T>& v3Point2, const PnControl<T>& control) {
    // GLSL: pn_triangles.tesc:44 pn_tess_level
    const vec2_t<T> v2P1 = (vec2_t<T>(v3Point1) + vec2_t<T>(v3Point2)) * T(0.5);
    vec2_t<T> v2P2 = v2P1;
    // distance and length: glm's in exact math, the driver's order in llvmpipe math (float).
    const auto distance = [&](const vec3_t<T>& a, const vec3_t<T>& b) {
        if constexpr (std::is_same_v<T, float>) {
            if (control.math == MathMode::llvmpipe) return llvmpipe_math::distance(a, b);
        }
        return glm::distance(a, b);
    };
    const auto length = [&](const vec2_t<T>& v) {
        if constexpr (std::is_same_v<T, float>) {
            if (control.math == MathMode::llvmpipe) return llvmpipe_math::length(v);
        }
        return glm::length(v);
    };
    v2P2.y += distance(v3Point1, v3Point2);
    const T fLength = length((v2P1 - v2P2) * control.v2Resolution * T(0.5));
    return glm::clamp(fLength / control.fPixelsPerEdge, control.minLevel, control.maxLevel);
}

template <typename T>
PatchLevels<T> pn_levels(const std::array<vec4_t<T>, 3>& glPosition,
                         const TriangleCorners<T>& v3VertexNormal, const PnControl<T>& control) {
    // GLSL: pn_triangles.tesc:54 pn_edge_level
    auto pn_edge_level = [&](int i, int j) {
        if (control.flatEdgesAtLevel1 && v3VertexNormal[i] == v3VertexNormal[j]) return T(1);
        return pn_tess_level(vec3_t<T>(glPosition[i]), vec3_t<T>(glPosition[j]), control);
    };
    PatchLevels<T> levels;
    // GLSL: pn_triangles.tesc:102 gl_TessLevelOuter
    levels.outer[0] = pn_edge_level(1, 2);
    levels.outer[1] = pn_edge_level(2, 0);
    levels.outer[2] = pn_edge_level(0, 1);
    levels.outer[3] = T(1);
    levels.inner[0] = std::max(levels.outer[0], std::max(levels.outer[1], levels.outer[2]));
    levels.inner[1] = T(1);
    return levels;
}

template <typename T>
PnPatch<T> pn_patch(const TriangleCorners<T>& v3VertexPos, const TriangleCorners<T>& v3VertexNormal,
                    const std::array<vec2_t<T>, 3>& v2VertexUV) {
    PnPatch<T> patch;
    patch.v3VertexPos = v3VertexPos;
    patch.v3VertexNormal = v3VertexNormal;
    patch.v2VertexUV = v2VertexUV;

    // One iteration per control-shader invocation (gl_InvocationID = i).
    for (int i = 0; i < 3; ++i) {
        const int iNextInvocID = i < 2 ? i + 1 : 0;
        const vec3_t<T> v3CurrPos = v3VertexPos[i];
        const vec3_t<T> v3NextPos = v3VertexPos[iNextInvocID];
        // GLSL: pn_triangles.tesc:71 v3CurrNormal
        const vec3_t<T> v3CurrNormal = glm::normalize(v3VertexNormal[i]);
        const vec3_t<T> v3NextNormal = glm::normalize(v3VertexNormal[iNextInvocID]);

        // GLSL: pn_triangles.tesc:74 v3ProjPoint1
        const vec3_t<T> v3ProjPoint1 = project_to_plane(v3NextPos, v3CurrPos, v3CurrNormal);
        const vec3_t<T> v3ProjPoint2 = project_to_plane(v3CurrPos, v3NextPos, v3NextNormal);

        // GLSL: pn_triangles.tesc:77 v3PatchE1
        patch.v3PatchE1[i] = ((T(2) * v3CurrPos) + v3ProjPoint1) / T(3);
        patch.v3PatchE2[i] = ((T(2) * v3NextPos) + v3ProjPoint2) / T(3);

        // GLSL: pn_triangles.tesc:84 v3EdgeNormal
        const vec3_t<T> v3Edge = v3NextPos - v3CurrPos;
        const vec3_t<T> v3NormalSum = v3CurrNormal + v3NextNormal;
        const T fV = T(2) * glm::dot(v3Edge, v3NormalSum) / glm::dot(v3Edge, v3Edge);
        patch.v3EdgeNormal[i] = glm::normalize(v3NormalSum - fV * v3Edge);
    }

    const vec3_t<T>& v3P030 = patch.v3VertexPos[0];
    const vec3_t<T>& v3P021 = patch.v3PatchE1[0];
    const vec3_t<T>& v3P012 = patch.v3PatchE2[0];
    const vec3_t<T>& v3P003 = patch.v3VertexPos[1];
    const vec3_t<T>& v3P102 = patch.v3PatchE1[1];
    const vec3_t<T>& v3P201 = patch.v3PatchE2[1];
    const vec3_t<T>& v3P300 = patch.v3VertexPos[2];
    const vec3_t<T>& v3P210 = patch.v3PatchE1[2];
    const vec3_t<T>& v3P120 = patch.v3PatchE2[2];

    // GLSL: pn_triangles.tesc:98 v3E
    const vec3_t<T> v3E = (v3P021 + v3P012 + v3P102 + v3P201 + v3P210 + v3P120) / T(6);
    const vec3_t<T> v3V = (v3P300 + v3P003 + v3P030) / T(3);
    // GLSL: pn_triangles.tesc:100 v3P111
    patch.v3P111 = v3E + ((v3E - v3V) / T(2));
    return patch;
}

#define TESSREF_INSTANTIATE(T)                                                                    \
    template vec3_t<T> project_to_plane(const vec3_t<T>&, const vec3_t<T>&, const vec3_t<T>&);    \
    template T pn_tess_level(const vec3_t<T>&, const vec3_t<T>&, const PnControl<T>&);            \
    template PatchLevels<T> pn_levels(const std::array<vec4_t<T>, 3>&, const TriangleCorners<T>&, \
                                      const PnControl<T>&);                                       \
    template PnPatch<T> pn_patch(const TriangleCorners<T>&, const TriangleCorners<T>&,            \
                                 const std::array<vec2_t<T>, 3>&);
TESSREF_INSTANTIATE(float)
TESSREF_INSTANTIATE(double)
#undef TESSREF_INSTANTIATE

}  // namespace tessref
