#!/usr/bin/env bash
# The whole test suite: sets up both environments (idempotent), then runs
#   1. every test on Blender 5.2 LTS (.venv: Python 3.13, bpy 5.2.3), and
#   2. the add-on, packaging and harness tests (tests/blender) on Blender 5.0 (.venv-blender50:
#      Python 3.11, bpy 5.0.1), which stands for 4.2-5.0 and their cp311 wheel.
# Extra arguments go to pytest on .venv only, e.g. scripts/run_tests.sh tests/core -x
# scripts/run_tests.sh --blender50 [args] runs pytest on .venv-blender50 only (default tests/blender).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup_env.sh" --all
cd "$ROOT"
pytest_in() { local venv="$1"; shift; "$ROOT/$venv/bin/python" -m pytest -q -ra "$@"; }

if [ "${1:-}" = "--blender50" ]; then
    shift
    pytest_in .venv-blender50 "${@:-tests/blender}"; exit
fi
if [ $# -gt 0 ]; then
    pytest_in .venv "$@"; exit
fi

status=0
echo "== Blender 5.2 (bpy $("$ROOT/.venv/bin/python" -c 'import bpy; print(bpy.app.version_string)' 2>/dev/null)): tests"
pytest_in .venv tests || status=$?
echo "== Blender 5.0 (bpy $("$ROOT/.venv-blender50/bin/python" -c 'import bpy; print(bpy.app.version_string)' 2>/dev/null)): tests/blender"
pytest_in .venv-blender50 tests/blender || status=$?
exit "$status"
