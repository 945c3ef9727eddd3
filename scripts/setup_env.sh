#!/usr/bin/env bash
# Idempotent set-up behind both README commands (`make run`, `make test`):
#   1. the project's own venv (.venv) from PyPI, pinned by constraints.txt, reinstalled only when
#      requirements.txt or constraints.txt change;
#   2. the ROS 2 wheels' exported CMake include paths pointed at this venv (fix_wheel_cmake_paths.py);
#   3. `colcon build --symlink-install` of src/ into build/ and install/ (incremental).
# Needs python3.11 (the ROS 2 Jazzy wheels are cp311), no root, no network beyond PyPI.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
venv="$root/.venv"
log() { echo "[setup] $*" >&2; }

find_python() {
  for candidate in "${SAT_PYTHON:-}" python3.11 python3; do
    [ -n "$candidate" ] || continue
    if command -v "$candidate" >/dev/null 2>&1 &&
       "$candidate" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' 2>/dev/null; then
      command -v "$candidate"; return 0
    fi
  done
  log "error: Python 3.11 is required (ROS 2 Jazzy wheels on PyPI are cp311); set SAT_PYTHON"
  return 1
}

if [ ! -x "$venv/bin/python" ]; then
  python=$(find_python)
  log "creating $venv with $python"
  "$python" -m venv "$venv"
fi

stamp="$venv/.sat-swarm-requirements.sha256"
wanted=$(cat requirements.txt constraints.txt | sha256sum | cut -d' ' -f1)
if [ "$(cat "$stamp" 2>/dev/null)" != "$wanted" ]; then
  log "installing requirements into .venv (first run takes a few minutes)"
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
    -r requirements.txt -c constraints.txt
  "$venv/bin/python" scripts/fix_wheel_cmake_paths.py "$venv" >&2
  echo "$wanted" > "$stamp"
fi

# shellcheck source=/dev/null
source "$venv/bin/activate"
export AMENT_PREFIX_PATH="$venv" CMAKE_PREFIX_PATH="$venv"
mkdir -p log
log "colcon build"
if ! colcon --log-base log build --symlink-install --base-paths src \
     > log/colcon-build.txt 2>&1; then
  tail -n 40 log/colcon-build.txt >&2
  log "error: colcon build failed (full output: log/colcon-build.txt)"
  exit 1
fi
