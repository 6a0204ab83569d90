// src/common/temp_name.h — the one rule for the names of temporary files and directories
// that tessref writes beside an output before renaming them into place (AtomicOutput in
// src/cli/cli_util.cpp, the sweep's directory and report files in src/sweep/).
//
// A temporary name is longer than the name it stands for (a leading dot, the process id, a
// counter, ".tmp"), so a legal output name near the file system's limit (NAME_MAX, 255
// bytes on Linux) would give an illegal temporary one: "File name too long" for an output
// the file system accepts. The part taken from the output's name is therefore cut until the
// whole fits, at a UTF-8 character boundary; what makes the name unique (process id,
// counter, mkdtemp's XXXXXX) and the extension a writer picks its format by are never cut.
#pragma once

#include <climits>
#include <string>
#include <string_view>

namespace tessref {

// The longest file name (one path component) tessref makes: Linux's NAME_MAX.
inline constexpr std::size_t kMaxFileName = NAME_MAX;

// lead + name + middle + suffix, with `name` cut (at a UTF-8 character boundary) so that the
// whole is at most kMaxFileName bytes.
inline std::string temporary_name(std::string_view lead, std::string_view name, std::string_view middle,
                                  std::string_view suffix) {
    const std::size_t fixed = lead.size() + middle.size() + suffix.size();
    std::size_t keep = name.size();
    if (fixed + keep > kMaxFileName) {
        keep = fixed < kMaxFileName ? kMaxFileName - fixed : 0;
        while (keep > 0 && (static_cast<unsigned char>(name[keep]) & 0xC0) == 0x80) --keep;
    }
    std::string out;
    out.reserve(fixed + keep);
    out.append(lead).append(name.substr(0, keep)).append(middle).append(suffix);
    return out;
}

}  // namespace tessref
