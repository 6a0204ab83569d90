// tessref golden: update writes golden/<scene>/ from the CPU reference; verify fails when the
// CPU side no longer makes those files (STALE) or when llvmpipe departs from them (FAIL).
// Every test works on a golden directory of its own, made from one small scene.
#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <span>
#include <string_view>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include "command_dir_test.h"
#include "common/isolated.h"
#include "golden/golden_internal.h"
#include "tessref/capture.h"
#include "tessref/golden.h"

namespace fs = std::filesystem;
using tessref::test::read_file;
using tessref::test::write_file;

namespace {

const std::string kScenes = std::string(TESSREF_SOURCE_DIR) + "/data/scenes";

class GoldenCommand : public tessref::test::CommandDirTest {
protected:
    tessref::test::RunResult golden(const std::string& action, const std::string& scene) {
        return run({"golden", action, scene, "--golden", path("golden"), "--scenes", kScenes});
    }
    void update(const std::string& scene) {
        const auto r = golden("update", scene);
        ASSERT_EQ(r.status, 0) << r.err;
    }
};

// run_isolated's `meanwhile` (golden verify's CPU side) runs in the parent while the child
// works: the child here waits for a file that only the parent's meanwhile makes.
TEST(RunIsolated, MeanwhileRunsInTheParentWhileTheChildWorks) {
    const fs::path flag = fs::temp_directory_path() / ("tessref-meanwhile-" + std::to_string(::getpid()));
    fs::remove(flag);
    const std::string answer = tessref::run_isolated(
        "a test child",
        [&] {
            for (int i = 0; i < 2000 && !fs::exists(flag); ++i) ::usleep(5000);  // up to 10 s
            return std::string(fs::exists(flag) ? "saw it" : "never saw it");
        },
        {}, [&] { std::ofstream(flag.string()) << "x"; });
    fs::remove(flag);
    EXPECT_EQ(answer, "saw it");
}

// A meanwhile that throws ends the child (killed, not waited for to finish, and reaped) and
// the exception goes on to the caller.
TEST(RunIsolated, AThrowingMeanwhileEndsTheChild) {
    const fs::path pid_file = fs::temp_directory_path() / ("tessref-meanwhile-pid-" + std::to_string(::getpid()));
    fs::remove(pid_file);
    pid_t child = 0;
    EXPECT_THROW(tessref::run_isolated(
                     "a test child",
                     [&] {
                         std::ofstream(pid_file.string() + ".part") << ::getpid();
                         fs::rename(pid_file.string() + ".part", pid_file);  // whole when it appears
                         ::sleep(30);
                         std::ofstream(pid_file.string() + ".finished") << "late";  // a child not killed
                         return std::string("late");
                     },
                     {},
                     [&] {
                         for (int i = 0; i < 2000 && !fs::exists(pid_file); ++i) ::usleep(5000);
                         std::ifstream(pid_file.string()) >> child;
                         throw tessref::Error("the parent's side failed");
                     }),
                 tessref::Error);
    fs::remove(pid_file);
    EXPECT_FALSE(fs::exists(pid_file.string() + ".finished"));
    fs::remove(pid_file.string() + ".finished");
    ASSERT_GT(child, 0);
    errno = 0;
    EXPECT_EQ(::kill(child, 0), -1);  // no such process: killed and reaped
    EXPECT_EQ(errno, ESRCH);
}

// A child that sends its result ahead in pieces (send_to_parent): on_chunk gets each piece
// whole and in order, after meanwhile, then the answer comes as always. The pieces are
// larger than the pipe holds (the child waits while the parent reads).
TEST(RunIsolated, PiecesSentAheadArriveWholeAndInOrderBeforeTheAnswer) {
    std::vector<std::string> pieces;
    bool meanwhile_done = false, piece_before_meanwhile = false;
    const std::string answer = tessref::run_isolated(
        "a test child",
        [] {
            for (int k = 0; k < 5; ++k) tessref::send_to_parent(std::string(std::size_t(300000) * k, char('a' + k)));
            return std::string("the answer");
        },
        {}, [&] { meanwhile_done = true; },
        [&](std::string_view piece) {
            piece_before_meanwhile = piece_before_meanwhile || !meanwhile_done;
            pieces.emplace_back(piece);
        });
    EXPECT_EQ(answer, "the answer");
    EXPECT_FALSE(piece_before_meanwhile);
    ASSERT_EQ(pieces.size(), 5u);
    for (int k = 0; k < 5; ++k) EXPECT_EQ(pieces[k], std::string(std::size_t(300000) * k, char('a' + k))) << k;
}

// An on_chunk that throws ends the child, which would otherwise go on sending (and wait on
// the full pipe for ever), and the exception goes on to the caller; a child that sent pieces
// and no answer has given no answer.
TEST(RunIsolated, AThrowingOnChunkEndsTheChildAndPiecesAreNoAnswer) {
    int seen = 0;
    EXPECT_THROW(tessref::run_isolated(
                     "a test child",
                     [] {
                         for (;;) tessref::send_to_parent(std::string(100000, 'x'));
                         return std::string();
                     },
                     {}, {},
                     [&](std::string_view) {
                         if (++seen == 3) throw tessref::Error("the parent's side failed");
                     }),
                 tessref::Error);
    EXPECT_EQ(seen, 3);
    try {
        tessref::run_isolated(
            "a test child",
            [] {
                tessref::send_to_parent("whole");
                ::_exit(0);  // no answer after the piece
                return std::string();
            },
            {}, {}, [](std::string_view) {});
        ADD_FAILURE() << "no error";
    } catch (const tessref::Error& e) {
        EXPECT_NE(std::string(e.what()).find("without an answer"), std::string::npos) << e.what();
    }
}

// start_isolated() and finish(): two children at once, each working from its start (the
// first waits for a file only the second makes, so it could not answer if the second
// started only when the first was finished), each answering its own finish().
TEST(RunIsolated, TwoChildrenStartedAtOnceWorkAtOnceAndAnswerTheirOwn) {
    const fs::path flag = fs::temp_directory_path() / ("tessref-two-children-" + std::to_string(::getpid()));
    fs::remove(flag);
    tessref::IsolatedChild first = tessref::start_isolated("a test child", [&] {
        for (int i = 0; i < 2000 && !fs::exists(flag); ++i) ::usleep(5000);  // up to 10 s
        return std::string(fs::exists(flag) ? "first saw the second" : "first alone");
    });
    tessref::IsolatedChild second = tessref::start_isolated("a test child", [&] {
        std::ofstream(flag.string()) << "x";
        return std::string("second");
    });
    EXPECT_TRUE(first.started());
    EXPECT_EQ(first.finish(), "first saw the second");
    EXPECT_FALSE(first.started());
    EXPECT_THROW(first.finish(), tessref::Error);  // once only
    EXPECT_EQ(second.finish(), "second");
    fs::remove(flag);
}

// A started child whose IsolatedChild goes away unfinished (an exception on the way, the
// caller done) is killed and reaped, not left running.
TEST(RunIsolated, AChildNeverFinishedIsKilledAndReaped) {
    const fs::path pid_file = fs::temp_directory_path() / ("tessref-unfinished-pid-" + std::to_string(::getpid()));
    fs::remove(pid_file);
    pid_t child = 0;
    {
        tessref::IsolatedChild c = tessref::start_isolated("a test child", [&] {
            std::ofstream(pid_file.string() + ".part") << ::getpid();
            fs::rename(pid_file.string() + ".part", pid_file);
            ::sleep(30);
            std::ofstream(pid_file.string() + ".finished") << "late";
            return std::string("late");
        });
        for (int i = 0; i < 2000 && !fs::exists(pid_file); ++i) ::usleep(5000);
        std::ifstream(pid_file.string()) >> child;
    }
    ASSERT_GT(child, 0);
    errno = 0;
    EXPECT_EQ(::kill(child, 0), -1);  // no such process: killed and reaped
    EXPECT_EQ(errno, ESRCH);
    EXPECT_FALSE(fs::exists(pid_file.string() + ".finished"));
    fs::remove(pid_file);
    fs::remove(pid_file.string() + ".finished");
}

// The digester fed the capture in pieces cut anywhere (inside a patch's run, inside a
// triangle, a piece of one vertex) gives capture_digest's digests of the whole.
TEST(CaptureDigest, FedInPiecesCutAnywhereIsTheWholeCapturesDigest) {
    std::vector<tessref::CapturedVertex> capture;
    for (std::uint32_t run = 0; run < 12; ++run)
        for (std::uint32_t k = 0; k < 3 * (50 + 13 * run); ++k) {
            tessref::CapturedVertex v;
            v.patch_id = run == 11 ? 2 : run;  // patch 2 comes back last
            v.tess_coord = {static_cast<float>(k) / 7.0f, 0.5f, 0.0f};
            v.position = {static_cast<float>(k), static_cast<float>(run), 1.0f};
            v.levels.outer = {static_cast<float>(run), 2.0f, 3.0f, 4.0f};
            capture.push_back(v);
        }
    const tessref::golden::CaptureDigest whole = tessref::golden::capture_digest(capture);
    for (const std::size_t step : {std::size_t(1), std::size_t(2), std::size_t(50), std::size_t(151), capture.size()}) {
        tessref::golden::CaptureDigester digester;
        for (std::size_t at = 0; at < capture.size(); at += step)
            digester.add(std::span<const tessref::CapturedVertex>(capture).subspan(at, std::min(step, capture.size() - at)));
        const tessref::golden::CaptureDigest pieces = digester.finish();
        EXPECT_EQ(pieces.sha256, whole.sha256) << step;
        EXPECT_EQ(pieces.triangles, whole.triangles) << step;
        ASSERT_EQ(pieces.patches.size(), whole.patches.size()) << step;
        for (std::size_t r = 0; r < whole.patches.size(); ++r) {
            EXPECT_EQ(pieces.patches[r].patch_id, whole.patches[r].patch_id) << step << " " << r;
            EXPECT_EQ(pieces.patches[r].levels, whole.patches[r].levels) << step << " " << r;
            EXPECT_EQ(pieces.patches[r].triangles, whole.patches[r].triangles) << step << " " << r;
            EXPECT_EQ(pieces.patches[r].sha256, whole.patches[r].sha256) << step << " " << r;
        }
    }
}

// capture_digest never holds the capture's text; its digests are still those of the text,
// as a reader recomputes them with grep and sha256sum: the whole text's, and each run of a
// patch's lines (its `patch` line and its vertices) on its own, a patch that comes back
// getting a second entry. Enough vertices for several of its windows.
TEST(CaptureDigest, IsTheDigestOfTheCaptureText) {
    std::vector<tessref::CapturedVertex> capture;
    for (std::uint32_t run = 0; run < 40; ++run) {
        const std::uint32_t patch = run == 39 ? 3 : run;  // patch 3 comes back last
        for (std::uint32_t k = 0; k < 3 * (run == 7 ? 100000 : 1000 + 37 * run); ++k) {
            tessref::CapturedVertex v;
            v.patch_id = patch;
            v.tess_coord = {static_cast<float>(k) / 3.0f, 0.25f, 0.0f};
            v.position = {static_cast<float>(k) * 0.1f, -1.0f / static_cast<float>(k + 1), 1e-30f};
            v.normal = {0.0f, 1.0f, static_cast<float>(patch)};
            v.levels.outer = {static_cast<float>(patch) + 0.5f, 2.0f, 3.0f, 4.0f};
            capture.push_back(v);
        }
    }
    const std::string text = tessref::capture_text(capture);
    const tessref::golden::CaptureDigest digest = tessref::golden::capture_digest(capture);
    EXPECT_EQ(digest.sha256, tessref::golden::sha256_hex(text));
    EXPECT_EQ(digest.triangles, capture.size() / 3);
    // The runs, cut from the text at its `patch` lines.
    std::vector<std::string> runs;
    for (std::size_t at = text.find("\npatch "); at != std::string::npos;) {
        const std::size_t next = text.find("\npatch ", at + 1);
        runs.push_back(text.substr(at + 1, next == std::string::npos ? std::string::npos : next - at));
        at = next;
    }
    ASSERT_EQ(digest.patches.size(), runs.size());
    ASSERT_EQ(runs.size(), 40u);
    for (std::size_t r = 0; r < runs.size(); ++r) {
        const tessref::golden::PatchDigest& p = digest.patches[r];
        const std::string first_line = runs[r].substr(0, runs[r].find('\n'));
        EXPECT_EQ("patch " + std::to_string(p.patch_id) + " levels " + p.levels, first_line) << r;
        EXPECT_EQ(p.sha256, tessref::golden::sha256_hex(runs[r]).substr(0, tessref::golden::kPatchDigits)) << r;
        EXPECT_EQ(p.triangles, (std::count(runs[r].begin(), runs[r].end(), '\n') - 1) / 3) << r;
    }
    EXPECT_EQ(digest.patches.back().patch_id, 3u);
}

TEST_F(GoldenCommand, UpdateWritesTheThreeFilesAndVerifyPasses) {
    update("thesis-map-4");
    for (const char* f : {"image.png", "capture.txt", "mesh.txt"})
        EXPECT_TRUE(fs::is_regular_file(dir_ / "golden" / "thesis-map-4" / f)) << f;
    const auto r = golden("verify", "thesis-map-4");
    EXPECT_EQ(r.status, 0) << r.out << r.err;
    EXPECT_NE(r.out.find("PASS"), std::string::npos) << r.out;
}

// The mesh digest is the SHA-256 of what `tessref mesh --binary` writes, checked with the
// system's sha256sum (an implementation of SHA-256 that is not ours).
TEST_F(GoldenCommand, MeshDigestIsTheSha256OfTheBinaryPly) {
    update("thesis-map-4");
    const auto m = run({"mesh", kScenes + "/thesis-map-4.toml", "--binary", "-o", path("m.ply")});
    ASSERT_EQ(m.status, 0) << m.err;
    const std::string sum_file = path("sum.txt");
    ASSERT_EQ(std::system(("sha256sum " + path("m.ply") + " > " + sum_file).c_str()), 0);
    const std::string sum = read_file(sum_file).substr(0, 64);
    const std::string digest = read_file(dir_ / "golden" / "thesis-map-4" / "mesh.txt");
    EXPECT_NE(digest.find("sha256 " + sum), std::string::npos) << digest << "\nsha256sum: " << sum;
}

TEST_F(GoldenCommand, AChangedPatchDigestMakesTheSceneStaleNamingThePatch) {
    update("thesis-map-4");
    const fs::path file = dir_ / "golden" / "thesis-map-4" / "capture.txt";
    std::string text = read_file(file);
    // Patch 17's digest: flip its last hex digit.
    const std::regex line("(\npatch 17 [^\n]* sha256 [0-9a-f]{15})([0-9a-f])");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(text, m, line));
    const char last = m[2].str()[0];
    text.replace(static_cast<std::size_t>(m.position(2)), 1, 1, last == '0' ? '1' : '0');
    // ... and the whole capture's digest, as a file edited by hand or by another version.
    const std::size_t at = text.find("capture patches");
    const std::size_t sha = text.find("sha256 ", at) + 7;
    text[sha] = text[sha] == '0' ? '1' : '0';
    write_file(file, text);
    const auto r = golden("verify", "thesis-map-4");
    EXPECT_EQ(r.status, 1) << r.out << r.err;
    EXPECT_NE(r.out.find("STALE"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("1 of 256 patches differ"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("first: patch 17"), std::string::npos) << r.out;
}

TEST_F(GoldenCommand, AnotherSceneImageMakesTheSceneStale) {
    update("thesis-map-4");
    update("thesis-map-18");
    fs::copy_file(dir_ / "golden" / "thesis-map-18" / "image.png", dir_ / "golden" / "thesis-map-4" / "image.png",
                  fs::copy_options::overwrite_existing);
    const auto r = golden("verify", "thesis-map-4");
    EXPECT_EQ(r.status, 1) << r.out << r.err;
    EXPECT_NE(r.out.find("stale: image"), std::string::npos) << r.out;
}

// A GL draw whose primitive count disagrees with the reference's prediction (the test hook
// of `tessref gl`) fails the scene.
TEST_F(GoldenCommand, AWrongGlDrawFailsTheScene) {
    update("thesis-map-4");
    ::setenv("TESSREF_GL_CORRUPT_BATCH", "0", 1);
    const auto r = golden("verify", "thesis-map-4");
    ::unsetenv("TESSREF_GL_CORRUPT_BATCH");
    EXPECT_EQ(r.status, 1) << r.out << r.err;
    EXPECT_NE(r.out.find("FAIL"), std::string::npos) << r.out;
}

TEST_F(GoldenCommand, BadInputIsExitTwo) {
    auto r = golden("verify", "no-such-scene");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("no-such-scene"), std::string::npos) << r.err;
    r = golden("verify", "thesis-map-4");  // no golden files yet
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("golden update"), std::string::npos) << r.err;
    r = golden("update", "../thesis-map-4");
    EXPECT_EQ(r.status, 2);
    EXPECT_FALSE(fs::exists(dir_ / "golden"));
}

// A golden file that is not what `golden update` writes is refused (exit 2, naming the
// file), never read as far as it goes: a malformed digest read as STALE (exit 1), and a
// deleted or duplicated patch line, levels that are not numbers or a patch count that is
// not the file's passed.
TEST_F(GoldenCommand, CorruptGoldenFilesAreRefused) {
    update("thesis-map-4");
    const fs::path dir = dir_ / "golden" / "thesis-map-4";
    const std::string capture = read_file(dir / "capture.txt"), mesh = read_file(dir / "mesh.txt");
    const auto replaced = [](std::string text, const std::string& from, const std::string& to) {
        const std::size_t at = text.find(from);
        EXPECT_NE(at, std::string::npos) << from;
        return at == std::string::npos ? text : text.replace(at, from.size(), to);
    };
    const std::size_t patch0 = capture.find("\npatch 0 ") + 1;
    const std::string patch0_line = capture.substr(patch0, capture.find('\n', patch0) + 1 - patch0);
    const std::size_t whole = capture.find(" sha256 ", capture.find("capture patches")) + 8;
    const std::size_t mesh_sha = mesh.find(" sha256 ") + 8;
    struct Case {
        std::string name, file, text;
    };
    const std::vector<Case> cases{
        {"digest one digit short", "capture.txt", std::string(capture).erase(whole, 1)},
        {"digest in upper case", "capture.txt", std::string(capture).replace(whole, 1, "A")},
        {"digest not hex", "capture.txt", std::string(capture).replace(whole, 1, "g")},
        {"patch digest short", "capture.txt", replaced(capture, patch0_line, patch0_line.substr(0, patch0_line.size() - 2) + "\n")},
        {"patch line duplicated", "capture.txt", replaced(capture, patch0_line, patch0_line + patch0_line)},
        {"patch line deleted", "capture.txt", replaced(capture, patch0_line, "")},
        {"levels nan", "capture.txt", std::regex_replace(capture, std::regex("\npatch 0 levels [^t]*triangles"), "\npatch 0 levels nan triangles")},
        {"six levels, one nan", "capture.txt", std::regex_replace(capture, std::regex("\n(patch 0 levels )[^ ]*"), "\n$1nan")},
        {"patch count 4000000000", "capture.txt", std::regex_replace(capture, std::regex("capture patches [0-9]+"), "capture patches 4000000000")},
        {"no size", "capture.txt", std::regex_replace(capture, std::regex("\nsize [^\n]*"), "")},
        {"mesh digest short", "mesh.txt", std::string(mesh).erase(mesh_sha, 1)},
        {"mesh digest not hex", "mesh.txt", std::string(mesh).replace(mesh_sha, 1, "z")},
        {"mesh line twice", "mesh.txt", mesh + mesh.substr(mesh.find("\nmesh ") + 1)},
    };
    for (const Case& c : cases) {
        write_file(dir / "capture.txt", c.file == "capture.txt" ? c.text : capture);
        write_file(dir / "mesh.txt", c.file == "mesh.txt" ? c.text : mesh);
        const auto r = golden("verify", "thesis-map-4");
        EXPECT_EQ(r.status, 2) << c.name << "\n" << r.out << r.err;
        EXPECT_NE(r.err.find(c.file), std::string::npos) << c.name << ": " << r.err;
    }
    write_file(dir / "capture.txt", capture);
    write_file(dir / "mesh.txt", mesh);
    const auto r = golden("verify", "thesis-map-4");
    EXPECT_EQ(r.status, 0) << r.out << r.err;
}

// update writes only what verify reads back: a scene file named "..toml" (stem ".", the
// golden directory itself) or with a newline in its name (which would break a comment line
// of capture.txt) is refused before anything is written.
TEST_F(GoldenCommand, UpdateRefusesSceneNamesVerifyCouldNotReadBack) {
    const std::string scene = tessref::test::with_absolute_data_paths(read_file(kScenes + "/thesis-map-4.toml"),
                                                                      fs::path(kScenes).parent_path());
    for (const std::string name : {"..toml", "a\nb.toml", "tab\there.toml"}) {
        fs::remove_all(dir_ / "scenes");
        fs::remove_all(dir_ / "golden");
        fs::create_directories(dir_ / "scenes");
        write_file(dir_ / "scenes" / name, scene);
        const auto r = run({"golden", "update", "--golden", path("golden"), "--scenes", path("scenes")});
        EXPECT_EQ(r.status, 2) << name << ": " << r.out << r.err;
        EXPECT_FALSE(fs::exists(dir_ / "golden")) << name;
    }
}

// ---- verify reports every scene, whatever happens to one (issue 27) -----------------------

// The verdict printed at the end of `scene`'s table row ("" when there is no row).
std::string table_verdict(const std::string& out, const std::string& scene) {
    const std::regex row("(^|\n)" + scene + " [^\n]* ([A-Z-]+)(\n|$)");
    std::smatch m;
    return std::regex_search(out, m, row) ? m[2].str() : std::string();
}

// One flipped byte in a golden image.png or a missing mesh.txt used to abort the whole run
// (exit 2, a half-printed table, no JSON). Each scene now gets its own verdict, the table
// and the JSON list every scene, and the exit status is the worst verdict's.
TEST_F(GoldenCommand, EveryScenesVerdictWhateverHappensToOne) {
    for (const char* scene : {"thesis-constant-1", "thesis-map-18", "thesis-map-4"}) update(scene);
    const fs::path image = dir_ / "golden" / "thesis-constant-1" / "image.png";
    std::string png = read_file(image);
    png[png.size() / 2] = static_cast<char>(png[png.size() / 2] ^ 0x5a);  // inside the pixel data
    write_file(image, png);
    fs::remove(dir_ / "golden" / "thesis-map-4" / "mesh.txt");
    const std::vector<std::string> args{"golden",  "verify",          "thesis-constant-1", "thesis-map-18", "thesis-map-4",
                                        "--golden", path("golden"), "--scenes",          kScenes};
    const auto r = run(args);
    EXPECT_EQ(r.status, 2) << r.out << r.err;
    EXPECT_EQ(table_verdict(r.out, "thesis-constant-1"), "CORRUPT") << r.out;
    EXPECT_EQ(table_verdict(r.out, "thesis-map-18"), "PASS") << r.out;
    EXPECT_EQ(table_verdict(r.out, "thesis-map-4"), "MISSING") << r.out;
    EXPECT_NE(r.out.find("mesh.txt is not there"), std::string::npos) << r.out;
    EXPECT_NE(r.err.find("image.png"), std::string::npos) << r.err;

    std::vector<std::string> json_args = args;
    json_args.push_back("--json");
    const auto j = run(json_args);
    EXPECT_EQ(j.status, 2) << j.out << j.err;
    const nlohmann::json report = nlohmann::json::parse(j.out);
    ASSERT_EQ(report["scenes"].size(), 3u) << j.out;
    EXPECT_EQ(report["scenes"][0]["verdict"], "CORRUPT");
    EXPECT_EQ(report["scenes"][1]["verdict"], "PASS");
    EXPECT_EQ(report["scenes"][2]["verdict"], "MISSING");
    EXPECT_EQ(report["worst"], "CORRUPT");
    EXPECT_EQ(report["passed"], false);

    // A stale scene alone is exit 1 (the worst verdict), not 2.
    update("thesis-map-4");
    fs::copy_file(dir_ / "golden" / "thesis-map-18" / "image.png", dir_ / "golden" / "thesis-map-4" / "image.png",
                  fs::copy_options::overwrite_existing);
    const auto stale = run({"golden", "verify", "thesis-map-4", "thesis-map-18", "--golden", path("golden"), "--scenes", kScenes});
    EXPECT_EQ(stale.status, 1) << stale.out << stale.err;
    EXPECT_EQ(table_verdict(stale.out, "thesis-map-4"), "STALE") << stale.out;
    EXPECT_EQ(table_verdict(stale.out, "thesis-map-18"), "PASS") << stale.out;
}

// The lines verify never read: a patch line's levels or digest edited by hand, while the
// whole capture's digest still names the reference's capture, is a file that disagrees
// with itself (CORRUPT), and so is an edited whole digest whose patch lines all match: no
// change of the reference makes either. (It used to PASS, and to say "0 of 256 patches
// differ (the patch count)".)
TEST_F(GoldenCommand, AGoldenFileThatDisagreesWithItselfIsCorrupt) {
    update("thesis-map-4");
    const fs::path file = dir_ / "golden" / "thesis-map-4" / "capture.txt";
    const std::string capture = read_file(file);
    const auto verify_with = [&](const std::string& text) {
        write_file(file, text);
        return golden("verify", "thesis-map-4");
    };
    // Patch 17's first level.
    auto r = verify_with(std::regex_replace(capture, std::regex("(\npatch 17 levels )[^ ]+"), "$010.5"));
    EXPECT_EQ(r.status, 2) << r.out << r.err;
    EXPECT_EQ(table_verdict(r.out, "thesis-map-4"), "CORRUPT") << r.out;
    EXPECT_NE(r.out.find("disagrees with itself"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("patch 17 ("), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("levels 0.5 "), std::string::npos) << r.out;
    // Patch 17's digest.
    std::smatch m;
    ASSERT_TRUE(std::regex_search(capture, m, std::regex("\npatch 17 [^\n]* sha256 [0-9a-f]{15}([0-9a-f])")));
    std::string edited = capture;
    edited[static_cast<std::size_t>(m.position(1))] = m[1].str()[0] == '0' ? '1' : '0';
    r = verify_with(edited);
    EXPECT_EQ(r.status, 2) << r.out << r.err;
    EXPECT_EQ(table_verdict(r.out, "thesis-map-4"), "CORRUPT") << r.out;
    // The whole digest alone.
    edited = capture;
    const std::size_t sha = edited.find("sha256 ", edited.find("capture patches")) + 7;
    edited[sha] = edited[sha] == '0' ? '1' : '0';
    r = verify_with(edited);
    EXPECT_EQ(r.status, 2) << r.out << r.err;
    EXPECT_EQ(table_verdict(r.out, "thesis-map-4"), "CORRUPT") << r.out;
    EXPECT_EQ(r.out.find("0 of 256"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("all 256 patch lines match"), std::string::npos) << r.out;
    // The mesh digest's counts.
    write_file(file, capture);
    const fs::path mesh = dir_ / "golden" / "thesis-map-4" / "mesh.txt";
    write_file(mesh, std::regex_replace(read_file(mesh), std::regex("triangles ([0-9]+)"), "triangles 1$1"));
    r = golden("verify", "thesis-map-4");
    EXPECT_EQ(r.status, 2) << r.out << r.err;
    EXPECT_EQ(table_verdict(r.out, "thesis-map-4"), "CORRUPT") << r.out;
}

// A scene of one's own (--scenes, --golden): the golden files' headers name the real scene
// file and the full command that rewrites them; when the reference changes, the stale
// patches are listed with their old and new levels. The constant control model gives every
// level of every patch the scene's `level` (control.h), so 1 before and 3 after.
TEST_F(GoldenCommand, OwnScenesNameTheirPathsAndStaleLevelsTheirValues) {
    fs::create_directories(dir_ / "scenes");
    const std::string scene = tessref::test::with_absolute_data_paths(read_file(kScenes + "/thesis-constant-1.toml"),
                                                                      fs::path(kScenes).parent_path());
    write_file(dir_ / "scenes" / "mine.toml", scene);
    const auto u = run({"golden", "update", "mine", "--golden", path("golden"), "--scenes", path("scenes")});
    ASSERT_EQ(u.status, 0) << u.out << u.err;
    const std::string command =
        "tessref golden update mine --golden " + path("golden") + " --scenes " + path("scenes");
    const std::string capture = read_file(dir_ / "golden" / "mine" / "capture.txt");
    EXPECT_NE(capture.find("# The CPU reference capture of " + path("scenes") + "/mine.toml,"), std::string::npos)
        << capture.substr(0, 600);
    EXPECT_NE(capture.find("# Regenerate: " + command + "\n"), std::string::npos) << capture.substr(0, 600);
    const std::string mesh = read_file(dir_ / "golden" / "mine" / "mesh.txt");
    EXPECT_NE(mesh.find("`tessref mesh " + path("scenes") + "/mine.toml --binary -o mesh.ply`"), std::string::npos) << mesh;
    EXPECT_NE(mesh.find("Regenerate: " + command + "\n"), std::string::npos) << mesh;

    write_file(dir_ / "scenes" / "mine.toml", std::regex_replace(scene, std::regex("\nlevel = 1.0"), "\nlevel = 3.0"));
    const auto r = run({"golden", "verify", "mine", "--golden", path("golden"), "--scenes", path("scenes")});
    EXPECT_EQ(r.status, 1) << r.out << r.err;
    EXPECT_EQ(table_verdict(r.out, "mine"), "STALE") << r.out;
    EXPECT_NE(r.out.find("256 of 256 patches differ"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("patch 0 (" + path("golden") + "/mine/capture.txt:"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("levels 1 1 1 1 1 1 in the file, 3 3 3 3 3 3 now"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("... and 248 more"), std::string::npos) << r.out;
}

// The shipped files name data/scenes/NAME.toml and `tessref golden update NAME`: the
// defaults write what they always wrote (golden/ stays byte-identical).
TEST(GoldenLocation, TheDefaultsNameWhatTheShippedFilesName) {
    const tessref::golden::Location shipped;
    EXPECT_EQ(shipped.scene_file("jacksboro").string(), "data/scenes/jacksboro.toml");
    EXPECT_EQ(shipped.update_command("jacksboro"), "tessref golden update jacksboro");
    const std::string file = read_file(fs::path(TESSREF_SOURCE_DIR) / "golden" / "jacksboro" / "capture.txt");
    EXPECT_NE(file.find("of data/scenes/jacksboro.toml,"), std::string::npos);
    EXPECT_NE(file.find("# Regenerate: tessref golden update jacksboro\n"), std::string::npos);
    const tessref::golden::Location mine{"my scenes", "out"};
    EXPECT_EQ(mine.update_command("a b"), "tessref golden update 'a b' --golden out --scenes 'my scenes'");
}

// Several scenes in one run, where each scene's GL child starts while the scene before it
// is completed, give each scene the row it gets alone, whatever the scenes around it are:
// drawn by llvmpipe, checked on the CPU only (pom), missing a file, or not loadable.
TEST_F(GoldenCommand, ScenesVerifiedTogetherGetTheRowsTheyGetAlone) {
    // A scene directory of its own beside the data's folders (the scenes name their
    // files relative to themselves), with one scene file that does not load.
    const fs::path data = fs::path(TESSREF_SOURCE_DIR) / "data";
    for (const char* folder : {"heightmaps", "textures", "tessmaps", "shaders"}) fs::create_directory_symlink(data / folder, dir_ / folder);
    fs::create_directories(dir_ / "scenes");
    const std::vector<std::string> order{"terrain-pom", "thesis-constant-1", "broken", "thesis-map-4", "jacksboro-geomipmap"};
    for (const std::string& scene : order)
        if (scene != "broken") fs::copy_file(data / "scenes" / (scene + ".toml"), dir_ / "scenes" / (scene + ".toml"));
    const auto golden_args = [&](const std::string& action, const std::vector<std::string>& names) {
        std::vector<std::string> a{"golden", action};
        a.insert(a.end(), names.begin(), names.end());
        for (const std::string& x : {std::string("--golden"), path("golden"), std::string("--scenes"), path("scenes")})
            a.push_back(x);
        return run(a);
    };
    const auto updated = golden_args("update", {"terrain-pom", "thesis-constant-1", "thesis-map-4", "jacksboro-geomipmap"});
    ASSERT_EQ(updated.status, 0) << updated.err;
    fs::copy(dir_ / "golden" / "thesis-constant-1", dir_ / "golden" / "broken");
    write_file(dir_ / "scenes" / "broken.toml", "[generator\n");
    fs::remove(dir_ / "golden" / "thesis-map-4" / "mesh.txt");

    // A scene's row and the notes under it, without the GL s column (a time) and the
    // name column's width (the longest name's).
    const auto row_of = [](const std::string& out, const std::string& scene) {
        std::smatch m;
        if (!std::regex_search(out, m, std::regex("\n(" + scene + " [^\n]*)\n((?:    [^\n]*\n)*)"))) return std::string();
        const std::string row = std::regex_replace(m[1].str(), std::regex(" +[0-9.]+(  [A-Z-]+)$"), "$1");
        return std::regex_replace(row, std::regex(" +"), " ") + "\n" + m[2].str();  // the name column's width
    };
    const auto together = golden_args("verify", order);
    EXPECT_EQ(together.status, 2) << together.out << together.err;
    EXPECT_NE(together.out.find("golden verify: llvmpipe"), std::string::npos) << together.out;
    for (const std::string& scene : order) {
        const auto alone = golden_args("verify", {scene});
        const std::string row = row_of(alone.out, scene);
        EXPECT_FALSE(row.empty()) << alone.out;
        EXPECT_EQ(row_of(together.out, scene), row) << scene << "\ntogether:\n" << together.out << "alone:\n" << alone.out;
    }
    EXPECT_EQ(table_verdict(together.out, "terrain-pom"), "CPU-ONLY") << together.out;
    EXPECT_EQ(table_verdict(together.out, "thesis-constant-1"), "PASS") << together.out;
    EXPECT_EQ(table_verdict(together.out, "broken"), "ERROR") << together.out;
    EXPECT_EQ(table_verdict(together.out, "thesis-map-4"), "MISSING") << together.out;
    EXPECT_EQ(table_verdict(together.out, "jacksboro-geomipmap"), "PASS") << together.out;
    // A run whose first scene llvmpipe does not draw still names the renderer.
    const auto pom_first = golden_args("verify", {"terrain-pom"});
    EXPECT_EQ(pom_first.status, 0) << pom_first.out << pom_first.err;
    EXPECT_NE(pom_first.out.find("golden verify: llvmpipe"), std::string::npos) << pom_first.out;
}

// Fixed-width columns that never run together, and a legend saying what each header means.
TEST_F(GoldenCommand, TheTableHasALegendAndSeparatedColumns) {
    update("thesis-map-4");
    const auto r = golden("verify", "thesis-map-4");
    ASSERT_EQ(r.status, 0) << r.out << r.err;
    std::smatch m;
    ASSERT_TRUE(std::regex_search(r.out, m, std::regex("\nthesis-map-4((?: +[-0-9.e+]+){10})  PASS\n"))) << r.out;
    for (const char* header : {"fail px", "lvl px", "max err", "pos ulp", "nrm ulp", "lvl patches", "lvl ulp", "lvl diff", "GL s"})
        EXPECT_TRUE(std::regex_search(r.out, std::regex("\n  " + std::string(header) + " +[a-z.]"))) << header << "\n" << r.out;
    EXPECT_NE(r.out.find("CORRUPT "), std::string::npos) << r.out;  // the verdicts' legend
    const auto help = run({"golden", "--help"});
    EXPECT_NE(help.out.find("lvl px"), std::string::npos) << help.out;
}

}  // namespace
