// tests/test_install.cpp — `cmake --install` gives a usable package (issue 9): the layout,
// a project outside the tree building against find_package(tessref) and running, and the
// installed executable finding its data relative to itself, never in the source tree.
//
// One install per test process into a fresh temporary prefix (ctest runs each test in its
// own process; an install copies files and takes well under a second).
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "run_program.h"

namespace {

namespace fs = std::filesystem;
using tessref::test::read_file;
using tessref::test::run_program;
using tessref::test::RunResult;

const fs::path kSource = TESSREF_SOURCE_DIR;
const std::string kScene = "thesis-constant-1.toml";

class Install : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        root_ = fs::temp_directory_path() / ("tessref_test_install_" + std::to_string(::getpid()));
        fs::remove_all(root_);
        fs::create_directories(root_);
        prefix_ = root_ / "prefix";
        install_ = run_program(TESSREF_CMAKE_COMMAND, {"--install", TESSREF_BUILD_DIR, "--prefix", prefix_.string()},
                               root_);
    }
    static void TearDownTestSuite() { fs::remove_all(root_); }

    void SetUp() override { ASSERT_EQ(install_.status, 0) << install_.out << install_.err; }

    // `tessref gl` on a shipped scene with TESSREF_DATA_DIR unset (or set to `data_dir`).
    static RunResult gl(const fs::path& exe, const fs::path& scene, const fs::path& out,
                        const std::string& data_dir = {}) {
        std::vector<std::string> args = {"-u", "TESSREF_DATA_DIR"};
        if (!data_dir.empty()) args.push_back("TESSREF_DATA_DIR=" + data_dir);
        for (const std::string a : {exe.string(), std::string("gl"), scene.string(), std::string("-o"), out.string(),
                                    std::string("--size"), std::string("64x40")})
            args.push_back(a);
        return run_program("env", args, root_);
    }

    static inline fs::path root_, prefix_;
    static inline RunResult install_;
};

TEST_F(Install, LaysOutBinLibIncludeShareAndThePackage) {
    for (const char* file : {"bin/tessref", "lib/libtessref.a", "lib/tessref/tessref_oiio.so", "include/tessref/scene.h",
                             "include/tessref/tessellator.h", "share/tessref/shaders/capture_tess_coord.tesc",
                             "share/tessref/scenes/thesis-constant-1.toml", "share/tessref/heightmaps/thesis-island.pgm",
                             "share/tessref/LICENSES.md", "lib/cmake/tessref/tessrefConfig.cmake",
                             "lib/cmake/tessref/tessrefConfigVersion.cmake", "lib/cmake/tessref/tessrefTargets.cmake"})
        EXPECT_TRUE(fs::is_regular_file(prefix_ / file)) << file;
    // Every public header and every file of data/, none left behind.
    for (const auto& e : fs::directory_iterator(kSource / "include" / "tessref"))
        EXPECT_TRUE(fs::is_regular_file(prefix_ / "include" / "tessref" / e.path().filename())) << e.path();
    for (const auto& e : fs::recursive_directory_iterator(kSource / "data"))
        if (e.is_regular_file())
            EXPECT_TRUE(fs::is_regular_file(prefix_ / "share" / "tessref" / fs::relative(e.path(), kSource / "data")))
                << e.path();
    // The package is relocatable: nothing in it names the source or build tree.
    for (const auto& e : fs::directory_iterator(prefix_ / "lib" / "cmake" / "tessref"))
        EXPECT_EQ(read_file(e.path()).find(kSource.string()), std::string::npos) << e.path();
}

// A project outside the tree: find_package(tessref), tessref::tessref, nothing else.
TEST_F(Install, ConsumerProjectBuildsAgainstThePackageAndRuns) {
    const fs::path src = root_ / "consumer", build = root_ / "consumer-build";
    fs::copy(kSource / "tests" / "install" / "consumer", src, fs::copy_options::recursive);
    const RunResult configure =
        run_program(TESSREF_CMAKE_COMMAND,
                    {"-S", src.string(), "-B", build.string(), "-G", TESSREF_CMAKE_GENERATOR,
                     std::string("-DCMAKE_MAKE_PROGRAM=") + TESSREF_CMAKE_MAKE_PROGRAM,
                     std::string("-DCMAKE_CXX_COMPILER=") + TESSREF_CXX_COMPILER,
                     "-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON",
                     "-DCMAKE_PREFIX_PATH=" + prefix_.string()},
                    root_);
    ASSERT_EQ(configure.status, 0) << configure.out << configure.err;
    const RunResult compile = run_program(TESSREF_CMAKE_COMMAND, {"--build", build.string()}, root_);
    ASSERT_EQ(compile.status, 0) << compile.out << compile.err;

    // No -I, -L or library path into the source or build tree on any compile or link line.
    const std::string commands = read_file(build / "compile_commands.json");
    ASSERT_NE(commands.find(prefix_.string() + "/include"), std::string::npos) << commands;
    EXPECT_EQ(commands.find(kSource.string()), std::string::npos) << commands;
    if (fs::exists(build / "build.ninja"))
        EXPECT_EQ(read_file(build / "build.ninja").find(kSource.string()), std::string::npos);

    // Its own binary is not in the prefix's bin/, so it is pointed at the data, as the
    // package's tessref_DATA_DIR tells a CMake user to.
    const RunResult run = run_program(
        "env", {"TESSREF_DATA_DIR=" + (prefix_ / "share" / "tessref").string(), (build / "consumer").string()}, root_);
    EXPECT_EQ(run.status, 0) << run.out << run.err;
    EXPECT_NE(run.out.find("consumer: ok"), std::string::npos) << run.out << run.err;
}

// The installed tree moved elsewhere still finds its shaders, ../share/tessref beside bin/,
// and its OpenImageIO module, ../lib/tessref/tessref_oiio.so (an EXR needs it).
TEST_F(Install, MovedInstalledExecutableFindsItsDataBesideItself) {
    const fs::path moved = root_ / "moved";
    fs::create_directories(moved);
    fs::copy(prefix_ / "bin", moved / "bin", fs::copy_options::recursive);
    fs::copy(prefix_ / "share", moved / "share", fs::copy_options::recursive);
    fs::copy(prefix_ / "lib", moved / "lib", fs::copy_options::recursive);
    const fs::path out = root_ / "moved.png";
    const RunResult r = gl(moved / "bin" / "tessref", moved / "share" / "tessref" / "scenes" / kScene, out);
    EXPECT_EQ(r.status, 0) << r.out << r.err;
    EXPECT_TRUE(fs::is_regular_file(out));
    const fs::path exr = root_ / "moved.exr";
    const RunResult e = run_program("env", {"-u", "TESSREF_OIIO_MODULE", "-u", "TESSREF_DATA_DIR", (moved / "bin" / "tessref").string(),
                                            "render", (moved / "share" / "tessref" / "scenes" / kScene).string(), "-o",
                                            exr.string(), "--size", "64x40"},
                                    root_);
    EXPECT_EQ(e.status, 0) << e.out << e.err;
    EXPECT_TRUE(fs::is_regular_file(exr));
}

// Without its share/, the installed executable does not fall back to the source tree's
// data/ (which exists, and which the scene itself comes from): it names where it looked.
TEST_F(Install, InstalledExecutableWithoutItsDataNamesThePlacesSearched) {
    const fs::path bare = root_ / "bare";
    fs::create_directories(bare);
    fs::copy(prefix_ / "bin", bare / "bin", fs::copy_options::recursive);
    const fs::path out = root_ / "bare.png";
    const RunResult r = gl(bare / "bin" / "tessref", kSource / "data" / "scenes" / kScene, out);
    EXPECT_EQ(r.status, 2) << r.out << r.err;
    EXPECT_NE(r.err.find("tessref: error: cannot find tessref's data directory"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("TESSREF_DATA_DIR (unset)"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find((bare / "share" / "tessref").string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find((bare / "bin" / "tessref-data").string()), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));

    // TESSREF_DATA_DIR still overrides the lookup.
    const RunResult with = gl(bare / "bin" / "tessref", kSource / "data" / "scenes" / kScene, out,
                              (prefix_ / "share" / "tessref").string());
    EXPECT_EQ(with.status, 0) << with.out << with.err;
    EXPECT_TRUE(fs::is_regular_file(out));
}

// The build tree's executable keeps using the source data/ (through build/tessref-data).
TEST_F(Install, BuildTreeExecutableFindsTheSourceData) {
    EXPECT_TRUE(fs::equivalent(fs::path(TESSREF_BUILD_DIR) / "tessref-data", kSource / "data"));
    const fs::path out = root_ / "build-tree.png";
    const RunResult r = gl(TESSREF_EXE, kSource / "data" / "scenes" / kScene, out);
    EXPECT_EQ(r.status, 0) << r.out << r.err;
    EXPECT_TRUE(fs::is_regular_file(out));
}

}  // namespace
