// read_ply.cpp — PLY files: ascii, binary little or big endian (mesh_io.h, read_mesh_file).
#include <atomic>

#include "mesh/read_internal.h"

namespace tessref::mesh_read {

namespace {

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

// The vertex and face elements of the header (a PLY file may declare others, which are read
// and dropped), once the file is known to be large enough for what the header declares.
struct PlyMeshElements {
    const PlyElement* vertex = nullptr;
    const PlyElement* face = nullptr;  // none: a point cloud
};
PlyMeshElements mesh_elements(Reading& r, const PlyHeader& h) {
    const bool ascii = h.format == PlyFormat::ascii;
    PlyMeshElements found;
    std::uint64_t min_bytes = 0;
    for (const PlyElement& e : h.elements) {
        if (e.name == "vertex" || e.name == "face") {
            const PlyElement*& slot = e.name == "vertex" ? found.vertex : found.face;
            if (slot) throw r.error("PLY header declares two '" + e.name + "' elements");
            slot = &e;
        }
        // The least a record takes: a token and a blank per property (ascii), or the
        // scalars and list counts (binary).
        std::uint64_t record = 0;
        for (const PlyProperty& p : e.properties) record += ascii ? 2 : size_of(p.list ? p.count_type : p.type);
        min_bytes = std::min<std::uint64_t>(UINT64_MAX / 2, min_bytes + saturating_bytes(e.count, record));
    }
    if (!found.vertex) throw r.error("PLY header declares no 'vertex' element");
    const std::uint64_t vertex_count = found.vertex->count, face_count = found.face ? found.face->count : 0;
    if (ascii && min_bytes > 0) --min_bytes;  // the last token needs no blank after it
    r.require(vertex_count, face_count, min_bytes, h.body_offset,
              "the header declares " + str(vertex_count) + " vertices and " + str(face_count) + " faces");
    return found;
}

// Vertex `i`'s record, its scalars in `reals`, into the mesh: position, and the normal, uv,
// patch id and tess coord the header declares. `first_line` (ascii) or `record_offset`
// (binary) places it for the errors.
void store_vertex(Reading& r, const PlyRoles& roles, const std::vector<Real>& reals, std::uint64_t i, bool ascii,
                  std::size_t first_line, std::size_t record_offset) {
    const Real xyz[3] = {reals[roles.x], reals[roles.y], reals[roles.z]};
    r.add_vertex(xyz, ascii ? Place{first_line} : Place{0, record_offset});
    const auto where = [&] { return ascii ? " at line " + str(first_line) : at_byte(record_offset); };
    const auto finite = [&](int role, const char* name) {
        if (!std::isfinite(reals[role].value))
            throw r.error("vertex " + str(i) + where() + " has a non-finite " + name, first_line);
        return reals[role].value;
    };
    if (roles.nx >= 0)
        r.mesh.normals.emplace_back(finite(roles.nx, "normal"), finite(roles.ny, "normal"), finite(roles.nz, "normal"));
    if (roles.u >= 0) r.mesh.uvs.emplace_back(finite(roles.u, "texture coordinate"), finite(roles.v, "texture coordinate"));
    if (roles.patch_id >= 0) {
        const double id = reals[roles.patch_id].exact;
        if (!(id >= 0.0 && id <= double(std::numeric_limits<std::uint32_t>::max()) && id == std::floor(id)))
            throw r.error("vertex " + str(i) + where() + " has patch_id " + Reading::number_text(id) +
                              ", not a whole number >= 0",
                          first_line);
        r.mesh.patch_ids.push_back(static_cast<std::uint32_t>(id));
    }
    if (roles.tess_u >= 0) {
        const glm::vec3 tess(finite(roles.tess_u, "tess coord"), finite(roles.tess_v, "tess coord"),
                             finite(roles.tess_w, "tess coord"));
        if (r.options.tess_coords) r.mesh.tess_coords.push_back(tess);
    }
}

// A binary PLY laid out as tessref, OpenMesh and most writers write one: the vertex element,
// then the face element and nothing else; vertex records of scalars only, with float x, y
// and z; faces of a one-byte count and 32-bit indices, every one a triangle (the file's size
// says so: exactly 13 bytes a face). Every record then has a known place, and the records
// are read in parallel. Anything the serial reading would refuse (a non-finite value, a
// patch id that is not a whole number, a count other than 3, an index beyond the vertices)
// makes this return false with the mesh left as it was, and the serial reading below names
// what it found where.
bool read_plain_binary_ply(Reading& r, const PlyHeader& h, const PlyRoles& roles, bool big) {
    if (h.format == PlyFormat::ascii || h.elements.size() != 2) return false;
    const PlyElement& ve = h.elements[0];
    const PlyElement& fe = h.elements[1];
    if (ve.name != "vertex" || fe.name != "face" || fe.properties.size() != 1) return false;
    const PlyProperty& list = fe.properties[0];
    if (!list.list || (list.name != "vertex_indices" && list.name != "vertex_index") || size_of(list.count_type) != 1 ||
        (list.type != Scalar::i32 && list.type != Scalar::u32))
        return false;
    std::vector<std::size_t> at;
    std::size_t record = 0;
    for (const PlyProperty& p : ve.properties) {
        if (p.list) return false;
        at.push_back(record);
        record += size_of(p.type);
    }
    for (int role : {roles.x, roles.y, roles.z})
        if (ve.properties[role].type != Scalar::f32) return false;
    const std::uint64_t vertices = ve.count, faces = fe.count;
    const std::size_t face_offset = h.body_offset + vertices * record;
    if (r.text.size() != face_offset + faces * 13) return false;

    IndexedMesh& mesh = r.mesh;
    const auto* bytes = reinterpret_cast<const unsigned char*>(r.text.data());
    // The arrays are made (and cleared: a vector clears what it grows by, and the kernel
    // clears each fresh page first) side by side, one array a task: on one thread the 80 MB
    // of a 2.4 M-triangle export's arrays held the reading's wall time at 0.076 s, 0.061 s
    // side by side.
    tessref::parallel_for(0, 7, [&](int array) {
        switch (array) {
            case 0: mesh.positions.resize(vertices); break;
            case 1: if (roles.nx >= 0) mesh.normals.resize(vertices); break;
            case 2: if (roles.u >= 0) mesh.uvs.resize(vertices); break;
            case 3: if (roles.patch_id >= 0) mesh.patch_ids.resize(vertices); break;
            case 4: if (roles.tess_u >= 0 && r.options.tess_coords) mesh.tess_coords.resize(vertices); break;
            case 5: mesh.face_start.resize(faces + 1); break;
            default: mesh.face_vertices.resize(3 * faces); break;
        }
    });
    std::atomic<bool> clean = true;
    // A property as store_vertex() takes it: through double, then rounded to float. A float
    // property (most are) is loaded here, without load_scalar()'s call and switch.
    const auto value = [&](const unsigned char* record_bytes, int role) {
        const Scalar type = ve.properties[role].type;
        return type == Scalar::f32 ? double(load<float>(record_bytes + at[role], big))
                                   : load_scalar(record_bytes + at[role], type, big);
    };
    const auto as_float = [](double v) { return static_cast<float>(v); };
    tessref::parallel_for(tbb::blocked_range<std::size_t>(0, vertices, 1 << 14), [&](const auto& range) {
        bool ok = true;
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
            const unsigned char* p = bytes + h.body_offset + i * record;
            const glm::vec3 xyz(load<float>(p + at[roles.x], big), load<float>(p + at[roles.y], big),
                                load<float>(p + at[roles.z], big));
            ok = ok && std::isfinite(xyz.x) && std::isfinite(xyz.y) && std::isfinite(xyz.z);
            mesh.positions[i] = glm::dvec3(xyz);
            if (roles.nx >= 0) {
                const glm::vec3 n(as_float(value(p, roles.nx)), as_float(value(p, roles.ny)), as_float(value(p, roles.nz)));
                ok = ok && std::isfinite(n.x) && std::isfinite(n.y) && std::isfinite(n.z);
                mesh.normals[i] = n;
            }
            if (roles.u >= 0) {
                const glm::vec2 uv(as_float(value(p, roles.u)), as_float(value(p, roles.v)));
                ok = ok && std::isfinite(uv.x) && std::isfinite(uv.y);
                mesh.uvs[i] = uv;
            }
            if (roles.patch_id >= 0) {
                const double id = value(p, roles.patch_id);
                ok = ok && id >= 0.0 && id <= double(std::numeric_limits<std::uint32_t>::max()) && id == std::floor(id);
                mesh.patch_ids[i] = ok ? static_cast<std::uint32_t>(id) : 0;
            }
            if (roles.tess_u >= 0) {
                const glm::vec3 t(as_float(value(p, roles.tess_u)), as_float(value(p, roles.tess_v)),
                                  as_float(value(p, roles.tess_w)));
                ok = ok && std::isfinite(t.x) && std::isfinite(t.y) && std::isfinite(t.z);
                if (r.options.tess_coords) mesh.tess_coords[i] = t;
            }
        }
        if (!ok) clean.store(false, std::memory_order_relaxed);
    });
    const bool signed_index = list.type == Scalar::i32;
    tessref::parallel_for(tbb::blocked_range<std::size_t>(0, faces, 1 << 14), [&](const auto& range) {
        bool ok = true;
        for (std::size_t f = range.begin(); f != range.end(); ++f) {
            const unsigned char* p = bytes + face_offset + 13 * f;
            ok = ok && p[0] == 3;
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t bits = load<std::uint32_t>(p + 1 + 4 * k, big);
                const std::int64_t index = signed_index ? std::int64_t(static_cast<std::int32_t>(bits)) : std::int64_t(bits);
                ok = ok && index >= 0 && static_cast<std::uint64_t>(index) < vertices;
                mesh.face_vertices[3 * f + k] = bits;
            }
            mesh.face_start[f + 1] = static_cast<std::uint32_t>(3 * (f + 1));
        }
        if (!ok) clean.store(false, std::memory_order_relaxed);
    });
    if (clean.load()) return true;
    for (auto* v : {&mesh.normals, &mesh.tess_coords}) v->clear();
    mesh.positions.clear();
    mesh.uvs.clear();
    mesh.patch_ids.clear();
    mesh.face_start.assign(1, 0);
    mesh.face_vertices.clear();
    return false;
}

}  // namespace

void read_ply(Reading& r) {
    const PlyHeader h = read_ply_header(r);
    const bool ascii = h.format == PlyFormat::ascii, big = h.format == PlyFormat::binary_big_endian;
    const auto [vertex_element, face_element] = mesh_elements(r, h);
    const std::uint64_t vertex_count = vertex_element->count, face_count = face_element ? face_element->count : 0;
    const PlyRoles vroles = ply_roles(r, *vertex_element, true);
    const PlyRoles froles = face_element ? ply_roles(r, *face_element, false) : PlyRoles{};
    r.reserve(vertex_count, face_count);
    if (vroles.nx >= 0) r.mesh.normals.reserve(vertex_count);
    if (vroles.u >= 0) r.mesh.uvs.reserve(vertex_count);
    if (vroles.patch_id >= 0) r.mesh.patch_ids.reserve(vertex_count);
    if (vroles.tess_u >= 0 && r.options.tess_coords) r.mesh.tess_coords.reserve(vertex_count);
    if (read_plain_binary_ply(r, h, vroles, big)) return;

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
                store_vertex(r, vroles, reals, i, ascii, first_line, record_offset);
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

}  // namespace tessref::mesh_read
