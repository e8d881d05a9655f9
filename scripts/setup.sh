#!/usr/bin/env bash
# Creates or updates .venv/ with everything the suite needs: the pinned PyPI requirements (ROS 2 Jazzy
# wheels included), emla_msgs built with CMake against those wheels, and the six Python packages.
# Each step is skipped when its inputs have not changed since it last succeeded (hashes in .venv/.stamps).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
VENV=$ROOT/.venv
STAMPS=$VENV/.stamps
PYTHON=${PYTHON:-python3}

say() { printf '[setup] %s\n' "$*"; }
digest() { cat "$@" | sha256sum | cut -d' ' -f1; }
fresh() { [ -f "$STAMPS/$1" ] && [ "$(cat "$STAMPS/$1")" = "$2" ]; }
mark() { echo "$2" > "$STAMPS/$1"; }

if ! "$PYTHON" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
  echo "setup: the ROS 2 Jazzy wheels need CPython 3.11; '$PYTHON' is $("$PYTHON" --version 2>&1). Set PYTHON=python3.11." >&2
  exit 1
fi
if [ ! -x "$VENV/bin/python" ]; then
  say "creating $VENV"
  "$PYTHON" -m venv "$VENV"
fi
mkdir -p "$STAMPS"
# One set-up at a time per venv (two test runs or shells may start it together).
exec 9>"$VENV/.setup.lock"
flock 9
# pip warns about every local index mirror it cannot use; keep the output to what matters.
pip_install() {
  "$VENV/bin/python" -m pip --disable-pip-version-check -q install "$@" 2>&1 | { grep -v 'is ignored: it is neither' || true; }
  return "${PIPESTATUS[0]}"
}

# Run a long step in the background and say every 15 s that it is still going (pip is quiet meanwhile).
with_progress() {
  local label=$1; shift
  "$@" &
  local pid=$! start=$SECONDS
  while kill -0 "$pid" 2>/dev/null; do
    sleep 1
    if (( SECONDS > start && (SECONDS - start) % 15 == 0 )); then say "  $label: $((SECONDS - start)) s"; fi
  done
  wait "$pid"
}

h=$(digest requirements.txt)
if ! fresh requirements "$h"; then
  say "installing pinned requirements (ROS 2 Jazzy wheels, numpy, scipy, ...; about a minute)"
  with_progress requirements pip_install -r requirements.txt
  mark requirements "$h"
fi

h=$(digest emla_msgs/CMakeLists.txt emla_msgs/package.xml emla_msgs/msg/*.msg)
if ! fresh emla_msgs "$h"; then
  say "building emla_msgs (rosidl) into the venv"
  build=$VENV/build/emla_msgs
  rm -rf "$build"
  mkdir -p "$build"
  (
    export CMAKE_PREFIX_PATH=$VENV AMENT_PREFIX_PATH=$VENV
    cmake -S emla_msgs -B "$build" -DCMAKE_INSTALL_PREFIX="$VENV" -DPython3_EXECUTABLE="$VENV/bin/python" \
      -DBUILD_TESTING=OFF -DCMAKE_BUILD_TYPE=Release > "$build/configure.log" 2>&1 \
      || { echo "setup: emla_msgs configure failed; see $build/configure.log" >&2; exit 1; }
    cmake --build "$build" -j "$(nproc)" > "$build/build.log" 2>&1 \
      || { echo "setup: emla_msgs build failed; see $build/build.log" >&2; exit 1; }
    cmake --install "$build" > "$build/install.log" 2>&1
  )
  mark emla_msgs "$h"
fi

for pkg in emla_core emla_sim emla_identification emla_control emla_bench emla_cli; do
  h=$(digest $(find "$pkg" -type f -not -path '*/__pycache__/*' -not -path '*.egg-info*' -not -path '*/build/*' | sort))
  if ! fresh "$pkg" "$h"; then
    say "installing $pkg"
    # A regular (non-editable) install: it also installs the ament index marker and package.xml.
    pip_install --no-deps --no-build-isolation --force-reinstall "./$pkg"
    rm -rf "$pkg/build" "$pkg"/*.egg-info
    mark "$pkg" "$h"
  fi
done
say "ready: $VENV/bin/emla"
