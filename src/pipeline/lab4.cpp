// lab4.cpp — lab 4's program (data/shaders/lab4_terrain.*): a camera-centred grid, the
// height sampled from the mip level that matches each vertex's tessellation level, and
// appendix A's normal at that same level.
#include "pipeline/terrain.h"

namespace tessref::pipeline {
namespace {

template <typename T>
class Lab4Program final : public TerrainProgram<T> {
public:
    Lab4Program(const Scene& s, const glm::dvec3& origin) : TerrainProgram<T>(s, origin) {
        const TerrainGrid& g = this->grid;
        evaluation.heightMap = this->heightMapLod;
        evaluation.mvp = this->camera.viewProjection;
        evaluation.horizontalScale = static_cast<T>(g.scale_xy);
        evaluation.verticalScale = static_cast<T>(g.scale_z);
        evaluation.texCoordOffset = vec2_t<T>(g.texcoord_offset);
        if (this->relative) {
            // Camera-relative: (x - o) / scale + (offset + o / scale), the offset in double.
            evaluation.mvp = this->camera.relativeViewProjection;
            evaluation.texCoordOffset = vec2_t<T>(g.texcoord_offset + this->ground_origin() / g.scale_xy);
        }
    }

private:
    void evaluate_block(std::size_t p, std::span<const DomainPoint<T>> tc, std::span<vec3_t<T>> position,
                        std::span<vec2_t<T>> textureCoordinate) const override {
        this->evaluate_each(tc, position, textureCoordinate, [&](const DomainPoint<T>& c) {
            return lab4_evaluate<T>(this->tcPosition[p], c, this->lab4Lod[p], evaluation);
        });
    }
    T vertex_lod(std::size_t p, const DomainPoint<T>& tc) const override {
        return this->lab4Lod[p].maxLogTessellationLevel - lab4_vertex_log_level<T>(tc, this->lab4Lod[p]);
    }

    Lab4Evaluation<T> evaluation{};
};

}  // namespace

template <typename T>
std::unique_ptr<PatchProgram<T>> make_lab4_program(const Scene& scene, const glm::dvec3& origin) {
    return std::make_unique<Lab4Program<T>>(scene, origin);
}
template std::unique_ptr<PatchProgram<float>> make_lab4_program(const Scene&, const glm::dvec3&);
template std::unique_ptr<PatchProgram<double>> make_lab4_program(const Scene&, const glm::dvec3&);

}  // namespace tessref::pipeline
