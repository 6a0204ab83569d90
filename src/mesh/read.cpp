// Reading a mesh file: a strict scan of its bytes, one function per format.
//
// Every mesh tessref takes from a user (`tessref check`, a scene's [[mesh]]) is read here.
// OpenMesh's readers could not be made safe against hostile files: its PLY header parser
// crashes on a `property` line before any `element`, its ASCII PLY reader reads
// uninitialised memory after a bad token (and then allocates without limit), its binary OFF
// and PLY readers trust the header's counts (gigabytes for a 4 kB file), its text readers
// turn a bad token into a vertex index, and it drops or shortens faces a checker must see.
// So each format is scanned here: the header grammar, every token, every index and the
// exact byte length are checked; counts from a header are held against the file's size and
// the memory limit before anything is allocated; every error names the file and the line
// (text) or byte offset (binary). OpenMesh keeps the part where it is the reference: which
// faces its kernel refuses, and the vertex normals of a scene's mesh, both from this scan
// through OpenMesh's importer (src/mesh/openmesh.h).
//
// Coordinates are rounded to float, as OpenMesh and admesh read them (and as the check's
// tolerances and its comparison with admesh assume); a reader note says so when the rounding
// makes coordinates equal that the file keeps apart.
#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>
#include <string_view>
#include <tuple>
#include <unordered_map>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check/check_internal.h"
#include "common/parallel.h"
#include "mesh/openmesh.h"
#include "tessref/check.h"
#include "tessref/error.h"
#include "tessref/limits.h"

namespace tessref {

void IndexedMesh::add_face(std::span<const std::uint32_t> vertex_ids) {
    if (face_vertices.size() + vertex_ids.size() > std::numeric_limits<std::uint32_t>::max())
        throw Error("mesh too large: more than 4294967295 face corners", Where::in_file(source));
    face_vertices.insert(face_vertices.end(), vertex_ids.begin(), vertex_ids.end());
    face_start.push_back(static_cast<std::uint32_t>(face_vertices.size()));
}

void IndexedMesh::add_triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    const std::uint32_t ids[3] = {a, b, c};
    add_face(ids);
}

namespace {

// Vertex ids are 32-bit, and the check uses the largest as "none".
constexpr std::uint64_t max_vertices = std::numeric_limits<std::uint32_t>::max() - 1;
constexpr std::uint64_t max_faces = std::numeric_limits<std::uint32_t>::max() - 1;

std::string str(std::uint64_t n) { return std::to_string(n); }
std::string at_byte(std::uint64_t offset) { return " at byte offset " + str(offset); }

// A token as it may appear in a message: printable, and not too long.
std::string quoted(std::string_view token) {
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

std::string_view without_plus(std::string_view t) {
    if (t.size() > 1 && t[0] == '+' && t[1] != '+' && t[1] != '-') t.remove_prefix(1);
    return t;
}

// nullopt when the whole token is not a number. "nan", "inf" and values beyond double or
// float range are numbers here; their non-finite results are for the caller to name.
std::optional<Real> parse_real(std::string_view token) {
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

std::optional<std::int64_t> parse_integer(std::string_view token) {
    const std::string_view t = without_plus(token);
    std::int64_t v = 0;
    const char* end = t.data() + t.size();
    const auto [p, ec] = std::from_chars(t.data(), end, v);
    if (t.empty() || p != end || ec != std::errc()) return std::nullopt;
    return v;
}

Real real_from_binary(double value) { return {value, static_cast<float>(value)}; }

// ---------------------------------------------------------------------------------------
// Text: lines and tokens, numbered from 1.

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

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

void split(std::string_view line, std::vector<std::string_view>& tokens) {
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

std::string_view strip_comment(std::string_view line) {
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

bool iequals(std::string_view a, std::string_view b) {
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
    std::vector<glm::dvec3> exact;  // the file's coordinates, where rounding lost something
    bool rounded = false;           // some coordinate is not a float in the file

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
        if (vertices > max_vertices)
            throw error(declared + ": more vertices than tessref can number (" + str(max_vertices) + ")");
        if (faces > max_faces) throw error(declared + ": more faces than tessref can number (" + str(max_faces) + ")");
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
        exact.reserve(vertices);
        mesh.face_start.reserve(faces + 1);
        mesh.face_vertices.reserve(saturating_bytes(faces, 3));
    }

    std::uint32_t add_vertex(const Real (&xyz)[3], const Place& place) {
        const std::size_t id = mesh.positions.size();
        const std::size_t line = place.line;
        if (id >= max_vertices) throw error("more vertices than tessref can number (" + str(max_vertices) + ")", line);
        for (int k = 0; k < 3; ++k) {
            if (!std::isfinite(xyz[k].exact))
                throw error("vertex " + str(id) + place.text() + " has a non-finite coordinate (" + "xyz"[k] + " = " +
                                number_text(xyz[k].exact) + ")",
                            line);
            if (!std::isfinite(xyz[k].value))
                throw error("vertex " + str(id) + place.text() + " has a coordinate beyond float range (" + "xyz"[k] + " = " +
                                number_text(xyz[k].exact) + ")",
                            line);
            rounded = rounded || double(xyz[k].value) != xyz[k].exact;
        }
        mesh.positions.emplace_back(xyz[0].value, xyz[1].value, xyz[2].value);
        exact.emplace_back(xyz[0].exact, xyz[1].exact, xyz[2].exact);
        return static_cast<std::uint32_t>(id);
    }

    void add_face(const std::vector<std::uint32_t>& ids, std::size_t line = 0) {
        if (mesh.face_count() >= max_faces) throw error("more faces than tessref can number (" + str(max_faces) + ")", line);
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
                              point_text(exact[vertex]);
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
        std::vector<Coordinate> coordinates(3 * exact.size());
        tessref::parallel_for(tbb::blocked_range<std::size_t>(0, exact.size(), 1 << 14), [&](const auto& r) {
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
            if (exact[c.vertex][c.axis] == exact[first.vertex][first.axis]) continue;
            ++merged;
            if (!first_merged || std::tie(c.vertex, c.axis) < std::tie(first_merged->vertex, first_merged->axis)) {
                first_merged = &c;
                first_of_its_float = &first;
            }
        }
        std::string example;
        if (first_merged) {
            const std::uint32_t v = first_merged->vertex, k = first_merged->axis;
            example = "vertex " + str(v) + " " + "xyz"[k] + " = " + number_text(exact[v][k]) + " reads as " +
                      number_text(static_cast<float>(mesh.positions[v][k])) + ", the same float as " +
                      number_text(exact[first_of_its_float->vertex][first_of_its_float->axis]);
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
    std::size_t next_progress_ = 0;
    std::uint64_t merged_corners_ = 0;
    std::string corner_example_;
};

// A vertex attribute (normal, texture coordinate): any finite number.
float attribute(Reading& r, std::string_view token, std::size_t line, const char* what) {
    const auto v = parse_real(token);
    if (!v) throw r.bad_token(token, line, std::string("a number (") + what + ")");
    if (!std::isfinite(v->value))
        throw r.error("non-finite " + std::string(what) + " " + quoted(token) + " at line " + str(line), line);
    return v->value;
}

// ---------------------------------------------------------------------------------------
// PLY

enum class Scalar : std::uint8_t { i8, u8, i16, u16, i32, u32, f32, f64 };

std::optional<Scalar> scalar_named(std::string_view name) {
    static const std::pair<std::string_view, Scalar> names[] = {
        {"char", Scalar::i8},    {"int8", Scalar::i8},     {"uchar", Scalar::u8},  {"uint8", Scalar::u8},
        {"short", Scalar::i16},  {"int16", Scalar::i16},   {"ushort", Scalar::u16}, {"uint16", Scalar::u16},
        {"int", Scalar::i32},    {"int32", Scalar::i32},   {"uint", Scalar::u32},   {"uint32", Scalar::u32},
        {"float", Scalar::f32},  {"float32", Scalar::f32}, {"double", Scalar::f64}, {"float64", Scalar::f64}};
    for (const auto& [n, s] : names)
        if (n == name) return s;
    return std::nullopt;
}
std::size_t size_of(Scalar s) {
    switch (s) {
        case Scalar::i8: case Scalar::u8: return 1;
        case Scalar::i16: case Scalar::u16: return 2;
        case Scalar::i32: case Scalar::u32: case Scalar::f32: return 4;
        case Scalar::f64: return 8;
    }
    return 0;
}
bool is_integer(Scalar s) { return s != Scalar::f32 && s != Scalar::f64; }

template <class T>
T load(const unsigned char* p, bool big_endian) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, p, sizeof(T));
    if (big_endian) std::reverse(b, b + sizeof(T));
    T v;
    std::memcpy(&v, b, sizeof(T));
    return v;
}
double load_scalar(const unsigned char* p, Scalar s, bool big_endian) {
    switch (s) {
        case Scalar::i8: return load<std::int8_t>(p, big_endian);
        case Scalar::u8: return load<std::uint8_t>(p, big_endian);
        case Scalar::i16: return load<std::int16_t>(p, big_endian);
        case Scalar::u16: return load<std::uint16_t>(p, big_endian);
        case Scalar::i32: return load<std::int32_t>(p, big_endian);
        case Scalar::u32: return load<std::uint32_t>(p, big_endian);
        case Scalar::f32: return load<float>(p, big_endian);
        case Scalar::f64: return load<double>(p, big_endian);
    }
    return 0.0;
}

struct PlyProperty {
    std::string name;
    Scalar type = Scalar::f32;  // of the items, for a list
    bool list = false;
    Scalar count_type = Scalar::u8;
};
struct PlyElement {
    std::string name;
    std::uint64_t count = 0;
    std::vector<PlyProperty> properties;
};
enum class PlyFormat { ascii, binary_little_endian, binary_big_endian };

struct PlyHeader {
    PlyFormat format = PlyFormat::ascii;
    std::vector<PlyElement> elements;
    std::size_t body_offset = 0, body_line = 0;
};

PlyHeader read_ply_header(Reading& r) {
    Lines lines(r.text);
    std::string_view line;
    std::vector<std::string_view> t;
    if (!lines.next(line) || (split(line, t), t.size() != 1 || t[0] != "ply"))
        throw r.error("not a PLY file: it does not start with a line 'ply'", 1);
    PlyHeader header;
    bool have_format = false;
    while (true) {
        if (lines.offset() > (std::size_t(1) << 20))
            throw r.error("PLY header has no 'end_header' in its first MiB", lines.number());
        if (!lines.next(line)) throw r.error("PLY header has no 'end_header'", lines.number());
        const std::size_t n = lines.number();
        split(line, t);
        if (t.empty() || t[0] == "comment" || t[0] == "obj_info") continue;
        const std::string where = " at line " + str(n);
        if (t[0] == "format") {
            if (have_format) throw r.error("PLY header: a second 'format' line" + where, n);
            if (t.size() != 3) throw r.error("PLY header: bad format line" + where + " (expected 'format <type> 1.0')", n);
            if (t[1] == "ascii") header.format = PlyFormat::ascii;
            else if (t[1] == "binary_little_endian") header.format = PlyFormat::binary_little_endian;
            else if (t[1] == "binary_big_endian") header.format = PlyFormat::binary_big_endian;
            else throw r.error("PLY header: unknown format " + quoted(t[1]) + where, n);
            have_format = true;
        } else if (t[0] == "element") {
            if (!have_format) throw r.error("PLY header: 'element' before 'format'" + where, n);
            const auto count = t.size() == 3 ? parse_integer(t[2]) : std::nullopt;
            if (!count || *count < 0) throw r.error("PLY header: bad element line" + where + " (expected 'element <name> <count>')", n);
            header.elements.push_back({std::string(t[1]), static_cast<std::uint64_t>(*count), {}});
        } else if (t[0] == "property") {
            if (header.elements.empty()) throw r.error("PLY header: 'property' before any 'element'" + where, n);
            PlyProperty p;
            if (t.size() == 5 && t[1] == "list") {
                const auto count_type = scalar_named(t[2]), type = scalar_named(t[3]);
                if (!count_type || !is_integer(*count_type) || !type)
                    throw r.error("PLY header: bad list property" + where + " (expected 'property list <integer type> <type> <name>')", n);
                p = {std::string(t[4]), *type, true, *count_type};
            } else if (t.size() == 3 && t[1] != "list") {
                const auto type = scalar_named(t[1]);
                if (!type) throw r.error("PLY header: unknown property type " + quoted(t[1]) + where, n);
                p = {std::string(t[2]), *type, false, Scalar::u8};
            } else {
                throw r.error("PLY header: bad property line" + where, n);
            }
            header.elements.back().properties.push_back(std::move(p));
        } else if (t[0] == "end_header") {
            if (!have_format) throw r.error("PLY header has no 'format' line", n);
            header.body_offset = lines.offset();
            header.body_line = n + 1;  // the line the data starts on
            return header;
        } else {
            throw r.error("PLY header: unknown keyword " + quoted(t[0]) + where, n);
        }
    }
}

// What the reader takes from an element's properties: their indices, or -1.
struct PlyRoles {
    int x = -1, y = -1, z = -1, nx = -1, ny = -1, nz = -1, u = -1, v = -1;
    int patch_id = -1, tess_u = -1, tess_v = -1, tess_w = -1;
    int indices = -1;
};

PlyRoles ply_roles(Reading& r, const PlyElement& e, bool vertex) {
    PlyRoles roles;
    const auto find = [&](std::initializer_list<std::string_view> names) {
        for (std::size_t i = 0; i < e.properties.size(); ++i)
            for (std::string_view name : names)
                if (e.properties[i].name == name) {
                    if (e.properties[i].list)
                        throw r.error("PLY header: vertex property '" + e.properties[i].name + "' is a list");
                    return static_cast<int>(i);
                }
        return -1;
    };
    if (vertex) {
        roles.x = find({"x"});
        roles.y = find({"y"});
        roles.z = find({"z"});
        for (const auto& [role, name] : {std::pair{roles.x, "x"}, std::pair{roles.y, "y"}, std::pair{roles.z, "z"}})
            if (role < 0) throw r.error(std::string("PLY vertex element has no property '") + name + "'");
        if (r.options.vertex_attributes) {
            roles.nx = find({"nx"});
            roles.ny = find({"ny"});
            roles.nz = find({"nz"});
            if (roles.nx < 0 || roles.ny < 0 || roles.nz < 0) roles.nx = roles.ny = roles.nz = -1;
            roles.u = find({"u", "s", "texture_u", "texture_s"});
            roles.v = find({"v", "t", "texture_v", "texture_t"});
            if (roles.u < 0 || roles.v < 0) roles.u = roles.v = -1;
        }
        if (r.options.provenance) {
            roles.patch_id = find({"patch_id"});
            roles.tess_u = find({"tess_u"});
            roles.tess_v = find({"tess_v"});
            roles.tess_w = find({"tess_w"});
            if (roles.tess_u < 0 || roles.tess_v < 0 || roles.tess_w < 0) roles.tess_u = roles.tess_v = roles.tess_w = -1;
        }
    } else {
        for (std::size_t i = 0; i < e.properties.size(); ++i)
            if (e.properties[i].name == "vertex_indices" || e.properties[i].name == "vertex_index") {
                if (!e.properties[i].list || !is_integer(e.properties[i].type))
                    throw r.error("PLY face property '" + e.properties[i].name + "' is not a list of integers");
                roles.indices = static_cast<int>(i);
                break;
            }
        if (roles.indices < 0) throw r.error("PLY face element has no 'vertex_indices' list");
    }
    return roles;
}

void read_ply(Reading& r) {
    const PlyHeader h = read_ply_header(r);
    const bool ascii = h.format == PlyFormat::ascii, big = h.format == PlyFormat::binary_big_endian;
    const PlyElement *vertex_element = nullptr, *face_element = nullptr;
    std::uint64_t min_bytes = 0;
    for (const PlyElement& e : h.elements) {
        if (e.name == "vertex" || e.name == "face") {
            const PlyElement*& slot = e.name == "vertex" ? vertex_element : face_element;
            if (slot) throw r.error("PLY header declares two '" + e.name + "' elements");
            slot = &e;
        }
        // The least a record takes: a token and a blank per property (ascii), or the
        // scalars and list counts (binary).
        std::uint64_t record = 0;
        for (const PlyProperty& p : e.properties) record += ascii ? 2 : size_of(p.list ? p.count_type : p.type);
        min_bytes = std::min<std::uint64_t>(UINT64_MAX / 2, min_bytes + saturating_bytes(e.count, record));
    }
    if (!vertex_element) throw r.error("PLY header declares no 'vertex' element");
    const std::uint64_t vertex_count = vertex_element->count, face_count = face_element ? face_element->count : 0;
    if (ascii && min_bytes > 0) --min_bytes;  // the last token needs no blank after it
    r.require(vertex_count, face_count, min_bytes, h.body_offset,
              "the header declares " + str(vertex_count) + " vertices and " + str(face_count) + " faces");
    const PlyRoles vroles = ply_roles(r, *vertex_element, true);
    const PlyRoles froles = face_element ? ply_roles(r, *face_element, false) : PlyRoles{};
    r.reserve(vertex_count, face_count);
    if (vroles.nx >= 0) r.mesh.normals.reserve(vertex_count);
    if (vroles.u >= 0) r.mesh.uvs.reserve(vertex_count);
    if (vroles.patch_id >= 0) r.mesh.patch_ids.reserve(vertex_count);
    if (vroles.tess_u >= 0) r.mesh.tess_coords.reserve(vertex_count);

    Tokens tokens(r.text, h.body_offset, h.body_line);
    std::size_t offset = h.body_offset;  // binary
    const auto* bytes = reinterpret_cast<const unsigned char*>(r.text.data());
    std::vector<Real> reals;             // the record's scalar properties
    std::vector<std::uint32_t> ids;
    for (const PlyElement& e : h.elements) {
        const bool is_vertex = &e == vertex_element, is_face = &e == face_element;
        reals.assign(e.properties.size(), Real{});
        // Binary records without lists have one size: where a whole record is in the file,
        // the properties the mesh takes are loaded straight from their offsets in it, the
        // rest skipped (the property-by-property loop below gives what a cut record says).
        std::size_t record_size = 0;
        std::vector<std::pair<int, std::size_t>> wanted;  // (property, offset in the record)
        if (!ascii && std::none_of(e.properties.begin(), e.properties.end(), [](const PlyProperty& p) { return p.list; })) {
            std::vector<std::size_t> at;
            for (const PlyProperty& p : e.properties) {
                at.push_back(record_size);
                record_size += size_of(p.type);
            }
            if (is_vertex)
                for (int role : {vroles.x, vroles.y, vroles.z, vroles.nx, vroles.ny, vroles.nz, vroles.u, vroles.v,
                                 vroles.patch_id, vroles.tess_u, vroles.tess_v, vroles.tess_w})
                    if (role >= 0) wanted.emplace_back(role, at[role]);
        }
        for (std::uint64_t i = 0; i < e.count; ++i) {
            const std::size_t record_offset = offset;
            std::size_t first_line = 0;
            // Only for messages: formatting it for every record was a tenth of the reading.
            const auto what = [&] { return e.name + " " + str(i); };
            const bool whole_record = record_size > 0 && r.text.size() - offset >= record_size;
            if (whole_record) {
                for (const auto& [pi, at] : wanted)
                    reals[pi] = real_from_binary(load_scalar(bytes + offset + at, e.properties[pi].type, big));
                offset += record_size;
            }
            for (std::size_t pi = 0; !whole_record && pi < e.properties.size(); ++pi) {
                const PlyProperty& p = e.properties[pi];
                const bool indices = is_face && static_cast<int>(pi) == froles.indices;
                if (indices) ids.clear();
                if (ascii) {
                    const std::string_view token = tokens.next();
                    if (pi == 0) first_line = tokens.line();
                    if (!p.list) {
                        const auto v = parse_real(token);
                        if (!v) throw r.bad_token(token, tokens.line(), "a number (" + what() + ", property " + p.name + ")");
                        reals[pi] = *v;
                        continue;
                    }
                    const auto count = parse_integer(token);
                    if (!count || *count < 0)
                        throw r.bad_token(token, tokens.line(), "a list length (" + what() + ", property " + p.name + ")");
                    if (static_cast<std::uint64_t>(*count) > tokens.bytes_left() / 2 + 1)
                        throw r.error("truncated file: " + what() + " at line " + str(tokens.line()) + " lists " +
                                          str(*count) + " values, more than the rest of the file holds",
                                      tokens.line());
                    for (std::int64_t k = 0; k < *count; ++k) {
                        const std::string_view item = tokens.next();
                        if (!indices) {
                            if (!parse_real(item))
                                throw r.bad_token(item, tokens.line(), "a number (" + what() + ", property " + p.name + ")");
                            continue;
                        }
                        const auto index = parse_integer(item);
                        if (!index) throw r.bad_token(item, tokens.line(), "a vertex index (" + what() + ")");
                        if (*index < 0 || static_cast<std::uint64_t>(*index) >= vertex_count)
                            throw r.error("face " + str(i) + " at line " + str(tokens.line()) + " refers to vertex " +
                                              std::to_string(*index) + ", but the file has " + str(vertex_count) +
                                              " vertices",
                                          tokens.line());
                        ids.push_back(static_cast<std::uint32_t>(*index));
                    }
                } else {
                    const std::size_t size = size_of(p.list ? p.count_type : p.type);
                    if (offset + size > r.text.size())
                        throw r.error("truncated file: " + what() + at_byte(offset) + " is cut off (the header declares " +
                                      str(e.count) + " " + e.name + " records)");
                    const double v = load_scalar(bytes + offset, p.list ? p.count_type : p.type, big);
                    if (!p.list) {
                        reals[pi] = real_from_binary(v);
                        offset += size;
                        continue;
                    }
                    if (v < 0) throw r.error(what() + at_byte(offset) + " has a negative list length (" + Reading::number_text(v) + ")");
                    const std::size_t item = size_of(p.type);
                    if (v * item > double(r.text.size() - offset - size))
                        throw r.error("truncated file: " + what() + at_byte(offset) + " lists " + Reading::number_text(v) +
                                      " values, more than the rest of the file holds");
                    const auto count = static_cast<std::uint64_t>(v);
                    offset += size;
                    if (indices)
                        for (std::uint64_t k = 0; k < count; ++k) {
                            const double index = load_scalar(bytes + offset + k * item, p.type, big);
                            if (index < 0 || index >= double(vertex_count))
                                throw r.error("face " + str(i) + at_byte(offset + k * item) + " refers to vertex " +
                                              Reading::number_text(index) + ", but the file has " +
                                              str(vertex_count) + " vertices");
                            ids.push_back(static_cast<std::uint32_t>(index));
                        }
                    offset += count * item;
                }
            }
            if (is_vertex) {
                const Real xyz[3] = {reals[vroles.x], reals[vroles.y], reals[vroles.z]};
                r.add_vertex(xyz, ascii ? Place{first_line} : Place{0, record_offset});
                const auto finite = [&](int role, const char* name) {
                    if (!std::isfinite(reals[role].value))
                        throw r.error("vertex " + str(i) + (ascii ? " at line " + str(first_line) : at_byte(record_offset)) +
                                          " has a non-finite " + name,
                                      first_line);
                    return reals[role].value;
                };
                if (vroles.nx >= 0)
                    r.mesh.normals.emplace_back(finite(vroles.nx, "normal"), finite(vroles.ny, "normal"),
                                                finite(vroles.nz, "normal"));
                if (vroles.u >= 0) r.mesh.uvs.emplace_back(finite(vroles.u, "texture coordinate"), finite(vroles.v, "texture coordinate"));
                if (vroles.patch_id >= 0) {
                    const double id = reals[vroles.patch_id].exact;
                    if (!(id >= 0.0 && id <= double(std::numeric_limits<std::uint32_t>::max()) && id == std::floor(id)))
                        throw r.error("vertex " + str(i) + (ascii ? " at line " + str(first_line) : at_byte(record_offset)) +
                                          " has patch_id " + Reading::number_text(id) + ", not a whole number >= 0",
                                      first_line);
                    r.mesh.patch_ids.push_back(static_cast<std::uint32_t>(id));
                }
                if (vroles.tess_u >= 0)
                    r.mesh.tess_coords.emplace_back(finite(vroles.tess_u, "tess coord"), finite(vroles.tess_v, "tess coord"),
                                                    finite(vroles.tess_w, "tess coord"));
            } else if (is_face) {
                r.add_face(ids, first_line);
            }
            r.progress(ascii ? tokens.offset() : offset);
        }
    }
    if (ascii) {
        if (!tokens.at_end()) {
            const std::string_view extra = tokens.next();
            throw r.error("unexpected data after the last element: " + quoted(extra) + " at line " + str(tokens.line()),
                          tokens.line());
        }
    } else if (offset != r.text.size()) {
        throw r.error(str(r.text.size() - offset) + " bytes after the last element" + at_byte(offset) +
                      " (the header declares less than the file holds)");
    }
}

// ---------------------------------------------------------------------------------------
// OFF: [ST][C][N]OFF, ascii (with # comments) or binary as OpenMesh writes it (little
// endian 32-bit counts, floats and indices; a face is its vertex count and its indices).

struct OffKind {
    bool texcoords = false, colours = false, normals = false, binary = false;
};

void read_off_binary(Reading& r, const OffKind& kind, std::size_t offset) {
    if (kind.colours) throw r.error("binary COFF (vertex colours) is not supported");
    const auto* bytes = reinterpret_cast<const unsigned char*>(r.text.data());
    const std::size_t size = r.text.size();
    if (offset + 12 > size) throw r.error("truncated file: binary OFF ends" + at_byte(size) + ", before its counts");
    const std::int32_t v = load<std::int32_t>(bytes + offset, false), f = load<std::int32_t>(bytes + offset + 4, false);
    if (v < 0 || f < 0)
        throw r.error("binary OFF declares " + std::to_string(v) + " vertices and " + std::to_string(f) + " faces" +
                      at_byte(offset));
    offset += 12;
    const std::size_t floats = 3 + (kind.normals ? 3 : 0) + (kind.texcoords ? 2 : 0);
    const std::uint64_t vertex_bytes = 4 * floats;
    r.require(std::uint64_t(v), std::uint64_t(f), std::uint64_t(v) * vertex_bytes + std::uint64_t(f) * 4, offset,
              "the header declares " + std::to_string(v) + " vertices and " + std::to_string(f) + " faces");
    r.reserve(std::uint64_t(v), std::uint64_t(f));
    for (std::int32_t i = 0; i < v; ++i, offset += vertex_bytes) {
        float value[8];
        for (std::size_t k = 0; k < floats; ++k) value[k] = load<float>(bytes + offset + 4 * k, false);
        const Real xyz[3] = {real_from_binary(value[0]), real_from_binary(value[1]), real_from_binary(value[2])};
        r.add_vertex(xyz, Place{0, offset});
        for (std::size_t k = 3; k < floats; ++k)
            if (!std::isfinite(value[k]))
                throw r.error("vertex " + str(std::uint64_t(i)) + at_byte(offset) + " has a non-finite " +
                              (kind.normals && k < 6 ? "normal" : "texture coordinate"));
        r.progress(offset);
        if (!r.options.vertex_attributes) continue;
        if (kind.normals) r.mesh.normals.emplace_back(value[3], value[4], value[5]);
        if (kind.texcoords) r.mesh.uvs.emplace_back(value[floats - 2], value[floats - 1]);
    }
    std::vector<std::uint32_t> ids;
    for (std::int32_t i = 0; i < f; ++i) {
        if (offset + 4 > size)
            throw r.error("truncated file: face " + str(std::uint64_t(i)) + at_byte(offset) + " is cut off");
        const std::int32_t n = load<std::int32_t>(bytes + offset, false);
        if (n < 0 || std::uint64_t(n) * 4 > size - offset - 4)
            throw r.error((n < 0 ? "" : "truncated file: ") + std::string("face ") + str(std::uint64_t(i)) + at_byte(offset) +
                          " lists " + std::to_string(n) + " vertices, " +
                          (n < 0 ? "a negative count" : "more than the rest of the file holds"));
        offset += 4;
        ids.clear();
        for (std::int32_t k = 0; k < n; ++k, offset += 4) {
            const std::int32_t index = load<std::int32_t>(bytes + offset, false);
            if (index < 0 || index >= v)
                throw r.error("face " + str(std::uint64_t(i)) + at_byte(offset) + " refers to vertex " +
                              std::to_string(index) + ", but the file has " + std::to_string(v) + " vertices");
            ids.push_back(static_cast<std::uint32_t>(index));
        }
        r.add_face(ids);
        r.progress(offset);
    }
    if (offset != size)
        throw r.error(str(size - offset) + " bytes after the last face" + at_byte(offset) +
                      " (the header declares less than the file holds)");
}

void read_off(Reading& r) {
    Lines lines(r.text);
    std::string_view line;
    std::vector<std::string_view> t;
    const auto next_content = [&]() {  // the next line with tokens (comments removed)
        while (lines.next(line)) {
            split(strip_comment(line), t);
            if (!t.empty()) return true;
        }
        return false;
    };
    if (!next_content()) throw r.error("not an OFF file: no content");
    // The keyword: [ST][C][N]OFF, optional (a file may start with its counts), sometimes
    // glued to the vertex count ("OFF8 12 0").
    OffKind kind;
    std::vector<std::string_view> counts;
    const std::string_view first = t[0];
    const auto off_at = first.find("OFF");
    if (off_at != std::string_view::npos) {
        std::string_view prefix = first.substr(0, off_at);
        const auto take = [&](std::string_view p) {
            if (prefix.substr(0, p.size()) != p) return false;
            prefix.remove_prefix(p.size());
            return true;
        };
        kind.texcoords = take("ST");
        kind.colours = take("C");
        kind.normals = take("N");
        if (take("4") || take("n"))
            throw r.error("OFF variant " + quoted(first) + " at line " + str(lines.number()) +
                              " (4D or n-dimensional vertices) is not supported",
                          lines.number());
        if (!prefix.empty())
            throw r.error("not an OFF file: unknown keyword " + quoted(first) + " at line " + str(lines.number()),
                          lines.number());
        const std::string_view glued = first.substr(off_at + 3);
        if (!glued.empty()) counts.push_back(glued);
        if (glued.empty() && t.size() >= 2 && t[1] == "BINARY") {
            if (t.size() > 2) throw r.error("OFF header: unexpected " + quoted(t[2]) + " after BINARY", lines.number());
            kind.binary = true;
            return read_off_binary(r, kind, lines.offset());
        }
        counts.insert(counts.end(), t.begin() + 1, t.end());
        if (counts.empty()) {
            if (!next_content()) throw r.error("truncated file: OFF header without counts", lines.number());
            counts = t;
        }
    } else if (parse_integer(first)) {
        counts = t;
    } else {
        throw r.error("not an OFF file: it starts with " + quoted(first) + " at line " + str(lines.number()),
                      lines.number());
    }
    const std::size_t count_line = lines.number();
    if (counts.size() < 2 || counts.size() > 3)
        throw r.error("OFF header: expected '<vertices> <faces> <edges>' at line " + str(count_line), count_line);
    std::int64_t declared[3] = {0, 0, 0};
    for (std::size_t k = 0; k < counts.size(); ++k) {
        const auto c = parse_integer(counts[k]);
        if (!c || *c < 0) throw r.bad_token(counts[k], count_line, "a count (vertices, faces, edges)");
        declared[k] = *c;
    }
    const auto vertex_count = static_cast<std::uint64_t>(declared[0]), face_count = static_cast<std::uint64_t>(declared[1]);
    // At least "0 0 0" and a line end a vertex, "0" and a line end a face.
    const std::uint64_t min_bytes = std::min<std::uint64_t>(UINT64_MAX / 2, saturating_bytes(vertex_count, 6)) +
                                    saturating_bytes(face_count, 2);
    r.require(vertex_count, face_count, min_bytes > 0 ? min_bytes - 1 : 0, lines.offset(),
              "the header declares " + str(vertex_count) + " vertices and " + str(face_count) + " faces");
    r.reserve(vertex_count, face_count);

    const std::size_t base = 3 + (kind.normals ? 3 : 0) + (kind.texcoords ? 2 : 0);
    const std::string layout = std::string("x y z") + (kind.normals ? " nx ny nz" : "") + (kind.colours ? " r g b [a]" : "") +
                               (kind.texcoords ? " s t" : "");
    for (std::uint64_t i = 0; i < vertex_count; ++i) {
        if (!next_content())
            throw r.error("truncated file: it ends after " + str(i) + " of the " + str(vertex_count) + " vertices",
                          lines.number());
        const std::size_t n = lines.number();
        const std::size_t colours = t.size() - std::min(t.size(), base);
        if (t.size() < base || (kind.colours ? colours != 3 && colours != 4 : colours != 0))
            throw r.error("vertex " + str(i) + " at line " + str(n) + " has " + str(t.size()) + " values, expected " +
                              layout,
                          n);
        Real xyz[3];
        for (int k = 0; k < 3; ++k) {
            const auto v = parse_real(t[k]);
            if (!v) throw r.bad_token(t[k], n, "a number (vertex " + str(i) + ")");
            xyz[k] = *v;
        }
        r.add_vertex(xyz, Place{n});
        r.progress(lines.offset());
        float a[12] = {};
        for (std::size_t k = 3; k < t.size(); ++k) {
            const bool normal = kind.normals && k < 6;
            const bool uv = kind.texcoords && k + 2 >= t.size();
            if (normal || uv) a[k - 3] = attribute(r, t[k], n, normal ? "normal" : "texture coordinate");
            else if (!parse_real(t[k])) throw r.bad_token(t[k], n, "a number (vertex " + str(i) + " colour)");
        }
        if (!r.options.vertex_attributes) continue;
        if (kind.normals) r.mesh.normals.emplace_back(a[0], a[1], a[2]);
        if (kind.texcoords) r.mesh.uvs.emplace_back(a[t.size() - 5], a[t.size() - 4]);
    }
    std::vector<std::uint32_t> ids;
    for (std::uint64_t i = 0; i < face_count; ++i) {
        if (!next_content())
            throw r.error("truncated file: it ends after " + str(i) + " of the " + str(face_count) + " faces",
                          lines.number());
        const std::size_t n = lines.number();
        const auto count = parse_integer(t[0]);
        if (!count || *count < 0) throw r.bad_token(t[0], n, "a vertex count (face " + str(i) + ")");
        if (static_cast<std::uint64_t>(*count) > t.size() - 1)
            throw r.error("face " + str(i) + " at line " + str(n) + " lists " + std::to_string(*count) +
                              " vertices, but the line holds " + str(t.size() - 1) + " values",
                          n);
        ids.clear();
        for (std::size_t k = 1; k <= static_cast<std::size_t>(*count); ++k) {
            const auto index = parse_integer(t[k]);
            if (!index) throw r.bad_token(t[k], n, "a vertex index (face " + str(i) + ")");
            if (*index < 0 || static_cast<std::uint64_t>(*index) >= vertex_count)
                throw r.error("face " + str(i) + " at line " + str(n) + " refers to vertex " + std::to_string(*index) +
                                  ", but the file has " + str(vertex_count) + " vertices",
                              n);
            ids.push_back(static_cast<std::uint32_t>(*index));
        }
        // An optional face colour: a colour-map index or three or four components.
        if (t.size() - 1 - ids.size() > 4)
            throw r.error("face " + str(i) + " at line " + str(n) + " has " + str(t.size() - 1 - ids.size()) +
                              " values after its " + str(ids.size()) + " vertex indices (at most a colour of 4)",
                          n);
        for (std::size_t k = ids.size() + 1; k < t.size(); ++k)
            if (!parse_real(t[k])) throw r.bad_token(t[k], n, "a number (face " + str(i) + " colour)");
        r.add_face(ids, n);
        r.progress(lines.offset());
    }
    if (next_content())
        throw r.error("unexpected data after the last face: " + quoted(t[0]) + " at line " + str(lines.number()),
                      lines.number());
}

// ---------------------------------------------------------------------------------------
// OBJ: v, vt, vn and f statements (f with v, v/vt, v/vt/vn and v//vn corners, negative
// indices counting back from the last element so far); other statements are ignored.

void read_obj(Reading& r) {
    Lines lines(r.text);
    std::string_view line;
    std::vector<std::string_view> t;
    std::vector<glm::vec3> normals;
    std::vector<glm::vec2> uvs;
    std::uint64_t normal_count = 0, uv_count = 0;
    struct Corner {
        std::uint32_t vertex;
        std::int64_t uv, normal;  // -1: none
    };
    std::vector<Corner> corners;  // with vertex_attributes: every face corner, in order
    // Positive indices may point forward; the largest of each kind is checked at the end.
    struct Largest {
        std::int64_t value = 0;
        std::size_t line = 0, face = 0;
    } largest[3];
    std::vector<std::uint32_t> ids;
    // Memory: the text is in memory; what it lists takes at most a few times its size.
    require_memory(saturating_bytes(r.text.size(), 8), "OBJ file of " + format_bytes(r.text.size()),
                   Where::in_file(r.path));
    while (lines.next(line)) {
        split(strip_comment(line), t);
        if (t.empty()) continue;
        const std::size_t n = lines.number();
        if (t[0] == "v") {
            if (t.size() < 4 || t.size() > 8)
                throw r.error("vertex " + str(r.mesh.positions.size()) + " at line " + str(n) + " has " +
                                  str(t.size() - 1) + " values, expected x y z (and w or r g b [a])",
                              n);
            Real xyz[3];
            for (std::size_t k = 1; k < t.size(); ++k) {
                const auto v = parse_real(t[k]);
                if (!v) throw r.bad_token(t[k], n, "a number (vertex " + str(r.mesh.positions.size()) + ")");
                if (k <= 3) xyz[k - 1] = *v;
            }
            r.add_vertex(xyz, Place{n});
        } else if (t[0] == "vt" || t[0] == "vn") {
            const bool normal = t[0] == "vn";
            if (normal ? t.size() != 4 : (t.size() < 2 || t.size() > 4))
                throw r.error(std::string(normal ? "normal" : "texture coordinate") + " at line " + str(n) + " has " +
                                  str(t.size() - 1) + " values, expected " + (normal ? "3" : "1 to 3"),
                              n);
            float a[3] = {0, 0, 0};
            for (std::size_t k = 1; k < t.size(); ++k)
                a[k - 1] = attribute(r, t[k], n, normal ? "normal" : "texture coordinate");
            ++(normal ? normal_count : uv_count);
            if (r.options.vertex_attributes) {
                if (normal) normals.emplace_back(a[0], a[1], a[2]);
                else uvs.emplace_back(a[0], a[1]);
            }
        } else if (t[0] == "f") {
            const std::size_t face = r.mesh.face_count();
            ids.clear();
            for (std::size_t k = 1; k < t.size(); ++k) {
                std::int64_t index[3] = {-1, -1, -1};  // 0-based vertex, uv, normal
                std::string_view rest = t[k];
                for (int part = 0; part < 3; ++part) {
                    const std::size_t slash = rest.find('/');
                    const std::string_view field = rest.substr(0, slash);
                    const char* names[3] = {"vertex", "texture coordinate", "normal"};
                    const std::uint64_t so_far[3] = {r.mesh.positions.size(), uv_count, normal_count};
                    if (!field.empty() || part == 0) {
                        const auto value = parse_integer(field);
                        if (!value || *value == 0)
                            throw r.bad_token(t[k], n, std::string("a face corner v, v/vt, v/vt/vn or v//vn with ") +
                                                           "indices counting from 1 (face " + str(face) + ")");
                        if (*value < -static_cast<std::int64_t>(so_far[part]))
                            throw r.error("face " + str(face) + " at line " + str(n) + " refers to " + names[part] + " " +
                                              std::to_string(*value) + ", but only " + str(so_far[part]) + " come before it",
                                          n);
                        if (*value > largest[part].value) largest[part] = {*value, n, face};
                        index[part] = *value < 0 ? std::int64_t(so_far[part]) + *value : *value - 1;
                    }
                    if (slash == std::string_view::npos) break;
                    if (part == 2) throw r.bad_token(t[k], n, "a face corner v, v/vt, v/vt/vn or v//vn");
                    rest.remove_prefix(slash + 1);
                }
                if (index[0] >= std::int64_t(max_vertices))
                    throw r.error("face " + str(face) + " at line " + str(n) + " refers to vertex " +
                                      std::to_string(index[0] + 1) + ", more than tessref can number",
                                  n);
                ids.push_back(static_cast<std::uint32_t>(index[0]));
                if (r.options.vertex_attributes) corners.push_back({ids.back(), index[1], index[2]});
            }
            r.add_face(ids, n);
        }
        r.progress(lines.offset());
    }
    const char* names[3] = {"vertex", "texture coordinate", "normal"};
    const std::uint64_t totals[3] = {r.mesh.positions.size(), uv_count, normal_count};
    for (int part = 0; part < 3; ++part)
        if (std::uint64_t(largest[part].value) > totals[part])
            throw r.error("face " + str(largest[part].face) + " at line " + str(largest[part].line) + " refers to " +
                              names[part] + " " + std::to_string(largest[part].value) + ", but the file has " +
                              str(totals[part]) + (part == 0 ? " vertices" : part == 1 ? " texture coordinates" : " normals"),
                          largest[part].line);
    if (!r.options.vertex_attributes) return;
    // As OpenMesh's OBJ reader: a vertex takes the attributes of its last corner.
    if (!normals.empty()) r.mesh.normals.assign(r.mesh.positions.size(), glm::vec3(0.0f));
    if (!uvs.empty()) r.mesh.uvs.assign(r.mesh.positions.size(), glm::vec2(0.0f));
    for (const Corner& c : corners) {
        if (c.normal >= 0 && !normals.empty()) r.mesh.normals[c.vertex] = normals[c.normal];
        if (c.uv >= 0 && !uvs.empty()) r.mesh.uvs[c.vertex] = uvs[c.uv];
    }
}

// ---------------------------------------------------------------------------------------
// STL: binary when the size is exactly 84 + 50 * the facet count in its header (as
// OpenMesh and admesh decide), else ASCII. Corners equal as floats are one vertex, numbered
// in order of first appearance, as OpenMesh's STL reader numbers them.

class StlVertices {
public:
    explicit StlVertices(Reading& r) : r_(r) {}
    // Non-finite corners never become vertices (add_vertex refuses them), so never match.
    std::uint32_t corner(const Real (&xyz)[3], const Place& place) {
        const FloatPointKey key(glm::vec3(xyz[0].value, xyz[1].value, xyz[2].value));
        if (const auto it = ids_.find(key); it != ids_.end()) {
            const glm::dvec3 file_value(xyz[0].exact, xyz[1].exact, xyz[2].exact);
            // -0 and +0 are one vertex in OpenMesh and admesh too: no precision lost there.
            if (file_value != r_.exact[it->second]) r_.merged_corner(it->second, file_value);
            return it->second;
        }
        const std::uint32_t id = r_.add_vertex(xyz, place);
        ids_.emplace(key, id);
        return id;
    }

private:
    Reading& r_;
    std::unordered_map<FloatPointKey, std::uint32_t, FloatPointHash> ids_;
};

void read_stl_binary(Reading& r, std::uint64_t facets) {
    r.require(facets / 2 + 3, facets, 0, 0, "the header declares " + str(facets) + " facets");
    r.reserve(facets / 2 + 3, facets);  // a closed surface has about half as many vertices
    StlVertices vertices(r);
    const auto* bytes = reinterpret_cast<const unsigned char*>(r.text.data());
    std::vector<std::uint32_t> ids(3);
    for (std::uint64_t i = 0; i < facets; ++i) {
        const std::size_t offset = 84 + 50 * i;
        for (int c = 0; c < 3; ++c) {
            const std::size_t at = offset + 12 + 12 * c;
            const Real xyz[3] = {real_from_binary(load<float>(bytes + at, false)),
                                 real_from_binary(load<float>(bytes + at + 4, false)),
                                 real_from_binary(load<float>(bytes + at + 8, false))};
            ids[c] = vertices.corner(xyz, Place{0, at, i, c});
        }
        r.add_face(ids);
        r.progress(offset);
    }
}

void read_stl_ascii(Reading& r) {
    Tokens tokens(r.text, 0, 1);
    StlVertices vertices(r);
    std::vector<std::uint32_t> ids(3);
    const auto expect = [&](std::string_view keyword) {
        const std::string_view t = tokens.next();
        if (!iequals(t, keyword)) throw r.bad_token(t, tokens.line(), "'" + std::string(keyword) + "' (ASCII STL)");
    };
    const auto number = [&](const std::string& what) {
        const std::string_view t = tokens.next();
        const auto v = parse_real(t);
        if (!v) throw r.bad_token(t, tokens.line(), "a number (" + what + ")");
        return *v;
    };
    // Some files hold several solids one after another.
    do {
        expect("solid");
        tokens.skip_rest_of_line();  // the name
        while (true) {
            const std::string_view t = tokens.next();
            if (iequals(t, "endsolid")) {
                tokens.skip_rest_of_line();
                break;
            }
            if (t.empty())
                throw r.error("truncated ASCII STL: it ends at line " + str(tokens.line()) + " without 'endsolid'",
                              tokens.line());
            if (!iequals(t, "facet")) throw r.bad_token(t, tokens.line(), "'facet' or 'endsolid' (ASCII STL)");
            const std::string facet = "facet " + str(r.mesh.face_count());
            expect("normal");
            for (int k = 0; k < 3; ++k) number(facet + " normal");  // not used; any number will do
            expect("outer");
            expect("loop");
            for (int c = 0; c < 3; ++c) {
                expect("vertex");
                const std::size_t line = tokens.line();
                const Real xyz[3] = {number(facet + " vertex"), number(facet + " vertex"), number(facet + " vertex")};
                ids[c] = vertices.corner(xyz, Place{line, SIZE_MAX, r.mesh.face_count(), c});
            }
            expect("endloop");
            expect("endfacet");
            r.add_face(ids, tokens.line());
            r.progress(tokens.offset());
        }
    } while (!tokens.at_end());
}

void read_stl(Reading& r) {
    const std::uint64_t size = r.text.size();
    if (size >= 84) {
        const std::uint64_t facets = load<std::uint32_t>(reinterpret_cast<const unsigned char*>(r.text.data()) + 80, false);
        if (84 + 50 * facets == size) return read_stl_binary(r, facets);
    }
    // Not binary by size: ASCII when it reads as text (a NUL or another control character
    // in the first 64 KiB says it is binary data).
    const std::string_view head = r.text.substr(0, 65536);
    const bool text = std::all_of(head.begin(), head.end(), [](char ch) {
        const auto c = static_cast<unsigned char>(ch);
        return c >= 32 || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v';
    });
    if (text) return read_stl_ascii(r);
    if (size >= 84) {
        const std::uint64_t facets = load<std::uint32_t>(reinterpret_cast<const unsigned char*>(r.text.data()) + 80, false);
        throw r.error("truncated or corrupt binary STL: the header declares " + str(facets) + " facets (" +
                      str(84 + 50 * facets) + " bytes), the file has " + str(size) + " bytes");
    }
    throw r.error("not an STL file: too short for binary STL (" + str(size) + " bytes) and not text");
}

// ---------------------------------------------------------------------------------------

// The file's bytes, mapped rather than copied: a header is checked against the file's size
// and the memory limit before the data behind it costs memory.
class MappedFile {
public:
    explicit MappedFile(const std::string& path) {
        const Where where = Where::in_file(path);
        fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);  // a FIFO must not block
        struct stat st {};
        if (fd_ < 0 || ::fstat(fd_, &st) != 0) throw Error(std::string("cannot open mesh file: ") + std::strerror(errno), where);
        if (!S_ISREG(st.st_mode)) throw Error("not a regular file", where);
        size_ = static_cast<std::size_t>(st.st_size);
        if (size_ == 0) throw Error("empty mesh file", where);
        data_ = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd_, 0);
        if (data_ == MAP_FAILED) throw Error(std::string("cannot read mesh file: ") + std::strerror(errno), where);
        ::madvise(data_, size_, MADV_SEQUENTIAL);
    }
    ~MappedFile() {
        if (data_ != MAP_FAILED) ::munmap(data_, size_);
        if (fd_ >= 0) ::close(fd_);
    }
    MappedFile(const MappedFile&) = delete;
    MappedFile& operator=(const MappedFile&) = delete;
    std::string_view text() const { return {static_cast<const char*>(data_), size_}; }

private:
    int fd_ = -1;
    void* data_ = MAP_FAILED;
    std::size_t size_ = 0;
};

std::string lowercase_extension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    if (!ext.empty() && ext[0] == '.') ext.erase(0, 1);
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

}  // namespace

IndexedMesh read_mesh_file(const std::string& path, const MeshFileOptions& options) {
    const Where where = Where::in_file(path);
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) throw Error("no such mesh file", where);
    if (std::filesystem::is_directory(path, ec)) throw Error("is a directory, not a mesh file", where);
    const std::string ext = lowercase_extension(path);
    if (ext != "ply" && ext != "obj" && ext != "off" && ext != "stl")
        throw Error("unsupported mesh format '" + ext + "' (expected .ply, .obj, .off or .stl)", where);
    const MappedFile file(path);
    Reading r(path, file.text(), options);
    r.mesh.format = ext;
    if (ext == "ply") read_ply(r);
    else if (ext == "off") read_off(r);
    else if (ext == "obj") read_obj(r);
    else read_stl(r);
    if (r.mesh.face_count() == 0) throw Error("no faces: a point cloud, not a mesh", where);
    r.note_rounding();
    if (options.progress) options.progress(1.0);
    return std::move(r.mesh);
}

IndexedMesh read_mesh_for_check(const std::string& path) { return read_mesh_for_check(path, {}); }

IndexedMesh read_mesh_for_check(const std::string& path, const std::function<void(double)>& progress) {
    MeshFileOptions options;
    options.progress = progress;
    IndexedMesh mesh = read_mesh_file(path, options);
    mesh.kernel_refused_faces = check_detail::kernel_refused_faces(mesh);
    return mesh;
}

std::vector<std::uint32_t> check_detail::kernel_refused_faces(const IndexedMesh& mesh) {
    // The importer explains each refusal on omerr(); the check's report does that.
    const mesh_detail::QuietStream quiet(::omerr());
    return mesh_detail::import_half_edge_mesh(mesh, false).refused_faces;
}

IndexedMesh indexed_mesh_from(const SurfaceMesh& surface) {
    // The exporter's weld, but every triangle kept: a triangle whose corners weld together
    // is what the check should report, not lose.
    WeldedMesh welded = weld_bitwise(surface);
    IndexedMesh mesh;
    mesh.positions = std::move(welded.mesh.positions);
    mesh.face_vertices.reserve(surface.triangles.size() * 3);
    mesh.face_start.reserve(surface.triangles.size() + 1);
    for (const auto& t : surface.triangles)
        mesh.add_triangle(welded.vertex_map[t[0]], welded.vertex_map[t[1]], welded.vertex_map[t[2]]);
    return mesh;
}

}  // namespace tessref
