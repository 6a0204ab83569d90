// thesis.cpp — the thesis's program (data/shaders/thesis_terrain.*): its vertex shader
// reads the height at each grid corner (the control shader's factors see it), its
// evaluation shader samples the height again at every domain point.
#include "pipeline/terrain.h"

namespace tessref::pipeline {
namespace {

template <typename T>
class ThesisProgram final : public TerrainProgram<T> {
public:
    explicit ThesisProgram(const Scene& s) : TerrainProgram<T>(s) {
        evaluation.heightMap = this->heightMap;
        evaluation.mvp = this->camera.viewProjection;
        evaluation.scaleXY = static_cast<T>(this->grid.scale_xy);
        evaluation.scaleZ = static_cast<T>(this->grid.scale_z);
    }

private:
    vec4_t<T> vertex(const vec3_t<T>& ground) const override {
        // thesis_terrain.vert
        return thesis_vertex<T>(vec2_t<T>(ground), this->heightMap, evaluation.scaleXY, evaluation.scaleZ);
    }
    EvaluatedVertex<T> evaluate_point(std::size_t p, const DomainPoint<T>& tc) const override {
        return thesis_evaluate<T>(this->tcPosition[p], tc, evaluation);
    }

    ThesisEvaluation<T> evaluation{};
};

}  // namespace

template <typename T>
std::unique_ptr<PatchProgram<T>> make_thesis_program(const Scene& scene) {
    return std::make_unique<ThesisProgram<T>>(scene);
}
template std::unique_ptr<PatchProgram<float>> make_thesis_program(const Scene&);
template std::unique_ptr<PatchProgram<double>> make_thesis_program(const Scene&);

}  // namespace tessref::pipeline
