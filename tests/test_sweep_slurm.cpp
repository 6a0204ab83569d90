// tests/test_sweep_slurm.cpp — scripts/slurm/sweep.sbatch as Slurm runs it, without a Slurm:
// sbatch starts the script once per array task with SLURM_ARRAY_TASK_ID,
// SLURM_ARRAY_TASK_COUNT, SLURM_ARRAY_TASK_MIN and SLURM_SUBMIT_DIR set (Slurm's sbatch(1),
// "OUTPUT ENVIRONMENT VARIABLES"); this test sets exactly those and runs it the same way.
// The merged shards must equal one unsharded sweep of the same arguments: sweep.csv
// byte-identical once the timing columns (*_ms) are removed, every picture byte-identical.
// (scripts/slurm/prove.sh does the same on a real single-node Slurm.)
#include <filesystem>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "command_dir_test.h"

namespace fs = std::filesystem;
using namespace tessref::test;

namespace {

// The CSV with every column whose header ends in "_ms" removed.
std::string without_timing(const std::string& csv) {
    std::istringstream in(csv);
    std::string line, result;
    std::vector<bool> keep;
    bool header = true;
    while (std::getline(in, line)) {
        std::vector<std::string> fields;
        std::string field;
        std::istringstream row(line);
        while (std::getline(row, field, ',')) fields.push_back(field);
        if (!line.empty() && line.back() == ',') fields.push_back("");
        if (header) {
            for (const std::string& name : fields) keep.push_back(!(name.size() > 3 && name.ends_with("_ms")));
            header = false;
        }
        std::string out;
        for (std::size_t i = 0; i < fields.size(); ++i)
            if (i >= keep.size() || keep[i]) out += (out.empty() ? "" : ",") + fields[i];
        result += out + "\n";
    }
    return result;
}

std::set<std::string> names_under(const fs::path& dir) {
    std::set<std::string> names;
    if (!fs::exists(dir)) return names;
    for (const auto& entry : fs::recursive_directory_iterator(dir))
        if (entry.is_regular_file()) names.insert(fs::relative(entry.path(), dir).string());
    return names;
}

class SweepSlurm : public CommandDirTest {
protected:
    // tessref ARGS, run inside the test's directory (relative names are its files).
    RunResult run_here(const std::vector<std::string>& args) { return run_program(TESSREF_EXE, args, dir_, dir_); }
};

TEST_F(SweepSlurm, ArrayTasksMergeToTheUnshardedSweep) {
    const std::string scene = std::string(TESSREF_SOURCE_DIR) + "/data/scenes/thesis-map-4.toml";
    const std::vector<std::string> sweep_args = {scene, "--levels", "1,2,3,4,5", "--precision", "gpu,exact",
                                                 "--size", "48x30"};
    std::vector<std::string> unsharded = {"sweep"};
    unsharded.insert(unsharded.end(), sweep_args.begin(), sweep_args.end());
    unsharded.insert(unsharded.end(), {"-o", "unsharded"});
    const RunResult one = run_here(unsharded);
    ASSERT_EQ(one.status, 0) << one.err;

    // Four array tasks, numbered from 3 as `sbatch --array=3-6` numbers them.
    const std::string script = std::string(TESSREF_SOURCE_DIR) + "/scripts/slurm/sweep.sbatch";
    for (int task = 3; task <= 6; ++task) {
        std::string command = "cd " + shell_quote(dir_.string()) + " && env TESSREF=" + shell_quote(TESSREF_EXE) +
                              " SLURM_ARRAY_TASK_ID=" + std::to_string(task) +
                              " SLURM_ARRAY_TASK_COUNT=4 SLURM_ARRAY_TASK_MIN=3 SLURM_ARRAY_TASK_MAX=6" +
                              " SLURM_SUBMIT_DIR=" + shell_quote(dir_.string()) + " bash " + shell_quote(script) +
                              " array";
        for (const std::string& arg : sweep_args) command += " " + shell_quote(arg);
        command += " >task.log 2>&1 </dev/null";
        ASSERT_EQ(std::system(command.c_str()), 0) << read_file(dir_ / "task.log");
    }
    // Each task wrote its own shard directory, named by its array index.
    for (int task = 3; task <= 6; ++task)
        EXPECT_TRUE(fs::exists(dir_ / "array" / ("shard-" + std::to_string(task)) / "sweep.csv")) << task;

    const RunResult merged = run_here({"sweep", "merge", "array/shard-3", "array/shard-4", "array/shard-5",
                                  "array/shard-6", "-o", "merged"});
    ASSERT_EQ(merged.status, 0) << merged.err;
    const std::string a = read_file(dir_ / "unsharded" / "sweep.csv");
    const std::string b = read_file(dir_ / "merged" / "sweep.csv");
    ASSERT_FALSE(a.empty());
    EXPECT_EQ(without_timing(a), without_timing(b));
    // 5 uniform levels + the scene's own row, each in two precisions: 12 rows and a header.
    EXPECT_EQ(std::count(a.begin(), a.end(), '\n'), 13) << a;

    const std::set<std::string> pictures = names_under(dir_ / "unsharded" / "images");
    EXPECT_FALSE(pictures.empty());
    EXPECT_EQ(pictures, names_under(dir_ / "merged" / "images"));
    for (const std::string& name : pictures)
        EXPECT_EQ(read_file(dir_ / "unsharded" / "images" / name), read_file(dir_ / "merged" / "images" / name))
            << name;
}

TEST_F(SweepSlurm, ScriptOutsideAnArrayRefusesToRun) {
    const std::string script = std::string(TESSREF_SOURCE_DIR) + "/scripts/slurm/sweep.sbatch";
    const RunResult r = run_program("bash", {script, "out", "scene.toml"}, dir_, dir_);
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("array"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "out"));
}

}  // namespace
