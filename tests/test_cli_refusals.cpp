// The `tessref` command's answers to hostile input that cuts across commands (issue 28,
// "Medium" and "Low"): an environment variable that is not a size, a report written into a
// full disk, file names that are not UTF-8, names as long as the file system allows, hex
// where decimal is meant. Each case states what must hold and runs the built binary
// (TESSREF_EXE) in a directory of its own.
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "command_dir_test.h"
#include "run_program.h"

namespace fs = std::filesystem;
using tessref::test::read_file;
using tessref::test::RunResult;
using tessref::test::shell_quote;
using tessref::test::write_file;

namespace {

const std::string kScenes = std::string(TESSREF_SOURCE_DIR) + "/data/scenes";
const std::string kScene = kScenes + "/thesis-map-4.toml";

class CliRefusals : public tessref::test::CommandDirTest {
protected:
    // Runs `prefix tessref args... suffix` through the shell (for an environment variable
    // or a redirection the common runner does not take), stdout and stderr captured.
    RunResult shell(const std::string& prefix, const std::vector<std::string>& args, const std::string& redirect_out = {}) {
        std::string command = "cd " + shell_quote(dir_.string()) + " && " + prefix + " " + shell_quote(TESSREF_EXE);
        for (const std::string& a : args) command += " " + shell_quote(a);
        const fs::path out = dir_ / "captured.stdout", err = dir_ / "captured.stderr";
        command += " >" + (redirect_out.empty() ? shell_quote(out.string()) : redirect_out) + " 2>" +
                   shell_quote(err.string()) + " </dev/null";
        const int raw = std::system(command.c_str());
        RunResult r;
        r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
        r.out = read_file(out);
        r.err = read_file(err);
        fs::remove(out);
        fs::remove(err);
        return r;
    }
    // tessref ARGS run inside the test's directory (relative names are its files).
    RunResult run(const std::vector<std::string>& args) {
        return tessref::test::run_program(TESSREF_EXE, args, dir_, dir_);
    }
    // Two 8x6 RGBA PNGs through `tessref render`, small and quick: the same scene twice.
    void two_pngs(const std::string& a, const std::string& b) {
        ASSERT_EQ(run({"render", kScene, "-o", path(a), "--size", "8x6"}).status, 0);
        fs::copy_file(path(a), path(b));
    }
};

TEST_F(CliRefusals, AnInvalidMaxMemoryEnvironmentIsRefusedAsTheFlagIs) {
    for (const std::string value : {"abc", "0", "-1", "1e400", "12Q"}) {
        const RunResult r = shell("TESSREF_MAX_MEMORY=" + shell_quote(value), {"render", kScene, "-o", "x.png", "--size", "8x6"});
        EXPECT_EQ(r.status, 2) << value << ": " << r.err;
        EXPECT_NE(r.err.find("TESSREF_MAX_MEMORY"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("'" + value + "'"), std::string::npos) << r.err;
        EXPECT_FALSE(fs::exists(dir_ / "x.png")) << value;
    }
    const RunResult ok = shell("TESSREF_MAX_MEMORY=2G", {"render", kScene, "-o", "x.png", "--size", "8x6"});
    EXPECT_EQ(ok.status, 0) << ok.err;
}

// TESSREF_SIMD (common/simd.h) names a SIMD level the CPU runs, or the command refuses it
// before any work; sse2 every x86-64 CPU runs, and it gives the default's image.
TEST_F(CliRefusals, AnUnknownSimdLevelIsRefused) {
    for (const std::string value : {"avx512", "SSE2", "neon", "avx2 "}) {
        const RunResult r = shell("TESSREF_SIMD=" + shell_quote(value), {"render", kScene, "-o", "x.png", "--size", "8x6"});
        EXPECT_EQ(r.status, 2) << value << ": " << r.err;
        EXPECT_EQ(r.err.rfind("tessref: error: '" + value + "' is not a SIMD level (sse2 or avx2) (TESSREF_SIMD)", 0), 0u)
            << r.err;
        EXPECT_FALSE(fs::exists(dir_ / "x.png")) << value;
    }
    const RunResult base = shell("TESSREF_SIMD=sse2", {"render", kScene, "-o", "x.png", "--size", "8x6"});
    ASSERT_EQ(base.status, 0) << base.err;
    ASSERT_EQ(run({"render", kScene, "-o", path("y.png"), "--size", "8x6"}).status, 0);
    EXPECT_EQ(read_file(dir_ / "x.png"), read_file(dir_ / "y.png"));
}

// A report that cannot be delivered is not a success: stdout into /dev/full is exit 2 with a
// message, whatever the command would have returned.
TEST_F(CliRefusals, AReportIntoAFullDiskIsExitTwo) {
    two_pngs("a.png", "b.png");
    const std::string mesh = std::string(TESSREF_SOURCE_DIR) + "/tests/data/check/cube.off";
    const std::vector<std::vector<std::string>> commands{
        {"--help"},
        {"--version"},
        {"compare", "--help"},
        {"compare", "a.png", "b.png", "--json"},
        {"compare", "a.png", "b.png"},
        {"check", mesh, "--json", "--no-probe"},
        {"inspect", kScene, "--pixel", "4,3", "--size", "8x6", "--json"},
    };
    for (const auto& args : commands) {
        const RunResult r = shell("", args, "/dev/full");
        EXPECT_EQ(r.status, 2) << args[0] << " " << args.back() << ": " << r.err;
        EXPECT_NE(r.err.find("tessref: error: cannot write to stdout"), std::string::npos) << r.err;
    }
}

// JSON strings are UTF-8 and a Linux file name is any bytes: the name is escaped (\xNN for
// a byte outside UTF-8), the report stays JSON, and no --diff picture is left on an error.
TEST_F(CliRefusals, NonUtf8FileNamesInJsonReportsAreEscaped) {
    const std::string a = "a\xff\xfe.png", b = "b\xc3\xa9.png";  // invalid bytes; a valid "é"
    two_pngs(a, b);
    const RunResult r = run({"compare", a, b, "--json", "--diff", "d\xff.png"});
    ASSERT_EQ(r.status, 0) << r.err;
    ASSERT_TRUE(nlohmann::json::accept(r.out)) << r.out;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["reference"], "a\\xFF\\xFE.png");
    EXPECT_EQ(j["test"], "b\xc3\xa9.png");
    EXPECT_EQ(j["diff"], "d\\xFF.png");
    EXPECT_TRUE(fs::exists(dir_ / "d\xff.png"));
}

TEST_F(CliRefusals, LevelsInHexAreRefusedAsOtherFlagsRefuseHex) {
    for (const std::string levels : {"0x10", "0X4", "1,0x2", "0x1..0x4"}) {
        const RunResult r = run({"sweep", kScene, "-o", "out", "--levels", levels, "--size", "8x6"});
        EXPECT_EQ(r.status, 2) << levels << ": " << r.err;
        EXPECT_NE(r.err.find("--levels"), std::string::npos) << r.err;
        EXPECT_FALSE(fs::exists(dir_ / "out"));
    }
    const RunResult e = run({"sweep", kScene, "-o", "out", "--error-bounds", "0x1", "--size", "8x6"});
    EXPECT_EQ(e.status, 2) << e.err;
    EXPECT_NE(e.err.find("--error-bounds"), std::string::npos) << e.err;
}

// A name the file system takes (up to NAME_MAX, 255 bytes) must be writable: the temporary
// name beside it must not be longer than the name itself allows.
TEST_F(CliRefusals, OutputNamesUpToTheFileSystemsLimitAreWritten) {
    const long name_max = ::pathconf(dir_.c_str(), _PC_NAME_MAX);
    ASSERT_GE(name_max, 250);
    for (const std::size_t length : {235, 245, 250, static_cast<int>(name_max)}) {
        const std::string name = std::string(length - 4, 'n') + ".png";
        const RunResult r = run({"render", kScene, "-o", name, "--size", "8x6"});
        EXPECT_EQ(r.status, 0) << length << ": " << r.err;
        EXPECT_TRUE(fs::is_regular_file(dir_ / name)) << length;
        fs::remove(dir_ / name);
        EXPECT_TRUE(files().empty()) << length << ": left " << *files().begin();
    }
}

// tessref's TIFFs name their fourth channel as alpha (unassociated, as the PNG's is), so
// that --ignore-alpha finds it.
TEST_F(CliRefusals, TiffAlphaIsMarkedSoIgnoreAlphaIgnoresIt) {
    ASSERT_EQ(run({"render", kScene, "-o", "a.tif", "--size", "8x6"}).status, 0);
    const RunResult r = run({"compare", "a.tif", "a.tif", "--ignore-alpha", "--json"});
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["channels"], nlohmann::json({"R", "G", "B"})) << r.out;
}

// An allocation that fails where no estimate caught it says which run failed, how much the
// process held and what the limit is, not a bare "out of memory". (Under a sanitizer, whose
// shadow memory needs more address space than the cap allows, it cannot run.)
TEST_F(CliRefusals, OutOfMemorySaysWhatAndWhere) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
    GTEST_SKIP() << "address space capped: not under a sanitizer";
#endif
    // 1.5 GB of address space, a 16384 x 16384 picture (some GB) allowed by --max-memory.
    const RunResult r = shell("ulimit -v 1500000;", {"render", kScene, "-o", "big.png", "--size", "16384x16384",
                                                     "--max-memory", "100G"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find("tessref: error: out of memory: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("in use"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("the limit on what inputs ask for is 100 GiB"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("(tessref render "), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "big.png"));
    EXPECT_TRUE(files().empty());
}

// A write that the disk refuses (full, or past the file size limit: RLIMIT_FSIZE stands in
// for a full disk here, without root or a small file system) is exit 2 with the reason, and
// the message names the file the user asked for, never the temporary name the bytes were
// going to; nothing is left behind. SIGXFSZ is ignored, so the write fails with EFBIG.
TEST_F(CliRefusals, AWriteTheDiskRefusesNamesTheUsersFileAndTheReason) {
    struct Case {
        std::vector<std::string> args;
        std::string named;  // what the message must name
    };
    const std::vector<Case> cases{
        {{"render", kScene, "-o", "x.png", "--size", "640x400"}, "x.png"},
        {{"render", kScene, "-o", "x.exr", "--size", "640x400"}, "x.exr"},
        {{"mesh", kScene, "-o", "x.ply"}, "x.ply"},
        {{"mesh", kScene, "-o", "x.obj"}, "x.obj"},
        {{"mesh", kScene, "-o", "y.ply", "--capture", "c.txt"}, "c.txt"},
        {{"sweep", kScene, "-o", "sw", "--levels", "1,2", "--size", "64x40"}, "sw/"},
    };
    for (const Case& c : cases) {
        const RunResult r = shell("trap '' XFSZ; ulimit -f 16;", c.args);
        EXPECT_EQ(r.status, 2) << c.named << ": " << r.err;
        EXPECT_NE(r.err.find("File too large"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find(c.named), std::string::npos) << r.err;
        EXPECT_EQ(r.err.find(".tmp"), std::string::npos) << r.err;
        EXPECT_TRUE(files().empty()) << c.named << ": left " << *files().begin();
    }
}

}  // namespace
