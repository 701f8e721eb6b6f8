#!/usr/bin/env bash
# Creates or updates everything Illumap needs on a fresh Debian machine: system packages, a
# Python 3.11 virtual environment with bpy, and the native core built and installed into it.
# Idempotent: each step records a stamp and is skipped when its inputs have not changed.
# Usage: scripts/setup_env.sh            (quiet unless something fails)
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$ROOT/.venv"
STAMPS="$ROOT/.stamps"
PY="$VENV/bin/python"
mkdir -p "$STAMPS"

log() { printf '[setup] %s\n' "$*" >&2; }
stamp_ok() { [ -f "$STAMPS/$1" ] && [ "$(cat "$STAMPS/$1")" = "$2" ]; }
stamp_set() { printf '%s' "$2" > "$STAMPS/$1"; }
# pip, without the machine-wide index warnings about local mirror folders that do not exist.
pip_quiet() {
    "$PY" -m pip -q --disable-pip-version-check "$@" \
        2> >(grep -v "is ignored: it is neither a file nor a directory" >&2)
}

apt_install() {
    local missing=()
    for pkg in "$@"; do
        dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
    done
    [ ${#missing[@]} -eq 0 ] && return 0
    log "installing Debian packages: ${missing[*]}"
    local sudo=""; [ "$(id -u)" -ne 0 ] && sudo="sudo"
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${missing[@]}" >/dev/null
}

# 1. System packages: a compiler and Embree (exact visibility) for the core, and the X/GL client
#    libraries that bpy loads even when it renders headless.
command -v g++ >/dev/null 2>&1 || apt_install g++
apt_install libembree-dev
PYTHON311="$(command -v python3.11 || true)"
if [ -z "$PYTHON311" ]; then
    apt_install python3.11 python3.11-venv python3.11-dev
    PYTHON311="$(command -v python3.11)"
fi

# 2. Virtual environment with the pinned requirements.
if [ ! -x "$PY" ]; then
    log "creating virtual environment in $VENV"
    "$PYTHON311" -m venv "$VENV"
fi
REQ_HASH="$(sha256sum "$ROOT/scripts/requirements.txt" | cut -d' ' -f1)"
if ! stamp_ok requirements "$REQ_HASH"; then
    log "installing Python requirements (bpy is large: this takes a few minutes once)"
    pip_quiet install --upgrade pip
    pip_quiet install -r "$ROOT/scripts/requirements.txt"
    stamp_set requirements "$REQ_HASH"
fi

if ! "$PY" -c "import bpy" >/dev/null 2>&1; then
    apt_install libx11-6 libxrender1 libxxf86vm1 libxfixes3 libxi6 libxkbcommon0 libsm6 \
        libgl1 libegl1 libglu1-mesa
    "$PY" -c "import bpy" || { log "bpy does not import; see the error above"; exit 1; }
fi
"$PY" - <<'PYCHECK'
import numpy, OpenImageIO
assert numpy.__version__ == "1.26.4", f"numpy {numpy.__version__} replaced the 1.26.4 that bpy needs"
PYCHECK

# 3. The native core: rebuilt only when its sources change (the CMake build dir is kept, so a
#    rebuild is incremental).
CORE_HASH="$(cd "$ROOT" && find core -type f \( -name '*.cpp' -o -name '*.hpp' -o -name '*.py' \
    -o -name 'CMakeLists.txt' -o -name 'pyproject.toml' \) -not -path 'core/build/*' -print0 \
    | sort -z | xargs -0 sha256sum | sha256sum | cut -d' ' -f1)"
if ! stamp_ok core "$CORE_HASH" || ! "$PY" -c "import illumap._core" >/dev/null 2>&1; then
    log "building the native core"
    (cd "$ROOT" && pip_quiet install --no-build-isolation ./core)
    stamp_set core "$CORE_HASH"
fi
"$PY" -c "import illumap._core" || { log "the native core does not import"; exit 1; }
