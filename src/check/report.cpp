// The check report as JSON (everything) and as a summary for people.
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "check/check_internal.h"

namespace tessref {

namespace {

using check_detail::format_number;
using check_detail::format_point;

nlohmann::json point_json(const glm::dvec3& p) { return nlohmann::json::array({p.x, p.y, p.z}); }

std::string_view expect_name(Expect e) {
    switch (e) {
        case Expect::closed: return "closed";
        case Expect::open: return "open";
        case Expect::automatic: break;
    }
    return "automatic";
}

std::string axis_name(int axis) { return std::string(1, "xyz"[axis]); }

template <class Ids>
std::string id_list(const Ids& ids, std::size_t limit = 8) {
    std::string out;
    std::size_t n = 0;
    for (auto id : ids) {
        if (n == limit) {
            out += " ...";
            break;
        }
        out += (n++ ? " " : "") + std::to_string(id);
    }
    return out;
}

}  // namespace

std::string report_json(const CheckReport& r) {
    using nlohmann::json;
    json j;
    j["source"] = r.source;
    j["format"] = r.format;
    j["reader_notes"] = r.reader_notes;
    j["passed"] = r.passed;
    j["expect"] = expect_name(r.expect);
    j["judged_as"] = r.judged_as;
    j["open_sheets"] = r.open_sheets;
    j["counts"] = {{"vertices", r.vertex_count},
                   {"faces", r.face_count},
                   {"triangles", r.triangle_count},
                   {"edges", r.edge_count},
                   {"boundary_edges", r.boundary_edge_count},
                   {"boundary_loops", r.boundary_loop_count},
                   {"components", r.component_count},
                   {"unreferenced_vertices", r.unreferenced_vertices},
                   {"topology_excluded_faces", r.topology_excluded_faces}};
    j["euler_characteristic"] = r.euler_characteristic;
    j["bbox"] = {{"min", point_json(r.bbox_min)}, {"max", point_json(r.bbox_max)}};
    j["surface_area"] = r.surface_area;
    j["signed_volume"] = r.signed_volume;
    j["tolerance"] = r.tolerance;
    j["up_axis"] = axis_name(r.up_axis);
    j["terrain_like"] = r.terrain_like;
    j["closed"] = r.closed;
    j["manifold"] = r.manifold;
    j["consistently_oriented"] = r.consistently_oriented;
    json loops = json::array();
    for (const BoundaryLoop& loop : r.boundary_loops)
        loops.push_back({{"edges", loop.edge_count},
                         {"length", loop.length},
                         {"gap", loop.gap},
                         {"area", loop.area},
                         {"closed", loop.closed},
                         {"allowed", loop.allowed},
                         {"centroid", point_json(loop.centroid)},
                         {"vertices", loop.vertices}});
    j["boundary_loops"] = std::move(loops);
    j["flipped_faces"] = r.flipped_faces;
    j["refused_for_flips"] = r.refused_for_flips;
    j["probe"] = {{"mode", r.probe.mode},
                  {"rays", r.probe.rays},
                  {"failed_rays", r.probe.failed_rays},
                  {"recast_rays", r.probe.recast_rays},
                  {"undecided_rays", r.probe.undecided_rays},
                  {"dismissed_rays", r.probe.dismissed_rays},
                  {"skipped_because", r.probe.skipped_because}};
    json defects = json::object();
    for (const DefectReport& d : r.defects) {
        json locations = json::array();
        for (const Defect& x : d.locations)
            locations.push_back({{"position", point_json(x.position)},
                                 {"faces", x.faces},
                                 {"vertices", x.vertices},
                                 {"patches", x.patches},
                                 {"measure", x.measure},
                                 {"detail", x.detail}});
        defects[std::string(defect_class_name(d.kind))] = {{"description", defect_class_description(d.kind)},
                                                           {"count", d.count},
                                                           {"locations", std::move(locations)}};
    }
    j["defects"] = std::move(defects);
    // File names and details are bytes, not always UTF-8 (a name in Latin-1): invalid
    // sequences become U+FFFD rather than a failed dump.
    return j.dump(2, ' ', false, json::error_handler_t::replace) + "\n";
}

std::string report_text(const CheckReport& r, std::size_t locations_per_class) {
    std::ostringstream out;
    out << "tessref check: " << (r.source.empty() ? std::string("(mesh in memory)") : r.source) << "\n";
    out << "  mesh        " << r.vertex_count << " vertices, " << r.face_count << " faces (" << r.triangle_count
        << " triangles), " << r.edge_count << " edges, " << r.component_count << " component"
        << (r.component_count == 1 ? "" : "s") << ", Euler characteristic " << r.euler_characteristic << "\n";
    out << "  shape       "
        << (r.closed ? std::string("closed")
                     : "open (" + std::to_string(r.boundary_edge_count) + " boundary edges in " +
                           std::to_string(r.boundary_loop_count) + (r.boundary_loop_count == 1 ? " loop)" : " loops)"))
        << ", " << (r.manifold ? "manifold" : "not manifold") << ", "
        << (r.consistently_oriented ? "consistently oriented" : "not consistently oriented");
    if (r.closed) out << ", signed volume " << format_number(r.signed_volume);
    out << "\n";
    out << "  judged as   " << r.judged_as
        << (r.open_sheets ? ", but for " + std::to_string(r.open_sheets) + " open sheet" +
                                (r.open_sheets == 1 ? " (a component seen from one side), its outline"
                                                    : "s (components seen from one side), their outlines") +
                                " allowed"
                          : std::string())
        << " (expect " << expect_name(r.expect) << ")"
        << (r.terrain_like ? ", a terrain with up along " + axis_name(r.up_axis) : std::string())
        << "; tolerance " << format_number(r.tolerance) << "\n";
    out << "  ray probe   " << r.probe.mode;
    if (r.probe.mode == "none") out << " (" << r.probe.skipped_because << ")";
    else out << ": " << r.probe.rays << " rays, " << r.probe.failed_rays << " failed";
    out << "\n";
    if (!r.flipped_faces.empty())
        out << "  flipped     " << r.flipped_faces.size() << " face" << (r.flipped_faces.size() == 1 ? "" : "s")
            << " against their neighbours: " << id_list(r.flipped_faces)
            << (r.refused_for_flips.empty() ? std::string()
                                            : " (OpenMesh's kernel refuses face" +
                                                  std::string(r.refused_for_flips.size() == 1 ? " " : "s ") +
                                                  id_list(r.refused_for_flips) + " because of them)")
            << "\n";
    for (const std::string& note : r.reader_notes) out << "  note        " << note << "\n";
    std::size_t failing = 0;
    for (const DefectReport& d : r.defects) failing += d.count > 0;
    out << "  result      " << (r.passed ? "PASS" : "FAIL: " + std::to_string(failing) + " defect class" + (failing == 1 ? "" : "es"))
        << "\n";
    if (!r.passed) out << "  ids         vertex and face ids are 0-based, in the order the file lists them\n";
    for (const DefectReport& d : r.defects) {
        if (d.count == 0) continue;
        out << "  " << defect_class_name(d.kind) << ": " << d.count << "  (" << defect_class_description(d.kind) << ")\n";
        for (std::size_t i = 0; i < d.locations.size() && i < locations_per_class; ++i) {
            const Defect& x = d.locations[i];
            out << "    at " << format_point(x.position) << ": " << x.detail;
            if (!x.faces.empty()) out << "; faces " << id_list(x.faces);
            if (!x.vertices.empty()) out << "; vertices " << id_list(x.vertices);
            if (!x.patches.empty()) out << "; patch" << (x.patches.size() == 1 ? " " : "es ") << id_list(x.patches);
            out << "\n";
        }
        if (d.count > std::min(d.locations.size(), locations_per_class))
            out << "    ... and " << d.count - std::min(d.locations.size(), locations_per_class) << " more\n";
    }
    return out.str();
}

}  // namespace tessref
