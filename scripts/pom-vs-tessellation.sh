#!/usr/bin/env bash
# Parallax occlusion mapping against the same displacement done by tessellation
# (docs/PARALLAX.md). A flat 8 x 8 square (plane xz, uv = (x / 8, -z / 8)) carries the brick
# height map of scripts/make-data.sh in two ways:
#   pom    flat (scale_z = 0), shading pom with parallax = MODE and bump_scale 0.04: the
#          height map's range [0, 1] is 0.04 uv = 0.32 world units deep below the plane;
#   tess   the cosc422 evaluation displacing the same square by height * 0.32 at constant
#          level L (8 x 8 patches), seen by the same camera raised by 0.32, so that its top
#          (height 1) is where the pom plane is.
# Both shade the diffuse texture only (flat normal map, no light, no shadow), so a pixel
# differs only where the two put a different texel: the parallax error. Prints one line per
# view, mode, layers and level (320 x 200 = 64000 pixels; oiiotool for the masked
# statistics). Usage: scripts/pom-vs-tessellation.sh [BUILD_DIR] (default build); writes under
# out/pom-vs-tessellation/.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$root/build}"
tessref="$build/tessref"
out="$root/out/pom-vs-tessellation"
mkdir -p "$out"
data="$root/data"
depth=0.32   # scale_z; bump_scale = depth / 8

scene() {  # scene NAME SCALE_Z EYE CENTER CONTROL SHADING_EXTRA
    cat > "$out/$1.toml" <<EOF
[scene]
name = "$1"
[domain]
plane = "xz"
patches = [8, 8]
x = [0.0, 8.0]
z = [0.0, -8.0]
heightmap = "$data/textures/pom-bricks-height.png"
scale_z = $2
[camera]
eye = $3
center = $4
up = [0.0, 1.0, 0.0]
fov_y = 50.0
viewport = [320, 200]
[generator]
domain = "quads"
spacing = "equal"
[control]
model = "constant"
level = $5
[evaluation]
model = "cosc422"
[geometry]
normals = "face"
[shading]
model = "pom"
light_direction = [0.0, -1.0, 0.0]
diffuse_colour = [10.0, 10.0, 10.0]
shininess = 10000.0
self_shadow = false
bump_scale = 0.04
$6
textures = { s2DiffuseTexture = "$data/textures/pom-bricks-diffuse.png", s2NormalTexture = [0.5, 0.5, 1.0], s2BumpTexture = "$data/textures/pom-bricks-height.png" }
EOF
}

raise() {  # raise "[x, y, z]" -> y + depth
    echo "$1" | tr -d '[],' | awk -v d="$depth" '{printf "[%s, %.4f, %s]\n", $1, $2 + d, $3}'
}

# compare A B -> "rmse  interior_rmse  silhouette_pixels": the RMSE of the whole pictures
# (tessref compare: RGBA, background included), the RMSE of RGB over the pixels both cover
# (the parallax error) and the pixels only one of them covers (the silhouette error).
compare() {
    local rmse sq mask sil
    rmse=$("$tessref" compare "$1" "$2" --max-failing-pixels 1000000000 2>/dev/null | awk '/^rmse/ {print $2}')
    sq=$(oiiotool "$1" --ch R,G,B "$2" --ch R,G,B --absdiff --dup --mul "$1" --ch A,A,A "$2" --ch A,A,A --mul --mul \
         --printstats -o "$out/sq.exr" | awk '/Stats Avg/ {print ($3 + $4 + $5) / 3}')
    mask=$(oiiotool "$1" --ch A "$2" --ch A --mul --printstats -o "$out/mask.exr" | awk '/Stats Avg/ {print $3}')
    sil=$(oiiotool "$1" --ch A "$2" --ch A --absdiff --printstats -o "$out/sil.exr" | awk '/Stats Avg/ {print $3}')
    awk -v r="$rmse" -v q="$sq" -v m="$mask" -v s="$sil" 'BEGIN {printf "%.4f\t%.4f\t%d\n", r, sqrt(q / m), s * 64000 + 0.5}'
}

# view name, eye, center
views=("front" "[4.0, 3.0, 1.5]" "[4.0, 0.0, -4.5]"
       "oblique" "[4.0, 0.9, 1.0]" "[4.0, 0.3, -8.0]"
       "grazing" "[4.0, 0.25, 0.5]" "[4.0, 0.15, -8.0]")
printf 'view\tmode\tlayers\tlevel\trmse\tinterior_rmse\tsilhouette_px\n'
for ((v = 0; v < ${#views[@]}; v += 3)); do
    name=${views[v]} eye=${views[v + 1]} center=${views[v + 2]}
    for level in 1 4 16 64; do
        scene "tess-$name-$level" "$depth" "$(raise "$eye")" "$(raise "$center")" "$level.0" 'parallax = "none"'
        "$tessref" render "$out/tess-$name-$level.toml" -o "$out/tess-$name-$level.png" >/dev/null
    done
    for mode in none parallax steep occlusion; do
        for layers in "5 15" "32 128"; do
            set -- $layers
            [[ $mode == none || $mode == parallax ]] && [[ $1 != 5 ]] && continue
            tag="$name-$mode-$1-$2"
            scene "pom-$tag" 0.0 "$eye" "$center" 1.0 "parallax = \"$mode\"
min_layers = $1
max_layers = $2"
            "$tessref" render "$out/pom-$tag.toml" -o "$out/pom-$tag.png" >/dev/null
            for level in 1 4 16 64; do
                printf '%s\t%s\t%s\t%s\t%s\n' "$name" "$mode" "$1-$2" "$level" \
                    "$(compare "$out/tess-$name-$level.png" "$out/pom-$tag.png")"
            done
        done
    done
done
