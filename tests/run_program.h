// tests/run_program.h — running programs (the built tessref, admesh) from the tests: one
// place for shell quoting and for capturing stdout, stderr and the exit status.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace tessref::test {

struct RunResult {
    int status = -1;  // the exit status; -1 when the program did not exit normally
    std::string out;
    std::string err;
};

inline std::string read_file(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

inline void write_file(const std::filesystem::path& path, const std::string& bytes) {
    std::ofstream out(path, std::ios::binary);
    out << bytes;
}

// A scene's text with its "../" paths (the shipped scenes' data/ layout) made absolute
// against `data_dir`, so that a variant of the scene written to a test's directory still
// finds its files.
inline std::string with_absolute_data_paths(std::string text, const std::filesystem::path& data_dir) {
    const std::string data = data_dir.string() + "/";
    for (std::size_t at = text.find("\"../"); at != std::string::npos; at = text.find("\"../", at))
        text.replace(at + 1, 3, data);
    return text;
}

inline std::string shell_quote(const std::string& arg) {
    std::string quoted = "'";
    for (const char c : arg) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return quoted + "'";
}

// Runs `program args...` (from `cwd` when given) with stdin from /dev/null; stdout and
// stderr go through files in `capture_dir`, which are removed again afterwards.
inline RunResult run_program(const std::string& program, const std::vector<std::string>& args,
                             const std::filesystem::path& capture_dir, const std::filesystem::path& cwd = {}) {
    std::string command = cwd.empty() ? std::string() : "cd " + shell_quote(cwd.string()) + " && ";
    command += shell_quote(program);
    for (const std::string& arg : args) command += " " + shell_quote(arg);
    const std::filesystem::path out = capture_dir / "captured.stdout", err = capture_dir / "captured.stderr";
    command += " >" + shell_quote(out.string()) + " 2>" + shell_quote(err.string()) + " </dev/null";
    const int raw = std::system(command.c_str());
    RunResult result;
    result.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
    result.out = read_file(out);
    result.err = read_file(err);
    std::filesystem::remove(out);
    std::filesystem::remove(err);
    return result;
}

}  // namespace tessref::test
