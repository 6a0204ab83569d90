// src/common/stream_failure.h — why a std::ostream stopped: the words of an error message.
#pragma once

#include <cerrno>
#include <string>
#include <system_error>

namespace tessref {

// The system's reason for a failed stream write ("No space left on device", "File too
// large"): libstdc++'s file buffer sets failbit right after the write(2) that failed, so
// errno still holds that call's error. A writer resets errno to 0 before it starts, so a
// failure with no system error behind it (errno still 0) says so instead of borrowing an
// older one.
inline std::string stream_failure() {
    const int error = errno;
    return error != 0 ? std::generic_category().message(error) : std::string("output stream failed");
}

}  // namespace tessref
