// program.cpp — make_program(): the one place that picks a model's program.
#include "pipeline/program.h"

namespace tessref::pipeline {

template <typename T> std::unique_ptr<PatchProgram<T>> make_thesis_program(const Scene&);
template <typename T> std::unique_ptr<PatchProgram<T>> make_cosc422_program(const Scene&);
template <typename T> std::unique_ptr<PatchProgram<T>> make_lab4_program(const Scene&);
template <typename T> std::unique_ptr<PatchProgram<T>> make_pn_program(const Scene&);

// The evaluation model decides the program: the loader has checked that the control model,
// the domain and the geometry stage fit it.
template <typename T>
std::unique_ptr<PatchProgram<T>> make_program(const Scene& scene) {
    switch (scene.evaluation.model) {
        case EvaluationModel::thesis: return make_thesis_program<T>(scene);
        case EvaluationModel::cosc422: return make_cosc422_program<T>(scene);
        case EvaluationModel::lab4: return make_lab4_program<T>(scene);
        case EvaluationModel::pn: return make_pn_program<T>(scene);
        case EvaluationModel::geomipmap: break;  // no patch program: run_geomipmap
    }
    return nullptr;
}
template std::unique_ptr<PatchProgram<float>> make_program(const Scene&);
template std::unique_ptr<PatchProgram<double>> make_program(const Scene&);

}  // namespace tessref::pipeline
