"""The φ scan's trials to a loose tolerance (docs/performance.md §11, "The φ scan's trials to
a loose tolerance"): how far the flow balance of a trial solved to ``mixed.SCAN_TOLERANCE``
lies from the same trial solved to the scene's tolerance from the same start, and what each
costs, over the load cycles of one block of one gear work item (the converged default, one
64² window on one 256² roughness realisation resampled, as ``bench_wear_convergence.py``).

For every loose trial solve the block makes, the trial is solved again at the scene's
tolerance from the same start (outside the run: the run goes on with the loose solve), and
the difference of the balance's mean open clearance is compared with SCAN_TOLERANCE ×
rms(gap), the error bound the margin ``mixed.SCAN_SIGN_MARGIN`` multiplies. One row per
tolerance; one rank.

    python benchmarks/bench_scan_tolerance.py --position 3 --cycles-M 0.02 \\
        --tolerances 1e-4 1e-3 1e-2
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from bench_wear_convergence import item_run, reference_surfaces
from table import emit, write_csv

from micropit_hpc.lubrication import mixed
from micropit_hpc.lubrication.dry import ContactError
from micropit_hpc.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
COLUMNS = ("scan_tol", "trials", "failed", "iters_tight", "iters_loose", "max_dgap_nm",
           "p99_dgap_nm", "max_dgap_over_tol_rms", "wall_s")


def measure(base, position, k_lub, n, cycles_M, reference, tolerance) -> tuple:
    """One block of ``cycles_M`` with the scan's trials at ``tolerance``: the row."""
    solve = mixed.solve_dry_contact
    rows, failed = [], [0]

    def watched(gap0, hs, load, **kw):
        if kw.get("tol") != tolerance:
            return solve(gap0, hs, load, **kw)
        try:
            loose = solve(gap0, hs, load, **kw)
        except ContactError:
            failed[0] += 1
            raise
        tight = solve(gap0, hs, load, **{**kw, "tol": base.lubrication.tol,
                                         "max_iter": base.lubrication.max_iter})
        rms = float(np.sqrt(((gap0 - gap0.mean()) ** 2).mean()))
        d = abs(np.maximum(loose.gap, 0).mean() - np.maximum(tight.gap, 0).mean())
        rows.append((tight.iterations, loose.iterations, d, d / (tolerance * rms)))
        return loose

    mixed.SCAN_TOLERANCE = tolerance
    mixed.solve_dry_contact = watched
    try:
        run = item_run(base, position, k_lub, n, max(cycles_M, base.life.block / 1e6), reference)
        t0 = time.perf_counter()
        run.run_block(cycles_M * 1e6)
        wall = time.perf_counter() - t0
    finally:
        mixed.solve_dry_contact = solve
    a = np.array(rows).reshape(-1, 4)
    return (tolerance, len(a), failed[0], float(a[:, 0].mean()), float(a[:, 1].mean()),
            float(a[:, 2].max() * 1e9), float(np.quantile(a[:, 2], 0.99) * 1e9),
            float(a[:, 3].max()), wall)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "paper_gear_z23.toml"))
    ap.add_argument("--position", type=int, default=3)
    ap.add_argument("--k-lub", type=float, default=5e-11)
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--cycles-M", type=float, default=0.02)
    ap.add_argument("--ref", type=int, default=256, help="grid of the surface realisation")
    ap.add_argument("--tolerances", type=float, nargs="+", default=[1e-4, 1e-3, 1e-2])
    ap.add_argument("--csv", default=None)
    a = ap.parse_args(argv)
    base = load_scene(a.scene)
    reference = reference_surfaces(base, a.ref)
    print(",".join(COLUMNS), flush=True)
    rows = []
    for t in a.tolerances:
        rows.append(measure(base, a.position, a.k_lub, a.n, a.cycles_M, reference, t))
        emit(rows[-1])
    write_csv(a.csv, COLUMNS, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
