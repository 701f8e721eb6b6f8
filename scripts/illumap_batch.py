"""Batch entry point: ``blender -b scene.blend --python scripts/illumap_batch.py -- <options>``.

Run ``... -- --help`` for the options and exit codes (documented in addon/batch.py; the codes
are ``addon.errors.ExitCode``: 0 ok, 1 internal error, 2 bad arguments, 3 bad scene/input,
4 solver failure, 5 output cannot be written, 130 cancelled).

Works from a repository checkout (the repo root goes on sys.path and ``addon`` is imported) and
with the extension installed (``bl_ext.<repo>.illumap.addon``).
"""

import importlib
import os
import sys


def _batch_module():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    if os.path.isfile(os.path.join(root, "addon", "batch.py")):
        if root not in sys.path:
            sys.path.insert(0, root)
        return importlib.import_module("addon.batch")
    import bpy  # an installed extension: find its package name
    for name in bpy.context.preferences.addons.keys():
        if name.split(".")[-1] == "illumap":
            return importlib.import_module(name + ".addon.batch")
    for name in ("bl_ext.user_default.illumap", "illumap_addon"):
        try:
            return importlib.import_module(name + ".addon.batch")
        except ImportError:
            continue
    raise SystemExit("illumap_batch: cannot find the Illumap add-on (checkout or installed extension)")


if __name__ == "__main__":
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    sys.exit(_batch_module().main(argv))
