#!/usr/bin/env bash
# The whole test suite: sets up the environment (idempotent), then runs every test with pytest
# on the bpy module. Extra arguments go to pytest, e.g. scripts/run_tests.sh tests/core -x
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup_env.sh"
cd "$ROOT"
exec "$ROOT/.venv/bin/python" -m pytest -q -ra "${@:-tests}"
