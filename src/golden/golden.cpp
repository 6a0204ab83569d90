// src/golden/golden.cpp — making and verifying a scene's golden files (tessref/golden.h).
//
// verify, per scene: (1) the CPU side again — the whole capture's digest, every patch line
// of capture.txt, the mesh digest and the image (exactly) must equal what the CPU pipeline
// makes now, else the scene is STALE (the reference changed: review, then `golden update`);
// a file whose own lines disagree (the whole digest matches the capture while a patch line
// does not, or every patch line matches while the whole digest does not) is CORRUPT, since
// no change of the reference can make that; (2) the GL backend (gl_render.h) draws the scene
// at the same size with its capture; its image is compared with image.png by compare.h's
// rule and its capture with the CPU capture by capture.h's, with the tolerances of
// golden.h, and the scene PASSES or FAILS.
#include "tessref/golden.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <set>
#include <sstream>

#include <malloc.h>
#include <unistd.h>

#include "common/input_file.h"
#include "golden/golden_internal.h"
#include "tessref/capture.h"
#include "tessref/compare.h"
#include "tessref/error.h"
#include "tessref/gl_render.h"
#include "tessref/limits.h"
#include "tessref/mesh.h"
#include "tessref/pipeline.h"
#include "tessref/prepare.h"

namespace tessref::golden {

namespace fs = std::filesystem;

namespace {

// `text` as one shell word: as it is when it has only characters no shell reads, else in
// single quotes.
std::string shell_word(const std::string& text) {
    const bool plain = !text.empty() && std::all_of(text.begin(), text.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || std::string_view("/._-+=:,@").find(c) != std::string_view::npos;
    });
    if (plain) return text;
    std::string out = "'";
    for (const char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return out + "'";
}

bool has_control_character(const std::string& text) {
    return std::any_of(text.begin(), text.end(),
                       [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; });
}

// ---- the CPU reference of one scene ----------------------------------------------------

struct CpuReference {
    Scene scene;  // the viewport replaced by the golden size
    RenderResult image;  // with the pipeline's surface, from which the capture is made
    // The capture, made from image.pipeline a window at a time: at 64 bytes a vertex it is
    // several times the surface it is made from (390 MB for thesis-constant-64).
    std::unique_ptr<PipelineCapture> capture;
    CaptureDigest digest;  // of the capture's text
    MeshDigest mesh;
};

// Triangles made into capture vertices at once, for the digest (about 16 MB of them).
constexpr std::size_t kCaptureWindowTriangles = std::size_t(1) << 16;

// The mesh exactly as `tessref mesh SCENE --binary -o mesh.ply` writes it (the scene's own
// viewport: mesh has no --size, and PN's levels follow the viewport), welded as it does
// (streamed where the scene allows) and hashed as it is written, never held as bytes.
MeshDigest mesh_digest(const Scene& scene) {
    MeshWriteOptions mesh_options;
    mesh_options.format = MeshFormat::ply;
    mesh_options.binary = true;
    Sha256Buffer sha;
    std::ostream out(&sha);
    MeshWriteReport stats;
    if (surface_streams(scene)) {
        const WeldedMesh welded = run_pipeline_welded(scene);
        stats = write_mesh(welded, out, mesh_options);
    } else {
        const PipelineResult pipeline = run_pipeline(scene);
        stats = write_mesh(pipeline.mesh, out, mesh_options);
    }
    out.flush();
    return {stats.vertices, stats.triangles, sha.bytes(), sha.hex()};
}

// `scene` as loaded, with its own viewport. The capture's digest is left to
// digest_capture(), so that `golden verify` can compare the capture with llvmpipe's first.
CpuReference cpu_reference(const Scene& scene, const fs::path& scene_path, glm::ivec2 size) {
    CpuReference ref;
    if (!scene.camera) throw Error("the scene has no [camera]: golden images need one", Where::in_file(scene_path.string()));
    RenderOptions render_options;
    render_options.size = size;
    render_options.keep_surface = true;  // the capture reads the surface
    // The mesh first: its surface is let go before the render's, which the capture is
    // made from, is made.
    ref.mesh = mesh_digest(scene);
    ref.image = render_scene(scene, render_options);
    ref.scene = scene;
    ref.scene.camera->viewport = size;  // the viewport the pipeline saw (render.h)
    ref.capture = std::make_unique<PipelineCapture>(ref.scene, *ref.image.pipeline);
    return ref;
}

// The digests of the capture's text (capture.txt), the capture made a window at a time.
void digest_capture(CpuReference& ref) {
    CaptureDigester digester;
    std::vector<CapturedVertex> window;
    for (std::size_t t = 0; t < ref.capture->triangles(); t += kCaptureWindowTriangles) {
        window.clear();
        ref.capture->append(t, t + kCaptureWindowTriangles, window);
        digester.add(window);
    }
    ref.digest = digester.finish();
}

std::string capture_file_text(const std::string& name, const Location& location, glm::ivec2 size,
                              const CpuReference& ref) {
    std::ostringstream out;
    out << kCaptureHeader << "\n"
        << "# The CPU reference capture of " << location.scene_file(name).string() << ", its viewport replaced by "
        << size.x << "x" << size.y << " (as `tessref render --size` runs the pipeline), as SHA-256 digests.\n"
        << "# Regenerate: " << location.update_command(name) << "\n"
        << "# capture: the SHA-256 of the whole capture text (capture.h); each `patch` line: the patch's six\n"
        << "# levels, its triangles and the first 16 hex digits of the SHA-256 of its lines of that text (its\n# `patch` line and its vertices).\n"
        << "size " << size.x << "x" << size.y << "\n"
        << "capture patches " << ref.digest.patches.size() << " triangles " << ref.digest.triangles << " sha256 "
        << ref.digest.sha256 << "\n";
    for (const PatchDigest& p : ref.digest.patches)
        out << "patch " << p.patch_id << " levels " << p.levels << " triangles " << p.triangles << " sha256 " << p.sha256
            << "\n";
    return out.str();
}

std::string mesh_file_text(const std::string& name, const Location& location, const CpuReference& ref) {
    std::ostringstream out;
    out << kMeshHeader << "\n"
        << "# The SHA-256 of the binary PLY that `tessref mesh " << location.scene_file(name).string()
        << " --binary -o mesh.ply` writes\n"
        << "# (check by hand: run it, then sha256sum mesh.ply). Regenerate: " << location.update_command(name) << "\n"
        << "mesh vertices " << ref.mesh.vertices << " triangles " << ref.mesh.triangles << " bytes " << ref.mesh.bytes
        << " sha256 " << ref.mesh.sha256 << "\n";
    return out.str();
}

std::string read_golden_text(const fs::path& path) {
    return read_input_file(path.string(), "golden file", kTableFileBytes);
}

// ---- step 1: the CPU side against the golden files -------------------------------------

// How many patch lines are listed one by one before "... and N more".
constexpr std::size_t kListedPatches = 8;

// The capture: STALE where the reference changed, CORRUPT where capture.txt disagrees with
// itself.
void check_capture(const CaptureDigest& golden, const CpuReference& ref, const fs::path& file, SceneVerdict& v) {
    const std::string where = file.string();
    const std::vector<PatchDigest>& patches = ref.digest.patches;
    const bool whole_matches = ref.digest.sha256 == golden.sha256;
    // The patch lines, paired in order (a patch that comes back in a later run of lines has
    // one line per run, on both sides).
    std::vector<std::string> differences;
    std::size_t differing = 0;  // pairs that differ
    std::uint32_t first = 0;
    const std::size_t common = std::min(golden.patches.size(), patches.size());
    for (std::size_t i = 0; i < common; ++i) {
        const PatchDigest& g = golden.patches[i];
        const PatchDigest& r = patches[i];
        if (g.patch_id == r.patch_id && g.levels == r.levels && g.triangles == r.triangles && g.sha256 == r.sha256)
            continue;
        if (differing++ == 0) first = r.patch_id;
        if (differences.size() >= kListedPatches) continue;
        std::string d = "patch " + std::to_string(r.patch_id) + " (" + where + ":" + std::to_string(g.line) + "):";
        if (g.patch_id != r.patch_id) {
            d += " the file has patch " + std::to_string(g.patch_id) + " here";
        } else if (g.levels != r.levels) {
            d += " levels " + g.levels + " in the file, " + r.levels + " now";
        } else if (g.triangles != r.triangles) {
            d += " " + std::to_string(g.triangles) + " triangles in the file, " + std::to_string(r.triangles) + " now";
        } else {
            d += " same levels and triangles, other tess coords, positions or normals (digest " + g.sha256 +
                 " in the file, " + r.sha256 + " now)";
        }
        differences.push_back(d);
    }
    const std::size_t unpaired = std::max(golden.patches.size(), patches.size()) - common;
    if (differing == 0 && unpaired) first = (patches.size() > common ? patches : golden.patches)[common].patch_id;
    const std::string count = std::to_string(differing + unpaired) + " of " + std::to_string(patches.size()) + " patches";
    const auto list = [&](std::vector<std::string>& into) {
        for (const std::string& d : differences) into.push_back("  " + d);
        if (differing > differences.size())
            into.push_back("  ... and " + std::to_string(differing - differences.size()) + " more");
        if (unpaired)
            into.push_back("  the file lists " + std::to_string(golden.patches.size()) + " patch lines, the capture has " +
                           std::to_string(patches.size()));
    };
    if (whole_matches && differing + unpaired == 0) return;
    if (whole_matches) {
        // The capture is the one the file's digest names, so its patch lines are wrong.
        v.corrupt.push_back(where + " disagrees with itself: its capture SHA-256 matches the reference capture, but " +
                            count + " of its patch lines do not (edited by hand?)");
        list(v.corrupt);
    } else if (differing + unpaired == 0) {
        v.corrupt.push_back(where + " disagrees with itself: all " + std::to_string(patches.size()) +
                            " patch lines match the reference capture, but its capture SHA-256 (" +
                            golden.sha256.substr(0, 16) + "...) is not the capture's (" +
                            ref.digest.sha256.substr(0, 16) +
                            "...): the `capture` line was edited, or the capture text's header lines changed");
    } else {
        v.stale.push_back("capture: " + count + " differ from capture.txt (first: patch " + std::to_string(first) + ")");
        list(v.stale);
    }
}

void check_mesh(const MeshDigest& golden, const MeshDigest& now, const fs::path& file, SceneVerdict& v) {
    const auto counts = [](const MeshDigest& m) {
        return std::to_string(m.vertices) + " vertices, " + std::to_string(m.triangles) + " triangles, " +
               std::to_string(m.bytes) + " bytes";
    };
    const bool same_counts = golden.vertices == now.vertices && golden.triangles == now.triangles && golden.bytes == now.bytes;
    if (golden.sha256 == now.sha256 && !same_counts)
        v.corrupt.push_back(file.string() + " disagrees with itself: its SHA-256 is the mesh's, but it counts " +
                            counts(golden) + " where the mesh has " + counts(now));
    else if (golden.sha256 != now.sha256)
        v.stale.push_back("mesh: the PLY's SHA-256 differs from mesh.txt (" +
                          (same_counts ? "same counts: " + counts(now) : counts(golden) + " in the file, " + counts(now) + " now") +
                          ")");
}

// ---- step 2: llvmpipe against the golden files -------------------------------------------

// llvmpipe's capture against the CPU reference's, patch by patch as the GL child sends it
// (a draw's vertices at a time), the CPU side's patch made from the pipeline when its
// turn comes: neither capture is held whole. The result is compare_captures()'s on the
// two whole captures, provided llvmpipe's brings each patch's triangles together, in
// ascending patch order, as its draws (consecutive patches each) and transform feedback
// (primitives in the order they are generated) give them; a capture that does not is an
// Error here.
class StreamedGlComparison {
public:
    StreamedGlComparison(const PipelineCapture& cpu, const CaptureCompareOptions& options,
                         std::vector<CapturedVertex>* keep_gl)
        : cpu_(cpu), compare_(options), keep_gl_(keep_gl) {
        for (const PipelineCapture::Run& r : cpu.runs()) cpu_patches_.push_back(r);
        std::stable_sort(cpu_patches_.begin(), cpu_patches_.end(),
                         [](const PipelineCapture::Run& a, const PipelineCapture::Run& b) { return a.patch < b.patch; });
    }

    void add(std::span<const CapturedVertex> gl) {
        gl_vertices_ += gl.size();
        if (keep_gl_) keep_gl_->insert(keep_gl_->end(), gl.begin(), gl.end());
        pending_.insert(pending_.end(), gl.begin(), gl.end());
        // Every patch that a later one follows is complete; the last may go on.
        const std::size_t triangles = pending_.size() / 3;
        std::size_t last_start = 0;
        for (std::size_t t = 1; t < triangles; ++t)
            if (pending_[3 * t].patch_id != pending_[3 * t - 3].patch_id) last_start = t;
        if (last_start == 0) return;
        compare_gl_patches(std::span<const CapturedVertex>(pending_).first(3 * last_start));
        pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(3 * last_start));
    }

    CaptureCompareResult finish() {
        if (gl_vertices_ % 3 != 0)
            throw Error("the test capture has " + std::to_string(gl_vertices_) + " vertices, not whole triangles");
        compare_gl_patches(pending_);
        pending_.clear();
        // The CPU's patches that llvmpipe did not capture.
        flush_cpu_before(UINT32_MAX, true);
        return compare_.finish();
    }

private:
    // The CPU's patches below `patch` not compared yet, each against nothing (missing in
    // the test), into pairs_; with `inclusive`, `patch` too.
    void flush_cpu_before(std::uint32_t patch, bool inclusive) {
        while (next_cpu_ < cpu_patches_.size() &&
               (cpu_patches_[next_cpu_].patch < patch || (inclusive && cpu_patches_[next_cpu_].patch == patch))) {
            add_pair(cpu_patches_[next_cpu_].patch, {});
        }
        compare_pairs();
    }

    // The CPU's triangles of `patch` (all its runs, in capture order) against `gl`; moves
    // next_cpu_ past the patch's runs.
    void add_pair(std::uint32_t patch, std::span<const CapturedVertex> gl) {
        std::vector<CapturedVertex>& cpu = cpu_vertices_.emplace_back();
        while (next_cpu_ < cpu_patches_.size() && cpu_patches_[next_cpu_].patch == patch) {
            cpu_.append(cpu_patches_[next_cpu_].first, cpu_patches_[next_cpu_].last, cpu);
            ++next_cpu_;
        }
        StreamedCaptureComparison::PatchPair pair;
        pair.patch = patch;
        pair.test = gl;
        pairs_.push_back(pair);
    }

    void compare_pairs() {
        for (std::size_t k = 0; k < pairs_.size(); ++k) pairs_[k].reference = cpu_vertices_[k];
        compare_.add(pairs_);
        pairs_.clear();
        cpu_vertices_.clear();
    }

    // Whole patches of llvmpipe's capture, each once, in ascending order.
    void compare_gl_patches(std::span<const CapturedVertex> gl) {
        const std::size_t triangles = gl.size() / 3;
        for (std::size_t first = 0; first < triangles;) {
            const std::uint32_t patch = gl[3 * first].patch_id;
            std::size_t last = first + 1;
            while (last < triangles && gl[3 * last].patch_id == patch) ++last;
            if (any_gl_ && patch <= last_gl_patch_)
                throw Error("llvmpipe's capture gives patch " + std::to_string(patch) + " after patch " +
                                std::to_string(last_gl_patch_) +
                                ", where its draws and transform feedback give the patches in order",
                            Where::at_patch(patch));
            any_gl_ = true;
            last_gl_patch_ = patch;
            // The CPU's patches before this one are missing in llvmpipe's capture.
            while (next_cpu_ < cpu_patches_.size() && cpu_patches_[next_cpu_].patch < patch)
                add_pair(cpu_patches_[next_cpu_].patch, {});
            add_pair(patch, gl.subspan(3 * first, 3 * (last - first)));
            first = last;
        }
        compare_pairs();
    }

    const PipelineCapture& cpu_;
    std::vector<PipelineCapture::Run> cpu_patches_;  // by patch, each patch's runs in capture order
    std::size_t next_cpu_ = 0;
    StreamedCaptureComparison compare_;
    std::vector<CapturedVertex>* keep_gl_;
    std::vector<CapturedVertex> pending_;  // llvmpipe's vertices of a patch that may go on
    std::size_t gl_vertices_ = 0;
    bool any_gl_ = false;
    std::uint32_t last_gl_patch_ = 0;
    std::vector<StreamedCaptureComparison::PatchPair> pairs_;
    std::vector<std::vector<CapturedVertex>> cpu_vertices_;  // the reference side of pairs_
};

// One scene on its way through verify: prepare_scene() reads its golden files, loads it and
// starts llvmpipe's child; complete_scene() computes the CPU side while that child draws,
// compares, and gives the verdict. `golden verify` prepares the next scene before it
// completes this one (verify_scenes()). Never moved once prepared: the GL options'
// functions point at it.
struct PreparedScene {
    SceneVerdict v;
    bool ready = false;  // the golden files read and the scene loaded: complete_scene() has work
    fs::path keep;
    fs::path capture_file, mesh_file, scene_path;
    fs::path work;  // the pictures' directory, made by complete_scene()
    CaptureDigest golden_capture;
    MeshDigest golden_mesh;
    FloatImage golden_image;
    glm::ivec2 size{};
    Scene scene;
    std::optional<gl::PendingRender> gl;  // unset: the scene is checked on the CPU only
    // Step 1's results, made while llvmpipe draws.
    CpuReference ref;
    bool image_differs = false;
    // Step 2's comparison, fed as llvmpipe's capture arrives.
    std::optional<StreamedGlComparison> streamed;
    std::vector<CapturedVertex> gl_capture;  // with --keep only, for a failing scene's files

    // (1) The CPU reference against its golden files: the pipeline, the image and the mesh
    // while llvmpipe draws (cpu_side), the capture's digests after llvmpipe's capture has
    // been compared with it (cpu_digests), when the surface it is made from is all that
    // is left to hold.
    void cpu_side() {
        ref = cpu_reference(scene, scene_path, size);
        write_image(ref.image, (work / "cpu.png").string(), ImageFormat::png, {});
        const FloatImage cpu_image = read_float_image((work / "cpu.png").string());
        image_differs = cpu_image.samples != golden_image.samples;
    }
    void cpu_digests() {
        digest_capture(ref);
        v.triangles = ref.digest.triangles;
        check_capture(golden_capture, ref, capture_file, v);
        check_mesh(golden_mesh, ref.mesh, mesh_file, v);
        if (image_differs) v.stale.push_back("image: the CPU picture differs from image.png");
    }
};

CaptureCompareOptions capture_compare_options() {
    CaptureCompareOptions capture_options;
    capture_options.max_position_ulps = kMaxPositionUlps;
    capture_options.max_normal_ulps = kMaxNormalUlps;
    capture_options.max_position_abs = kMaxPositionAbs;
    capture_options.max_normal_abs = kMaxNormalAbs;
    capture_options.max_listed = 1000000;
    return capture_options;
}

// (2) Starts the GL backend on the scene: its child draws it at the golden size with its
// capture, from now on; the CPU side runs when complete_scene() finishes the render.
void start_gl(PreparedScene& p) {
    gl::SceneRenderOptions gl_options;
    gl_options.size = p.size;
    gl_options.capture = true;
    gl_options.meanwhile = [&p] { p.cpu_side(); };
    gl_options.return_pipeline = false;  // the CPU side has its own, in exact math
    gl_options.capture_sink = [&p](std::span<const CapturedVertex> draw) {
        if (!p.streamed)  // after cpu_side, which made the CPU capture
            p.streamed.emplace(*p.ref.capture, capture_compare_options(), p.keep.empty() ? nullptr : &p.gl_capture);
        p.streamed->add(draw);
    };
    if (const char* hook = std::getenv("TESSREF_GL_CORRUPT_BATCH"); hook && *hook)  // as `tessref gl`
        gl_options.corrupt_prediction_of_batch = std::atoll(hook);
    // In a child process with its own limits, as `tessref gl` (gl_render.h).
    p.gl = gl::start_render_scene_isolated(p.scene, gl_options);
}

// The GL side against the golden files, with the CPU side (which makes `ref`) run while
// llvmpipe draws: the two sides share nothing until the comparison, which takes llvmpipe's
// capture draw by draw as the child sends it; the digests run when the child is done.
void compare_with_gl(PreparedScene& p) {
    SceneVerdict& v = p.v;
    const CpuReference& ref = p.ref;
    const FloatImage& golden_image = p.golden_image;
    const fs::path& work = p.work;
    const bool keep = !p.keep.empty();
    std::optional<StreamedGlComparison>& streamed = p.streamed;
    const std::vector<CapturedVertex>& gl_capture = p.gl_capture;
    gl::IsolatedRender isolated = p.gl->finish();
    p.gl.reset();
    gl::SceneRender& r = isolated.render;
    v.renderer = isolated.renderer;
    v.seconds_gl = r.stats.seconds_gl + r.stats.seconds_capture;
    p.cpu_digests();
    if (!r.batch_failure.empty()) {
        v.failures.push_back(r.batch_failure);
        return;
    }
    RenderResult gl_image;
    gl_image.width = r.width;
    gl_image.height = r.height;
    gl_image.colour = std::move(r.colour);
    write_image(gl_image, (work / "gl.png").string(), ImageFormat::png, {});
    CompareOptions image_options;
    image_options.threshold = kImageThreshold;
    image_options.max_position_deviation = kImagePositionDeviation;
    image_options.max_failing_pixels = kImageMaxFailingPixels;
    const FloatImage test_image = read_float_image((work / "gl.png").string());
    const CompareResult image = compare_images(golden_image, test_image, image_options);
    v.max_error = image.max_error;

    if (!streamed) streamed.emplace(*ref.capture, capture_compare_options(), nullptr);  // llvmpipe captured nothing
    const CaptureCompareResult c = streamed->finish();
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
            for (int dy = -kImagePositionDeviation; dy <= kImagePositionDeviation && !explained; ++dy)
                for (int dx = -kImagePositionDeviation; dx <= kImagePositionDeviation && !explained; ++dx) {
                    const int sx = x + dx, sy = y + dy;
                    if (sx < 0 || sy < 0 || sx >= image.width || sy >= image.height) continue;
                    explained = level_divergent.count(ref.image.patch_id[ref.image.index(sx, sy)]) != 0;
                }
            ++(explained ? v.explained_pixels : v.failing_pixels);
        }
    if (v.failing_pixels > kImageMaxFailingPixels) {
        write_float_image(difference_picture(golden_image, test_image, image).image, (work / "diff.png").string());
        v.failures.push_back("image: " + std::to_string(v.failing_pixels) + " failing pixels");
    } else if (v.explained_pixels && keep) {
        write_float_image(difference_picture(golden_image, test_image, image).image, (work / "diff.png").string());
    }
    if (c.missing_in_test || c.missing_in_reference) v.failures.push_back("capture: patches missing on one side");
    if (c.tess_coord_divergences_with_equal_levels)
        v.failures.push_back("capture: " + std::to_string(c.tess_coord_divergences_with_equal_levels) +
                             " patches with equal levels but different tess coords");
    if (c.triangle_divergences)
        v.failures.push_back("capture: " + std::to_string(c.triangle_divergences) + " patches with other triangles");
    if (c.orientation_divergences)
        v.failures.push_back("capture: " + std::to_string(c.flipped_triangles) + " triangles the other way round in " +
                             std::to_string(c.orientation_divergences) + " patches");
    if (c.value_divergences)
        v.failures.push_back("capture: " + std::to_string(c.failing_vertices) + " vertices beyond " +
                             std::to_string(kMaxPositionUlps) + " position / " + std::to_string(kMaxNormalUlps) +
                             " normal ulps");
    if (v.level_difference > kMaxLevelDifference)
        v.failures.push_back("capture: a level differs by " + std::to_string(v.level_difference) + " (more than " +
                             std::to_string(kMaxLevelDifference) + ")");
    if (!v.failures.empty() && keep) {
        std::ofstream((work / "cpu-capture.txt").string())
            << capture_text(capture_from_pipeline(ref.scene, *ref.image.pipeline), "tessref golden (CPU)");
        std::ofstream((work / "gl-capture.txt").string()) << capture_text(gl_capture, "tessref golden (GL)");
    }
}

// Reads the scene's golden files, loads it and starts llvmpipe on it. Never throws for the
// scene's own input: a golden file that is not there is MISSING, one that cannot be read
// CORRUPT, anything else the scene's ERROR, in the verdict (then `ready` stays false).
std::unique_ptr<PreparedScene> prepare_scene(const std::string& name, const Location& location, const fs::path& keep) {
    auto prepared = std::make_unique<PreparedScene>();
    PreparedScene& p = *prepared;
    SceneVerdict& v = p.v;
    v.scene = name;
    p.keep = keep;
    try {
        check_scene_name(name);
        p.scene_path = location.scene_file(name);
        if (!fs::is_regular_file(p.scene_path))
            throw Error("no scene '" + name + "' (" + p.scene_path.string() + ")", Where::in_file(name));
        const fs::path dir = location.golden / name;
        for (const char* file : {"image.png", "capture.txt", "mesh.txt"}) {
            const fs::path path = dir / file;
            std::error_code ec;
            if (!fs::exists(fs::symlink_status(path, ec)))
                v.missing.push_back(path.string() + " is not there (run `" + location.update_command(name) +
                                    "` to make it)");
        }
        if (!v.missing.empty()) {
            // The files that are there are still read: one that cannot be (a FIFO, a
            // directory) is named too.
            for (const char* file : {"capture.txt", "mesh.txt"}) {
                const fs::path path = dir / file;
                std::error_code ec;
                if (!fs::exists(fs::symlink_status(path, ec))) continue;
                try {
                    (void)read_golden_text(path);
                } catch (const Error& e) {
                    v.corrupt.push_back(e.message());
                }
            }
            return prepared;
        }
        p.capture_file = dir / "capture.txt";
        p.mesh_file = dir / "mesh.txt";
        const fs::path image_file = dir / "image.png";
        try {
            p.golden_capture = parse_capture_digest(read_golden_text(p.capture_file), p.capture_file.string());
            p.size = parse_size(p.golden_capture.size, Where::in_file(p.capture_file.string()));
            // The size comes from a file: the whole verification's memory at that size is
            // asked for before anything is drawn (limits.h). Held at once: the CPU render,
            // the golden, CPU and GL pictures as floats with their codes (20 bytes a pixel
            // each), the GL colour in the child, on the pipe and in the parent (16 bytes a
            // pixel each), the failing-pixel mask.
            const std::uint64_t pixels = static_cast<std::uint64_t>(p.size.x) * static_cast<std::uint64_t>(p.size.y);
            require_memory(estimate_render_memory(p.size, RenderMode::fill, false, ImageFormat::png, {}) +
                               saturating_bytes(pixels, 3 * 20 + 3 * 16 + 1),
                           "verifying a golden image of " + std::to_string(p.size.x) + "x" + std::to_string(p.size.y) +
                               " pixels",
                           Where::in_file(p.capture_file.string()));
            p.golden_mesh = parse_mesh_digest(read_golden_text(p.mesh_file), p.mesh_file.string());
            p.golden_image = read_float_image(image_file.string());
            if (p.golden_image.width != p.size.x || p.golden_image.height != p.size.y)
                throw Error("image.png is " + std::to_string(p.golden_image.width) + "x" +
                                std::to_string(p.golden_image.height) + " but capture.txt says " + p.golden_capture.size,
                            Where::in_file(image_file.string()));
        } catch (const Error& e) {
            v.corrupt.push_back(e.message());
            return prepared;
        }
        p.scene = load_scene(p.scene_path.string());
        p.ready = true;
        // pom shading has a twin (pn-pom and terrain-pom) but its layer search and shadow
        // trace flip on the last bits of llvmpipe's dFdx tangent frame in a few pixels,
        // beyond this step's rule (45 and 44 pixels at 320x200; terrain-pom's capture
        // passes, normals within 2 ulps): tests/test_parallax.cpp holds them with their own
        // counts, and their golden files are checked on the CPU only.
        if (p.scene.shading.model.kind != ShadingKind::pom) start_gl(p);
    } catch (const Error& e) {
        v.error = e.message();
        p.ready = false;
    } catch (const std::exception& e) {  // memory
        v.error = e.what();
        p.ready = false;
    }
    return prepared;
}

// Steps 1 and 2 of a prepared scene; its verdict.
SceneVerdict complete_scene(PreparedScene& p) {
    SceneVerdict& v = p.v;
    if (!p.ready) return std::move(v);
    try {
        p.work = p.keep.empty() ? fs::temp_directory_path() / ("tessref-golden-" + std::to_string(::getpid()))
                                : p.keep / v.scene;
        fs::create_directories(p.work);
        // The pictures go through PNG files, as `compare` reads them; without --keep they are
        // removed however this function leaves (an early return, an exception).
        struct RemoveUnlessKept {
            const fs::path& dir;
            bool keep;
            ~RemoveUnlessKept() {
                std::error_code ec;
                if (!keep) fs::remove_all(dir, ec);
            }
        } remove_unless_kept{p.work, !p.keep.empty()};
        if (!p.gl) {
            p.cpu_side();
            p.cpu_digests();
            v.gl_compared = false;
        } else {
            compare_with_gl(p);
        }
    } catch (const Error& e) {
        v.error = e.message();
    } catch (const std::exception& e) {  // a file system error of --keep, memory
        v.error = e.what();
    }
    return std::move(v);
}

}  // namespace

// ---- Location, scene names ---------------------------------------------------------------

std::string Location::update_command(const std::string& name) const {
    std::string command = "tessref golden update " + shell_word(name);
    if (golden != fs::path("golden")) command += " --golden " + shell_word(golden.string());
    if (scenes != fs::path("data/scenes")) command += " --scenes " + shell_word(scenes.string());
    return command;
}

void check_scene_name(const std::string& name) {
    // The name becomes a directory under --golden and is written into the golden files'
    // comment lines: "." (the file "..toml") would be --golden itself, and a control
    // character (a newline) would break a comment line that verify then refuses.
    if (name.empty() || name == "." || has_control_character(name) || name.find('/') != std::string::npos ||
        name.find("..") != std::string::npos)
        throw Error("a scene is named by its file stem in --scenes (e.g. thesis-all-10), not '" + name + "'",
                    Where::in_file(name));
}

std::vector<std::string> all_scenes(const Location& location) {
    std::vector<std::string> names;
    std::error_code ec;
    for (const fs::directory_entry& e : fs::directory_iterator(location.scenes, ec))
        if (e.path().extension() == ".toml") names.push_back(e.path().stem().string());
    if (ec) throw Error("cannot list the scenes: " + ec.message(), Where::in_file(location.scenes.string()));
    std::sort(names.begin(), names.end());
    if (names.empty()) throw Error("no *.toml scene", Where::in_file(location.scenes.string()));
    return names;
}

// ---- update --------------------------------------------------------------------------------

GoldenFiles make_golden_files(const std::string& name, const Location& location, glm::ivec2 size) {
    check_scene_name(name);
    // The directories are written into the files' comment lines, as the name is.
    for (const fs::path& dir : {location.golden, location.scenes})
        if (has_control_character(dir.string()))
            throw Error("a control character in a directory name would break the golden files' comment lines",
                        Where::in_file(dir.string()));
    const fs::path scene_path = location.scene_file(name);
    if (!fs::is_regular_file(scene_path))
        throw Error("no scene '" + name + "' (" + scene_path.string() + ")", Where::in_file(name));
    CpuReference ref = cpu_reference(load_scene(scene_path.string()), scene_path, size);
    digest_capture(ref);
    GoldenFiles files;
    files.capture_txt = capture_file_text(name, location, size, ref);
    files.mesh_txt = mesh_file_text(name, location, ref);
    files.patches = ref.digest.patches.size();
    files.triangles = ref.digest.triangles;
    files.mesh_triangles = ref.mesh.triangles;
    files.image = std::move(ref.image);
    return files;
}

// ---- verify --------------------------------------------------------------------------------

const char* verdict_name(Verdict v) {
    switch (v) {
        case Verdict::pass: return "PASS";
        case Verdict::cpu_only: return "CPU-ONLY";
        case Verdict::fail: return "FAIL";
        case Verdict::stale: return "STALE";
        case Verdict::missing: return "MISSING";
        case Verdict::corrupt: return "CORRUPT";
        case Verdict::error: return "ERROR";
    }
    return "ERROR";
}

int exit_status(Verdict v) {
    switch (v) {
        case Verdict::pass:
        case Verdict::cpu_only: return 0;
        case Verdict::fail:
        case Verdict::stale: return 1;
        default: return 2;
    }
}

Verdict SceneVerdict::verdict() const {
    if (!error.empty()) return Verdict::error;
    if (!corrupt.empty()) return Verdict::corrupt;
    if (!missing.empty()) return Verdict::missing;
    if (!stale.empty()) return Verdict::stale;
    if (!failures.empty()) return Verdict::fail;
    return gl_compared ? Verdict::pass : Verdict::cpu_only;
}

void verify_scenes(const std::vector<std::string>& names, const Location& location, const fs::path& keep,
                   const std::function<void(SceneVerdict)>& done) {
    // The next scene's llvmpipe child starts before this scene's CPU side: llvmpipe compiles
    // the shaders and tessellates on one thread, so a scene alone keeps one of two cores
    // busy most of its time; two scenes at once keep both. Each child is forked between the
    // scenes' parallel work, never during it (isolated.h).
    std::unique_ptr<PreparedScene> next = names.empty() ? nullptr : prepare_scene(names[0], location, keep);
    for (std::size_t i = 0; i < names.size(); ++i) {
        const std::unique_ptr<PreparedScene> now = std::move(next);
        if (i + 1 < names.size()) next = prepare_scene(names[i + 1], location, keep);
        SceneVerdict v = complete_scene(*now);
        // What this scene freed goes back to the system before the scene after next has its
        // GL child forked: the child's resident size counts every page the parent still holds.
        ::malloc_trim(0);
        done(std::move(v));
    }
}

}  // namespace tessref::golden
