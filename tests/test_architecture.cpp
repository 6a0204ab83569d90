// tests/test_architecture.cpp — the layering docs/ARCHITECTURE.md states, read from the
// sources' #include lines.
//
// The contract checked here:
//  - loading a scene only parses: no file of src/scene/ includes the header of a stage that
//    runs after the load (pipeline, render, raster, mesh export, checks, captures, GL); what
//    needs a stage's result is the preparation pass (tessref/prepare.h);
//  - mesh files are read and written in src/mesh/: nothing there includes the checks
//    (tessref/check.h, src/check/), and check.h no longer declares the readers;
//  - the GL backend's header is not a hub: it includes neither the CPU render (render.h),
//    the pipeline (pipeline.h) nor captures (capture.h);
//  - the golden workflow's domain (tolerances, digest files, verifying a scene) is the golden
//    room's (tessref/golden.h, src/golden/), which knows nothing of the command line; the
//    command (src/cli/cmd_golden.cpp) parses flags and prints, and runs no stage itself;
//  - one picture kit: the diagrams (pattern pictures, sweep plots, defect pictures) share
//    src/picture/'s colour, SVG escape and bitmap face; no other file defines its own;
//  - parse_scene() runs no stage: a scene whose camera clearance the pipeline cannot
//    compute parses, keeping its camera and leaving its light map to prepare_scene().
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "tessref/error.h"
#include "tessref/prepare.h"
#include "tessref/scene.h"

namespace fs = std::filesystem;
using namespace tessref;

namespace {

const fs::path kSource = TESSREF_SOURCE_DIR;

// The quoted includes of one file ("tessref/scene.h", "mesh/openmesh.h").
std::vector<std::string> includes_of(const fs::path& file) {
    std::ifstream in(file);
    EXPECT_TRUE(in) << file;
    static const std::regex include(R"re(^\s*#\s*include\s*"([^"]+)")re");
    std::vector<std::string> out;
    std::string line;
    std::smatch m;
    while (std::getline(in, line))
        if (std::regex_search(line, m, include)) out.push_back(m[1]);
    return out;
}

std::vector<fs::path> sources_under(const fs::path& dir) {
    std::vector<fs::path> out;
    for (const auto& e : fs::recursive_directory_iterator(dir))
        if (e.path().extension() == ".cpp" || e.path().extension() == ".h") out.push_back(e.path());
    return out;
}

// Every include of `files` that `forbidden` holds (an entry ending in '/' is a folder).
std::vector<std::string> offending(const std::vector<fs::path>& files, const std::set<std::string>& forbidden) {
    std::vector<std::string> out;
    for (const fs::path& f : files)
        for (const std::string& inc : includes_of(f))
            for (const std::string& bad : forbidden)
                if (inc == bad || (bad.back() == '/' && inc.rfind(bad, 0) == 0))
                    out.push_back(fs::relative(f, kSource).string() + " includes " + inc);
    return out;
}

std::string joined(const std::vector<std::string>& v) {
    std::string s;
    for (const auto& x : v) s += "\n  " + x;
    return s;
}

}  // namespace

TEST(Layers, SceneLoadingIncludesNoLaterStage) {
    const auto bad = offending(sources_under(kSource / "src" / "scene"),
                               {"tessref/pipeline.h", "tessref/render.h", "tessref/raster.h", "tessref/raycast.h",
                                "tessref/check.h", "tessref/capture.h", "tessref/gl_backend.h", "tessref/compare.h",
                                "tessref/solid.h", "tessref/prepare.h", "tessref/golden.h", "pipeline/", "render/",
                                "raster/", "check/", "capture/", "gl/", "golden/", "cli/"});
    EXPECT_TRUE(bad.empty()) << joined(bad);
}

TEST(Layers, MeshFilesDoNotDependOnTheChecks) {
    const auto bad = offending(sources_under(kSource / "src" / "mesh"), {"tessref/check.h", "check/"});
    EXPECT_TRUE(bad.empty()) << joined(bad);
    // The readers' public home is mesh I/O, not the checks.
    std::ifstream check_h(kSource / "include" / "tessref" / "check.h");
    const std::string text((std::istreambuf_iterator<char>(check_h)), std::istreambuf_iterator<char>());
    EXPECT_EQ(text.find("IndexedMesh read_mesh_file("), std::string::npos);
    EXPECT_EQ(text.find("struct IndexedMesh"), std::string::npos);
}

TEST(Layers, GlBackendHeaderIsNoHub) {
    const auto bad = offending({kSource / "include" / "tessref" / "gl_backend.h"},
                               {"tessref/render.h", "tessref/pipeline.h", "tessref/capture.h"});
    EXPECT_TRUE(bad.empty()) << joined(bad);
}

TEST(Layers, GoldenDomainLivesInItsRoomNotInTheCommand) {
    std::vector<fs::path> room = sources_under(kSource / "src" / "golden");
    room.push_back(kSource / "include" / "tessref" / "golden.h");
    EXPECT_GE(room.size(), 3u);
    const auto up = offending(room, {"cli/"});
    EXPECT_TRUE(up.empty()) << joined(up);
    // The command reaches the stages only through the room.
    const auto stages = offending({kSource / "src" / "cli" / "cmd_golden.cpp"},
                                  {"tessref/capture.h", "tessref/compare.h", "tessref/pipeline.h", "tessref/mesh.h",
                                   "tessref/prepare.h", "tessref/limits.h"});
    EXPECT_TRUE(stages.empty()) << joined(stages);
}

// The text of every .h and .cpp under src/ but `except` (a folder), as (relative path, text).
std::vector<std::pair<std::string, std::string>> sources_except(const fs::path& except) {
    std::vector<std::pair<std::string, std::string>> out;
    for (const fs::path& f : sources_under(kSource / "src")) {
        if (f.string().rfind(except.string(), 0) == 0) continue;
        std::ifstream in(f);
        out.emplace_back(fs::relative(f, kSource).string(),
                         std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()));
    }
    return out;
}

TEST(Layers, OnePictureKit) {
    // Definitions, not uses: an escape function, a colour struct, a bitmap glyph table.
    const std::regex own_kit(R"re(std::string\s+xml_escape\s*\(|struct\s+(Color|Colour|Rgb)\s*\{|struct\s+Glyph\s*\{)re");
    std::vector<std::string> bad;
    for (const auto& [path, text] : sources_except(kSource / "src" / "picture"))
        if (std::regex_search(text, own_kit)) bad.push_back(path);
    EXPECT_TRUE(bad.empty()) << "defines its own escape, colour or font instead of src/picture/'s:" << joined(bad);
}

// Every parallel algorithm goes through src/common/parallel.h's wrappers, which ThreadSanitizer
// builds annotate (Debian's libtbb is not instrumented), and every call names them
// `tessref::`: with a TBB range among the arguments an unqualified call also finds TBB's own
// function by argument-dependent lookup and may take it, unannotated (the ray scene's frame
// did, and a TSan run reported a race there).
TEST(Layers, ParallelCallsGoThroughTheAnnotatedWrappers) {
    const std::regex unqualified(R"re((^|[^:\w])parallel_(for|reduce|sort)\s*\(|tbb::parallel_(for|reduce|sort|invoke)\b)re");
    std::vector<std::string> bad;
    for (const auto& [path, text] : sources_except(kSource / "src" / "common" / "parallel.h")) {
        std::smatch m;
        if (std::regex_search(text, m, unqualified)) bad.push_back(path + ": " + m.str());
    }
    EXPECT_TRUE(bad.empty()) << "calls a parallel algorithm other than as tessref::parallel_*:" << joined(bad);
}

// The lab 4 canyon with a camera clearance (and `extra` appended).
std::string clearance_scene(const std::string& extra = "") {
    std::ifstream in(kSource / "data" / "scenes" / "lab4-canyon.toml");
    EXPECT_TRUE(in);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string camera = "[camera]\n";
    text.insert(text.find(camera) + camera.size(), "ground_clearance = 2.0\n");
    return text + extra;
}
const std::string kCanyon = (kSource / "data" / "scenes" / "lab4-canyon.toml").string();

// A budget the grid passes (2048 triangles at least) but the tessellated surface does not:
// only running the pipeline finds that out, and parsing does not run it.
TEST(Preparation, ParsingRunsNoStage) {
    const std::string text = clearance_scene("\n[limits]\nmax_triangles = 4096\n");
    Scene parsed;
    ASSERT_NO_THROW(parsed = parse_scene_from_string(text, kCanyon));
    EXPECT_TRUE(parsed.preparation.ground_clearance);
    EXPECT_FALSE(parsed.preparation.done);
    try {
        load_scene_from_string(text, kCanyon);
        FAIL() << "the clearance's pipeline run exceeds the budget";
    } catch (const Error& e) {
        EXPECT_EQ(e.where().key, "camera.ground_clearance") << e.what();
        EXPECT_NE(std::string(e.what()).find("max_triangles"), std::string::npos) << e.what();
    }
}

// Prepared, the eye is lifted (a shipped camera is not exactly the clearance above the
// surface), the center by as much, the shading's camera uniforms with it; and only once.
TEST(Preparation, LiftsTheCameraOnce) {
    const Scene parsed = parse_scene_from_string(clearance_scene(), kCanyon);
    ASSERT_TRUE(parsed.camera);
    Scene prepared = parsed;
    prepare_scene(prepared);
    EXPECT_TRUE(prepared.preparation.done);
    EXPECT_NE(prepared.camera->eye.y, parsed.camera->eye.y);
    EXPECT_EQ(prepared.camera->eye.x, parsed.camera->eye.x);
    EXPECT_DOUBLE_EQ(prepared.camera->center.y - prepared.camera->eye.y,
                     parsed.camera->center.y - parsed.camera->eye.y);
    EXPECT_EQ(parsed.shading.model.lab4.cameraPosition, glm::vec3(parsed.camera->eye));
    EXPECT_EQ(prepared.shading.model.lab4.cameraPosition, glm::vec3(prepared.camera->eye));
    Scene again = prepared;
    prepare_scene(again);
    EXPECT_EQ(again.camera->eye, prepared.camera->eye);
    EXPECT_EQ(load_scene_from_string(clearance_scene(), kCanyon).camera->eye, prepared.camera->eye);
}

// The geomipmapped terrain's light map is the preparation's, not the parser's.
TEST(Preparation, ComputesTheLightMap) {
    const std::string path = (kSource / "data" / "scenes" / "jacksboro-geomipmap-lit.toml").string();
    const Scene parsed = parse_scene(path);
    EXPECT_EQ(parsed.shading.model.geomip.lightMap, nullptr);
    ASSERT_TRUE(parsed.preparation.light_map);
    const Scene loaded = load_scene(path);
    ASSERT_NE(loaded.shading.model.geomip.lightMap, nullptr);
    const GeomipTerrain terrain = geomip_terrain(loaded);
    EXPECT_EQ(loaded.shading.model.geomip.lightMap->width(), terrain.map.width);
    EXPECT_EQ(loaded.shading.model.geomip.lightMap->height(), terrain.map.height);
}
