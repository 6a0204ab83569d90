// tessref golden — the CPU reference as the golden output of the GL backend.
//
//   tessref golden update [SCENE...] [--golden DIR] [--scenes DIR] [--size WxH]
//   tessref golden verify [SCENE...] [--golden DIR] [--scenes DIR] [--keep DIR] [--json]
//
// A SCENE is a file stem of --scenes (default data/scenes; "thesis-all-10"); none: every
// *.toml there. golden/<scene>/ holds three files, each naming the command that rewrites
// it (`tessref golden update <scene>`) and how to re-derive it by hand:
//   image.png    `tessref render <scene> --size 320x200`: the CPU reference picture;
//   capture.txt  the CPU reference capture (capture.h) of the pipeline at that viewport,
//                as one SHA-256 per patch (with its levels and triangle count) and one of
//                the whole capture text: a full capture is up to 150 MB a scene, its
//                digest 30 KB, and `verify` recomputes the capture anyway;
//   mesh.txt     the SHA-256 of `tessref mesh <scene> --binary -o mesh.ply`.
//
// verify, per scene: (1) the CPU side again — the capture's per-patch digests, the mesh
// digest and the image (exactly) must equal the golden files, else the scene is STALE (the
// reference changed: review, then `golden update`); (2) the GL backend (gl_backend.h) draws
// the scene at the same size with its capture; its image is compared with image.png by
// compare.h's rule and its capture with the CPU capture by capture.h's, with the
// tolerances of golden/README.md (kGolden* below), and the scene PASSES or FAILS. A table
// (scene, triangles, failing pixels, worst ulps, patches whose levels differ, verdict) on
// stdout; exit 1 when any scene is stale or fails.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <openssl/evp.h>

#include "cli/cli_util.h"
#include "common/input_file.h"
#include "cli/commands.h"
#include "cli/golden_files.h"
#include "tessref/capture.h"
#include "tessref/compare.h"
#include "tessref/error.h"
#include "tessref/gl_render.h"
#include "tessref/limits.h"
#include "tessref/mesh.h"
#include "tessref/prepare.h"
#include "tessref/render.h"
#include "tessref/pipeline.h"

namespace tessref::cli {

namespace {

namespace fs = std::filesystem;

// ---- the tolerances of verify (golden/README.md says why each is what it is) ------------

// Image: the CTS rule (compare.h) with a threshold of 2 codes of 8 bits (+ half a code of
// slack for the float rounding of code/255), a position deviation of 1 pixel, no failing
// pixel.
constexpr double kGoldenThreshold = 2.5 / 255.0;
constexpr int kGoldenPositionDeviation = 1;
constexpr std::uint64_t kGoldenMaxFailingPixels = 0;
// Capture: positions bit-identical, or within 1e-6 (PN's positions near zero, where
// llvmpipe's and the reference's rounding of its cubic differ by far less than that);
// normals within 3 ulps or 1e-6 (normalize and cross, rounded in another order); the levels
// of a patch may differ by at most 1/64 where the control stage calls acos (llvmpipe
// approximates it by a polynomial, the reference rounds the exact value), and then that
// patch's tess coords and the pixels it covers differ too.
constexpr std::uint64_t kGoldenMaxPositionUlps = 0;
constexpr double kGoldenMaxPositionAbs = 1e-6;
constexpr std::uint64_t kGoldenMaxNormalUlps = 3;
constexpr double kGoldenMaxNormalAbs = 1e-6;
constexpr double kGoldenMaxLevelDifference = 1.0 / 64.0;

struct GoldenOptions {
    std::string action;  // update | verify
    std::vector<std::string> scenes;
    std::string golden_dir = "golden";
    std::string scenes_dir = "data/scenes";
    std::string size = "320x200";
    std::string keep;
    bool json = false;
};

std::string sha256_hex(std::string_view bytes) {
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int length = 0;
    if (EVP_Digest(bytes.data(), bytes.size(), digest, &length, EVP_sha256(), nullptr) != 1)
        throw Error("SHA-256 failed (OpenSSL)");
    std::string hex;
    char two[3];
    for (unsigned int i = 0; i < length; ++i) {
        std::snprintf(two, sizeof two, "%02x", digest[i]);
        hex += two;
    }
    return hex;
}

std::string read_text(const fs::path& path) {
    std::error_code ec;
    if (!fs::exists(fs::symlink_status(path, ec)))
        throw Error("cannot read the golden file (run `tessref golden update` to make it)", Where::in_file(path.string()));
    return read_input_file(path.string(), "golden file", kTableFileBytes);
}

// ---- the CPU reference of one scene ----------------------------------------------------

struct PatchDigest {
    std::uint32_t patch_id = 0;
    std::string levels;  // the six levels, %.9g
    std::size_t triangles = 0;
    std::string sha256;
};

struct CpuReference {
    Scene scene;  // the viewport replaced by the golden size
    RenderResult image;
    std::vector<CapturedVertex> capture;
    std::vector<PatchDigest> patches;
    std::string capture_sha256;
    std::size_t triangles = 0;
    std::string mesh_sha256;
    std::size_t mesh_bytes = 0;
    std::size_t mesh_vertices = 0;
    std::size_t mesh_triangles = 0;
};

// Per patch, from the capture text (capture.h): its six levels as the text writes them, its
// triangles, and the SHA-256 of its lines (its `patch` line and its vertices): what a reader
// of `tessref mesh --capture` output can recompute with grep and sha256sum. A patch whose
// vertices come back in a later run of lines gets one entry per run.
std::vector<PatchDigest> patch_digests(const std::string& capture_text) {
    std::vector<PatchDigest> out;
    std::string body;
    std::size_t vertex_lines = 0;
    const auto finish = [&] {
        if (out.empty()) return;
        out.back().triangles = vertex_lines / 3;
        out.back().sha256 = sha256_hex(body).substr(0, kGoldenPatchDigits);
    };
    std::istringstream lines(capture_text);
    for (std::string line; std::getline(lines, line);) {
        if (line.rfind("patch ", 0) == 0) {
            finish();
            PatchDigest p;
            std::istringstream words(line.substr(6));
            words >> p.patch_id;
            const std::size_t levels = line.find(" levels ");
            p.levels = levels == std::string::npos ? std::string() : line.substr(levels + 8);
            out.push_back(p);
            body.clear();
            vertex_lines = 0;
        } else if (out.empty() || line.empty() || line[0] == '#') {
            continue;  // the version and comment lines
        } else {
            ++vertex_lines;
        }
        body += line + "\n";
    }
    finish();
    return out;
}

// `scene` as loaded, with its own viewport.
CpuReference cpu_reference(const Scene& scene, const fs::path& scene_path, glm::ivec2 size) {
    CpuReference ref;
    if (!scene.camera) throw Error("the scene has no [camera]: golden images need one", Where::in_file(scene_path.string()));
    RenderOptions render_options;
    render_options.size = size;
    render_options.keep_surface = true;  // the capture reads the surface
    ref.image = render_scene(scene, render_options);
    ref.scene = scene;
    ref.scene.camera->viewport = size;  // the viewport the pipeline saw (render.h)
    ref.capture = capture_from_pipeline(ref.scene, *ref.image.pipeline);
    const std::string text = capture_text(ref.capture);
    ref.patches = patch_digests(text);
    ref.capture_sha256 = sha256_hex(text);
    ref.triangles = ref.capture.size() / 3;

    // The mesh exactly as `tessref mesh SCENE --binary -o mesh.ply` writes it (the scene's
    // own viewport: mesh has no --size, and PN's levels follow the viewport).
    const PipelineResult pipeline = run_pipeline(scene);
    std::ostringstream mesh_bytes;
    MeshWriteOptions mesh_options;
    mesh_options.format = MeshFormat::ply;
    mesh_options.binary = true;
    const MeshWriteReport stats = write_mesh(pipeline.mesh, mesh_bytes, mesh_options);
    ref.mesh_sha256 = sha256_hex(mesh_bytes.str());
    ref.mesh_bytes = mesh_bytes.str().size();
    ref.mesh_vertices = stats.vertices;
    ref.mesh_triangles = stats.triangles;
    return ref;
}

std::string capture_file_text(const std::string& name, glm::ivec2 size, const CpuReference& ref) {
    std::ostringstream out;
    out << kGoldenCaptureHeader << "\n"
        << "# The CPU reference capture of data/scenes/" << name << ".toml, its viewport replaced by " << size.x << "x"
        << size.y << " (as `tessref render --size` runs the pipeline), as SHA-256 digests.\n"
        << "# Regenerate: tessref golden update " << name << "\n"
        << "# capture: the SHA-256 of the whole capture text (capture.h); each `patch` line: the patch's six\n"
        << "# levels, its triangles and the first 16 hex digits of the SHA-256 of its lines of that text (its\n# `patch` line and its vertices).\n"
        << "size " << size.x << "x" << size.y << "\n"
        << "capture patches " << ref.patches.size() << " triangles " << ref.triangles << " sha256 " << ref.capture_sha256
        << "\n";
    for (const PatchDigest& p : ref.patches)
        out << "patch " << p.patch_id << " levels " << p.levels << " triangles " << p.triangles << " sha256 " << p.sha256
            << "\n";
    return out.str();
}

std::string mesh_file_text(const std::string& name, const CpuReference& ref) {
    std::ostringstream out;
    out << kGoldenMeshHeader << "\n"
        << "# The SHA-256 of the binary PLY that `tessref mesh data/scenes/" << name
        << ".toml --binary -o mesh.ply` writes\n"
        << "# (check by hand: run it, then sha256sum mesh.ply). Regenerate: tessref golden update " << name << "\n"
        << "mesh vertices " << ref.mesh_vertices << " triangles " << ref.mesh_triangles << " bytes " << ref.mesh_bytes
        << " sha256 " << ref.mesh_sha256 << "\n";
    return out.str();
}

// ---- scene list ------------------------------------------------------------------------

std::vector<std::string> scene_names(const GoldenOptions& options) {
    std::vector<std::string> names = options.scenes;
    if (names.empty()) {
        std::error_code ec;
        for (const fs::directory_entry& e : fs::directory_iterator(options.scenes_dir, ec))
            if (e.path().extension() == ".toml") names.push_back(e.path().stem().string());
        if (ec) throw Error("cannot list the scenes: " + ec.message(), Where::in_file(options.scenes_dir));
        std::sort(names.begin(), names.end());
        if (names.empty()) throw Error("no *.toml scene", Where::in_file(options.scenes_dir));
    }
    for (const std::string& n : names) {
        // The name becomes a directory under --golden and is written into the golden files'
        // comment lines: "." (the file "..toml") would be --golden itself, and a control
        // character (a newline) would break a comment line that verify then refuses.
        const bool control = std::any_of(n.begin(), n.end(), [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; });
        if (n.empty() || n == "." || control || n.find('/') != std::string::npos || n.find("..") != std::string::npos)
            throw Error("a scene is named by its file stem in --scenes (e.g. thesis-all-10), not '" + n + "'",
                        Where::in_file(n));
        if (!fs::is_regular_file(fs::path(options.scenes_dir) / (n + ".toml")))
            throw Error("no scene '" + n + "' (" + (fs::path(options.scenes_dir) / (n + ".toml")).string() + ")",
                        Where::in_file(n));
    }
    return names;
}

// ---- update ----------------------------------------------------------------------------

int run_update(const GoldenOptions& options) {
    const glm::ivec2 size = parse_image_size(options.size);
    for (const std::string& name : scene_names(options)) {
        const fs::path scene_path = fs::path(options.scenes_dir) / (name + ".toml");
        const CpuReference ref = cpu_reference(load_scene(scene_path.string()), scene_path, size);
        const fs::path dir = fs::path(options.golden_dir) / name;
        std::error_code ec;
        fs::create_directories(dir, ec);
        if (ec) throw Error("cannot create the directory: " + ec.message(), Where::in_file(dir.string()));
        AtomicOutput image((dir / "image.png").string());
        write_image(ref.image, image.temp_path().string(), ImageFormat::png, {});
        write_output((dir / "capture.txt").string(), capture_file_text(name, size, ref));
        write_output((dir / "mesh.txt").string(), mesh_file_text(name, ref));
        image.commit();
        std::cout << dir.string() << ": image.png " << size.x << "x" << size.y << ", capture.txt "
                  << ref.patches.size() << " patches " << ref.triangles << " triangles, mesh.txt "
                  << ref.mesh_triangles << " triangles\n";
    }
    return 0;
}

// ---- verify ----------------------------------------------------------------------------

struct SceneVerdict {
    std::string scene;
    std::size_t triangles = 0;
    std::vector<std::string> stale;  // what of the CPU side differs from the golden files
    std::uint64_t failing_pixels = 0;   // failing under compare.h's rule, not explained (below)
    std::uint64_t explained_pixels = 0; // failing, on or next to a patch whose levels differ
    double max_error = 0.0;
    std::uint64_t position_ulps = 0;
    std::uint64_t normal_ulps = 0;
    std::size_t level_divergent_patches = 0;  // tess coords differ because the levels do
    std::uint64_t level_ulps = 0;
    double level_difference = 0.0;  // the largest |reference level - GL level| of those patches
    std::vector<std::string> failures;  // why the GL side fails
    double seconds_gl = 0.0;
    // False for a scene whose model has no GLSL twin: only step (1) ran, and the verdict
    // says so instead of claiming a GL comparison (every shipped model has one now).
    bool gl_compared = true;

    std::string verdict() const {
        return !stale.empty() ? "STALE" : !failures.empty() ? "FAIL" : gl_compared ? "PASS" : "CPU-ONLY";
    }
    bool ok() const { return verdict() == "PASS" || verdict() == "CPU-ONLY"; }
};

SceneVerdict verify_scene(const GoldenOptions& options, const std::string& name,
                          const fs::path& keep) {
    SceneVerdict v;
    v.scene = name;
    const fs::path dir = fs::path(options.golden_dir) / name;
    const GoldenCapture golden_capture =
        parse_golden_capture(read_text(dir / "capture.txt"), (dir / "capture.txt").string());
    const glm::ivec2 size = parse_image_size(golden_capture.size, (dir / "capture.txt").string());
    // The size comes from a file: the whole verification's memory at that size is asked for
    // before anything is drawn (limits.h). Held at once: the CPU render, the golden, CPU and
    // GL pictures as floats with their codes (20 bytes a pixel each), the GL colour in the
    // child, on the pipe and in the parent (16 bytes a pixel each), the failing-pixel mask.
    const std::uint64_t pixels = static_cast<std::uint64_t>(size.x) * static_cast<std::uint64_t>(size.y);
    require_memory(estimate_render_memory(size, RenderMode::fill, false, ImageFormat::png, {}) +
                       saturating_bytes(pixels, 3 * 20 + 3 * 16 + 1),
                   "verifying a golden image of " + std::to_string(size.x) + "x" + std::to_string(size.y) + " pixels",
                   Where::in_file((dir / "capture.txt").string()));
    const std::string golden_mesh = parse_golden_mesh(read_text(dir / "mesh.txt"), (dir / "mesh.txt").string()).sha256;
    const FloatImage golden_image = read_float_image((dir / "image.png").string());

    // (1) The CPU reference against its golden files.
    const fs::path scene_path = fs::path(options.scenes_dir) / (name + ".toml");
    const Scene scene = load_scene(scene_path.string());
    const CpuReference ref = cpu_reference(scene, scene_path, size);
    v.triangles = ref.triangles;
    if (ref.capture_sha256 != golden_capture.capture_sha256) {
        std::size_t differing = 0;
        std::uint32_t first = 0;
        for (const PatchDigest& p : ref.patches) {
            auto it = golden_capture.patch_sha256.find(p.patch_id);
            if (it == golden_capture.patch_sha256.end() || it->second != p.sha256) {
                if (differing++ == 0) first = p.patch_id;
            }
        }
        v.stale.push_back("capture: " + std::to_string(differing) + " of " + std::to_string(ref.patches.size()) +
                          " patches differ from capture.txt" +
                          (differing ? " (first: patch " + std::to_string(first) + ")" : " (the patch count)"));
    }
    if (ref.mesh_sha256 != golden_mesh) v.stale.push_back("mesh: the PLY's SHA-256 differs from mesh.txt");
    const fs::path work = keep.empty() ? fs::temp_directory_path() / ("tessref-golden-" + std::to_string(::getpid()))
                                       : keep / name;
    fs::create_directories(work);
    // The pictures go through PNG files, as `compare` reads them; without --keep they are
    // removed however this function leaves (an early return, an exception).
    struct RemoveUnlessKept {
        const fs::path& dir;
        bool keep;
        ~RemoveUnlessKept() {
            std::error_code ec;
            if (!keep) fs::remove_all(dir, ec);
        }
    } remove_unless_kept{work, !keep.empty()};
    write_image(ref.image, (work / "cpu.png").string(), ImageFormat::png, {});
    const FloatImage cpu_image = read_float_image((work / "cpu.png").string());
    if (cpu_image.samples != golden_image.samples) v.stale.push_back("image: the CPU picture differs from image.png");

    // (2) The GL backend against the golden image and the CPU capture.
    // pom shading has a twin (pn-pom and terrain-pom) but its layer search and shadow trace
    // flip on the last bits of llvmpipe's dFdx tangent frame in a few pixels, beyond this
    // step's rule (45 and 44 pixels at 320x200; terrain-pom's capture passes, normals within
    // 2 ulps): tests/test_parallax.cpp holds them with their own counts, and their golden
    // files are checked on the CPU only.
    if (scene.shading.model.kind == ShadingKind::pom) {
        v.gl_compared = false;
        return v;
    }
    gl::SceneRenderOptions gl_options;
    gl_options.size = size;
    gl_options.capture = true;
    if (const char* hook = std::getenv("TESSREF_GL_CORRUPT_BATCH"); hook && *hook)  // as `tessref gl`
        gl_options.corrupt_prediction_of_batch = std::atoll(hook);
    // In a child process with its own limits, as `tessref gl` (gl_backend.h).
    const gl::SceneRender r = gl::render_scene_isolated(scene, gl_options).render;
    v.seconds_gl = r.stats.seconds_gl + r.stats.seconds_capture;
    if (!r.batch_failure.empty()) {
        v.failures.push_back(r.batch_failure);
        return v;
    }
    RenderResult gl_image;
    gl_image.width = r.width;
    gl_image.height = r.height;
    gl_image.colour = r.colour;
    write_image(gl_image, (work / "gl.png").string(), ImageFormat::png, {});
    CompareOptions image_options;
    image_options.threshold = kGoldenThreshold;
    image_options.max_position_deviation = kGoldenPositionDeviation;
    image_options.max_failing_pixels = kGoldenMaxFailingPixels;
    const FloatImage test_image = read_float_image((work / "gl.png").string());
    const CompareResult image = compare_images(golden_image, test_image, image_options);
    v.max_error = image.max_error;

    Capture cpu_capture;
    cpu_capture.vertices = ref.capture;
    Capture gl_capture;
    gl_capture.vertices = r.capture;
    CaptureCompareOptions capture_options;
    capture_options.max_position_ulps = kGoldenMaxPositionUlps;
    capture_options.max_normal_ulps = kGoldenMaxNormalUlps;
    capture_options.max_position_abs = kGoldenMaxPositionAbs;
    capture_options.max_normal_abs = kGoldenMaxNormalAbs;
    capture_options.max_listed = 1000000;
    const CaptureCompareResult c = compare_captures(cpu_capture, gl_capture, capture_options);
    v.position_ulps = c.worst_position.ulps;
    v.normal_ulps = c.worst_normal.ulps;
    // Patches whose levels differ (the control stage's acos, see golden/README.md): their
    // tess coords differ too, and so may the pixels they cover.
    const bool triangles = ref.scene.generator.domain == Domain::triangles;
    std::set<std::uint32_t> level_divergent;
    for (const DivergingPatch& d : c.listed) {
        if (d.kind != PatchDivergence::tess_coords || !d.levels_known || d.level_ulps == 0) continue;
        level_divergent.insert(d.patch_id);
        v.level_ulps = std::max(v.level_ulps, d.level_ulps);
        for (int i = 0; i < (triangles ? 3 : 4); ++i)
            v.level_difference = std::max(
                v.level_difference, std::abs(double(d.reference_levels.outer[i]) - double(d.test_levels.outer[i])));
        for (int i = 0; i < (triangles ? 1 : 2); ++i)
            v.level_difference = std::max(
                v.level_difference, std::abs(double(d.reference_levels.inner[i]) - double(d.test_levels.inner[i])));
    }
    v.level_divergent_patches = level_divergent.size();

    // A failing pixel is explained when the CPU picture shows a level-divergent patch there
    // or next to it (within the position deviation): that patch's surface moved a little.
    // Any other failing pixel fails the scene.
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x) {
            if (!image.failing[static_cast<std::size_t>(y) * image.width + x]) continue;
            bool explained = false;
            for (int dy = -kGoldenPositionDeviation; dy <= kGoldenPositionDeviation && !explained; ++dy)
                for (int dx = -kGoldenPositionDeviation; dx <= kGoldenPositionDeviation && !explained; ++dx) {
                    const int sx = x + dx, sy = y + dy;
                    if (sx < 0 || sy < 0 || sx >= image.width || sy >= image.height) continue;
                    explained = level_divergent.count(ref.image.patch_id[ref.image.index(sx, sy)]) != 0;
                }
            ++(explained ? v.explained_pixels : v.failing_pixels);
        }
    if (v.failing_pixels > kGoldenMaxFailingPixels) {
        write_float_image(difference_picture(golden_image, image), (work / "diff.png").string());
        v.failures.push_back("image: " + std::to_string(v.failing_pixels) + " failing pixels");
    } else if (v.explained_pixels && !keep.empty()) {
        write_float_image(difference_picture(golden_image, image), (work / "diff.png").string());
    }
    if (c.missing_in_test || c.missing_in_reference)
        v.failures.push_back("capture: patches missing on one side");
    if (c.tess_coord_divergences_with_equal_levels)
        v.failures.push_back("capture: " + std::to_string(c.tess_coord_divergences_with_equal_levels) +
                             " patches with equal levels but different tess coords");
    if (c.triangle_divergences) v.failures.push_back("capture: " + std::to_string(c.triangle_divergences) + " patches with other triangles");
    if (c.orientation_divergences)
        v.failures.push_back("capture: " + std::to_string(c.flipped_triangles) + " triangles the other way round in " +
                             std::to_string(c.orientation_divergences) + " patches");
    if (c.value_divergences)
        v.failures.push_back("capture: " + std::to_string(c.failing_vertices) + " vertices beyond " +
                             std::to_string(kGoldenMaxPositionUlps) + " position / " +
                             std::to_string(kGoldenMaxNormalUlps) + " normal ulps");
    if (v.level_difference > kGoldenMaxLevelDifference)
        v.failures.push_back("capture: a level differs by " + std::to_string(v.level_difference) + " (more than " +
                             std::to_string(kGoldenMaxLevelDifference) + ")");
    if (!v.failures.empty() && !keep.empty()) {
        std::ofstream((work / "cpu-capture.txt").string()) << capture_text(ref.capture, "tessref golden (CPU)");
        std::ofstream((work / "gl-capture.txt").string()) << capture_text(r.capture, "tessref golden (GL)");
    }
    return v;
}

int run_verify(const GoldenOptions& options) {
    const std::vector<std::string> names = scene_names(options);
    const fs::path keep = options.keep;
    const std::string renderer = gl::renderer_isolated();
    std::vector<SceneVerdict> verdicts;
    if (!options.json)
        std::cout << "golden verify: " << renderer << " against " << options.golden_dir << "/\n"
                  << std::left << std::setw(20) << "scene" << std::right << std::setw(10) << "triangles"
                  << std::setw(9) << "fail px" << std::setw(8) << "lvl px" << std::setw(9) << "max err" << std::setw(9) << "pos ulp"
                  << std::setw(9) << "nrm ulp" << std::setw(12) << "lvl patches" << std::setw(9) << "lvl ulp" << std::setw(10) << "lvl diff"
                  << std::setw(8) << "GL s" << "  verdict\n";
    for (const std::string& name : names) {
        verdicts.push_back(verify_scene(options, name, keep));
        const SceneVerdict& v = verdicts.back();
        if (options.json) continue;
        char err[32];
        std::snprintf(err, sizeof err, "%.4f", v.max_error);
        char ldiff[32];
        std::snprintf(ldiff, sizeof ldiff, "%.2g", v.level_difference);
        char secs[32];
        std::snprintf(secs, sizeof secs, "%.2f", v.seconds_gl);
        std::cout << std::left << std::setw(20) << v.scene << std::right << std::setw(10) << v.triangles << std::setw(9)
                  << v.failing_pixels << std::setw(8) << v.explained_pixels << std::setw(9) << err << std::setw(9) << v.position_ulps << std::setw(9)
                  << v.normal_ulps << std::setw(12) << v.level_divergent_patches << std::setw(9) << v.level_ulps << std::setw(10) << ldiff
                  << std::setw(8) << secs << "  " << v.verdict() << "\n";
        for (const std::string& s : v.stale) std::cout << "    stale: " << s << "\n";
        for (const std::string& f : v.failures) std::cout << "    fails: " << f << "\n";
    }
    const bool ok = std::all_of(verdicts.begin(), verdicts.end(), [](const SceneVerdict& v) { return v.ok(); });
    if (options.json) {
        nlohmann::json j;
        j["renderer"] = utf8_for_json(renderer);
        j["passed"] = ok;
        const auto texts = [](const std::vector<std::string>& lines) {
            std::vector<std::string> out;
            for (const std::string& line : lines) out.push_back(utf8_for_json(line));
            return out;
        };
        for (const SceneVerdict& v : verdicts)
            j["scenes"].push_back({{"scene", utf8_for_json(v.scene)},
                                   {"triangles", v.triangles},
                                   {"failing_pixels", v.failing_pixels},
                                   {"level_divergent_pixels", v.explained_pixels},
                                   {"max_error", v.max_error},
                                   {"position_ulps", v.position_ulps},
                                   {"normal_ulps", v.normal_ulps},
                                   {"level_divergent_patches", v.level_divergent_patches},
                                   {"level_ulps", v.level_ulps},
                                   {"level_difference", v.level_difference},
                                   {"stale", texts(v.stale)},
                                   {"failures", texts(v.failures)},
                                   {"verdict", v.verdict()}});
        std::cout << j.dump(2) << "\n";
    } else {
        std::cout << (ok ? "every scene passes" : "some scene is stale or fails")
                  << (keep.empty() ? "" : " (pictures and captures kept in " + keep.string() + ")") << "\n";
    }
    return ok ? 0 : 1;
}

}  // namespace

Command add_golden_command(CLI::App& parent) {
    auto options = std::make_shared<GoldenOptions>();
    CLI::App* app = parent.add_subcommand(
        "golden",
        "The CPU reference as golden output: `update` writes golden/<scene>/ (image.png, capture.txt, mesh.txt) "
        "from the CPU pipeline; `verify` checks the CPU side still makes them, then renders every scene through the "
        "GL backend (llvmpipe) and compares its image and capture with them (tolerances: golden/README.md).");
    app->add_option("action", options->action, "update | verify")->required()->check(CLI::IsMember({"update", "verify"}));
    app->add_option("scenes", options->scenes, "Scene names: file stems in --scenes (default: every *.toml there)");
    app->add_option("--golden", options->golden_dir, "The golden directory")->capture_default_str();
    app->add_option("--scenes", options->scenes_dir, "Where the scenes are")->capture_default_str();
    app->add_option("--size", options->size, "update: the image size (the viewport the pipeline sees)")
        ->capture_default_str();
    app->add_option("--keep", options->keep,
                    "verify: keep every scene's CPU and GL pictures (and, for failing scenes, the diff picture and "
                    "both captures) under DIR/<scene>/")
        ->type_name("DIR");
    app->add_flag("--json", options->json, "verify: the table as JSON");
    app->footer("Example: tessref golden verify thesis-all-10 jacksboro --keep out/");
    return Command{app, [options] {
                       if (options->action == "update") return run_update(*options);
                       return run_verify(*options);
                   }};
}

}  // namespace tessref::cli
