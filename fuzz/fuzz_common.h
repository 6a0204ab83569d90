// fuzz/fuzz_common.h — what every harness shares.
//
// A harness feeds bytes to one of tessref's readers and lets exactly one kind of failure
// through silently: tessref::Error, the library's answer to bad input. Anything else (a
// crash, a sanitizer report, another exception escaping, a hang, running out of memory) is
// a finding. The library's loaders take paths, so the bytes go to a file under /dev/shm
// (one directory per process, so parallel fuzzing jobs never share a file).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <string_view>

#include <unistd.h>

#include "tessref/error.h"
#include "tessref/limits.h"

namespace tessref_fuzz {

// The memory budget of tessref::require_memory during fuzzing: well under libFuzzer's
// -rss_limit_mb=2048, so an input that declares a huge size must be refused by the
// library's own check, not by the fuzzer's out-of-memory detector.
inline constexpr std::uint64_t kMemoryLimit = 256ull << 20;

inline void init_limits() {
    static const bool done = [] {
        tessref::set_memory_limit(kMemoryLimit);
        return true;
    }();
    (void)done;
}

// This process's private directory under /dev/shm (or $TMPDIR when /dev/shm is absent),
// removed at exit.
inline const std::filesystem::path& scratch_dir() {
    static const std::filesystem::path dir = [] {
        std::filesystem::path base = "/dev/shm";
        std::error_code ec;
        if (!std::filesystem::is_directory(base, ec)) base = std::filesystem::temp_directory_path();
        std::filesystem::path d = base / ("tessref-fuzz-" + std::to_string(::getpid()));
        std::filesystem::create_directories(d);
        std::atexit([] {
            std::error_code ignored;
            std::filesystem::remove_all(scratch_dir(), ignored);
        });
        return d;
    }();
    return dir;
}

// Writes the input to <scratch>/<name> and returns its path.
inline std::string write_input(const std::uint8_t* data, std::size_t size, const std::string& name) {
    const std::filesystem::path path = scratch_dir() / name;
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) std::abort();  // the harness's own failure, not the library's: stop loudly
    if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
    std::fclose(f);
    return path.string();
}

inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
    return {reinterpret_cast<const char*>(data), size};
}

// Runs `body`, swallowing tessref::Error only.
template <class F>
void expect_only_tessref_errors(F&& body) {
    try {
        body();
    } catch (const tessref::Error& e) {
        // The documented answer to bad input. TESSREF_FUZZ_VERBOSE=1 shows it (to check
        // that the seeds load instead of failing early).
        static const bool verbose = std::getenv("TESSREF_FUZZ_VERBOSE") != nullptr;
        if (verbose) std::fprintf(stderr, "tessref::Error: %s\n", e.message().c_str());
    }
}

}  // namespace tessref_fuzz
