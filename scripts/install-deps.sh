#!/usr/bin/env bash
# Installs, from Debian bookworm, every package tessref needs to build, test and run.
# Idempotent: only what is missing is installed. Must run as root (or with sudo).
set -euo pipefail

packages=(
  g++ cmake ninja-build pkg-config
  libglm-dev libpng-dev zlib1g-dev libopenimageio-dev libopenmesh-dev libembree-dev libosmesa6-dev
  libtbb-dev libtomlplusplus-dev libcli11-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  fonts-dejavu-core admesh
  glslang-tools
  # The shader interpreter's front end (src/shader/): glslang's library, SPIRV-Tools' validator
  glslang-dev spirv-tools
  # SHA-256 of the golden digests (tessref golden)
  libssl-dev
  # OpenImageIO's CMake package lists /usr/include/opencv4 among its include
  # directories; without the OpenCV headers CMake refuses the imported target.
  libopencv-core-dev
  # OpenImageIO's CMake package also imports its command-line tools (iconvert, oiiotool,
  # ...) and refuses to configure when /usr/bin/iconvert is missing; --no-install-recommends
  # leaves them out, so they are named here.
  openimageio-tools
  # A compiler cache (scripts/build.sh): rebuilds, and builds of other clones on the same
  # machine, compile only what changed.
  ccache
  # The linker CMakeLists.txt prefers: it links the project's 50-odd executables several
  # times faster than GNU ld (without it, GNU ld links).
  lld
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: need root to install: ${missing[*]}" >&2; exit 1; }
  SUDO=sudo
fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
