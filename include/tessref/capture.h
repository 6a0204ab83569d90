// tessref/capture.h — every evaluated vertex of every primitive, from either side: the GL
// backend (transform feedback, gl_backend.h) or the CPU reference (capture_from_pipeline),
// in one layout, written, read back, and compared patch by patch in ulps.
//
// LAYOUT. Three CapturedVertex per triangle, in the order the primitive generator emitted
// them (GL: as transform feedback wrote them). Every vertex carries its patch id, its
// gl_TessCoord, its world position, the normal the last stage before rasterization hands
// on, and its patch's levels.
//
// FILES (the extension decides):
//  .txt  Text, %.9g (every float reads back bitwise; NaN as "nan", infinities "inf"):
//          tessref-capture 1
//          # comment lines (anywhere)
//          patch ID levels o0 o1 o2 o3 i0 i1      before each patch's vertices
//          ID u v w x y z nx ny nz                one line per vertex, three per triangle
//        A patch's vertices follow its `patch` line and repeat its id (grep-able); a patch
//        may come back in a later run of lines (its levels must then be the same bits).
//  .ply  `tessref mesh`'s PLY layout (patch_id, tess_u/v/w, normals) through write_mesh,
//        NOT welded: one vertex per triangle corner, so each corner keeps its own patch and
//        tess coord. PLY has no place for the levels: a capture read from PLY has
//        Capture::has_levels false, and the comparison reports its levels as unknown.
//
// COMPARISON (compare_captures). Patches are matched by id; a patch present on one side
// only diverges. Within a patch, vertices are matched by tess coord (exact float bits) and
// triangles as the sets of their three tess coords, so the order of the triangles and the
// rotation or orientation of each triangle's corners do not matter:
//  - the multisets of tess coords must be identical, else a tess-coord divergence (with both
//    sides' levels and their largest difference in ulps: on identical levels the generator
//    is bit-identical, so this points at the control stage);
//  - then the triangles (as tess-coord sets) must be identical, else a triangle divergence;
//  - then each triangle's corners must run the same way round (the cyclic order of its tess
//    coords), else an orientation divergence: a `cw` evaluation layout where the reference
//    has `ccw` makes the same triangles facing the other way, which culling and every
//    normal computed from the corners see (a triangle with two equal tess coords has no
//    orientation and is not counted);
//  - then every triangle corner's position and normal are compared component by component
//    in ulps (ulp_distance below); a corner fails when a position component is more than
//    max_position_ulps or a normal component more than max_normal_ulps away.
// It passes when no patch diverges.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/mesh.h"
#include "tessref/tessellator.h"

namespace tessref {

struct IndexedMesh;  // mesh_io.h

struct Scene;
struct PipelineResult;

// One vertex of one primitive.
struct CapturedVertex {
    std::uint32_t patch_id = 0;
    glm::vec3 tess_coord{0.0f};
    glm::vec3 position{0.0f};  // world space, as the evaluation stage computed it
    // What the last stage before rasterization hands on: the geometry shader's gNormal
    // (thesis normal_map) or faceNormal (cosc422 face), the evaluation shader's normal
    // (lab 4, PN); zero where none.
    glm::vec3 normal{0.0f};
    TessLevels levels{};  // the patch's gl_TessLevelOuter/Inner, as the evaluation stage read them
};

struct Capture {
    std::vector<CapturedVertex> vertices;  // three per triangle
    bool has_levels = true;                // false when read from PLY (levels are zero)
    std::string source;                    // the file it was read from, "" in memory
};

// The CPU reference's capture of a pipeline run of `scene`, in GL's layout: patch after
// patch in patch order, each patch's triangles in the primitive generator's order, each
// triangle's corners in the order the generator emitted them (the mesh's triangles are
// turned back where the pipeline re-oriented them to face up/out, scene.h). The normal is
// what the GL twins hand to the rasterizer where the CPU has it: the face normal of
// [geometry] normals = "face" (of the corners in generator order, as cosc422_terrain.geom
// computes it; for a re-oriented triangle the negation of the pipeline's, which may differ
// from GL's in the sign of a zero component), else the mesh's vertex normals (thesis normal_map, lab 4 height_field, PN's
// evaluation normal), else zero. Known gap: lab 4 without [geometry] has no CPU normal
// (zero here) while its evaluation shader computes one. Throws tessref::Error when the
// mesh's triangles are not the generator's pattern for the patch's levels.
std::vector<CapturedVertex> capture_from_pipeline(const Scene& scene, const PipelineResult& result);

// The same capture made a range of triangles at a time, for a consumer that needs only a
// few patches of it at once (`golden verify` digests it in windows and compares it with
// llvmpipe's patch by patch, never holding the 64 bytes a vertex of the whole). The
// constructor checks the mesh as capture_from_pipeline does (the same Errors) and keeps
// `result`, which must outlive it.
class PipelineCapture {
public:
    PipelineCapture(const Scene& scene, const PipelineResult& result);
    std::size_t triangles() const { return triangles_; }
    // Appends the capture's vertices of its triangles [first, last) to `out`.
    void append(std::size_t first, std::size_t last, std::vector<CapturedVertex>& out) const;
    // The capture's triangles as maximal runs of one patch (the patch of a triangle's first
    // corner, as the comparison groups them), in capture order.
    struct Run {
        std::uint32_t patch = 0;
        std::size_t first = 0, last = 0;  // triangles [first, last)
    };
    const std::vector<Run>& runs() const { return runs_; }

private:
    // A patch's triangles laid out as its pattern's primitives from its first vertex on
    // (no pattern: a geomipmapped terrain's triangles, taken as the mesh holds them).
    struct Block {
        std::size_t first = 0;  // the block's first triangle
        std::size_t base = 0;   // its patch's first vertex
        std::uint32_t patch = 0;
        std::shared_ptr<const Pattern> pattern;
    };
    const PipelineResult& result_;
    std::size_t triangles_ = 0;
    std::vector<Block> blocks_;  // by first triangle
    std::vector<Run> runs_;
};

// The capture as a SurfaceMesh: three vertices per triangle, normals, patch ids and tess
// coords; write it with MeshWriteOptions::weld = false (write_capture does).
SurfaceMesh capture_mesh(std::span<const CapturedVertex> capture);

// The text form above. `origin` goes into a comment line ("tessref gl", "tessref mesh").
std::string capture_text(std::span<const CapturedVertex> capture, const std::string& origin = {});
// The lines capture_text writes after its header lines, appended to `out`: a `patch` line
// at the first vertex and wherever the patch id changes, and a line per vertex. The text of
// a capture cut at its patch runs is the header and each run's lines, one after the other.
void append_capture_lines(std::span<const CapturedVertex> capture, std::string& out);

// Writes the capture to `out` as text or as a PLY (binary: PLY's little-endian form), by
// format. Throws tessref::Error (a non-finite position cannot go to PLY; a failed stream).
enum class CaptureFormat : std::uint8_t { text, ply };
void write_capture(std::span<const CapturedVertex> capture, std::ostream& out, CaptureFormat format,
                   const std::string& origin = {});
// The format of a capture file name: .txt or .ply (any case). Throws tessref::Error naming
// `path` (and `flag`, when given, as the place) for another extension.
CaptureFormat capture_format_from_path(const std::string& path, const std::string& flag = {});
// Whether `path` names a capture (.txt or .ply), for commands that take images too.
bool is_capture_path(const std::string& path);

// Reads a capture written by capture_text or write_capture. Strict: a text file must start
// with the version line, every number must be a whole token, a vertex line needs a `patch`
// line before it with the same id, and the vertex count of every run must be a multiple
// of three; a PLY must have patch_id, tess_u/v/w and normals on its vertices, triangles
// only, and no corner shared by two patches (a welded PLY). Every error is a
// tessref::Error naming the file and the line (text; PLY: the line or byte offset where the
// mesh reader finds it, else the face). Memory is required before the vertices are read.
Capture read_capture(const std::string& path);
// read_capture() of a PLY already read (read_mesh_file with vertex attributes and
// provenance), `path` naming it in errors: `tessref check` reads a PLY once, and checks it as
// the mesh it is when it is not a capture.
Capture capture_from_ply_mesh(const IndexedMesh& mesh, const std::string& path);

// ---- comparison ------------------------------------------------------------------------

// Ulps between two floats: the distance of their bit patterns on the number line (sign-
// aware: -x and x are 2 * bits(x) apart; +0 and -0 are 0 apart). Two NaNs: 0; a NaN against
// a number: kInfiniteUlps.
inline constexpr std::uint64_t kInfiniteUlps = std::numeric_limits<std::uint64_t>::max();
std::uint64_t ulp_distance(float a, float b);

// The defaults of `tessref compare` on captures: bit-identical. Expected differences
// between llvmpipe and the CPU twins (docs/PERFORMANCE.md, "The CPU reference against
// llvmpipe") are given with the flags.
inline constexpr std::uint64_t kDefaultMaxPositionUlps = 0;
inline constexpr std::uint64_t kDefaultMaxNormalUlps = 0;

struct CaptureCompareOptions {
    std::uint64_t max_position_ulps = kDefaultMaxPositionUlps;
    std::uint64_t max_normal_ulps = kDefaultMaxNormalUlps;
    // A component also passes when it is within this absolute distance of the other (0: not
    // used). Near zero a float's ulp is tiny (1e-7 has ulps of 7e-15), so an ulp bound alone
    // fails values that differ by far less than anything visible.
    double max_position_abs = 0.0;
    double max_normal_abs = 0.0;
    std::size_t max_listed = 10;  // diverging patches listed in detail, in patch order
};

enum class PatchDivergence : std::uint8_t {
    missing_in_test,       // the reference has the patch, the test does not
    missing_in_reference,
    tess_coords,           // the multisets of tess coords differ
    triangles,             // same tess coords, different triangles
    orientation,           // same triangles, some with their corners the other way round
    values,                // some corner's position or normal beyond the tolerance
};
const char* to_string(PatchDivergence kind);

// The largest ulp distance of one kind and where it is (the first place, in patch order,
// then the test's order of the reference's triangles).
struct WorstUlps {
    std::uint64_t ulps = 0;
    bool found = false;  // some vertex was compared
    std::uint32_t patch_id = 0;
    glm::vec3 tess_coord{0.0f};
    int component = 0;  // x, y, z
    glm::vec3 reference{0.0f};
    glm::vec3 test{0.0f};
};

struct DivergingPatch {
    std::uint32_t patch_id = 0;
    PatchDivergence kind = PatchDivergence::values;
    std::size_t reference_vertices = 0;  // triangle corners on each side
    std::size_t test_vertices = 0;
    bool levels_known = false;           // both sides' levels are known
    TessLevels reference_levels{};
    TessLevels test_levels{};
    // The largest ulp distance between the levels the patch's domain uses (quads: all six;
    // triangles: outer 0..2 and inner 0; the domain is triangles when a tess coord has w != 0).
    std::uint64_t level_ulps = 0;
    // tess_coords: a tess coord of one side that the other lacks (the smallest such, by bits);
    // triangles: a corner of the first triangle that differs.
    glm::vec3 tess_coord{0.0f};
    bool tess_coord_in_reference = true;
    // orientation: how many of the patch's triangles face the other way (the first one's
    // smallest tess coord is tess_coord).
    std::size_t flipped_triangles = 0;
    // values: failing corners, and the first one (in the comparison's order).
    std::size_t failing_vertices = 0;
    glm::vec3 reference_position{0.0f}, test_position{0.0f};
    glm::vec3 reference_normal{0.0f}, test_normal{0.0f};
    std::uint64_t position_ulps = 0;  // of that corner (largest component)
    std::uint64_t normal_ulps = 0;
};

// One component over every compared triangle corner: x, y, z of the position, or the
// normal (each corner's largest normal component difference).
struct ComponentSummary {
    std::size_t compared = 0;    // corners
    std::uint64_t max_ulps = 0;
    double max_abs = 0.0;        // the largest |reference - test| (+inf against a NaN)
    double sum_abs = 0.0;        // for the mean: sum_abs / compared
    std::size_t beyond = 0;      // corners where this component is beyond the tolerance
};

struct CaptureCompareResult {
    std::size_t reference_patches = 0;
    std::size_t test_patches = 0;
    std::size_t compared_patches = 0;   // on both sides with the same tess coords and triangles
    std::size_t vertices_compared = 0;  // triangle corners
    std::size_t failing_vertices = 0;
    std::size_t missing_in_test = 0;
    std::size_t missing_in_reference = 0;
    std::size_t tess_coord_divergences = 0;
    std::size_t tess_coord_divergences_with_equal_levels = 0;  // levels known and bit-identical
    std::size_t triangle_divergences = 0;
    std::size_t orientation_divergences = 0;
    std::size_t flipped_triangles = 0;  // over all patches with an orientation divergence
    std::size_t value_divergences = 0;
    WorstUlps worst_position;
    WorstUlps worst_normal;
    std::array<ComponentSummary, 4> components;  // x, y, z, normal
    std::vector<std::pair<std::uint32_t, std::size_t>> failing_vertices_per_patch;  // patch order
    std::vector<DivergingPatch> listed;  // the first max_listed diverging patches
    bool passed = true;

    std::size_t diverging_patches() const {
        return missing_in_test + missing_in_reference + tess_coord_divergences + triangle_divergences +
               orientation_divergences + value_divergences;
    }
};

// Throws tessref::Error when a capture is not whole triangles of one patch each.
CaptureCompareResult compare_captures(const Capture& reference, const Capture& test,
                                      const CaptureCompareOptions& options = {});

// compare_captures() fed a few patches at a time, for a caller that never holds either
// capture whole (`golden verify` compares llvmpipe's capture as its child process sends it,
// patch by patch, against the CPU reference's, made from the pipeline). Each patch comes
// once, in ascending id order over all calls, with all its triangles of each side (an
// empty side: the patch is missing there); the patches of one call are compared in
// parallel. The result is compare_captures()'s on the two captures the patches make
// (ComponentSummary::sum_abs, there too, is summed patch by patch). Throws tessref::Error as
// compare_captures() does, and for patches out of order.
class StreamedCaptureComparison {
public:
    explicit StreamedCaptureComparison(const CaptureCompareOptions& options = {});
    ~StreamedCaptureComparison();
    StreamedCaptureComparison(const StreamedCaptureComparison&) = delete;
    StreamedCaptureComparison& operator=(const StreamedCaptureComparison&) = delete;
    struct PatchPair {
        std::uint32_t patch = 0;
        std::span<const CapturedVertex> reference, test;  // the patch's triangles, three vertices each
        bool reference_has_levels = true, test_has_levels = true;
    };
    void add(std::span<const PatchPair> patches);
    CaptureCompareResult finish();  // once, after the last patch

private:
    struct State;
    std::unique_ptr<State> state_;
};

}  // namespace tessref
