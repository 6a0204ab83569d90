#!/usr/bin/env bash
# Prints, for each public header (or those named), how many of tessref's own headers its
# include closure holds and which: a header that pulls in most of the others is a hub, and
# every file that includes it recompiles when any of them changes. Reads `g++ -MM`.
set -euo pipefail
cd "$(dirname "$0")/.."
headers=("$@")
[ ${#headers[@]} -gt 0 ] || headers=(include/tessref/*.h)
total=$(( $(ls include/tessref/*.h | wc -l) - 1 ))  # the other public headers
for h in "${headers[@]}"; do
    deps=$(echo "#include \"${h#include/}\"" |
        g++ -std=c++20 -Iinclude -Isrc $(pkg-config --cflags-only-I glm 2>/dev/null || true) -MM -x c++ - |
        tr ' \\' '\n\n' | grep -E '^(include/tessref|src)/.*\.h$' | grep -vx "$h" | sort -u || true)
    n=$(printf '%s' "$deps" | grep -c . || true)
    printf '%-34s %2d of %d: %s\n' "$h" "$n" "$total" "$(echo $deps | sed 's#include/tessref/##g')"
done
