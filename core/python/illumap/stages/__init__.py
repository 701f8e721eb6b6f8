"""A run as values (no bpy), one concept per module:

* ``scene`` — the scene as plain data (``Scene``, its ``Source``s, ``PointCloud``s and
  ``Receivers``);
* ``choices`` — what a run spends, from its settings (occluders, surfel target, shadow rays);
* ``light`` — ``Scene`` → ``Lit``: the direct light at the surfels, and whether any reaches;
* ``solve`` — ``Lit`` → ``Solved``;
* ``passes`` — ``Solved`` → ``Gathered`` (``illumap.gather``) and the one loop over a run's
  passes, ``run`` (``illumap.run``);
* ``errors`` — why a run stops.

Nothing is imported here, so each module loads only what it needs.
"""
