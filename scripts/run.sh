#!/usr/bin/env bash
# The main job on the embedded defaults: installs what is missing, builds, then
#  1. tessellates the default pattern and draws it (out/pattern.txt, .svg, .png);
#  2. runs the jacksboro terrain scene (a real height map, the thesis's formula (2)):
#     exports its mesh (out/jacksboro.ply), checks it for cracks (out/jacksboro-check.json),
#     and renders it (out/jacksboro.png) beside its Embree ground truth
#     (out/jacksboro-raytrace.png) and the provenance of every pixel (out/jacksboro.exr).
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

scene=data/scenes/jacksboro.toml
"$tessref" mesh "$scene" -o out/jacksboro.ply --binary
"$tessref" check out/jacksboro.ply --expect open --json > out/jacksboro-check.json \
  && echo "check: out/jacksboro.ply passes (open terrain, no crack)"
"$tessref" render "$scene" -o out/jacksboro.png
"$tessref" render "$scene" --aov depth,patch,triangle,tesscoord,level -o out/jacksboro.exr
"$tessref" render "$scene" --raytrace -o out/jacksboro-raytrace.png
echo "wrote out/pattern.{txt,svg,png}, out/jacksboro.{ply,png,exr}, out/jacksboro-raytrace.png, out/jacksboro-check.json"
