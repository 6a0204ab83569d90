// toml_reader.h — typed, position-aware reading of scene tables (private to src/scene/).
//
// Every read records the key as used; finish() then reports a key nobody read as unknown
// (or as not used by the chosen model, when the table knows it). Every error is a
// tessref::Error whose Where holds the scene file, the line and column of the offending
// node (the key itself for an unknown key, the table header for a missing key) and the
// dotted key.
#pragma once

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>
#include <toml++/toml.h>

#include "tessref/error.h"

namespace tessref::scene_detail {

// The place of a TOML node: error.h's Where::at with the node's line and column.
inline Where where_at(const std::string& file, const toml::source_region& region,
                      const std::string& key) {
    return Where::at(file, region.begin.line, region.begin.column, key);
}

inline const char* type_name(const toml::node& node) {
    switch (node.type()) {
        case toml::node_type::table: return "a table";
        case toml::node_type::array: return "an array";
        case toml::node_type::string: return "a string";
        case toml::node_type::integer: return "an integer";
        case toml::node_type::floating_point: return "a real number";
        case toml::node_type::boolean: return "a boolean";
        case toml::node_type::date: return "a date";
        case toml::node_type::time: return "a time";
        case toml::node_type::date_time: return "a date-time";
        default: return "nothing";
    }
}

inline std::string format_number(double v) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.9g", v);
    return buffer;
}

class TableReader {
public:
    // `name` is the dotted path of the table ("control", "mesh[1]").
    // `known_keys`: every key the table may hold under any model. A key outside it is
    // reported at once as unknown (before a missing key, since a misspelt key usually
    // is the missing one).
    TableReader(const std::string& file, const toml::table& table, std::string name,
                std::vector<std::string> known_keys)
        : file_(file), table_(table), name_(std::move(name)), known_(std::move(known_keys)) {
        for (auto&& [k, n] : table_) {
            const std::string ks(k.str());
            if (std::find(known_.begin(), known_.end(), ks) == known_.end()) {
                std::string list;
                for (const auto& kk : known_) list += (list.empty() ? "" : ", ") + kk;
                throw Error("unknown key " + key(ks) + " in [" + name_ + "] (known: " + list + ")",
                            where_at(file_, k.source(), key(ks)));
            }
        }
    }

    const std::string& name() const { return name_; }
    const std::string& file() const { return file_; }
    std::string key(const std::string& k) const { return name_ + "." + k; }

    bool has(const std::string& k) const { return table_.get(k) != nullptr; }

    const toml::node* node(const std::string& k) {
        const toml::node* n = table_.get(k);
        if (n) used_.insert(k);
        return n;
    }

    Where where(const std::string& k) const {
        if (const toml::node* n = table_.get(k)) return where_at(file_, n->source(), key(k));
        return where_at(file_, table_.source(), key(k));
    }
    Where where_table() const { return where_at(file_, table_.source(), name_); }

    [[noreturn]] void fail(const std::string& k, const std::string& what) const {
        throw Error(what, where(k));
    }
    [[noreturn]] void missing(const std::string& k, const std::string& why = "") const {
        throw Error("missing key " + key(k) + (why.empty() ? "" : " (" + why + ")"), where(k));
    }
    [[noreturn]] void wrong_type(const std::string& k, const toml::node& n, const char* expected) const {
        throw Error(key(k) + " must be " + expected + ", not " + type_name(n), where(k));
    }

    // ---- scalars ------------------------------------------------------------------
    std::optional<std::string> string_opt(const std::string& k) {
        const toml::node* n = node(k);
        if (!n) return std::nullopt;
        if (!n->is_string()) wrong_type(k, *n, "a string");
        return n->as_string()->get();
    }
    std::string string(const std::string& k, const std::string& why = "") {
        auto v = string_opt(k);
        if (!v) missing(k, why);
        return *v;
    }
    // One of `choices`; the error lists them.
    std::optional<std::string> choice_opt(const std::string& k, const std::vector<std::string>& choices) {
        auto v = string_opt(k);
        if (!v) return std::nullopt;
        for (const auto& c : choices)
            if (*v == c) return v;
        std::string list;
        for (const auto& c : choices) list += (list.empty() ? "\"" : ", \"") + c + "\"";
        fail(k, key(k) + " = \"" + *v + "\" is not one of " + list);
    }
    std::string choice(const std::string& k, const std::vector<std::string>& choices,
                       const std::string& why = "") {
        auto v = choice_opt(k, choices);
        if (!v) missing(k, why);
        return *v;
    }

    static std::optional<double> as_number(const toml::node& n) {
        if (n.is_integer()) return static_cast<double>(n.as_integer()->get());
        if (n.is_floating_point()) return n.as_floating_point()->get();
        return std::nullopt;
    }

    // A finite real in [lo, hi] (inclusive unless the open flags say otherwise).
    std::optional<double> real_opt(const std::string& k, double lo = -HUGE_VAL, double hi = HUGE_VAL,
                                   bool lo_open = false, bool hi_open = false) {
        const toml::node* n = node(k);
        if (!n) return std::nullopt;
        auto v = as_number(*n);
        if (!v) wrong_type(k, *n, "a number");
        check_range(k, *v, lo, hi, lo_open, hi_open);
        return v;
    }
    double real(const std::string& k, double lo = -HUGE_VAL, double hi = HUGE_VAL,
                bool lo_open = false, bool hi_open = false, const std::string& why = "") {
        auto v = real_opt(k, lo, hi, lo_open, hi_open);
        if (!v) missing(k, why);
        return *v;
    }
    double real_or(const std::string& k, double fallback, double lo = -HUGE_VAL, double hi = HUGE_VAL,
                   bool lo_open = false, bool hi_open = false) {
        auto v = real_opt(k, lo, hi, lo_open, hi_open);
        return v ? *v : fallback;
    }

    std::optional<std::int64_t> integer_opt(const std::string& k, std::int64_t lo, std::int64_t hi) {
        const toml::node* n = node(k);
        if (!n) return std::nullopt;
        if (!n->is_integer()) wrong_type(k, *n, "an integer");
        const std::int64_t v = n->as_integer()->get();
        if (v < lo || v > hi)
            fail(k, key(k) + " = " + std::to_string(v) + " is out of range [" + std::to_string(lo) + ", " +
                        std::to_string(hi) + "]");
        return v;
    }

    std::optional<bool> boolean_opt(const std::string& k) {
        const toml::node* n = node(k);
        if (!n) return std::nullopt;
        if (!n->is_boolean()) wrong_type(k, *n, "a boolean");
        return n->as_boolean()->get();
    }

    // An array of exactly `count` numbers, each finite.
    std::optional<std::vector<double>> reals_opt(const std::string& k, std::size_t count) {
        const toml::node* n = node(k);
        if (!n) return std::nullopt;
        const toml::array* a = n->as_array();
        if (!a) wrong_type(k, *n, ("an array of " + std::to_string(count) + " numbers").c_str());
        if (a->size() != count)
            fail(k, key(k) + " must have " + std::to_string(count) + " numbers, not " + std::to_string(a->size()));
        std::vector<double> out;
        for (std::size_t i = 0; i < a->size(); ++i) {
            const toml::node& e = *a->get(i);
            auto v = as_number(e);
            const std::string ek = key(k) + "[" + std::to_string(i) + "]";
            if (!v) throw Error(ek + " must be a number, not " + std::string(type_name(e)), where_at(file_, e.source(), ek));
            if (!std::isfinite(*v)) throw Error(ek + " must be finite", where_at(file_, e.source(), ek));
            if (const char* why = not_a_float(*v))
                throw Error(ek + " = " + format_number(*v) + " " + why, where_at(file_, e.source(), ek));
            out.push_back(*v);
        }
        return out;
    }
    std::optional<glm::dvec3> vec3_opt(const std::string& k) {
        auto v = reals_opt(k, 3);
        if (!v) return std::nullopt;
        return glm::dvec3((*v)[0], (*v)[1], (*v)[2]);
    }
    std::optional<glm::dvec2> vec2_opt(const std::string& k) {
        auto v = reals_opt(k, 2);
        if (!v) return std::nullopt;
        return glm::dvec2((*v)[0], (*v)[1]);
    }
    // A colour: [r, g, b] or [r, g, b, a], each finite; alpha 1 when left out.
    std::optional<glm::dvec4> colour_opt(const std::string& k) {
        const toml::node* n = node(k);
        if (!n) return std::nullopt;
        const char* expected = "an array of 3 or 4 numbers ([r, g, b] or [r, g, b, a])";
        const toml::array* a = n->as_array();
        if (!a) wrong_type(k, *n, expected);
        if (a->size() != 3 && a->size() != 4)
            fail(k, key(k) + " must be " + expected + ", not an array of " + std::to_string(a->size()));
        const std::vector<double> v = *reals_opt(k, a->size());
        return glm::dvec4(v[0], v[1], v[2], v.size() == 4 ? v[3] : 1.0);
    }
    // An array of exactly `count` integers in [lo, hi].
    std::optional<std::vector<std::int64_t>> integers_opt(const std::string& k, std::size_t count,
                                                          std::int64_t lo, std::int64_t hi) {
        const toml::node* n = node(k);
        if (!n) return std::nullopt;
        const toml::array* a = n->as_array();
        if (!a) wrong_type(k, *n, ("an array of " + std::to_string(count) + " integers").c_str());
        if (a->size() != count)
            fail(k, key(k) + " must have " + std::to_string(count) + " integers, not " + std::to_string(a->size()));
        std::vector<std::int64_t> out;
        for (std::size_t i = 0; i < a->size(); ++i) {
            const toml::node& e = *a->get(i);
            const std::string ek = key(k) + "[" + std::to_string(i) + "]";
            if (!e.is_integer())
                throw Error(ek + " must be an integer, not " + std::string(type_name(e)), where_at(file_, e.source(), ek));
            const std::int64_t v = e.as_integer()->get();
            if (v < lo || v > hi)
                throw Error(ek + " = " + std::to_string(v) + " is out of range [" + std::to_string(lo) + ", " +
                                std::to_string(hi) + "]",
                            where_at(file_, e.source(), ek));
            out.push_back(v);
        }
        return out;
    }

    const toml::table* table_opt(const std::string& k) {
        const toml::node* n = node(k);
        if (!n) return nullptr;
        if (!n->is_table()) wrong_type(k, *n, "a table");
        return n->as_table();
    }

    // Reports the first key of the table that no read consumed (known to the table, but
    // not used by the chosen model: `context` says which).
    void finish(const std::string& context = "") const {
        for (auto&& [k, n] : table_) {
            const std::string ks(k.str());
            if (used_.count(ks)) continue;
            throw Error("key " + key(ks) + " is not used" + (context.empty() ? "" : " " + context),
                        where_at(file_, k.source(), key(ks)));
        }
    }

private:
    // Why `v` cannot be a scene value, or nullptr. The gpu precision computes in float (each
    // stage converts the scene's doubles once): a value beyond float's range would become
    // infinite there (scale_z = 1e39: an empty mesh), and one nonzero but below float's
    // normal range would lose its digits or turn 0 (scale_xy = 1e-45 divides the texture
    // coordinates to infinity). No scene quantity needs either.
    static const char* not_a_float(double v) {
        if (!std::isfinite(v)) return "must be finite";
        if (std::abs(v) > static_cast<double>(FLT_MAX))
            return "is beyond float's range (3.4e38), in which the gpu precision computes";
        if (v != 0.0 && std::abs(v) < static_cast<double>(FLT_MIN))
            return "is below float's normal range (1.2e-38), in which the gpu precision computes: use 0 or a larger value";
        return nullptr;
    }

    void check_range(const std::string& k, double v, double lo, double hi, bool lo_open, bool hi_open) const {
        if (!std::isfinite(v)) fail(k, key(k) + " must be finite");
        // The control table is exempt: its levels and limits reach the generator as GL takes
        // them, and a denormal level (culled by llvmpipe) or a limit that overflows the level
        // to infinity are cases the extremes suite runs on purpose.
        if (const char* why = name_.rfind("control", 0) == 0 ? nullptr : not_a_float(v))
            fail(k, key(k) + " = " + format_number(v) + " " + why);
        const bool below = lo_open ? !(v > lo) : !(v >= lo);
        const bool above = hi_open ? !(v < hi) : !(v <= hi);
        if (below || above) {
            std::string range = std::string(lo_open ? "(" : "[") + (std::isinf(lo) ? "-inf" : format_number(lo)) +
                                ", " + (std::isinf(hi) ? "inf" : format_number(hi)) + (hi_open ? ")" : "]");
            fail(k, key(k) + " = " + format_number(v) + " is out of range " + range);
        }
    }

    const std::string& file_;
    const toml::table& table_;
    std::string name_;
    std::vector<std::string> known_;
    std::set<std::string> used_;
};

}  // namespace tessref::scene_detail

namespace tessref::scene_detail {

// The deepest TOML a scene may be: tables, dotted keys, inline tables and arrays counted
// together. The shipped scenes reach 3; toml++ recurses once or more per level and
// overflowed the stack at some tens of thousands.
inline constexpr int kMaxTomlNesting = 64;

// Throws an Error at the line and column where `text` first nests deeper than
// kMaxTomlNesting, before toml++ sees it (src/scene/toml_depth.cpp).
void check_toml_nesting(std::string_view text, const std::string& file);

}  // namespace tessref::scene_detail
