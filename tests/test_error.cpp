// The places errors name (tessref/error.h): each Where factory fills only its own fields,
// and str() writes them in the documented form "file:line:column, key K, patch P", leaving
// out what is unknown (an empty file or key, a line of 0, a patch id of -1).
#include <gtest/gtest.h>

#include "tessref/error.h"

using tessref::Error;
using tessref::Where;

namespace {

// All five fields, so that a factory filling a field it does not take fails.
void expect_fields(const Where& w, const std::string& file, int line, int column, const std::string& key,
                   long long patch_id) {
    EXPECT_EQ(w.file, file);
    EXPECT_EQ(w.line, line);
    EXPECT_EQ(w.column, column);
    EXPECT_EQ(w.key, key);
    EXPECT_EQ(w.patch_id, patch_id);
}

TEST(Where, NothingKnownIsEmpty) {
    EXPECT_EQ(Where{}.str(), "");
    EXPECT_EQ(Error("bad level").message(), "bad level");
}

TEST(Where, InFile) {
    expect_fields(Where::in_file("scene.toml"), "scene.toml", 0, 0, "", -1);
    EXPECT_EQ(Where::in_file("scene.toml").str(), "scene.toml");
    expect_fields(Where::in_file("mesh.obj", 12), "mesh.obj", 12, 0, "", -1);
    EXPECT_EQ(Where::in_file("mesh.obj", 12).str(), "mesh.obj:12");
    EXPECT_EQ(Where::in_file("scene.toml", 12, 5).str(), "scene.toml:12:5");
    // A column means nothing without its line.
    EXPECT_EQ(Where::in_file("scene.toml", 0, 5).str(), "scene.toml");
    // For command-line input the "file" is the flag.
    EXPECT_EQ(Where::in_file("--outer").str(), "--outer");
    // Line 2^40 of a file does not fit the int field: it stays at the largest line there is.
    EXPECT_EQ(Where::in_file("big.txt", std::size_t(1) << 40).str(), "big.txt:2147483647");
}

TEST(Where, AtKey) {
    expect_fields(Where::at_key("outer[2]"), "", 0, 0, "outer[2]", -1);
    EXPECT_EQ(Where::at_key("outer[2]").str(), "key outer[2]");
    expect_fields(Where::at_key("scene.toml", "camera"), "scene.toml", 0, 0, "camera", -1);
    EXPECT_EQ(Where::at_key("scene.toml", "camera").str(), "scene.toml, key camera");
}

TEST(Where, At) {
    const Where w = Where::at("scene.toml", 12, 5, "control.weights");
    expect_fields(w, "scene.toml", 12, 5, "control.weights", -1);
    EXPECT_EQ(w.str(), "scene.toml:12:5, key control.weights");
}

TEST(Where, AtPatch) {
    expect_fields(Where::at_patch(7), "", 0, 0, "", 7);
    EXPECT_EQ(Where::at_patch(7).str(), "patch 7");
    // Patch 0 is a patch; only -1 means unknown.
    EXPECT_EQ(Where::at_patch(0).str(), "patch 0");
    EXPECT_EQ(Where::at_patch(-1).str(), "");
    expect_fields(Where::at_patch("scene.toml", 7), "scene.toml", 0, 0, "", 7);
    EXPECT_EQ(Where::at_patch("scene.toml", 7).str(), "scene.toml, patch 7");
}

TEST(Where, EveryFieldInOrder) {
    Where w = Where::at("scene.toml", 12, 5, "control.weights");
    w.patch_id = 7;
    EXPECT_EQ(w.str(), "scene.toml:12:5, key control.weights, patch 7");
    EXPECT_EQ(Error("weights must be positive", w).message(),
              "weights must be positive (scene.toml:12:5, key control.weights, patch 7)");
}

}  // namespace
