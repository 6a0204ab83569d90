// End-to-end tests of what the `tessref` command writes and says: -o to something that is
// not a regular file (symlinks, FIFOs, device nodes), temporary files on signals, the
// check report with a non-UTF-8 file name, messages that name what the user typed, the
// render memory estimate and --max-memory.
//
// Device nodes: the tests first write to private nodes made with mknod (same major/minor as
// /dev/full and /dev/null) in their own directory, and touch the real /dev/full and
// /dev/null only once the private ones survived, so a regression replaces a node of the
// test's own, not the machine's.
#include <gtest/gtest.h>

#include "command_dir_test.h"
#include "run_program.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <regex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "tessref/render.h"

namespace fs = std::filesystem;

namespace {

using tessref::test::read_file;
using tessref::test::run_program;
using tessref::test::RunResult;
using tessref::test::write_file;

const fs::path kSource = TESSREF_SOURCE_DIR;

std::string scene(const std::string& name) { return (kSource / "data/scenes" / (name + ".toml")).string(); }

// A fresh, empty directory per test, removed afterwards (tests/command_dir_test.h).
using CliOutputTest = tessref::test::CommandDirTest;

// A small pattern: a few lines of text, quick to make.
std::vector<std::string> isolines(std::vector<std::string> extra = {}) {
    std::vector<std::string> args{"tessellate", "--domain", "isolines", "--spacing", "equal", "--outer", "2,3,1,1"};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
}

bool is_char_device(const fs::path& p, dev_t device) {
    struct stat info {};
    return ::lstat(p.c_str(), &info) == 0 && S_ISCHR(info.st_mode) && info.st_rdev == device;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// ---------------------------------------------------------------------------------------
// -o to what is not a regular file

TEST_F(CliOutputTest, SymlinkToARegularFileReplacesTheFileAndKeepsTheLink) {
    write_file(dir_ / "real.txt", "old contents\n");
    fs::create_symlink("real.txt", dir_ / "link.txt");
    const RunResult expected = run(isolines());
    ASSERT_EQ(expected.status, 0) << expected.err;

    const RunResult r = run(isolines({"-o", path("link.txt")}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(fs::is_symlink(fs::symlink_status(dir_ / "link.txt")));
    EXPECT_EQ(fs::read_symlink(dir_ / "link.txt"), fs::path("real.txt"));
    EXPECT_EQ(read_file(dir_ / "real.txt"), expected.out);
    EXPECT_EQ(files(), (std::set<std::string>{"link.txt", "real.txt"}));  // no temporary file left
}

TEST_F(CliOutputTest, DanglingSymlinkCreatesTheFileItNames) {
    fs::create_symlink("new.txt", dir_ / "link.txt");
    const RunResult r = run(isolines({"-o", path("link.txt")}));
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(fs::is_symlink(fs::symlink_status(dir_ / "link.txt")));
    EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(dir_ / "new.txt")));
    EXPECT_TRUE(contains(read_file(dir_ / "new.txt"), "# tessref tessellate --domain isolines"));
    EXPECT_EQ(files(), (std::set<std::string>{"link.txt", "new.txt"}));
}

TEST_F(CliOutputTest, FifoIsWrittenThroughAndStaysAFifo) {
    const fs::path fifo = dir_ / "pipe.txt";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    // The test holds a write end of its own, so its reader neither sees EOF before tessref
    // opens the FIFO nor blocks forever if tessref never does (a regression that renames).
    const int read_fd = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
    ASSERT_GE(read_fd, 0);
    const int hold_fd = ::open(fifo.c_str(), O_WRONLY);
    ASSERT_GE(hold_fd, 0);
    ::fcntl(read_fd, F_SETFL, ::fcntl(read_fd, F_GETFL) & ~O_NONBLOCK);
    std::string received;
    std::thread reader([&] {
        char buffer[4096];
        ssize_t n;
        while ((n = ::read(read_fd, buffer, sizeof buffer)) > 0) received.append(buffer, static_cast<std::size_t>(n));
    });
    const RunResult r = run(isolines({"-o", fifo.string()}));
    ::close(hold_fd);
    reader.join();
    ::close(read_fd);

    ASSERT_EQ(r.status, 0) << r.err;
    struct stat info {};
    ASSERT_EQ(::lstat(fifo.c_str(), &info), 0);
    EXPECT_TRUE(S_ISFIFO(info.st_mode));
    EXPECT_EQ(received, run(isolines()).out);
    EXPECT_EQ(files(), (std::set<std::string>{"pipe.txt"}));
}

TEST_F(CliOutputTest, DeviceNodesAreWrittenThroughNeverReplaced) {
    const dev_t full = ::makedev(1, 7), null = ::makedev(1, 3);
    // Private nodes first (root only); without the right to make one, no rename could
    // replace a node in /dev either.
    const bool private_nodes = ::mknod(path("full.txt").c_str(), S_IFCHR | 0666, full) == 0 &&
                               ::mknod(path("null.txt").c_str(), S_IFCHR | 0666, null) == 0;
    std::vector<std::pair<fs::path, fs::path>> targets;  // (full, null)
    if (private_nodes) targets.push_back({dir_ / "full.txt", dir_ / "null.txt"});
    targets.push_back({"/dev/full", "/dev/null"});

    for (const auto& [full_node, null_node] : targets) {
        SCOPED_TRACE(full_node.string());
        const RunResult no_space = run(isolines({"-o", full_node.string()}));
        EXPECT_EQ(no_space.status, 2);
        EXPECT_TRUE(contains(no_space.err, "No space left on device")) << no_space.err;
        EXPECT_TRUE(contains(no_space.err, full_node.string())) << no_space.err;
        const RunResult discarded = run(isolines({"-o", null_node.string()}));
        EXPECT_EQ(discarded.status, 0) << discarded.err;
        // mesh and render choose the format by the name: a symlink with an extension.
        fs::remove(dir_ / "out.stl");
        fs::remove(dir_ / "out.png");
        fs::create_symlink(null_node, dir_ / "out.stl");
        fs::create_symlink(null_node, dir_ / "out.png");
        const RunResult mesh = run({"mesh", scene("thesis-map-4"), "-o", path("out.stl")});
        EXPECT_EQ(mesh.status, 0) << mesh.err;
        const RunResult render = run({"render", scene("thesis-map-4"), "--size", "64x40", "-o", path("out.png")});
        EXPECT_EQ(render.status, 0) << render.err;
        EXPECT_TRUE(fs::is_symlink(fs::symlink_status(dir_ / "out.stl")));
        EXPECT_TRUE(fs::is_symlink(fs::symlink_status(dir_ / "out.png")));
        // A regression must stop at the private nodes.
        ASSERT_TRUE(is_char_device(full_node, full)) << full_node << " was replaced";
        ASSERT_TRUE(is_char_device(null_node, null)) << null_node << " was replaced";
    }
    std::set<std::string> expected{"out.stl", "out.png"};
    if (private_nodes) expected.insert({"full.txt", "null.txt"});
    EXPECT_EQ(files(), expected);
}

TEST_F(CliOutputTest, DirectoryTargetIsRefused) {
    fs::create_directory(dir_ / "sub");
    const RunResult r = run(isolines({"-o", path("sub")}));
    EXPECT_EQ(r.status, 2);
    EXPECT_TRUE(contains(r.err, "directory")) << r.err;
    EXPECT_TRUE(fs::is_directory(dir_ / "sub"));
}

// ---------------------------------------------------------------------------------------
// Signals

TEST_F(CliOutputTest, SignalDuringMeshRemovesTheTemporaryFile) {
    for (const int signal_number : {SIGTERM, SIGINT, SIGHUP}) {
        SCOPED_TRACE(signal_number);
        const std::string output = path("big.stl");
        const pid_t pid = ::fork();
        ASSERT_GE(pid, 0);
        if (pid == 0) {
            const int devnull = ::open("/dev/null", O_RDWR);
            ::dup2(devnull, 0);
            ::dup2(devnull, 1);
            ::dup2(devnull, 2);
            // 2 million triangles: a few seconds, 100 MB of binary STL.
            ::execl(TESSREF_EXE, "tessref", "mesh", scene("thesis-constant-64").c_str(), "-o", output.c_str(),
                    "--binary", static_cast<char*>(nullptr));
            ::_exit(127);
        }
        // The temporary file exists from before the pipeline runs to the rename.
        bool temp_seen = false;
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
        while (!temp_seen && std::chrono::steady_clock::now() < deadline) {
            for (const std::string& name : files()) temp_seen |= name.starts_with(".big.stl.") && contains(name, ".tmp");
            if (!temp_seen) std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(200));  // inside the pipeline
        int status = 0;
        const bool still_running = ::waitpid(pid, &status, WNOHANG) == 0;
        ::kill(pid, signal_number);
        if (still_running) ::waitpid(pid, &status, 0);
        ASSERT_TRUE(temp_seen);
        ASSERT_TRUE(still_running) << "tessref mesh finished before the signal; the test needs a bigger scene";
        EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == signal_number) << "status " << status;
        EXPECT_EQ(files(), std::set<std::string>{});  // neither the temporary file nor a partial output
    }
}

// ---------------------------------------------------------------------------------------
// check: file names and messages

TEST_F(CliOutputTest, CheckJsonReportWithANonUtf8FileName) {
    const std::string name = "bad\xff" "name.ply";
    fs::copy_file(kSource / "tests/data/check/cube.ply", dir_ / name);
    const RunResult r = run({"check", path(name), "--json"});
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json report = nlohmann::json::parse(r.out);
    const std::string source = report.at("source");
    EXPECT_TRUE(contains(source, "bad\xEF\xBF\xBDname.ply")) << source;  // the byte as U+FFFD
}

TEST_F(CliOutputTest, CheckToleranceMessagesNameTheValueTyped) {
    const std::string cube = (kSource / "tests/data/check/cube.ply").string();
    for (const std::string value : {"-1", "nan", "inf", "-inf", "abc"}) {
        SCOPED_TRACE(value);
        const RunResult r = run({"check", cube, "--tolerance", value});
        EXPECT_EQ(r.status, 2);
        EXPECT_TRUE(contains(r.err, "'" + value + "'")) << r.err;
        EXPECT_TRUE(contains(r.err, "(--tolerance)")) << r.err;
        EXPECT_FALSE(std::regex_search(r.err, std::regex("[0-9]{20}"))) << r.err;  // no DBL_MAX spelt out
    }
    EXPECT_EQ(run({"check", cube, "--tolerance", "0"}).status, 0);
    EXPECT_EQ(run({"check", cube, "--tolerance", "1e-6"}).status, 0);
}

TEST_F(CliOutputTest, CheckImageWithoutAnExtensionIsRefusedNamingIt) {
    const RunResult r = run({"check", (kSource / "tests/data/check/cube.ply").string(), "--image", path("x")});
    EXPECT_EQ(r.status, 2);
    EXPECT_TRUE(contains(r.err, "'" + path("x") + "'")) << r.err;
    EXPECT_TRUE(contains(r.err, "(--image)")) << r.err;
    EXPECT_FALSE(contains(r.err, ".tmp")) << r.err;
    EXPECT_EQ(files(), std::set<std::string>{});
}

// ---------------------------------------------------------------------------------------
// mesh --base, tessellate without --inner

TEST_F(CliOutputTest, MeshBaseMessagesNameTheFlagAndTheValueTyped) {
    for (const std::string value : {"-inf", "inf", "nan", "abc", "1e9"}) {
        SCOPED_TRACE(value);
        const RunResult r = run({"mesh", scene("thesis-map-4"), "--solid", "--base", value, "-o", path("s.stl")});
        EXPECT_EQ(r.status, 2);
        EXPECT_TRUE(contains(r.err, "'" + value + "'")) << r.err;
        EXPECT_TRUE(contains(r.err, "(--base)")) << r.err;
        EXPECT_FALSE(contains(r.err, "base_z")) << r.err;
    }
    EXPECT_EQ(files(), std::set<std::string>{});
}

TEST_F(CliOutputTest, IsolinesWithoutInnerSayInnerWasNotGiven) {
    const RunResult text = run(isolines());
    ASSERT_EQ(text.status, 0) << text.err;
    EXPECT_FALSE(contains(text.out, "--inner")) << text.out;
    EXPECT_TRUE(contains(text.out, "# levels given: outer 2 3 1 1, inner not given")) << text.out;
    const RunResult json = run(isolines({"--format", "json"}));
    ASSERT_EQ(json.status, 0) << json.err;
    const nlohmann::json doc = nlohmann::json::parse(json.out);
    EXPECT_TRUE(doc.at("levels").at("given").at("inner").is_null());
    EXPECT_FALSE(contains(doc.at("command").get<std::string>(), "--inner"));
    // Given, it is still echoed.
    const RunResult given = run(isolines({"--inner", "5,5"}));
    EXPECT_TRUE(contains(given.out, "--inner 5,5")) << given.out;
}

// ---------------------------------------------------------------------------------------
// render memory, --max-memory

// The estimate against the peaks measured for render.cpp's comment (maximum resident set
// of `tessref render thesis-map-4 --size S -o x.png|x.exr`, MiB): per pixel, the growth
// between two sizes, which leaves out the process and the scene; 2% for measuring noise.
// It must cover what a render needs and refuse only what cannot fit (16384x16384 needed
// more than this machine's 24 GB and died).
TEST(RenderMemoryEstimate, FollowsTheMeasuredPeaks) {
    using tessref::AovSelection;
    using tessref::ImageFormat;
    using tessref::RenderMode;
    const double mib = 1024.0 * 1024.0, noise = 0.98;
    const double pixels_2048 = 2048.0 * 2048.0, pixels_4096 = 4096.0 * 4096.0;
    auto estimate = [](int side, RenderMode mode, ImageFormat format, const AovSelection& aovs = {}) {
        return static_cast<double>(tessref::estimate_render_memory({side, side}, mode, false, format, aovs));
    };
    // png: 614 MiB at 2048x2048, 2017 at 4096x4096.
    const double png_per_pixel = (2017 - 614) * mib / (pixels_4096 - pixels_2048);
    EXPECT_GE(estimate(4096, RenderMode::fill, ImageFormat::png), noise * png_per_pixel * pixels_4096);
    EXPECT_LE(estimate(4096, RenderMode::fill, ImageFormat::png), 1.10 * png_per_pixel * pixels_4096);
    EXPECT_GT(estimate(16384, RenderMode::fill, ImageFormat::png), 24.0 * 1024 * mib);
    // exr with every AOV: 627 and 2036 MiB.
    AovSelection all;
    all.depth = all.patch = all.triangle = all.tesscoord = all.level = true;
    const double exr_per_pixel = (2036 - 627) * mib / (pixels_4096 - pixels_2048);
    EXPECT_GE(estimate(4096, RenderMode::fill, ImageFormat::exr, all), noise * exr_per_pixel * pixels_4096);
    // --overlay-wireframe: 842 MiB at 2048x2048, 228 more than the plain render.
    EXPECT_GE(estimate(2048, RenderMode::fill_with_wireframe, ImageFormat::png),
              noise * (png_per_pixel * pixels_2048 + (842 - 614) * mib));
}

TEST_F(CliOutputTest, RenderRefusesAnImageBeyondTheMemoryLimitBeforeRendering) {
    // Under an address-space limit, so that a regression fails with bad_alloc instead of
    // taking the machine's memory. Not under ThreadSanitizer or AddressSanitizer, which
    // cannot start at all in 8 GB of address space (they map their shadow memory at fixed
    // ranges far beyond that).
#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
    const std::string limit = "";
#else
    const std::string limit = "ulimit -v 8000000 && ";
#endif
    std::vector<std::string> args{"-c", limit + "exec \"$0\" \"$@\"", TESSREF_EXE,
                                  "render",  scene("thesis-map-4"), "--size", "16384x16384", "-o", path("big.png")};
    const auto start = std::chrono::steady_clock::now();
    const RunResult r = run_program("/bin/sh", args, dir_);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_EQ(r.status, 2);
    EXPECT_TRUE(contains(r.err, "16384x16384 pixels needs")) << r.err;
    EXPECT_TRUE(contains(r.err, "--max-memory")) << r.err;
    EXPECT_LT(seconds, 20.0);  // the old failure came after 32 s of pipeline
    EXPECT_EQ(files(), std::set<std::string>{});
}

TEST_F(CliOutputTest, MaxMemoryBeforeAndAfterTheCommandName) {
    // 512x512: about 30 MB by the estimate; 1M refuses it, 64M lets it through.
    const std::vector<std::string> render{"render", scene("thesis-map-4"), "--size", "512x512", "-o", path("r.png")};
    auto with = [&](const std::string& limit, bool before) {
        std::vector<std::string> args = render;
        args.insert(before ? args.begin() : args.end(), {"--max-memory", limit});
        return run(args);
    };
    for (const bool before : {true, false}) {
        SCOPED_TRACE(before ? "before" : "after");
        const RunResult refused = with("1M", before);
        EXPECT_EQ(refused.status, 2);
        EXPECT_TRUE(contains(refused.err, "limit of 1.0 MiB")) << refused.err;
        const RunResult allowed = with("64M", before);
        EXPECT_EQ(allowed.status, 0) << allowed.err;
        for (const std::string bad : {"abc", "-1", "0"}) {
            const RunResult r = with(bad, before);
            EXPECT_EQ(r.status, 2) << bad;
            EXPECT_TRUE(contains(r.err, "(--max-memory)")) << r.err;
            EXPECT_TRUE(contains(r.err, "'" + bad + "'")) << r.err;
        }
    }
}

}  // namespace
