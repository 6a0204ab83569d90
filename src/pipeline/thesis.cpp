// thesis.cpp — the thesis's program (data/shaders/thesis_terrain.*): its vertex shader
// reads the height at each grid corner (the control shader's factors see it), its
// evaluation shader samples the height again at every domain point.
#include "pipeline/terrain.h"

namespace tessref::pipeline {
namespace {

template <typename T>
class ThesisProgram final : public TerrainProgram<T> {
public:
    ThesisProgram(const Scene& s, const glm::dvec3& origin) : TerrainProgram<T>(s, origin) {
        evaluation.heightMap = this->heightMap;
        evaluation.mvp = this->camera.viewProjection;
        evaluation.scaleXY = static_cast<T>(this->grid.scale_xy);
        evaluation.scaleZ = static_cast<T>(this->grid.scale_z);
        if (this->relative) {
            // Camera-relative: textureCoordinate = position.xy / scaleXY + textureOffset, with
            // textureOffset = origin.xy / scaleXY in double, rounded once. The shaders' functions
            // stay as they are: the offset is added to what they sample at (a sampler that adds
            // it) and to the coordinate they return (evaluate_point), the same float sum.
            textureOffset = vec2_t<T>(this->ground_origin() / this->grid.scale_xy);
            const Sampler2D<T> world = this->heightMap;
            const vec2_t<T> offset = textureOffset;
            relativeHeightMap = [world, offset](vec2_t<T> st) { return world(st + offset); };
            evaluation.heightMap = relativeHeightMap;
            evaluation.mvp = this->camera.relativeViewProjection;
        }
    }

private:
    vec4_t<T> vertex(const vec3_t<T>& ground, bool relative) const override {
        // thesis_terrain.vert
        return thesis_vertex<T>(vec2_t<T>(ground), relative ? relativeHeightMap : this->heightMap, evaluation.scaleXY,
                                evaluation.scaleZ);
    }
    EvaluatedVertex<T> evaluate_point(std::size_t p, const DomainPoint<T>& tc) const override {
        EvaluatedVertex<T> out = thesis_evaluate<T>(this->tcPosition[p], tc, evaluation);
        if (this->relative) out.textureCoordinate = out.textureCoordinate + textureOffset;
        return out;
    }

    ThesisEvaluation<T> evaluation{};
    vec2_t<T> textureOffset{T(0)};  // camera-relative only
    Sampler2D<T> relativeHeightMap;  // camera-relative only
};

}  // namespace

template <typename T>
std::unique_ptr<PatchProgram<T>> make_thesis_program(const Scene& scene, const glm::dvec3& origin) {
    return std::make_unique<ThesisProgram<T>>(scene, origin);
}
template std::unique_ptr<PatchProgram<float>> make_thesis_program(const Scene&, const glm::dvec3&);
template std::unique_ptr<PatchProgram<double>> make_thesis_program(const Scene&, const glm::dvec3&);

}  // namespace tessref::pipeline
