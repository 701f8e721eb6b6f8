#!/usr/bin/env bash
# Creates or updates everything Illumap needs on a fresh Debian machine: system packages, the
# Python virtual environments with bpy, and the native core built and installed into each.
#
#   .venv            Python 3.13, bpy 5.2.3 (Blender 5.2 LTS; scripts/requirements.txt): the
#                    primary environment, used by the sample, the tests and the benchmarks.
#   .venv-blender50  Python 3.11, bpy 5.0.1 (Blender 4.2-5.0; scripts/requirements-blender50.txt):
#                    builds the cp311 wheel and runs the add-on and packaging tests there.
#
# Usage: scripts/setup_env.sh              (.venv only: enough for the sample)
#        scripts/setup_env.sh --all        (both: the tests and the extension zip need both)
#        scripts/setup_env.sh --blender50  (.venv-blender50 only)
# Idempotent: each step records a stamp and is skipped when its inputs have not changed. A venv
# made with another Python version (e.g. an old 3.11 .venv) is deleted and made again.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
STAMPS="$ROOT/.stamps"
mkdir -p "$STAMPS"

log() { printf '[setup] %s\n' "$*" >&2; }
stamp_ok() { [ -f "$STAMPS/$1" ] && [ "$(cat "$STAMPS/$1")" = "$2" ]; }
stamp_set() { printf '%s' "$2" > "$STAMPS/$1"; }
# pip, without the machine-wide index warnings about local mirror folders that do not exist.
pip_quiet() {
    local py="$1"; shift
    "$py" -m pip -q --disable-pip-version-check "$@" \
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

# An interpreter for Python $1 (e.g. 3.13): pyenv's build, one on PATH, then Debian's (Debian 12
# has 3.11 only; pyenv builds 3.13 where it is installed but lacks that version).
find_python() {
    local version="$1" candidate
    local pyenv_root="${PYENV_ROOT:-$HOME/.pyenv}"
    for candidate in $(ls -d "$pyenv_root/versions/$version".* 2>/dev/null | sort -V -r); do
        if [ -x "$candidate/bin/python$version" ]; then echo "$candidate/bin/python$version"; return; fi
    done
    # A pyenv shim on PATH fails when that version is not selected: check that it runs.
    candidate="$(command -v "python$version" || true)"
    if [ -n "$candidate" ] && "$candidate" -c "" >/dev/null 2>&1; then echo "$candidate"; return; fi
    if [ "$version" = "3.11" ]; then
        apt_install python3.11 python3.11-venv python3.11-dev
        command -v python3.11; return
    fi
    if command -v pyenv >/dev/null 2>&1; then
        log "building Python $version with pyenv (once; several minutes)"
        pyenv install -s "$version" >&2
        find_python "$version"; return
    fi
    log "no Python $version found: install it (pyenv install $version) and run this again"
    exit 1
}

# setup_venv DIR PYTHON_VERSION REQUIREMENTS: the venv, its pinned requirements, the native core.
setup_venv() {
    local venv="$ROOT/$1" version="$2" req="$ROOT/$3" name="$1" key="${1#.}"
    local py="$venv/bin/python"
    if [ -e "$venv" ] && ! "$py" -c "import sys; sys.exit(sys.version_info[:2] != tuple(map(int, '$version'.split('.'))))" >/dev/null 2>&1; then
        log "$name holds another Python (or a broken one): making it again with Python $version"
        rm -rf "$venv"
    fi
    if [ ! -x "$py" ]; then
        local base; base="$(find_python "$version")"
        log "creating virtual environment $name with $base"
        "$base" -m venv "$venv"
        rm -f "$STAMPS/$key".*
    fi

    local build_req="$ROOT/scripts/requirements-build.txt"
    local req_hash; req_hash="$(cat "$req" "$build_req" | sha256sum | cut -d' ' -f1)"
    if ! stamp_ok "$key.requirements" "$req_hash"; then
        log "installing $3 into $name (bpy is large: this takes a few minutes once)"
        pip_quiet "$py" install --upgrade pip
        pip_quiet "$py" install -r "$req" -r "$build_req"
        stamp_set "$key.requirements" "$req_hash"
    fi

    if ! "$py" -c "import bpy" >/dev/null 2>&1; then
        apt_install libx11-6 libxrender1 libxxf86vm1 libxfixes3 libxi6 libxkbcommon0 libsm6 \
            libgl1 libegl1 libglu1-mesa
        "$py" -c "import bpy" || { log "bpy does not import in $name; see the error above"; exit 1; }
    fi
    # bpy needs exactly the numpy its requirements file pins; catch anything that replaced it.
    local numpy_pin; numpy_pin="$(sed -n 's/^numpy==//p' "$req")"
    "$py" -c "import numpy, OpenImageIO; v = numpy.__version__; assert v == '$numpy_pin', \
f'numpy {v} replaced the $numpy_pin that bpy needs in $name'"

    # The native core, as the portable manylinux_2_28 wheel the extension ships (Zig's clang,
    # static Embree without TBB: scripts/build_wheels.py), installed so that every test runs
    # against the wheel. Rebuilt only when its sources or build scripts change (one CMake build
    # dir per platform and wheel tag under core/build, so a rebuild is incremental; Embree is
    # built once, into build/embree).
    # (A plain `pip install ./core` since then replaced it: install the wheel again.)
    if ! stamp_ok "$key.core" "$CORE_HASH" || ! "$py" -c "import illumap._core, importlib.metadata as m
assert 'manylinux_2_28' in m.distribution('illumap').read_text('WHEEL')" >/dev/null 2>&1; then
        log "building the native core wheel for $name"
        (cd "$ROOT" && "$py" scripts/build_wheels.py --install >/dev/null)
        stamp_set "$key.core" "$CORE_HASH"
    fi
    "$py" -c "import illumap._core" || { log "the native core does not import in $name"; exit 1; }
}

PRIMARY=1; BLENDER50=0
case "${1:-}" in
    "") ;;
    --all) BLENDER50=1 ;;
    --blender50) PRIMARY=0; BLENDER50=1 ;;
    *) log "unknown option $1 (expected --all or --blender50)"; exit 2 ;;
esac

# 1. System packages: g++ and Debian's Embree for the native component tests
#    (core/tests_native/run.sh) and a plain `pip install ./core`; the wheels themselves are built
#    with Zig (a PyPI package) and Embree from Debian's source package. bpy's X/GL client
#    libraries are installed when bpy first fails to import.
command -v g++ >/dev/null 2>&1 || apt_install g++
apt_install libembree-dev

# What the core wheel is made of: its sources and the scripts that build it.
CORE_HASH="$(cd "$ROOT" && { find core -type f \( -name '*.cpp' -o -name '*.hpp' -o -name '*.py' \
    -o -name 'CMakeLists.txt' -o -name '*.cmake' -o -name 'pyproject.toml' -o -name '*.json' \) \
    -not -path 'core/build/*' -print0 | sort -z | xargs -0 sha256sum; sha256sum scripts/build_wheels.py \
    scripts/build_embree.py scripts/zig_toolchain.py scripts/wheel_abi.py; } | sha256sum | cut -d' ' -f1)"

# 2. The environments.
[ "$PRIMARY" -eq 1 ] && setup_venv .venv 3.13 scripts/requirements.txt
[ "$BLENDER50" -eq 1 ] && setup_venv .venv-blender50 3.11 scripts/requirements-blender50.txt
# The stamps of the layout before two environments; harmless, but confusing when left behind.
rm -f "$STAMPS/requirements" "$STAMPS/core"
exit 0
