// read_obj.cpp — OBJ files (mesh_io.h, read_mesh_file): v, vt, vn and f statements (f with v,
// v/vt, v/vt/vn and v//vn corners, negative indices counting back from the last element so
// far); other statements are ignored.
#include "mesh/read_internal.h"

namespace tessref::mesh_read {

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
                if (index[0] >= std::int64_t(kMaxVertices))
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

}  // namespace tessref::mesh_read
