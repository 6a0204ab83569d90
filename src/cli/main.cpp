// tessref — the command. Parses the command line with CLI11, runs the one subcommand named,
// and maps every outcome to an exit status:
//   0  done;  1  a check or comparison failed;  2  bad input (tessref::Error or a command
//   line CLI11 rejects), reported as `tessref: error: <what> (<where>)` on stderr; also a
//   report on stdout that could not be written (finish_stdout).
// The subcommands live in src/cli/cmd_<name>.cpp and are listed in make_commands() below.
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <iostream>
#include <new>
#include <string>
#include <vector>

#include <unistd.h>

#include <CLI/CLI.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "common/simd.h"
#include "common/temp_cleanup.h"
#include "tessref/error.h"
#include "tessref/limits.h"

namespace {

constexpr int kExitBadInput = 2;

// Every subcommand, in the order `tessref --help` lists them. Add new ones here.
std::vector<tessref::cli::Command> make_commands(CLI::App& app) {
    return {
        tessref::cli::add_tessellate_command(app),
        tessref::cli::add_mesh_command(app),
        tessref::cli::add_check_command(app),
        tessref::cli::add_render_command(app),
        tessref::cli::add_inspect_command(app),
        tessref::cli::add_compare_command(app),
        tessref::cli::add_gl_command(app),
        tessref::cli::add_golden_command(app),
        tessref::cli::add_sweep_command(app),
        tessref::cli::add_pvs_command(app),
        tessref::cli::add_trace_command(app),
    };
}

void print_error(const std::string& message) {
    std::fflush(stdout);
    std::cerr << "tessref: error: " << tessref::with_user_file_names(message) << std::endl;
}

// The command line as typed, for messages that must say which run failed.
std::string command_line(int argc, char** argv) {
    std::string line = "tessref";
    for (int i = 1; i < argc && line.size() < 200; ++i) line += std::string(" ") + argv[i];
    return line.size() < 200 ? line : line.substr(0, 200) + "...";
}

// The memory the process holds now (its resident set), from /proc/self/statm; 0 unknown.
std::uint64_t resident_bytes() {
    std::ifstream statm("/proc/self/statm");
    std::uint64_t pages = 0, resident = 0;
    if (!(statm >> pages >> resident)) return 0;
    const long page = ::sysconf(_SC_PAGE_SIZE);
    return page > 0 ? resident * static_cast<std::uint64_t>(page) : 0;
}

// A std::bad_alloc that reached main: no loader's estimate caught it, so say at least which
// run it was, how much the process held and what the limit is.
std::string out_of_memory_message(int argc, char** argv) {
    const std::uint64_t held = resident_bytes();
    return "out of memory: an allocation failed" +
           (held ? " with " + tessref::format_bytes(held) + " in use" : std::string()) +
           " (the limit on what inputs ask for is " + tessref::format_bytes(tessref::memory_limit()) +
           ": --max-memory, TESSREF_MAX_MEMORY) (" + command_line(argc, argv) + ")";
}

// TESSREF_MAX_MEMORY, when set, must be a size as --max-memory's is: a typo must not leave
// the default limit in force unnoticed.
void check_memory_environment() {
    const char* env = std::getenv("TESSREF_MAX_MEMORY");
    if (env && !tessref::parse_byte_size(env))
        throw tessref::Error("'" + std::string(env) + "' is not a memory size (e.g. 4G, 512M, 1000000)",
                             tessref::Where::in_file("TESSREF_MAX_MEMORY"));
}

int run(int argc, char** argv);

// Everything a command printed on stdout (a report, --json, --help) is only delivered once
// it is flushed: a write error there (a full disk, /dev/full, a closed pipe) turns the exit
// status into 2 with a message, whatever the command returned; the one place that checks.
int finish_stdout(int status) {
    std::cout.flush();
    const bool failed = !std::cout.good() || std::fflush(stdout) != 0 || std::ferror(stdout);
    if (!failed) return status;
    const int error = errno;
    std::cerr << "tessref: error: cannot write to stdout: "
              << (error ? std::strerror(error) : "write error") << " (stdout)" << std::endl;
    return kExitBadInput;
}

}  // namespace

int main(int argc, char** argv) { return finish_stdout(run(argc, argv)); }

namespace {

int run(int argc, char** argv) {
    // Ctrl-C or a kill while an output is being written must not leave its temporary file.
    tessref::install_signal_cleanup();
    CLI::App app{"tessref — a CPU reference of the GPU tessellation pipeline: control stage, "
                 "primitive generator, evaluation, geometry, raster and shading.",
                 "tessref"};
    app.set_version_flag("--version", std::string("tessref ") + TESSREF_VERSION);
    app.require_subcommand(1);
    app.footer("Exit status: 0 ok, 1 a check or comparison failed, 2 bad input.\n"
               "Run 'tessref <command> --help' for a command's options.");

    try {
        const std::vector<tessref::cli::Command> commands = make_commands(app);
        // One memory budget for the whole process (tessref/limits.h): loaders and commands
        // refuse, before allocating, inputs that would need more. Accepted before or after
        // the command's name.
        std::string max_memory;
        app.add_option("--max-memory", max_memory,
                       "Refuse inputs and work needing more memory than this, e.g. 4G or 512M "
                       "(default: 3/4 of physical memory, or TESSREF_MAX_MEMORY)");
        for (const tessref::cli::Command& command : commands) command.app->fallthrough();
        // CLI11 reports a mistyped command as "A subcommand is required"; name it instead.
        const auto names_a_command = [&commands](const std::string& word) {
            for (const tessref::cli::Command& command : commands)
                if (command.app->check_name(word)) return true;
            return false;
        };
        if (argc > 1 && argv[1][0] != '-' && !names_a_command(argv[1])) {
            std::string known;
            for (const tessref::cli::Command& command : commands)
                known += (known.empty() ? "" : ", ") + command.app->get_name();
            throw tessref::Error("unknown command '" + std::string(argv[1]) + "'; the commands are " + known,
                                 tessref::Where::in_file("command line"));
        }
        try {
            app.parse(argc, argv);
        } catch (const CLI::Success& success) {
            // --help, --help-all, --version: printed on stdout, exit 0.
            return app.exit(success);
        } catch (const CLI::ParseError& parse_error) {
            const tessref::Error error(parse_error.what(), tessref::Where::in_file("command line"));
            print_error(error.message());
            std::cerr << "Run 'tessref --help' or 'tessref <command> --help' for usage." << std::endl;
            return kExitBadInput;
        }
        check_memory_environment();
        tessref::check_simd_environment();
        if (!max_memory.empty()) {
            const auto bytes = tessref::parse_byte_size(max_memory);
            if (!bytes)
                throw tessref::Error("'" + max_memory + "' is not a memory size (e.g. 4G, 512M, 1000000)",
                                     tessref::Where::in_file("--max-memory"));
            tessref::set_memory_limit(*bytes);
        }
        for (const tessref::cli::Command& command : commands) {
            if (command.app->parsed()) return command.run();
        }
        // require_subcommand(1) makes this unreachable; keep a clear message anyway.
        print_error("no command given (command line)");
        return kExitBadInput;
    } catch (const tessref::Error& error) {
        print_error(error.message());
        return kExitBadInput;
    } catch (const std::bad_alloc&) {
        print_error(out_of_memory_message(argc, argv));
        return kExitBadInput;
    } catch (const std::exception& error) {
        print_error(error.what());
        return kExitBadInput;
    }
}

}  // namespace
