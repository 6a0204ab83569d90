#include "cli/cli_util.h"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <climits>
#include <csignal>
#include <fcntl.h>
#include <iostream>
#include <sys/stat.h>
#include <system_error>
#include <unistd.h>

#include <CLI/CLI.hpp>

#include "common/input_file.h"
#include "pipeline/stage_uniforms.h"
#include "tessref/shader.h"
#include "common/temp_cleanup.h"
#include "common/temp_name.h"
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

std::optional<double> parse_double(std::string_view text) {
    text = trim(text);
    if (text.empty()) return std::nullopt;
    const std::string copy(text);
    char* end = nullptr;
    const double value = std::strtod(copy.c_str(), &end);
    if (end != copy.c_str() + copy.size()) return std::nullopt;
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
            throw Error(what, Where::in_file(flag));
        }
        values.push_back(*value);
    }
    if (values.size() != count) {
        throw Error("expected " + std::to_string(count) + " comma-separated numbers, got " +
                        std::to_string(values.size()) + " in '" + std::string(text) + "'",
                    Where::in_file(flag));
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

std::string utf8_for_json(std::string_view text) {
    std::string out;
    out.reserve(text.size());
    const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(text[i]); };
    for (std::size_t i = 0; i < text.size();) {
        const unsigned char lead = byte(i);
        // The length of a well-formed sequence starting here (RFC 3629: no overlong forms,
        // no surrogates, nothing above U+10FFFF), 0 when there is none.
        std::size_t length = 0;
        if (lead < 0x80) {
            length = 1;
        } else {
            const std::size_t want = lead >= 0xC2 && lead <= 0xDF ? 2 : lead >= 0xE0 && lead <= 0xEF ? 3
                                     : lead >= 0xF0 && lead <= 0xF4 ? 4 : 0;
            if (want && i + want <= text.size()) {
                unsigned char lo = 0x80, hi = 0xBF;  // the second byte's range
                if (lead == 0xE0) lo = 0xA0;
                if (lead == 0xED) hi = 0x9F;
                if (lead == 0xF0) lo = 0x90;
                if (lead == 0xF4) hi = 0x8F;
                bool ok = byte(i + 1) >= lo && byte(i + 1) <= hi;
                for (std::size_t k = 2; ok && k < want; ++k) ok = byte(i + k) >= 0x80 && byte(i + k) <= 0xBF;
                if (ok) length = want;
            }
        }
        if (length) {
            out.append(text.substr(i, length));
            i += length;
        } else {
            char escaped[8];
            std::snprintf(escaped, sizeof escaped, "\\x%02X", lead);
            out += escaped;
            ++i;
        }
    }
    return out;
}

// ---------------------------------------------------------------------------------------
// Output

namespace {

// The descriptor a path names without being a file of its own: /dev/stdout, /dev/stderr,
// /dev/fd/N, /proc/self/fd/N. Writing there must go to the descriptor (its offset, its
// O_APPEND), not to a reopened or renamed file: `-o /dev/stdout >> log` appends.
std::optional<int> descriptor_path(const std::filesystem::path& path) {
    const std::string text = path.lexically_normal().string();
    if (text == "/dev/stdout") return STDOUT_FILENO;
    if (text == "/dev/stderr") return STDERR_FILENO;
    for (const std::string_view prefix : {"/dev/fd/", "/proc/self/fd/"}) {
        if (text.starts_with(prefix)) {
            const std::optional<long long> fd = parse_integer(std::string_view(text).substr(prefix.size()));
            if (fd && *fd >= 0 && *fd <= INT_MAX) return static_cast<int>(*fd);
        }
    }
    return std::nullopt;
}

// `path` with every symlink of its last component followed, also when the last one dangles
// (the file it names is then created, and the link stays a link).
std::filesystem::path follow_links(std::filesystem::path path, const std::string& given) {
    for (int hop = 0; hop < 40; ++hop) {
        std::error_code error;
        if (!std::filesystem::is_symlink(std::filesystem::symlink_status(path, error))) return path;
        const std::filesystem::path link = std::filesystem::read_symlink(path, error);
        if (error) throw Error("cannot follow the symlink: " + error.message(), Where::in_file(given));
        path = link.is_absolute() ? link : path.parent_path() / link;
    }
    throw Error("cannot write output file: " + errno_text(ELOOP), Where::in_file(given));
}

// Writes all of `bytes` to `fd`, retrying short writes; returns 0 or the errno.
int write_all(int fd, const char* bytes, std::size_t size) {
    std::size_t written = 0;
    while (written < size) {
        const ssize_t n = ::write(fd, bytes + written, size - written);
        if (n < 0) {
            if (errno == EINTR) continue;
            return errno;
        }
        written += static_cast<std::size_t>(n);
    }
    return 0;
}

}  // namespace

AtomicOutput::AtomicOutput(std::filesystem::path target, std::string temp_extension)
    : target_(std::move(target)) {
    if (target_.empty()) throw Error("empty output file name");
    if (target_.has_filename() == false || target_.filename() == "." || target_.filename() == "..")
        throw Error("not a file name", Where::in_file(target_.string()));
    const std::string given = target_.string();

    // What the name is now decides between a rename and a write-through (see the header).
    if (const std::optional<int> fd = descriptor_path(target_)) {
        write_through_ = true;
        write_through_fd_ = *fd;
    }
    struct stat info {};
    if (::stat(target_.c_str(), &info) == 0) {
        if (S_ISDIR(info.st_mode)) throw Error("cannot write output file: it is a directory", Where::in_file(given));
        if (!S_ISREG(info.st_mode)) write_through_ = true;
        if (!write_through_) replaced_ = follow_links(target_, given);
        if (write_through_ && write_through_fd_ < 0 && ::access(target_.c_str(), W_OK) != 0)
            throw Error("cannot write output file: " + errno_text(errno), Where::in_file(given));
    } else if (errno == ENOENT && !write_through_) {
        replaced_ = follow_links(target_, given);
    } else if (!write_through_) {
        throw Error("cannot write output file: " + errno_text(errno), Where::in_file(given));
    }

    refuse_an_input();
    // Two outputs of one command that are one file: one of them would be lost.
    for (const AtomicOutput* other : live_outputs()) {
        if (other->write_through_ || write_through_) continue;
        std::error_code error;
        const bool same = std::filesystem::exists(replaced_, error)
                              ? std::filesystem::equivalent(replaced_, other->replaced_, error)
                              : std::filesystem::weakly_canonical(replaced_, error) ==
                                    std::filesystem::weakly_canonical(other->replaced_, error);
        if (same)
            throw Error("'" + given + "' is also the output " + other->target_.string() +
                            ": one would replace the other",
                        Where::in_file(given));
    }

    // The temporary file: beside the file a rename replaces (same file system), or in the
    // temp directory for a write-through (no file may be created beside /dev/null).
    std::filesystem::path dir;
    std::string lead, base;
    if (write_through_) {
        std::error_code error;
        dir = std::filesystem::temp_directory_path(error);
        if (error) dir = "/tmp";
        lead = "tessref-";
        base = target_.filename().string();
    } else {
        dir = replaced_.parent_path();
        lead = ".";
        base = replaced_.filename().string();
    }
    const std::string extension = temp_extension.empty() ? target_.extension().string() : temp_extension;
    static std::atomic<unsigned> counter{0};
    for (int attempt = 0; attempt < 100; ++attempt) {
        // "<lead><name>.<pid>-<n>.tmp<ext>": unique to this process, the target's extension,
        // the name cut where the whole would not fit in a file name (temp_name.h).
        const std::string name = temporary_name(
            lead, base, "." + std::to_string(::getpid()) + "-" + std::to_string(counter.fetch_add(1)) + ".tmp",
            extension);
        const std::filesystem::path candidate = dir.empty() ? std::filesystem::path(name) : dir / name;
        // Registered before it exists, so no signal can come between creating and listing it.
        const int slot = register_temporary(candidate);
        const int fd = ::open(candidate.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0) {
            ::close(fd);
            temp_ = candidate;
            temp_slot_ = slot;
            name_temporary(temp_, target_);
            live_outputs().push_back(this);
            return;
        }
        const int error = errno;
        unregister_temporary(slot);
        if (error != EEXIST) throw Error("cannot create output file: " + errno_text(error), Where::in_file(given));
    }
    throw Error("cannot create a temporary file next to the output", Where::in_file(given));
}

AtomicOutput::~AtomicOutput() {
    if (!committed_) discard();
    std::vector<const AtomicOutput*>& live = live_outputs();
    live.erase(std::remove(live.begin(), live.end(), this), live.end());
}

std::vector<const AtomicOutput*>& AtomicOutput::live_outputs() {
    static std::vector<const AtomicOutput*> outputs;
    return outputs;
}

// The one check that an output is not one of the command's inputs (common/input_file.h):
// at construction for the inputs read so far, and again at commit() for all of them (most
// commands read their inputs after naming their output, so that a bad -o fails first).
void AtomicOutput::refuse_an_input() const {
    std::string input;
    if (write_through_fd_ >= 0) input = input_open_as(write_through_fd_);
    else if (!write_through_) input = input_named_by(replaced_.string());
    if (!input.empty())
        throw Error("'" + target_.string() + "' is the input " + input + " of this command: writing it would destroy it",
                    Where::in_file(target_.string()));
}

void AtomicOutput::discard() {
    if (!temp_.empty()) ::unlink(temp_.c_str());
    unregister_temporary(temp_slot_);
    temp_slot_ = -1;
    committed_ = true;  // nothing left to clean up
}

void AtomicOutput::write(std::string_view bytes) {
    const int fd = ::open(temp_.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
    if (fd < 0) throw Error("cannot write output file: " + errno_text(errno), Where::in_file(target_.string()));
    const int error = write_all(fd, bytes.data(), bytes.size());
    if (error != 0) {
        ::close(fd);
        throw Error("cannot write output file: " + errno_text(error), Where::in_file(target_.string()));
    }
    if (::close(fd) != 0)
        throw Error("cannot write output file: " + errno_text(errno), Where::in_file(target_.string()));
}

void AtomicOutput::commit() {
    if (committed_) return;
    try {
        refuse_an_input();
    } catch (const Error&) {
        discard();
        throw;
    }
    if (!write_through_) {
        if (::rename(temp_.c_str(), replaced_.c_str()) != 0) {
            const int error = errno;
            discard();
            throw Error("cannot write output file: " + errno_text(error), Where::in_file(target_.string()));
        }
        unregister_temporary(temp_slot_);
        temp_slot_ = -1;
        committed_ = true;
        return;
    }
    // Write-through: copy the finished temporary file to the device, FIFO or descriptor.
    int error = 0;
    const int in = ::open(temp_.c_str(), O_RDONLY | O_CLOEXEC);
    if (in < 0) error = errno;
    int out = write_through_fd_;
    if (error == 0 && out < 0) {
        out = ::open(target_.c_str(), O_WRONLY | O_CLOEXEC);  // a FIFO waits here for its reader
        if (out < 0) error = errno;
    }
    if (error == 0 && write_through_fd_ == STDOUT_FILENO) {
        std::cout.flush();  // what the command printed before stays before the file
        std::fflush(stdout);
    }
    std::vector<char> buffer(1 << 20);
    while (error == 0) {
        const ssize_t n = ::read(in, buffer.data(), buffer.size());
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) error = errno;
        if (n <= 0) break;
        error = write_all(out, buffer.data(), static_cast<std::size_t>(n));
    }
    if (in >= 0) ::close(in);
    if (out >= 0 && write_through_fd_ < 0 && ::close(out) != 0 && error == 0) error = errno;
    discard();
    if (error != 0) throw Error("cannot write output file: " + errno_text(error), Where::in_file(target_.string()));
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
    if (!w || !h) throw Error("image size '" + text + "' is not WIDTHxHEIGHT (e.g. 320x200)", Where::in_file(flag));
    if (*w < 1 || *h < 1 || *w > 16384 || *h > 16384)
        throw Error("image size " + text + " is outside 1..16384 in width or height", Where::in_file(flag));
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
    if (!precision) throw Error("unknown precision '" + text + "'; expected gpu or exact", Where::in_file("--precision"));
    return *precision;
}

// --shader STAGE=FILE: FILE relative to the working directory; one flag per stage.
std::vector<StageShader> parse_shader_flags(const std::vector<std::string>& flags) {
    std::vector<StageShader> shaders;
    for (const std::string& flag : flags) {
        const std::string typed = "--shader " + flag;
        const std::size_t eq = flag.find('=');
        if (eq == std::string::npos || eq + 1 == flag.size())
            throw Error("--shader takes STAGE=FILE, not '" + flag + "'", Where::in_file("--shader"));
        const std::string name = flag.substr(0, eq);
        const auto stage = shader_stage_from_string(name);
        if (!stage)
            throw Error("unknown shader stage '" + name + "' in " + typed +
                            " (known: vertex|vert, tess_control|tesc, tess_evaluation|tese, geometry|geom, "
                            "fragment|frag)",
                        Where::in_file("--shader"));
        for (const StageShader& s : shaders)
            if (s.stage == *stage)
                throw Error(std::string("--shader names the ") + to_string(*stage) + " stage twice (" + s.origin +
                                ", " + typed + ")",
                            Where::in_file("--shader"));
        shaders.push_back(StageShader{*stage, flag.substr(eq + 1), typed, Where::in_file("--shader")});
    }
    return shaders;
}

void apply_shader_flags(Scene& scene, const std::vector<StageShader>& flags) {
    scene.shaders = pipeline::with_shader_flags(scene.shaders, flags);
}

void apply_max_instructions_flag(const std::string& text) {
    if (text.empty()) return;
    const std::optional<long long> n = parse_integer(text);
    if (!n || *n < 1)
        throw Error("--max-instructions takes a whole number >= 1, not '" + text + "'", Where::in_file("--max-instructions"));
    shader::set_default_max_instructions(static_cast<std::uint64_t>(*n));
}

MathMode parse_math_flag(const std::string& text) {
    if (text == "exact") return MathMode::exact;
    if (text == "llvmpipe") return MathMode::llvmpipe;
    throw Error("unknown math mode '" + text + "'; expected exact or llvmpipe", Where::in_file("--math"));
}

std::string math_note(MathMode math) { return math == MathMode::llvmpipe ? ", llvmpipe math" : ""; }

ThreadLimit::ThreadLimit(int threads) {
    if (threads < 0)
        throw Error("thread count must be >= 0 (0: every core), got " + std::to_string(threads), Where::in_file("--threads"));
    if (threads > 0) control_.emplace(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
}

void add_math_option(CLI::App& app, std::string& math) {
    app.add_option("--math", math,
                    "The control stage's acos and log2 in gpu precision: exact (the C library, correctly rounded) "
                    "or llvmpipe (Mesa llvmpipe's approximations, bit for bit, as `tessref gl` predicts with)")
        ->default_val("exact");
}

void add_cpu_shader_options(CLI::App& app, std::vector<std::string>& shaders, std::string& max_instructions) {
    app.add_option("--shader", shaders, "A GLSL file of your own for one stage (repeatable; over the scene's [shaders]): STAGE is "
                    "vertex|vert, tess_control|tesc, tess_evaluation|tese or geometry|geom, which the CPU runs through its SPIR-V "
                    "interpreter with the twins' uniforms and textures (docs/CLI.md: Your shaders on the CPU)")
        ->type_name("STAGE=FILE")
        ->allow_extra_args(false);
    app.add_option("--max-instructions", max_instructions,
                    "Instructions one shader invocation of a user's stage may run before it is stopped (default "
                    "10000000): a shader that never ends is an error naming the stage, patch and invocation")
        ->type_name("N");
}

}  // namespace tessref::cli
