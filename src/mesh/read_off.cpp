// read_off.cpp — OFF files (mesh_io.h, read_mesh_file): [ST][C][N]OFF, ascii (with # comments)
// or binary as OpenMesh writes it (little endian 32-bit counts, floats and indices; a face is
// its vertex count and its indices).
#include "mesh/read_internal.h"

namespace tessref::mesh_read {

namespace {

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

}  // namespace

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

}  // namespace tessref::mesh_read
