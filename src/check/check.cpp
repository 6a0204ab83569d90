// check_mesh(): runs the steps of src/check/ in order over one CheckState and decides.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>
#include <functional>
#include <unordered_map>

#include "check/check_internal.h"
#include "mesh/openmesh.h"
#include "tessref/error.h"

namespace tessref {

std::string_view defect_class_name(DefectClass kind) {
    switch (kind) {
        case DefectClass::boundary_loop: return "boundary_loop";
        case DefectClass::non_manifold_edge: return "non_manifold_edge";
        case DefectClass::non_manifold_vertex: return "non_manifold_vertex";
        case DefectClass::refused_face: return "refused_face";
        case DefectClass::inconsistent_orientation: return "inconsistent_orientation";
        case DefectClass::inverted_volume: return "inverted_volume";
        case DefectClass::degenerate_face: return "degenerate_face";
        case DefectClass::duplicate_face: return "duplicate_face";
        case DefectClass::coincident_vertices: return "coincident_vertices";
        case DefectClass::near_coincident_vertices: return "near_coincident_vertices";
        case DefectClass::t_junction: return "t_junction";
        case DefectClass::probe_miss: return "probe_miss";
        case DefectClass::probe_odd_parity: return "probe_odd_parity";
        case DefectClass::probe_escape: return "probe_escape";
        case DefectClass::facing_down: return "facing_down";
    }
    return "unknown";
}

std::string_view defect_class_description(DefectClass kind) {
    switch (kind) {
        case DefectClass::boundary_loop: return "boundary loops (holes, cracks, open edges)";
        case DefectClass::non_manifold_edge: return "non-manifold edges (more than two faces)";
        case DefectClass::non_manifold_vertex: return "non-manifold vertices (more than one fan)";
        case DefectClass::refused_face: return "faces OpenMesh refused or skipped";
        case DefectClass::inconsistent_orientation: return "edges with inconsistent orientation";
        case DefectClass::inverted_volume: return "closed components facing inward";
        case DefectClass::degenerate_face: return "degenerate faces";
        case DefectClass::duplicate_face: return "duplicate faces";
        case DefectClass::coincident_vertices: return "unwelded vertices at equal positions";
        case DefectClass::near_coincident_vertices: return "unwelded vertices within the tolerance";
        case DefectClass::t_junction: return "T-junctions";
        case DefectClass::probe_miss: return "probe: rays through the terrain";
        case DefectClass::probe_odd_parity: return "probe: lines with odd crossings";
        case DefectClass::probe_escape: return "probe: rays escaping from inside";
        case DefectClass::facing_down: return "terrain faces facing down its up axis (wound the other way)";
    }
    return "unknown";
}

namespace {

using namespace check_detail;

// Why each face is left out of the topology, if it is, and which vertices the faces use.
// In parallel, in fixed chunks whose defects are added in face order; an index beyond the
// vertices (only a mesh built in memory has one: the readers refuse it) is reported for the
// first such face, as a serial pass would.
void classify_faces(CheckState& state) {
    const IndexedMesh& mesh = state.mesh;
    const std::size_t vertex_count = mesh.vertex_count();
    state.face_status.resize(mesh.face_count());
    state.vertex_referenced.assign(vertex_count, 0);
    struct ChunkResult {
        std::vector<Defect> defects;  // the chunk's first max_locations
        std::size_t count = 0;
        std::size_t bad_face = SIZE_MAX;  // the chunk's first face with an index beyond the vertices
        std::uint32_t bad_vertex = 0;
    };
    const auto finite = [](const glm::dvec3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); };
    auto results = map_chunks<ChunkResult>(mesh.face_count(), 1 << 14, [&](std::size_t f0, std::size_t f1, ChunkResult& out) {
        for (std::size_t f = f0; f < f1; ++f) {
            const auto face = mesh.face(f);
            state.face_status[f] = face_kept;
            bool all_finite = true;
            for (std::uint32_t v : face) {
                if (v >= vertex_count) {
                    out.bad_face = f;
                    out.bad_vertex = v;
                    return;
                }
                std::atomic_ref<std::uint8_t>(state.vertex_referenced[v]).store(1, std::memory_order_relaxed);
                all_finite = all_finite && finite(mesh.positions[v]);
            }
            bool repeated = false;
            for (std::size_t i = 0; i < face.size() && !repeated; ++i)
                for (std::size_t j = i + 1; j < face.size(); ++j)
                    if (face[i] == face[j]) {
                        repeated = true;
                        break;
                    }
            if (face.size() < 3) state.face_status[f] = face_too_few_vertices;
            else if (repeated) state.face_status[f] = face_repeated_vertex;
            else if (!all_finite) state.face_status[f] = face_non_finite;
            if (state.face_status[f] == face_kept) continue;
            if (out.count++ >= state.options.max_locations) continue;

            Defect d;
            glm::dvec3 centre(0.0);
            std::size_t finite_corners = 0;
            for (std::uint32_t v : face) {
                const glm::dvec3& p = mesh.positions[v];
                if (finite(p)) {
                    centre += p;
                    ++finite_corners;
                }
            }
            d.position = finite_corners ? centre / double(finite_corners) : glm::dvec3(0.0);
            d.faces = {static_cast<std::uint32_t>(f)};
            d.vertices.assign(face.begin(), face.end());
            d.detail = "face " + std::to_string(f) +
                       (state.face_status[f] == face_too_few_vertices ? " has fewer than three vertices"
                        : state.face_status[f] == face_repeated_vertex ? " repeats a vertex"
                                                                        : " has a vertex with non-finite coordinates");
            out.defects.push_back(std::move(d));
        }
    });
    for (const ChunkResult& r : results)
        if (r.bad_face != SIZE_MAX)
            throw Error("face " + std::to_string(r.bad_face) + " refers to vertex " + std::to_string(r.bad_vertex) +
                            ", but the mesh has " + std::to_string(vertex_count) + " vertices",
                        Where::in_file(mesh.source));
    // Counts are exact; only the first max_locations locations are kept, in face order.
    DefectReport& degenerate = state.report.defects[int(DefectClass::degenerate_face)];
    for (ChunkResult& r : results) {
        degenerate.count += r.count;
        for (Defect& d : r.defects)
            if (degenerate.locations.size() < state.options.max_locations) degenerate.locations.push_back(std::move(d));
    }
}

void report_refused_faces(CheckState& state, const std::vector<std::uint32_t>& refused_faces) {
    const IndexedMesh& mesh = state.mesh;
    // Where every edge has at most two faces and every vertex one fan, the kernel refuses a
    // kept face only for an edge two faces traverse the same way: a flipped face, already
    // reported as inconsistent_orientation and listed as flipped. One defect, one report.
    const bool explained_by_flips = state.non_manifold_edges == 0 && state.inconsistent_edges != 0 &&
                                    state.report.count(DefectClass::non_manifold_vertex) == 0;
    for (std::uint32_t f : refused_faces) {
        if (f >= mesh.face_count()) continue;
        if (explained_by_flips && state.face_status[f] == face_kept) {
            state.report.refused_for_flips.push_back(f);
            continue;
        }
        Defect d;
        const auto face = mesh.face(f);
        glm::dvec3 centre(0.0);
        for (std::uint32_t v : face) centre += mesh.positions[v];
        d.position = face.empty() ? glm::dvec3(0.0) : centre / double(face.size());
        d.faces = {f};
        d.vertices.assign(face.begin(), face.end());
        const bool dropped = state.face_status[f] == face_too_few_vertices || state.face_status[f] == face_repeated_vertex;
        d.detail = dropped ? "OpenMesh's importer drops face " + std::to_string(f) + " (a repeated vertex, or fewer than three)"
                           : "OpenMesh's kernel refused face " + std::to_string(f) +
                                 " (a complex edge or vertex) and added it on copies of its vertices";
        state.add_defect(DefectClass::refused_face, std::move(d));
    }
}

// Vertex defects name their vertices; add the faces around them.
void attach_faces(CheckState& state) {
    std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> faces_of;
    for (DefectClass kind : {DefectClass::coincident_vertices, DefectClass::near_coincident_vertices})
        for (const Defect& d : state.report.of(kind).locations)
            for (std::uint32_t v : d.vertices) faces_of.try_emplace(v);
    if (faces_of.empty()) return;
    const IndexedMesh& mesh = state.mesh;
    for (std::uint32_t f = 0; f < mesh.face_count(); ++f)
        for (std::uint32_t v : mesh.face(f))
            if (auto it = faces_of.find(v); it != faces_of.end() && it->second.size() < 8) it->second.push_back(f);
    for (DefectClass kind : {DefectClass::coincident_vertices, DefectClass::near_coincident_vertices})
        for (Defect& d : state.report.defects[int(kind)].locations) {
            for (std::uint32_t v : d.vertices) {
                const auto& faces = faces_of[v];
                d.faces.insert(d.faces.end(), faces.begin(), faces.end());
            }
            std::sort(d.faces.begin(), d.faces.end());
            d.faces.erase(std::unique(d.faces.begin(), d.faces.end()), d.faces.end());
        }
}

// Which faces OpenMesh's kernel refuses, asked once the topology is known (after
// classify_edges_and_vertices): read_and_check_mesh() may then answer without the import.
using RefusedFaces = std::function<const std::vector<std::uint32_t>&(const CheckState&)>;

void name_patches(CheckState& state);

CheckReport run_checks(const IndexedMesh& mesh, const CheckOptions& options, const RefusedFaces& refused_faces) {
    CheckReport report;
    report.source = mesh.source;
    report.format = mesh.format;
    report.reader_notes = mesh.reader_notes;
    report.vertex_count = mesh.vertex_count();
    report.face_count = mesh.face_count();
    report.expect = options.expect;
    for (int k = 0; k < kDefectClassCount; ++k) report.defects.push_back({static_cast<DefectClass>(k), 0, {}});
    if (options.tolerance && !(*options.tolerance >= 0.0 && std::isfinite(*options.tolerance)))
        throw Error("the tolerance must be a finite number >= 0", Where::in_file("--tolerance"));

    CheckState state{mesh, options, report};
    state.progress("topology", 0.0);
    classify_faces(state);

    // The bounding box of the vertices the faces use (minima and maxima are exact, so the
    // chunks' boxes join into the box a serial pass finds).
    struct Box {
        bool any = false;
        glm::dvec3 lo{0.0}, hi{0.0};
    };
    const auto boxes = map_chunks<Box>(mesh.vertex_count(), 1 << 15, [&](std::size_t v0, std::size_t v1, Box& box) {
        for (std::size_t v = v0; v < v1; ++v) {
            const glm::dvec3& p = mesh.positions[v];
            if (!state.vertex_referenced[v] || !std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
            box.lo = box.any ? glm::min(box.lo, p) : p;
            box.hi = box.any ? glm::max(box.hi, p) : p;
            box.any = true;
        }
    });
    bool any = false;
    for (const Box& box : boxes) {
        if (!box.any) continue;
        state.bbox_min = any ? glm::min(state.bbox_min, box.lo) : box.lo;
        state.bbox_max = any ? glm::max(state.bbox_max, box.hi) : box.hi;
        any = true;
    }
    state.diagonal = glm::distance(state.bbox_min, state.bbox_max);
    report.bbox_min = state.bbox_min;
    report.bbox_max = state.bbox_max;
    // Default: about what single-precision rounding can move a vertex at the mesh's scale
    // (2^-24 of the largest coordinate is 6e-8 of it), so that copies of one point computed
    // twice coincide within it, while points placed apart on purpose do not.
    const double magnitude = std::max({state.diagonal, glm::length(state.bbox_min), glm::length(state.bbox_max)});
    state.tolerance = options.tolerance.value_or(1e-7 * magnitude);
    report.tolerance = state.tolerance;
    report.unreferenced_vertices = static_cast<std::size_t>(
        std::count(state.vertex_referenced.begin(), state.vertex_referenced.end(), std::uint8_t{0}));

    build_corner_table(state);
    state.progress("topology", 0.15);
    classify_edges_and_vertices(state);
    report.closed = state.boundary.empty();
    state.progress("topology", 0.4);
    find_components(state);
    check_orientation(state);
    // Only this step adds refused_face defects, and no later step reads them; after the
    // orientation, whose flipped faces explain some refusals (report_refused_faces).
    report_refused_faces(state, refused_faces(state));
    state.progress("coincident vertices", 0.45);
    find_coincident_vertices(state);
    state.corner_faces.release();
    state.corner_start.release();
    state.progress("geometry", 0.5);
    analyse_face_geometry(state);
    trace_boundary_loops(state);
    judge_boundary(state);
    find_faces_facing_down(state);
    state.progress("T-junctions", 0.7);
    find_t_junctions(state);
    run_ray_probe(state);
    attach_faces(state);
    name_patches(state);

    // The vertices of kept faces are those find_components numbered.
    const auto kept_faces = static_cast<std::size_t>(std::count(state.face_status.begin(), state.face_status.end(), std::uint8_t{face_kept}));
    const auto kept_vertices = static_cast<std::size_t>(
        mesh.vertex_count() - std::count(state.vertex_component.begin(), state.vertex_component.end(), kNoIndex));
    report.topology_excluded_faces = mesh.face_count() - kept_faces;
    report.euler_characteristic = static_cast<long long>(kept_vertices) - static_cast<long long>(report.edge_count) +
                                  static_cast<long long>(kept_faces);
    report.manifold = report.count(DefectClass::non_manifold_edge) == 0 && report.count(DefectClass::non_manifold_vertex) == 0;
    report.consistently_oriented =
        report.count(DefectClass::inconsistent_orientation) == 0 && report.count(DefectClass::inverted_volume) == 0;
    report.passed = std::all_of(report.defects.begin(), report.defects.end(), [](const DefectReport& r) { return r.count == 0; });
    state.progress("done", 1.0);
    return report;
}

// In a mesh that carries patch ids, every location names its patches: a crack or a hole in
// a tessellated surface is the business of the patches around it.
void name_patches(CheckState& state) {
    const IndexedMesh& mesh = state.mesh;
    if (mesh.patch_ids.size() != mesh.vertex_count()) return;
    for (DefectReport& d : state.report.defects)
        for (Defect& x : d.locations) {
            for (std::uint32_t v : x.vertices)
                if (v < mesh.vertex_count()) x.patches.push_back(mesh.patch_ids[v]);
            for (std::uint32_t f : x.faces)
                if (f < mesh.face_count())
                    for (std::uint32_t v : mesh.face(f)) x.patches.push_back(mesh.patch_ids[v]);
            std::sort(x.patches.begin(), x.patches.end());
            x.patches.erase(std::unique(x.patches.begin(), x.patches.end()), x.patches.end());
        }
}

// Whether the kernel provably refuses only the faces its importer drops (check.h,
// read_and_check_mesh): every face it adds is kept, and the kept faces are an oriented
// 2-manifold with boundary.
bool kernel_refuses_only_dropped_faces(const CheckState& state) {
    if (state.non_manifold_edges != 0 || state.inconsistent_edges != 0) return false;
    if (state.report.count(DefectClass::non_manifold_vertex) != 0) return false;
    return std::all_of(state.face_status.begin(), state.face_status.end(), [](std::uint8_t status) {
        return status == face_kept || status == face_too_few_vertices || status == face_repeated_vertex;
    });
}

}  // namespace

CheckReport check_mesh(const IndexedMesh& mesh, const CheckOptions& options) {
    return run_checks(mesh, options, [&mesh](const CheckState&) -> const std::vector<std::uint32_t>& {
        return mesh.kernel_refused_faces;
    });
}

CheckedMesh check_indexed_mesh(IndexedMesh mesh, const CheckOptions& options) {
    CheckedMesh out;
    out.mesh = std::move(mesh);
    std::vector<std::uint32_t>& refused = out.mesh.kernel_refused_faces;
    out.report = run_checks(out.mesh, options, [&refused](const CheckState& state) -> const std::vector<std::uint32_t>& {
        refused.clear();
        if (kernel_refuses_only_dropped_faces(state)) {
            // An add_face with a complex edge needs a half-edge already traversed the same way;
            // a complex vertex, a closed fan and a further face there (a second fan, or a third
            // face on one of its edges); a failed re-linking, the new face closing a fan while
            // another fan waits at the vertex (again a second fan). None exists here.
            for (std::size_t f = 0; f < state.face_status.size(); ++f)
                if (state.face_status[f] != face_kept) refused.push_back(static_cast<std::uint32_t>(f));
        } else {
            refused = kernel_refused_faces(state.mesh);
        }
        return refused;
    });
    return out;
}

CheckedMesh read_and_check_mesh(const std::string& path, const CheckOptions& options,
                                const std::function<void(double)>& read_progress) {
    MeshFileOptions read_options;
    read_options.progress = read_progress;
    read_options.provenance = true;  // a PLY's patch ids name the patches of each location
    read_options.tess_coords = false;
    return check_indexed_mesh(read_mesh_file(path, read_options), options);
}

// ---------------------------------------------------------------------------------------
// The mesh as the check reads it: the file's faces, and which of them OpenMesh's kernel
// refuses.

IndexedMesh read_mesh_for_check(const std::string& path) { return read_mesh_for_check(path, {}); }

IndexedMesh read_mesh_for_check(const std::string& path, const std::function<void(double)>& progress) {
    MeshFileOptions options;
    options.progress = progress;
    options.provenance = true;
    IndexedMesh mesh = read_mesh_file(path, options);
    mesh.kernel_refused_faces = check_detail::kernel_refused_faces(mesh);
    return mesh;
}

std::vector<std::uint32_t> check_detail::kernel_refused_faces(const IndexedMesh& mesh) {
    // The importer explains each refusal on omerr(); the check's report does that.
    const mesh_detail::QuietStream quiet(::omerr());
    return mesh_detail::import_half_edge_mesh(mesh, false).refused_faces;
}

}  // namespace tessref
