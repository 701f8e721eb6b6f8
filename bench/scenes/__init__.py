"""The scene library of the benchmarks, the calibration and the tests: every scene's geometry,
materials and lights declared once as plain data, and thin builders that make surfels or
Blender objects of them.

| module | what | needs |
|---|---|---|
| ``cornell`` | the one Cornell box: Cornell's published quads, reflectances and light; its published form (Blender scenes) and its regular form (surfel benchmarks) | numpy |
| ``shapes`` | geometry as arrays: grids over quads (optionally jittered), boxes, midpoint grids, the Stanford bunny scan | numpy |
| ``spec`` | a scene as data: materials, meshes, lamps, world, camera | numpy |
| ``meshes`` | the scenes built as meshes, as data: the reference scenes (``REFERENCE``) and the preview scenes | numpy |
| ``surfels`` | the surfel scenes (``build``: the Cornell box on grids or sampled as triangles, the bunny scan, the room) and their converged references and errors | illumap |
| ``records`` | where a result file comes from (commit, native build) and writing it | |
| ``blender`` | the Blender builder: ``build(name)`` makes a reference scene in an empty file (``ReferenceScene``) | bpy |
| ``preview`` | the preview scenes built, given as scans, and shown after Compute | bpy, addon |

The exact cases with closed forms (sphere interior, closed box, view-factor pairs; the room
``box_room``) are ``illumap.scenes``: shipped with the core and importable without bpy or this
folder, since the core tests and ``surfels.interior`` build on them.

Scripts that put ``bench/`` on ``sys.path`` import ``from scenes import surfels as S``; code
run from the repository root imports ``bench.scenes.…``.
"""
