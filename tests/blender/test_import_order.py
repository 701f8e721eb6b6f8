"""``illumap`` and ``bpy`` in one Python process, imported in either order: both load and both
work afterwards (the core's exact visibility runs its Embree on several threads, and bpy
evaluates a subdivided mesh with its own TBB). A core linked to the system's TBB once made
``import illumap`` then ``import bpy`` fail with an undefined tbb symbol in libopenvdb."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

USE_CORE = """
    import numpy as np
    import illumap
    from illumap import scenes
    box = scenes.closed_box(20, emission=1.0, albedo=0.5)
    solution = illumap.solve(box, method="direct", visibility="exact", threads=2)
    assert solution.converged and np.isfinite(solution.radiosity).all()
    assert solution.radiosity.min() > 0.0, solution.radiosity.min()
"""
USE_BPY = """
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_uv_sphere_add()
    sphere = bpy.context.active_object
    sphere.modifiers.new("Subdivision", "SUBSURF").levels = 2
    evaluated = sphere.evaluated_get(bpy.context.evaluated_depsgraph_get())
    assert len(evaluated.data.vertices) > 4 * len(sphere.data.vertices)
"""


@pytest.mark.parametrize("first", ["illumap", "bpy"])
def test_illumap_and_bpy_import_in_either_order(first: str) -> None:
    imports = ["import illumap._core", "import bpy"]
    if first == "bpy":
        imports.reverse()
    code = "\n".join(imports) + textwrap.dedent(USE_CORE) + textwrap.dedent(USE_BPY) + \
        textwrap.dedent(USE_CORE) + "\nprint('OK', bpy.app.version_string)\n"
    # A bare interpreter: nothing of the test run (sys.path, conftest) is preloaded.
    result = subprocess.run([sys.executable, "-c", code], text=True, capture_output=True,
                            timeout=600, cwd=os.path.dirname(os.path.abspath(__file__)))
    assert result.returncode == 0 and "OK" in result.stdout, result.stdout + result.stderr
