// Finding the run-time data: see data_dir.h.
#include "common/data_dir.h"

#include <cstdlib>
#include <filesystem>
#include <system_error>
#include <vector>

#include "tessref/error.h"

#ifndef TESSREF_BIN_TO_DATA
#error "TESSREF_BIN_TO_DATA (the install's bin -> share/tessref relative path) comes from CMakeLists.txt"
#endif

namespace tessref {

namespace fs = std::filesystem;

std::string data_dir() {
    if (const char* env = std::getenv("TESSREF_DATA_DIR"); env && *env) return env;

    std::vector<fs::path> searched;
    std::error_code ec;
    // The kernel's link names the executable after every symlink, so a tessref linked into
    // ~/bin still finds the share/ of the prefix it was installed to.
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) {
        const fs::path dir = exe.parent_path();
        for (const fs::path& candidate : {(dir / TESSREF_BIN_TO_DATA).lexically_normal(), dir / "tessref-data"}) {
            if (fs::is_directory(candidate / "shaders", ec)) return candidate.string();
            searched.push_back(candidate);
        }
    }
    std::string what = "cannot find tessref's data directory (shaders/, scenes/); searched: TESSREF_DATA_DIR (unset)";
    if (searched.empty()) what += ", nothing beside the executable (/proc/self/exe unreadable)";
    for (const fs::path& p : searched) what += ", " + p.string();
    what += "; set TESSREF_DATA_DIR to the directory that holds shaders/";
    throw Error(what);
}

}  // namespace tessref
