// terrain.cpp — the grid's vertex buffer, the terrain control models and the per-vertex
// geometry normals, shared by the thesis, cosc422 and lab4 programs.
#include "pipeline/terrain.h"

#include <algorithm>
#include <cmath>

#include "tessref/geometry.h"

namespace tessref::pipeline {

template <typename T>
glm::dvec2 TerrainProgram<T>::ground_origin() const {
    return grid.plane == GroundPlane::xy ? glm::dvec2(origin.x, origin.y) : glm::dvec2(origin.x, origin.z);
}

template <typename T>
TerrainProgram<T>::TerrainProgram(const Scene& s, const glm::dvec3& o)
    : scene(s), grid(*s.grid), origin(o), relative(o != glm::dvec3(0.0)), camera(s, o) {
    const TerrainGrid& g = grid;
    height_texture = std::shared_ptr<const Texture>(g.heightmap, &g.heightmap->texture);
    heightMap = sampler<T>(height_texture);
    heightMapLod = sampler_lod<T>(height_texture);
    heightMapRedBatch = sampler_red_batch<T>(height_texture);
    if (g.normal_map) normalMap = sampler<T>(g.normal_map);
    normalMapBatch = sampler_batch<T>(g.normal_map);
    for (double u : g.u_coords) u_coords.push_back(static_cast<T>(u));
    for (double v : g.v_coords) v_coords.push_back(static_cast<T>(v));
    if (relative) {
        // Shifted in double, then rounded once: the vertex buffer a camera-relative
        // application would upload.
        const glm::dvec2 o2 = ground_origin();
        for (double u : g.u_coords) u_relative.push_back(static_cast<T>(u - o2.x));
        for (double v : g.v_coords) v_relative.push_back(static_cast<T>(v - o2.y));
    }

    // The grid's facing: cross(c3 - c0, c1 - c0) against the plane's up axis.
    const auto c = g.corners(0);
    const glm::dvec3 up = g.plane == GroundPlane::xy ? glm::dvec3(0, 0, 1) : glm::dvec3(0, 1, 0);
    const bool ccw_faces_up = glm::dot(glm::cross(c[3] - c[0], c[1] - c[0]), up) > 0.0;
    this->flip = ccw_faces_up != (scene.generator.winding == Winding::ccw);
    this->has_uvs = true;
    geometry_vertex_normals = scene.geometry && (scene.geometry->normals == GeometryNormals::normal_map ||
                                                 scene.geometry->normals == GeometryNormals::height_field);
    this->has_normals = geometry_vertex_normals;

    const std::size_t n = g.patch_count();
    tcPosition.assign(n, {});
    if (!scene.control) return;
    const ControlStage& c0 = *scene.control;
    if (c0.model == ControlModel::thesis) {
        static_cast<ThesisControlParams<T>&>(thesisControl) = c0.thesis.as<T>();
        thesisControl.scaleXY = static_cast<T>(g.scale_xy);
        thesisControl.cameraPosition = camera.cameraPosition;
        thesisControl.tessellationMap = sampler<T>(c0.tessellation_map);
        thesisControl.normalMap = normalMap;
    } else if (c0.model == ControlModel::lab4) {
        static_cast<Lab4ControlParams<T>&>(lab4Control) = c0.lab4.as<T>();
        lab4Control.cameraPosition = camera.cameraPosition;
        lab4Lod.assign(n, {});
    }
}

// The vertex shader on the patch's four grid corners, then the control shader.
template <typename T>
PatchLevels<T> TerrainProgram<T>::control(std::size_t p) {
    const std::size_t i = p % static_cast<std::size_t>(grid.patches_u);
    const std::size_t j = p / static_cast<std::size_t>(grid.patches_u);
    auto ground = [&](const std::vector<T>& us, const std::vector<T>& vs, std::size_t a, std::size_t b) {
        return grid.plane == GroundPlane::xy ? vec3_t<T>(us[a], vs[b], T(0)) : vec3_t<T>(us[a], T(0), vs[b]);
    };
    // control.h layout: c0 = (u,v) (0,0), c1 = (0,1), c2 = (1,1), c3 = (1,0).
    auto flat = [&](const std::vector<T>& us, const std::vector<T>& vs) {
        return std::array<vec3_t<T>, 4>{ground(us, vs, i, j), ground(us, vs, i, j + 1), ground(us, vs, i + 1, j + 1),
                                        ground(us, vs, i + 1, j)};
    };
    // The control stage always sees the world corners (its levels do not depend on the
    // option); the evaluation reads the origin-relative ones when camera-relative.
    std::array<vec4_t<T>, 4> corners;
    const auto world = flat(u_coords, v_coords);
    for (int k = 0; k < 4; ++k) corners[k] = vertex(world[k], false);
    if (relative) {
        const auto shifted = flat(u_relative, v_relative);
        for (int k = 0; k < 4; ++k) tcPosition[p][k] = vertex(shifted[k], true);
    } else {
        tcPosition[p] = corners;
    }
    const QuadCorners<T> vPosition{vec3_t<T>(corners[0]), vec3_t<T>(corners[1]), vec3_t<T>(corners[2]),
                                   vec3_t<T>(corners[3])};
    if (!scene.control) return {};  // GL's default patch levels: 1
    const ControlStage& c = *scene.control;
    switch (c.model) {
        case ControlModel::constant: return scene_constant_levels<T>(c);
        case ControlModel::thesis: return thesis_levels<T>(vPosition, thesisControl);
        case ControlModel::cosc422: return cosc422_levels<T>(vPosition, c.cosc422, camera.view);
        case ControlModel::lab4: {
            const Lab4ControlOutput<T> out = lab4_control<T>(vPosition, lab4Control);
            lab4Lod[p] = out.lod;
            return out.levels;
        }
        case ControlModel::pn: break;  // rejected at load for a terrain
    }
    return {};
}

template <typename T>
void TerrainProgram<T>::evaluate(std::size_t p, std::span<const DomainPoint<T>> points, SurfaceMesh& mesh,
                                 std::size_t first_vertex, bool normals) const {
    evaluate_into(p, points, mesh, first_vertex, normals, nullptr);
}

template <typename T>
void TerrainProgram<T>::evaluate_into(std::size_t p, std::span<const DomainPoint<T>> points, SurfaceMesh& mesh,
                                      std::size_t first_vertex, bool normals,
                                      PatchStream::Projection* projection) const {
    const bool write_normals = geometry_vertex_normals && normals;
    std::array<vec3_t<T>, kBlock> position;
    std::array<vec2_t<T>, kBlock> textureCoordinate;
    std::array<vec3_t<T>, kBlock> normal;
    for (std::size_t k0 = 0; k0 < points.size(); k0 += kBlock) {
        const std::size_t count = std::min(kBlock, points.size() - k0);
        const auto tc = points.subspan(k0, count);
        const std::span<vec3_t<T>> positions(position.data(), count);
        const std::span<vec2_t<T>> coordinates(textureCoordinate.data(), count);
        evaluate_block(p, tc, positions, coordinates);
        if (write_normals) vertex_normals(p, tc, positions, coordinates, std::span<vec3_t<T>>(normal.data(), count));
        // The mesh in double, written in order.
        const std::size_t v = first_vertex + k0;
        if (!projection || projection->positions)
            for (std::size_t k = 0; k < count; ++k) mesh.positions[v + k] = glm::dvec3(position[k]);
        for (std::size_t k = 0; k < count; ++k) mesh.uvs[v + k] = glm::dvec2(textureCoordinate[k]);
        if (write_normals)
            for (std::size_t k = 0; k < count; ++k) mesh.normals[v + k] = glm::dvec3(normal[k]);
        // gl_Position from the block's positions as computed (rounded to float when T is
        // double, as the mesh's would be): the same clip coordinates as from the mesh.
        if (projection)
            projection->finite &= project_vertices(positions.data(), count, projection->mvp, projection->clip + v);
    }
}

template <typename T>
void TerrainProgram<T>::later_normals(std::size_t p, std::span<const DomainPoint<T>> points,
                                      std::span<const std::uint32_t> vertices, SurfaceMesh& mesh) const {
    if (!geometry_vertex_normals) return;
    // A normal-map normal reads the texture coordinate alone: the positions (scattered
    // loads, the vertices are the few that won a pixel) only for height-field normals.
    const bool positions = scene.geometry->normals == GeometryNormals::height_field;
    std::array<vec3_t<T>, kBlock> position{};
    std::array<vec2_t<T>, kBlock> textureCoordinate;
    std::array<vec3_t<T>, kBlock> normal;
    for (std::size_t k0 = 0; k0 < points.size(); k0 += kBlock) {
        const std::size_t count = std::min(kBlock, points.size() - k0);
        for (std::size_t k = 0; k < count; ++k) textureCoordinate[k] = vec2_t<T>(mesh.uvs[vertices[k0 + k]]);
        if (positions)
            for (std::size_t k = 0; k < count; ++k) position[k] = vec3_t<T>(mesh.positions[vertices[k0 + k]]);
        vertex_normals(p, points.subspan(k0, count), std::span<const vec3_t<T>>(position.data(), count),
                       std::span<const vec2_t<T>>(textureCoordinate.data(), count),
                       std::span<vec3_t<T>>(normal.data(), count));
        for (std::size_t k = 0; k < count; ++k) mesh.normals[vertices[k0 + k]] = glm::dvec3(normal[k]);
    }
}

template <typename T>
void TerrainProgram<T>::vertex_normals(std::size_t p, std::span<const DomainPoint<T>> tc,
                                       std::span<const vec3_t<T>> position,
                                       std::span<const vec2_t<T>> textureCoordinate,
                                       std::span<vec3_t<T>> normal) const {
    if (scene.geometry->normals == GeometryNormals::normal_map) {
        // thesis_terrain.geom: gNormal = NormalFromTexture(texture(normalMap, textureCoordinate).rgb)
        std::array<vec4_t<T>, kBlock> texel;
        const std::span<vec4_t<T>> texels(texel.data(), tc.size());
        normalMapBatch(textureCoordinate, texels);
        thesis_normals_from_texture<T>(texels, normalMatrix, normal);
        return;
    }
    for (std::size_t k = 0; k < tc.size(); ++k)
        normal[k] = height_field_normal<T>(scene, position[k], vertex_lod(p, tc[k]), origin);
}

template <typename T>
vec3_t<T> height_field_normal(const Scene& scene, const vec3_t<T>& position, T lod, const glm::dvec3& origin) {
    const TerrainGrid& g = *scene.grid;
    // The origin along the grid's axes (0 without camera-relative evaluation, where the
    // mapping below is the one it always was: adding 0 changes no double).
    const glm::dvec2 o = g.plane == GroundPlane::xy ? glm::dvec2(origin.x, origin.y) : glm::dvec2(origin.x, origin.z);
    const Texture& texture = g.heightmap->texture;
    Lab4NormalSampling<T> sampling;
    sampling.verticalScale = static_cast<T>(g.scale_z);
    sampling.lod = lod;
    switch (scene.evaluation.model) {
        case EvaluationModel::lab4:  // lab4_terrain.tese: lab4_vertex_normal(position.x, position.z, lod)
        case EvaluationModel::thesis:
            // texCoord = (x, z) / horizontalScale + texCoordOffset; the thesis's xy / scaleXY
            // is the same with its y as appendix A's z and no offset.
            sampling.heightMap = [&texture](vec2_t<T> st, T level) { return texture.textureLod(st, level); };
            sampling.horizontalScale = static_cast<T>(g.scale_xy);
            // Relative to origin: (x - o) / scale + (offset + o / scale), the sum in double.
            if (scene.evaluation.model == EvaluationModel::lab4)
                sampling.texCoordOffset =
                    vec2_t<T>(o == glm::dvec2(0.0) ? g.texcoord_offset : g.texcoord_offset + o / g.scale_xy);
            else if (o != glm::dvec2(0.0))
                sampling.texCoordOffset = vec2_t<T>(o / g.scale_xy);
            sampling.h = static_cast<T>(g.scale_xy / texture.width());
            break;
        case EvaluationModel::cosc422: {
            // GLSL: cosc422_terrain.tese:36 (x - xMin) / (xMax - xMin)
            // s = (x - xMin) / (xMax - xMin), t = (z - zMin) / (zMax - zMin), as the
            // evaluation shader maps it; horizontalScale 1 and no offset pass (x, z) through.
            // GLSL: cosc422_terrain.tese:40 height_field_normal (tessref gl defines TERRAIN_NORMALS)
            const vec2_t<T> lo(static_cast<T>(g.extent_u.x - o.x), static_cast<T>(g.extent_v.x - o.y));
            const vec2_t<T> size(static_cast<T>(g.extent_u.y - g.extent_u.x), static_cast<T>(g.extent_v.y - g.extent_v.x));
            sampling.heightMap = [&texture, lo, size](vec2_t<T> p, T level) {
                return texture.textureLod((p - lo) / size, level);
            };
            // GLSL: cosc422_terrain.tese:32 gridStep (set by tessref gl as this h, in double, then rounded)
            sampling.h = static_cast<T>(std::abs(g.extent_u.y - g.extent_u.x) / texture.width());
            break;
        }
        case EvaluationModel::pn: break;  // no height field
        case EvaluationModel::geomipmap: break;  // no patch program (run_geomipmap)
    }
    if (g.plane == GroundPlane::xz) return lab4_vertex_normal<T>(position.x, position.z, sampling);
    // Plane xy: appendix A's frame (x, up, z') has z' = world y, so its (nx, n_up, nz') is
    // the world normal (nx, nz', n_up).
    const vec3_t<T> n = lab4_vertex_normal<T>(position.x, position.y, sampling);
    return vec3_t<T>(n.x, n.z, n.y);
}

template vec3_t<float> height_field_normal(const Scene&, const vec3_t<float>&, float, const glm::dvec3&);
template vec3_t<double> height_field_normal(const Scene&, const vec3_t<double>&, double, const glm::dvec3&);

template class TerrainProgram<float>;
template class TerrainProgram<double>;

}  // namespace tessref::pipeline
