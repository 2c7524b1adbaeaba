#!/usr/bin/env bash
# ctest `install_find_package`: installs this build into a temporary prefix, builds the project
# in tests/install/consumer against it with find_package(mlspaces CONFIG) and runs it; runs
# the installed `mlspaces` command. Nothing from the build or source tree is on the consumer's
# paths: it sees the prefix only (MuJoCo is found the way the installed package records).
#   install_test.sh BUILD_DIR SOURCE_DIR WORK_DIR PYTHON (the venv python with mujoco)
set -euo pipefail
BUILD="$(realpath "$1")" SOURCE="$(realpath "$2")" WORK="$3" PYTHON="$4"
rm -rf "$WORK" && mkdir -p "$WORK"
PREFIX="$WORK/prefix"
EXAMPLE="$SOURCE/examples/custom_assets/asset_library"

fail() { echo "install_test: $*" >&2; exit 1; }

cmake --install "$BUILD" --prefix "$PREFIX" >"$WORK/install.log" || {
  cat "$WORK/install.log"; fail "cmake --install failed"; }
for f in lib/cmake/mlspaces/mlspacesConfig.cmake lib/cmake/mlspaces/mlspacesTargets.cmake \
         lib/cmake/mlspaces/FindMuJoCo.cmake include/mlspaces/library/registry.h \
         include/mlspaces/core/error.h share/mlspaces/robots/franka_droid/franka_droid.xml \
         bin/mlspaces; do
  [[ -e "$PREFIX/$f" ]] || fail "not installed: $f"
done

# Configure and build the outside project against the prefix alone.
cmake -S "$SOURCE/tests/install/consumer" -B "$WORK/consumer" -G Ninja \
  -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$PREFIX" >"$WORK/configure.log" 2>&1 || {
  cat "$WORK/configure.log"; fail "the consumer project does not configure"; }
cmake --build "$WORK/consumer" >"$WORK/build.log" 2>&1 || {
  cat "$WORK/build.log"; fail "the consumer project does not build"; }
if grep -qF -- "$SOURCE/include" "$WORK/consumer/build.ninja"; then
  fail "the consumer compiles with the source tree's headers, not the installed ones"
fi

out=$("$WORK/consumer/consumer_library" "$EXAMPLE" red_block)
[[ "$out" == "located red_block in lib: red_block.xml" ]] || fail "consumer_library said: $out"
if err=$("$WORK/consumer/consumer_library" "$EXAMPLE" no_such_uid 2>&1); then
  fail "an unknown UID did not fail"
fi
[[ "$err" == *"no_such_uid"* ]] || fail "unknown UID error does not name it: $err"

out=$("$WORK/consumer/consumer" "$EXAMPLE" red_block)
echo "$out"
mass=$(sed -n 's/^mass //p' <<<"$out")
[[ -n "$mass" ]] || fail "no mass from the consumer: $out"
python_mass=$("$PYTHON" -c "
import mujoco; m = mujoco.MjModel.from_xml_path('$EXAMPLE/red_block/red_block.xml'); print(repr(float(m.body_mass[1])))")
awk -v a="$mass" -v b="$python_mass" 'BEGIN { d = a - b; if (d < 0) d = -d; exit !(b > 0 && d <= 1e-5 * b) }' ||
  fail "consumer mass $mass differs from the mujoco module's $python_mass"
grep -q "^robot found" <<<"$out" || fail "the robot model is not found: $out"

# The installed command runs without LD_LIBRARY_PATH (RPATH into MuJoCo's package).
out=$(env -u LD_LIBRARY_PATH "$PREFIX/bin/mlspaces" locate red_block \
        --asset-library "lib=$EXAMPLE")
[[ "$out" == *red_block.xml* ]] || fail "installed mlspaces locate said: $out"
echo "install_test: installed package builds and runs an outside project"
