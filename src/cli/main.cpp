// tessref — the command. Parses the command line with CLI11, runs the one subcommand named,
// and maps every outcome to an exit status:
//   0  done;  1  a check or comparison failed;  2  bad input (tessref::Error or a command
//   line CLI11 rejects), reported as `tessref: error: <what> (<where>)` on stderr.
// The subcommands live in src/cli/cmd_<name>.cpp and are listed in make_commands() below.
#include <cstdio>
#include <exception>
#include <iostream>
#include <new>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "tessref/error.h"
#include "tessref/limits.h"

namespace {

constexpr int exit_bad_input = 2;

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
    };
}

void print_error(const std::string& message) {
    std::fflush(stdout);
    std::cerr << "tessref: error: " << message << std::endl;
}

}  // namespace

int main(int argc, char** argv) {
    // Ctrl-C or a kill while an output is being written must not leave its temporary file.
    tessref::cli::install_signal_cleanup();
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
            return exit_bad_input;
        }
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
        return exit_bad_input;
    } catch (const tessref::Error& error) {
        print_error(error.message());
        return exit_bad_input;
    } catch (const std::bad_alloc&) {
        print_error("out of memory");
        return exit_bad_input;
    } catch (const std::exception& error) {
        print_error(error.what());
        return exit_bad_input;
    }
}
