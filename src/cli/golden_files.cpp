#include "cli/golden_files.h"

#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <vector>

#include <glm/glm.hpp>

#include "cli/cli_util.h"
#include "tessref/error.h"

namespace tessref::cli {

namespace {

// The words of a line, split at single spaces as the writer writes them: a doubled space,
// a tab or a trailing space is not the writer's and is refused with the rest.
std::vector<std::string_view> words_of(std::string_view line) {
    std::vector<std::string_view> words;
    std::size_t start = 0;
    for (;;) {
        const std::size_t space = line.find(' ', start);
        words.push_back(line.substr(start, space == std::string_view::npos ? std::string_view::npos : space - start));
        if (space == std::string_view::npos) break;
        start = space + 1;
    }
    return words;
}

bool is_hex_digest(std::string_view word, std::size_t digits) {
    if (word.size() != digits) return false;
    for (const char c : word)
        if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
    return true;
}

// A count as the writer prints it: decimal digits, no sign, at most what size_t holds.
std::optional<std::size_t> count_of(std::string_view word) {
    if (word.empty() || word.size() > 18) return std::nullopt;  // 10^18 - 1: more than any file holds
    for (const char c : word)
        if (c < '0' || c > '9') return std::nullopt;
    const std::optional<long long> value = parse_integer(word);
    if (!value) return std::nullopt;
    return static_cast<std::size_t>(*value);
}

// Calls line(number, text) for every line but comments and blank lines, after checking the
// first line is `header`.
template <class F>
void for_each_line(std::string_view text, const std::string& path, const char* header, const char* what, F&& line) {
    std::size_t number = 0;
    bool seen_header = false;
    while (!text.empty()) {
        const std::size_t end = text.find('\n');
        std::string_view current = text.substr(0, end);
        text.remove_prefix(end == std::string_view::npos ? text.size() : end + 1);
        ++number;
        if (!current.empty() && current.back() == '\r') current.remove_suffix(1);
        if (!seen_header) {
            if (current != header)
                throw Error(std::string("not a ") + what + " (the first line must be '" + header + "')",
                            Where::in_file(path, number));
            seen_header = true;
            continue;
        }
        if (current.empty() || current.front() == '#') continue;
        line(number, current);
    }
    if (!seen_header) throw Error(std::string("not a ") + what + " (the file is empty)", Where::in_file(path));
}

}  // namespace

GoldenCapture parse_golden_capture(std::string_view text, const std::string& path) {
    GoldenCapture g;
    bool have_size = false, have_capture = false;
    std::size_t patch_lines = 0, patch_triangles = 0;
    for_each_line(text, path, kGoldenCaptureHeader, "golden capture digest", [&](std::size_t n, std::string_view line) {
        const Where where = Where::in_file(path, n);
        const std::vector<std::string_view> w = words_of(line);
        const auto bad = [&](const std::string& why) {
            throw Error("malformed line '" + std::string(line.substr(0, 120)) + "': " + why, where);
        };
        if (w[0] == "size") {
            if (have_size) bad("a second `size` line");
            if (w.size() != 2) bad("expected `size WxH`");
            (void)parse_image_size(std::string(w[1]), path);
            g.size = std::string(w[1]);
            have_size = true;
        } else if (w[0] == "capture") {
            if (have_capture) bad("a second `capture` line");
            if (w.size() != 7 || w[1] != "patches" || w[3] != "triangles" || w[5] != "sha256")
                bad("expected `capture patches P triangles T sha256 H`");
            const auto patches = count_of(w[2]), triangles = count_of(w[4]);
            if (!patches || !triangles) bad("the counts are not whole numbers");
            if (!is_hex_digest(w[6], 64)) bad("the sha256 is not 64 lower-case hex digits");
            g.patches = *patches;
            g.triangles = *triangles;
            g.capture_sha256 = std::string(w[6]);
            have_capture = true;
        } else if (w[0] == "patch") {
            if (!have_capture) bad("a `patch` line before the `capture` line");
            if (w.size() != 13 || w[2] != "levels" || w[9] != "triangles" || w[11] != "sha256")
                bad("expected `patch ID levels L1 L2 L3 L4 L5 L6 triangles N sha256 H`");
            const auto id = count_of(w[1]), triangles = count_of(w[10]);
            if (!id || *id > std::numeric_limits<std::uint32_t>::max()) bad("the patch id is not a 32-bit whole number");
            for (std::size_t k = 3; k < 9; ++k) {
                const std::optional<float> level = parse_float(w[k]);
                if (!level || !std::isfinite(*level)) bad("level " + std::to_string(k - 2) + " is not a finite number");
            }
            if (!triangles) bad("the triangle count is not a whole number");
            if (!is_hex_digest(w[12], kGoldenPatchDigits))
                bad("the sha256 is not " + std::to_string(kGoldenPatchDigits) + " lower-case hex digits");
            ++patch_lines;
            patch_triangles += *triangles;
            if (patch_lines > g.patches) bad("more `patch` lines than the `capture` line's " + std::to_string(g.patches));
            g.patch_sha256[static_cast<std::uint32_t>(*id)] = std::string(w[12]);
        } else {
            bad("unknown line");
        }
    });
    const Where where = Where::in_file(path);
    if (!have_size) throw Error("not a golden capture digest: no `size` line", where);
    if (!have_capture) throw Error("not a golden capture digest: no `capture` line", where);
    if (patch_lines != g.patches)
        throw Error("the `capture` line counts " + std::to_string(g.patches) + " patches, the file lists " +
                        std::to_string(patch_lines) + " (a deleted or duplicated `patch` line?)",
                    where);
    if (patch_triangles != g.triangles)
        throw Error("the `capture` line counts " + std::to_string(g.triangles) + " triangles, the `patch` lines add up to " +
                        std::to_string(patch_triangles),
                    where);
    return g;
}

GoldenMesh parse_golden_mesh(std::string_view text, const std::string& path) {
    GoldenMesh m;
    bool have_mesh = false;
    for_each_line(text, path, kGoldenMeshHeader, "golden mesh digest", [&](std::size_t n, std::string_view line) {
        const Where where = Where::in_file(path, n);
        const std::vector<std::string_view> w = words_of(line);
        const auto bad = [&](const std::string& why) {
            throw Error("malformed line '" + std::string(line.substr(0, 120)) + "': " + why, where);
        };
        if (w[0] != "mesh") bad("unknown line");
        if (have_mesh) bad("a second `mesh` line");
        if (w.size() != 9 || w[1] != "vertices" || w[3] != "triangles" || w[5] != "bytes" || w[7] != "sha256")
            bad("expected `mesh vertices V triangles T bytes B sha256 H`");
        const auto vertices = count_of(w[2]), triangles = count_of(w[4]), bytes = count_of(w[6]);
        if (!vertices || !triangles || !bytes) bad("the counts are not whole numbers");
        if (!is_hex_digest(w[8], 64)) bad("the sha256 is not 64 lower-case hex digits");
        m = {*vertices, *triangles, *bytes, std::string(w[8])};
        have_mesh = true;
    });
    if (!have_mesh) throw Error("not a golden mesh digest: no `mesh` line", Where::in_file(path));
    return m;
}

}  // namespace tessref::cli
