// src/cli/golden_files.h — reading the digest files of `tessref golden` (capture.txt,
// mesh.txt; their format is written by src/cli/cmd_golden.cpp and described in
// golden/README.md).
//
// A golden file is trusted input to `verify`: a digest it holds decides PASS or STALE. So a
// file that is not exactly what `golden update` writes is refused (tessref::Error naming
// the file and the line, exit 2) rather than read as far as it goes: a malformed digest
// would otherwise read as "the reference changed" (STALE), and a deleted or duplicated
// `patch` line, or levels that are not numbers, would go unnoticed.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>

namespace tessref::cli {

inline constexpr const char* kGoldenCaptureHeader = "tessref-golden-capture 1";
inline constexpr const char* kGoldenMeshHeader = "tessref-golden-mesh 1";
// A patch's digest keeps the first 16 hex digits of its SHA-256 (64 bits: a changed patch
// goes unnoticed with probability 2^-64; the whole capture's digest is kept in full).
inline constexpr std::size_t kGoldenPatchDigits = 16;

struct GoldenCapture {
    std::string size;                                 // "WxH", as parse_image_size reads it
    std::size_t patches = 0;                          // the `capture` line's count
    std::size_t triangles = 0;                        // ... and its triangles
    std::string capture_sha256;                       // 64 lower-case hex digits
    std::map<std::uint32_t, std::string> patch_sha256;  // 16 lower-case hex digits each
};

struct GoldenMesh {
    std::size_t vertices = 0;
    std::size_t triangles = 0;
    std::size_t bytes = 0;
    std::string sha256;  // 64 lower-case hex digits
};

// Parse the text of capture.txt / mesh.txt; `path` names the file in errors.
//
// capture.txt: the header line; comment lines (#) and blank lines anywhere; exactly one
// `size WxH` (1..16384 each); exactly one `capture patches P triangles T sha256 H`; then
// exactly P lines `patch ID levels L1 .. L6 triangles N sha256 h` (six finite numbers,
// N whole) whose N add up to T.
// mesh.txt: the header line, comments, exactly one
// `mesh vertices V triangles T bytes B sha256 H`.
GoldenCapture parse_golden_capture(std::string_view text, const std::string& path);
GoldenMesh parse_golden_mesh(std::string_view text, const std::string& path);

}  // namespace tessref::cli
