// tests/command_dir_test.h — the fixture of the end-to-end tests of the `tessref` command:
// a fresh, empty directory per test (removed afterwards), the command run inside it, and
// what it left there, so a test can see that a failing command wrote nothing.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "run_program.h"

namespace tessref::test {

class CommandDirTest : public ::testing::Test {
protected:
    void SetUp() override {
        static int counter = 0;
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = std::filesystem::temp_directory_path() /
               ("tessref_test_" + std::string(info->test_suite_name()) + "_" + std::to_string(::getpid()) + "_" +
                std::to_string(counter++));
        std::filesystem::remove_all(dir_);
        std::filesystem::create_directories(dir_);
    }
    void TearDown() override { std::filesystem::remove_all(dir_); }

    // Runs the built tessref with `args`, inside the test's directory.
    RunResult run(const std::vector<std::string>& args) { return run_program(TESSREF_EXE, args, dir_); }

    // The names in the test directory (what a command left there).
    std::set<std::string> files() const {
        std::set<std::string> names;
        for (const auto& entry : std::filesystem::directory_iterator(dir_))
            names.insert(entry.path().filename().string());
        return names;
    }
    std::string path(const std::string& name) const { return (dir_ / name).string(); }

    std::filesystem::path dir_;
};

}  // namespace tessref::test
