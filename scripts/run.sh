#!/usr/bin/env bash
# The main job on the embedded default: installs what is missing, builds, then
# tessellates the default pattern and draws it (out/pattern.txt, .svg, .png).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
BUILD_DIR=${BUILD_DIR:-build}
mkdir -p out
tessref="$BUILD_DIR/tessref"
default=(--domain quads --spacing fractional_odd --winding ccw --outer 3.5,5,2.2,7 --inner 4.5,6)
"$tessref" tessellate "${default[@]}" --format text -o out/pattern.txt
"$tessref" tessellate "${default[@]}" --format svg -o out/pattern.svg
"$tessref" tessellate "${default[@]}" --format png -o out/pattern.png
grep '^#' out/pattern.txt
echo "wrote out/pattern.txt, out/pattern.svg, out/pattern.png"
