// tessref/limits.h — the memory budget for what input asks tessref to allocate.
//
// A file can declare sizes it does not hold (a PGM header of 100000 x 100000, a PLY header
// of 2^31 faces) and a command line can ask for work that cannot fit (`render --size
// 16384x16384`). Allocating first and failing later means minutes of swapping and an
// out-of-memory kill, or a bare "out of memory" with nothing named. So every loader and
// command estimates the bytes an input asks for *before* allocating, and calls
// require_memory(), which refuses with a tessref::Error that names the input, the figure
// and the limit.
//
// The limit is the process's; by default three quarters of the physical memory (so a
// refusal comes before the kernel's OOM killer would), overridden by the environment
// variable TESSREF_MAX_MEMORY or the command's `--max-memory` flag (both take a size such
// as "512M", "16G" or a plain number of bytes).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "tessref/error.h"

namespace tessref {

// The current limit in bytes.
std::uint64_t memory_limit();
// Sets the limit for the rest of the process (0 restores the default).
void set_memory_limit(std::uint64_t bytes);
// The default: TESSREF_MAX_MEMORY when set and valid, else 3/4 of physical memory.
std::uint64_t default_memory_limit();

// Throws Error("<what> needs <N> of memory, more than the limit of <L> (raise it with
// --max-memory or TESSREF_MAX_MEMORY)", where) when bytes > memory_limit(). `what` names
// the input in the user's terms ("height map of 100000 x 100000 samples").
void require_memory(std::uint64_t bytes, const std::string& what, const Where& where = {});

// bytes * count, saturating at UINT64_MAX (sizes computed from untrusted counts).
std::uint64_t saturating_bytes(std::uint64_t count, std::uint64_t bytes_each);

// "1.5 GiB", "740 MiB", "12 KiB", "100 bytes".
std::string format_bytes(std::uint64_t bytes);

// Parses "123", "512K", "512M", "16G", "1T" (binary units, optional trailing "B" or "iB",
// case-insensitive, decimals allowed: "1.5G"). nullopt when not a positive size.
std::optional<std::uint64_t> parse_byte_size(std::string_view text);

}  // namespace tessref
