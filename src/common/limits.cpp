#include "tessref/limits.h"

#include <atomic>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include <unistd.h>

namespace tessref {

namespace {

std::atomic<std::uint64_t> g_limit{0};  // 0: not set, use the default

}  // namespace

std::uint64_t default_memory_limit() {
    if (const char* env = std::getenv("TESSREF_MAX_MEMORY")) {
        if (const auto parsed = parse_byte_size(env)) return *parsed;
    }
    const long pages = sysconf(_SC_PHYS_PAGES);
    const long page_size = sysconf(_SC_PAGE_SIZE);
    if (pages <= 0 || page_size <= 0) return std::uint64_t{8} << 30;  // unknown: 8 GiB
    return saturating_bytes(static_cast<std::uint64_t>(pages), static_cast<std::uint64_t>(page_size)) / 4 * 3;
}

std::uint64_t memory_limit() {
    const std::uint64_t set = g_limit.load(std::memory_order_relaxed);
    return set != 0 ? set : default_memory_limit();
}

void set_memory_limit(std::uint64_t bytes) { g_limit.store(bytes, std::memory_order_relaxed); }

void require_memory(std::uint64_t bytes, const std::string& what, const Where& where) {
    const std::uint64_t limit = memory_limit();
    if (bytes <= limit) return;
    throw Error(what + " needs " + format_bytes(bytes) + " of memory, more than the limit of " +
                    format_bytes(limit) + " (raise it with --max-memory or TESSREF_MAX_MEMORY)",
                where);
}

std::uint64_t saturating_bytes(std::uint64_t count, std::uint64_t bytes_each) {
    if (bytes_each != 0 && count > std::numeric_limits<std::uint64_t>::max() / bytes_each)
        return std::numeric_limits<std::uint64_t>::max();
    return count * bytes_each;
}

std::string format_bytes(std::uint64_t bytes) {
    static const char* const units[] = {"KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
    if (bytes < 1024) return std::to_string(bytes) + (bytes == 1 ? " byte" : " bytes");
    double value = static_cast<double>(bytes);
    int unit = -1;
    while (value >= 1024.0 && unit < 5) {
        value /= 1024.0;
        ++unit;
    }
    char text[64];
    std::snprintf(text, sizeof text, value < 10.0 ? "%.1f %s" : "%.0f %s", value, units[unit]);
    return text;
}

std::optional<std::uint64_t> parse_byte_size(std::string_view text) {
    while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front()))) text.remove_prefix(1);
    while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.remove_suffix(1);
    double number = 0.0;
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), number);
    if (error != std::errc() || end == text.data()) return std::nullopt;
    std::string unit(end, text.data() + text.size());
    for (char& c : unit) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (unit.ends_with("ib")) unit.resize(unit.size() - 2);
    else if (unit.size() > 1 && unit.ends_with("b")) unit.resize(unit.size() - 1);
    else if (unit == "b") unit.clear();
    double scale = 1.0;
    if (unit.empty()) scale = 1.0;
    else if (unit == "k") scale = 1024.0;
    else if (unit == "m") scale = 1024.0 * 1024.0;
    else if (unit == "g") scale = 1024.0 * 1024.0 * 1024.0;
    else if (unit == "t") scale = 1024.0 * 1024.0 * 1024.0 * 1024.0;
    else return std::nullopt;
    const double bytes = number * scale;
    if (!std::isfinite(bytes) || bytes < 1.0 || bytes >= 1.8e19) return std::nullopt;
    return static_cast<std::uint64_t>(bytes);
}

}  // namespace tessref
