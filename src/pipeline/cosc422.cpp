// cosc422.cpp — the COSC422 terrain exercise's program (data/shaders/cosc422_terrain.*):
// a pass-through vertex shader, texture coordinates from the grid's extent, height in y.
#include "pipeline/terrain.h"

namespace tessref::pipeline {
namespace {

template <typename T>
class Cosc422Program final : public TerrainProgram<T> {
public:
    explicit Cosc422Program(const Scene& s) : TerrainProgram<T>(s) {
        const TerrainGrid& g = this->grid;
        evaluation.heightMap = this->heightMap;
        evaluation.mvpMatrix = this->camera.viewProjection;
        evaluation.xMin = static_cast<T>(g.extent_u.x);
        evaluation.xMax = static_cast<T>(g.extent_u.y);
        evaluation.zMin = static_cast<T>(g.extent_v.x);
        evaluation.zMax = static_cast<T>(g.extent_v.y);
        evaluation.heightScale = static_cast<T>(g.scale_z);
    }

private:
    EvaluatedVertex<T> evaluate_point(std::size_t p, const DomainPoint<T>& tc) const override {
        return cosc422_evaluate<T>(this->tcPosition[p], tc, evaluation);
    }

    Cosc422Evaluation<T> evaluation{};
};

}  // namespace

template <typename T>
std::unique_ptr<PatchProgram<T>> make_cosc422_program(const Scene& scene) {
    return std::make_unique<Cosc422Program<T>>(scene);
}
template std::unique_ptr<PatchProgram<float>> make_cosc422_program(const Scene&);
template std::unique_ptr<PatchProgram<double>> make_cosc422_program(const Scene&);

}  // namespace tessref::pipeline
