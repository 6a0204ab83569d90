// src/mesh/read_internal.h — what the mesh file readers share (private to src/mesh/):
// numbers as a file spells them, lines and tokens, and Reading, the mesh being read with its
// file, options and messages. One reader per format: read_ply.cpp, read_obj.cpp,
// read_off.cpp, read_stl.cpp; read.cpp picks one by extension (read_mesh_file, mesh_io.h).
#pragma once

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <tuple>
#include <unordered_map>
#include <vector>

#include <glm/glm.hpp>

#include "common/parallel.h"
#include "tessref/error.h"
#include "tessref/limits.h"
#include "tessref/mesh_io.h"

namespace tessref::mesh_read {

// Vertex ids are 32-bit, and the check uses the largest as "none".
constexpr std::uint64_t kMaxVertices = std::numeric_limits<std::uint32_t>::max() - 1;
constexpr std::uint64_t kMaxFaces = std::numeric_limits<std::uint32_t>::max() - 1;

inline std::string str(std::uint64_t n) { return std::to_string(n); }
inline std::string at_byte(std::uint64_t offset) { return " at byte offset " + str(offset); }

// A token as it may appear in a message: printable, and not too long.
inline std::string quoted(std::string_view token) {
    std::string s = "'";
    for (char c : token.substr(0, 40)) s += (static_cast<unsigned char>(c) < 32 || c == 127) ? '?' : c;
    return s + (token.size() > 40 ? "...'" : "'");
}

// ---------------------------------------------------------------------------------------
// Numbers

// A coordinate as the file has it, and as it is read (rounded to float, directly from the
// text where there is one, as OpenMesh's readers round it).
struct Real {
    double exact = 0.0;
    float value = 0.0f;
};

inline std::string_view without_plus(std::string_view t) {
    if (t.size() > 1 && t[0] == '+' && t[1] != '+' && t[1] != '-') t.remove_prefix(1);
    return t;
}

// nullopt when the whole token is not a number. "nan", "inf" and values beyond double or
// float range are numbers here; their non-finite results are for the caller to name.
inline std::optional<Real> parse_real(std::string_view token) {
    const std::string_view t = without_plus(token);
    if (t.empty()) return std::nullopt;
    const char* end = t.data() + t.size();
    Real r;
    const auto [p, ec] = std::from_chars(t.data(), end, r.exact);
    if (p != end || ec == std::errc::invalid_argument) return std::nullopt;
    if (ec == std::errc::result_out_of_range) r.exact = std::strtod(std::string(t).c_str(), nullptr);
    // A double that is a float is also the float nearest the text: a nearer float would be
    // a nearer double. Such tokens (whole and binary-fraction coordinates) skip the second
    // parse; the rest are rounded from the text, not from the double (no double rounding).
    if (ec == std::errc() && double(static_cast<float>(r.exact)) == r.exact) {
        r.value = static_cast<float>(r.exact);
        return r;
    }
    if (std::from_chars(t.data(), end, r.value).ec == std::errc::result_out_of_range)
        r.value = std::abs(r.exact) < 1.0 ? static_cast<float>(r.exact)
                                          : std::copysign(std::numeric_limits<float>::infinity(), float(r.exact));
    return r;
}

inline std::optional<std::int64_t> parse_integer(std::string_view token) {
    const std::string_view t = without_plus(token);
    std::int64_t v = 0;
    const char* end = t.data() + t.size();
    const auto [p, ec] = std::from_chars(t.data(), end, v);
    if (t.empty() || p != end || ec != std::errc()) return std::nullopt;
    return v;
}

inline Real real_from_binary(double value) { return {value, static_cast<float>(value)}; }

// ---------------------------------------------------------------------------------------
// Text: lines and tokens, numbered from 1.

inline bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

class Lines {
public:
    Lines(std::string_view text, std::size_t offset = 0, std::size_t line = 0)
        : text_(text), offset_(offset), line_(line) {}
    // The next line without its line end; false at the end of the text.
    bool next(std::string_view& line) {
        if (offset_ >= text_.size()) return false;
        const std::size_t end = std::min(text_.find('\n', offset_), text_.size());
        line = text_.substr(offset_, end - offset_);
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        offset_ = end + 1;
        ++line_;
        return true;
    }
    std::size_t number() const { return line_; }   // of the line last returned
    std::size_t offset() const { return std::min(offset_, text_.size()); }  // where the next begins

private:
    std::string_view text_;
    std::size_t offset_, line_;
};

inline void split(std::string_view line, std::vector<std::string_view>& tokens) {
    tokens.clear();
    std::size_t i = 0;
    while (true) {
        while (i < line.size() && is_blank(line[i])) ++i;
        if (i >= line.size()) return;
        const std::size_t start = i;
        while (i < line.size() && !is_blank(line[i])) ++i;
        tokens.push_back(line.substr(start, i - start));
    }
}

inline std::string_view strip_comment(std::string_view line) {
    const auto hash = line.find('#');
    return hash == std::string_view::npos ? line : line.substr(0, hash);
}

// Whitespace-separated tokens across lines (ASCII PLY data, ASCII STL).
class Tokens {
public:
    Tokens(std::string_view text, std::size_t offset, std::size_t line) : text_(text), offset_(offset), line_(line) {}
    std::string_view next() {
        skip_space();
        if (offset_ < text_.size()) token_line_ = line_;  // at the end: the last token's line
        const std::size_t start = offset_;
        while (offset_ < text_.size() && !is_blank(text_[offset_]) && text_[offset_] != '\n') ++offset_;
        return text_.substr(start, offset_ - start);  // empty at the end
    }
    void skip_rest_of_line() {
        while (offset_ < text_.size() && text_[offset_] != '\n') ++offset_;
    }
    bool at_end() {
        skip_space();
        return offset_ >= text_.size();
    }
    std::size_t line() const { return token_line_; }  // of the token last returned
    std::size_t offset() const { return offset_; }
    std::size_t bytes_left() const { return text_.size() - offset_; }

private:
    void skip_space() {
        while (offset_ < text_.size() && (is_blank(text_[offset_]) || text_[offset_] == '\n')) {
            if (text_[offset_] == '\n') ++line_;
            ++offset_;
        }
    }
    std::string_view text_;
    std::size_t offset_, line_, token_line_ = 0;
};

inline bool iequals(std::string_view a, std::string_view b) {
    return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
               return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
           });
}

// ---------------------------------------------------------------------------------------
// What all readers share: the mesh being built, errors naming the file, the memory budget,
// progress, and the float rounding of coordinates.

struct FloatPointKey {
    std::uint32_t x, y, z;
    // Equal as floats: -0 and +0 are one key (as OpenMesh's STL reader merges them).
    static std::uint32_t bits(float f) { return f == 0.0f ? 0u : std::bit_cast<std::uint32_t>(f); }
    explicit FloatPointKey(const glm::vec3& p) : x(bits(p.x)), y(bits(p.y)), z(bits(p.z)) {}
    bool operator==(const FloatPointKey&) const = default;
};
struct FloatPointHash {
    std::size_t operator()(const FloatPointKey& k) const {
        std::uint64_t h = k.x * 0x9E3779B97F4A7C15ull;
        h ^= (h >> 29) + k.y * 0xBF58476D1CE4E5B9ull;
        h ^= (h >> 31) + k.z * 0x94D049BB133111EBull;
        return static_cast<std::size_t>(h ^ (h >> 32));
    }
};

// Where a vertex is in the file, for messages: a line, or a byte offset, and for STL the
// facet and corner.
struct Place {
    std::size_t line = 0;
    std::size_t byte = SIZE_MAX;
    std::uint64_t facet = UINT64_MAX;
    int corner = 0;
    std::string text() const {
        std::string s = line ? " at line " + str(line) : byte != SIZE_MAX ? at_byte(byte) : std::string();
        if (facet != UINT64_MAX) s += " (facet " + str(facet) + ", corner " + str(std::uint64_t(corner)) + ")";
        return s;
    }
};

class Reading {
public:
    Reading(const std::string& path, std::string_view text, const MeshFileOptions& options)
        : path(path), text(text), options(options) {
        mesh.source = path;
    }

    const std::string& path;
    std::string_view text;
    const MeshFileOptions& options;
    IndexedMesh mesh;
    bool rounded = false;  // some coordinate is not a float in the file

    // The file's coordinates of vertex v. Until a coordinate loses something to the
    // rounding, each is its float (mesh.positions), and only then is a copy of the file's
    // values kept: a file of float coordinates (every binary export) writes no second array.
    glm::dvec3 exact(std::size_t v) const { return rounded ? exact_[v] : mesh.positions[v]; }

    Error error(const std::string& what, std::size_t line = 0) const {
        return Error(what, Where::in_file(path, line));
    }
    Error bad_token(std::string_view token, std::size_t line, const std::string& expected) const {
        return error((token.empty() ? "unexpected end of file after line " : "bad token " + quoted(token) + " at line ") +
                         str(line) + ": expected " + expected,
                     line);
    }

    // Refuses, before allocating, counts the file cannot hold or memory cannot take.
    // min_bytes: the least the declared data needs in the file after offset.
    void require(std::uint64_t vertices, std::uint64_t faces, std::uint64_t min_bytes, std::size_t offset,
                 const std::string& declared) const {
        if (vertices > kMaxVertices)
            throw error(declared + ": more vertices than tessref can number (" + str(kMaxVertices) + ")");
        if (faces > kMaxFaces) throw error(declared + ": more faces than tessref can number (" + str(kMaxFaces) + ")");
        if (faces > std::numeric_limits<std::uint32_t>::max() / 3)
            throw error(declared + ": at three corners a face, more face corners than tessref can number (" +
                        str(std::numeric_limits<std::uint32_t>::max()) + ")");
        const std::uint64_t left = text.size() - std::min(offset, text.size());
        if (min_bytes > left)
            throw error("truncated file: " + declared + ", which need at least " + str(min_bytes) +
                        " bytes after the header; the file has " + str(left));
        require_memory(memory_for(vertices, faces), "mesh of " + str(vertices) + " vertices and " + str(faces) + " faces",
                       Where::in_file(path));
    }
    std::uint64_t memory_for(std::uint64_t vertices, std::uint64_t faces) const {
        // Positions and the file's values, attributes, three corners a face, and OpenMesh's
        // kernel for the refusal check (about 100 bytes a face).
        const std::uint64_t per_vertex = 2 * sizeof(glm::dvec3) + (options.vertex_attributes ? 20 : 0) + (options.provenance ? 16 : 0);
        const std::uint64_t a = saturating_bytes(vertices, per_vertex), b = saturating_bytes(faces, 16 + 100);
        return a > UINT64_MAX - b ? UINT64_MAX : a + b;
    }
    void reserve(std::uint64_t vertices, std::uint64_t faces) {
        mesh.positions.reserve(vertices);
        reserved_vertices_ = vertices;
        mesh.face_start.reserve(faces + 1);
        mesh.face_vertices.reserve(saturating_bytes(faces, 3));
    }

    std::uint32_t add_vertex(const Real (&xyz)[3], const Place& place) {
        const std::size_t id = mesh.positions.size();
        const std::size_t line = place.line;
        if (id >= kMaxVertices) throw error("more vertices than tessref can number (" + str(kMaxVertices) + ")", line);
        bool lost = false;
        for (int k = 0; k < 3; ++k) {
            if (!std::isfinite(xyz[k].exact))
                throw error("vertex " + str(id) + place.text() + " has a non-finite coordinate (" + "xyz"[k] + " = " +
                                number_text(xyz[k].exact) + ")",
                            line);
            if (!std::isfinite(xyz[k].value))
                throw error("vertex " + str(id) + place.text() + " has a coordinate beyond float range (" + "xyz"[k] + " = " +
                                number_text(xyz[k].exact) + ")",
                            line);
            lost = lost || double(xyz[k].value) != xyz[k].exact;
        }
        if (lost && !rounded) {
            // The first coordinate rounding changed: the vertices before it are their floats.
            exact_.reserve(std::max<std::size_t>(reserved_vertices_, id + 1));
            exact_.assign(mesh.positions.begin(), mesh.positions.end());
            rounded = true;
        }
        mesh.positions.emplace_back(xyz[0].value, xyz[1].value, xyz[2].value);
        if (rounded) exact_.emplace_back(xyz[0].exact, xyz[1].exact, xyz[2].exact);
        return static_cast<std::uint32_t>(id);
    }

    void add_face(const std::vector<std::uint32_t>& ids, std::size_t line = 0) {
        if (mesh.face_count() >= kMaxFaces) throw error("more faces than tessref can number (" + str(kMaxFaces) + ")", line);
        mesh.add_face(ids);
    }

    void progress(std::size_t offset) {
        if (!options.progress || offset < next_progress_) return;
        next_progress_ = offset + (std::size_t(1) << 20);
        options.progress(text.empty() ? 1.0 : std::min(1.0, double(offset) / double(text.size())));
    }

    // An STL corner that rounding to float made equal to an earlier vertex.
    void merged_corner(std::uint32_t vertex, const glm::dvec3& file_value) {
        if (merged_corners_++ == 0)
            corner_example_ = "a corner at " + point_text(file_value) + " reads as vertex " + str(vertex) + " at " +
                              point_text(exact(vertex));
    }

    // The reader note for coordinates that rounding to float made equal.
    void note_rounding() {
        if (!rounded && merged_corners_ == 0) return;
        // A coordinate is merged when its float holds an earlier coordinate of another value
        // in the file. Sorted by (float, place in the file), each float's first coordinate
        // leads its run; the example is the merged coordinate first in the file. (A hash map
        // of first values, visited in file order, was a sixth of reading an ASCII PLY.)
        struct Coordinate {
            std::uint32_t bits;    // FloatPointKey::bits of the float
            std::uint32_t vertex;
            std::uint32_t axis;
            auto operator<=>(const Coordinate&) const = default;
        };
        const std::size_t vertices = mesh.positions.size();
        std::vector<Coordinate> coordinates(3 * vertices);
        tessref::parallel_for(tbb::blocked_range<std::size_t>(0, vertices, 1 << 14), [&](const auto& r) {
            for (std::size_t v = r.begin(); v != r.end(); ++v)
                for (std::uint32_t k = 0; k < 3; ++k)
                    coordinates[3 * v + k] = {FloatPointKey::bits(static_cast<float>(mesh.positions[v][k])),
                                              static_cast<std::uint32_t>(v), k};
        });
        tessref::parallel_sort(coordinates.begin(), coordinates.end());
        std::uint64_t merged = 0;
        const Coordinate* first_merged = nullptr;
        const Coordinate* first_of_its_float = nullptr;
        for (std::size_t i = 0, run = 0; i < coordinates.size(); ++i) {
            const Coordinate& c = coordinates[i];
            if (c.bits != coordinates[run].bits) run = i;
            const Coordinate& first = coordinates[run];
            if (exact(c.vertex)[c.axis] == exact(first.vertex)[first.axis]) continue;
            ++merged;
            if (!first_merged || std::tie(c.vertex, c.axis) < std::tie(first_merged->vertex, first_merged->axis)) {
                first_merged = &c;
                first_of_its_float = &first;
            }
        }
        std::string example;
        if (first_merged) {
            const std::uint32_t v = first_merged->vertex, k = first_merged->axis;
            example = "vertex " + str(v) + " " + "xyz"[k] + " = " + number_text(exact(v)[k]) + " reads as " +
                      number_text(static_cast<float>(mesh.positions[v][k])) + ", the same float as " +
                      number_text(exact(first_of_its_float->vertex)[first_of_its_float->axis]);
        }
        if (merged > 0)
            mesh.reader_notes.push_back("coordinates are read as float and lose precision: " + str(merged) +
                                        " vertex coordinates become equal to a different value of the file (" +
                                        example + "); faces may read as degenerate");
        if (merged_corners_ > 0)
            mesh.reader_notes.push_back("coordinates are read as float and lose precision: " + str(merged_corners_) +
                                        " STL corners become one vertex with a corner the file places elsewhere (" +
                                        corner_example_ + ")");
    }
    static std::string point_text(const glm::dvec3& p) {
        return "(" + number_text(p.x) + ", " + number_text(p.y) + ", " + number_text(p.z) + ")";
    }

    static std::string number_text(double x) {
        char buffer[40];
        // Whole numbers in full (100000001, not 1.00000001e+08), others as short as exact.
        const auto r = x == std::floor(x) && std::abs(x) < 1e17
                           ? std::to_chars(buffer, buffer + sizeof buffer, x, std::chars_format::fixed, 0)
                           : std::to_chars(buffer, buffer + sizeof buffer, x);
        return std::string(buffer, r.ptr);
    }

private:
    std::vector<glm::dvec3> exact_;  // only once `rounded`
    std::size_t reserved_vertices_ = 0;
    std::size_t next_progress_ = 0;
    std::uint64_t merged_corners_ = 0;
    std::string corner_example_;
};

// A vertex attribute (normal, texture coordinate): any finite number.
inline float attribute(Reading& r, std::string_view token, std::size_t line, const char* what) {
    const auto v = parse_real(token);
    if (!v) throw r.bad_token(token, line, std::string("a number (") + what + ")");
    if (!std::isfinite(v->value))
        throw r.error("non-finite " + std::string(what) + " " + quoted(token) + " at line " + str(line), line);
    return v->value;
}

// Binary data: a T from its bytes, in the file's byte order.
template <class T>
T load(const unsigned char* p, bool big_endian) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, p, sizeof(T));
    if (big_endian) std::reverse(b, b + sizeof(T));
    T v;
    std::memcpy(&v, b, sizeof(T));
    return v;
}

// The readers, one per format (the mesh so far in r.mesh; errors through r).
void read_ply(Reading& r);
void read_off(Reading& r);
void read_obj(Reading& r);
void read_stl(Reading& r);

}  // namespace tessref::mesh_read
