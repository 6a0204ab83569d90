// read_stl.cpp — STL files (mesh_io.h, read_mesh_file): binary when the size is exactly
// 84 + 50 * the facet count in its header (as OpenMesh and admesh decide), else ASCII.
// Corners equal as floats are one vertex, numbered in order of first appearance, as
// OpenMesh's STL reader numbers them.
#include "mesh/read_internal.h"

namespace tessref::mesh_read {

namespace {

class StlVertices {
public:
    explicit StlVertices(Reading& r) : r_(r) {}
    // Non-finite corners never become vertices (add_vertex refuses them), so never match.
    std::uint32_t corner(const Real (&xyz)[3], const Place& place) {
        const FloatPointKey key(glm::vec3(xyz[0].value, xyz[1].value, xyz[2].value));
        if (const auto it = ids_.find(key); it != ids_.end()) {
            const glm::dvec3 file_value(xyz[0].exact, xyz[1].exact, xyz[2].exact);
            // -0 and +0 are one vertex in OpenMesh and admesh too: no precision lost there.
            if (file_value != r_.exact(it->second)) r_.merged_corner(it->second, file_value);
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

}  // namespace

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

}  // namespace tessref::mesh_read
