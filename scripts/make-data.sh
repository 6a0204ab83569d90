#!/usr/bin/env bash
# Regenerates the synthetic data of the shipped scenes (see scripts/make-data.cpp for what
# each file is and why). Deterministic: running it again reproduces the committed files.
# Usage: scripts/make-data.sh            (writes into data/ of this repository)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
mkdir -p "$root/data/heightmaps" "$root/data/tessmaps" "$root/data/meshes" "$root/data/textures" "$root/data/alphamaps"
g++ -std=c++20 -O2 -o "$work/make-data" "$root/scripts/make-data.cpp" \
    -lOpenImageIO -lOpenImageIO_Util -lOpenMeshCore
"$work/make-data" "$root/data"
