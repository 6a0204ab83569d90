#include "tessref/error.h"

#include <algorithm>
#include <climits>
#include <utility>

namespace tessref {

namespace {

int clamped(std::size_t n) { return static_cast<int>(std::min<std::size_t>(n, INT_MAX)); }

}  // namespace

Where Where::in_file(std::string file, std::size_t line, std::size_t column) {
    Where where;
    where.file = std::move(file);
    where.line = clamped(line);
    where.column = clamped(column);
    return where;
}

Where Where::at_key(std::string key) {
    Where where;
    where.key = std::move(key);
    return where;
}

Where Where::at_key(std::string file, std::string key) {
    Where where = in_file(std::move(file));
    where.key = std::move(key);
    return where;
}

Where Where::at(std::string file, std::size_t line, std::size_t column, std::string key) {
    Where where = in_file(std::move(file), line, column);
    where.key = std::move(key);
    return where;
}

Where Where::at_patch(long long patch_id) {
    Where where;
    where.patch_id = patch_id;
    return where;
}

Where Where::at_patch(std::string file, long long patch_id) {
    Where where = in_file(std::move(file));
    where.patch_id = patch_id;
    return where;
}

std::string Where::str() const {
    std::string out;
    auto add = [&out](const std::string& part) {
        if (!out.empty()) out += ", ";
        out += part;
    };
    if (!file.empty()) {
        std::string f = file;
        if (line > 0) {
            f += ":" + std::to_string(line);
            if (column > 0) f += ":" + std::to_string(column);
        }
        add(f);
    }
    if (!key.empty()) add("key " + key);
    if (patch_id >= 0) add("patch " + std::to_string(patch_id));
    return out;
}

std::string Error::message() const {
    const std::string w = where_.str();
    return w.empty() ? std::string(what()) : std::string(what()) + " (" + w + ")";
}

}  // namespace tessref
