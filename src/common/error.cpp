#include "tessref/error.h"

namespace tessref {

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
