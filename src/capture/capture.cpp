// Captures (tessref/capture.h): the CPU reference's, and the two file forms, written and read.
#include "tessref/capture.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <string_view>
#include <system_error>
#include <unordered_map>

#include "common/file_name.h"
#include "common/float_text.h"
#include "common/input_file.h"
#include "common/stream_failure.h"
#include "tessref/error.h"
#include "tessref/limits.h"
#include "tessref/mesh_io.h"
#include "tessref/pipeline.h"

namespace tessref {

namespace {

constexpr std::string_view kVersionLine = "tessref-capture 1";

}  // namespace

// ---- the CPU reference -----------------------------------------------------------------

std::vector<CapturedVertex> capture_from_pipeline(const Scene& scene, const PipelineResult& result) {
    const PipelineCapture source(scene, result);
    const std::size_t triangles = source.triangles();
    require_memory(saturating_bytes(saturating_bytes(triangles, 3), sizeof(CapturedVertex)),
                   "the capture of " + std::to_string(triangles) + " triangles");
    std::vector<CapturedVertex> capture;
    capture.reserve(triangles * 3);
    source.append(0, triangles, capture);
    return capture;
}

PipelineCapture::PipelineCapture(const Scene& scene, const PipelineResult& result)
    : result_(result), triangles_(result.mesh.triangles.size()) {
    const SurfaceMesh& mesh = result.mesh;
    const std::size_t triangles = triangles_;
    if (scene.evaluation.model == EvaluationModel::geomipmap || result.geometry_shader) {
        // No primitive generator: the CPU built each patch's triangles (geomipmap.h), and
        // the capture is those triangles as the vertex buffer holds them, in mesh order.
        // Or a user's geometry shader emitted them, in mesh order too (in GL's corner
        // order once the pipeline's reversal is undone).
        if (triangles) blocks_.push_back({0, 0, 0, nullptr});
        for (std::size_t t = 0; t < triangles; ++t) {
            const std::uint32_t p = mesh.patch_ids[mesh.triangles[t][0]];
            if (runs_.empty() || runs_.back().patch != p) runs_.push_back({p, t, t});
            runs_.back().last = t + 1;
        }
    } else {
        // The pipeline lays each patch's vertices out as the pattern's points, from the
        // patch's first vertex on, and its triangles as the pattern's primitives, in order.
        std::vector<std::size_t> first_vertex(result.levels.size(), SIZE_MAX);
        for (std::size_t v = mesh.patch_ids.size(); v-- > 0;)
            if (mesh.patch_ids[v] < first_vertex.size()) first_vertex[mesh.patch_ids[v]] = v;
        PatternCache cache;
        std::size_t t = 0;
        while (t < triangles) {
            const std::uint32_t p = mesh.patch_ids[mesh.triangles[t][0]];
            const Where where = Where::at_patch(p);
            if (p >= result.levels.size()) throw Error("the pipeline's mesh names a patch it has no levels for", where);
            std::shared_ptr<const Pattern> pattern = cache.get(scene.generator, result.levels[p]);
            const std::size_t base = first_vertex[p];
            const std::size_t count = pattern->primitive_count();
            if (pattern->vertices_per_primitive() != 3 || t + count > triangles)
                throw Error("the pipeline's triangles are not the primitive generator's for the patch's levels", where);
            for (std::size_t k = 0; k < count; ++k) {
                const auto prim = pattern->primitive(k);
                const std::array<std::size_t, 3> generated{base + prim[0], base + prim[1], base + prim[2]};
                const auto& tri = mesh.triangles[t + k];
                const bool as_generated = tri[0] == generated[0] && tri[1] == generated[1] && tri[2] == generated[2];
                const bool reoriented = tri[0] == generated[0] && tri[1] == generated[2] && tri[2] == generated[1];
                if (!as_generated && !reoriented)
                    throw Error("the pipeline's triangle " + std::to_string(t + k) +
                                    " is not the primitive generator's for the patch's levels",
                                where);
            }
            blocks_.push_back({t, base, p, std::move(pattern)});
            if (count && (runs_.empty() || runs_.back().patch != p)) runs_.push_back({p, t, t});
            if (count) runs_.back().last = t + count;
            t += count;
        }
    }
}

void PipelineCapture::append(std::size_t first, std::size_t last, std::vector<CapturedVertex>& out) const {
    const SurfaceMesh& mesh = result_.mesh;
    const PipelineResult& result = result_;
    last = std::min(last, triangles_);
    if (first >= last) return;
    out.reserve(out.size() + 3 * (last - first));
    // The block that holds `first`: the last one starting at or before it.
    std::size_t b = static_cast<std::size_t>(
        std::upper_bound(blocks_.begin(), blocks_.end(), first, [](std::size_t t, const Block& k) { return t < k.first; }) -
        blocks_.begin() - 1);
    for (std::size_t t = first; t < last; ++t) {
        while (b + 1 < blocks_.size() && blocks_[b + 1].first <= t) ++b;
        const Block& block = blocks_[b];
        const auto& tri = mesh.triangles[t];
        if (!block.pattern) {
            const std::array<std::uint32_t, 3> corners =
                result.reversed ? std::array<std::uint32_t, 3>{tri[0], tri[2], tri[1]} : tri;
            for (const std::uint32_t v : corners) {
                CapturedVertex c;
                c.patch_id = mesh.patch_ids[v];
                c.tess_coord = mesh.tess_coords[v];
                c.position = glm::vec3(mesh.positions[v]);
                if (!result.face_normals.empty())
                    c.normal = glm::vec3(result.face_normals[t]);
                else if (!mesh.normals.empty())
                    c.normal = glm::vec3(mesh.normals[v]);
                c.levels = result.levels[c.patch_id];
                out.push_back(c);
            }
            continue;
        }
        const auto prim = block.pattern->primitive(t - block.first);
        const std::array<std::size_t, 3> generated{block.base + prim[0], block.base + prim[1], block.base + prim[2]};
        const bool reoriented = !(tri[1] == generated[1] && tri[2] == generated[2]);  // checked by the constructor
        const std::uint32_t p = block.patch;
        for (const std::size_t v : generated) {
            CapturedVertex c;
            c.patch_id = p;
            c.tess_coord = mesh.tess_coords[v];
            c.position = glm::vec3(mesh.positions[v]);
            if (!result.face_normals.empty()) {
                // The pipeline's face normal is of the re-oriented corners; the geometry
                // shader sees them as generated: cross(b - a, c - a) with b and c swapped is
                // the exact negation, but for the sign of a zero component (x - y and y - x
                // are both +0 when x == y).
                c.normal = reoriented ? -glm::vec3(result.face_normals[t]) : glm::vec3(result.face_normals[t]);
            } else if (!mesh.normals.empty()) {
                c.normal = glm::vec3(mesh.normals[v]);
            }
            c.levels = result.levels[p];
            out.push_back(c);
        }
    }
}

// ---- writing ---------------------------------------------------------------------------

SurfaceMesh capture_mesh(std::span<const CapturedVertex> capture) {
    SurfaceMesh mesh;
    const std::size_t n = capture.size() / 3 * 3;
    mesh.positions.reserve(n);
    mesh.normals.reserve(n);
    mesh.patch_ids.reserve(n);
    mesh.tess_coords.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        mesh.positions.emplace_back(capture[i].position);
        mesh.normals.emplace_back(capture[i].normal);
        mesh.patch_ids.push_back(capture[i].patch_id);
        mesh.tess_coords.push_back(capture[i].tess_coord);
    }
    mesh.triangles.reserve(n / 3);
    for (std::size_t t = 0; t < n / 3; ++t)
        mesh.triangles.push_back({static_cast<std::uint32_t>(3 * t), static_cast<std::uint32_t>(3 * t + 1),
                                  static_cast<std::uint32_t>(3 * t + 2)});
    return mesh;
}

std::string capture_text(std::span<const CapturedVertex> capture, const std::string& origin) {
    std::string out(kVersionLine);
    out += "\n";
    if (!origin.empty()) out += "# " + origin + "\n";
    out +=
        "# patch ID levels o0 o1 o2 o3 i0 i1: the patch's gl_TessLevelOuter/Inner, then its vertices\n"
        "# ID u v w x y z nx ny nz: one line per vertex, three per triangle, in the order emitted\n";
    append_capture_lines(capture, out);
    return out;
}

void append_capture_lines(std::span<const CapturedVertex> capture, std::string& out) {
    // Each line is formatted into `line` ("%u" and "%.9g" words, src/common/float_text.h),
    // then appended; the string grows by doubling, so its copies stay a fraction of the text.
    char line[16 + 10 * (kFloatTextMax + 1)];
    const auto word = [](char* p, float x) {
        *p++ = ' ';
        return write_float_g9(p, x);
    };
    const auto id = [](char* p, std::uint32_t v) { return std::to_chars(p, p + 16, v).ptr; };
    const CapturedVertex* previous = nullptr;
    for (const CapturedVertex& v : capture) {
        if (!previous || previous->patch_id != v.patch_id) {
            const TessLevels& l = v.levels;
            char* p = line;
            std::memcpy(p, "patch ", 6);
            p = id(p + 6, v.patch_id);
            std::memcpy(p, " levels", 7);
            p += 7;
            for (const float x : {l.outer[0], l.outer[1], l.outer[2], l.outer[3], l.inner[0], l.inner[1]}) p = word(p, x);
            *p++ = '\n';
            out.append(line, p);
        }
        previous = &v;
        char* p = id(line, v.patch_id);
        for (const float x : {v.tess_coord.x, v.tess_coord.y, v.tess_coord.z, v.position.x, v.position.y, v.position.z,
                              v.normal.x, v.normal.y, v.normal.z})
            p = word(p, x);
        *p++ = '\n';
        out.append(line, p);
    }
}

void write_capture(std::span<const CapturedVertex> capture, std::ostream& out, CaptureFormat format,
                   const std::string& origin) {
    errno = 0;  // stream_failure() reports only what this write's calls set
    if (format == CaptureFormat::text) {
        out << capture_text(capture, origin);
    } else {
        MeshWriteOptions options;
        options.format = MeshFormat::ply;
        options.weld = false;
        write_mesh(capture_mesh(capture), out, options);
    }
    out.flush();
    if (!out) throw Error("cannot write the capture: " + stream_failure());
}

CaptureFormat capture_format_from_path(const std::string& path, const std::string& flag) {
    const std::string ext = lowercase_extension(path);
    if (ext == "txt") return CaptureFormat::text;
    if (ext == "ply") return CaptureFormat::ply;
    throw Error("a capture is .txt or .ply, not '" + path + "'", Where::in_file(flag.empty() ? path : flag));
}

bool is_capture_path(const std::string& path) {
    const std::string ext = lowercase_extension(path);
    return ext == "txt" || ext == "ply";
}

// ---- reading ---------------------------------------------------------------------------

namespace {

// The next blank-separated token of a line.
std::string_view next_token(std::string_view& rest) {
    std::size_t start = 0;
    while (start < rest.size() && (rest[start] == ' ' || rest[start] == '\t' || rest[start] == '\r')) ++start;
    std::size_t end = start;
    while (end < rest.size() && rest[end] != ' ' && rest[end] != '\t' && rest[end] != '\r') ++end;
    const std::string_view token = rest.substr(start, end - start);
    rest.remove_prefix(end);
    return token;
}

std::string quoted(std::string_view token) {
    std::string s = "'";
    for (char c : token.substr(0, 40)) s += (static_cast<unsigned char>(c) < 32 || c == 127) ? '?' : c;
    return s + (token.size() > 40 ? "...'" : "'");
}

class TextReader {
public:
    TextReader(const std::string& path, std::string_view text) : path_(path), text_(text) {}

    Capture read() {
        Capture capture;
        capture.source = path_;
        // Every vertex is a line: the line count bounds the vertices before any is read.
        const std::size_t lines = static_cast<std::size_t>(std::count(text_.begin(), text_.end(), '\n')) + 1;
        require_memory(saturating_bytes(lines, sizeof(CapturedVertex)),
                       "a capture of up to " + std::to_string(lines) + " vertices", Where::in_file(path_));
        std::string_view line;
        if (!next_line(line) || trimmed(line) != kVersionLine)
            throw error("not a tessref capture: the first line is not '" + std::string(kVersionLine) + "'");
        bool in_patch = false;
        std::uint32_t patch = 0;
        TessLevels levels{};
        std::size_t run = 0;  // vertices since the last patch line
        std::unordered_map<std::uint32_t, TessLevels> seen;  // levels of each patch met
        while (next_line(line)) {
            std::string_view rest = line;
            const std::string_view first = next_token(rest);
            if (first.empty() || first[0] == '#') continue;
            if (first == "patch") {
                if (in_patch && run % 3 != 0) throw run_error(patch, run, line_ - 1);
                patch = read_id(next_token(rest), "a patch id");
                if (next_token(rest) != "levels") throw error("bad patch line: expected 'patch ID levels o0 o1 o2 o3 i0 i1'");
                for (float& l : levels.outer) l = read_float(next_token(rest), "a level");
                for (float& l : levels.inner) l = read_float(next_token(rest), "a level");
                end_of_line(rest);
                // A patch seen before (in an earlier run) must have the same levels.
                const auto [it, first_time] = seen.try_emplace(patch, levels);
                if (!first_time && std::memcmp(&it->second, &levels, sizeof levels) != 0) {
                    throw error("patch " + std::to_string(patch) + " comes back with other levels than before");
                }
                in_patch = true;
                run = 0;
                continue;
            }
            if (!in_patch) throw error("a vertex line before any 'patch ID levels ...' line");
            CapturedVertex v;
            v.patch_id = read_id(first, "a patch id");
            if (v.patch_id != patch)
                throw error("vertex of patch " + std::to_string(v.patch_id) + " under the line 'patch " +
                            std::to_string(patch) + "'");
            for (int k = 0; k < 3; ++k) v.tess_coord[k] = read_float(next_token(rest), "a tess coord");
            for (int k = 0; k < 3; ++k) v.position[k] = read_float(next_token(rest), "a position");
            for (int k = 0; k < 3; ++k) v.normal[k] = read_float(next_token(rest), "a normal");
            end_of_line(rest);
            v.levels = levels;
            capture.vertices.push_back(v);
            ++run;
        }
        if (in_patch && run % 3 != 0) throw run_error(patch, run, line_);
        return capture;
    }

private:
    bool next_line(std::string_view& line) {
        if (offset_ >= text_.size()) return false;
        const std::size_t end = std::min(text_.find('\n', offset_), text_.size());
        line = text_.substr(offset_, end - offset_);
        offset_ = end + 1;
        ++line_;
        return true;
    }
    static std::string_view trimmed(std::string_view s) {
        while (!s.empty() && (s.back() == '\r' || s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
        return s;
    }
    Error error(const std::string& what) const { return error_at(what, line_); }
    Error error_at(const std::string& what, std::size_t line) const {
        return Error(what + " at line " + std::to_string(line), Where::in_file(path_, line));
    }
    Error run_error(std::uint32_t patch, std::size_t run, std::size_t line) const {
        return error_at("patch " + std::to_string(patch) + " has " + std::to_string(run) +
                            " vertex lines before this point, not whole triangles (three lines each)",
                        line);
    }
    void end_of_line(std::string_view rest) const {
        const std::string_view extra = next_token(rest);
        if (!extra.empty()) throw error("unexpected " + quoted(extra) + " after the last number");
    }
    std::uint32_t read_id(std::string_view token, const char* what) const {
        std::uint32_t value = 0;
        const auto r = std::from_chars(token.data(), token.data() + token.size(), value);
        if (token.empty() || r.ec != std::errc() || r.ptr != token.data() + token.size())
            throw error(bad(token, what));
        return value;
    }
    float read_float(std::string_view token, const char* what) const {
        float value = 0.0f;
        // from_chars takes no '+'; printf writes none, a hand-made file may.
        std::string_view t = token;
        if (t.size() > 1 && t[0] == '+' && t[1] != '-' && t[1] != '+') t.remove_prefix(1);
        const auto r = std::from_chars(t.data(), t.data() + t.size(), value);
        // A magnitude beyond float's range is refused (result_out_of_range), not made inf.
        if (t.empty() || r.ec != std::errc() || r.ptr != t.data() + t.size()) throw error(bad(token, what));
        return value;
    }
    static std::string bad(std::string_view token, const char* what) {
        return token.empty() ? std::string("the line ends where ") + what + " was expected"
                             : "bad number " + quoted(token) + " (expected " + what + ")";
    }

    const std::string& path_;
    std::string_view text_;
    std::size_t offset_ = 0;
    std::size_t line_ = 0;
};

Capture read_ply_capture(const std::string& path) {
    MeshFileOptions options;
    options.vertex_attributes = true;
    options.provenance = true;
    return capture_from_ply_mesh(read_mesh_file(path, options), path);
}

}  // namespace

Capture capture_from_ply_mesh(const IndexedMesh& mesh, const std::string& path) {
    const Where where = Where::in_file(path);
    if (mesh.patch_ids.empty() || mesh.tess_coords.empty() || mesh.normals.empty())
        throw Error("not a capture: the PLY's vertices lack patch_id, tess_u/tess_v/tess_w or nx/ny/nz", where);
    Capture capture;
    capture.source = path;
    capture.has_levels = false;
    require_memory(saturating_bytes(saturating_bytes(mesh.face_count(), 3), sizeof(CapturedVertex)),
                   "a capture of " + std::to_string(mesh.face_count()) + " triangles", where);
    capture.vertices.reserve(mesh.face_count() * 3);
    for (std::size_t f = 0; f < mesh.face_count(); ++f) {
        const auto face = mesh.face(f);
        if (face.size() != 3)
            throw Error("face " + std::to_string(f) + " has " + std::to_string(face.size()) +
                            " corners: a capture holds triangles",
                        where);
        for (const std::uint32_t v : face) {
            if (mesh.patch_ids[v] != mesh.patch_ids[face[0]])
                throw Error("face " + std::to_string(f) + " has corners of patches " + std::to_string(mesh.patch_ids[face[0]]) +
                                " and " + std::to_string(mesh.patch_ids[v]) +
                                ": a welded mesh, not a capture (whose corners each keep their patch)",
                            where);
            CapturedVertex c;
            c.patch_id = mesh.patch_ids[v];
            c.tess_coord = mesh.tess_coords[v];
            c.position = glm::vec3(mesh.positions[v]);
            c.normal = mesh.normals[v];
            capture.vertices.push_back(c);
        }
    }
    return capture;
}

Capture read_capture(const std::string& path) {
    const CaptureFormat format = capture_format_from_path(path);
    if (format == CaptureFormat::ply) return read_ply_capture(path);
    // Captures of large terrains are large: held to the memory budget only.
    const std::string text = read_input_file(path, "capture file", kNoCap);
    return TextReader(path, text).read();
}

}  // namespace tessref
