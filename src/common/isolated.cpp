#include "common/isolated.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <algorithm>
#include <new>

#include "tessref/limits.h"

namespace tessref {

namespace {

// The page the child writes its phase into and the parent reads after the child died.
struct Phase {
    char doing[1536];
    char file[1024];
    int line;
};
Phase* g_phase = nullptr;  // non-null in the child only
int g_answer_fd = -1;      // the child's end of the pipe, in the child only

void copy_to(char* to, std::size_t size, const std::string& from) {
    const std::size_t n = std::min(size - 1, from.size());
    std::memcpy(to, from.data(), n);
    to[n] = '\0';
}

// The child's answer on the pipe: pieces sent ahead ('C', the length as 8 bytes, the
// bytes; any number of them), then one tag byte and the bytes up to the end of the pipe:
//   'R' result bytes | 'E' an Error: what \0 file \0 line \0 column \0 key \0 patch
void put_u64(std::string& out, std::uint64_t v) { out.append(reinterpret_cast<const char*>(&v), sizeof v); }

bool write_all(int fd, const char* bytes, std::size_t size) {
    while (size > 0) {
        const ssize_t n = ::write(fd, bytes, size);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return false;
        bytes += n;
        size -= static_cast<std::size_t>(n);
    }
    return true;
}

std::string error_bytes(const Error& e) {
    const Where& w = e.where();
    std::string out = "E";
    const std::string what = e.what();
    for (const std::string* s : {&what, &w.file, &w.key}) {
        put_u64(out, s->size());
        out += *s;
    }
    put_u64(out, static_cast<std::uint64_t>(static_cast<std::int64_t>(w.line)));
    put_u64(out, static_cast<std::uint64_t>(static_cast<std::int64_t>(w.column)));
    put_u64(out, static_cast<std::uint64_t>(w.patch_id));
    return out;
}

Error error_from(const std::string& bytes) {
    std::size_t at = 1;
    auto u64 = [&]() -> std::uint64_t {
        std::uint64_t v = 0;
        if (at + sizeof v <= bytes.size()) std::memcpy(&v, bytes.data() + at, sizeof v);
        at += sizeof v;
        return v;
    };
    auto str = [&]() {
        const std::uint64_t n = u64();
        std::string s = at <= bytes.size() ? bytes.substr(at, static_cast<std::size_t>(n)) : std::string();
        at += static_cast<std::size_t>(n);
        return s;
    };
    const std::string what = str();
    Where where;
    where.file = str();
    where.key = str();
    where.line = static_cast<int>(static_cast<std::int64_t>(u64()));
    where.column = static_cast<int>(static_cast<std::int64_t>(u64()));
    where.patch_id = static_cast<long long>(u64());
    return Error(what, where);
}

// The address space mapped now (/proc/self/statm's first field, in pages).
std::uint64_t mapped_bytes() {
    std::FILE* f = std::fopen("/proc/self/statm", "r");
    unsigned long long pages = 0;
    if (f) {
        if (std::fscanf(f, "%llu", &pages) != 1) pages = 0;
        std::fclose(f);
    }
    return saturating_bytes(pages, static_cast<std::uint64_t>(::sysconf(_SC_PAGE_SIZE)));
}

[[noreturn]] void run_child(int fd, const std::function<std::string()>& work, std::uint64_t address_space) {
    for (const int s : {SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGPIPE}) ::signal(s, SIG_DFL);  // the parent cleans up
    const struct rlimit no_core {0, 0};
    ::setrlimit(RLIMIT_CORE, &no_core);
    const struct rlimit space {address_space, address_space};
    ::setrlimit(RLIMIT_AS, &space);
    std::string answer;
    try {
        answer = "R" + work();
    } catch (const Error& e) {
        answer = error_bytes(e);
    } catch (const std::bad_alloc&) {
        answer = error_bytes(Error("out of memory (the limit of " + format_bytes(address_space) +
                                   " of address space) while " + std::string(g_phase->doing)));
    } catch (const std::exception& e) {
        answer = error_bytes(Error(std::string(e.what()) + " while " + g_phase->doing));
    }
    const bool written = write_all(fd, answer.data(), answer.size());
    ::_exit(written ? 0 : 3);
}

const char* signal_text(int s) {
    switch (s) {
        case SIGSEGV: return "SIGSEGV (a crash)";
        case SIGBUS: return "SIGBUS (a crash)";
        case SIGABRT: return "SIGABRT (an abort)";
        case SIGILL: return "SIGILL (a crash)";
        case SIGFPE: return "SIGFPE (a crash)";
        case SIGKILL: return "SIGKILL (the kernel's out-of-memory killer, or a user)";
        default: return strsignal(s);
    }
}

}  // namespace

double isolation_time_limit() {
    const char* env = std::getenv("TESSREF_GL_TIME_LIMIT");
    if (!env || !*env) return 600.0;
    char* end = nullptr;
    const double seconds = std::strtod(env, &end);
    if (end == env || *end != '\0' || !std::isfinite(seconds) || seconds <= 0.0 || seconds > 1e6)
        throw Error(std::string("'") + env + "' is not a time limit in seconds (a number in (0, 1e6])",
                    Where::at_key("TESSREF_GL_TIME_LIMIT"));
    return seconds;
}

void send_to_parent(std::string_view bytes) {
    if (g_answer_fd < 0) throw Error("send_to_parent() outside a child process of run_isolated()");
    std::string head = "C";
    put_u64(head, bytes.size());
    if (!write_all(g_answer_fd, head.data(), head.size()) || !write_all(g_answer_fd, bytes.data(), bytes.size()))
        throw Error("cannot send to the parent process: " + std::string(std::strerror(errno)));
}

void set_isolated_phase(const std::string& doing, const Where& where) {
    if (!g_phase) return;
    copy_to(g_phase->doing, sizeof g_phase->doing, doing);
    copy_to(g_phase->file, sizeof g_phase->file, where.file);
    g_phase->line = where.line;
}

struct IsolatedChild::State {
    std::string what;
    double seconds = 0.0;
    std::uint64_t budget = 0;
    Phase* phase = nullptr;  // a shared page, unmapped with the state
    int fd = -1;             // the pipe's read end
    pid_t child = -1;        // reaped: -1

    ~State() {
        if (fd >= 0) ::close(fd);
        if (child > 0) {
            ::kill(child, SIGKILL);
            reap();
        }
        if (phase) ::munmap(phase, sizeof(Phase));
    }
    int reap() {
        int status = 0;
        while (::waitpid(child, &status, 0) < 0 && errno == EINTR) {
        }
        child = -1;
        return status;
    }
};

IsolatedChild::IsolatedChild(std::unique_ptr<State> state) : state_(std::move(state)) {}
IsolatedChild::IsolatedChild() = default;
IsolatedChild::IsolatedChild(IsolatedChild&&) noexcept = default;
IsolatedChild& IsolatedChild::operator=(IsolatedChild&&) noexcept = default;
IsolatedChild::~IsolatedChild() = default;

IsolatedChild start_isolated(const std::string& what, const std::function<std::string()>& work,
                             const IsolationLimits& limits) {
    auto st = std::make_unique<IsolatedChild::State>();
    st->what = what;
    st->seconds = limits.seconds > 0.0 ? limits.seconds : isolation_time_limit();
    st->budget = limits.memory_bytes != 0 ? limits.memory_bytes : memory_limit();
    const std::uint64_t mapped = mapped_bytes();
    const std::uint64_t address_space = mapped > UINT64_MAX - st->budget ? UINT64_MAX : mapped + st->budget;

    void* shared = ::mmap(nullptr, sizeof(Phase), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    if (shared == MAP_FAILED) throw Error(what + ": cannot map a page for the child process: " + std::strerror(errno));
    st->phase = new (shared) Phase{};
    copy_to(st->phase->doing, sizeof st->phase->doing, "starting");

    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) throw Error(what + ": cannot make a pipe: " + std::strerror(errno));
    std::fflush(nullptr);  // nothing buffered is written twice
    const pid_t child = ::fork();
    if (child < 0) {
        ::close(fds[0]);
        ::close(fds[1]);
        throw Error(what + ": cannot start a child process: " + std::strerror(errno));
    }
    if (child == 0) {
        ::close(fds[0]);
        g_phase = st->phase;
        g_answer_fd = fds[1];
        run_child(fds[1], work, address_space);
    }
    ::close(fds[1]);
    st->fd = fds[0];
    st->child = child;
    return IsolatedChild(std::move(st));
}

std::string IsolatedChild::finish(const std::function<void()>& meanwhile,
                                  const std::function<void(std::string_view)>& on_chunk) {
    if (!state_) throw Error("IsolatedChild::finish() of a child that was not started or is finished");
    // However this ends, the state goes with it: an exception kills and reaps the child.
    const std::unique_ptr<State> st = std::move(state_);
    const std::string& what = st->what;
    if (meanwhile) meanwhile();

    // Read the answer until the child closes the pipe (it exits), or the time is up. The
    // pieces sent ahead go to on_chunk as each is complete; `at` is where the next begins.
    std::string answer;
    std::size_t at = 0;
    bool in_answer = false;  // past the pieces: the rest is the answer
    const auto take_pieces = [&] {
        while (!in_answer && at < answer.size()) {
            if (answer[at] != 'C') {
                in_answer = true;
                break;
            }
            std::uint64_t n = 0;
            if (answer.size() - at < 1 + sizeof n) break;
            std::memcpy(&n, answer.data() + at + 1, sizeof n);
            if (answer.size() - at - 1 - sizeof n < n) break;
            if (on_chunk) on_chunk(std::string_view(answer).substr(at + 1 + sizeof n, n));
            at += 1 + sizeof n + n;
        }
        if (at > 0 && (in_answer || at == answer.size() || at >= (std::size_t(1) << 20))) {
            answer.erase(0, at);
            at = 0;
        }
    };
    bool timed_out = false;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(st->seconds);
    char block[1 << 16];
    for (;;) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0) {
            timed_out = true;
            break;
        }
        struct pollfd p {st->fd, POLLIN, 0};
        const int ready = ::poll(&p, 1, static_cast<int>(std::min<long long>(left.count(), 1000)));
        if (ready < 0 && errno == EINTR) continue;
        if (ready <= 0) continue;
        const ssize_t n = ::read(st->fd, block, sizeof block);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break;
        answer.append(block, static_cast<std::size_t>(n));
        take_pieces();
    }
    // A piece the child did not finish is no answer.
    if (!in_answer) answer.clear();
    ::close(st->fd);
    st->fd = -1;
    if (timed_out) ::kill(st->child, SIGKILL);
    const int status = st->reap();

    const std::string doing = st->phase->doing;
    Where where;
    if (st->phase->file[0])
        where = Where::in_file(st->phase->file, static_cast<std::size_t>(std::max(0, st->phase->line)));
    char limit_text[64];
    std::snprintf(limit_text, sizeof limit_text, "%g s", st->seconds);
    if (timed_out)
        throw Error(what + " ran past its time limit of " + limit_text + " while " + doing +
                        " (raise it with TESSREF_GL_TIME_LIMIT=SECONDS)",
                    where);
    if (WIFSIGNALED(status))
        throw Error(what + " was killed by " + signal_text(WTERMSIG(status)) + " while " + doing +
                        "; its memory limit was " + format_bytes(st->budget) +
                        " (a driver that runs out of memory crashes; raise it with --max-memory or TESSREF_MAX_MEMORY)",
                    where);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || answer.empty())
        throw Error(what + " ended without an answer (exit status " +
                        std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ") while " + doing,
                    where);
    if (answer[0] == 'E') throw error_from(answer);
    answer.erase(0, 1);  // in place: a capture's answer is hundreds of MB, a copy as many again
    return answer;
}

std::string run_isolated(const std::string& what, const std::function<std::string()>& work,
                         const IsolationLimits& limits, const std::function<void()>& meanwhile,
                         const std::function<void(std::string_view)>& on_chunk) {
    return start_isolated(what, work, limits).finish(meanwhile, on_chunk);
}

}  // namespace tessref
