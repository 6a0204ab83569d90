// program.cpp — make_program(): the one place that picks a model's program.
#include "pipeline/program.h"

#include <string>
#include <type_traits>

#include "tessref/error.h"

namespace tessref::pipeline {

template <typename T> std::unique_ptr<PatchProgram<T>> make_thesis_program(const Scene&, const glm::dvec3&);
template <typename T> std::unique_ptr<PatchProgram<T>> make_cosc422_program(const Scene&, const glm::dvec3&);
template <typename T> std::unique_ptr<PatchProgram<T>> make_lab4_program(const Scene&, const glm::dvec3&);
template <typename T> std::unique_ptr<PatchProgram<T>> make_pn_program(const Scene&, const glm::dvec3&);

// The evaluation model decides the program: the loader has checked that the control model,
// the domain and the geometry stage fit it.
template <typename T>
std::unique_ptr<PatchProgram<T>> make_model_program(const Scene& scene, const glm::dvec3& origin) {
    switch (scene.evaluation.model) {
        case EvaluationModel::thesis: return make_thesis_program<T>(scene, origin);
        case EvaluationModel::cosc422: return make_cosc422_program<T>(scene, origin);
        case EvaluationModel::lab4: return make_lab4_program<T>(scene, origin);
        case EvaluationModel::pn: return make_pn_program<T>(scene, origin);
        case EvaluationModel::geomipmap: break;  // no patch program: run_geomipmap
    }
    return nullptr;
}

// A user's vertex, control or evaluation shader ([shaders], --shader) runs through the
// interpreter (user_program.cpp), in float as the GPU runs it.
template <typename T>
std::unique_ptr<PatchProgram<T>> make_program(const Scene& scene, const glm::dvec3& origin) {
    std::unique_ptr<PatchProgram<T>> model = make_model_program<T>(scene, origin);
    if (!model) return model;
    const std::vector<StageShader> user = interpreted_stages(scene);
    if (user.empty()) return model;
    const std::string what = std::string("the ") + to_string(user.front().stage) + " shader " + user.front().path;
    if constexpr (!std::is_same_v<T, float>) {
        throw Error(what + " runs in gpu precision only (the interpreter computes in float, as the GPU does): "
                    "leave --precision at gpu",
                    user.front().where);
    } else {
        if (origin != glm::dvec3(0.0))
            throw Error(what + " cannot run with camera-relative evaluation (a shader computes its texture "
                        "coordinates from the world position it is given)",
                        user.front().where);
        return make_user_program(scene, std::move(model), user);
    }
}
template std::unique_ptr<PatchProgram<float>> make_model_program(const Scene&, const glm::dvec3&);
template std::unique_ptr<PatchProgram<double>> make_model_program(const Scene&, const glm::dvec3&);
template std::unique_ptr<PatchProgram<float>> make_program(const Scene&, const glm::dvec3&);
template std::unique_ptr<PatchProgram<double>> make_program(const Scene&, const glm::dvec3&);

}  // namespace tessref::pipeline
