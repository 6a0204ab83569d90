// program.cpp — make_program(): the one place that picks a model's program.
#include "pipeline/program.h"

namespace tessref::pipeline {

template <typename T> std::unique_ptr<PatchProgram<T>> make_thesis_program(const Scene&, const glm::dvec3&);
template <typename T> std::unique_ptr<PatchProgram<T>> make_cosc422_program(const Scene&, const glm::dvec3&);
template <typename T> std::unique_ptr<PatchProgram<T>> make_lab4_program(const Scene&, const glm::dvec3&);
template <typename T> std::unique_ptr<PatchProgram<T>> make_pn_program(const Scene&, const glm::dvec3&);

// The evaluation model decides the program: the loader has checked that the control model,
// the domain and the geometry stage fit it.
template <typename T>
std::unique_ptr<PatchProgram<T>> make_program(const Scene& scene, const glm::dvec3& origin) {
    switch (scene.evaluation.model) {
        case EvaluationModel::thesis: return make_thesis_program<T>(scene, origin);
        case EvaluationModel::cosc422: return make_cosc422_program<T>(scene, origin);
        case EvaluationModel::lab4: return make_lab4_program<T>(scene, origin);
        case EvaluationModel::pn: return make_pn_program<T>(scene, origin);
        case EvaluationModel::geomipmap: break;  // no patch program: run_geomipmap
    }
    return nullptr;
}
template std::unique_ptr<PatchProgram<float>> make_program(const Scene&, const glm::dvec3&);
template std::unique_ptr<PatchProgram<double>> make_program(const Scene&, const glm::dvec3&);

}  // namespace tessref::pipeline
