// src/golden/golden_internal.h — what the golden room's files share and nobody else needs.
#pragma once

#include <string>
#include <string_view>

#include <glm/glm.hpp>

#include "tessref/error.h"

namespace tessref::golden {

// The SHA-256 of `bytes` in 64 lower-case hex digits (OpenSSL).
std::string sha256_hex(std::string_view bytes);

// "WxH" (1..16384 each) as `size` lines and `--size` write it; an Error at `where` otherwise.
glm::ivec2 parse_size(const std::string& text, const Where& where);

}  // namespace tessref::golden
