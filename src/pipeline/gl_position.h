// gl_position.h — the renderer's gl_Position of the evaluation's positions: mvp * vec4(p, 1)
// in float, as llvmpipe sums it. One place for the render's whole-surface pass, its streamed
// chunks, and the terrain evaluation that projects each block of points as it writes them
// (PatchProgram::evaluate_projected), so that every path gives the same bits.
#pragma once

#include <cstddef>

#include <glm/glm.hpp>

namespace tessref::pipeline {

// mvp * vec4(p, 1.0) as llvmpipe sums it: column by column in order, each step rounded,
// ((m0 x + m1 y) + m2 z) + m3. glm adds the two halves pairwise, (m0 x + m1 y) + (m2 z + m3),
// which for a terrain far from the origin moves clip coordinates by an ulp often enough to
// change thousands of pixels' coverage against llvmpipe (tests/extremes: the terrain 1e6
// units out). Separate statements, so that no compiler fuses a multiply and an add.
inline glm::vec4 gl_position(const glm::mat4& m, const glm::vec3& p) {
    glm::vec4 sum = m[0] * p.x;
    const glm::vec4 y = m[1] * p.y;
    sum += y;
    const glm::vec4 z = m[2] * p.z;
    sum += z;
    sum += m[3];
    return sum;
}

// gl_position of q[0, n), each position rounded to float first (a double one), into
// clip[0, n); whether every position is finite. Eight positions at a time with AVX2 where
// simd_level() says so (the same operations lane by lane: the same bits).
bool project_vertices(const glm::dvec3* q, std::size_t n, const glm::mat4& m, glm::vec4* clip);
bool project_vertices(const glm::vec3* q, std::size_t n, const glm::mat4& m, glm::vec4* clip);

}  // namespace tessref::pipeline
