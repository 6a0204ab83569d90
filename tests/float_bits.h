// tests/float_bits.h — a float's bit pattern and back, for the tests that compare results to
// the bit (llvmpipe's math, the tessellator's coordinates, the interpreter's instructions).
#pragma once

#include <bit>
#include <cstdint>

inline std::uint32_t bits(float f) { return std::bit_cast<std::uint32_t>(f); }
inline float from_bits(std::uint32_t b) { return std::bit_cast<float>(b); }
