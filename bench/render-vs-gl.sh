#!/usr/bin/env bash
# bench/render-vs-gl.sh — `tessref render` (the CPU reference) against `tessref gl` (the same
# scene through the GLSL twins on Mesa llvmpipe), whole processes as a user runs them,
# alternating render/gl for PAIRS pairs per scene; prints the medians, the ratio gl/render
# (above 1: the reference is faster), the peak memory of each (/usr/bin/time's maximum
# resident set) and where the time goes on each side (the commands' own phase times, of
# the median run).
#
#   bench/render-vs-gl.sh [PAIRS=3] [path/to/tessref]
#
# Scenes, at their 1280x800 viewport: thesis-all-10 and jacksboro (data/scenes/), and the
# Jacksboro DEM as 64 x 64 patches at uniform levels 16 and 63 (bench/scenes/; 2.37 M and
# 32.5 M triangles). Both include loading the scene, as a user's run does. `gl` also runs
# the CPU pipeline first (its primitive counts check every draw), which a plain llvmpipe
# application would not: the column "llvmpipe s" is the gl process's time less that CPU
# pipeline (the time it prints), and the ratio "llvmpipe/render" is the one to quote.
# gl runs each scene at the draw size (--max-primitives-per-draw, gl_flags below) measured
# best for llvmpipe (docs/PERFORMANCE.md, "Benchmarks").
set -euo pipefail
cd "$(dirname "$0")/.."
pairs=${1:-3}
tessref=${2:-${BUILD_DIR:-build}/tessref}
[[ -x "$tessref" ]] || { echo "render-vs-gl: no tessref at $tessref (build first)" >&2; exit 2; }
[[ -x /usr/bin/time ]] || { echo "render-vs-gl: needs /usr/bin/time (apt-get install time)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

scenes=(data/scenes/thesis-all-10.toml data/scenes/jacksboro.toml
        bench/scenes/jacksboro-grid-16.toml bench/scenes/jacksboro-grid-63.toml)

# the gl draw size per scene (none: tessref gl's default, 32768 predicted primitives a draw)
declare -A gl_flags=([bench/scenes/jacksboro-grid-16.toml]="--max-primitives-per-draw 4096"
                     [bench/scenes/jacksboro-grid-63.toml]="--max-primitives-per-draw 32768")

median() { sort -g | awk '{v[NR]=$1} END {print (NR%2) ? v[(NR+1)/2] : (v[NR/2]+v[NR/2+1])/2}'; }

# run KIND SCENE N: one timed process; appends "seconds maxrss_kb" to $work/KIND.N and keeps
# its stdout in $work/KIND.N.out.
run() {
  local kind=$1 scene=$2 n=$3 extra=()
  if [[ $kind == gl ]]; then read -r -a extra <<< "${gl_flags[$scene]:-}"; fi
  /usr/bin/time -f "%e %M" -o "$work/t" "$tessref" "$kind" "$scene" -o "$work/$kind.png" "${extra[@]}" \
    > "$work/$kind.$n.out"
  cat "$work/t" >> "$work/$kind.times"
  if [[ $kind == gl ]]; then
    # the process less the CPU pipeline it ran for its predictions
    local predictions
    predictions=$(sed -n 's/.*CPU pipeline for the predictions \([0-9.e+-]*\) s).*/\1/p' "$work/$kind.$n.out")
    echo "$(awk '{print $1}' "$work/t") - ${predictions:-0}" | bc -l >> "$work/llvmpipe.times"
  fi
}

echo "tessref render vs tessref gl (llvmpipe), $pairs alternating pairs per scene, medians; $(nproc) cores"
printf "%-22s %10s %10s %11s %16s %10s %10s\n" "scene" "render s" "gl s" "llvmpipe s" "llvmpipe/render" "render MB" "gl MB"
details=()
for scene in "${scenes[@]}"; do
  rm -f "$work"/*.times
  for ((i = 0; i < pairs; i++)); do
    run render "$scene" "$i"
    run gl "$scene" "$i"
  done
  r=$(awk '{print $1}' "$work/render.times" | median)
  g=$(awk '{print $1}' "$work/gl.times" | median)
  l=$(median < "$work/llvmpipe.times")
  rm_kb=$(awk '{print $2}' "$work/render.times" | median)
  gm_kb=$(awk '{print $2}' "$work/gl.times" | median)
  name=$(basename "$scene" .toml)
  printf "%-22s %10.3f %10.3f %11.3f %16.2f %10.0f %10.0f\n" "$name" "$r" "$g" "$l" "$(echo "$l / $r" | bc -l)" \
    "$(echo "$rm_kb / 1024" | bc -l)" "$(echo "$gm_kb / 1024" | bc -l)"
  details+=("$name: render $(sed -n 's/.*covered pixels //p' "$work/render.0.out"); gl $(sed -n 's/.*predicted), //p' "$work/gl.0.out")")
done
echo
echo "where the time goes (first run of each; render times its load and PNG write too; the rest of a"
echo "gl process's time is loading the scene, its textures and normal map, writing the PNG, the"
echo "context and shader compilation):"
printf '  %s\n' "${details[@]}"
