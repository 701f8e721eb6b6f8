"""Illumap against an independent reference: Cycles bakes of meshes as users build them.

Run ``.venv/bin/python -m bench.reference --help`` (or ``bench/reference/run.py``) from the
repository root. ``bench/scenes`` declares and builds the scenes (``meshes``, ``blender``),
``bake`` bakes Cycles' outgoing radiance per vertex, ``score`` compares, ``run`` is the front
door (cached references, Illumap settings, Cycles sample sweep, ``bench/results/reference.json``).
"""
