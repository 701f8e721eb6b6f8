"""Solver benchmark: iterations and time against albedo ρ for Jacobi, CG and GMRES.

Two cases, each timed in this one run:
  * the closed box (grid sampling, 6·n² surfels, default n = 16 → 1536) with the exact direct
    operator and the disc near field: uniform emission 1, uniform ρ;
  * a larger randomly sampled closed box with the FMM operator (default N ≈ 12k, p = 4).

Jacobi at high ρ needs ~log(tol)/log(ρ·λ) sweeps; on the FMM case it is capped by
``--jacobi-cap`` and the remaining sweeps are *estimated* from the last 50 residuals (marked
"est." in the table; everything else is measured).

Usage:
    python bench/micro/bench_solvers.py [--box-n 16] [--fmm-n 12000] [--order 4] [--tol 1e-6]
                                        [--jacobi-cap 300] [--out results.json]
Prints a markdown table; --out also writes every measured number as JSON.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time

import numpy as np

import illumap
from illumap import scenes

RHOS = (0.5, 0.9, 0.99)
SOLVERS = ("jacobi", "cg", "gmres")


def estimate_remaining(residuals, tol, window=50):
    """Sweeps still needed from the geometric rate over the last `window` Jacobi residuals."""
    r = np.asarray(residuals)
    if len(r) <= window or r[-1] <= tol:
        return None
    rate = (r[-1] / r[-1 - window]) ** (1.0 / window)
    if not 0 < rate < 1:
        return math.inf
    return int(math.ceil(math.log(tol / r[-1]) / math.log(rate)))


def run_case(name, surfels, operator, build_seconds, tol, caps):
    rows = []
    for rho in RHOS:
        s = surfels.replace(albedo=np.full((surfels.n, 3), rho))
        for solver in SOLVERS:
            cap = caps.get(solver)
            t = time.perf_counter()
            sol = illumap.solve(s, operator=operator, solver=solver, tol=tol,
                                max_iterations=cap)
            seconds = time.perf_counter() - t
            extra = None
            if solver == "jacobi" and not sol.converged and cap is not None \
                    and sol.iterations >= cap and "warning" in sol.stats \
                    and "diverged" not in sol.stats["warning"]:
                extra = estimate_remaining(sol.residuals, tol)
            B = sol.radiosity[:, 0]
            rows.append(dict(
                case=name, n=surfels.n, rho=rho, solver=solver, iterations=sol.iterations,
                applications=sol.stats["operator_applications"], seconds=seconds,
                seconds_per_application=seconds / max(1, sol.stats["operator_applications"]),
                converged=sol.converged, final_residual=sol.stats["final_residual"],
                estimated_total_iterations=(sol.iterations + extra) if extra is not None
                else None,
                furnace_mean=float(np.mean(B) * (1 - rho)), warning=sol.stats.get("warning"),
                build_seconds=build_seconds,
            ))
            print(f"  {name} ρ={rho} {solver}: {sol.iterations} it, {seconds:.2f} s, "
                  f"residual {sol.stats['final_residual']:.2e}", file=sys.stderr, flush=True)
    return rows


def table(rows):
    lines = ["| case | N | ρ | solver | iterations | operator applies | time (s) | "
             "final rel. residual | converged | mean B·(1−ρ) |",
             "|---|---:|---:|---|---:|---:|---:|---:|---|---:|"]
    for r in rows:
        it = str(r["iterations"])
        if r["estimated_total_iterations"] is not None:
            it += f" (est. {r['estimated_total_iterations']} to converge)"
        lines.append(
            f"| {r['case']} | {r['n']} | {r['rho']} | {r['solver']} | {it} | "
            f"{r['applications']} | {r['seconds']:.2f} | {r['final_residual']:.1e} | "
            f"{'yes' if r['converged'] else 'no'} | {r['furnace_mean']:.3f} |")
    return "\n".join(lines)


def ratios(rows):
    out = []
    by = {(r["case"], r["rho"], r["solver"]): r for r in rows}
    for case in dict.fromkeys(r["case"] for r in rows):
        for rho in RHOS:
            j, c = by.get((case, rho, "jacobi")), by.get((case, rho, "cg"))
            if j and c and c["iterations"]:
                est = j["estimated_total_iterations"]
                if est is not None and math.isfinite(est):
                    seconds = j["seconds"] * est / max(1, j["iterations"])
                    out.append(f"- {case}, ρ = {rho}: Jacobi/CG iterations ≈ "
                               f"{est / c['iterations']:.0f}×, time ≈ "
                               f"{seconds / c['seconds']:.0f}× (Jacobi stopped at "
                               f"{j['iterations']} sweeps; the rest extrapolated from its "
                               "measured rate)")
                else:
                    out.append(f"- {case}, ρ = {rho}: Jacobi/CG iterations = "
                               f"{j['iterations'] / c['iterations']:.0f}×, time = "
                               f"{j['seconds'] / c['seconds']:.0f}×")
    return "\n".join(out)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--box-n", type=int, default=16, help="grid per face of the direct box")
    parser.add_argument("--fmm-n", type=int, default=12000,
                        help="surfels of the FMM case (0 skips it)")
    parser.add_argument("--order", type=int, default=illumap.DEFAULT_ORDER)
    parser.add_argument("--theta", type=float, default=illumap.DEFAULT_THETA)
    parser.add_argument("--tol", type=float, default=1e-6)
    parser.add_argument("--jacobi-cap", type=int, default=300,
                        help="max Jacobi sweeps on the FMM case")
    parser.add_argument("--out", help="write the results as JSON")
    args = parser.parse_args(argv)

    rows = []
    box = scenes.closed_box(args.box_n, albedo=0.5, emission=1.0)
    t = time.perf_counter()
    direct = illumap.TransportOperator(box, method="direct")
    build = time.perf_counter() - t
    rows += run_case("box, direct", box, direct, build, args.tol, {})

    if args.fmm_n > 0:
        per_face = max(1, int(round(math.sqrt(args.fmm_n / 6))))
        big = scenes.closed_box(per_face, sampling="random", albedo=0.5, emission=1.0, seed=1)
        t = time.perf_counter()
        fmm = illumap.TransportOperator(big, method="fmm", order=args.order, theta=args.theta)
        build = time.perf_counter() - t
        rows += run_case(f"random box, fmm p={args.order}", big, fmm, build, args.tol,
                         {"jacobi": args.jacobi_cap})

    print(f"\nSolver benchmark (tol {args.tol:g}, disc near field, uniform E = 1 and ρ; "
          f"{platform.node()}, {illumap._core.hardware_threads()} threads)\n")
    print(table(rows))
    print()
    print(ratios(rows))
    if args.out:
        with open(args.out, "w") as f:
            json.dump({"tol": args.tol, "order": args.order, "theta": args.theta,
                       "rows": rows}, f, indent=1)
    return rows


if __name__ == "__main__":
    main()
