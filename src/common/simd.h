// Which instruction set the hot loops run with: a few loops of the streamed render have an
// AVX2 (with FMA) variant beside their baseline x86-64 (SSE2) one, chosen at run time, so
// that the default build still runs on every x86-64 CPU. Every variant computes the same
// values bit for bit (the same operations in the same order, lane by lane, and an FMA only
// where the baseline calls std::fma, which is exactly rounded either way); the tests render
// with each level the CPU runs and compare the bytes.
//
// The level is the CPU's best unless TESSREF_SIMD names one (sse2 or avx2): a way to see the
// baseline's speed, and the tests' way to run both. The tessref command refuses a value that
// is not a level, or one the CPU cannot run (check_simd_environment); the library, which has
// no place to report it, then takes the CPU's best.
#pragma once

#include <optional>
#include <string_view>

namespace tessref {

enum class SimdLevel { sse2, avx2 };

// The level the hot loops use now (one relaxed load after the first call).
SimdLevel simd_level();
// Sets it, e.g. a test running each level in turn; a level the CPU cannot run is refused
// with an Error.
void set_simd_level(SimdLevel level);
// The widest level this CPU runs (avx2 needs AVX2 and FMA).
SimdLevel cpu_simd_level();
// "sse2" or "avx2"; nothing for anything else.
std::optional<SimdLevel> parse_simd_level(std::string_view name);
const char* simd_level_name(SimdLevel level);
// TESSREF_SIMD, when set, must name a level the CPU runs: an Error naming the variable
// otherwise.
void check_simd_environment();

}  // namespace tessref
