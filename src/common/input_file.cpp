#include "common/input_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <mutex>
#include <vector>

#include "tessref/limits.h"

namespace tessref {

namespace {

struct KnownInput {
    dev_t device;
    ino_t inode;
    std::string path;
};

std::mutex g_inputs_mutex;
std::vector<KnownInput> g_inputs;

void remember(const struct stat& st, const std::string& path) {
    const std::lock_guard<std::mutex> lock(g_inputs_mutex);
    for (const KnownInput& k : g_inputs)
        if (k.device == st.st_dev && k.inode == st.st_ino) return;
    g_inputs.push_back({st.st_dev, st.st_ino, path});
}

std::string lookup(const struct stat& st) {
    const std::lock_guard<std::mutex> lock(g_inputs_mutex);
    for (const KnownInput& k : g_inputs) {
        if (k.device != st.st_dev || k.inode != st.st_ino) continue;
        // Still that file: an input deleted since (a temporary picture read back) may have
        // left its inode number to a new file, which is no input.
        struct stat now {};
        if (::stat(k.path.c_str(), &now) == 0 && now.st_dev == k.device && now.st_ino == k.inode) return k.path;
    }
    return {};
}

}  // namespace

void note_input(const std::string& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0) remember(st, path);
}

std::string input_named_by(const std::string& path) {
    struct stat st {};
    return ::stat(path.c_str(), &st) == 0 ? lookup(st) : std::string();
}

std::string input_open_as(int fd) {
    struct stat st {};
    return ::fstat(fd, &st) == 0 ? lookup(st) : std::string();
}

InputFile::InputFile(const std::string& path, const std::string& kind, Where where, FileUse use)
    : path_(path), kind_(kind), where_(std::move(where)) {
    if (where_.file.empty() && where_.key.empty()) where_ = Where::in_file(path);
    fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
    if (fd_ < 0) {
        const int error = errno;
        fail(error == ENOENT ? "not found" : std::string("cannot be opened: ") + std::strerror(error));
    }
    struct stat st {};
    if (::fstat(fd_, &st) != 0) fail(std::string("cannot be read: ") + std::strerror(errno));
    if (S_ISDIR(st.st_mode)) fail("is a directory, not a file");
    if (!S_ISREG(st.st_mode)) fail("is not a regular file (a device, FIFO or socket has no end to read to)");
    size_ = static_cast<std::uint64_t>(st.st_size);
    if (use == FileUse::input) remember(st, path);
    // Reads from here on may block as a regular file's do (O_NONBLOCK means nothing there).
}

InputFile::~InputFile() {
    if (fd_ >= 0) ::close(fd_);
}

void InputFile::fail(const std::string& what) const {
    Where where = where_;
    // A scene key's place names the scene; the file itself is then part of the message.
    const bool names_file = where.file == path_;
    throw Error(kind_ + (names_file ? std::string() : " " + path_) + " " + what, where);
}

std::string InputFile::head(std::size_t count) const {
    std::string bytes(count, '\0');
    std::size_t got = 0;
    while (got < count) {
        const ssize_t n = ::pread(fd_, bytes.data() + got, count - got, static_cast<off_t>(got));
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) fail(std::string("cannot be read: ") + std::strerror(errno));
        if (n == 0) break;
        got += static_cast<std::size_t>(n);
    }
    bytes.resize(got);
    return bytes;
}

std::string InputFile::read_all(std::uint64_t max_bytes) const {
    if (size_ > max_bytes)
        fail("is " + format_bytes(size_) + ", more than a " + kind_ + " may be (" + format_bytes(max_bytes) + ")");
    require_memory(size_, kind_ + " " + path_ + " of " + format_bytes(size_), where_);
    std::string bytes = head(static_cast<std::size_t>(size_));
    if (bytes.size() != size_) fail("changed while it was read (shorter than its size)");
    return bytes;
}

std::string read_input_file(const std::string& path, const std::string& kind, std::uint64_t max_bytes, Where where,
                            FileUse use) {
    return InputFile(path, kind, std::move(where), use).read_all(max_bytes);
}

}  // namespace tessref
