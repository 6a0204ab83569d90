// tests/geomip_maps.h — height maps the geomipmapping suites build by hand.
#pragma once

#include <cstddef>

#include "tessref/geomipmap.h"

namespace tessref::test {

// A width x height map of one height everywhere.
inline geomip::HeightSamples flat_map(int width, int height, double value = 0.0) {
    geomip::HeightSamples m;
    m.width = width;
    m.height = height;
    m.samples.assign(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), value);
    return m;
}

}  // namespace tessref::test
