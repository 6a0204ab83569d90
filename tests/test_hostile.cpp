// tests/test_hostile.cpp — hostile input against the commands added last (gl with a user's
// shader, golden, sweep, compare), the cases of issue 28's "High" list: each one crashed,
// hung, ran out of memory or destroyed a user's file. Every case runs the built tessref
// under `timeout` (a regression that hangs fails instead of stopping the suite) and, where
// the old failure was memory, under an address-space cap (`prlimit --as`), so that a
// regression crashes rather than exhausting the machine.
//
// TESSREF_TEST_EXE, when set, runs the cases against another tessref (an older build, to see
// them fail there).
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <zlib.h>

#include <gtest/gtest.h>

#include "command_dir_test.h"
#include "run_program.h"

namespace fs = std::filesystem;

namespace tessref::test {
namespace {

const std::string kData = TESSREF_DATA_DIR;
const std::string kScene = kData + "/scenes/thesis-all-10.toml";

std::string exe() {
    const char* other = std::getenv("TESSREF_TEST_EXE");
    return other && *other ? other : TESSREF_EXE;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

class Hostile : public CommandDirTest {
protected:
    // tessref `args` in the test directory, killed after `seconds`, with `env` ("NAME=value")
    // and at most `address_space` bytes of it (0: no cap).
    RunResult tessref(const std::vector<std::string>& args, int seconds = 60, const std::vector<std::string>& env = {},
                      std::uint64_t address_space = 0) {
        std::vector<std::string> command = {std::to_string(seconds)};
#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
        // The sanitizers cannot start in a few GB of address space (their shadow memory is
        // mapped at fixed ranges far beyond); the limits under test are tessref's own.
        address_space = 0;
#endif
        if (address_space) {
            command.push_back("prlimit");
            command.push_back("--as=" + std::to_string(address_space));
        }
        command.push_back("env");
        for (const std::string& e : env) command.push_back(e);
        command.push_back(exe());
        for (const std::string& a : args) command.push_back(a);
        return run_program("timeout", command, dir_, dir_);
    }
    // The names in the directory that a command left behind (temporary files start with '.').
    std::vector<std::string> leftovers() const {
        std::vector<std::string> names;
        for (const auto& entry : fs::directory_iterator(dir_))
            if (entry.path().filename().string().front() == '.') names.push_back(entry.path().filename().string());
        return names;
    }
    // A directory of its own holding a copy of the thesis map scene and its files, so that an
    // output can be aimed at them.
    std::string copied_map_scene() {
        for (const char* sub : {"scenes", "textures", "heightmaps", "tessmaps"}) fs::create_directories(dir_ / "sc" / sub);
        fs::copy_file(kData + "/scenes/thesis-map-4.toml", dir_ / "sc/scenes/thesis-map-4.toml");
        fs::copy_file(kData + "/textures/thesis-island-colour.png", dir_ / "sc/textures/thesis-island-colour.png");
        fs::copy_file(kData + "/heightmaps/thesis-island.pgm", dir_ / "sc/heightmaps/thesis-island.pgm");
        fs::copy_file(kData + "/tessmaps/thesis-roads.pgm", dir_ / "sc/tessmaps/thesis-roads.pgm");
        return path("sc/scenes/thesis-map-4.toml");
    }
};

// An 8-bit RGBA PNG of one colour, written with zlib (the suite's own encoder, not tessref's).
void write_flat_png(const fs::path& path, int width, int height) {
    auto be32 = [](std::string& out, std::uint32_t v) {
        for (int s = 24; s >= 0; s -= 8) out += static_cast<char>((v >> s) & 0xff);
    };
    auto chunk = [&](std::string& out, const char* type, const std::string& data) {
        be32(out, static_cast<std::uint32_t>(data.size()));
        const std::string body = std::string(type, 4) + data;
        out += body;
        be32(out, static_cast<std::uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(body.data()), static_cast<uInt>(body.size()))));
    };
    std::string raw;
    const std::string row = std::string(1, '\0') + std::string(static_cast<std::size_t>(width) * 4, '\x40');
    for (int y = 0; y < height; ++y) raw += row;
    uLongf packed_size = compressBound(static_cast<uLong>(raw.size()));
    std::string packed(packed_size, '\0');
    compress2(reinterpret_cast<Bytef*>(packed.data()), &packed_size, reinterpret_cast<const Bytef*>(raw.data()),
              static_cast<uLong>(raw.size()), 9);
    packed.resize(packed_size);
    std::string header;
    be32(header, static_cast<std::uint32_t>(width));
    be32(header, static_cast<std::uint32_t>(height));
    header += std::string("\x08\x06\x00\x00\x00", 5);
    std::string png = "\x89PNG\r\n\x1a\n";
    chunk(png, "IHDR", header);
    chunk(png, "IDAT", packed);
    chunk(png, "IEND", "");
    write_file(path, png);
}

// ---- 1. the GL backend in a child process ------------------------------------------------

const char* const kHugeArrayShader =
    "#version 450 core\nlayout(location=0) out vec4 f;\nuniform float scaleZ;\n"
    "void main(){float a[2147483647];a[int(scaleZ)]=1.0;f=vec4(a[int(scaleZ)+1]);}\n";

TEST_F(Hostile, UserShaderThatExhaustsMemoryIsAnErrorNamingItNotACrash) {
    write_file(dir_ / "arr.frag", kHugeArrayShader);
    const auto r = tessref({"gl", kScene, "-o", "o.png", "--size", "64x40", "--shader", "frag=arr.frag"}, 120,
                           {"TESSREF_MAX_MEMORY=1G"}, std::uint64_t{6} << 30);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "tessref: error: ")) << r.err;
    EXPECT_TRUE(contains(r.err, "arr.frag")) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "o.png"));
    EXPECT_TRUE(leftovers().empty()) << leftovers().front();
}

TEST_F(Hostile, UserShaderThatRunsPastTheTimeLimitIsKilled) {
    write_file(dir_ / "loop.frag",
               "#version 450 core\nlayout(location=0) out vec4 f;\nuniform float scaleZ;\n"
               "void main(){float x=0.0;for(int i=0;i<60000;i++)for(int j=0;j<60000;j++)for(int k=0;k<60000;k++)"
               "x+=sin(x+float(k)*scaleZ);f=vec4(x);}\n");
    const auto start = std::chrono::steady_clock::now();
    const auto r = tessref({"gl", kScene, "-o", "o.png", "--size", "64x40", "--shader", "frag=loop.frag",
                            "--capture", "c.txt"},
                           40, {"TESSREF_GL_TIME_LIMIT=2"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "time limit of 2 s")) << r.err;
    EXPECT_TRUE(contains(r.err, "loop.frag")) << r.err;
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 30.0);
    EXPECT_FALSE(fs::exists(dir_ / "o.png"));
    EXPECT_FALSE(fs::exists(dir_ / "c.txt"));
    EXPECT_TRUE(leftovers().empty()) << leftovers().front();
}

TEST_F(Hostile, DriverCrashCreatingTheContextIsAnError) {
    const auto r = tessref({"gl", kScene, "-o", "x.png", "--size", "64x40"}, 60, {"MESA_GLSL_VERSION_OVERRIDE=110"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "OSMesa context")) << r.err;
    EXPECT_TRUE(leftovers().empty()) << leftovers().front();
}

TEST_F(Hostile, InvalidGlTimeLimitIsRefused) {
    const auto r = tessref({"gl", kScene, "-o", "x.png", "--size", "64x40"}, 60, {"TESSREF_GL_TIME_LIMIT=abc"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "TESSREF_GL_TIME_LIMIT")) << r.err;
}

TEST_F(Hostile, NulByteInAShaderIsRefusedNotTruncated) {
    write_file(dir_ / "nul.frag", std::string("#version 450 core\nlayout(location=0) out vec4 f;\n"
                                              "void main(){f=vec4(1.0);}\n\0garbage that GL never sees\n",
                                              100));
    const auto r = tessref({"gl", kScene, "-o", "x.png", "--size", "64x40", "--shader", "frag=nul.frag"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "NUL byte")) << r.err;
    EXPECT_TRUE(contains(r.err, "nul.frag:4")) << r.err;
}

// The messages of a user's shader that GL refuses at the draw name the file.
TEST_F(Hostile, IsolinesEvaluationShaderErrorNamesTheFile) {
    std::string tese = read_file(std::string(TESSREF_SOURCE_DIR) + "/tests/data/gl/raised.tese");
    const std::size_t at = tese.find("layout(quads,");
    ASSERT_NE(at, std::string::npos);
    tese.replace(at, 13, "layout(isolines,");
    write_file(dir_ / "lines.tese", tese);
    const auto r = tessref({"gl", kScene, "-o", "x.png", "--size", "64x40", "--shader", "tese=lines.tese"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "GL_INVALID_OPERATION")) << r.err;
    EXPECT_TRUE(contains(r.err, "lines.tese")) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "x.png"));
}

// ---- 2. every text input: regular files only, a size cap ---------------------------------

TEST_F(Hostile, FifoAndDeviceAsSceneAreRefusedAtOnce) {
    ASSERT_EQ(::mkfifo(path("p").c_str(), 0600), 0);
    for (const std::string scene : {path("p"), std::string("/dev/zero")}) {
        const auto r = tessref({"render", scene, "-o", "x.png"}, 20);
        EXPECT_EQ(r.status, 2) << scene << ": " << r.err;
        EXPECT_TRUE(contains(r.err, "not a regular file")) << r.err;
        EXPECT_TRUE(contains(r.err, scene)) << r.err;
    }
}

TEST_F(Hostile, SceneLargerThanItsCapIsRefusedBeforeReading) {
    write_file(dir_ / "big.toml", "");
    fs::resize_file(dir_ / "big.toml", std::uintmax_t{17} << 20);  // 17 MiB of zeros
    const auto r = tessref({"mesh", "big.toml", "-o", "x.ply"}, 20);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "more than a scene file may be")) << r.err;
}

TEST_F(Hostile, FifoAsShaderIsRefused) {
    ASSERT_EQ(::mkfifo(path("s.frag").c_str(), 0600), 0);
    const auto r = tessref({"gl", kScene, "-o", "x.png", "--size", "64x40", "--shader", "frag=s.frag"}, 20);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "not a regular file")) << r.err;
    EXPECT_TRUE(contains(r.err, "s.frag")) << r.err;
}

TEST_F(Hostile, FifoAsAShardsSweepJsonIsRefused) {
    fs::create_directories(dir_ / "sh");
    ASSERT_EQ(::mkfifo(path("sh/sweep.json").c_str(), 0600), 0);
    write_file(dir_ / "sh/sweep.csv", "scene\n");
    const auto r = tessref({"sweep", "merge", "sh", "sh", "-o", "m"}, 20);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "not a regular file")) << r.err;
}

TEST_F(Hostile, FifoAsGoldenCaptureIsRefused) {
    fs::create_directories(dir_ / "golden/thesis-all-10");
    ASSERT_EQ(::mkfifo(path("golden/thesis-all-10/capture.txt").c_str(), 0600), 0);
    const auto r = tessref({"golden", "verify", "thesis-all-10", "--golden", "golden", "--scenes", kData + "/scenes"}, 20);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "not a regular file")) << r.err;
}

// ---- 3. deep TOML nesting ----------------------------------------------------------------

TEST_F(Hostile, DeepTomlNestingIsAnErrorNotAStackOverflow) {
    const int n = 50000;
    std::string dots;
    for (int i = 0; i < n; ++i) dots += i ? ".a" : "a";
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"table", "[" + dots + "]\n"},
        {"dotted key", dots + " = 1\n"},
        {"arrays", "a = " + std::string(n, '[') + std::string(n, ']') + "\n"},
        {"inline tables", [&] {
             std::string s = "a = ";
             for (int i = 0; i < n; ++i) s += "{b=";
             return s + "1" + std::string(n, '}') + "\n";
         }()},
    };
    for (const auto& [name, text] : cases) {
        write_file(dir_ / "d.toml", text);
        const auto r = tessref({"mesh", "d.toml", "-o", "x.ply"}, 30);
        EXPECT_EQ(r.status, 2) << name << ": " << r.err;
        EXPECT_TRUE(contains(r.err, "nests deeper than 64 levels")) << name << ": " << r.err;
        EXPECT_TRUE(contains(r.err, "d.toml:1:")) << name << ": " << r.err;
    }
    // Nesting within the limit is not refused for its depth (here: not a scene).
    write_file(dir_ / "d.toml", "[a.b.c]\nd.e = [[1, 2], {f = [3]}]\n");
    const auto ok = tessref({"mesh", "d.toml", "-o", "x.ply"}, 30);
    EXPECT_FALSE(contains(ok.err, "nests deeper")) << ok.err;
}

// ---- 4. sweep -o replaces only an earlier sweep ------------------------------------------

TEST_F(Hostile, SweepDoesNotReplaceADirectoryThatMerelyHoldsASweepJson) {
    fs::create_directories(dir_ / "d");
    write_file(dir_ / "d/precious.txt", "keep\n");
    write_file(dir_ / "d/sweep.json", "");
    const auto r = tessref({"sweep", kScene, "-o", "d", "--levels", "1", "--size", "32x20"}, 120);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_EQ(read_file(dir_ / "d/precious.txt"), "keep\n");
    // A real sweep's directory with a user's file added is not a sweep's either.
    fs::remove_all(dir_ / "d");
    ASSERT_EQ(tessref({"sweep", kScene, "-o", "d", "--levels", "1", "--size", "32x20"}, 120).status, 0);
    write_file(dir_ / "d/images/notes.txt", "mine\n");
    const auto again = tessref({"sweep", kScene, "-o", "d", "--levels", "1", "--size", "32x20"}, 120);
    EXPECT_EQ(again.status, 2) << again.err;
    EXPECT_TRUE(contains(again.err, "notes.txt")) << again.err;
    EXPECT_EQ(read_file(dir_ / "d/images/notes.txt"), "mine\n");
    // Without it, the earlier sweep is replaced.
    fs::remove(dir_ / "d/images/notes.txt");
    EXPECT_EQ(tessref({"sweep", kScene, "-o", "d", "--levels", "1", "--size", "32x20"}, 120).status, 0);
}

// ---- 5. --max-memory per command ---------------------------------------------------------

TEST_F(Hostile, CompareAsksForBothImagesAtOnce) {
    // 2048 x 2048 RGBA 8-bit: 80 MiB each as codes and floats; both with the mask: 164 MiB.
    write_flat_png(dir_ / "a.png", 2048, 2048);
    write_flat_png(dir_ / "b.png", 2048, 2048);
    const auto r = tessref({"compare", "a.png", "b.png", "--max-memory", "120M"}, 60);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "comparing two images of 2048 x 2048 pixels needs")) << r.err;
    const auto diff = tessref({"compare", "a.png", "b.png", "--max-memory", "200M", "--diff", "d.png"}, 60);
    EXPECT_EQ(diff.status, 2) << diff.err;
    EXPECT_TRUE(contains(diff.err, "and writing their diff")) << diff.err;
    EXPECT_FALSE(fs::exists(dir_ / "d.png"));
    EXPECT_EQ(tessref({"compare", "a.png", "b.png", "--max-memory", "200M"}, 60).status, 0);
}

TEST_F(Hostile, GoldenVerifyAsksForTheSizeItsGoldenSays) {
    fs::create_directories(dir_ / "golden");
    fs::copy(std::string(TESSREF_SOURCE_DIR) + "/golden/jacksboro", dir_ / "golden/jacksboro");
    std::string capture = read_file(dir_ / "golden/jacksboro/capture.txt");
    const std::size_t at = capture.find("\nsize 320x200\n");
    ASSERT_NE(at, std::string::npos);
    capture.replace(at, 14, "\nsize 16384x16384\n");
    write_file(dir_ / "golden/jacksboro/capture.txt", capture);
    const auto r = tessref({"golden", "verify", "jacksboro", "--golden", "golden", "--scenes", kData + "/scenes",
                            "--max-memory", "4G"},
                           60, {}, std::uint64_t{8} << 30);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "verifying a golden image of 16384x16384 pixels needs")) << r.err;
}

// ---- 6. magic bytes first ----------------------------------------------------------------

TEST_F(Hostile, ZeroFilledImageIsRefusedByItsFirstBytes) {
    write_file(dir_ / "z.png", "");
    fs::resize_file(dir_ / "z.png", std::uintmax_t{256} << 20);
    write_flat_png(dir_ / "ref.png", 4, 4);
    const auto start = std::chrono::steady_clock::now();
    const auto r = tessref({"compare", "z.png", "ref.png"}, 60, {}, std::uint64_t{2} << 30);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "its first bytes are no image format")) << r.err;
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 10.0);
    // The same for a height map a scene names.
    const std::string scene = copied_map_scene();
    write_file(dir_ / "sc/heightmaps/thesis-island.pgm", "");
    fs::resize_file(dir_ / "sc/heightmaps/thesis-island.pgm", std::uintmax_t{64} << 20);
    const auto map = tessref({"render", scene, "-o", "x.png", "--size", "32x20"}, 60);
    EXPECT_EQ(map.status, 2) << map.err;
    EXPECT_TRUE(contains(map.err, "its first bytes are no image format")) << map.err;
}

// A valid signature or magic followed by a gigabyte of zeros: refused at its first bytes
// after the magic, without walking or reading the rest (the walk took minutes 12 bytes at a
// time; the PNM reader read the whole file before its header). The memory cap is far below
// the file's size.
TEST_F(Hostile, AGigabyteBehindAValidMagicIsNotRead) {
    write_flat_png(dir_ / "ref.png", 4, 4);
    write_file(dir_ / "sig.png", std::string("\x89PNG\r\n\x1a\n", 8));
    fs::resize_file(dir_ / "sig.png", std::uintmax_t{1} << 30);
    const auto png = tessref({"compare", "sig.png", "ref.png"}, 60, {}, std::uint64_t{512} << 20);
    EXPECT_EQ(png.status, 2) << png.err;
    EXPECT_TRUE(contains(png.err, "the bytes at 8 ('?\?\?\?') are no chunk type")) << png.err;

    // The first chunk of a PNG is IHDR.
    write_file(dir_ / "text.png", std::string("\x89PNG\r\n\x1a\n\0\0\0\0tEXt\0\0\0\0", 20));
    const auto first = tessref({"compare", "text.png", "ref.png"}, 60);
    EXPECT_EQ(first.status, 2) << first.err;
    EXPECT_TRUE(contains(first.err, "its first chunk is 'tEXt', not IHDR")) << first.err;

    for (const std::string& magic : {std::string("P5 "), std::string("P2\n# a comment\n")}) {
        write_file(dir_ / "big.pgm", magic);
        fs::resize_file(dir_ / "big.pgm", std::uintmax_t{1} << 30);
        const auto pnm = tessref({"compare", "big.pgm", "ref.png"}, 60, {}, std::uint64_t{512} << 20);
        EXPECT_EQ(pnm.status, 2) << pnm.err;
        EXPECT_TRUE(contains(pnm.err, "its PGM header does not end within its first 64 KiB")) << magic << ": " << pnm.err;
    }
    // A header that goes on past 64 KiB (a comment without end).
    write_file(dir_ / "long.pgm", "P5\n#" + std::string(std::size_t{70} << 10, 'x'));
    const auto longer = tessref({"compare", "long.pgm", "ref.png"}, 60);
    EXPECT_EQ(longer.status, 2) << longer.err;
    EXPECT_TRUE(contains(longer.err, "header does not end within its first 64 KiB")) << longer.err;

    // Samples are read up to what the header says: a small binary PGM with a gigabyte after
    // its samples reads under the same cap, and a plain PGM far longer than its samples
    // could be as text is refused.
    for (const char* name : {"tail.pgm", "tail2.pgm"}) {
        write_file(dir_ / name, std::string("P5 4 4 255\n") + std::string(16, '\x80'));
        fs::resize_file(dir_ / name, std::uintmax_t{1} << 30);
    }
    const auto tail = tessref({"compare", "tail.pgm", "tail2.pgm", "--json"}, 60, {}, std::uint64_t{512} << 20);
    EXPECT_EQ(tail.status, 0) << tail.err;
    write_file(dir_ / "plain.pgm", "P2 2 2 255\n1 2 3 4\n");
    fs::resize_file(dir_ / "plain.pgm", std::uintmax_t{4} << 20);
    const auto plain = tessref({"compare", "plain.pgm", "ref.png"}, 60);
    EXPECT_EQ(plain.status, 2) << plain.err;
    EXPECT_TRUE(contains(plain.err, "samples take at most")) << plain.err;
}

// ---- 7. outputs never replace the command's own inputs -----------------------------------

TEST_F(Hostile, RenderDoesNotOverwriteItsScenesTexture) {
    const std::string scene = copied_map_scene();
    const std::string texture = read_file(dir_ / "sc/textures/thesis-island-colour.png");
    fs::create_symlink("thesis-island-colour.png", dir_ / "sc/textures/link.png");
    fs::create_hard_link(dir_ / "sc/textures/thesis-island-colour.png", dir_ / "hard.png");
    for (const std::string out : {path("sc/textures/thesis-island-colour.png"), path("sc/textures/link.png"), path("hard.png")}) {
        const auto r = tessref({"render", scene, "-o", out, "--size", "32x20"}, 60);
        EXPECT_EQ(r.status, 2) << out << ": " << r.err;
        EXPECT_TRUE(contains(r.err, "is the input")) << r.err;
        EXPECT_EQ(read_file(dir_ / "sc/textures/thesis-island-colour.png"), texture) << out;
    }
    EXPECT_TRUE(fs::is_symlink(dir_ / "sc/textures/link.png"));
    const auto scene_itself = tessref({"render", scene, "-o", scene, "--size", "32x20"}, 60);
    EXPECT_EQ(scene_itself.status, 2) << scene_itself.err;
}

TEST_F(Hostile, MeshOutputsThatAreOneFileAreRefused) {
    const auto r = tessref({"mesh", kScene, "-o", "same.ply", "--capture", "same.ply"}, 60);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "also the output")) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "same.ply"));
}

TEST_F(Hostile, SweepMergeDoesNotReplaceAShard) {
    for (const char* shard : {"0/2", "1/2"}) {
        const std::string out = std::string("sh") + shard[0];
        ASSERT_EQ(tessref({"sweep", kScene, "-o", out, "--levels", "1", "--size", "32x20", "--shard", shard}, 120).status, 0);
    }
    const std::string json = read_file(dir_ / "sh0/sweep.json");
    const auto r = tessref({"sweep", "merge", "sh0", "sh1", "-o", "sh0"}, 60);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "input")) << r.err;
    EXPECT_EQ(read_file(dir_ / "sh0/sweep.json"), json);
    // Into a new directory, and over that merge again, it works.
    EXPECT_EQ(tessref({"sweep", "merge", "sh0", "sh1", "-o", "m"}, 60).status, 0);
    EXPECT_EQ(tessref({"sweep", "merge", "sh0", "sh1", "-o", "m"}, 60).status, 0);
}

TEST_F(Hostile, CompareDiffOverAnInputIsRefused) {
    write_flat_png(dir_ / "a.png", 4, 4);
    write_flat_png(dir_ / "b.png", 4, 4);
    const std::string before = read_file(dir_ / "b.png");
    fs::create_hard_link(dir_ / "b.png", dir_ / "hard.png");
    const auto r = tessref({"compare", "a.png", "b.png", "--diff", "hard.png"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_EQ(read_file(dir_ / "b.png"), before);
}

}  // namespace
}  // namespace tessref::test
