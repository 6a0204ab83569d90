// tessref/check.h — watertightness and crack checks for any mesh, tessref's own or a user's.
//
// A mesh is read exactly as its file lists it (read_mesh_for_check): a strict scan of the
// file (mesh_io.h, read_mesh_file) that refuses, naming the line or byte offset, anything it
// cannot read exactly; OpenMesh's kernel is then asked which faces it would refuse, so non-manifold
// input is analysed as it is, not as a half-edge structure would like it to be.
// check_mesh() then finds, each as a class with a count and located instances
// (coordinates, face ids, vertex ids):
//
//   boundary_loop              boundary edges, chained into loops (edge count, length);
//                              the outer outline of an open (terrain) mesh is allowed,
//                              everything else is a defect
//   non_manifold_edge          an edge shared by more than two faces
//   non_manifold_vertex        a vertex whose faces form more than one fan
//   refused_face               a face OpenMesh's kernel would refuse (complex edge or
//                              vertex, repeated vertex, fewer than three vertices)
//   inconsistent_orientation   an edge its two faces traverse in the same direction
//   inverted_volume            a closed component with a negative signed volume
//   degenerate_face            a repeated vertex, or a height below the tolerance
//   duplicate_face             a face over the same vertex set as an earlier face
//   coincident_vertices        distinct vertices at bitwise-equal positions (unwelded)
//   near_coincident_vertices   distinct vertices closer than the tolerance, not equal and
//                              not joined by an edge
//   t_junction                 a vertex on the interior of a boundary edge of another
//                              face: within the tolerance in 3D, or, on a terrain, within
//                              the tolerance seen from above (the crack between two patches
//                              whose shared edge was tessellated differently)
//   probe_miss                 terrain: a vertical ray inside the outline that hits nothing
//   probe_odd_parity           closed mesh: a line through the mesh crossing it an odd
//                              number of times
//   probe_escape               closed mesh: a ray from inside that leaves without a hit
//   facing_down                terrain: a face whose normal points down its up axis (the
//                              up axis's positive direction: z for a terrain in the xy
//                              plane), i.e. wound cw where the terrain is ccw from above; a
//                              flipped face (inconsistent_orientation) is not reported again
//
// A capture (capture.h) is checked as the mesh weld_capture() makes of it, and
// shared_edge_cracks() names the patches whose shared edges were tessellated differently.
//
// Faces with a repeated vertex and later copies of duplicate faces are reported and then
// left out of the topology (edges, fans, loops, orientation), so one defect is reported as
// itself rather than as a cascade of others.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/mesh.h"
#include "tessref/mesh_io.h"

namespace tessref {
struct Capture;
}  // namespace tessref

namespace tessref {

// read_mesh_file() for the check: also fills kernel_refused_faces.
IndexedMesh read_mesh_for_check(const std::string& path);
// The same, calling progress(fraction read) now and then (from the calling thread).
IndexedMesh read_mesh_for_check(const std::string& path, const std::function<void(double)>& progress);

enum class Expect { automatic, closed, open };

struct CheckOptions {
    // closed: no boundary edge at all. open: boundary edges allowed only as one loop, the
    // outer outline (a terrain). automatic: closed rules, unless the mesh has boundary
    // edges and looks like a terrain (every face seen from one side along one axis); and on
    // a mesh with boundary edges that does not, per component: one that looks like a
    // terrain by itself (an open sheet, a plate under a model) may have its outer outline.
    Expect expect = Expect::automatic;
    // Absolute distance under which vertices coincide, a vertex lies on an edge, and a face
    // is degenerate (thinner than this across its longest edge). Default: 1e-7 times the
    // larger of the bounding box diagonal and the largest coordinate's distance from the
    // origin -- about what single-precision rounding moves a vertex at the mesh's scale.
    std::optional<double> tolerance;
    // The Embree ray-cast crack probe; resolution is the number of rays per side of the
    // probe grid (terrain: resolution^2 vertical rays; closed: resolution^2 lines along
    // each of three axes, plus as many escape rays from inside).
    bool ray_probe = true;
    int probe_resolution = 512;
    // Where in its grid cell each probe ray runs, as fractions of the cell: the ray of cell
    // (i, j) across axis a runs through bbox_min + (i + offset.x) * extent / resolution along
    // axis (a + 1) % 3 and (j + offset.y) * extent / resolution along axis (a + 2) % 3 (for
    // terrains, a is the up axis). The default keeps rays off the vertices of regular grids;
    // tests set it to put rays exactly through vertices and edges. A ray that grazes an edge
    // or a vertex anyway is cast again beside it, so the verdict does not depend on it.
    glm::dvec2 probe_offset{0.5371, 0.5953};
    // Located instances kept per class (counts stay exact).
    std::size_t max_locations = 1000;
    // Called with a stage name and the fraction of the whole check done, from the calling
    // thread only.
    std::function<void(std::string_view stage, double fraction)> progress;
};

enum class DefectClass {
    boundary_loop,
    non_manifold_edge,
    non_manifold_vertex,
    refused_face,
    inconsistent_orientation,
    inverted_volume,
    degenerate_face,
    duplicate_face,
    coincident_vertices,
    near_coincident_vertices,
    t_junction,
    probe_miss,
    probe_odd_parity,
    probe_escape,
    facing_down,
};
inline constexpr int kDefectClassCount = 15;
std::string_view defect_class_name(DefectClass kind);         // "t_junction"
std::string_view defect_class_description(DefectClass kind);  // "T-junction"

// One located defect: where it is and what it touches.
struct Defect {
    glm::dvec3 position{0.0};           // a representative point
    std::vector<std::uint32_t> faces;   // face ids involved
    std::vector<std::uint32_t> vertices;
    double measure = 0.0;  // class-specific: loop length, face height, distance, ray count
    std::string detail;    // one line for people
    // The patches of its vertices and its faces' vertices, in a mesh that carries patch ids
    // (a PLY of `tessref mesh`: the property patch_id); sorted, distinct; else empty.
    std::vector<std::uint32_t> patches;
};

struct DefectReport {
    DefectClass kind{};
    std::size_t count = 0;          // exact
    std::vector<Defect> locations;  // the first max_locations, in a deterministic order
};

struct BoundaryLoop {
    std::vector<std::uint32_t> vertices;  // in the direction the faces traverse them
    std::size_t edge_count = 0;
    double length = 0.0;
    double area = 0.0;      // magnitude of the loop's vector area
    bool closed = true;     // false: a chain that could not be closed (orientation breaks)
    bool allowed = false;   // the outer outline of an open mesh
    glm::dvec3 centroid{0.0};
    // A defect loop's largest gap, in world units: the loop is split at its two vertices
    // farthest apart into two sides, and this is the largest distance from a vertex of one
    // side to the other side (a crack's width or step; about 0.7 of a round hole's
    // diameter). 0 for the allowed outline.
    double gap = 0.0;
};

struct ProbeStats {
    std::string mode = "none";  // "terrain", "closed" or "none"
    std::string skipped_because;  // when mode is "none"
    std::size_t rays = 0;
    std::size_t failed_rays = 0;  // the failures reported as defects
    // Rays cast again beside themselves: closed-mesh lines with a hit that grazed an edge
    // or a vertex (within single-precision rounding, which then decides what they hit), and
    // terrain rays that missed (a hole only if the one beside misses too).
    std::size_t recast_rays = 0;
    // Rays that found no clean way past the edges they grazed, and count as no failure.
    std::size_t undecided_rays = 0;
    // Failures on a mesh whose topology rules them out (every edge has two faces, but for
    // an open terrain's outline): what rounding still did, not reported as defects.
    std::size_t dismissed_rays = 0;
};

struct CheckReport {
    std::string source;
    std::string format;
    std::vector<std::string> reader_notes;  // from IndexedMesh::reader_notes
    std::size_t vertex_count = 0;
    std::size_t face_count = 0;
    std::size_t triangle_count = 0;  // after fan-triangulating polygons
    std::size_t edge_count = 0;
    std::size_t unreferenced_vertices = 0;
    std::size_t component_count = 0;  // connected through shared vertices
    std::size_t boundary_edge_count = 0;
    std::size_t boundary_loop_count = 0;      // all of them (boundary_loops keeps the first)
    std::size_t topology_excluded_faces = 0;  // repeated-vertex faces and duplicate copies
    long long euler_characteristic = 0;       // V - E + F over the analysed faces
    glm::dvec3 bbox_min{0.0}, bbox_max{0.0};
    double surface_area = 0.0;
    double signed_volume = 0.0;  // meaningful for closed meshes
    double tolerance = 0.0;
    int up_axis = 2;           // the axis most faces face along (terrain "up")
    bool terrain_like = false; // open, and every face seen from one side along up_axis
    bool closed = false;       // no boundary edge
    bool manifold = false;
    bool consistently_oriented = false;
    Expect expect = Expect::automatic;
    std::string judged_as;     // "closed" or "open": the rules applied
    // Under Expect::automatic, on a mesh that is neither closed nor a terrain: the components
    // judged open sheets (check_detail's judge_sheets: a boundary, every face seen from one
    // side), each with its outer outline allowed; the rest is held to the closed rules.
    std::size_t open_sheets = 0;
    std::vector<BoundaryLoop> boundary_loops;  // at most max_locations, largest first
    std::vector<std::uint32_t> flipped_faces;  // minority orientation within a component
    // Faces OpenMesh's kernel refused only because of the flipped faces (the flip is the
    // defect, reported once as inconsistent_orientation; not again as refused_face).
    std::vector<std::uint32_t> refused_for_flips;
    ProbeStats probe;
    std::vector<DefectReport> defects;  // one per DefectClass, in enum order
    bool passed = false;

    const DefectReport& of(DefectClass kind) const { return defects[static_cast<int>(kind)]; }
    std::size_t count(DefectClass kind) const { return of(kind).count; }
};

// Runs every check. Deterministic: the same mesh and options give the same report,
// whatever the thread count.
CheckReport check_mesh(const IndexedMesh& mesh, const CheckOptions& options = {});

// read_mesh_for_check() then check_mesh(), as `tessref check` runs them: the same mesh
// (kernel_refused_faces included) and the same report, in less time. OpenMesh's import,
// which asks its kernel which faces it refuses, is sequential and about a fifth of the
// whole; it is skipped where the check's own topology proves that the kernel refuses no face
// but those with a repeated vertex or fewer than three vertices (its importer drops them):
// every edge has at most two faces and they traverse it in opposite directions, every vertex
// has one fan, and no face is a duplicate or has a non-finite corner. Then no face the
// importer adds, in any order, meets a complex edge, a complex vertex or a failed patch
// re-linking (OpenMesh's PolyConnectivity::add_face), so none is refused. Otherwise the
// import runs as read_mesh_for_check() runs it.
struct CheckedMesh {
    IndexedMesh mesh;
    CheckReport report;
};
CheckedMesh read_and_check_mesh(const std::string& path, const CheckOptions& options = {},
                                const std::function<void(double)>& read_progress = {});

// read_and_check_mesh() of a mesh already in memory (a welded capture, below).
CheckedMesh check_indexed_mesh(IndexedMesh mesh, const CheckOptions& options = {});

// ---- captures (capture.h): every vertex of every primitive, each patch's own copies ------

// A capture as a mesh to check: its vertices merged where their positions are bitwise equal
// (weld_tolerance 0: the rule of `tessref mesh`'s export, so a crack between patches stays a
// crack), or within weld_tolerance of an earlier kept vertex (each vertex joins the first
// kept one that near, in capture order); its triangles in capture order, as emitted.
// `source` names the capture in the report. Throws tessref::Error for a negative or
// non-finite tolerance.
IndexedMesh weld_capture(const Capture& capture, double weld_tolerance = 0.0, const std::string& source = {});

// Two patches whose shared edge was tessellated differently: the vertices each put on the
// edge differ, so the surface cracks there. The edge is shared when both patches have its
// two corners at bitwise-equal positions; a side of the domain is the outer level GL pairs
// with it (quads: outer[0] u = 0, outer[1] v = 0, outer[2] u = 1, outer[3] v = 1;
// triangles: outer[0] u = 0, outer[1] v = 0, outer[2] w = 0).
struct SharedEdgeCrack {
    std::uint32_t patch_a = 0, patch_b = 0;  // patch_a < patch_b
    int side_a = 0, side_b = 0;              // the outer level index of the edge in each
    float level_a = 0.0f, level_b = 0.0f;    // those levels (0 when the capture has none)
    std::size_t points_a = 0, points_b = 0;  // vertices each patch put on the edge
    glm::dvec3 from{0.0}, to{0.0};           // the edge's corners in world space
};
std::vector<SharedEdgeCrack> shared_edge_cracks(const Capture& capture);

// The whole report as JSON text (pretty-printed, ends with a newline).
std::string report_json(const CheckReport& report);
// A human-readable summary: counts per class and the first few locations of each.
std::string report_text(const CheckReport& report, std::size_t locations_per_class = 5);

// A top view (along report.up_axis) of the mesh drawn lightly, the defects marked in one
// colour per class, with a legend. Written to `path` as is, in the format its extension names (the caller
// makes it atomic). Throws tessref::Error when the image cannot be written.
void write_defect_image(const IndexedMesh& mesh, const CheckReport& report,
                        const std::string& path, int width = 1024);

}  // namespace tessref
