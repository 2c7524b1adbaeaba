#!/usr/bin/env bash
# Installs every Debian 12 package mlspaces needs to build, test and run. Idempotent: when
# everything is present it changes nothing and takes a fraction of a second.
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config ccache git
  # core: JSON, zlib (NPZ), YAML, CLI
  nlohmann-json3-dev libsimdjson-dev zlib1g-dev libyaml-cpp-dev libcli11-dev
  # tests and benchmarks; Debian's numpy writes/reads NPY/NPZ in interop tests
  libgtest-dev libgmock-dev libbenchmark-dev python3 python3-numpy hyperfine
  # sim: MuJoCo 2.2.2 (its CMake config needs qhull headers and OpenGL), XML
  libmujoco-dev libqhull-dev libgl-dev libopengl-dev libpugixml-dev
  # datagen: HDF5 trajectories (h5py reads them back in tests)
  libhdf5-dev python3-h5py
  # rendering: headless GL (OSMesa, EGL surfaceless) and video encoding (FFmpeg)
  libosmesa6-dev libegl-dev libavcodec-dev libavformat-dev libswscale-dev libavutil-dev
  # resources: packages (.tar.zst via libarchive + zstd), UID index hash, SHA-256, downloads
  libarchive-dev libzstd-dev libxxhash-dev libssl-dev libcurl4-openssl-dev
)

missing=()
for pkg in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$pkg")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "install-deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
