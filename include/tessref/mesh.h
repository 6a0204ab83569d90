// tessref/mesh.h — the tessellated surface as plain data, and its export.
//
// SurfaceMesh is what the pipeline (scene -> control -> generator -> evaluation ->
// geometry) produces and what `tessref mesh` writes through OpenMesh. Every vertex
// remembers where it came from: the patch that emitted it and its gl_TessCoord, so a
// defect found later (a crack, a wrong normal) can be traced back to a patch.
//
// Export (write_mesh) in three steps:
//  1. Validate: every per-vertex array is empty or as long as `positions`, every triangle
//     index is in range. A violation throws tessref::Error.
//  2. Weld (weld_bitwise): vertices are merged ONLY where their positions are bitwise
//     equal, so two patches that compute a shared edge identically share its vertices,
//     and a crack (positions that differ by even one ulp) stays a visible hole in the
//     file. The one exception to "bitwise": -0.0 and +0.0 are the same coordinate (they
//     compare equal and no GPU rasterizes a gap between them), so the sign of a zero is
//     ignored. When the merged copies disagree on their other attributes (normal, uv,
//     tess coord, patch id), the welded vertex takes ALL of them from one copy: the copy
//     with the lowest patch id, and among those the one emitted first. The result does not
//     depend on the order of the input vertices beyond that tie-break.
//  3. Write: PLY through tessref's own writer, which writes byte for byte what OpenMesh's
//     PLY writer writes for the same mesh and options (tests/test_mesh.cpp compares the two;
//     src/mesh/openmesh.h keeps OpenMesh's as the reference) straight from the welded
//     arrays, blocks of records formatted in parallel and written in order; OBJ, OFF and
//     STL through OpenMesh's writers
//     (OpenMesh::IO::IOManager, on a stream, fed by an exporter; see below). What each
//     format carries:
//       ply  positions, vertex normals (nx ny nz), uv (u v), and the provenance of every
//            vertex as extra properties: `property int patch_id`, `property float tess_u`,
//            `tess_v`, `tess_w`; ascii or --binary (little endian).
//       obj  positions, normals (vn), uv (vt); ascii only (OBJ has no binary form:
//            asking for one is an Error).
//       off  positions, normals, uv (the "STNOFF" variant); ascii, or OpenMesh's binary
//            OFF (a "... BINARY" header line) with binary = true.
//       stl  positions only (STL has no vertex attributes); facet normals are computed by
//            OpenMesh from each triangle's (float) corners. ascii or binary.
//     ASCII numbers are written with 9 significant digits (enough for any float to read
//     back bitwise). Caveats of OpenMesh 9.0's writers, kept rather than hand-writing a
//     format: every writer stores positions, normals and uvs as 32-bit float, so positions
//     of an `exact` (double) run are rounded to the nearest float in the file (welding
//     still happens on the double bit patterns; MeshWriteReport says what the rounding
//     lost, and `tessref mesh` warns); the ASCII STL writer prints vertex
//     coordinates (and the facet normals after the first) with 10 significant digits, not
//     9 (it hard-codes that).
//
// The triangles reach OpenMesh's writers through its exporter interface as a plain list:
// OpenMesh's half-edge structure is not built, so a mesh it could not hold (an edge with
// three or more triangles, two fans meeting at one vertex) is still written exactly as it
// is. A triangle whose corners weld into fewer than three distinct vertices has no area
// and no edges to share; it is left out and counted in
// MeshWriteReport::degenerate_triangles.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

namespace tessref {

struct SurfaceMesh {
    // One entry per emitted vertex (not welded: patches that share an edge each emit
    // their own copies; export welds only bitwise-equal positions).
    std::vector<glm::dvec3> positions;   // world space; float-exact values in gpu precision
    std::vector<glm::dvec3> normals;     // empty when no stage produced normals
    std::vector<glm::dvec2> uvs;         // texture coordinates; empty when none
    std::vector<std::uint32_t> patch_ids;
    std::vector<glm::vec3> tess_coords;  // gl_TessCoord of the vertex in its patch
    std::vector<std::array<std::uint32_t, 3>> triangles;  // counter-clockwise seen from outside/above
};

// ---------------------------------------------------------------------------------------
// Formats

enum class MeshFormat : std::uint8_t { ply, obj, off, stl };

// "ply", "obj", "off", "stl".
std::string_view to_string(MeshFormat format);
// The format named by a lower- or upper-case name without the dot; nullopt if unknown.
std::optional<MeshFormat> parse_mesh_format(std::string_view name);
// The format of an output path from its extension ("out/terrain.PLY" -> ply). Throws
// tessref::Error naming the path when the extension is missing or not one of the four.
MeshFormat mesh_format_from_path(const std::string& path);
// Whether OpenMesh writes `format` in a binary form (ply, off, stl: yes; obj: no).
bool mesh_format_has_binary(MeshFormat format);

// ---------------------------------------------------------------------------------------
// Checks and welding

// Throws tessref::Error when the arrays of `mesh` disagree in length (normals, uvs,
// patch_ids, tess_coords must each be empty or one per position) or a triangle names a
// vertex that does not exist (the error's patch id is that triangle's first corner's).
void validate(const SurfaceMesh& mesh);

struct WeldedMesh {
    SurfaceMesh mesh;                        // welded vertices, triangles re-indexed
    std::vector<std::uint32_t> vertex_map;   // emitted vertex -> welded vertex (weld_bitwise only)
    std::size_t emitted_vertices = 0;        // vertices before welding
    std::size_t degenerate_triangles = 0;    // dropped: corners welded into < 3 vertices
};

// Welds vertices whose positions are bitwise equal (up to the sign of zero), keeping the
// attributes of the copy with the lowest patch id (then the lowest index). Welded
// vertices are numbered in order of their first emitted copy; triangles keep their order
// and orientation. Validates `mesh` first.
WeldedMesh weld_bitwise(const SurfaceMesh& mesh);

// weld_bitwise() of a surface that arrives in pieces (pipeline.h, stream_surface), so that
// the unwelded surface is never held whole: add() the pieces in order, each a SurfaceMesh
// whose triangles index its own vertices, then take() the result once. It is bit for bit
// weld_bitwise() of the pieces concatenated (their triangles shifted to the concatenated
// vertices), except that vertex_map stays empty (4 bytes an emitted vertex); weld_bitwise()
// is one add() of the whole surface. Memory: the
// welded mesh, and a hash table of 16 to 32 bytes per expected (at least per welded)
// vertex. add() validates each piece, and throws tessref::Error when a piece's attributes
// (which of normals, uvs, patch_ids, tess_coords it has) differ from the first piece's.
class SurfaceWelder {
public:
    // The expected counts (upper bounds are best: the emitted ones) size the hash table and
    // reserve the welded arrays' address space; more is welded correctly, just slower.
    explicit SurfaceWelder(std::size_t expected_vertices = 0, std::size_t expected_triangles = 0);
    ~SurfaceWelder();
    SurfaceWelder(SurfaceWelder&&) noexcept;
    SurfaceWelder& operator=(SurfaceWelder&&) noexcept;

    // vertex_map, when given, receives the piece's vertex -> welded vertex.
    void add(const SurfaceMesh& piece, std::vector<std::uint32_t>* vertex_map = nullptr);
    WeldedMesh take();

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// ---------------------------------------------------------------------------------------
// Writing

struct MeshWriteOptions {
    MeshFormat format = MeshFormat::ply;
    bool binary = false;       // ply, off, stl; an Error for obj
    int ascii_digits = 9;      // significant digits of every ASCII number
    // false: every emitted vertex is written as it is, none merged and no triangle left out
    // (a capture, include/tessref/capture.h, where each corner keeps its own patch id and
    // tess coord; welding would give a shared corner the lower patch's).
    bool weld = true;
    // Called from the calling thread with a stage ("welding", "collecting", "writing") and
    // the fraction of it done, a few hundred times at most; may be empty. OpenMesh's
    // writer reports nothing while it runs, so for OBJ, OFF and STL "writing" comes at 0
    // and 1 only, after "collecting" (the copy into OpenMesh's kernel); PLY has no
    // "collecting" and reports its writing as it goes.
    std::function<void(std::string_view stage, double fraction)> progress;
};

struct MeshWriteReport {
    std::size_t emitted_vertices = 0;      // vertices of the SurfaceMesh
    std::size_t vertices = 0;              // vertices written (after welding)
    std::size_t triangles = 0;             // triangles written
    std::size_t degenerate_triangles = 0;  // left out (see above)
    // What the file's 32-bit floats keep of the positions (an `exact` run computes them in
    // double): how many distinct float points the `vertices` fall on, and how many written
    // triangles have area in double but none with float corners. Both show precision lost,
    // typically far from the origin (at 9.1e6 floats are 1 apart).
    std::size_t float_distinct_vertices = 0;
    std::size_t float_degenerate_triangles = 0;
    double largest_coordinate = 0.0;  // max |x|, |y|, |z| written
    double float_spacing = 0.0;       // between the float at largest_coordinate and the next

    // One line saying what float storage lost (counts, largest coordinate, spacing there);
    // empty when it lost nothing.
    std::string precision_warning() const;
};

// Welds `mesh` and writes it to `out` (opened in binary mode for a binary format), PLY with
// tessref's writer, the other formats through OpenMesh. Besides `mesh`, the memory it takes
// is the weld's (while welding, a hash table of 16 to 32 bytes and a map of 4 bytes per
// emitted vertex; then 4 bytes per welded vertex and 12 per triangle), for PLY a few MiB of
// formatted records, and for OBJ, OFF and STL OpenMesh's copy of the welded vertices. Throws tessref::Error when the mesh is inconsistent, a position is not finite
// or beyond the float range (files store floats; the error names the vertex, its patch and
// tess coord), the options ask for what the format cannot do, or the stream fails. `out` may then hold part of a file: a caller
// writing a file writes a temporary file next to it and renames it only on success, as
// `tessref mesh` does (cli::AtomicOutput).
MeshWriteReport write_mesh(const SurfaceMesh& mesh, std::ostream& out,
                           const MeshWriteOptions& options);
// The same for a mesh already welded (weld_bitwise, SurfaceWelder): the bytes and report
// that write_mesh() of the unwelded surface gives (options.weld must be true).
MeshWriteReport write_mesh(const WeldedMesh& welded, std::ostream& out, const MeshWriteOptions& options);

// A welded PLY written as the surface arrives, so that neither the unwelded nor the welded
// surface is ever held: the file write_mesh() writes for the pieces concatenated (the
// same bytes and report), or nothing when the pieces break what the streaming relies on,
// and then the caller writes the file otherwise (run_pipeline_welded() and write_mesh()).
//
// What it relies on, and why it is enough. A welded vertex takes its attributes from its
// copy with the lowest patch id, then the earliest: with patch ids that never decrease
// from copy to copy, that is its first copy, so its record is written the moment it is
// first met, in the order the file numbers it. Its id is needed again only by the
// triangles, which PLY lists after every vertex: the writer keeps each emitted vertex's
// welded id (4 bytes) and asks the caller for the emitted triangles again at the end
// (the pipeline has them from its patterns without evaluating anything). The weld itself
// needs, for each new copy, every earlier vertex it could equal. Within a piece the writer
// keeps them all; across pieces only each patch's vertices on the surface of its bounding
// box, and only those look there, because the others (a patch's "interior", strictly
// inside its box on every axis) are checked, at the end, to lie outside the box of every
// patch of another piece: then no copy of another piece can equal them. Tessellated terrains pass that check (a patch's interior points lie
// strictly between its edges, and its neighbours begin at them); a surface whose patches
// overlap (PN triangles' curved patches) does not, and is written otherwise. Also
// written otherwise: positions that are not float values (exact precision, camera-relative
// evaluation; what float storage loses is then measured over all of them), a header whose
// counts have fewer digits than the bounds given at the start (the vertex records are
// written after a header of that length), and more vertices or triangles than 32-bit ids
// name. Memory: 4 bytes per emitted vertex, the shared vertices' table (about 40 bytes
// each: a terrain's patch borders) and a piece's formatted records.
class StreamedPlyWriter {
public:
    // `out` must be a seekable stream at its start (a file); `emitted_vertices` and
    // `emitted_triangles` are the surface's counts before welding (the header's bounds).
    // options.format must be ply, options.weld true.
    StreamedPlyWriter(std::ostream& out, const MeshWriteOptions& options, std::size_t emitted_vertices,
                      std::size_t emitted_triangles);
    ~StreamedPlyWriter();
    StreamedPlyWriter(const StreamedPlyWriter&) = delete;
    StreamedPlyWriter& operator=(const StreamedPlyWriter&) = delete;

    // The next piece: whole patches in patch order, its triangles indexing its own vertices.
    // false when the file cannot be streamed (see above; then add() and finish() do nothing
    // more); throws tessref::Error for an inconsistent piece (validate()) or a stream failure.
    bool add(const SurfaceMesh& piece);
    // Fills `out` with the emitted triangles from index `first` on (indices of the emitted
    // vertices, every piece's after the last); called from several threads at once.
    using TriangleSource = std::function<void(std::size_t first, std::span<std::array<std::uint32_t, 3>> out)>;
    // The triangles and the header; nullopt when the file could not be streamed.
    std::optional<MeshWriteReport> finish(const TriangleSource& triangles);

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace tessref
