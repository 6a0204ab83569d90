// cosc422.cpp — the COSC422 terrain exercise's program (data/shaders/cosc422_terrain.*):
// a pass-through vertex shader, texture coordinates from the grid's extent, height in y.
#include "pipeline/terrain.h"

namespace tessref::pipeline {
namespace {

template <typename T>
class Cosc422Program final : public TerrainProgram<T> {
public:
    Cosc422Program(const Scene& s, const glm::dvec3& origin) : TerrainProgram<T>(s, origin) {
        const TerrainGrid& g = this->grid;
        // Camera-relative: the extent shifted by the origin in double, then rounded, as the
        // corners are (o is 0 otherwise, and x - 0 is x).
        const glm::dvec2 o = this->ground_origin();
        evaluation.heightMap = this->heightMap;
        evaluation.mvpMatrix = this->relative ? this->camera.relativeViewProjection : this->camera.viewProjection;
        evaluation.xMin = static_cast<T>(g.extent_u.x - o.x);
        evaluation.xMax = static_cast<T>(g.extent_u.y - o.x);
        evaluation.zMin = static_cast<T>(g.extent_v.x - o.y);
        evaluation.zMax = static_cast<T>(g.extent_v.y - o.y);
        evaluation.heightScale = static_cast<T>(g.scale_z);
    }

private:
    void evaluate_block(std::size_t p, std::span<const DomainPoint<T>> tc, std::span<vec3_t<T>> position,
                        std::span<vec2_t<T>> textureCoordinate) const override {
        this->evaluate_each(tc, position, textureCoordinate, [&](const DomainPoint<T>& c) {
            return cosc422_evaluate<T>(this->tcPosition[p], c, evaluation);
        });
    }

    Cosc422Evaluation<T> evaluation{};
};

}  // namespace

template <typename T>
std::unique_ptr<PatchProgram<T>> make_cosc422_program(const Scene& scene, const glm::dvec3& origin) {
    return std::make_unique<Cosc422Program<T>>(scene, origin);
}
template std::unique_ptr<PatchProgram<float>> make_cosc422_program(const Scene&, const glm::dvec3&);
template std::unique_ptr<PatchProgram<double>> make_cosc422_program(const Scene&, const glm::dvec3&);

}  // namespace tessref::pipeline
