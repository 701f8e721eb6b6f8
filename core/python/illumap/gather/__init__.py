"""The light where the user sees it (DESIGN.md §6), after the solve, no bpy: the meshes'
corners and the point clouds' points (``receive``), one concept per module:

* ``rays`` — how many rays a receiver casts (the settings', or a target error's);
* ``ids`` — the identities rays follow from; which triangles are two-sided;
* ``corners`` — mesh corners clear of rounding, and merged where they see the same light;
* ``covered`` — receivers another surface lies flat against;
* ``straddling`` — surfels whose disc reaches through another surface, evaluated afresh;
* ``lattice`` — the gather's table: lamp and sky light cast at its points, contacts;
* ``gaps`` — receivers facing a surface across a gap finer than that table;
* ``scans`` — a point cloud's points, and the outward side of a scan's;
* ``evaluation`` — one batch of receivers: direct light, gather, cache, corrections;
* ``receive`` — every receiver of a scene, as a new value (``ReceiverLight``).
"""

from .receive import ReceiverLight, receive

__all__ = ["ReceiverLight", "receive"]
