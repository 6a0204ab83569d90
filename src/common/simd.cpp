#include "common/simd.h"

#include <atomic>
#include <cstdlib>
#include <string>

#include "tessref/error.h"

namespace tessref {

namespace {

constexpr int kUnset = -1;
std::atomic<int> g_level{kUnset};

bool runs(SimdLevel level) { return level <= cpu_simd_level(); }

SimdLevel initial_level() {
    if (const char* env = std::getenv("TESSREF_SIMD"); env && *env)
        if (const auto named = parse_simd_level(env); named && runs(*named)) return *named;
    return cpu_simd_level();
}

}  // namespace

SimdLevel cpu_simd_level() {
#if defined(__x86_64__) && defined(__GNUC__)
    static const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    return avx2 ? SimdLevel::avx2 : SimdLevel::sse2;
#else
    return SimdLevel::sse2;
#endif
}

SimdLevel simd_level() {
    int level = g_level.load(std::memory_order_relaxed);
    if (level == kUnset) {
        // Two first calls at once both compute the same level: no harm in either storing it.
        level = static_cast<int>(initial_level());
        g_level.store(level, std::memory_order_relaxed);
    }
    return static_cast<SimdLevel>(level);
}

void set_simd_level(SimdLevel level) {
    if (!runs(level))
        throw Error(std::string("this CPU cannot run the ") + simd_level_name(level) + " variants",
                    Where::at_key("simd"));
    g_level.store(static_cast<int>(level), std::memory_order_relaxed);
}

std::optional<SimdLevel> parse_simd_level(std::string_view name) {
    if (name == "sse2") return SimdLevel::sse2;
    if (name == "avx2") return SimdLevel::avx2;
    return std::nullopt;
}

const char* simd_level_name(SimdLevel level) { return level == SimdLevel::avx2 ? "avx2" : "sse2"; }

void check_simd_environment() {
    const char* env = std::getenv("TESSREF_SIMD");
    if (env == nullptr || *env == '\0') return;
    const auto named = parse_simd_level(env);
    if (!named)
        throw Error("'" + std::string(env) + "' is not a SIMD level (sse2 or avx2)", Where::in_file("TESSREF_SIMD"));
    if (!runs(*named))
        throw Error(std::string("this CPU cannot run the ") + env + " variants (it lacks AVX2 or FMA)",
                    Where::in_file("TESSREF_SIMD"));
}

}  // namespace tessref
