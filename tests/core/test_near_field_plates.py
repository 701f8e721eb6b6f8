"""A scan's surfel facing another object's surfels across a thin gap (``near_field.hpp``'s
plates rule, ``TransportOperator(scan_surfels=)``).

A large scan surfel 1.5 mm above a grid of smaller floor surfels, facing down (the bunny
scan's base over its floor). Its disc lies over the floor everywhere, so its form factors to
the floor cells are the shares of its area that lie over each cell (the height is a
fifteenth of the disc's radius), and they sum to 1. The point rule sees the floor only from
the disc's centre: the cell under the centre took half the row and the row summed to 0.65-0.76;
such a surfel passed its light to one floor surfel and back, and the gap under the bunny read
0.13 against Cycles' 0.85.

Bounds: the floor surfels are octagons of their cells' area, not the square cells, which
moves a cell's share by up to ~0.04 near the disc's rim and leaves ~5% of the plane between
octagons; the disc rule averages over 7 points of the receiver's disc. 0.05 per entry and
0.06 on the sum hold for a correct disc-to-octagon integration of this layout; the point
rule misses them by 0.14-0.24 on the sum and 0.14 on one entry.
"""

import numpy as np
import pytest

import illumap
from illumap.operator import TransportOperator
from illumap_core_testing import requires_native

pytestmark = requires_native

SPACING = 0.02     # m between floor surfels (a cell of SPACING² each)
GRID = 7           # GRID × GRID floor surfels, centred on the origin
HEIGHT = 0.0015    # m: the gap


def _layout(ratio: float):
    """Floor surfels (GRID², facing up) and one surfel of ``ratio`` cells' area facing down
    HEIGHT above them, off the grid's centre."""
    xs = (np.arange(GRID) - GRID // 2) * SPACING
    fx, fy = np.meshgrid(xs, xs)
    floor = np.c_[fx.ravel(), fy.ravel(), np.zeros(GRID * GRID)]
    big = np.array([[0.3 * SPACING, 0.2 * SPACING, HEIGHT]])
    positions = np.r_[floor, big]
    normals = np.r_[np.tile([0.0, 0.0, 1.0], (GRID * GRID, 1)), [[0.0, 0.0, -1.0]]]
    areas = np.r_[np.full(GRID * GRID, SPACING ** 2), [ratio * SPACING ** 2]]
    zeros = np.zeros((len(positions), 3))
    return illumap.Surfels(positions, normals, areas, zeros, zeros)


def _exact_shares(surfels) -> np.ndarray:
    """The share of the top surfel's disc over each floor cell (squares), by sampling."""
    rng = np.random.default_rng(1)
    radius = np.sqrt(surfels.areas[-1] / np.pi)
    r = radius * np.sqrt(rng.random(400_000))
    t = 2.0 * np.pi * rng.random(400_000)
    xy = surfels.positions[-1, :2] + np.c_[r * np.cos(t), r * np.sin(t)]
    cell = np.round(xy / SPACING).astype(np.int64) + GRID // 2
    return np.bincount(cell[:, 1] * GRID + cell[:, 0], minlength=GRID * GRID) / len(xy)


def _row(op, surfels, i: int) -> np.ndarray:
    """Row ``i`` of the operator, entry by entry (exact direct sums)."""
    n = surfels.n
    out = np.empty(n)
    for j in range(n):
        x = np.zeros((n, 3))
        x[j] = 1.0
        out[j] = op.apply_rows(x, [i])[0, 0]
    return out


@pytest.mark.parametrize("ratio", [2.0, 4.0])
def test_scan_surfel_over_a_floor_sees_the_cells_under_its_disc(ratio):
    surfels = _layout(ratio)
    scan = np.r_[np.zeros(GRID * GRID, dtype=np.int64), [1]]
    op = TransportOperator(surfels, method="direct", scan_surfels=scan)
    row = _row(op, surfels, surfels.n - 1)[:-1]
    share = _exact_shares(surfels)
    print(f"\nratio {ratio}: row sum {row.sum():.3f}; largest shares "
          f"{np.round(np.sort(share)[::-1][:4], 3)}, entries there "
          f"{np.round(row[np.argsort(-share)[:4]], 3)}")
    assert abs(row.sum() - 1.0) <= 0.06
    assert np.max(np.abs(row - share)) <= 0.05


def test_pairs_within_one_scan_keep_the_point_rule():
    """Both surfels of one scan (a point's neighbour's back side on the same bumpy base): the
    same operator as with no scan at all."""
    surfels = _layout(2.0)
    same = TransportOperator(surfels, method="direct", scan_surfels=np.ones(surfels.n, int))
    none = TransportOperator(surfels, method="direct")
    x = np.random.default_rng(2).random((surfels.n, 3))
    assert np.array_equal(same.apply(x), none.apply(x))


@pytest.mark.parametrize("bad", [np.ones(3, int), -np.ones(GRID * GRID + 1, int),
                                 np.full(GRID * GRID + 1, 0.5)])
def test_bad_scan_surfels_are_refused(bad):
    with pytest.raises(illumap.InputError, match="scan_surfels"):
        TransportOperator(_layout(2.0), method="direct", scan_surfels=bad)


def test_the_solve_numbers_each_clouds_surfels():
    """``stages.solve.scan_surfels``: a mesh's surfels 0, each point cloud's (both sides of its
    points) its place among the scene's clouds, counted from 1; None without a cloud."""
    from illumap.settings import Settings
    from illumap.stages.scene import PointCloud, Scene, Source
    from illumap.stages.solve import scan_surfels
    n = 9
    zeros = np.zeros((n, 3))
    sources = (Source("Floor", "MESH", 0, 3, 1.0), Source("Bunny", "POINTS", 3, 5, 1.0),
               Source("Room", "POINTS", 5, 7, 1.0), Source("Bunny", "BACK", 7, 9, 1.0))

    def cloud(name):
        return PointCloud(name, zeros[:2], zeros[:2], zeros[:2], zeros[:2], np.arange(2))

    scene = Scene(settings=Settings(), positions=zeros, normals=np.tile([0, 0, 1.0], (n, 1)),
                  areas=np.ones(n), albedo=zeros, emission=zeros, solve_emission=zeros,
                  sources=sources, clouds=(cloud("Bunny"), cloud("Room")))
    assert scan_surfels(scene).tolist() == [0, 0, 0, 1, 1, 2, 2, 1, 1]
    mesh_only = Scene(**{**scene.__dict__, "sources": sources[:1], "clouds": ()})
    assert scan_surfels(mesh_only) is None
