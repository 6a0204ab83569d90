// src/common/temp_cleanup.h — temporary files and directories removed when the process is
// killed by a signal, and those a killed process left removed by the next run.
//
// Every output tessref writes goes to a temporary name beside it first (temp_name.h) and is
// renamed into place when complete. An exception or early return removes it (its owner's
// destructor); a signal does not run destructors, so each live temporary is also listed here,
// in fixed slots that a signal handler may read, and install_signal_cleanup()'s handler
// removes them (a directory with everything under it) with async-signal-safe calls only,
// then lets the signal kill the process as it would have (the exit status still says
// "killed by signal"). SIGKILL, a power cut or a handler that loses a race with a thread
// still writing leave a temporary behind: its name holds the process id, and
// remove_stale_temporaries() removes those whose process is gone when the next run writes
// beside them.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace tessref {

// Handlers for SIGINT, SIGTERM, SIGHUP, SIGQUIT and SIGPIPE (each unless ignored, as under
// nohup) that remove every registered temporary and then die of the same signal.
void install_signal_cleanup();

// Lists `path` (a file, or a directory removed with its contents) for the handler; returns
// its slot, or -1 when no slot is free or the path is too long (it is then still removed by
// its owner on errors, only not on signals).
int register_temporary(const std::filesystem::path& path, bool directory = false);
void unregister_temporary(int slot);

// Messages name the user's file, never its temporary. `shown_as` is the name the user gave
// for what `path` (a temporary file, or a directory whose contents are written before it is
// renamed into place) becomes; with_user_file_names() puts it back into an error message
// that a writer (libpng, OpenEXR, a stream) phrased with the path it was handed.
void name_temporary(const std::filesystem::path& path, const std::filesystem::path& shown_as);
std::string with_user_file_names(std::string message);

// Removes the entries of `dir` named lead + <any prefix of name> + middle_before_pid + <pid>
// + <anything>, whose process <pid> no longer exists (kill(pid, 0) says ESRCH): the
// temporaries of a run of this same output that was killed. Entries of a live process (a
// concurrent run) and every other name are left alone. Errors are ignored: this is tidying.
void remove_stale_temporaries(const std::filesystem::path& dir, std::string_view lead, std::string_view name,
                              std::string_view before_pid);

}  // namespace tessref
