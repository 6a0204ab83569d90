#include "cli/cli_util.h"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <system_error>
#include <unistd.h>

#include "tessref/error.h"

namespace tessref::cli {

namespace {

std::string_view trim(std::string_view text) {
    const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; };
    while (!text.empty() && is_space(text.front())) text.remove_prefix(1);
    while (!text.empty() && is_space(text.back())) text.remove_suffix(1);
    return text;
}

std::string errno_text(int error) { return std::generic_category().message(error); }

}  // namespace

// ---------------------------------------------------------------------------------------
// Numbers

std::optional<float> parse_float(std::string_view text) {
    text = trim(text);
    if (text.empty()) return std::nullopt;
    // strtof needs a terminated string; it skips leading spaces (trimmed above) and reads
    // as much as it can, so the whole-text check is that it stopped at the end. The
    // command never calls setlocale, so the decimal point is '.'.
    const std::string copy(text);
    char* end = nullptr;
    errno = 0;
    const float value = std::strtof(copy.c_str(), &end);
    if (end != copy.c_str() + copy.size()) return std::nullopt;
    // ERANGE: overflow gives +-HUGE_VALF (= +-inf), underflow the nearest float; both are
    // what the user wrote, as far as a float can say it.
    return value;
}

std::optional<long long> parse_integer(std::string_view text) {
    text = trim(text);
    if (!text.empty() && text.front() == '+') text.remove_prefix(1);
    if (text.empty()) return std::nullopt;
    long long value = 0;
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || ptr != text.data() + text.size()) return std::nullopt;
    return value;
}

std::vector<float> parse_float_list(std::string_view text, std::size_t count,
                                    const std::string& flag) {
    std::vector<std::string_view> items;
    std::size_t start = 0;
    while (true) {
        const std::size_t comma = text.find(',', start);
        items.push_back(text.substr(start, comma == std::string_view::npos ? std::string_view::npos
                                                                             : comma - start));
        if (comma == std::string_view::npos) break;
        start = comma + 1;
    }
    std::vector<float> values;
    values.reserve(items.size());
    for (std::size_t i = 0; i < items.size(); ++i) {
        const std::optional<float> value = parse_float(items[i]);
        if (!value) {
            const std::string what =
                trim(items[i]).empty()
                    ? "item " + std::to_string(i + 1) + " is empty"
                    : "item " + std::to_string(i + 1) + ": '" + std::string(items[i]) +
                          "' is not a number";
            throw Error(what, where_file(flag));
        }
        values.push_back(*value);
    }
    if (values.size() != count) {
        throw Error("expected " + std::to_string(count) + " comma-separated numbers, got " +
                        std::to_string(values.size()) + " in '" + std::string(text) + "'",
                    where_file(flag));
    }
    return values;
}

std::string format_float(float x) {
    if (std::isnan(x)) return "nan";
    if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.9g", static_cast<double>(x));
    return buffer;
}

std::string format_float_short(float x) {
    if (!std::isfinite(x)) return format_float(x);
    char buffer[32];
    for (int digits = 1; digits <= 9; ++digits) {
        std::snprintf(buffer, sizeof buffer, "%.*g", digits, static_cast<double>(x));
        if (std::strtof(buffer, nullptr) == x) break;
    }
    return buffer;
}

std::string format_double(double x) {
    if (std::isnan(x)) return "nan";
    if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
    char buffer[40];
    std::snprintf(buffer, sizeof buffer, "%.17g", x);
    return buffer;
}

// ---------------------------------------------------------------------------------------
// Output

AtomicOutput::AtomicOutput(std::filesystem::path target, std::string temp_extension)
    : target_(std::move(target)) {
    if (target_.empty()) throw Error("empty output file name");
    if (target_.has_filename() == false || target_.filename() == "." || target_.filename() == "..")
        throw Error("not a file name", where_file(target_.string()));
    const std::filesystem::path dir = target_.parent_path();
    const std::string extension = temp_extension.empty() ? target_.extension().string() : temp_extension;
    static std::atomic<unsigned> counter{0};
    for (int attempt = 0; attempt < 100; ++attempt) {
        // ".<name>.<pid>-<n>.tmp<ext>": hidden, unique to this process, same extension.
        const std::string name = "." + target_.filename().string() + "." +
                                 std::to_string(::getpid()) + "-" +
                                 std::to_string(counter.fetch_add(1)) + ".tmp" + extension;
        const std::filesystem::path candidate = dir.empty() ? std::filesystem::path(name) : dir / name;
        const int fd = ::open(candidate.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0) {
            ::close(fd);
            temp_ = candidate;
            return;
        }
        if (errno != EEXIST) {
            throw Error("cannot create output file: " + errno_text(errno),
                        where_file(target_.string()));
        }
    }
    throw Error("cannot create a temporary file next to the output", where_file(target_.string()));
}

AtomicOutput::~AtomicOutput() {
    if (!committed_ && !temp_.empty()) ::unlink(temp_.c_str());
}

void AtomicOutput::write(std::string_view bytes) {
    const int fd = ::open(temp_.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
    if (fd < 0) throw Error("cannot write output file: " + errno_text(errno), where_file(target_.string()));
    std::size_t written = 0;
    while (written < bytes.size()) {
        const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
        if (n < 0) {
            if (errno == EINTR) continue;
            const int error = errno;
            ::close(fd);
            throw Error("cannot write output file: " + errno_text(error), where_file(target_.string()));
        }
        written += static_cast<std::size_t>(n);
    }
    if (::close(fd) != 0)
        throw Error("cannot write output file: " + errno_text(errno), where_file(target_.string()));
}

void AtomicOutput::commit() {
    if (committed_) return;
    if (::rename(temp_.c_str(), target_.c_str()) != 0) {
        const int error = errno;
        ::unlink(temp_.c_str());
        committed_ = true;  // nothing left to clean up
        throw Error("cannot write output file: " + errno_text(error), where_file(target_.string()));
    }
    committed_ = true;
}

bool is_stdout(const std::string& target) { return target.empty() || target == "-"; }

void write_output(const std::string& target, std::string_view bytes) {
    if (is_stdout(target)) {
        if (std::fwrite(bytes.data(), 1, bytes.size(), stdout) != bytes.size() || std::fflush(stdout) != 0)
            throw Error("cannot write to stdout: " + errno_text(errno));
        return;
    }
    AtomicOutput output(target);
    output.write(bytes);
    output.commit();
}

std::string lowercase_extension(const std::string& path) {
    std::string extension = std::filesystem::path(path).extension().string();
    if (!extension.empty() && extension.front() == '.') extension.erase(0, 1);
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return extension;
}

// ---------------------------------------------------------------------------------------
// Progress

bool stderr_is_terminal() { return ::isatty(STDERR_FILENO) == 1; }

Progress::Progress(std::string label, std::size_t total)
    : label_(std::move(label)), total_(total), enabled_(stderr_is_terminal()) {}

Progress::~Progress() { finish(); }

void Progress::advance(std::size_t steps) { set(done_ + steps); }

void Progress::set(std::size_t done) {
    done_ = std::min(done, total_);
    draw(false);
}

void Progress::draw(bool force) {
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    if (!force && drawn_ && now - last_draw_ < std::chrono::milliseconds(100)) return;
    last_draw_ = now;
    drawn_ = true;
    const int percent = total_ == 0 ? 100 : static_cast<int>(100.0 * static_cast<double>(done_) /
                                                             static_cast<double>(total_));
    std::fprintf(stderr, "\r%s %3d%% (%zu/%zu)\033[K", label_.c_str(), percent, done_, total_);
    std::fflush(stderr);
}

void Progress::finish() {
    if (!enabled_ || !drawn_) return;
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
    drawn_ = false;
    enabled_ = false;
}

glm::ivec2 parse_image_size(const std::string& text, const std::string& flag) {
    const std::size_t x = text.find_first_of("xX");
    const std::optional<long long> w = x == std::string::npos ? std::nullopt : parse_integer(text.substr(0, x));
    const std::optional<long long> h = x == std::string::npos ? std::nullopt : parse_integer(text.substr(x + 1));
    if (!w || !h) throw Error("image size '" + text + "' is not WIDTHxHEIGHT (e.g. 320x200)", where_file(flag));
    if (*w < 1 || *h < 1 || *w > 16384 || *h > 16384)
        throw Error("image size " + text + " is outside 1..16384 in width or height", where_file(flag));
    return {static_cast<int>(*w), static_cast<int>(*h)};
}

void StageProgress::operator()(std::string_view stage, double fraction) {
    if (stage != stage_) {
        progress_.reset();  // clears the previous stage's line
        stage_ = std::string(stage);
        progress_ = std::make_unique<Progress>(stage_, kSteps);
    }
    progress_->set(static_cast<std::size_t>(fraction * static_cast<double>(kSteps)));
}

Precision parse_precision_flag(const std::string& text) {
    const std::optional<Precision> precision = parse_precision(text);
    if (!precision) throw Error("unknown precision '" + text + "'; expected gpu or exact", where_file("--precision"));
    return *precision;
}

ThreadLimit::ThreadLimit(int threads) {
    if (threads < 0)
        throw Error("thread count must be >= 0 (0: every core), got " + std::to_string(threads), where_file("--threads"));
    if (threads > 0) control_.emplace(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
}

}  // namespace tessref::cli
