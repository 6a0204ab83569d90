// Tests of the mesh readers (src/mesh/read_*.cpp) against hostile and unusual files.
//
// The contract: a file that is exactly what its format says reads as it lists itself (the
// counts, positions and faces written here by hand); anything else is refused at once with
// a tessref::Error naming the file and the line (text) or byte offset (binary) -- exit 2
// from `tessref check`, never a crash (exit 139), a hang, unbounded memory, or a mesh with
// invented defects (exit 1). The hostile files are the reports: stored small under
// tests/data/readers/, or built here (binary data, a cut copy of an exported mesh, a
// sparse file whose header declares 2^31 faces). A scene's [[mesh]] is read by the same
// reader, so `tessref mesh` on such a scene exits 2 as well.
#include <gtest/gtest.h>

#include "run_program.h"
#include "scratch_dir.h"

#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

#include "tessref/check.h"
#include "tessref/error.h"
#include "tessref/limits.h"
#include "tessref/prepare.h"
#include "tessref/scene.h"

namespace fs = std::filesystem;
using tessref::IndexedMesh;
using tessref::test::read_file;
using tessref::test::RunResult;
using tessref::test::write_file;

namespace {

const fs::path data_dir = fs::path(TESSREF_SOURCE_DIR) / "tests" / "data" / "readers";
const fs::path corpus_dir = fs::path(TESSREF_SOURCE_DIR) / "tests" / "data" / "check";

const tessref::test::ScratchDir& scratch_dir = tessref::test::ScratchDir::add("mesh_readers");

fs::path scratch(const std::string& name, const std::string& bytes) {
    const fs::path path = scratch_dir() / name;
    write_file(path, bytes);
    return path;
}

RunResult tessref(std::vector<std::string> args) { return tessref::test::run_program(TESSREF_EXE, args, scratch_dir()); }

// The error read_mesh_for_check throws; a failure when it throws none.
tessref::Error read_error(const fs::path& path) {
    try {
        tessref::read_mesh_for_check(path.string());
    } catch (const tessref::Error& e) {
        return e;
    }
    ADD_FAILURE() << path << " was read without an error";
    return tessref::Error("");
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// `tessref check FILE` refuses the file: exit 2, one error line naming the file and `part`.
void expect_refused(const fs::path& path, const std::string& part, int line = 0) {
    SCOPED_TRACE(path.filename().string());
    const auto start = std::chrono::steady_clock::now();
    const RunResult r = tessref({"check", path.string()});
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(20));
    EXPECT_EQ(r.status, 2) << r.out << r.err;
    EXPECT_EQ(r.err.rfind("tessref: error: ", 0), 0u) << r.err;
    EXPECT_TRUE(contains(r.err, path.string())) << r.err;
    EXPECT_TRUE(contains(r.err, part)) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
    const tessref::Error e = read_error(path);
    EXPECT_EQ(e.where().file, path.string());
    if (line > 0) {
        EXPECT_EQ(e.where().line, line) << e.what();
        EXPECT_TRUE(contains(e.what(), "line " + std::to_string(line))) << e.what();
    }
}

std::string le32(std::uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); }
std::string f32(float v) { return std::string(reinterpret_cast<const char*>(&v), 4); }
std::string f64(double v) { return std::string(reinterpret_cast<const char*>(&v), 8); }
std::string be(std::string bytes) { return {bytes.rbegin(), bytes.rend()}; }

// A unit cube as triangles: its corners (x fastest) and 12 outward triangles.
const double cube_corners[8][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1}};
const int cube_triangles[12][3] = {{0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}, {0, 1, 5}, {0, 5, 4},
                                   {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};

// A binary STL of the cube, with one corner replaced by `corner`.
std::string binary_stl_cube(float corner = 0.0f) {
    std::string s(80, ' ');
    s += le32(12);
    for (int t = 0; t < 12; ++t) {
        s += f32(0) + f32(0) + f32(0);
        for (int c = 0; c < 3; ++c)
            for (int k = 0; k < 3; ++k)
                s += f32(t == 5 && c == 2 && k == 1 ? corner + float(cube_corners[cube_triangles[t][c]][k])
                                                    : float(cube_corners[cube_triangles[t][c]][k]));
        s += std::string(2, '\0');
    }
    return s;
}

// A binary little-endian PLY of the cube with double coordinates at offset + corner * step.
std::string double_ply_cube(double offset, double step) {
    std::string s = "ply\nformat binary_little_endian 1.0\nelement vertex 8\nproperty double x\nproperty double y\n"
                    "property double z\nelement face 12\nproperty list uchar int vertex_indices\nend_header\n";
    for (const auto& p : cube_corners)
        for (double c : p) s += f64(offset + c * step);
    for (const auto& t : cube_triangles) {
        s += '\3';
        for (int v : t) s += le32(static_cast<std::uint32_t>(v));
    }
    return s;
}

// What `tessref mesh` writes for a shipped scene (binary OFF or another format).
fs::path exported(const std::string& name, bool binary) {
    const fs::path out = scratch_dir() / name;
    if (fs::exists(out)) return out;
    std::vector<std::string> args = {"mesh", (fs::path(TESSREF_SOURCE_DIR) / "data/scenes/thesis-constant-1.toml").string(),
                                     "-o", out.string()};
    if (binary) args.push_back("--binary");
    const RunResult r = tessref(args);
    EXPECT_EQ(r.status, 0) << r.err;
    return out;
}

// ---------------------------------------------------------------------------------------
// The defects

// 2: OpenMesh's PLY header parser crashed (exit 139) on a property before any element;
// `mesh` and `render` crashed too when a scene's [[mesh]] named such a file.
TEST(MeshReaders, PlyPropertyBeforeAnyElementIsRefusedNotACrash) {
    const fs::path file = data_dir / "property_before_element.ply";
    expect_refused(file, "'property' before any 'element'", 3);

    const fs::path scene = scratch("hostile_scene.toml",
                                   "[scene]\nname = \"h\"\n[[mesh]]\npath = \"" + file.string() +
                                       "\"\n[evaluation]\nmodel = \"pn\"\n[control]\nmodel = \"pn\"\n");
    const fs::path out = scratch_dir() / "hostile.ply";
    for (const char* command : {"mesh", "render"}) {
        SCOPED_TRACE(command);
        const std::string output = std::string(command) == "mesh" ? out.string() : (scratch_dir() / "h.png").string();
        const RunResult r = tessref({command, scene.string(), "-o", output});
        EXPECT_EQ(r.status, 2) << r.err;
        EXPECT_TRUE(contains(r.err, "'property' before any 'element'")) << r.err;
        EXPECT_TRUE(contains(r.err, "mesh[0].path")) << r.err;
        EXPECT_FALSE(fs::exists(output));
    }
}

// 3: a non-number in an ASCII PLY vertex line gave exit 1 or memory without limit.
TEST(MeshReaders, AsciiPlyBadVertexTokenNamesTheLine) {
    expect_refused(data_dir / "bad_vertex_token.ply", "bad token 'x' at line 11", 11);
}

// 4: a cut binary OFF took seconds and gigabytes, or invented a face referring to vertex
// 1065352704 (the bits of 1.0f); every cut must be an immediate "truncated file".
TEST(MeshReaders, TruncatedBinaryOffIsRefusedAtEveryCut) {
    const std::string whole = read_file(exported("whole.off", true));
    ASSERT_GT(whole.size(), 4258u);
    ASSERT_EQ(whole.rfind("STNOFF BINARY\n", 0), 0u);
    const IndexedMesh mesh = tessref::read_mesh_for_check(exported("whole.off", true).string());
    EXPECT_EQ(mesh.vertex_count(), 289u);  // what `tessref mesh` reports for the scene
    EXPECT_EQ(mesh.face_count(), 512u);

    expect_refused(scratch("cut_4258.off", whole.substr(0, 4258)), "truncated file");
    // Every 37th length: in the header, the counts, the vertices, and the faces.
    const fs::path cut = scratch_dir() / "cut.off";
    for (std::size_t n = 1; n < whole.size(); n += 37) {
        write_file(cut, whole.substr(0, n));
        const tessref::Error e = read_error(cut);
        EXPECT_TRUE(contains(e.what(), "truncated") || contains(e.what(), "OFF")) << n << ": " << e.what();
    }
    // And one byte too many.
    expect_refused(scratch("long.off", whole + "x"), "1 bytes after the last face");
}

// 6: non-finite coordinates: OBJ's gave a misleading index error, the others were checked
// as if fine. The vertex is named, with its line or byte offset.
TEST(MeshReaders, NonFiniteCoordinatesNameTheVertex) {
    expect_refused(data_dir / "nan_vertex.obj", "vertex 0 at line 1 has a non-finite coordinate (x = nan)", 1);
    expect_refused(data_dir / "nan_vertex.off", "vertex 2 at line 5 has a non-finite coordinate (x = nan)", 5);
    expect_refused(data_dir / "inf_vertex.ply", "vertex 1 at line 11 has a non-finite coordinate (y = inf)", 11);
    expect_refused(data_dir / "nan_vertex.stl", "has a non-finite coordinate (y = nan)", 6);
    // Binary: facet 5's third corner is the 18th corner record; byte 84 + 5 * 50 + 12 + 24.
    expect_refused(scratch("inf.stl", binary_stl_cube(INFINITY)), "at byte offset 370 (facet 5, corner 2)");
    expect_refused(scratch("nan.ply", double_ply_cube(NAN, 1.0)), "vertex 0 at byte offset");
    // A double beyond float range is not a float coordinate either.
    expect_refused(scratch("big.ply", double_ply_cube(1e300, 1.0)), "beyond float range");
}

// 7: non-numbers in face or vertex records were read as meshes with invented defects.
TEST(MeshReaders, BadTokensInRecordsAreBadInput) {
    expect_refused(data_dir / "bad_vertex_token.stl", "bad token 'blah' at line 6", 6);
    expect_refused(data_dir / "bad_face_token.ply", "bad token 'x' at line 13", 13);
    expect_refused(data_dir / "huge_face.off", "face 0 at line 6 lists 300000000 vertices", 6);
    expect_refused(scratch("float_index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n"), "bad token '1.5' at line 6", 6);
    expect_refused(scratch("bad_corner.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2/x 3\n"), "bad token '2/x' at line 4", 4);
    expect_refused(scratch("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"), "bad token '0' at line 4", 4);
    expect_refused(scratch("bad_v.obj", "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n"), "bad token 'zero' at line 2", 2);
}

// 8: '#' comments are legal anywhere in OFF.
TEST(MeshReaders, OffCommentsAreAccepted) {
    const IndexedMesh with = tessref::read_mesh_for_check((data_dir / "comments.off").string());
    const fs::path plain =
        scratch("plain.off", "OFF\n4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n");
    const IndexedMesh without = tessref::read_mesh_for_check(plain.string());
    EXPECT_EQ(with.positions, without.positions);
    EXPECT_EQ(with.face_vertices, without.face_vertices);
    EXPECT_EQ(with.face_start, without.face_start);
    ASSERT_EQ(with.vertex_count(), 4u);
    EXPECT_EQ(with.positions[3], glm::dvec3(0, 0, 1));
    const RunResult r = tessref({"check", (data_dir / "comments.off").string()});
    EXPECT_EQ(r.status, 0) << r.out << r.err;
}

// 10: a double-precision cube at 1e8 reads as 12 degenerate faces (float cannot hold
// 100000001); the report must say that the reading lost precision. The same cube with a
// step of 8 (exact in float) reads without a note.
TEST(MeshReaders, PrecisionLostOnReadingIsNoted) {
    const IndexedMesh lost = tessref::read_mesh_for_check(scratch("cube1e8.ply", double_ply_cube(1e8, 1.0)).string());
    ASSERT_EQ(lost.reader_notes.size(), 1u);
    EXPECT_TRUE(contains(lost.reader_notes[0], "lose precision")) << lost.reader_notes[0];
    EXPECT_TRUE(contains(lost.reader_notes[0], "100000001")) << lost.reader_notes[0];
    const RunResult r = tessref({"check", (scratch_dir() / "cube1e8.ply").string()});
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(contains(r.out, "note") && contains(r.out, "lose precision")) << r.out;

    const IndexedMesh exact = tessref::read_mesh_for_check(scratch("cube1e8_8.ply", double_ply_cube(1e8, 8.0)).string());
    EXPECT_TRUE(exact.reader_notes.empty());
    EXPECT_EQ(exact.positions[7], glm::dvec3(1e8 + 8, 1e8 + 8, 1e8 + 8));
    // Decimal text that float rounds, but keeps apart: no note.
    const IndexedMesh text = tessref::read_mesh_for_check((corpus_dir / "near_vertex.off").string());
    EXPECT_TRUE(text.reader_notes.empty());
    // ASCII STL corners 0.1 and 0.1000000001 become one vertex: a note.
    const IndexedMesh stl = tessref::read_mesh_for_check(
        scratch("merged.stl",
                "solid m\nfacet normal 0 0 1\nouter loop\nvertex 0.1 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n"
                "facet normal 0 0 1\nouter loop\nvertex 0.1000000001 0 0\nvertex 0 1 0\nvertex 0 0 1\nendloop\nendfacet\n"
                "endsolid m\n")
            .string());
    EXPECT_EQ(stl.vertex_count(), 4u);
    ASSERT_EQ(stl.reader_notes.size(), 1u);
    EXPECT_TRUE(contains(stl.reader_notes[0], "STL corners")) << stl.reader_notes[0];
}

// Text coordinates read as the float nearest the text (as OpenMesh reads them), not as the
// float nearest the double nearest it: ties between two floats go to the even one, values
// a double holds exactly that are floats (whole numbers, binary fractions, subnormals),
// and those just off a tie either way.
TEST(MeshReaders, CoordinatesReadAsTheFloatNearestTheirText) {
    const std::vector<std::string> tokens = {
        "16777217", "16777219", "-16777217", "0.1", "-0", "2.5", "1e-45", "1e-40", "3.4028235e38",
        "1.0000000596046447753906250", "1.00000005960464477539062500000001", "1.0000000596046447753906249999",
        "0.30000001192092896", "123456.789", "+7", "0x10", "1e-320"};
    // Three tokens a vertex line, one face.
    const auto off = [](std::vector<std::string> xyz) {
        while (xyz.size() % 3) xyz.push_back("0");
        std::string text = "OFF\n" + std::to_string(xyz.size() / 3) + " 1 0\n";
        for (std::size_t i = 0; i < xyz.size(); i += 3) text += xyz[i] + " " + xyz[i + 1] + " " + xyz[i + 2] + "\n";
        return text + "3 0 1 2\n";
    };
    // Hexadecimal is no number here: refused, naming the line (vertex 5 is line 8).
    expect_refused(scratch("hex_coordinate.off", off(tokens)), "bad token '0x10' at line 8", 8);
    std::vector<std::string> padded = tokens;
    padded[15] = "16";
    while (padded.size() % 3) padded.push_back("0");
    const std::string text = off(padded);
    const IndexedMesh mesh = tessref::read_mesh_for_check(scratch("nearest_float.off", text).string());
    ASSERT_EQ(mesh.vertex_count() * 3, padded.size());
    for (std::size_t i = 0; i < padded.size(); ++i) {
        SCOPED_TRACE(padded[i]);
        const float nearest = std::strtof(padded[i].c_str(), nullptr);
        const double read = mesh.positions[i / 3][static_cast<int>(i % 3)];
        EXPECT_EQ(read, double(nearest));
        EXPECT_EQ(std::signbit(read), std::signbit(nearest));
    }
    EXPECT_EQ(mesh.positions[0][0], 16777216.0);
    EXPECT_EQ(mesh.positions[0][1], 16777220.0);
    EXPECT_EQ(mesh.positions[3][0], 1.0);                              // a tie: even
    EXPECT_EQ(mesh.positions[3][1], double(std::nextafter(1.0f, 2.0f)));  // just above it
    EXPECT_EQ(mesh.positions[3][2], 1.0);                              // just below it
}

// The rounding note counts every coordinate whose float an earlier coordinate of another
// value in the file already has (on any axis), and names the first such coordinate in the
// file and the value of the first coordinate of its float; -0 and 0 are one value.
TEST(MeshReaders, RoundingNoteNamesTheFirstMergedCoordinate) {
    const IndexedMesh mesh = tessref::read_mesh_for_check(
        scratch("merged.off", "OFF\n5 2 0\n"
                              "0.1 5 0\n"
                              "-0 0.1000000001 7\n"
                              "0.10000000002 0 0.1\n"
                              "5.0000000001 1 7\n"
                              "0 1 7.000000000000001\n"
                              "3 0 1 2\n3 2 3 4\n")
            .string());
    ASSERT_EQ(mesh.reader_notes.size(), 1u);
    EXPECT_EQ(mesh.reader_notes[0],
              "coordinates are read as float and lose precision: 4 vertex coordinates become equal to a different "
              "value of the file (vertex 1 y = 0.1000000001 reads as 0.10000000149011612, the same float as 0.1); "
              "faces may read as degenerate");
}

// 12: messages say what the file said.
TEST(MeshReaders, MessagesSayWhatTheFileSaid) {
    // The index as written (999, not 998), and its line.
    expect_refused(data_dir / "index_999.obj", "face 1 at line 6 refers to vertex 999, but the file has 3 vertices", 6);
    expect_refused(scratch("negative.obj", "v 0 0 0\nv 1 0 0\nf -1 -2 -3\n"), "refers to vertex -3, but only 2", 3);
    expect_refused(scratch("int64_min.obj", "v 0 0 0\nf 1 -9223372036854775808 1\n"),
                   "refers to vertex -9223372036854775808, but only 1", 2);
    // A header claiming 2e9 vertices in a small file: truncated, at once.
    expect_refused(data_dir / "huge_vertex_count.ply", "truncated file: the header declares 2000000000 vertices");
    // An ASCII STL is an ASCII STL, also when it is broken.
    expect_refused(scratch("nosolid.stl", "facet normal 0 0 1\nouter loop\nvertex 0 0 0\n"),
                   "bad token 'facet' at line 1: expected 'solid' (ASCII STL)", 1);
    expect_refused(scratch("cut.stl", "solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"),
                   "unexpected end of file after line 5: expected 'vertex'", 5);
    const RunResult r = tessref({"check", (scratch_dir() / "nosolid.stl").string()});
    EXPECT_FALSE(contains(r.err, "binary")) << r.err;
}

// A header declaring 2^31 faces, in a file large enough to hold them (sparse: no disk
// used): refused before allocating, with the reason.
TEST(MeshReaders, TwoToThe31FacesAreRefusedBeforeAllocating) {
    const std::string header =
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 2147483648\nproperty list uchar int vertex_indices\nend_header\n";
    const fs::path path = scratch("faces2g.ply", header + std::string(36, '\0'));
    fs::resize_file(path, header.size() + 36 + 13ull * 2147483648ull);
    const auto start = std::chrono::steady_clock::now();
    expect_refused(path, "2147483648 faces: at three corners a face, more face corners than tessref can number");
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
    fs::remove(path);
}

// Counts within the numbering but beyond the memory limit: refused by require_memory.
TEST(MeshReaders, CountsBeyondTheMemoryLimitAreRefused) {
    std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex 100000\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n";
    ply += std::string(100000 * 12, '\0');
    const fs::path path = scratch("many.ply", ply);
    tessref::set_memory_limit(1 << 20);
    const tessref::Error e = read_error(path);
    tessref::set_memory_limit(0);
    EXPECT_TRUE(contains(e.what(), "mesh of 100000 vertices and 0 faces needs")) << e.what();
    EXPECT_TRUE(contains(e.what(), "--max-memory")) << e.what();
}

// A scene's [[mesh]] from an STL file (no normals in the format): OpenMesh's STL reader
// left the requested normal option set, so the loader kept its zero normals; now the
// normals are computed from the faces, as for any file without normals (unit length, and
// at a cube corner the normalized sum of the faces' normals points outward).
TEST(MeshReaders, SceneMeshFromStlGetsComputedNormals) {
    const fs::path stl = scratch("scene_cube.stl", binary_stl_cube());
    // The shipped PN scene with its first mesh (scale 0.25, at x = -0.7) replaced.
    std::string text = read_file(fs::path(TESSREF_SOURCE_DIR) / "data/scenes/pn-triangles.toml");
    const std::string first = "../meshes/icosahedron.off";
    ASSERT_NE(text.find(first), std::string::npos);
    text.replace(text.find(first), first.size(), stl.string());
    const tessref::Scene scene = tessref::load_scene_from_string(
        text, (fs::path(TESSREF_SOURCE_DIR) / "data/scenes/pn-triangles.toml").string());
    ASSERT_TRUE(scene.meshes);
    const tessref::TriangleMeshes& m = *scene.meshes;
    ASSERT_EQ(m.paths.at(0), stl.string());
    for (std::size_t t = 0; t < 12; ++t)  // the STL's 12 facets over its 8 corners come first
        for (std::uint32_t v : m.triangles.at(t)) EXPECT_LT(v, 8u);
    EXPECT_TRUE(m.uvs.empty());
    const glm::dvec3 centre = glm::dvec3(-0.7, 0.0, 0.0) + 0.25 * glm::dvec3(0.5);
    for (std::size_t v = 0; v < 8; ++v) {
        EXPECT_NEAR(glm::length(m.normals[v]), 1.0, 1e-6) << v;
        EXPECT_GT(glm::dot(m.normals[v], m.positions[v] - centre), 0.0) << v;
    }
}

// Not a file: a directory, a FIFO (opening it for reading would wait for a writer
// forever), a device.
TEST(MeshReaders, NonRegularFilesAreRefused) {
    const fs::path fifo = scratch_dir() / "fifo.ply";
    fs::remove(fifo);
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    expect_refused(fifo, "not a regular file");
    fs::create_directories(scratch_dir() / "dir.off");
    expect_refused(scratch_dir() / "dir.off", "is a directory");
    const tessref::Error e = read_error("/dev/null");
    EXPECT_TRUE(contains(e.what(), "unsupported mesh format")) << e.what();
}

// The same through a scene's [[mesh]] and the command: the scene says what the path is (a
// FIFO, a directory), not "no such file", exits 2 and writes nothing; a path that is not
// there is still "no such file".
TEST(MeshReaders, SceneMeshThatIsNotAFileSaysWhatItIs) {
    const fs::path fifo = scratch_dir() / "scene_fifo.ply";
    fs::remove(fifo);
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    const fs::path dir = scratch_dir() / "scene_dir.obj";
    fs::create_directories(dir);
    struct Case {
        fs::path path;
        std::string says;
    };
    for (const Case& c : {Case{fifo, "a FIFO (named pipe)"}, Case{dir, "is a directory"},
                          Case{scratch_dir() / "absent.ply", "no such file"}}) {
        SCOPED_TRACE(c.path.string());
        const fs::path scene = scratch("not_a_file_scene.toml", "[scene]\nname = \"n\"\n[[mesh]]\npath = \"" +
                                                                    c.path.string() +
                                                                    "\"\n[evaluation]\nmodel = \"pn\"\n");
        const fs::path out = scratch_dir() / "not_a_file.ply";
        const RunResult r = tessref({"mesh", scene.string(), "-o", out.string()});
        EXPECT_EQ(r.status, 2) << r.err;
        EXPECT_TRUE(contains(r.err, c.says)) << r.err;
        EXPECT_TRUE(contains(r.err, "mesh[0].path")) << r.err;
        if (c.says != "no such file") EXPECT_FALSE(contains(r.err, "no such file")) << r.err;
        EXPECT_FALSE(fs::exists(out));
    }
}

// ---------------------------------------------------------------------------------------
// What the formats allow

TEST(MeshReaders, PlyBigEndianExtraPropertiesListsAndElements) {
    // x y z as shorts among other properties (a list in the vertex element), an element
    // between vertex and face, the face list named vertex_index with ushort indices and an
    // extra list after it.
    std::string s = "ply\nformat binary_big_endian 1.0\ncomment made by hand\nelement vertex 3\nproperty uchar flag\n"
                    "property short x\nproperty list uchar float junk\nproperty short y\nproperty short z\n"
                    "element edge 1\nproperty int a\nproperty int b\n"
                    "element face 1\nproperty list uint ushort vertex_index\nproperty list uchar double more\nend_header\n";
    const auto i16 = [](int v) {
        const auto x = static_cast<std::int16_t>(v);
        return be(std::string(reinterpret_cast<const char*>(&x), 2));
    };
    const int xyz[3][3] = {{0, 0, 0}, {2, 0, 0}, {0, -3, 7}};
    for (const auto& p : xyz) s += '\1' + i16(p[0]) + '\2' + be(f32(1.5f)) + be(f32(2.5f)) + i16(p[1]) + i16(p[2]);
    s += be(le32(0)) + be(le32(1));
    s += be(le32(3));
    for (int i : {0, 1, 2}) s += i16(i);
    s += '\1' + be(f64(0.25));
    const IndexedMesh mesh = tessref::read_mesh_for_check(scratch("be.ply", s).string());
    ASSERT_EQ(mesh.vertex_count(), 3u);
    EXPECT_EQ(mesh.positions[1], glm::dvec3(2, 0, 0));
    EXPECT_EQ(mesh.positions[2], glm::dvec3(0, -3, 7));
    ASSERT_EQ(mesh.face_count(), 1u);
    EXPECT_EQ(mesh.face_vertices, (std::vector<std::uint32_t>{0, 1, 2}));
    // The same file one byte short is truncated.
    expect_refused(scratch("be_cut.ply", s.substr(0, s.size() - 1)), "truncated file");
}

// Binary vertex records without lists are read whole: each property the mesh takes from
// its offset in the record, in either byte order, whatever the types around it, with and
// without the attributes and provenance asked for.
TEST(MeshReaders, PlyBinaryFixedRecordsOfMixedTypes) {
    for (const bool big : {false, true}) {
        SCOPED_TRACE(big ? "big endian" : "little endian");
        const auto order = [big](std::string bytes) { return big ? be(bytes) : bytes; };
        const auto i16 = [&](int v) {
            const auto x = static_cast<std::int16_t>(v);
            return order(std::string(reinterpret_cast<const char*>(&x), 2));
        };
        std::string s = std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") +
                        " 1.0\nelement vertex 3\nproperty uchar flag\nproperty double x\nproperty float nx\n"
                        "property short y\nproperty float ny\nproperty float nz\nproperty float z\nproperty int patch_id\n"
                        "property float tess_u\nproperty float tess_v\nproperty float tess_w\nproperty float u\n"
                        "property float v\nelement marker 2\nproperty double m\n"
                        "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
        const double xyz[3][3] = {{0.5, 0, 0}, {2, 0, 1.25}, {-1e8 - 8, -3, 7}};
        for (int i = 0; i < 3; ++i) {
            const double* p = xyz[i];
            s += char(i) + order(f64(p[0])) + order(f32(0.0f)) + i16(int(p[1])) + order(f32(0.6f)) + order(f32(0.8f)) +
                 order(f32(float(p[2]))) + order(le32(40u + i)) + order(f32(0.25f * i)) + order(f32(0.5f)) +
                 order(f32(0.125f)) + order(f32(1.0f / (i + 1))) + order(f32(-2.0f));
        }
        s += order(f64(1.0)) + order(f64(2.0));
        s += std::string(1, '\3') + order(le32(0)) + order(le32(1)) + order(le32(2));
        const fs::path path = scratch(big ? "fixed_be.ply" : "fixed_le.ply", s);
        tessref::MeshFileOptions all;
        all.vertex_attributes = true;
        all.provenance = true;
        for (const bool everything : {false, true}) {
            const IndexedMesh mesh = tessref::read_mesh_file(path.string(), everything ? all : tessref::MeshFileOptions{});
            ASSERT_EQ(mesh.vertex_count(), 3u);
            for (int i = 0; i < 3; ++i)
                EXPECT_EQ(mesh.positions[i], glm::dvec3(float(xyz[i][0]), xyz[i][1], xyz[i][2])) << i;
            EXPECT_EQ(mesh.face_vertices, (std::vector<std::uint32_t>{0, 1, 2}));
            if (!everything) {
                EXPECT_TRUE(mesh.normals.empty() && mesh.uvs.empty() && mesh.patch_ids.empty());
                continue;
            }
            ASSERT_EQ(mesh.normals.size(), 3u);
            EXPECT_EQ(mesh.normals[2], glm::vec3(0.0f, 0.6f, 0.8f));
            EXPECT_EQ(mesh.uvs[2], glm::vec2(1.0f / 3, -2.0f));
            EXPECT_EQ(mesh.patch_ids, (std::vector<std::uint32_t>{40, 41, 42}));
            EXPECT_EQ(mesh.tess_coords[2], glm::vec3(0.5f, 0.5f, 0.125f));
        }
        // One byte short: refused before any record is read.
        expect_refused(scratch("fixed_cut.ply", s.substr(0, s.size() - 1)), "truncated file");
    }
}

// A binary PLY as `tessref mesh --binary` lays it out (float x y z among other scalars, then
// only triangles of a one-byte count and int indices) is read with its records in parallel.
// It must read as the same mesh written as ASCII PLY (the serial reading of text), over
// more records than one parallel chunk holds; and a bad value in it is still named with its
// record and byte offset, as the serial reading names it.
TEST(MeshReaders, PlainBinaryPlyReadsAsItsAsciiTwinAndNamesBadRecords) {
    constexpr int n = 150;  // n x n vertices, 2 (n-1)^2 triangles: 22 500 and 44 402
    const std::string properties =
        "property float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
        "property int patch_id\nproperty float tess_u\nproperty float tess_v\nproperty float tess_w\n";
    const int faces = 2 * (n - 1) * (n - 1);
    const std::string counts = "element vertex " + std::to_string(n * n) + "\n" + properties + "element face " +
                               std::to_string(faces) + "\nproperty list uchar int vertex_indices\nend_header\n";
    std::string binary = "ply\nformat binary_little_endian 1.0\n" + counts;
    std::string ascii = "ply\nformat ascii 1.0\n" + counts;
    const std::size_t header = binary.size(), record = 40;
    const auto text = [](float v) {
        char buffer[32];
        std::snprintf(buffer, sizeof buffer, "%.9g ", v);  // 9 digits: the text reads back as this float
        return std::string(buffer);
    };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const float values[3] = {0.1f * i, 0.3f * j, std::sin(0.05f * float(i * j))};
            const float normal[3] = {0.0f, 0.6f, 0.8f}, tess[3] = {i / float(n), j / float(n), 0.25f};
            const std::uint32_t patch = std::uint32_t(j / 10 * 15 + i / 10);
            for (float v : values) binary += f32(v), ascii += text(v);
            for (float v : normal) binary += f32(v), ascii += text(v);
            binary += le32(patch), ascii += std::to_string(patch) + " ";
            for (float v : tess) binary += f32(v), ascii += text(v);
            ascii += "\n";
        }
    ASSERT_EQ(binary.size(), header + record * n * n);
    for (int j = 0; j + 1 < n; ++j)
        for (int i = 0; i + 1 < n; ++i) {
            const int a = j * n + i;
            const std::array<std::array<int, 3>, 2> triangles{{{a, a + 1, a + n + 1}, {a, a + n + 1, a + n}}};
            for (const auto& t : triangles) {
                binary += '\3';
                ascii += "3";
                for (int k = 0; k < 3; ++k) binary += le32(std::uint32_t(t[k])), ascii += " " + std::to_string(t[k]);
                ascii += "\n";
            }
        }
    tessref::MeshFileOptions all;
    all.vertex_attributes = true;
    all.provenance = true;
    const fs::path binary_path = scratch("plain_le.ply", binary);
    const IndexedMesh b = tessref::read_mesh_file(binary_path.string(), all);
    const IndexedMesh a = tessref::read_mesh_file(scratch("plain_ascii.ply", ascii).string(), all);
    ASSERT_EQ(b.vertex_count(), std::size_t(n * n));
    ASSERT_EQ(b.face_count(), std::size_t(faces));
    EXPECT_EQ(b.positions, a.positions);
    EXPECT_EQ(b.normals, a.normals);
    EXPECT_EQ(b.uvs, a.uvs);
    EXPECT_EQ(b.patch_ids, a.patch_ids);
    EXPECT_EQ(b.tess_coords, a.tess_coords);
    EXPECT_EQ(b.face_start, a.face_start);
    EXPECT_EQ(b.face_vertices, a.face_vertices);
    EXPECT_TRUE(b.reader_notes.empty() && a.reader_notes.empty());

    // Bad records near the end, in a later chunk than the first: named as the serial reading
    // names them, by their number and byte offset.
    const auto with = [&](std::size_t at, const std::string& bytes) {
        std::string s = binary;
        s.replace(at, bytes.size(), bytes);
        return s;
    };
    const std::size_t v = n * n - 7, face_offset = header + record * n * n, f = faces - 3;
    expect_refused(scratch("plain_inf.ply", with(header + record * v + 4, f32(INFINITY))),
                   "vertex " + std::to_string(v) + " at byte offset " + std::to_string(header + record * v) +
                       " has a non-finite coordinate (y = inf)");
    const tessref::Error normal = [&] {
        try {
            tessref::read_mesh_file(scratch("plain_nan_normal.ply", with(header + record * v + 16, f32(NAN))).string(), all);
        } catch (const tessref::Error& e) {
            return e;
        }
        return tessref::Error("no error");
    }();
    EXPECT_TRUE(contains(normal.what(), "vertex " + std::to_string(v) + " at byte offset " +
                                            std::to_string(header + record * v) + " has a non-finite normal"))
        << normal.what();
    expect_refused(scratch("plain_patch.ply", with(header + record * v + 24, le32(std::uint32_t(-1)))),
                   "vertex " + std::to_string(v) + " at byte offset " + std::to_string(header + record * v) +
                       " has patch_id -1, not a whole number >= 0");
    expect_refused(scratch("plain_index.ply", with(face_offset + 13 * f + 5, le32(std::uint32_t(n * n)))),
                   "face " + std::to_string(f) + " at byte offset " + std::to_string(face_offset + 13 * f + 5) +
                       " refers to vertex " + std::to_string(n * n) + ", but the file has " + std::to_string(n * n) +
                       " vertices");
    expect_refused(scratch("plain_negative.ply", with(face_offset + 13 * f + 9, le32(std::uint32_t(-2)))),
                   "face " + std::to_string(f) + " at byte offset " + std::to_string(face_offset + 13 * f + 9) +
                       " refers to vertex -2");

    // The check reads the patch ids without the tess coords (MeshFileOptions::tess_coords),
    // and refuses a non-finite tess coord all the same (`tessref check`, in expect_refused),
    // in the parallel reading and in the serial one of the ASCII twin.
    tessref::MeshFileOptions check_reading;
    check_reading.provenance = true;
    check_reading.tess_coords = false;
    for (const fs::path& path : {binary_path, scratch_dir() / "plain_ascii.ply"}) {
        const IndexedMesh m = tessref::read_mesh_file(path.string(), check_reading);
        EXPECT_EQ(m.positions, a.positions);
        EXPECT_EQ(m.patch_ids, a.patch_ids);
        EXPECT_TRUE(m.tess_coords.empty() && m.normals.empty());
    }
    expect_refused(scratch("plain_nan_tess.ply", with(header + record * v + 36, f32(NAN))),
                   "vertex " + std::to_string(v) + " at byte offset " + std::to_string(header + record * v) +
                       " has a non-finite tess coord");
    std::string ascii_nan = ascii;
    const std::size_t line_start = ascii_nan.find("\n", ascii_nan.find("end_header")) + 1;
    const std::size_t line_end = ascii_nan.find("\n", line_start);
    const std::size_t last = ascii_nan.rfind("0.25 ", line_end);
    ASSERT_GT(last, line_start);
    ascii_nan.replace(last, 4, "nan ");
    const int first_line = static_cast<int>(std::count(counts.begin(), counts.end(), '\n')) + 3;  // ply, format, counts
    expect_refused(scratch("plain_nan_tess_ascii.ply", ascii_nan), "vertex 0 at line " + std::to_string(first_line) +
                                                                       " has a non-finite tess coord", first_line);
}

TEST(MeshReaders, ObjCornerFormsNegativeIndicesAndOtherStatements) {
    const IndexedMesh mesh = tessref::read_mesh_for_check(
        scratch("forms.obj", "# comment\nmtllib x.mtl\no thing\nv 0 0 0\nv 1 0 0 1\nv 0 1 0 0.5 0.5 0.5\nvt 0 0\n"
                             "vn 0 0 1\ng part\nusemtl m\ns off\nf 1/1/1 2//1 3/1\nv 1 1 0\nf -3 -1 -2\nl 1 2\n")
            .string());
    ASSERT_EQ(mesh.vertex_count(), 4u);
    ASSERT_EQ(mesh.face_count(), 2u);
    EXPECT_EQ(mesh.face_vertices, (std::vector<std::uint32_t>{0, 1, 2, 1, 3, 2}));
    // The scene loader's attributes: a vertex takes its last corner's normal and uv.
    tessref::MeshFileOptions options;
    options.vertex_attributes = true;
    const IndexedMesh with = tessref::read_mesh_file((scratch_dir() / "forms.obj").string(), options);
    ASSERT_EQ(with.normals.size(), 4u);
    EXPECT_EQ(with.normals[1], glm::vec3(0, 0, 1));
    EXPECT_EQ(with.normals[2], glm::vec3(0, 0, 0));  // its corner has a uv only
    ASSERT_EQ(with.uvs.size(), 4u);
}

TEST(MeshReaders, OffVariantsAndOpenMeshBinaryOff) {
    // STNOFF as `tessref mesh` writes it, ascii and binary: the same mesh.
    const IndexedMesh ascii = tessref::read_mesh_for_check(exported("whole_ascii.off", false).string());
    const IndexedMesh binary = tessref::read_mesh_for_check(exported("whole.off", true).string());
    EXPECT_EQ(ascii.face_vertices, binary.face_vertices);
    EXPECT_EQ(ascii.positions.size(), binary.positions.size());
    // COFF with 3 or 4 colour values, face colours, counts on the keyword line.
    const IndexedMesh coff = tessref::read_mesh_for_check(
        scratch("c.off", "COFF 3 1 0\n0 0 0 255 0 0\n1 0 0 0 1 0 1\n0 1 0 0 0 1 1\n3 0 1 2 0.5 0.5 0.5\n").string());
    EXPECT_EQ(coff.positions[2], glm::dvec3(0, 1, 0));
    expect_refused(scratch("4off.off", "4OFF\n3 1 0\n0 0 0 1\n1 0 0 1\n0 1 0 1\n3 0 1 2\n"), "not supported", 1);
    expect_refused(scratch("nocolour.off", "NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0\n0 1 0 0 0 1\n3 0 1 2\n"),
                   "vertex 1 at line 4 has 3 values, expected x y z nx ny nz", 4);
    expect_refused(scratch("extra.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n"),
                   "unexpected data after the last face", 7);
}

TEST(MeshReaders, StlAsciiSeveralSolidsAndBinary) {
    const IndexedMesh two = tessref::read_mesh_for_check(
        scratch("two.stl",
                "solid a b c\r\n  facet normal -nan -nan -nan\r\n outer loop\r\n vertex 0 0 0\r\n vertex 1 0 0\r\n"
                " vertex 0 1 0\r\n endloop\r\n endfacet\r\nendsolid a\r\nSOLID\nFACET NORMAL 0 0 1\nOUTER LOOP\n"
                "VERTEX 1 0 0\nVERTEX 0 1 0\nVERTEX 1 1 -0\nENDLOOP\nENDFACET\nENDSOLID\n")
            .string());
    EXPECT_EQ(two.vertex_count(), 4u);  // corners equal as floats are one vertex
    EXPECT_EQ(two.face_vertices, (std::vector<std::uint32_t>{0, 1, 2, 1, 2, 3}));
    const IndexedMesh cube = tessref::read_mesh_for_check(scratch("cube.stl", binary_stl_cube()).string());
    EXPECT_EQ(cube.vertex_count(), 8u);
    EXPECT_EQ(cube.face_count(), 12u);
    expect_refused(scratch("short.stl", binary_stl_cube().substr(0, 600)), "truncated or corrupt binary STL");
}

// No byte of a valid file, changed to anything, makes a reader crash, hang or throw
// anything but tessref::Error (run under ASan/UBSan too: TESSREF_SANITIZE).
TEST(MeshReaders, MutatedFilesNeverCrash) {
    std::vector<std::pair<std::string, std::string>> files = {
        {"m.ply", read_file(corpus_dir / "cube.ply")},         {"b.ply", read_file(corpus_dir / "cube_binary.ply")},
        {"m.obj", read_file(corpus_dir / "cube_quads.obj")},   {"m.off", read_file(corpus_dir / "cube.off")},
        {"m.stl", read_file(corpus_dir / "cube.stl")},         {"b.stl", read_file(corpus_dir / "cube_binary.stl")},
        {"b.off", read_file(exported("whole.off", true)).substr(0, 2000)},
        {"d.ply", double_ply_cube(1.0, 1.0)}};
    const char replacements[] = {'\0', '\n', ' ', '#', '-', '9', 'x', '/', '\xff', '\x7f', 'e', '.'};
    std::mt19937 random(12345);
    int read = 0, refused = 0;
    for (const auto& [name, original] : files) {
        const fs::path path = scratch_dir() / ("mutated_" + name);
        for (int trial = 0; trial < 300; ++trial) {
            std::string bytes = original;
            const int changes = 1 + trial % 3;
            for (int c = 0; c < changes; ++c) {
                const std::size_t at = random() % bytes.size();
                if (trial % 5 == 4) bytes[at] = static_cast<char>(random() & 0xff);
                else bytes[at] = replacements[random() % sizeof replacements];
            }
            if (trial % 7 == 6) bytes.resize(random() % bytes.size() + 1);
            write_file(path, bytes);
            try {
                tessref::read_mesh_for_check(path.string());
                ++read;
            } catch (const tessref::Error& e) {
                ++refused;
                EXPECT_EQ(e.where().file, path.string());
            }
        }
    }
    EXPECT_GT(refused, 0);
    EXPECT_GT(read, 0);
}

}  // namespace
