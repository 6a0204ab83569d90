// The nesting check run before toml++ parses a scene: see toml_reader.h.
//
// toml++ parses tables, dotted keys, inline tables and arrays by recursion, one stack frame
// (or more) per level, so `[a.a.a....]` with 50 000 parts, the same as a dotted key, or
// 50 000 nested `[`, overflowed the stack (SIGSEGV) before it reported anything. This scan
// finds the deepest point of the text without building anything: strings and comments are
// skipped, every '.' of a key (outside quotes) and every open '[' or '{' of a value is one
// level. It may count a level more than toml++ would (a malformed file it then refuses
// anyway), never fewer.
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "scene/toml_reader.h"

namespace tessref::scene_detail {

namespace {

// Skips the string that starts at text[i] (a quote), returning the index after it (or the
// end of the text for an unterminated one: toml++ reports that).
std::size_t skip_string(std::string_view text, std::size_t i) {
    const char quote = text[i];
    const bool multi = text.substr(i, 3) == std::string_view(quote == '"' ? "\"\"\"" : "'''");
    i += multi ? 3 : 1;
    while (i < text.size()) {
        const char c = text[i];
        if (quote == '"' && c == '\\') {
            i += 2;
            continue;
        }
        if (!multi && c == '\n') return i;
        if (c == quote && (!multi || text.substr(i, 3) == std::string_view(quote == '"' ? "\"\"\"" : "'''"))) {
            i += multi ? 3 : 1;
            // A multi-line string may end in up to two more quotes of its own.
            while (multi && i < text.size() && text[i] == quote) ++i;
            return i;
        }
        ++i;
    }
    return i;
}

}  // namespace

void check_toml_nesting(std::string_view text, const std::string& file) {
    struct Open {
        bool table;  // an inline table (keys inside), else an array
        int depth;   // its own depth
    };
    std::vector<Open> open;
    bool in_key = true;      // reading a key: at a line's start, in a [header], after { or , of a table
    bool in_header = false;  // inside [table] or [[table]]
    int parts = 0;           // the parts of the key (or header) read so far
    int table_depth = 0;     // the depth of the last [table] header: its keys start there
    int value_depth = 0;     // the depth of the value after the last '='
    std::size_t line = 1, line_start = 0;

    auto base = [&] { return in_header ? 0 : open.empty() ? table_depth : open.back().depth; };
    auto check = [&](int depth, std::size_t at) {
        if (depth > kMaxTomlNesting)
            throw Error("the TOML nests deeper than " + std::to_string(kMaxTomlNesting) +
                            " levels (tables, dotted keys, inline tables and arrays together); a scene needs a few",
                        Where::in_file(file, line, at - line_start + 1));
    };

    for (std::size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (c == '"' || c == '\'') {
            if (in_key && parts == 0) parts = 1;
            i = skip_string(text, i) - 1;
            continue;
        }
        if (c == '#') {
            while (i + 1 < text.size() && text[i + 1] != '\n') ++i;
            continue;
        }
        if (c == '\n') {
            ++line;
            line_start = i + 1;
            if (open.empty()) {
                in_key = true;
                in_header = false;
                parts = 0;
            }
            continue;
        }
        if (in_key) {
            if (c == '[' && open.empty() && parts == 0) {
                in_header = true;  // [table] or [[array of tables]]
            } else if (c == '.') {
                check(base() + ++parts, i);
            } else if (c == ']' && in_header) {
                table_depth = parts;
                in_key = false;  // the rest of the line: a second ']' and a comment
            } else if (c == '=') {
                in_key = false;
                value_depth = base() + parts;
                check(value_depth, i);
            } else if (c == '}' && !open.empty() && open.back().table) {
                open.pop_back();  // an empty inline table, or one ending after a comma
                in_key = false;
            } else if (parts == 0 && c != ' ' && c != '\t' && c != '\r') {
                parts = 1;
            }
            continue;
        }
        // A value (or the end of a header line).
        if ((c == '[' || c == '{') && !in_header) {
            const int depth = (open.empty() || open.back().table ? value_depth : open.back().depth) + 1;
            check(depth, i);
            open.push_back({c == '{', depth});
            if (c == '{') {
                in_key = true;
                parts = 0;
            }
        } else if ((c == ']' || c == '}') && !open.empty()) {
            open.pop_back();
        } else if (c == ',' && !open.empty() && open.back().table) {
            in_key = true;
            parts = 0;
        }
    }
}

}  // namespace tessref::scene_detail
