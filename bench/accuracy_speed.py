#!/usr/bin/env python3
"""Error against wall time for every method, on the three benchmark scenes (bench/scenes.py).

For each scene a converged reference is solved once: the direct O(N^2) operator at high density
(``--ref-n`` surfels), CG to a relative residual of 1e-9, with the best visibility mode the
build has (``exact`` when available, else ``none``). Every setting is then run at several
densities; its error is the relative RMS per surfel (emitters excluded) against the reference
evaluated at its own surfels by one exact gather (bench/scenes.py: ``reference_at``), and its
time is the wall time of ``illumap.solve`` (operator build + solve). The reference's own floor
(the gather evaluated at the reference's surfels) is recorded as ``reference_floor``: errors
below it are not resolved.

Curves (one per method; points along a curve are surfel densities):
  fmm p in {0,2,3,4,6,8} x visibility in {none, seed, exact} (modes the build lacks are listed
  under "unavailable" with the reason), direct, and Jacobi / CG / GMRES (FMM p=4).
  With --auto it also runs ``illumap.accuracy.choose_settings`` at targets 10%, 3%, 1%.

    .venv/bin/python bench/accuracy_speed.py --quick --out bench/results/accuracy_speed.json

Times are from this run on this machine; compare ratios, not absolute times.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import illumap  # noqa: E402
from illumap.operator import VISIBILITIES  # noqa: E402

import scenes as S  # noqa: E402

ORDERS = (0, 2, 3, 4, 6, 8)
VISIBILITY_MODES = ("none", "seed", "exact")
SOLVE_TOL = 1e-4

QUICK = dict(ref_n=12000, sizes=(500, 1000, 2000, 4000), orders=ORDERS)
FULL = dict(ref_n=24000, sizes=(500, 1000, 2000, 4000, 8000, 12000), orders=ORDERS)


def available_visibilities():
    """(available list, {mode: reason} for the rest)."""
    ok, missing = [], {}
    for mode in VISIBILITY_MODES:
        implemented = VISIBILITIES.get(mode, (False, False))[0]
        if implemented:
            ok.append(mode)
        else:
            missing[mode] = "not available in this build (illumap.operator.VISIBILITIES)"
    return ok, missing


def settings(orders, visibilities):
    """Every hand-picked setting: (family, label, solve keywords)."""
    out = [("direct", "direct", dict(method="direct", solver="auto", tol=SOLVE_TOL))]
    for vis in visibilities:
        for p in orders:
            kw = dict(method="fmm", order=p, theta=0.5, solver="auto", tol=SOLVE_TOL)
            if vis != "none":
                kw["visibility"] = vis
            out.append((f"fmm/{vis}", f"FMM p={p} vis={vis}", kw))
    for solver in ("jacobi", "cg", "gmres"):
        out.append(("solver", f"{solver} (FMM p=4)",
                    dict(method="fmm", order=4, theta=0.5, solver=solver, tol=SOLVE_TOL)))
    return out


def timed_solve(surfels, kw):
    t = time.perf_counter()
    sol = illumap.solve(surfels, **kw)
    return sol, time.perf_counter() - t


def run_scene(name, cfg, visibilities, auto_targets, log, sweep=True):
    ref_vis = "exact" if "exact" in visibilities else "none"
    t = time.perf_counter()
    ref = S.build(name, cfg["ref_n"], seed=12345)
    ref_sol = S.reference_solution(ref, visibility=ref_vis)
    ref_time = time.perf_counter() - t
    floor = S.relative_rms(S.reference_at(ref, ref_sol.radiosity, ref), ref_sol.radiosity,
                           ref.emission)
    log(f"[{name}] reference N={ref.n} vis={ref_vis} {ref_time:.1f}s "
        f"iterations={ref_sol.iterations} floor={floor:.4f}")
    points = []
    for n in (cfg["sizes"] if sweep else ()):
        q = S.build(name, n)
        B_ref = S.reference_at(ref, ref_sol.radiosity, q)
        for family, label, kw in settings(cfg["orders"], visibilities):
            if kw["method"] == "direct" and q.n > 8000:
                continue
            sol, dt = timed_solve(q, kw)
            err = S.relative_rms(sol.radiosity, B_ref, q.emission)
            if dt < 0.5:   # best of 3 for short runs: the machine is shared
                for _ in range(2):
                    sol2, dt2 = timed_solve(q, kw)
                    dt = min(dt, dt2)
            points.append(dict(scene=name, family=family, label=label, n=q.n, time=dt,
                               error=err, iterations=sol.iterations, converged=sol.converged,
                               settings={k: v for k, v in kw.items()}))
            log(f"  {name} N={q.n:6d} {label:24s} {dt:8.3f}s err={err:.4f} it={sol.iterations}")
    for target in auto_targets:
        from illumap import accuracy
        kind = "point_cloud" if name == "bunny" else None
        probe = S.build(name, cfg["sizes"][0])
        summary = accuracy.scene_summary(probe, kind)
        summary["n"] = S.BUNNY_MAX if name == "bunny" else 10 ** 9   # what sampling allows
        chosen = accuracy.choose_settings(summary, target, kind=kind)
        kw = accuracy.solve_keywords(chosen)
        if chosen["n"] > ref.n / 1.2:
            log(f"  {name} auto target={target:g}: needs N={chosen['n']}, beyond what the "
                f"reference (N={ref.n}) resolves; not run")
            points.append(dict(scene=name, family="auto", label=f"auto {target:g}",
                               n=chosen["n"], time=None, error=None, target=target,
                               settings=kw, chosen=chosen, skipped="beyond the reference"))
            continue
        q = S.build(name, chosen["n"])
        B_ref = S.reference_at(ref, ref_sol.radiosity, q)
        chosen = accuracy.choose_settings(q, target, kind=kind)   # cost model at the real N
        kw = accuracy.solve_keywords(chosen)
        sol, dt = timed_solve(q, kw)
        if dt < 0.5:   # best of 3, as for the hand-picked settings
            dt = min([dt] + [timed_solve(q, kw)[1] for _ in range(2)])
        err = S.relative_rms(sol.radiosity, B_ref, q.emission)
        est = accuracy.estimate_error(sol, q, coarse=True)
        points.append(dict(scene=name, family="auto", label=f"auto {target:g}", n=q.n,
                           time=dt, error=err, iterations=sol.iterations, target=target,
                           converged=sol.converged, settings=kw, chosen=chosen, estimate=est))
        log(f"  {name} N={q.n:6d} auto target={target:<6g} {dt:8.3f}s err={err:.4f} "
            f"estimate={est['total']:.4f} {kw}")
    return dict(reference=dict(n=ref.n, visibility=ref_vis, time=ref_time,
                               iterations=ref_sol.iterations, floor=floor), points=points)


def calibrate(names, n, orders=ORDERS, thetas=(0.35, 0.5, 0.7), log=print):
    """The FMM error model of illumap.accuracy: for each scene at about ``n`` surfels, the
    relative RMS difference between the FMM solution (order p, opening angle theta) and the
    direct solution on the same surfels (both to a residual of 1e-9), and the FMM's apply time
    relative to the direct apply time."""
    rows = []
    for name in names:
        q = S.build(name, n)
        direct_op = illumap.TransportOperator(q, method="direct")
        ref = illumap.solve(q, operator=direct_op, tol=1e-9)
        x = ref.radiosity
        t = time.perf_counter()
        direct_op.apply(x)
        t_direct = time.perf_counter() - t
        for theta in thetas:
            for p in orders:
                t = time.perf_counter()
                op = illumap.TransportOperator(q, method="fmm", order=p, theta=theta)
                t_build = time.perf_counter() - t
                t = time.perf_counter()
                op.apply(x)
                t_apply = time.perf_counter() - t
                sol = illumap.solve(q, operator=op, tol=1e-9)
                err = S.relative_rms(sol.radiosity, ref.radiosity, q.emission)
                rows.append(dict(scene=name, n=q.n, order=p, theta=theta, error=err,
                                 t_build=t_build, t_apply=t_apply, t_direct_apply=t_direct))
                log(f"  calibrate {name} N={q.n} theta={theta} p={p}: err={err:.2e} "
                    f"apply={t_apply:.3f}s (direct {t_direct:.3f}s) build={t_build:.3f}s")
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true", help="small sizes (default)")
    mode.add_argument("--full", action="store_true", help="larger reference and sizes")
    ap.add_argument("--scenes", nargs="+", default=list(S.SCENES), choices=S.SCENES)
    ap.add_argument("--auto", action="store_true", help="also run the automatic mode")
    ap.add_argument("--auto-only", action="store_true",
                    help="run only the reference and the automatic mode, and replace the "
                         "automatic-mode points of an existing --out file (same mode)")
    ap.add_argument("--out", default="bench/results/accuracy_speed.json")
    ap.add_argument("--calibrate", type=int, metavar="N", default=0,
                    help="only measure the FMM error model at about N surfels per scene and "
                         "write it to --out (illumap.accuracy.CALIBRATION comes from this)")
    args = ap.parse_args(argv)
    if args.calibrate:
        rows = calibrate(args.scenes, args.calibrate)
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump(dict(calibration=rows, date=time.strftime("%Y-%m-%d %H:%M UTC",
                                                                   time.gmtime())), f, indent=1)
        print(f"wrote {args.out}")
        return
    cfg = dict(FULL if args.full else QUICK)
    visibilities, unavailable = available_visibilities()
    for mode, why in unavailable.items():
        print(f"visibility={mode!r}: skipped, {why}", flush=True)
    results = dict(mode="full" if args.full else "quick", config=cfg, solve_tol=SOLVE_TOL,
                   visibilities=visibilities, unavailable=unavailable,
                   machine=dict(platform=platform.platform(), cpus=os.cpu_count(),
                                threads=illumap._core.hardware_threads()),
                   date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), scenes={})
    t0 = time.perf_counter()
    for name in args.scenes:
        results["scenes"][name] = run_scene(name, cfg, visibilities,
                                            (0.1, 0.03, 0.01) if (args.auto or args.auto_only)
                                            else (), lambda s: print(s, flush=True),
                                            sweep=not args.auto_only)
    if args.auto_only:
        with open(args.out) as f:
            old = json.load(f)
        for name, new in results["scenes"].items():
            kept = [p for p in old["scenes"][name]["points"] if p["family"] != "auto"]
            old["scenes"][name]["points"] = kept + new["points"]
        old["auto_date"] = results["date"]
        results = old
    results["wall_time"] = time.perf_counter() - t0
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(results, f, indent=1)
    print(f"wrote {args.out} ({results['wall_time']:.0f}s)")


if __name__ == "__main__":
    main()
