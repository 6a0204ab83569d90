// tessref/golden.h — the CPU reference as the golden output of the GL backend.
//
// golden/<scene>/ holds three files written from the CPU pipeline (golden/README.md):
//   image.png    the CPU reference picture at the golden size (320x200 for the shipped ones);
//   capture.txt  the CPU reference capture (capture.h) at that viewport, as one SHA-256 per
//                patch (with its six levels and triangle count) and one of the whole text;
//   mesh.txt     the SHA-256 of `tessref mesh SCENE --binary -o mesh.ply`.
//
// Verifying a scene gives it one verdict, and a verdict never stops the verification of the
// next scene (`tessref golden verify` prints a complete table whatever happens):
//   PASS      the CPU side still makes the golden files and llvmpipe matches them;
//   CPU-ONLY  as PASS, but the scene is not compared with GL (pom shading, see verify);
//   FAIL      llvmpipe departs from the golden files beyond the tolerances below;
//   STALE     the CPU reference no longer makes the golden files (review, then update);
//   MISSING   a golden file is not there (`golden update` makes it);
//   CORRUPT   a golden file is unreadable, malformed or disagrees with itself (its whole
//             digest matches while a patch line does not, or the other way round);
//   ERROR     the scene or its run failed (a scene that does not load, a crashed GL child).
// The worst verdict of a run decides the exit status: 0 for PASS and CPU-ONLY, 1 for FAIL
// and STALE, 2 for MISSING, CORRUPT and ERROR (tessref's status for bad input).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/capture.h"
#include "tessref/render.h"

namespace tessref::golden {

// ---- tolerances of verify (golden/README.md says why each is what it is) ----------------

// Image: compare.h's rule with a threshold of 2 codes of 8 bits (+ half a code of slack for
// the float rounding of code/255), a position deviation of 1 pixel, no failing pixel.
inline constexpr double kImageThreshold = 2.5 / 255.0;
inline constexpr int kImagePositionDeviation = 1;
inline constexpr std::uint64_t kImageMaxFailingPixels = 0;
// Capture: positions bit-identical, or within 1e-6 (PN's positions near zero, where
// llvmpipe's and the reference's rounding of its cubic differ by far less than that);
// normals within 3 ulps or 1e-6 (normalize and cross, rounded in another order); the levels
// of a patch may differ by at most 1/64 where the control stage calls acos (llvmpipe
// approximates it by a polynomial, the reference rounds the exact value), and then that
// patch's tess coords and the pixels it covers differ too.
inline constexpr std::uint64_t kMaxPositionUlps = 0;
inline constexpr double kMaxPositionAbs = 1e-6;
inline constexpr std::uint64_t kMaxNormalUlps = 3;
inline constexpr double kMaxNormalAbs = 1e-6;
inline constexpr double kMaxLevelDifference = 1.0 / 64.0;

// ---- the digest files --------------------------------------------------------------------

inline constexpr const char* kCaptureHeader = "tessref-golden-capture 1";
inline constexpr const char* kMeshHeader = "tessref-golden-mesh 1";
// A patch's digest keeps the first 16 hex digits of its SHA-256 (64 bits: a changed patch
// goes unnoticed with probability 2^-64; the whole capture's digest is kept in full).
inline constexpr std::size_t kPatchDigits = 16;

// One `patch` line: the patch's six levels as the capture text writes them ("%.9g" each,
// space-separated), its triangles and the first kPatchDigits hex digits of the SHA-256 of
// its lines of the capture text (its `patch` line and its vertices).
struct PatchDigest {
    std::uint32_t patch_id = 0;
    std::string levels;
    std::size_t triangles = 0;
    std::string sha256;
    std::size_t line = 0;  // in capture.txt (0: computed, not read)
};

struct CaptureDigest {
    std::string size;  // "WxH"
    std::size_t triangles = 0;
    std::string sha256;  // of the whole capture text, 64 lower-case hex digits
    std::vector<PatchDigest> patches;  // in the capture's order
};

struct MeshDigest {
    std::size_t vertices = 0;
    std::size_t triangles = 0;
    std::size_t bytes = 0;
    std::string sha256;  // 64 lower-case hex digits
};

// Parse the text of capture.txt / mesh.txt; `path` names the file in errors. A file that is
// not exactly what `update` writes is a tessref::Error naming the file and the line: a
// malformed digest must not read as "the reference changed" (STALE).
//
// capture.txt: the header line; comment lines (#) and blank lines anywhere; exactly one
// `size WxH` (1..16384 each); exactly one `capture patches P triangles T sha256 H`; then
// exactly P lines `patch ID levels L1 .. L6 triangles N sha256 h` (six finite numbers,
// N whole) whose N add up to T.
// mesh.txt: the header line, comments, exactly one
// `mesh vertices V triangles T bytes B sha256 H`.
CaptureDigest parse_capture_digest(std::string_view text, const std::string& path);
MeshDigest parse_mesh_digest(std::string_view text, const std::string& path);

// The digests of capture_text(capture) (capture.h), what a reader of `tessref mesh
// --capture` output can recompute with grep and sha256sum: the SHA-256 of the whole text,
// and per patch its levels as written, its triangles and the SHA-256 of its lines (its
// `patch` line and its vertices; a patch whose vertices come back in a later run of lines
// gets one entry per run). `size` is left empty. The text is never held whole: it is
// made run by run, in parallel, a few MB at a time.
CaptureDigest capture_digest(std::span<const CapturedVertex> capture);

// capture_digest() fed the capture a piece at a time, so that the capture itself need not
// be held (`golden verify` makes it from the pipeline a window at a time): the pieces, one
// after the other, are the capture; a patch's run of vertices may be cut between two.
class CaptureDigester {
public:
    CaptureDigester();
    ~CaptureDigester();
    CaptureDigester(const CaptureDigester&) = delete;
    CaptureDigester& operator=(const CaptureDigester&) = delete;
    void add(std::span<const CapturedVertex> piece);
    CaptureDigest finish();  // once, after the last piece

private:
    struct State;
    std::unique_ptr<State> state_;
};

// ---- where the scenes and golden files are -------------------------------------------------

struct Location {
    std::filesystem::path scenes = "data/scenes";  // SCENE is scenes/SCENE.toml
    std::filesystem::path golden = "golden";       // its files are golden/SCENE/
    std::filesystem::path scene_file(const std::string& name) const { return scenes / (name + ".toml"); }
    // The command that rewrites a scene's golden files, in full (with --golden and --scenes
    // where they are not the defaults), as the files' headers name it.
    std::string update_command(const std::string& name) const;
};

// Throws tessref::Error when `name` cannot name a scene whose golden files verify can read
// back: empty, ".", with a '/', "..", or a control character (a newline would break a
// comment line of capture.txt).
void check_scene_name(const std::string& name);
// Every *.toml stem of location.scenes, sorted (an Error when there is none).
std::vector<std::string> all_scenes(const Location& location);

// ---- update ---------------------------------------------------------------------------------

// The three files of one scene, made from the CPU pipeline at `size`; the caller writes them
// (atomically) to location.golden / name.
struct GoldenFiles {
    RenderResult image;
    std::string capture_txt;
    std::string mesh_txt;
    std::size_t patches = 0;
    std::size_t triangles = 0;       // of the capture
    std::size_t mesh_triangles = 0;  // of the mesh
};
GoldenFiles make_golden_files(const std::string& name, const Location& location, glm::ivec2 size);

// ---- verify ---------------------------------------------------------------------------------

enum class Verdict { pass, cpu_only, fail, stale, missing, corrupt, error };  // best to worst
const char* verdict_name(Verdict v);  // "PASS", "CPU-ONLY", ...
int exit_status(Verdict v);           // 0, 1 or 2 (above)

struct SceneVerdict {
    std::string scene;
    std::size_t triangles = 0;
    std::uint64_t failing_pixels = 0;    // failing under compare.h's rule, not explained (below)
    std::uint64_t explained_pixels = 0;  // failing, on or next to a patch whose levels differ
    double max_error = 0.0;
    std::uint64_t position_ulps = 0;
    std::uint64_t normal_ulps = 0;
    std::size_t level_divergent_patches = 0;  // tess coords differ because the levels do
    std::uint64_t level_ulps = 0;
    double level_difference = 0.0;  // the largest |reference level - GL level| of those patches
    double seconds_gl = 0.0;
    std::string renderer;  // GL_RENDERER of the context that drew the scene; empty: none did
    // False for a scene not compared with GL (only the CPU side was checked).
    bool gl_compared = true;
    // Why the verdict is not PASS, one list per kind: each line says what and where.
    std::vector<std::string> missing;  // golden files that are not there
    std::vector<std::string> corrupt;  // golden files unreadable or disagreeing with themselves
    std::vector<std::string> stale;    // what of the CPU side differs from the golden files
    std::vector<std::string> failures; // why the GL side fails
    std::string error;                 // the run's tessref::Error, when it failed

    Verdict verdict() const;
};

// Verifies each of `names` in order (per scene: step 1, the CPU side, then step 2, llvmpipe
// through the GL backend; golden/README.md) and hands each scene's verdict to `done` as soon
// as it is known. Never throws for a scene's own input: what went wrong is in its verdict.
// `keep` (when not empty): keep each scene's pictures, and for a failing scene the diff
// picture and both captures, under keep/<name>/. The next scene's GL child draws while this
// scene's CPU side is computed, so the scenes take less time together than one after the
// other; a scene's verdict does not depend on the scenes around it.
void verify_scenes(const std::vector<std::string>& names, const Location& location,
                   const std::filesystem::path& keep, const std::function<void(SceneVerdict)>& done);

}  // namespace tessref::golden
