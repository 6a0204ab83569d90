#include "common/temp_cleanup.h"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <climits>
#include <csignal>
#include <cstring>
#include <mutex>
#include <utility>
#include <vector>
#include <system_error>

#include <dirent.h>
#include <fcntl.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace tessref {

namespace {

// Live temporaries, for the signal handler: it may only read memory that no one frees or
// moves under it, so each slot is a fixed path buffer behind a lock-free state.
constexpr int kSlotFree = 0, kSlotFilling = 1, kSlotLive = 2;
struct TempSlot {
    std::atomic<int> state{kSlotFree};
    bool directory = false;
    char path[PATH_MAX];
};
TempSlot temp_slots[64];

// The kernel's directory entry (getdents64(2)); glibc's readdir is not async-signal-safe.
struct KernelDirent {
    unsigned long long d_ino;
    long long d_off;
    unsigned short d_reclen;
    unsigned char d_type;
    char d_name[1];
};

bool is_dot_or_dot_dot(const char* name) {
    return name[0] == '.' && (name[1] == '\0' || (name[1] == '.' && name[2] == '\0'));
}

// Removes `name` under the directory `parent` (a directory with everything in it), with
// async-signal-safe system calls only. Another thread of the process may still be writing
// into it: each directory is read again until a pass finds nothing left (at most 64
// passes), and the depth is bounded (tessref's temporary directories are two levels deep).
void remove_tree(int parent, const char* name, int depth) {
    if (::unlinkat(parent, name, 0) == 0 || (errno != EISDIR && errno != EPERM)) return;
    const int fd = ::openat(parent, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) return;
    alignas(8) char buffer[4096];
    for (int pass = 0; pass < 64 && depth < 16; ++pass) {
        bool found = false;
        ::lseek(fd, 0, SEEK_SET);
        for (;;) {
            const long n = ::syscall(SYS_getdents64, fd, buffer, sizeof buffer);
            if (n <= 0) break;
            for (long at = 0; at < n;) {
                const auto* entry = reinterpret_cast<const KernelDirent*>(buffer + at);
                at += entry->d_reclen;
                if (is_dot_or_dot_dot(entry->d_name)) continue;
                found = true;
                remove_tree(fd, entry->d_name, depth + 1);
            }
        }
        if (!found) break;
    }
    ::close(fd);
    ::unlinkat(parent, name, AT_REMOVEDIR);
}

extern "C" void remove_temporaries_and_die(int signal_number) {
    const int saved = errno;
    for (TempSlot& slot : temp_slots) {
        if (slot.state.load() != kSlotLive) continue;
        if (slot.directory)
            remove_tree(AT_FDCWD, slot.path, 0);
        else
            ::unlink(slot.path);
    }
    errno = saved;
    ::signal(signal_number, SIG_DFL);
    ::raise(signal_number);  // pending until this handler returns, then the default action
}

}  // namespace

void install_signal_cleanup() {
    // SIGPIPE too: a reader of a FIFO or pipe output that goes away kills us the same way.
    // SIGQUIT (Ctrl-\) dumps core by default, and still does, after the cleanup.
    for (const int signal_number : {SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGPIPE}) {
        struct sigaction current {};
        if (::sigaction(signal_number, nullptr, &current) != 0 || current.sa_handler == SIG_IGN) continue;
        struct sigaction action {};
        action.sa_handler = remove_temporaries_and_die;
        sigemptyset(&action.sa_mask);
        ::sigaction(signal_number, &action, nullptr);
    }
}

int register_temporary(const std::filesystem::path& path, bool directory) {
    std::error_code error;
    const std::string absolute = std::filesystem::absolute(path, error).string();
    if (error || absolute.size() >= PATH_MAX) return -1;
    for (int i = 0; i < static_cast<int>(std::size(temp_slots)); ++i) {
        int expected = kSlotFree;
        if (!temp_slots[i].state.compare_exchange_strong(expected, kSlotFilling)) continue;
        std::memcpy(temp_slots[i].path, absolute.c_str(), absolute.size() + 1);
        temp_slots[i].directory = directory;
        temp_slots[i].state.store(kSlotLive);
        return i;
    }
    return -1;
}

void unregister_temporary(int slot) {
    if (slot >= 0) temp_slots[slot].state.store(kSlotFree);
}

namespace {
// Every temporary this process named, never forgotten: an error is printed after its owner
// has removed the file. A handful per command.
std::mutex user_names_mutex;
std::vector<std::pair<std::string, std::string>> user_names;  // temporary path, name shown
}  // namespace

void name_temporary(const std::filesystem::path& path, const std::filesystem::path& shown_as) {
    const std::lock_guard lock(user_names_mutex);
    user_names.emplace_back(path.string(), shown_as.string());
    std::error_code error;
    const std::filesystem::path absolute = std::filesystem::absolute(path, error);
    if (!error && absolute != path) user_names.emplace_back(absolute.string(), shown_as.string());
}

std::string with_user_file_names(std::string message) {
    const std::lock_guard lock(user_names_mutex);
    // Longest first, so that an absolute path is replaced whole before its relative tail is.
    std::vector<std::pair<std::string, std::string>> names = user_names;
    std::stable_sort(names.begin(), names.end(),
                     [](const auto& a, const auto& b) { return a.first.size() > b.first.size(); });
    for (const auto& [temporary, shown] : names) {
        if (temporary.empty()) continue;
        for (std::size_t at = message.find(temporary); at != std::string::npos;
             at = message.find(temporary, at + shown.size()))
            message.replace(at, temporary.size(), shown);
    }
    return message;
}

void remove_stale_temporaries(const std::filesystem::path& dir, std::string_view lead, std::string_view name,
                              std::string_view before_pid) {
    std::error_code ec;
    for (const std::filesystem::directory_entry& entry :
         std::filesystem::directory_iterator(dir.empty() ? "." : dir, ec)) {
        const std::string file = entry.path().filename().string();
        // lead + a prefix of name (temp_name.h may have cut it) + before_pid + digits.
        if (!file.starts_with(lead)) continue;
        long long pid = 0;
        for (std::size_t marker = file.find(before_pid, lead.size()); marker != std::string::npos && pid == 0;
             marker = file.find(before_pid, marker + 1)) {
            const std::string_view kept = std::string_view(file).substr(lead.size(), marker - lead.size());
            if (!name.starts_with(kept) || (kept.empty() && !name.empty())) continue;
            std::size_t at = marker + before_pid.size();
            const std::size_t digits_start = at;
            long long digits = 0;
            while (at < file.size() && file[at] >= '0' && file[at] <= '9' && at - digits_start < 10)
                digits = digits * 10 + (file[at++] - '0');
            if (at > digits_start) pid = digits;
        }
        if (pid <= 0 || pid > INT_MAX || pid == ::getpid()) continue;
        if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // alive, or not ours to judge
        std::error_code ignored;
        std::filesystem::remove_all(entry.path(), ignored);
    }
}

}  // namespace tessref
