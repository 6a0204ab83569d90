// terrain.h — what the three terrain programs (thesis, cosc422, lab4) share: the grid as
// the application's vertex buffer, the height and normal maps as samplers, the terrain
// control models, and the geometry stage's per-vertex normals.
#pragma once

#include <array>
#include <cstddef>
#include <span>
#include <vector>

#include "pipeline/program.h"
#include "tessref/evaluation.h"

namespace tessref::pipeline {

// [geometry] normals = "height_field" at a world position of the scene's terrain: lab 4's
// appendix-A normal (evaluation.h's lab4_vertex_normal, the one implementation), one
// height-map texel apart, from mip `lod`, through the evaluation model's own world ->
// texture mapping (lab 4: xz / scale_xy + offset; thesis: xy / scale_xy; COSC422: the
// extent). Returned in world axes, pointing up the plane's up axis. `origin`: the position is
// relative to it (camera-relative evaluation), and the mapping is shifted by it in double.
template <typename T>
vec3_t<T> height_field_normal(const Scene& scene, const vec3_t<T>& position, T lod,
                              const glm::dvec3& origin = glm::dvec3(0.0));

template <typename T>
class TerrainProgram : public PatchProgram<T> {
public:
    PatchLevels<T> control(std::size_t patch) override;
    void evaluate(std::size_t patch, std::span<const DomainPoint<T>> points, SurfaceMesh& mesh,
                  std::size_t first_vertex, bool normals) const override;
    void evaluate_projected(std::size_t patch, std::span<const DomainPoint<T>> points, SurfaceMesh& mesh,
                            std::size_t first_vertex, bool normals, PatchStream::Projection& projection) const override {
        evaluate_into(patch, points, mesh, first_vertex, normals, &projection);
    }
    void geometry_normals(std::size_t patch, std::span<const DomainPoint<T>> points, std::span<const vec3_t<T>> position,
                          std::span<const vec2_t<T>> uv, std::span<vec3_t<T>> normal) const override {
        if (!geometry_vertex_normals) return;
        for (std::size_t k0 = 0; k0 < points.size(); k0 += kBlock) {
            const std::size_t count = std::min(kBlock, points.size() - k0);
            vertex_normals(patch, points.subspan(k0, count), position.subspan(k0, count), uv.subspan(k0, count),
                           normal.subspan(k0, count));
        }
    }
    // From the positions and texture coordinates evaluate() wrote (the evaluation's own
    // values, widened to double and so narrowed back exactly): the normal map's fetch or the
    // height field's differences, without evaluating the surface again.
    void later_normals(std::size_t patch, std::span<const DomainPoint<T>> points, std::span<const std::uint32_t> vertices,
                       SurfaceMesh& mesh) const override;
    void use_math(MathMode math) override {
        thesisControl.math = math;
        lab4Control.math = math;
    }

protected:
    TerrainProgram(const Scene& scene, const glm::dvec3& origin);

    // The model's vertex shader on one corner of the grid (ground plane, height 0); `relative`:
    // the corner is relative to origin (the evaluation's corners), else in world coordinates
    // (the control stage's).
    virtual vec4_t<T> vertex(const vec3_t<T>& ground, bool /*relative*/) const { return vec4_t<T>(ground, T(1)); }
    // evaluate() works on blocks of at most this many points: what it keeps of each (position,
    // texture coordinate, normal-map sample, normal) lives on the stack, and the samplers
    // and the normals run once per block.
    static constexpr std::size_t kBlock = 64;
    // The model's evaluation shader at a block of domain points (at most kBlock) of a patch
    // whose control stage ran: each point's position and texture coordinate (the mesh's;
    // gl_Position is not kept). The spans have the same size.
    virtual void evaluate_block(std::size_t patch, std::span<const DomainPoint<T>> tc, std::span<vec3_t<T>> position,
                                std::span<vec2_t<T>> textureCoordinate) const = 0;
    // evaluate_block of a model that evaluates a point at a time: shader(tc) -> EvaluatedVertex.
    template <typename Shader>
    static void evaluate_each(std::span<const DomainPoint<T>> tc, std::span<vec3_t<T>> position,
                              std::span<vec2_t<T>> textureCoordinate, const Shader& shader) {
        for (std::size_t k = 0; k < tc.size(); ++k) {
            const EvaluatedVertex<T> vertex = shader(tc[k]);
            position[k] = vertex.position;
            textureCoordinate[k] = vertex.textureCoordinate;
        }
    }
    // The mip level the evaluation sampled the height at (lab 4), for height-field normals.
    virtual T vertex_lod(std::size_t /*patch*/, const DomainPoint<T>& /*tc*/) const { return T(0); }
    // The geometry stage's per-vertex normals ([geometry] normals = "normal_map" or
    // "height_field") of a block that evaluate_block wrote; the spans have the same size.
    void vertex_normals(std::size_t patch, std::span<const DomainPoint<T>> tc, std::span<const vec3_t<T>> position,
                        std::span<const vec2_t<T>> textureCoordinate, std::span<vec3_t<T>> normal) const;

    const Scene& scene;
    const TerrainGrid& grid;
    const glm::dvec3 origin;     // camera-relative evaluation: non-zero (pipeline.h)
    const bool relative;         // origin is non-zero
    // The origin along the grid's two axes (x and y for plane xy, x and z for plane xz).
    glm::dvec2 ground_origin() const;
    CameraUniforms<T> camera;
    std::shared_ptr<const Texture> height_texture;
    Sampler2D<T> heightMap;
    Sampler2DLod<T> heightMapLod;
    Sampler2D<T> normalMap;                      // unbound unless the scene has a normal map
    Sampler2DRedBatch<T> heightMapRedBatch;      // heightMap's r (the height), many coordinates at a time
    Sampler2DBatch<T> normalMapBatch;            // normalMap, many coordinates at a time
    mat3_t<T> normalMatrix{T(1)};                // the thesis's normalMatrix: model is the identity
    std::vector<std::array<vec4_t<T>, 4>> tcPosition;  // per patch: the control stage's output corners

    // Control models, bound once (only the scene's is read).
    ThesisControl<T> thesisControl{};
    Lab4Control<T> lab4Control{};
    std::vector<Lab4Lod<T>> lab4Lod;             // per patch, with control model lab4

private:
    // evaluate(), and evaluate_projected() where projection is not null.
    void evaluate_into(std::size_t patch, std::span<const DomainPoint<T>> points, SurfaceMesh& mesh,
                       std::size_t first_vertex, bool normals, PatchStream::Projection* projection) const;

    std::vector<T> u_coords, v_coords;  // grid corner coordinates as the vertex buffer holds them
    std::vector<T> u_relative, v_relative;  // the same minus origin (rounded once), when relative
    bool geometry_vertex_normals = false;
};

}  // namespace tessref::pipeline
