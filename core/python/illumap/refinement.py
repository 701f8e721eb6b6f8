"""Adaptive refinement: from a first pass's solution, a density multiplier per region of the
meshes, higher where the light varies.

The steps: each first-pass surfel's luminance against its ADAPTIVE_NEIGHBOURS nearest
neighbours (``sampling.local_variation``); the meshes' triangles split into regions of about
ADAPTIVE_SURFELS_PER_REGION first-pass surfels (``sampling.Regions``); each region's largest
variation turned into a multiplier in [1, ``max_ratio``] (``sampling.density_multipliers``;
regions too small to hold a first-pass surfel take the variation of the nearest one).
Sampling the meshes again with these multipliers and the same count is the second pass.
The automatic mode's ``solve_triangles`` and the add-on's second pass both refine here.
Numpy in, numpy out; the k nearest neighbours come from the native core unless the caller
passes its own ``knn``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .sampling import Regions, density_multipliers, local_variation

__all__ = ["Refinement", "refine", "luminance", "LUMINANCE_WEIGHTS", "ADAPTIVE_NEIGHBOURS",
           "ADAPTIVE_SURFELS_PER_REGION", "ADAPTIVE_MAX_RATIO"]

#: Rec. 709 luminance of linear RGB: what "the light varies" is measured on.
LUMINANCE_WEIGHTS = np.array([0.2126, 0.7152, 0.0722])
#: Neighbours compared per surfel to measure how much the first pass's illumination varies.
ADAPTIVE_NEIGHBOURS = 8
#: First-pass surfels per region (regions are the mesh triangles split until each holds about
#: this many): enough to see a variation inside one.
ADAPTIVE_SURFELS_PER_REGION = 6
#: Upper bound of the density multipliers (the lower one is 1).
ADAPTIVE_MAX_RATIO = 4.0


def luminance(rgb) -> np.ndarray:
    """Rec. 709 luminance (N,) of linear RGB (N, 3)."""
    return np.asarray(rgb, dtype=np.float64) @ LUMINANCE_WEIGHTS


@dataclass
class Refinement:
    """The regions of each mesh and the density multiplier of every region."""

    regions: list               # sampling.Regions per mesh, in the order given
    multipliers: np.ndarray     # (R,) over all meshes' regions, mesh after mesh, in [1, max_ratio]

    @property
    def count(self) -> int:
        """Regions over all meshes."""
        return int(sum(reg.count for reg in self.regions))

    def per_mesh(self) -> list:
        """The multipliers of each mesh's regions."""
        out, start = [], 0
        for reg in self.regions:
            out.append(self.multipliers[start:start + reg.count])
            start += reg.count
        return out


def _native_knn(points, queries, k):
    from . import _core
    idx, dist = _core.knn(points, queries, k)
    return np.asarray(idx), np.asarray(dist)


def refine(positions, radiosity, meshes, *, max_ratio: float = ADAPTIVE_MAX_RATIO,
           knn=None) -> Refinement:
    """Density multipliers per region from a first pass.

    positions, radiosity : (N, 3) of the first pass's surfels (m; RGB radiosity). The meshes'
        surfels come first, mesh after mesh; any further ones (e.g. points of a scan) count
        as neighbours only.
    meshes : sequence of ``(corners, triangle, bary, area)`` per mesh: its triangles' corners
        (T, 3, 3) in m, the triangle (n,) and barycentric coordinates (n, 3) of each of its
        first-pass surfels, and its total area in m² (the first pass's density there is
        n / area).
    max_ratio : the multipliers' upper bound.
    knn : ``knn(points, queries, k) -> (indices (M, k), distances (M, k))``, sorted by distance;
        default the native core's.
    """
    knn = _native_knn if knn is None else knn
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    values = luminance(radiosity)
    k = min(ADAPTIVE_NEIGHBOURS + 1, len(positions))
    idx, _ = knn(positions, positions, k)
    variation = local_variation(values, np.asarray(idx)[:, 1:])
    regions, located, offset, n_mesh = [], [], 0, 0
    for corners, triangle, bary, area in meshes:
        density = len(triangle) / area
        reg = Regions.build(corners, ADAPTIVE_SURFELS_PER_REGION / density)
        located.append(offset + reg.locate(triangle, bary))
        regions.append(reg)
        offset += reg.count
        n_mesh += len(triangle)
    # Regions too small to hold a first-pass surfel take the variation of the nearest one.
    centres = np.ascontiguousarray(np.concatenate([reg.corners.mean(axis=1) for reg in regions]))
    nearest, _ = knn(positions, centres, 1)
    multipliers = density_multipliers(np.concatenate(located), variation[:n_mesh], offset,
                                      max_ratio=max_ratio,
                                      fill=variation[np.asarray(nearest)[:, 0]])
    return Refinement(regions=regions, multipliers=multipliers)
