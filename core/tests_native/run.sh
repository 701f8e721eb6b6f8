#!/usr/bin/env bash
# Builds and runs the native visibility tests with g++ directly (no CMake, no Python).
#   core/tests_native/run.sh            # tests (about 3 minutes on 2 busy cores)
#   core/tests_native/run.sh --bench N [samples]  # also the precompute benchmark at N surfels
#                                        (exact; ILLUMAP_VIS_SHAPE=quad for squares)
# Exits non-zero when a test fails or does not build.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
src="$here/../src"
out="${ILLUMAP_TEST_BUILD:-${TMPDIR:-/tmp}/illumap_tests_native}"
mkdir -p "$out"
CXX="${CXX:-g++}"
flags=(-std=c++17 -O2 -Wall -I "$src")
libs=(-lembree3 -pthread)
common=("$src/visibility/visibility.cpp" "$src/visibility/visibility_factory.cpp"
        "$src/visibility/raycast.cpp" "$src/visibility/seed_visibility.cpp" "$src/geometry/octree.cpp")

echo "building test_visibility -> $out"
"$CXX" "${flags[@]}" "$here/test_visibility.cpp" "${common[@]}" -o "$out/test_visibility" "${libs[@]}"
# Both visibility.hpp and the FMM's traversal.hpp must be includable in one unit.
if [ -f "$src/transport/traversal.hpp" ]; then
  printf '#include "transport/traversal.hpp"\n#include "visibility/visibility.hpp"\n#include "visibility/visibility_factory.hpp"\n#include "visibility/raycast.hpp"\n#include "visibility/seed_visibility.hpp"\nint main(){return 0;}\n' > "$out/headers.cpp"
  "$CXX" "${flags[@]}" -fsyntax-only "$out/headers.cpp"
fi
"$out/test_visibility"
# The exact-mode tests again with equal-area squares instead of discs (VisibilityOptions::shape).
ILLUMAP_VIS_SHAPE=quad "$out/test_visibility" "degenerate occluder half rooms scale reciprocity furnace coverage"

if [ "${1:-}" = "--bench" ]; then
  "$CXX" "${flags[@]}" "$here/bench_visibility.cpp" "${common[@]}" -o "$out/bench_visibility" "${libs[@]}"
  "$out/bench_visibility" "${2:-100000}" exact 0 "${3:-8}"
fi
