// src/cli/commands.h — the subcommands of the `tessref` command.
//
// Each subcommand lives in its own file, src/cli/cmd_<name>.cpp, and exposes exactly one
// function here, add_<name>_command(), which adds its CLI::App (options, help text) to the
// parent and returns a Command. main.cpp lists every add_*_command() call in one place;
// a new subcommand is: write cmd_<name>.cpp, declare its function below, add one line to
// the list in main.cpp.
//
// Contract of Command::run (called once, after the whole command line parsed):
//  - return 0 when the command did what was asked;
//  - return 1 when a check or comparison it performed failed (the result is still written);
//  - throw tessref::Error on bad input (a flag value, a file, a scene): main prints
//    `tessref: error: <what> (<where>)` and exits 2. Never write a partial output file
//    (use cli::AtomicOutput / cli::write_output from cli_util.h).
#pragma once

#include <functional>

namespace CLI {
class App;
}

namespace tessref::cli {

struct Command {
    CLI::App* app = nullptr;  // the subcommand added to the parent (owned by the parent)
    std::function<int()> run;  // runs the command with the parsed options
};

// tessref tessellate — the primitive generator's pattern for one set of levels
// (text, json, obj, svg, png). src/cli/cmd_tessellate.cpp
Command add_tessellate_command(CLI::App& parent);
Command add_mesh_command(CLI::App& parent);  // tessref mesh: src/cli/cmd_mesh.cpp
Command add_check_command(CLI::App& parent);  // tessref check: src/cli/cmd_check.cpp
Command add_render_command(CLI::App& parent);  // tessref render: src/cli/cmd_render.cpp
Command add_inspect_command(CLI::App& parent);  // tessref inspect: src/cli/cmd_inspect.cpp
Command add_compare_command(CLI::App& parent);  // tessref compare: src/cli/cmd_compare.cpp
Command add_gl_command(CLI::App& parent);  // tessref gl: src/cli/cmd_gl.cpp
Command add_golden_command(CLI::App& parent);  // tessref golden: src/cli/cmd_golden.cpp
Command add_sweep_command(CLI::App& parent);  // tessref sweep: src/cli/cmd_sweep.cpp

Command add_pvs_command(CLI::App& parent);  // tessref pvs: src/cli/cmd_pvs.cpp
Command add_trace_command(CLI::App& parent);  // tessref trace: src/cli/cmd_trace.cpp

// Later subcommands, one file each (declare here, list in main.cpp).

}  // namespace tessref::cli
