"""White furnace against Cycles: seven geometry classes, every surface white, a white sky.

Every material is a white Diffuse BSDF (albedo 1; Illumap clamps it to 0.999, as it must for
its solve to converge), there are no lamps and no emitters, and the world's Background is
(1, 1, 1) at strength 1. Whatever light can reach then reads 1 and what is sealed inside a
closed part reads 0; nothing may read above 1. The cases are built by
``bench/reference/furnace.py`` (its docstring describes them): Suzanne on a floor (open, eyes
inside the head), two interpenetrating boxes, a box and a sphere resting on a floor, a thin
two-sided plate over a floor, the Stanford bunny as a point cloud without and with normals,
and a room with a table given as one point cloud without normals (twin points where surfaces
meet).

The reference is Cycles baking the same meshes (``furnace.bake_reference``: DIFFUSE, direct +
indirect, CPU, no clamping), the mean of two bakes with different seeds. A point without a
normal shows its brighter side (Illumap's warning says so): the room scan's walls and floor
are baked a second time with their normals flipped and the larger value kept; the bunny's
five holes are filled for Cycles (faces only, the points unchanged), so its inside is sealed
and its outside is the brighter side. Two choices differ from ``bench/reference/bake.py``,
both measured (16-sample bakes, relative RMS over a case):

* 1024 bounces (Cycles' maximum), not 64: the gap under the bunny's flat base takes hundreds.
  At albedo 1, 64 bounces read the bunny case 14.5% under 1024 (which read 1.0000), the
  resting sphere's case 2.2%.
* The materials' albedo is Illumap's clamp, 0.999, for the bakes: a correct solver of the
  clamped scene meets that, not the ideal furnace. The clamp alone moves the bunny case by
  2.7% (its mean 0.9914 against 1.0000: the gap's many bounces), Suzanne's and the resting
  case by 0.5%.

Per class, over every vertex that Cycles bakes (RGB mean): relative RMS ≤ 0.01 + the
reference's own noise (half the relative RMS difference of its two bakes, measured in each
run: ``SAMPLES`` per bake), no point above 1.005, and a solve that converged without "not
positive definite". The bounds are not fitted to today's code: 3 of the 7 fail, and are
marked strict xfail (``KNOWN_FAILURES``) so that one that starts to pass is noticed.

Measured 2026-12-07 on 2 shared cores (``bench/reference/furnace.py --conserve off`` and
``--conserve on``; relative RMS against the bench's 512-sample references (the bunny's 128),
whose own noise is 0.0001-0.0029; this test's 16-128-sample references agreed within 0.0003):

==============  ======  ==============================  ==============================
class           points  conservation off (before)       conservation on (shipped)
                        RMS / mean ratio / max / solve  RMS / mean ratio / max / solve
==============  ======  ==============================  ==============================
monkey          3,661   0.833 / 1.652 / 2.933 / stops   0.233 / 1.103 / 1.010 / conv.
intersecting    2,421   0.081 / 1.006 / 1.014 / conv.   0.081 / 1.007 / 1.001 / conv.
resting         2,485   0.067 / 0.990 / 1.082 / conv.   0.028 / 0.997 / 1.005 / conv.
plate           1,402   0.0004 / 1.000 / 1.000 / conv.  0.0001 / 1.000 / 0.999 / conv.
scan            35,795  2.183 / 3.068 / 8.141 / stops   0.037 / 0.989 / 1.099 / conv.
scan_normals    35,795  0.223 / 0.923 / 1.648 / conv.   0.133 / 0.944 / 1.004 / conv.
room_scan       4,357   0.195 / 1.178 / 1.493 / conv.   0.0005 / 1.000 / 0.999 / conv.
==============  ======  ==============================  ==============================

"stops": CG stopped on "not positive definite" and the result was written all the same.

With the first-hit fill (rows the kernel cannot raise to their share take the rest from their
rays' first hits, ``illumap.conservation.first_hit_fill``; same references, 2026-12-07):
monkey 0.237, intersecting 0.027, resting 0.026 (max 1.003), plate 0.0001, scan 0.015 (max
1.054, 0.37% of points above 1.005), scan_normals 0.053 (max 1.024), room_scan 0.0004.

With enclosed surfels taking their rows from first hits (``illumap.sealing``: surfels that the
sky reaches under 10% in 128 bounces of the first-hit transport; same references,
2026-12-07): monkey 0.064 (max 0.9996, none above 1.005; 4,770 of 20,000 surfels
enclosed), the six others as above (intersecting 0.027, resting 0.026, plate 0.0001, scan
0.015, scan_normals 0.053, room_scan 0.0004).

With the contacts' receivers (``illumap.gather.covered``: a surface covers a receiver only
where it lies flat against it, not where another mesh's tilted triangle touches it at a
corner, and any of another mesh's nearest triangles may cover it; ``illumap.gather.corners``:
a corner whose lifted ray origin lies beyond another surface starts 5% into its face) and a
one-sided scan's splats two-sided to the gather (their backs show the point's light, as the
solve's hemisphere counts them lit); same 512-sample references, one session, 2026-12-07,
before → after: monkey 0.0644 → 0.0571, intersecting 0.0272 → 0.0050, resting 0.0257 →
0.0058, plate 0.0001 → 0.0001, scan 0.0153 → 0.0153, scan_normals 0.0528 → 0.0290 (max 1.024
→ 1.062, points above 1.005 0.04% → 0.15%), room_scan 0.0004 → 0.0004. The intersecting and
resting cases pass.

With the gather's lattice counting each direction once (``illumap.gather.lattice``: where
the sky is cast afresh at a lattice point, the surfels' indirect light there is lowered to
the share of the hemisphere the sky leaves, never raised); same references, 2026-12-07,
before (the figures above; scan and resting rerun before the change: the same) → after (one
run, ``bench/reference/furnace.py``, 2 shared cores at load 7-10): monkey 0.0571 → 0.0565, intersecting 0.0050 → 0.0051, resting
0.0058 → 0.0061 (max 0.9998), plate 0.0001, scan 0.0153 → 0.0154 (max 1.054 → 1.002, points
above 1.005 0.37% → 0), scan_normals 0.0290 → 0.0298 (max 1.062 → 0.999, 0.15% → 0),
room_scan 0.0004. No class reads above 1.005 any more; the scans fail on their RMS only.

Where the failures were left before that (the intersecting and resting notes are fixed by it):

* monkey: with the first-hit rows, the 147 vertices Cycles reads below 0.3 (mean 0.016) read
  0.064 and hold 21% of the squared error; the 84 that Cycles reads 0.3-0.7 read 0.733
  against 0.606 (32%), the rest 0.957 against 0.944 (47%). The pockets behind the eyes are
  not sealed: a slit between each eye's rim and its socket lets a few of the hemisphere
  rays in, which Cycles sees as 1e-5 of what the pocket absorbs. Before the first-hit rows
  those 147 vertices read 0.946 and held 78% of the squared error:
  the transport couples the sealed surfels to lit ones (docs/results.md, "Where Suzanne's
  leak comes from": segments behind a surfel's own face, now blocked, and the FMM's sampled
  classes), and at albedo 0.999 a leak ε reads ε/(ε + 0.001) (docs/stability.md). Suzanne reads
  0.94-0.98 against Cycles' 0.826, and 0.36% of the points over 1.005 (the
  gather's exact part casts the sky afresh at its lattice points beside the surfels' own
  share; the bunny scan has 0.35% over, to 1.099). Much of the gap is Cycles': it drops the directions a smooth normal's hemisphere
  has below a face, so its flat-shaded Suzanne reads 0.926 (``--cases monkey_flat``).
* intersecting: 19 of the 361 sealed vertices carry 99.5% of the squared error: 13 of box A's
  bottom vertices inside box B's footprint, where both bottoms lie on the floor, read 0.999
  (receivers, not surfels: the corners of faces that pass into the other box).
* resting: the sphere's contact: its pole and the floor vertex under it read 0 (Cycles 0.86).
* scan, scan_normals: most of the squared error lay within 2 cm of the floor, the bunny's
  flat base, which read dark (Cycles 0.92-0.94): rows the near field finds in contact with
  the floor could not reach their share. With the fill the scan reads 1.5% and 0.37% of its
  points above 1.005 (the gather's exact part, as on Suzanne); with the scan's normals 5.3%,
  still worse than without them (the issue asks that given normals do at least as well).
* With the normals of the hole-filled mesh (211 rim normals tilted 1-48°, ``furnace.py
  --cases scan_fill_normals``) the solve stopped after 4 iterations, not positive definite
  (measured with conservation off).

With the near field's plates rule (a scan's surfel and another object's facing it across a
thin gap: form factors averaged over the receiver's disc, no centre-to-centre visibility test;
``core/src/transport/near_field.hpp``), 2026-12-07, cached references: scan_normals 2.98% →
0.96% (max 1.0000; 1.11% against this test's 16-sample bakes, bound 1.59%: it passes), scan
1.54% → 1.57%, the others unchanged. The gap's base and floor surfels had coupled to each
other alone and read 0.09-0.13.

With a visibility fraction per point for a scan's far PARTIAL leaf pairs (``traversal.hpp``,
``TraversalOptions::scan``: one fraction per leaf pair had lent a floor leaf's view of the
bunny's lit inside, through a hole in its base, to every floor surfel of the leaf: 0.31 of
coupling where the exact sums give 0.02), 2026-12-07: scan 1.55% → 1.36% against the cached
128-sample references (max 1.0023 → 1.0015), 1.46% against this test's 16-sample bakes
(bound 1.59%: it passes); scan_normals 0.95%, room_scan 0.04%, the mesh classes unchanged
(no scan: the same lists).

Each test prints what it measured (``pytest -s``).
"""

import pytest

from illumap_bpy_testing import requires_core

from bench.reference import furnace

pytestmark = [requires_core, pytest.mark.slow]   # against Cycles bakes or renders

#: Relative RMS Illumap may differ from the reference by, over and above the reference's noise.
RMS = 0.01
#: No point may read above this (the sky's radiance is 1).
ABOVE = furnace.ABOVE
#: Samples per reference bake (two bakes): their noise is measured in each run and added to
#: the bound. The bunny costs ~0.7 s a sample (the gap under its base takes hundreds of
#: bounces); Suzanne's smooth normals make its bakes noisy but cheap.
SAMPLES = {"monkey": 128, "intersecting": 32, "resting": 64, "plate": 16, "scan": 16,
           "scan_normals": 16, "room_scan": 64}

#: Baked references by name (``scan`` and ``scan_normals`` bake the same meshes):
#: (values at the scored vertices, noise, bake seconds).
_REFERENCES: dict = {}


def built_with_reference(name):
    """Case ``name`` built in a fresh file, and its reference (baked once per session)."""
    case = furnace.build(name)
    key = case.reference or case.name
    if key not in _REFERENCES:
        ref = furnace.bake_reference(case, SAMPLES[name])
        _REFERENCES[key] = furnace.reference_values(case, ref) + (ref["seconds"],)
        case = furnace.build(name)           # a fresh file for Illumap
    return case, _REFERENCES[key]


#: Classes that fail today, each for the reason measured above (issue "Light is conserved").
#: Strict: a case that starts to pass fails here until its entry is removed.
KNOWN_FAILURES = {
    "monkey": "2.29% against the 512-sample cached bakes (2.66% before enclosed back surfels "
              "kept their solved values in the gather and the gather's field lookup stopped "
              "taking surfels behind a triangle): the 0.70-0.80 band and the face 5-20 cm above "
              "the floor hold most of the squared error (lit rays that meet an eye beside its "
              "socket's rim take enclosed surfels under it; 1.90% with the front field's lifted "
              "segments, which darken the lamps bench's awning); narrow creases (lips) gather "
              "from surfels the surfel spacing cannot resolve",
}


@pytest.mark.parametrize("name", [
    pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=KNOWN_FAILURES[n]))
    if n in KNOWN_FAILURES else n for n in furnace.CLASSES])
def test_white_furnace(name, registered_addon):
    case, (ref, noise, bake_seconds) = built_with_reference(name)
    values, result, seconds = furnace.run_illumap(case)
    row = furnace.score(case, values, ref, result)
    bound = RMS + noise
    print(f"\n{name}: rel. RMS {row['relative_rms']:.4f} (bound {bound:.4f}, reference noise "
          f"{noise:.5f} at 2 x {SAMPLES[name]} samples), mean ratio {row['mean_ratio']:.4f}, "
          f"max {row['max']:.4f}, above {ABOVE}: {row['above']:.2%}, converged "
          f"{row['converged']}, Illumap {seconds:.1f} s, Cycles {sum(bake_seconds):.1f} s")
    for obj, o in row["objects"].items():
        print(f"    {obj:10s} rel. RMS {o['relative_rms']:.4f} mean {o['mean']:.4f} (Cycles "
              f"{o['mean_reference']:.4f}) max {o['max']:.4f}; worst {o['worst']:.3f} against "
              f"{o['worst_reference']:.3f} at {o['worst_at']}")
    failures = []
    if not result.converged:
        failures.append("the solve did not converge")
    if row["not_positive_definite"]:
        failures.append("the solve warned 'not positive definite'")
    if row["above"] > 0:
        failures.append(f"{row['above']:.2%} of the points read above {ABOVE} "
                        f"(max {row['max']:.4f})")
    if not row["relative_rms"] <= bound:
        failures.append(f"relative RMS {row['relative_rms']:.4f} > {bound:.4f} (0.01 + reference "
                        f"noise {noise:.5f}); mean ratio {row['mean_ratio']:.4f}")
    assert not failures, f"{name}: " + "; ".join(failures)
