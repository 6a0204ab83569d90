// The COSC422 terrain exercise's control shader, twin of data/shaders/cosc422_terrain.tesc.
#include "tessref/control.h"

namespace tessref {

template <typename T>
T cosc422_level(T zAvg) {
    // GLSL: cosc422_terrain.tesc:16 cosc422_level
    return (zAvg + T(100)) * T(18) / T(100) + T(2);
}

template <typename T>
PatchLevels<T> cosc422_levels(const QuadCorners<T>& corners, Cosc422Space space,
                              const mat4_t<T>& modelView) {
    // GLSL: cosc422_terrain.tesc:21 level_z
    auto level_z = [&](const vec3_t<T>& position) {
        return space == Cosc422Space::eye ? (modelView * vec4_t<T>(position, T(1))).z : position.z;
    };
    const T z0 = level_z(corners[0]);
    const T z1 = level_z(corners[1]);
    const T z2 = level_z(corners[2]);
    const T z3 = level_z(corners[3]);

    PatchLevels<T> levels;
    // GLSL: cosc422_terrain.tesc:37 gl_TessLevelOuter
    levels.outer[0] = cosc422_level((z0 + z1) / T(2));
    levels.outer[1] = cosc422_level((z0 + z3) / T(2));
    levels.outer[2] = cosc422_level((z3 + z2) / T(2));
    levels.outer[3] = cosc422_level((z1 + z2) / T(2));

    // GLSL: cosc422_terrain.tesc:43 gl_TessLevelInner
    const T zAvg = (z0 + z1 + z2 + z3) / T(4);
    levels.inner[0] = cosc422_level(zAvg);
    levels.inner[1] = cosc422_level(zAvg);
    return levels;
}

template float cosc422_level(float);
template double cosc422_level(double);
template PatchLevels<float> cosc422_levels(const QuadCorners<float>&, Cosc422Space, const mat4_t<float>&);
template PatchLevels<double> cosc422_levels(const QuadCorners<double>&, Cosc422Space, const mat4_t<double>&);

}  // namespace tessref
