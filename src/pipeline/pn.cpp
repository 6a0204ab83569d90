// pn.cpp — the PN-triangles program (data/shaders/pn_triangles.*): one patch per mesh
// triangle; the control stage writes the PN control points, the evaluation the curved
// surface and its normal.
#include "pipeline/program.h"

#include <type_traits>
#include <vector>

#include "shader/llvmpipe_math.h"
#include "tessref/evaluation.h"

namespace tessref::pipeline {
namespace {

template <typename T>
class PnProgram final : public PatchProgram<T> {
public:
    PnProgram(const Scene& s, const glm::dvec3& o)
        : scene(s), meshes(*s.meshes), camera(s, o), origin(o), relative(o != glm::dvec3(0.0)) {
        this->flip = scene.generator.winding == Winding::cw;
        this->has_uvs = !meshes.uvs.empty();
        this->has_normals = !scene.geometry;  // the evaluation's normal, unless [geometry] replaces it
        if (scene.control && scene.control->model == ControlModel::pn) {
            static_cast<PnControlParams<T>&>(control_uniforms) = scene.control->pn.as<T>();
            const glm::ivec2 vp = scene.camera ? scene.camera->viewport : glm::ivec2(1280, 800);
            control_uniforms.v2Resolution = vec2_t<T>(static_cast<T>(vp.x), static_cast<T>(vp.y));
        }
        static_cast<PnEvaluationParams<T>&>(evaluation) = scene.evaluation.pn.as<T>();
        evaluation.m4ViewProjection = relative ? camera.relativeViewProjection : camera.viewProjection;
        patches.assign(meshes.patch_count(), {});
    }

    PatchLevels<T> control(std::size_t p) override {
        const auto& tri = meshes.triangles[p];
        TriangleCorners<T> pos, nrm;
        std::array<vec2_t<T>, 3> uv{};
        std::array<vec4_t<T>, 3> glPosition{};
        for (int k = 0; k < 3; ++k) {
            pos[k] = vec3_t<T>(meshes.positions[tri[k]]);
            nrm[k] = vec3_t<T>(meshes.normals[tri[k]]);
            if (!meshes.uvs.empty()) uv[k] = vec2_t<T>(meshes.uvs[tri[k]]);
            glPosition[k] = vertex(pos[k]);
        }
        if (relative) {
            // Camera-relative: the evaluation's control points from the positions minus the
            // origin (shifted in double, rounded once); the control stage above keeps the
            // world positions, so its levels do not change.
            TriangleCorners<T> shifted;
            for (int k = 0; k < 3; ++k) shifted[k] = vec3_t<T>(meshes.positions[tri[k]] - origin);
            patches[p] = pn_patch<T>(shifted, nrm, uv);
        } else {
            patches[p] = pn_patch<T>(pos, nrm, uv);
        }
        if (!scene.control) return {};  // GL's default patch levels: 1
        if (scene.control->model == ControlModel::pn) return pn_levels<T>(glPosition, nrm, control_uniforms);
        return scene_constant_levels<T>(*scene.control);
    }

    void use_math(MathMode math) override { control_uniforms.math = math; }

    // The tutorial's vertex shader: gl_Position = m4ViewProjection * (m4Transform * position),
    // the model transform the identity. In llvmpipe math (float) the product's sums in the
    // driver's order.
    vec4_t<T> vertex(const vec3_t<T>& position) const {
        if constexpr (std::is_same_v<T, float>) {
            if (control_uniforms.math == MathMode::llvmpipe)
                return llvmpipe_math::transform(camera.viewProjection, vec4_t<T>(position, T(1)));
        }
        return camera.viewProjection * vec4_t<T>(position, T(1));
    }

    void evaluate(std::size_t p, std::span<const DomainPoint<T>> points, SurfaceMesh& mesh,
                  std::size_t first_vertex, bool normals) const override {
        for (std::size_t k = 0; k < points.size(); ++k) {
            const EvaluatedVertex<T> ev = pn_evaluate<T>(patches[p], points[k], evaluation);
            const std::size_t v = first_vertex + k;
            mesh.positions[v] = glm::dvec3(ev.position);
            if (this->has_uvs) mesh.uvs[v] = glm::dvec2(ev.textureCoordinate);
            if (this->has_normals && normals) mesh.normals[v] = glm::dvec3(ev.normal);
        }
    }

private:
    const Scene& scene;
    const TriangleMeshes& meshes;
    CameraUniforms<T> camera;
    const glm::dvec3 origin;  // camera-relative evaluation: non-zero (pipeline.h)
    const bool relative;
    PnControl<T> control_uniforms{};
    PnEvaluation<T> evaluation{};
    std::vector<PnPatch<T>> patches;  // per patch: the control stage's output
};

}  // namespace

template <typename T>
std::unique_ptr<PatchProgram<T>> make_pn_program(const Scene& scene, const glm::dvec3& origin) {
    return std::make_unique<PnProgram<T>>(scene, origin);
}
template std::unique_ptr<PatchProgram<float>> make_pn_program(const Scene&, const glm::dvec3&);
template std::unique_ptr<PatchProgram<double>> make_pn_program(const Scene&, const glm::dvec3&);

}  // namespace tessref::pipeline
