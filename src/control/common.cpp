// Shared pieces of the control stage: canonical edge order and the constant model.
#include "tessref/control.h"

namespace tessref {

template <typename T>
Edge<T> canonical_edge(const vec3_t<T>& p, const vec3_t<T>& q) {
    // GLSL: thesis_terrain.tesc:95 canonical_edge
    const bool swapEnds =
        q.x < p.x || (q.x == p.x && (q.y < p.y || (q.y == p.y && q.z < p.z)));
    return swapEnds ? Edge<T>{q, p} : Edge<T>{p, q};
}

template <typename T>
PatchLevels<T> constant_levels(T level) {
    PatchLevels<T> levels;
    levels.outer = {level, level, level, level};
    levels.inner = {level, level};
    return levels;
}

template Edge<float> canonical_edge(const vec3_t<float>&, const vec3_t<float>&);
template Edge<double> canonical_edge(const vec3_t<double>&, const vec3_t<double>&);
template PatchLevels<float> constant_levels(float);
template PatchLevels<double> constant_levels(double);

}  // namespace tessref
