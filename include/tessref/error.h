// tessref/error.h — the one exception type of tessref.
//
// Every failure caused by input (a flag, a scene, an image, a mesh) is thrown as
// tessref::Error carrying what failed and where. The command prints
//   tessref: error: <what> (<where>)
// and exits with status 2. Nothing else is thrown across the public API on bad input.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>

namespace tessref {

// Where an error was found. Every field is optional; str() joins the present ones.
struct Where {
    std::string file;    // file name, or the flag name for command-line input ("--outer")
    int line = 0;        // 1-based; 0 = unknown
    int column = 0;      // 1-based; 0 = unknown
    std::string key;     // e.g. "control.weights" or "outer[2]"
    long long patch_id = -1;

    // The places errors name, one factory each; the fields a factory does not take stay
    // unknown. (Designated initializers that skip fields warn under -Wextra.) A line or
    // column beyond INT_MAX is kept as INT_MAX.
    static Where in_file(std::string file, std::size_t line = 0, std::size_t column = 0);  // "scene.toml:12:5"
    static Where at_key(std::string key);                     // "key outer[2]" (an argument, no file)
    static Where at_key(std::string file, std::string key);   // "scene.toml, key camera"
    static Where at(std::string file, std::size_t line, std::size_t column, std::string key);  // "scene.toml:12:5, key camera.eye"
    static Where at_patch(long long patch_id);                // "patch 7"
    static Where at_patch(std::string file, long long patch_id);  // "scene.toml, patch 7"

    std::string str() const;  // "scene.toml:12:5, key control.weights, patch 7"
};

class Error : public std::runtime_error {
public:
    explicit Error(const std::string& what, Where where = {})
        : std::runtime_error(what), where_(std::move(where)) {}
    const Where& where() const noexcept { return where_; }
    // "<what> (<where>)" or just "<what>" when nothing is known about the place.
    std::string message() const;

private:
    Where where_;
};

}  // namespace tessref
