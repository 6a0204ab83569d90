// common/file_name.h — a file's format as its name says it (private to the library).
#pragma once

#include <cctype>
#include <filesystem>
#include <string>

namespace tessref {

// The extension without its dot, lowercased ("x.PLY" -> "ply"); "" when there is none.
// Formats are chosen by it (meshes, captures, `tessref tessellate -o`).
inline std::string lowercase_extension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    if (!ext.empty() && ext[0] == '.') ext.erase(0, 1);
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

}  // namespace tessref
