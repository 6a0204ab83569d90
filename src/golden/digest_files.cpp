// src/golden/digest_files.cpp — the digest files of golden/<scene>/ (capture.txt, mesh.txt):
// reading them strictly, and the per-patch digests of a capture text.
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <optional>
#include <vector>

#include <openssl/evp.h>

#include "common/parallel.h"
#include "golden/golden_internal.h"
#include "tessref/error.h"
#include "tessref/golden.h"

namespace tessref::golden {

namespace {

std::string hex_of(const unsigned char* bytes, unsigned int length) {
    static const char* const hex_digits = "0123456789abcdef";
    std::string hex;
    for (unsigned int i = 0; i < length; ++i) {
        hex += hex_digits[bytes[i] >> 4];
        hex += hex_digits[bytes[i] & 15];
    }
    return hex;
}

// A float as the capture text prints it ("%.9g", "nan", "inf"): the whole word.
std::optional<float> parse_float(std::string_view word) {
    if (word.empty() || word.front() == ' ') return std::nullopt;
    const std::string copy(word);
    char* end = nullptr;
    const float value = std::strtof(copy.c_str(), &end);
    if (end != copy.c_str() + copy.size()) return std::nullopt;
    return value;
}

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
    std::size_t value = 0;
    const auto [end, ec] = std::from_chars(word.data(), word.data() + word.size(), value);
    if (ec != std::errc() || end != word.data() + word.size()) return std::nullopt;
    return value;
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

CaptureDigest parse_capture_digest(std::string_view text, const std::string& path) {
    CaptureDigest g;
    std::size_t declared_patches = 0;
    bool have_size = false, have_capture = false;
    std::size_t patch_lines = 0, patch_triangles = 0;
    for_each_line(text, path, kCaptureHeader, "golden capture digest", [&](std::size_t n, std::string_view line) {
        const Where where = Where::in_file(path, n);
        const std::vector<std::string_view> w = words_of(line);
        const auto bad = [&](const std::string& why) {
            throw Error("malformed line '" + std::string(line.substr(0, 120)) + "': " + why, where);
        };
        if (w[0] == "size") {
            if (have_size) bad("a second `size` line");
            if (w.size() != 2) bad("expected `size WxH`");
            (void)parse_size(std::string(w[1]), Where::in_file(path, n));
            g.size = std::string(w[1]);
            have_size = true;
        } else if (w[0] == "capture") {
            if (have_capture) bad("a second `capture` line");
            if (w.size() != 7 || w[1] != "patches" || w[3] != "triangles" || w[5] != "sha256")
                bad("expected `capture patches P triangles T sha256 H`");
            const auto patches = count_of(w[2]), triangles = count_of(w[4]);
            if (!patches || !triangles) bad("the counts are not whole numbers");
            if (!is_hex_digest(w[6], 64)) bad("the sha256 is not 64 lower-case hex digits");
            declared_patches = *patches;
            g.triangles = *triangles;
            g.sha256 = std::string(w[6]);
            have_capture = true;
        } else if (w[0] == "patch") {
            if (!have_capture) bad("a `patch` line before the `capture` line");
            if (w.size() != 13 || w[2] != "levels" || w[9] != "triangles" || w[11] != "sha256")
                bad("expected `patch ID levels L1 L2 L3 L4 L5 L6 triangles N sha256 H`");
            const auto id = count_of(w[1]), triangles = count_of(w[10]);
            if (!id || *id > std::numeric_limits<std::uint32_t>::max()) bad("the patch id is not a 32-bit whole number");
            std::string levels;
            for (std::size_t k = 3; k < 9; ++k) {
                const std::optional<float> level = parse_float(w[k]);
                if (!level || !std::isfinite(*level)) bad("level " + std::to_string(k - 2) + " is not a finite number");
                levels += (k > 3 ? " " : "") + std::string(w[k]);
            }
            if (!triangles) bad("the triangle count is not a whole number");
            if (!is_hex_digest(w[12], kPatchDigits))
                bad("the sha256 is not " + std::to_string(kPatchDigits) + " lower-case hex digits");
            ++patch_lines;
            patch_triangles += *triangles;
            if (patch_lines > declared_patches)
                bad("more `patch` lines than the `capture` line's " + std::to_string(declared_patches));
            g.patches.push_back({static_cast<std::uint32_t>(*id), levels, *triangles, std::string(w[12]), n});
        } else {
            bad("unknown line");
        }
    });
    const Where where = Where::in_file(path);
    if (!have_size) throw Error("not a golden capture digest: no `size` line", where);
    if (!have_capture) throw Error("not a golden capture digest: no `capture` line", where);
    if (patch_lines != declared_patches)
        throw Error("the `capture` line counts " + std::to_string(declared_patches) + " patches, the file lists " +
                        std::to_string(patch_lines) + " (a deleted or duplicated `patch` line?)",
                    where);
    if (patch_triangles != g.triangles)
        throw Error("the `capture` line counts " + std::to_string(g.triangles) + " triangles, the `patch` lines add up to " +
                        std::to_string(patch_triangles),
                    where);
    return g;
}

MeshDigest parse_mesh_digest(std::string_view text, const std::string& path) {
    MeshDigest m;
    bool have_mesh = false;
    for_each_line(text, path, kMeshHeader, "golden mesh digest", [&](std::size_t n, std::string_view line) {
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

std::string sha256_hex(std::string_view bytes) {
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int length = 0;
    if (EVP_Digest(bytes.data(), bytes.size(), digest, &length, EVP_sha256(), nullptr) != 1)
        throw Error("SHA-256 failed (OpenSSL)");
    return hex_of(digest, length);
}

Sha256::Sha256() : context_(EVP_MD_CTX_new()) {
    if (!context_ || EVP_DigestInit_ex(static_cast<EVP_MD_CTX*>(context_), EVP_sha256(), nullptr) != 1)
        throw Error("SHA-256 failed (OpenSSL)");
}
Sha256::~Sha256() { EVP_MD_CTX_free(static_cast<EVP_MD_CTX*>(context_)); }
void Sha256::add(std::string_view bytes) {
    if (EVP_DigestUpdate(static_cast<EVP_MD_CTX*>(context_), bytes.data(), bytes.size()) != 1)
        throw Error("SHA-256 failed (OpenSSL)");
}
std::string Sha256::hex() {
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int length = 0;
    if (EVP_DigestFinal_ex(static_cast<EVP_MD_CTX*>(context_), digest, &length) != 1)
        throw Error("SHA-256 failed (OpenSSL)");
    return hex_of(digest, length);
}

glm::ivec2 parse_size(const std::string& text, const Where& where) {
    const std::size_t x = text.find('x');
    const std::optional<std::size_t> w = x == std::string::npos ? std::nullopt : count_of(std::string_view(text).substr(0, x));
    const std::optional<std::size_t> h = x == std::string::npos ? std::nullopt : count_of(std::string_view(text).substr(x + 1));
    if (!w || !h) throw Error("image size '" + text + "' is not WIDTHxHEIGHT (e.g. 320x200)", where);
    if (*w < 1 || *h < 1 || *w > 16384 || *h > 16384)
        throw Error("image size " + text + " is outside 1..16384 in width or height", where);
    return {static_cast<int>(*w), static_cast<int>(*h)};
}

namespace {

// Vertices formatted at once before their text joins the whole digest: about 25 MB of text.
constexpr std::size_t kDigestWindowVertices = std::size_t(1) << 18;

}  // namespace

struct CaptureDigester::State {
    Sha256 whole;
    CaptureDigest digest;
    std::size_t vertices = 0;
    std::vector<CapturedVertex> carry;  // the last run added: it may go on in the next piece
    std::vector<std::string> texts;    // the window being formatted
    std::vector<std::string> pending;  // the window before it: its first pending_count texts
    std::size_t pending_count = 0;     // are not yet in the whole digest

    // Whole runs, formatted and digested run by run in parallel a window of about
    // kDigestWindowVertices at a time. The whole text's digest, which must take the text in
    // order on one thread, takes each window's text while the next window is formatted
    // (one more task of that parallel loop), so that it keeps no core waiting.
    void digest_runs(const std::vector<std::span<const CapturedVertex>>& runs) {
        for (std::size_t first = 0; first < runs.size();) {
            std::size_t last = first + 1, window = runs[first].size();
            while (last < runs.size() && window + runs[last].size() <= kDigestWindowVertices) window += runs[last++].size();
            texts.resize(last - first);
            const std::size_t base = digest.patches.size();
            digest.patches.resize(base + (last - first));
            tessref::parallel_for(std::size_t(0), last - first + 1, [&](std::size_t i) {
                if (i == 0) {
                    add_pending();
                    return;
                }
                const std::size_t r = first + i - 1;
                const std::span<const CapturedVertex> run = runs[r];
                std::string& text = texts[i - 1];
                text.clear();
                append_capture_lines(run, text);
                PatchDigest& p = digest.patches[base + (i - 1)];
                p.patch_id = run.front().patch_id;
                const std::string_view patch_line = std::string_view(text).substr(0, text.find('\n'));
                const std::size_t levels = patch_line.find(" levels ");
                if (levels != std::string_view::npos) p.levels = std::string(patch_line.substr(levels + 8));
                p.triangles = run.size() / 3;
                p.sha256 = sha256_hex(text).substr(0, kPatchDigits);
            });
            std::swap(texts, pending);  // the strings keep their capacity for the window after next
            pending_count = last - first;
            first = last;
        }
    }
    void add_pending() {
        for (std::size_t i = 0; i < pending_count; ++i) whole.add(pending[i]);
        pending_count = 0;
    }
};

CaptureDigester::CaptureDigester() : state_(std::make_unique<State>()) {
    state_->whole.add(capture_text({}));  // the header lines
}
CaptureDigester::~CaptureDigester() = default;

void CaptureDigester::add(std::span<const CapturedVertex> piece) {
    State& s = *state_;
    s.vertices += piece.size();
    std::size_t i = 0;
    // A run cut by the end of the last piece goes on here: the text has no `patch` line there.
    if (!s.carry.empty())
        while (i < piece.size() && piece[i].patch_id == s.carry.back().patch_id) ++i;
    s.carry.insert(s.carry.end(), piece.begin(), piece.begin() + static_cast<std::ptrdiff_t>(i));
    if (i == piece.size()) return;
    // Every run that the piece ends is complete; its last run is carried to the next piece.
    std::vector<std::span<const CapturedVertex>> runs;
    if (!s.carry.empty()) runs.push_back(s.carry);
    std::size_t start = i;
    for (std::size_t k = i + 1; k < piece.size(); ++k)
        if (piece[k].patch_id != piece[k - 1].patch_id) {
            runs.push_back(piece.subspan(start, k - start));
            start = k;
        }
    s.digest_runs(runs);
    s.carry.assign(piece.begin() + static_cast<std::ptrdiff_t>(start), piece.end());
}

CaptureDigest CaptureDigester::finish() {
    State& s = *state_;
    if (!s.carry.empty()) s.digest_runs({std::span<const CapturedVertex>(s.carry)});
    s.add_pending();
    s.carry.clear();
    s.digest.triangles = s.vertices / 3;
    s.digest.sha256 = s.whole.hex();
    return std::move(s.digest);
}

CaptureDigest capture_digest(std::span<const CapturedVertex> capture) {
    CaptureDigester digester;
    digester.add(capture);
    return digester.finish();
}

}  // namespace tessref::golden
