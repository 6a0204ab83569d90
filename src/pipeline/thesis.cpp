// thesis.cpp — the thesis's program (data/shaders/thesis_terrain.*): its vertex shader
// reads the height at each grid corner (the control shader's factors see it), its
// evaluation shader samples the height again at every domain point.
#include "pipeline/terrain.h"

#include <algorithm>
#include <array>

namespace tessref::pipeline {
namespace {

template <typename T>
class ThesisProgram final : public TerrainProgram<T> {
public:
    ThesisProgram(const Scene& s, const glm::dvec3& origin) : TerrainProgram<T>(s, origin) {
        scaleXY = static_cast<T>(this->grid.scale_xy);
        scaleZ = static_cast<T>(this->grid.scale_z);
        evaluationHeightMap = this->heightMap;
        evaluationHeightMapRedBatch = this->heightMapRedBatch;
        if (this->relative) {
            // Camera-relative: textureCoordinate = position.xy / scaleXY + textureOffset, with
            // textureOffset = origin.xy / scaleXY in double, rounded once. The shaders' functions
            // stay as they are: the offset is added to what they sample at (samplers that add
            // it) and to the coordinate they return (evaluate_block), the same float sum.
            textureOffset = vec2_t<T>(this->ground_origin() / this->grid.scale_xy);
            const vec2_t<T> offset = textureOffset;
            const Sampler2D<T> world = this->heightMap;
            evaluationHeightMap = [world, offset](vec2_t<T> st) { return world(st + offset); };
            const Sampler2DRedBatch<T> worldBatch = this->heightMapRedBatch;
            evaluationHeightMapRedBatch = [worldBatch, offset](std::span<const vec2_t<T>> st, std::span<T> out) {
                std::array<vec2_t<T>, TerrainProgram<T>::kBlock> shifted;
                for (std::size_t k0 = 0; k0 < st.size(); k0 += shifted.size()) {
                    const std::size_t count = std::min(shifted.size(), st.size() - k0);
                    for (std::size_t k = 0; k < count; ++k) shifted[k] = st[k0 + k] + offset;
                    worldBatch(std::span<const vec2_t<T>>(shifted.data(), count), out.subspan(k0, count));
                }
            };
        }
    }

private:
    vec4_t<T> vertex(const vec3_t<T>& ground, bool relative) const override {
        // thesis_terrain.vert
        return thesis_vertex<T>(vec2_t<T>(ground), relative ? evaluationHeightMap : this->heightMap, scaleXY, scaleZ);
    }
    void evaluate_block(std::size_t p, std::span<const DomainPoint<T>> tc, std::span<vec3_t<T>> position,
                        std::span<vec2_t<T>> textureCoordinate) const override {
        // thesis_terrain.tese (thesis_evaluate) without gl_Position, which the mesh does not keep.
        thesis_evaluate_batch<T>(this->tcPosition[p], tc, evaluationHeightMapRedBatch, scaleXY, scaleZ, position,
                                 textureCoordinate);
        if (this->relative)
            for (vec2_t<T>& st : textureCoordinate) st = st + textureOffset;
    }

    T scaleXY = T(1), scaleZ = T(1);  // the uniforms
    vec2_t<T> textureOffset{T(0)};    // camera-relative only
    // The evaluation's heightMap: the scene's, or when camera-relative one that adds
    // textureOffset to the coordinate.
    Sampler2D<T> evaluationHeightMap;
    Sampler2DRedBatch<T> evaluationHeightMapRedBatch;
};

}  // namespace

template <typename T>
std::unique_ptr<PatchProgram<T>> make_thesis_program(const Scene& scene, const glm::dvec3& origin) {
    return std::make_unique<ThesisProgram<T>>(scene, origin);
}
template std::unique_ptr<PatchProgram<float>> make_thesis_program(const Scene&, const glm::dvec3&);
template std::unique_ptr<PatchProgram<double>> make_thesis_program(const Scene&, const glm::dvec3&);

}  // namespace tessref::pipeline
