// program.h — a scene's shaders bound to its uniforms, in one precision: the CPU
// counterpart of a linked GL program.
//
// run_pipeline() (pipeline.cpp) drives the passes over the patches and knows no model;
// everything model-specific sits behind PatchProgram, one implementation per evaluation
// model and one file each:
//   terrain.{h,cpp}  the grid's vertex buffer, the terrain control models (constant,
//                    thesis, cosc422, lab4) and the per-vertex geometry normals
//   thesis.cpp       thesis_terrain.{vert,tesc,tese,geom}
//   cosc422.cpp      cosc422_terrain.{tesc,tese,geom}
//   lab4.cpp         lab4_terrain.{tesc,tese}
//   pn.cpp           pn_triangles.{vert,tesc,tese}
// make_program() is the one place that looks at the scene's model names.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "pipeline/gl_position.h"
#include "tessref/control.h"
#include "tessref/mesh.h"
#include "tessref/pipeline.h"
#include "tessref/scene.h"
#include "tessref/tessellator.h"

namespace tessref::pipeline {

template <typename T>
class PatchProgram {
public:
    virtual ~PatchProgram() = default;

    // The vertex and tessellation control shaders of one patch: its levels. The program
    // keeps what its evaluation shader reads from the control stage (output corners, PN
    // control points, lab 4 mip levels) in a slot of its own for that patch. Called once
    // per patch, concurrently for different patches.
    virtual PatchLevels<T> control(std::size_t patch) = 0;

    // The evaluation shader at each of the patch's domain points, then the geometry
    // stage's per-vertex normal if the scene asks for one: writes positions (and uvs and
    // normals where has_uvs / has_normals) at mesh indices first_vertex + k. normals false:
    // leaves mesh.normals alone (the renderer computes them later for the few vertices that
    // need them; every output is a function of its own point, so the values are the same).
    // Called after control() of the same patch, concurrently for different patches.
    virtual void evaluate(std::size_t patch, std::span<const DomainPoint<T>> points, SurfaceMesh& mesh,
                          std::size_t first_vertex, bool normals) const = 0;

    // evaluate(), then gl_Position of every point it wrote (PatchStream::Projection: the
    // renderer's, pipeline/gl_position.h) into projection.clip[first_vertex + k]. This default
    // reads mesh.positions back; TerrainProgram projects each block of points from the
    // positions its evaluation computed, still on its stack (in float at gpu precision),
    // where the renderer reloaded the 24-byte double positions the evaluation had just stored.
    virtual void evaluate_projected(std::size_t patch, std::span<const DomainPoint<T>> points, SurfaceMesh& mesh,
                                    std::size_t first_vertex, bool normals, PatchStream::Projection& projection) const {
        evaluate(patch, points, mesh, first_vertex, normals);
        projection.finite &= project_vertices(mesh.positions.data() + first_vertex, points.size(), projection.mvp,
                                              projection.clip + first_vertex);
    }

    // The per-vertex normals that evaluate() left out (normals false) for some of the points
    // it evaluated: point k was written at mesh index vertices[k], and its normal goes to
    // mesh.normals[vertices[k]], the value evaluate() with normals true writes. This default
    // evaluates the points again; a program whose normals follow from the position and
    // texture coordinate it wrote computes only the normals (TerrainProgram).
    virtual void later_normals(std::size_t patch, std::span<const DomainPoint<T>> points,
                               std::span<const std::uint32_t> vertices, SurfaceMesh& mesh) const {
        if (!has_normals) return;
        SurfaceMesh some;
        some.positions.resize(points.size());
        if (has_uvs) some.uvs.resize(points.size());
        some.normals.resize(points.size());
        evaluate(patch, points, some, 0, true);
        for (std::size_t k = 0; k < points.size(); ++k) mesh.normals[vertices[k]] = some.normals[k];
    }

    // The math mode of the control stage's transcendentals (control.h MathMode); set once,
    // before the first control(). Models without transcendentals ignore it.
    virtual void use_math(MathMode) {}
    // The geometry stage's per-vertex normals ([geometry] normals = "normal_map" or
    // "height_field") at points whose positions and texture coordinates another evaluation
    // shader computed (a user's, run by the interpreter); the spans have the same size.
    // Called after control() of the same patch. Programs without such a stage write nothing.
    virtual void geometry_normals(std::size_t /*patch*/, std::span<const DomainPoint<T>> /*points*/,
                                  std::span<const vec3_t<T>> /*position*/, std::span<const vec2_t<T>> /*uv*/,
                                  std::span<vec3_t<T>> /*normal*/) const {}

    // A user's geometry shader (user_program.cpp) makes the patch's output: any number of
    // triangles with any positions, so the surface's size is known only once it has run.
    // geometry() runs the evaluation at every domain point of the pattern and the geometry
    // shader over the pattern's triangles (as GL hands them on: the generator's order and
    // orientation), and writes what it emitted as whole triangles, three vertices each, in
    // the order emitted: positions, patch ids, tess coords, uvs and normals where has_uvs /
    // has_normals, each triangle reversed (1 <-> 2) where flip is set, as emit() reverses the
    // pattern's; `face_normals` one per triangle when the scene asks for face normals.
    // Called after control() of the same patch, concurrently for different patches.
    virtual bool geometry_shader() const { return false; }
    virtual void geometry(std::size_t /*patch*/, const Pattern& /*pattern*/, SurfaceMesh& /*out*/,
                          std::vector<glm::dvec3>& /*face_normals*/) const {}

    bool has_uvs = false;     // the evaluation writes texture coordinates
    bool has_normals = false; // the evaluation or the geometry stage writes vertex normals
    bool flip = false;        // reverse each triangle so that it faces up / out
};

// A geomipmapped terrain has no tessellation stages and so no PatchProgram: run_pipeline
// hands it to this whole-terrain pass instead (geomipmap.cpp).
PipelineResult run_geomipmap(const Scene& scene, const PipelineOptions& options);

// The scene's program in precision T (float: Precision::gpu, double: Precision::exact).
// origin: camera-relative evaluation (pipeline.h PipelineOptions::camera_relative) when
// non-zero: control() reads the world corners as always, evaluate() works on the corners
// minus origin (shifted in double) with the texture mapping shifted alike, and writes
// positions relative to origin.
template <typename T>
std::unique_ptr<PatchProgram<T>> make_program(const Scene& scene, const glm::dvec3& origin);

// The scene's evaluation model's program (the C++ models; nullptr for geomipmap).
template <typename T>
std::unique_ptr<PatchProgram<T>> make_model_program(const Scene& scene, const glm::dvec3& origin);

// The user's vertex, control, evaluation and geometry shaders of the scene's [shaders] that
// the CPU runs through the interpreter: those whose text is not exactly the shipped twin's (a
// twin given as a user file keeps its C++ model). Empty for a geomipmapped terrain (no
// tessellation stages); never a fragment shader, which the pipeline does not run (a user's
// fragment shader is the render's: src/render/user_fragment.cpp).
// Throws tessref::Error when a file cannot be read.
std::vector<StageShader> interpreted_stages(const Scene& scene);

// The program that runs `user` (interpreted_stages) through the SPIR-V interpreter, with the
// model's program for what the interpreter does not run (user_program.cpp).
std::unique_ptr<PatchProgram<float>> make_user_program(const Scene& scene, std::unique_ptr<PatchProgram<float>> model,
                                                       const std::vector<StageShader>& user);

// The uniforms every model reads from the camera, in precision T (identity without one).
template <typename T>
struct CameraUniforms {
    mat4_t<T> view{T(1)};
    mat4_t<T> viewProjection{T(1)};
    vec3_t<T> cameraPosition{T(0)};
    // The evaluation's gl_Position of origin-relative positions (camera-relative evaluation).
    mat4_t<T> relativeViewProjection{T(1)};
    CameraUniforms(const Scene& scene, const glm::dvec3& origin) {
        if (!scene.camera) return;
        view = mat4_t<T>(scene.camera->view());
        viewProjection = mat4_t<T>(scene.camera->view_projection());
        cameraPosition = vec3_t<T>(scene.camera->eye);
        relativeViewProjection = mat4_t<T>(camera_moved_by(*scene.camera, origin).view_projection());
    }
};

// A texture as a GLSL sampler2D; an unbound sampler (null texture) reads 0.
template <typename T>
Sampler2D<T> sampler(const std::shared_ptr<const Texture>& texture) {
    if (!texture) return [](vec2_t<T>) { return vec4_t<T>(T(0)); };
    return [texture](vec2_t<T> st) { return texture->texture(st); };
}
template <typename T>
Sampler2DBatch<T> sampler_batch(const std::shared_ptr<const Texture>& texture) {
    if (!texture)
        return [](std::span<const vec2_t<T>>, std::span<vec4_t<T>> out) {
            std::fill(out.begin(), out.end(), vec4_t<T>(T(0)));
        };
    return [texture](std::span<const vec2_t<T>> st, std::span<vec4_t<T>> out) { texture->texture(st, out); };
}
template <typename T>
Sampler2DRedBatch<T> sampler_red_batch(const std::shared_ptr<const Texture>& texture) {
    if (!texture)
        return [](std::span<const vec2_t<T>>, std::span<T> red) { std::fill(red.begin(), red.end(), T(0)); };
    return [texture](std::span<const vec2_t<T>> st, std::span<T> red) { texture->texture_red(st, red); };
}
template <typename T>
Sampler2DLod<T> sampler_lod(const std::shared_ptr<const Texture>& texture) {
    return [texture](vec2_t<T> st, T lod) { return texture->textureLod(st, lod); };
}

// The constant control model, the only one every domain accepts.
template <typename T>
PatchLevels<T> scene_constant_levels(const ControlStage& control) {
    return constant_levels<T>(static_cast<T>(control.constant.level));
}

}  // namespace tessref::pipeline
