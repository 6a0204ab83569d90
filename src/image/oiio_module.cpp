// Loading tessref_oiio.so: see oiio_module.h.
#include "image/oiio_module.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <system_error>

#include "tessref/error.h"

#if !defined(TESSREF_BIN_TO_MODULE) || !defined(TESSREF_DATA_TO_MODULE) || !defined(TESSREF_OIIO_MODULE_NAME)
#error "TESSREF_BIN_TO_MODULE, TESSREF_DATA_TO_MODULE and TESSREF_OIIO_MODULE_NAME come from CMakeLists.txt"
#endif

namespace tessref::image {

namespace fs = std::filesystem;

namespace {

struct Loaded {
    const tessref_oiio_api* api = nullptr;
    std::string failure;  // why it could not be loaded (kept: every later call says the same)
};

Loaded load() {
    Loaded loaded;
    std::string searched;
    std::string dl_failures;
    for (const std::string& candidate : oiio_module_candidates()) {
        if (!searched.empty()) searched += ", ";
        searched += candidate;
        std::error_code ec;
        if (!fs::is_regular_file(candidate, ec)) continue;
        // RTLD_LOCAL: OpenImageIO's symbols stay out of the process's global scope.
        void* handle = dlopen(candidate.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (handle == nullptr) {
            const char* reason = dlerror();
            dl_failures += "; " + candidate + " does not load: " + (reason ? reason : "unknown reason");
            continue;
        }
        const auto entry = reinterpret_cast<tessref_oiio_api_fn>(dlsym(handle, TESSREF_OIIO_ENTRY));
        const tessref_oiio_api* api = entry ? entry(TESSREF_OIIO_ABI) : nullptr;
        if (api == nullptr) {
            dl_failures += "; " + candidate + " is not a tessref_oiio module of interface version " +
                           std::to_string(TESSREF_OIIO_ABI) + " (built from another tessref?)";
            dlclose(handle);
            continue;
        }
        loaded.api = api;  // never closed: its functions are used until the process ends
        return loaded;
    }
    loaded.failure = "cannot load tessref's OpenImageIO module " TESSREF_OIIO_MODULE_NAME "; searched: " + searched +
                     dl_failures + "; set TESSREF_OIIO_MODULE to the module's file";
    return loaded;
}

}  // namespace

std::vector<std::string> oiio_module_candidates() {
    std::vector<std::string> out;
    // Set, it is the only place: a module named on purpose is never swapped for another.
    if (const char* env = std::getenv("TESSREF_OIIO_MODULE"); env && *env) return {env};
    out.push_back("TESSREF_OIIO_MODULE (unset)");
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) {
        const fs::path dir = exe.parent_path();
        out.push_back(((dir / TESSREF_BIN_TO_MODULE).lexically_normal() / TESSREF_OIIO_MODULE_NAME).string());
        out.push_back((dir / TESSREF_OIIO_MODULE_NAME).string());
    }
    if (const char* data = std::getenv("TESSREF_DATA_DIR"); data && *data)
        out.push_back(((fs::path(data) / TESSREF_DATA_TO_MODULE).lexically_normal() / TESSREF_OIIO_MODULE_NAME).string());
    return out;
}

const tessref_oiio_api& oiio_module(const std::string& why, const std::string& path) {
    static std::once_flag once;
    static Loaded loaded;
    std::call_once(once, [] { loaded = load(); });
    if (loaded.api == nullptr) throw Error(why + " needs OpenImageIO: " + loaded.failure, Where::in_file(path));
    return *loaded.api;
}

}  // namespace tessref::image
