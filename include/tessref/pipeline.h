// tessref/pipeline.h — runs a scene through the stages, as GL runs a draw of patches:
//
//   vertex + tessellation control   control.h      per patch: corners and six levels
//   (budget)                        tessellator.h  estimate_triangles, before tessellating
//   primitive generator             tessellator.h  one Pattern per distinct level set
//   tessellation evaluation         evaluation.h   per domain point: position, uv, normal
//   geometry                        geometry.h     per-vertex, per-face or smooth normals
//
// and returns the tessellated surface. The stages themselves are pure functions of plain
// data; src/pipeline/ binds a scene's parameters to them (one binding per evaluation
// model, chosen once per run) and drives the passes over the patches.
//
// OUTPUT. The SurfaceMesh holds, patch after patch in patch order, every domain point of
// the patch's pattern (generator order) evaluated, and the pattern's triangles re-indexed.
// Triangles are counter-clockwise seen from above (terrain: +z for plane xy, +y for plane
// xz) or from outside (meshes, whose faces are counter-clockwise seen from outside, as OBJ
// and OFF files have them): the generator's winding is applied, and the index order is
// reversed when the winding and the grid's orientation together would give the other side.
// Patch ids: terrain patch (i, j) is j * nu + i; mesh patches are the faces, mesh after
// mesh, in file order. The output is byte-identical whatever the thread count: each patch
// fills a pre-sized slot.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/mesh.h"
#include "tessref/scene.h"
#include "tessref/tessellator.h"

namespace tessref {

// Wall-clock seconds of the passes of one run_pipeline() call (steady_clock), for `tessref
// sweep`. Informative only: nothing else depends on them, and asking for them changes no
// output. Per-vertex geometry normals (normal map, height field) and face normals are
// computed in the evaluation pass, vertex by vertex, so they count as evaluation; geometry
// is the pass that runs on its own after it (smooth normals; 0 for other scenes).
struct PipelineTimings {
    double control = 0.0;     // pass 1, vertex + control shaders, and pass 2, the budget
    double generator = 0.0;   // pass 3, patterns and output ranges
    double evaluation = 0.0;  // pass 4, evaluation (and per-vertex / per-face geometry)
    double geometry = 0.0;    // smooth normals over the whole surface, or a user's geometry shader
                              // (with the evaluation it reads: its output is made before pass 4)
};

struct PipelineOptions {
    Precision precision = Precision::gpu;  // gpu: float stages, exact: double stages
    // The control stage's acos and log2 in gpu precision (control.h MathMode): exact (the
    // C library) or llvmpipe (Mesa's approximations, bit for bit). Exact precision ignores it.
    MathMode math = MathMode::exact;
    // Called with (patches done, patch count) as patches finish, from worker threads
    // (serialized by the pipeline); may be empty.
    std::function<void(std::size_t done, std::size_t total)> progress;
    PatternCache* cache = nullptr;         // shared cache; a private one when null

    // Camera-relative evaluation (gpu precision only; ignored in exact precision, whose
    // output it would change by nothing but double rounding). Off: every output as before.
    // On, with a [camera]: the evaluation stage works in float coordinates relative to
    // PipelineResult::origin, the eye (for a terrain, the eye's ground position: the eye
    // with its component along the plane's up axis set to 0, because the evaluation writes
    // the height itself, absolute, from the height map). The grid corners / mesh positions
    // are shifted by -origin in double and then rounded to float, and the model's world ->
    // texture mapping is shifted with them, also in double (thesis and lab 4: a texture-
    // coordinate offset origin / scale_xy added to position / scale_xy; COSC422: the extent
    // minus origin), so texture coordinates, heights and positions carry float's error at
    // the terrain's size around the eye instead of at its distance from the world origin.
    // The control stage runs as without the option, on the world corners: its levels are
    // bit-identical. SurfaceMesh::positions stay WORLD positions (the eye-relative float
    // position plus origin, in double); the eye-relative floats themselves are kept in
    // PipelineResult::relative_positions for the renderer, which projects them with the
    // view-projection of the camera moved by -origin (render.h). Texture coordinates are
    // the shifted mapping's: they differ from the option's off values by float rounding
    // (PN meshes: bit-identical, they are the mesh's attributes).
    bool camera_relative = false;
    PipelineTimings* timings = nullptr;    // filled when not null (see PipelineTimings)
};

// Patches a geomipmapped terrain's [culling] removed (geomipmap.h, CULLING and PVS); all 0
// without [culling] and for the other models.
struct CullStats {
    std::size_t ground_rectangle = 0;  // outside the frustum's ground rectangle
    std::size_t frustum_planes = 0;    // box outside one of the six planes
    std::size_t pvs = 0;               // inside the frustum, not in the eye's cell's set
    bool pvs_applied = false;          // the scene has a PVS and the eye is inside its cells
    std::size_t frustum() const { return ground_rectangle + frustum_planes; }
    std::size_t total() const { return frustum() + pvs; }
};

// Which stages ran (a stage the scene does not name does not run).
struct StagesRun {
    bool control = false;
    bool evaluation = false;
    bool geometry = false;
};

struct PipelineResult {
    SurfaceMesh mesh;
    std::vector<glm::dvec3> face_normals;  // one per triangle with [geometry] normals = "face"
    std::vector<TessLevels> levels;        // per patch: what the control stage wrote
    std::uint64_t estimated_triangles = 0;
    std::size_t distinct_patterns = 0;     // distinct level sets (patterns) of this run
    StagesRun stages{};
    // Culled patches (geomipmap [culling]) emit no vertex and no triangle; their levels are
    // still chosen and reported (a visible neighbour adapts to them as without culling).
    CullStats culled{};
    // Geomipmapped terrains only: per mesh vertex, the geomorphing vertex shader's attributes
    // (geomip_terrain.vert: sampleHeight, morphTarget, tween) as floats; with the gpu
    // precision each position's z is geomip::morph_height of them. Empty for other models.
    std::vector<glm::vec3> geomorph;
    // A user's geometry shader ran ([shaders] geom): the mesh's triangles are the ones it
    // emitted, patch by patch in the order emitted, three vertices of their own each (GL's
    // order of their corners, reversed 1 <-> 2 where `reversed`, as the pipeline reverses
    // the generator's triangles to face up), not the generator's pattern.
    bool geometry_shader = false;
    bool reversed = false;

    // camera_relative (PipelineOptions): the point the evaluation worked relative to, and its
    // float output positions (mesh.positions[v] == origin + relative_positions[v] in double).
    // origin (0, 0, 0) and no relative positions without the option.
    glm::dvec3 origin{0.0};
    std::vector<glm::vec3> relative_positions;
};

// The pipeline with its surface produced on demand, patch by patch, instead of all at once:
// the first three passes (control, budget, generator) run in the constructor, and emit()
// runs the fourth for one patch into storage of the caller's. run_pipeline() is a
// PatchStream emitted into one mesh; a consumer that needs each patch only briefly (the
// renderer, which projects, rasterizes and forgets it) holds a few patches at a time
// instead of the surface. Everything emit() writes is bit-identical to what run_pipeline()
// writes for that patch, so ids and values agree between the two.
class PatchStream {
public:
    // The stream reads `scene` (its textures, grid and camera) whenever it evaluates: the
    // scene must outlive it. Throws as run_pipeline does before tessellating (budget, empty scene). A geomipmapped
    // terrain has no tessellation stages to stream: it throws (check streams()).
    PatchStream(const Scene& scene, const PipelineOptions& options = {});
    ~PatchStream();
    PatchStream(PatchStream&&) noexcept;
    PatchStream& operator=(PatchStream&&) noexcept;

    // Whether the scene's surface can be streamed (every model but geomipmap).
    static bool streams(const Scene& scene);

    std::size_t patch_count() const;
    const std::vector<TessLevels>& levels() const;   // per patch, as the control stage wrote them
    std::uint64_t estimated_triangles() const;
    std::size_t distinct_patterns() const;
    const Pattern& pattern(std::size_t patch) const;
    // Patch p's vertices and triangles in run_pipeline()'s mesh: [vertex_base(p), vertex_base(p + 1))
    // and [triangle_base(p), triangle_base(p + 1)); p may be patch_count().
    std::size_t vertex_base(std::size_t patch) const;
    std::size_t triangle_base(std::size_t patch) const;
    // The patch owning a triangle of run_pipeline()'s mesh.
    std::size_t patch_of_triangle(std::size_t triangle) const;
    // The end of a run of whole patches from `first` (< patch_count()): the first patch, and
    // the ones after it while the run holds at most `triangles` triangles.
    std::size_t run_end(std::size_t first, std::size_t triangles) const;
    bool has_uvs() const;       // emit() writes mesh.uvs
    bool has_normals() const;   // emit() writes mesh.normals (per-vertex geometry normals)
    bool face_normals() const;  // [geometry] normals = "face": emit() writes face normals
    bool smooth_normals() const;  // [geometry] normals = "smooth": need the whole surface
    // A user's geometry shader ran (PipelineResult::geometry_shader): its output is computed
    // for every patch when the stream opens and held, and emit() copies it.
    bool geometry_shader() const;
    bool reversed() const;  // the triangles are reversed (1 <-> 2) to face up / out
    // Camera-relative evaluation (PipelineOptions::camera_relative): positions from emit()
    // are the evaluation's, relative to origin(); (0, 0, 0) otherwise.
    glm::dvec3 origin() const;

    // Sizes `mesh` (and face_normals, when face_normals()) for `vertices` and `triangles`
    // of emit()'s output: the arrays emit() writes, and only those.
    void size(SurfaceMesh& mesh, std::vector<glm::dvec3>& face_normals, std::size_t vertices,
              std::size_t triangles) const;
    // Pass 4 for one patch: its evaluated vertices at mesh index first_vertex on (positions,
    // patch_ids, tess_coords, and uvs / normals where has_uvs() / has_normals()), its
    // triangles at first_triangle on, indexing from first_vertex, and their face normals
    // into face_normals[first_triangle...] when face_normals() and the pointer is not null.
    // The caller sizes the arrays. Concurrent calls for different patches are safe.
    // VertexNormals::later: mesh.normals is left as it is; later_normals() gives the same
    // normals for the vertices that need one (the renderer: those of triangles that win a
    // pixel, a tenth of them on a finely tessellated terrain), saving the geometry stage's
    // texture fetch for the rest.
    // Provenance::later: mesh.patch_ids and mesh.tess_coords (where each vertex came from)
    // may be left as they are, for a caller that reads them for a few vertices at most, from
    // triangle() (the renderer without provenance buffers: 16 of the
    // about 70 bytes a vertex that emit() writes on a terrain).
    // Triangles::shared (only for a patch whose shared_triangles() is not empty): mesh.triangles
    // is left as it is, for a caller that reads shared_triangles(patch) instead (the streamed
    // render of a chunk of one patch: at level 63 the copy was 5 % of the render).
    // projection (not null): also gl_Position of every vertex emit() writes, as the renderer
    // computes it (mvp * vec4(position rounded to float, 1), pipeline/gl_position.h), into
    // clip[first_vertex + k], clearing `finite` when a position is not: a terrain projects
    // each block of points while its float positions are at hand, where the renderer read
    // the double positions back (one Projection per thread: emit writes `finite`).
    // positions false: mesh.positions may be left as they are, for a caller that reads only
    // the clip positions (the streamed render whose shading takes no world position, without
    // height-field normals: at level 63 the 24-byte stores were a third of the evaluation's
    // own time); emit() still writes them where it computes face normals from them.
    enum class VertexNormals { now, later };
    enum class Provenance { now, later };
    enum class Triangles { write, shared };
    struct Projection {
        glm::mat4 mvp{1.0f};
        glm::vec4* clip = nullptr;
        bool positions = true;
        bool finite = true;
    };
    void emit(std::size_t patch, SurfaceMesh& mesh, std::size_t first_vertex, std::size_t first_triangle,
              std::vector<glm::dvec3>* face_normals, VertexNormals normals = VertexNormals::now,
              Provenance provenance = Provenance::now, Triangles triangles = Triangles::write,
              Projection* projection = nullptr) const;
    // size() and emit() for the run of patches [first, last) as one mesh: its vertices and
    // triangles from index 0, the triangles indexing the run's own vertices; face normals
    // into *face_normals when face_normals() and the pointer is not null. Triangles::shared:
    // mesh.triangles is left empty. projection: clip[0, the run's vertex count) as emit's.
    void emit_run(std::size_t first, std::size_t last, SurfaceMesh& mesh, std::vector<glm::dvec3>* face_normals,
                  VertexNormals normals = VertexNormals::now, Provenance provenance = Provenance::now,
                  Triangles triangles = Triangles::write, Projection* projection = nullptr) const;
    // Patch p's triangles as emit() writes them less first_vertex (indexing the patch's own
    // vertices from 0), where they are its pattern's indices as they are, shared by every
    // patch of the pattern and held by the stream: not reversed (reversed() false) and no
    // geometry shader. Empty otherwise. Every index is below the patch's vertex count
    // (pattern(patch).points().size(): the generator's indices name its own points).
    std::span<const std::array<std::uint32_t, 3>> shared_triangles(std::size_t patch) const;

    // The vertex normals that emit(..., VertexNormals::later) left out, for some of patch's
    // vertices: `points` are indices into pattern(patch).points() of vertices that emit wrote
    // at mesh index first + point (as emit_run writes a run's patches), and each gets
    // mesh.normals[first + point], the value emit(..., VertexNormals::now) writes. A terrain
    // computes them from the positions and uvs emit wrote there (no second evaluation);
    // other surfaces evaluate the points again. Concurrent calls for different vertices are safe.
    void later_normals(std::size_t patch, std::span<const std::uint32_t> points, SurfaceMesh& mesh,
                       std::size_t first) const;

    // One triangle of run_pipeline()'s mesh on its own: `out` gets its three vertices as
    // run_pipeline()'s mesh holds them (world positions), in the triangle's order, and the
    // one triangle {0, 1, 2}; face_normal (when not null and face_normals()) its face
    // normal. Returns the vertices' indices in run_pipeline()'s mesh.
    std::array<std::uint32_t, 3> triangle(std::size_t triangle, SurfaceMesh& out, glm::dvec3* face_normal) const;

    // The triangles of run_pipeline()'s mesh from index `first` on, as emit() writes them
    // (indexing run_pipeline()'s vertices), into `out`, from the patterns alone: nothing is
    // evaluated. Concurrent calls are safe.
    void triangles(std::size_t first, std::span<std::array<std::uint32_t, 3>> out) const;

    struct Impl;

private:
    std::unique_ptr<Impl> impl_;
};

// Runs the scene's pipeline. Throws tessref::Error (key "limits.max_triangles") when the
// estimate exceeds the scene's budget, before any tessellation; and when a vertex
// evaluates to infinity or NaN (naming the patch, the tess coord and, for a terrain, the
// height texel).
PipelineResult run_pipeline(const Scene& scene, const PipelineOptions& options = {});

// weld_bitwise(run_pipeline(scene, options).mesh), bit for bit, without holding the unwelded
// surface where surface_streams(scene): the patches are evaluated a few hundred thousand
// triangles at a time, in parallel, and welded in patch order as they come (SurfaceWelder),
// so the memory is the welded mesh's, not the emitted one's as well. vertex_map is left
// empty. Throws what run_pipeline() throws (the non-finite vertex error for the same first
// vertex). options.progress is called from the calling thread; options.timings is not filled.
WeldedMesh run_pipeline_welded(const Scene& scene, const PipelineOptions& options = {});
// run_pipeline_welded()'s mesh written as a PLY file while it is evaluated, with neither the
// unwelded nor the welded surface held (StreamedPlyWriter, mesh.h): the bytes and report of
// write_mesh(run_pipeline_welded(scene, options), out, write_options). nullopt when the file
// cannot be streamed: a scene that is not surface_streams(), exact precision, camera-relative
// evaluation, a format other than PLY, or what StreamedPlyWriter refuses (overlapping
// patches); `out` then holds part of a file, and the caller writes run_pipeline_welded()'s
// mesh afresh. Throws what run_pipeline() throws. options.progress is called from the
// calling thread, write_options.progress for the triangles ("writing").
std::optional<MeshWriteReport> write_pipeline_ply(const Scene& scene, const PipelineOptions& options,
                                                  const MeshWriteOptions& write_options, std::ostream& out);
// Whether run_pipeline_welded() streams the scene: PatchStream::streams(scene), and no
// smooth normals (geometry.h sums those over the whole surface). Elsewhere it welds
// run_pipeline()'s mesh, holding both.
bool surface_streams(const Scene& scene);

// camera_relative: the origin the evaluation works relative to (see PipelineOptions): the
// camera's eye, for a terrain with its up-axis component 0; (0, 0, 0) without a camera.
glm::dvec3 camera_relative_origin(const Scene& scene);
// The camera moved by -origin (eye and center; up unchanged), whose view-projection, built
// in double, projects origin-relative positions as camera.view_projection() projects world
// ones: lookAt(eye - origin, center - origin, up) has at most the eye's up-axis height left
// in its translation.
SceneCamera camera_moved_by(SceneCamera camera, const glm::dvec3& origin);

}  // namespace tessref
