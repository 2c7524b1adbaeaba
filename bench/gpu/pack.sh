#!/usr/bin/env bash
# Packs what the GPU render benchmark needs on a bare device machine (issue 33, point 2), here,
# on the machine that built it:
#   .gpu/bundle.tar.xz  the CLI and the render quality bench with every shared library they load
#                       (ldd's closure, libmujoco included) but the C library and the GL loaders
#   .gl/*.deb           Debian's GL vendor-neutral loaders (libglvnd, libEGL, libOpenGL, ...), so
#                       that the device's NVIDIA EGL driver is found (device README's recipe)
# Both folders are ignored by git; the device tool carries them:
#   run(command="bash bench/gpu/device.sh", carry=[".gpu", ".gl"], timeout_s=600)
#
#   bench/gpu/pack.sh [BUILD_DIR]        (default build; build it first: scripts/build.sh)
set -euo pipefail
cd "$(dirname "$0")/../.."
BUILD=${1:-build}
BINS=("$BUILD/apps/mlspaces/mlspaces" "$BUILD/bench/datagen_render_quality_bench")
for f in "${BINS[@]}"; do
  [[ -x $f ]] || { echo "pack: $f is missing (build it: scripts/build.sh)" >&2; exit 2; }
done
STAGE=$(mktemp -d)
trap 'rm -rf "$STAGE"' EXIT
mkdir -p "$STAGE/bin" "$STAGE/lib"
for f in "${BINS[@]}"; do strip --strip-unneeded -o "$STAGE/bin/$(basename "$f")" "$f"; done

# The shared libraries: ldd's closure of both programs, less the C library (the device's is
# newer and must match its loader) and the GL loaders (the device's driver goes with glvnd's).
skip='^(ld-linux.*|libc|libm|libpthread|libdl|librt|libresolv|libGL|libGLX|libGLdispatch|libEGL|libOpenGL|libGLES.*)\.so'
missing=0
while read -r name path; do
  if [[ $path == "not" || ! -f $path ]]; then
    echo "pack: $name is not found by ldd" >&2
    missing=1
    continue
  fi
  [[ $name =~ $skip ]] || cp -L "$path" "$STAGE/lib/$name"
done < <(ldd "${BINS[@]}" | awk '/=>/ {print $1, $3}' | sort -u)
((missing == 0)) || exit 1

mkdir -p .gpu
tar -C "$STAGE" -cf - bin lib | xz -T0 -6 > .gpu/bundle.tar.xz.tmp
mv .gpu/bundle.tar.xz.tmp .gpu/bundle.tar.xz

if ! compgen -G ".gl/libEGL1_*.deb" > /dev/null; then
  mkdir -p .gl /tmp/mlspaces-apt-amd64/partial
  o=(-oAPT::Architecture=amd64 -oAPT::Architectures=amd64
    -oDir::State::Lists=/tmp/mlspaces-apt-amd64)
  apt-get "${o[@]}" -qq update
  (cd .gl && apt-get "${o[@]}" -qq download libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
fi
size=$(du -cb .gpu/bundle.tar.xz .gl/*.deb | tail -1 | cut -f1)
echo "pack: .gpu/bundle.tar.xz ($(ls "$STAGE/lib" | wc -l) libraries) and .gl:" \
  "$((size / 1048576)) MiB to carry (limit 64 MiB with the working tree)"
