#!/usr/bin/env bash
# Installs what mlspaces needs to build, test and run: the Debian 12 packages (apt), and the
# project venv <repo>/.venv with the pinned Python packages of requirements.txt (MuJoCo among
# them: the C++ build links the wheel's libmujoco, see cmake/FindMuJoCo.cmake). Idempotent:
# when everything is present it changes nothing and takes a fraction of a second.
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config ccache git
  # style: .clang-format (ctest format_check), .clang-tidy (scripts/lint.sh --tidy)
  clang-format clang-tidy
  # core: JSON, zlib (NPZ), YAML, CLI
  nlohmann-json3-dev libsimdjson-dev zlib1g-dev libyaml-cpp-dev libcli11-dev
  # tests and benchmarks (numpy, h5py, pytest come from the venv)
  libgtest-dev libgmock-dev libbenchmark-dev hyperfine
  # sim: reading MJCF sources to locate MuJoCo's errors (MuJoCo itself comes from the venv's
  # mujoco wheel)
  libpugixml-dev
  # datagen: HDF5 trajectories
  libhdf5-dev
  # rendering: headless GL (OSMesa, EGL surfaceless) and video encoding (FFmpeg)
  libosmesa6-dev libegl-dev libavcodec-dev libavformat-dev libswscale-dev libavutil-dev
  # pictures (`mlspaces render`): PNG files, and stb_easy_font for the labels (a header)
  libpng-dev libstb-dev
  # LeRobot export tests: ffprobe checks the exported videos (docs/lerobot.md)
  ffmpeg
  # resources: packages (.tar.zst via libarchive + zstd), UID index hash, SHA-256, downloads
  libarchive-dev libzstd-dev libxxhash-dev libssl-dev libcurl4-openssl-dev
  # built-in data: the original's objathor metadata store (LMDB of zstd pickles)
  liblmdb-dev
  # fuzzing (scripts/fuzz.sh): clang 14 and its runtimes, libFuzzer among them
  clang libclang-rt-14-dev
)

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

# The project venv: pinned pip packages (requirements.txt). The stamp holds the hash of the
# requirements file it was installed from, so a changed pin reinstalls and an unchanged one
# costs one sha256sum.
install_venv() {
  local venv="$ROOT/.venv" req="$ROOT/requirements.txt"
  local want
  want="$(sha256sum "$req" | cut -d' ' -f1)"
  if [ -x "$venv/bin/python" ] && [ -d "$venv/wheelhouse" ] &&
     [ "$(cat "$venv/.mlspaces-requirements" 2>/dev/null)" = "$want" ]; then
    echo "install-deps: venv $venv up to date"
    return
  fi
  if ! command -v python3 >/dev/null; then
    echo "install-deps: python3 (3.10 or newer, with venv and pip) is not on PATH" >&2
    exit 1
  fi
  echo "install-deps: pip-installing requirements.txt into $venv"
  [ -x "$venv/bin/python" ] || python3 -m venv "$venv"
  "$venv/bin/python" -m pip install -q --disable-pip-version-check -r "$req"
  # The Python package's pinned runtime dependencies as wheels, so the ctest python_wheel can
  # install the built wheel into a fresh venv offline (tests/python/wheel_test.sh).
  "$venv/bin/python" -m pip download -q --disable-pip-version-check -d "$venv/wheelhouse" \
    $(grep -E '^(mujoco|numpy|pydantic|scipy)==' "$req")
  echo "$want" > "$venv/.mlspaces-requirements"
}

missing=()
for pkg in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$pkg")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  install_venv
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "install-deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
install_venv
