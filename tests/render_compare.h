// tests/render_compare.h — two renders compared byte for byte: every per-pixel buffer, the
// counts and the matrix (the streamed render against the whole-surface pass, one thread count
// against another, one SIMD level against another).
#pragma once

#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "tessref/render.h"

template <typename T>
bool same_bytes(const std::vector<T>& a, const std::vector<T>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

inline void expect_identical_renders(const tessref::RenderResult& a, const tessref::RenderResult& b) {
    EXPECT_TRUE(same_bytes(a.colour, b.colour)) << "colour";
    EXPECT_TRUE(same_bytes(a.depth, b.depth)) << "depth";
    EXPECT_TRUE(same_bytes(a.patch_id, b.patch_id)) << "patch_id";
    EXPECT_TRUE(same_bytes(a.triangle_id, b.triangle_id)) << "triangle_id";
    EXPECT_TRUE(same_bytes(a.tess_coord, b.tess_coord)) << "tess_coord";
    EXPECT_TRUE(same_bytes(a.barycentric, b.barycentric)) << "barycentric";
    EXPECT_TRUE(same_bytes(a.level, b.level)) << "level";
    EXPECT_EQ(a.stats.triangles, b.stats.triangles);
    EXPECT_EQ(a.stats.vertices, b.stats.vertices);
    EXPECT_EQ(a.stats.covered_pixels, b.stats.covered_pixels);
    EXPECT_EQ(a.stats.raster.triangles_in, b.stats.raster.triangles_in);
    EXPECT_EQ(a.stats.raster.triangles_clipped, b.stats.raster.triangles_clipped);
    EXPECT_EQ(a.stats.raster.triangles_rejected, b.stats.raster.triangles_rejected);
    EXPECT_EQ(a.stats.raster.primitives, b.stats.raster.primitives);
    EXPECT_EQ(a.stats.raster.primitives_culled, b.stats.raster.primitives_culled);
    EXPECT_EQ(a.stats.raster.fragments, b.stats.raster.fragments);
    EXPECT_EQ(a.stats.raster.fragments_passed, b.stats.raster.fragments_passed);
    EXPECT_EQ(a.mvp, b.mvp);
}
