// src/common/input_file.h — the one way tessref opens a file it reads.
//
// Every input (a scene, a shader, a PVS file, a golden file, a sweep table, an image's
// first bytes) is opened here, so that every one of them gets the same three checks before
// a byte is read:
//  - regular files only: a FIFO would block the open and then be read until its writer
//    stops (forever, for one that never writes), /dev/zero or /dev/urandom never end, and a
//    directory has no bytes; each is refused with an Error naming the file;
//  - the open never blocks (O_NONBLOCK: a FIFO that appears between the check and the open
//    is still seen by fstat on the descriptor, which is what is checked);
//  - a size cap per kind of input, from the file's size before reading it: a 3 GB "scene"
//    is refused at once instead of after reading 2 GB of it. The caps are far above any
//    real input of the kind (see the k*Bytes constants) and each is also held to the
//    memory budget (limits.h).
#pragma once

#include <cstdint>
#include <string>

#include "tessref/error.h"

namespace tessref {

// Caps per kind of text input, far above the largest real one of each.
inline constexpr std::uint64_t kSceneFileBytes = std::uint64_t{16} << 20;    // shipped scenes: < 3 KiB
inline constexpr std::uint64_t kShaderFileBytes = std::uint64_t{4} << 20;    // shipped shaders: < 9 KiB
inline constexpr std::uint64_t kTableFileBytes = std::uint64_t{256} << 20;   // golden and sweep files
inline constexpr std::uint64_t kNoCap = UINT64_MAX;                          // the memory budget only

// A regular file opened for reading (close-on-exec, never blocking). `kind` names the file
// in messages ("scene file", "the PVS file"); `where` is where the error points (the file
// itself when empty; a scene key for a file a scene names).
// What the file is to the command: an input (remembered: no output may replace it), or a
// file only looked at (whether an output directory is an earlier sweep's).
enum class FileUse { input, inspection };

class InputFile {
public:
    InputFile(const std::string& path, const std::string& kind, Where where = {}, FileUse use = FileUse::input);
    ~InputFile();
    InputFile(const InputFile&) = delete;
    InputFile& operator=(const InputFile&) = delete;

    std::uint64_t size() const { return size_; }
    const std::string& path() const { return path_; }
    // Up to `count` bytes from the start (fewer when the file is shorter): magic numbers.
    std::string head(std::size_t count) const;
    // The whole file, refused (before reading) when larger than `max_bytes` or the memory
    // budget.
    std::string read_all(std::uint64_t max_bytes) const;

private:
    [[noreturn]] void fail(const std::string& what) const;

    std::string path_;
    std::string kind_;
    Where where_;
    int fd_ = -1;
    std::uint64_t size_ = 0;
};

// InputFile(path, kind, where).read_all(max_bytes).
std::string read_input_file(const std::string& path, const std::string& kind, std::uint64_t max_bytes,
                            Where where = {}, FileUse use = FileUse::input);

// ---- the inputs of this process ----------------------------------------------------------
//
// Every file opened through InputFile is remembered (device and inode, and the name it was
// read by), so that no output of the command replaces one of its own inputs: `render
// sc.toml -o tex.png` where tex.png is the scene's texture, a diff written over the image it
// compares, `sweep merge a b -o a`. The check is by inode, so symlinks and hard links to an
// input are caught as the input itself. A reader that does not open through InputFile (the
// memory-mapped mesh readers) names its file with note_input().

// Remembers `path` (followed through symlinks) as an input; nothing when it does not exist.
void note_input(const std::string& path);
// The name of the input that `path` (followed through symlinks) is, or "" when it is none.
std::string input_named_by(const std::string& path);
// The same for an open descriptor (an output written through /dev/stdout into a file).
std::string input_open_as(int fd);

}  // namespace tessref
