"""Runs Illumap's tests inside Blender (or the bpy module), with pytest.

    blender -b --factory-startup --python tests/run_in_blender.py -- [pytest arguments]

Without arguments it runs the whole suite under ``tests/``. Blender's bundled Python has no
pytest: point ``ILLUMAP_SITE_PACKAGES`` at a site-packages directory that has pytest (and the
``illumap`` core, unless the extension is installed), e.g. ``.venv/lib/python3.11/site-packages``.
The process exits with pytest's exit code, so a failure, an error or an empty selection (5) is
non-zero.
"""

import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main() -> int:
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    extra = os.environ.get("ILLUMAP_SITE_PACKAGES")
    if extra and extra not in sys.path:
        sys.path.append(extra)
    try:
        import pytest
    except ImportError:
        print("run_in_blender: pytest is not importable; set ILLUMAP_SITE_PACKAGES", file=sys.stderr)
        return 2
    os.chdir(ROOT)
    return int(pytest.main(args or [os.path.join(ROOT, "tests")]))


if __name__ == "__main__":
    sys.exit(main())
