#!/usr/bin/env bash
# Regenerates every golden file: golden/<scene>/ of every shipped scene (`tessref golden
# update`: image.png, capture.txt, mesh.txt) and the extra images of `tessref render`
# (golden/render/*.png) from golden/render/cases.txt: one line per image, its file name then
# the arguments of `tessref render`, run from the repository root. The images are regression baselines made
# by tessref itself: run this only after reviewing an intended change of the rendered
# output, and commit the images with that change.
#
#   scripts/regenerate-golden.sh [path/to/tessref]    (default: ${BUILD_DIR:-build}/tessref)
set -euo pipefail
cd "$(dirname "$0")/.."
TESSREF=${1:-${BUILD_DIR:-build}/tessref}
if [[ ! -x "$TESSREF" ]]; then
    echo "regenerate-golden: no tessref binary at $TESSREF (build first: scripts/build.sh, or pass its path)" >&2
    exit 2
fi
# Every scene's golden/<scene>/ (image.png, capture.txt, mesh.txt).
"$TESSREF" golden update
count=0
while read -r image args; do
    [[ -z "$image" || "$image" == \#* ]] && continue
    # shellcheck disable=SC2086  # the arguments are words on purpose
    "$TESSREF" render $args -o "golden/render/$image" >/dev/null
    echo "golden/render/$image: tessref render $args"
    count=$((count + 1))
done < golden/render/cases.txt
echo "regenerated golden/<scene>/ of every scene and $count images of golden/render/"
