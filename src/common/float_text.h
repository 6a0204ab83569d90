#pragma once
// A float as printf's "%.9g" writes it (nine significant digits, trailing zeros dropped,
// "nan", "-nan", "inf", "-inf"), byte for byte, at a tenth of glibc's cost: the capture text
// prints nine of them a vertex, and a 2-million-triangle capture spent 17 s in snprintf.

#include <cstddef>

namespace tessref {

// Room at the output: the longest text is 15 bytes ("-1.23456789e-38"), and the writer
// copies whole words past its end.
inline constexpr std::size_t kFloatTextMax = 24;

// Writes `x` as "%.9g" would at `out` (kFloatTextMax bytes there), returns the end; no
// terminating zero.
char* write_float_g9(char* out, float x);

}  // namespace tessref
