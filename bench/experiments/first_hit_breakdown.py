#!/usr/bin/env python3
"""Where a white-furnace case's squared error lies, vertex by vertex (a diagnostic).

Runs ``bench/reference/furnace.py``'s case against its cached Cycles reference and splits the
summed squared error (the numerator of the relative RMS) by object, by the reference's value
(sealed 0, contact 0.5/0.75 means of a POINT bake, lit 1), by height above the floor, and
lists the worst vertices with their position, Illumap's value and the reference's; the arrays
go to out/breakdown/<case>.npz.

    .venv/bin/python bench/experiments/first_hit_breakdown.py intersecting resting monkey
"""

from __future__ import annotations

import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "reference"))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, os.path.dirname(os.path.dirname(HERE)))

from reference import furnace, bake  # noqa: E402


def breakdown(name: str, samples: int = furnace.DEFAULT_SAMPLES, worst: int = 25,
              save: str | None = None) -> dict:
    """Print the case's error breakdown; returns the arrays (got, ref, positions, owner)."""
    case = furnace.build(name)
    if case.max_samples:
        samples = min(samples, case.max_samples)
    ref = furnace.load_reference(case, samples, furnace.illumap_albedo())
    if ref is None:
        raise SystemExit(f"{name}: no cached reference at {samples} samples")
    ref_values, noise = furnace.reference_values(case, ref)
    case = furnace.build(name)
    values, result, seconds = furnace.run_illumap(case)
    got, owner = furnace._stack(case, values)
    pos = np.concatenate([bake.vertex_positions(o)[bake.baked_vertices(o)]
                          for o in case.scene.scored])
    err2 = (got - ref_values) ** 2
    total = err2.sum()
    denom = (ref_values ** 2).sum()
    print(f"\n== {name}: rel. RMS {np.sqrt(total / denom):.4f} ({len(got)} points, "
          f"{seconds:.2f} s, noise {noise:.5f})")
    print("  by object:")
    for k, obj in enumerate(case.scene.scored):
        m = owner == k
        print(f"    {obj.name:12s} share {err2[m].sum() / total:6.1%}  "
              f"rms-contrib {np.sqrt(err2[m].sum() / denom):.4f}  points {m.sum()}")
    print("  by reference value:")
    for lo, hi in ((-1, 0.05), (0.05, 0.45), (0.45, 0.55), (0.55, 0.7), (0.7, 0.8),
                   (0.8, 0.95), (0.95, 2)):
        m = (ref_values >= lo) & (ref_values < hi)
        if m.any():
            print(f"    ref in [{max(lo, 0):.2f},{hi:.2f}) points {m.sum():6d} share "
                  f"{err2[m].sum() / total:6.1%} mean got {got[m].mean():.4f} ref "
                  f"{ref_values[m].mean():.4f}")
    print("  by height z:")
    for lo, hi in ((-1, 0.005), (0.005, 0.05), (0.05, 0.2), (0.2, 10)):
        m = (pos[:, 2] >= lo) & (pos[:, 2] < hi)
        if m.any():
            print(f"    z in [{lo:.3f},{hi:.3f}) points {m.sum():6d} share "
                  f"{err2[m].sum() / total:6.1%} mean signed {np.mean(got[m] - ref_values[m]):+.4f}")
    order = np.argsort(-err2)[:worst]
    print(f"  worst {worst}: object, position, got, ref")
    for i in order:
        print(f"    {case.scene.scored[owner[i]].name:10s} {np.round(pos[i], 3)} "
              f"{got[i]:.3f} {ref_values[i]:.3f}")
    out = dict(got=got, ref=ref_values, pos=pos, owner=owner)
    if save:
        np.savez(save, **out)
    return out


if __name__ == "__main__":
    furnace.reference_run.register_addon()
    folder = os.path.join(os.path.dirname(os.path.dirname(HERE)), "out", "breakdown")
    os.makedirs(folder, exist_ok=True)
    for case_name in sys.argv[1:] or ["intersecting", "resting", "monkey"]:
        breakdown(case_name, save=os.path.join(folder, f"{case_name}.npz"))
