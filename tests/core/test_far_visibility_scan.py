"""A scan's far PARTIAL leaf pairs take a visibility fraction per point (``traversal.hpp``:
``TraversalOptions::scan``, ``InteractionLists::point_w``).

A floor of surfels under an occluding plane with a square hole, and a patch of a scan's
surfels far above it, facing down (the bunny scan's base over its floor: a floor leaf of which
one point sees the scan's lit inside through a hole in the base). Only the floor surfels under
the hole see the patch. The floor leaves that straddle the hole's edges are far from the
patch's leaves and PARTIAL: one sampled fraction per leaf pair gave every floor surfel of such
a leaf the same share of the patch, so surfels that see none of it took up to a third of the
largest coupling (the bunny's gap read 0.96 against Cycles' 0.90). With a fraction per point
(8 sampled rays from each point of the wider leaf), a point that sees none of the other leaf
gets exactly none of it.

What the bound leaves open: node pairs above the leaves are still classified from 8 sampled
pairs, so a large pair whose samples all see (or all miss) is taken as wholly visible (or
dropped); this layout's hole is placed where that does not happen.
"""

import numpy as np

import illumap
from illumap.operator import TransportOperator
from illumap_core_testing import requires_native

pytestmark = requires_native

SPACING = 0.025          # m between surfels (floor and patch)
HOLE = (0.44, 0.59)      # m: the hole's square [a, b]² in the occluder, off the octree's cuts
OCCLUDER_Z = 0.05        # m: the occluding plane's height
PATCH_Z = 1.0            # m: the patch's height


def _scene():
    """(surfels, occluder triangles, scan ids, floor rows, patch rows)."""
    g = (np.arange(40) + 0.5) * SPACING
    fx, fy = np.meshgrid(g, g, indexing="ij")
    floor = np.c_[fx.ravel(), fy.ravel(), np.zeros(fx.size)]
    p = 0.35 + (np.arange(12) + 0.5) * SPACING
    px, py = np.meshgrid(p, p, indexing="ij")
    patch = np.c_[px.ravel(), py.ravel(), np.full(px.size, PATCH_Z)]
    positions = np.r_[floor, patch]
    normals = np.r_[np.tile([0.0, 0.0, 1.0], (len(floor), 1)),
                    np.tile([0.0, 0.0, -1.0], (len(patch), 1))]
    n = len(positions)
    surfels = illumap.Surfels(positions, normals, np.full(n, SPACING ** 2),
                              np.full((n, 3), 0.5), np.zeros((n, 3)))
    a, b = HOLE
    z = OCCLUDER_Z

    def rect(x0, x1, y0, y1):
        return [[[x0, y0, z], [x1, y0, z], [x1, y1, z]], [[x0, y0, z], [x1, y1, z], [x0, y1, z]]]

    triangles = np.array(rect(-1, a, -1, 2) + rect(b, 2, -1, 2) + rect(a, b, -1, a)
                         + rect(a, b, b, 2), dtype=np.float64)
    scan = np.zeros(n, dtype=np.int64)
    scan[len(floor):] = 1
    return surfels, triangles, scan, np.arange(len(floor)), np.arange(len(floor), n)


def _operator(surfels, triangles, scan):
    return TransportOperator(surfels, visibility="exact", occluder_triangles=triangles,
                             scan_surfels=scan)


def test_a_floor_surfel_that_sees_none_of_a_scan_gets_none_of_it():
    surfels, triangles, scan, floor, patch = _scene()
    op = _operator(surfels, triangles, scan)
    x = np.zeros((surfels.n, 3))
    x[patch] = 1.0
    fmm = op.apply(x)[floor, 0]
    exact = op.apply_rows(x, floor)[:, 0]
    assert (exact > 0).sum() > 20, "the layout lets the floor under the hole see the patch"
    blocked = exact == 0.0
    leak = fmm[blocked].max()
    assert leak <= 0.01 * exact.max(), (
        f"a floor surfel that sees none of the patch takes {leak:.4g} from it "
        f"({leak / exact.max():.0%} of the largest exact coupling, {exact.max():.4g})")


def test_per_point_fractions_keep_reciprocity():
    """x · A K y = y · A K x (diag(A) F V symmetric): the weights of a point serve both
    directions of its pairs. Bound: the expansions' own error at order 3, θ 0.5 (~5e-4)."""
    surfels, triangles, scan, _, _ = _scene()
    op = _operator(surfels, triangles, scan)
    rng = np.random.default_rng(3)
    x, y = rng.random((surfels.n, 3)), rng.random((surfels.n, 3))
    a = surfels.areas[:, None]
    left = float(np.sum(x * a * op.apply(y)))
    right = float(np.sum(y * a * op.apply(x)))
    print(f"relative asymmetry {abs(left - right) / abs(left):.2e}")
    assert abs(left - right) <= 2e-3 * abs(left), (left, right)
