#!/usr/bin/env bash
# The main job on the bundled Cornell box: sets up the environment (idempotent), computes the
# illumination map headless through Blender's command line with the default settings (Medium),
# saves the result as a .blend and renders the meshes with the light Illumap evaluated at their
# corners (the mesh preview) with Cycles. Outputs go to out/.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup_env.sh"
cd "$ROOT"
mkdir -p out
"$ROOT/scripts/blender" -b sample_blends/cornell_box.blend \
    --python scripts/illumap_batch.py -- \
    --quality medium --resolution 512 --samples 16 --render-preview meshes \
    --output out/cornell_box_lit.blend --render out/cornell_box.png --overwrite "$@"
