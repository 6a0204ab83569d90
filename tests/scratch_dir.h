// tests/scratch_dir.h — one scratch directory per test process, for suites whose tests
// write files that several of them share: /tmp/tessref_test_<suite>_<pid>, made on first
// use and removed with everything in it when the suite ends (a gtest Environment, so also
// after failed tests). Use it at namespace scope, once per executable:
//   const tessref::test::ScratchDir& scratch_dir = tessref::test::ScratchDir::add("check");
//   ... scratch_dir() / "mesh.obj" ...
// (Tests that want a fresh, empty directory each use command_dir_test.h instead.)
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

#include <gtest/gtest.h>

namespace tessref::test {

class ScratchDir : public ::testing::Environment {
public:
    // Registers the directory's removal at the end of the suite; the Environment is gtest's
    // from then on.
    static const ScratchDir& add(const std::string& suite) {
        return *static_cast<ScratchDir*>(::testing::AddGlobalTestEnvironment(new ScratchDir(suite)));
    }

    // The directory, created if it does not exist.
    std::filesystem::path operator()() const {
        std::filesystem::create_directories(path_);
        return path_;
    }

    void TearDown() override {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }

private:
    explicit ScratchDir(const std::string& suite)
        : path_(std::filesystem::temp_directory_path() / ("tessref_test_" + suite + "_" + std::to_string(::getpid()))) {}

    std::filesystem::path path_;
};

}  // namespace tessref::test
