"""Cold dry solves of every time step of a paper gear position, with and without the early
updates of the yielded set (``dry.EARLY_UPDATE_ITERATIONS``; docs/performance.md §11, "Early
updates of the yielded set"): iterations, pressure error against a tight reference, and how
many solves take more iterations with them than without.

    .venv/bin/python benchmarks/bench_early_updates.py --n 64 --position 3 --phi 0.25 0.5 0.75 1

Each step's rough gap (``PositionCycle.rough_gap``: both flanks slid into place) is solved
cold at the solid-load fractions ``--phi`` of the step's mean pressure, as the mixed level's
φ scan does, to ``--tol``; the reference is the solve at ``--ref-tol``. One core.
Iterations are deterministic; the times are not, and are not printed.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np

from micropit_hpc.cycle import PositionCycle
from micropit_hpc.lubrication import dry
from micropit_hpc.plan import make_plan
from micropit_hpc.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]


def step_gaps(n: int, position: int):
    """(cycle, [(step, gap0, mean pressure)]) of the paper gear's ``position`` on n × n."""
    base = load_scene(str(ROOT / "scenes" / "paper_gear_z23.toml"))
    scene = replace(base, window=replace(base.window, nx=n, ny=None))
    plan = make_plan(scene, positions=[position], life=False)
    cycle = PositionCycle(plan.study, position, window=plan.window)
    return cycle, [(j, cycle.rough_gap(j), cycle.mean_pressure(cycle.centre(cycle.time(j))))
                   for j in range(cycle.steps)]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--position", type=int, default=3)
    ap.add_argument("--phi", type=float, nargs="+", default=[0.25, 0.5, 0.75, 1.0])
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--ref-tol", type=float, default=1e-12)
    ap.add_argument("--early", type=int, default=dry.EARLY_UPDATE_ITERATIONS,
                    help="dry.EARLY_UPDATE_ITERATIONS of the 'with' column")
    a = ap.parse_args(argv)
    cycle, steps = step_gaps(a.n, a.position)
    hs = dry.ElasticHalfSpaces(cycle.grid, cycle.study.E_prime)
    default = dry.EARLY_UPDATE_ITERATIONS
    its = {0: [], a.early: []}
    errs = {0: [], a.early: []}
    try:
        for _, gap0, p_mean in steps:
            for phi in a.phi:
                P = phi * p_mean
                if P <= 0.0:
                    continue
                dry.EARLY_UPDATE_ITERATIONS = 0
                ref = dry.solve_dry_contact(gap0, hs, P, cycle.p_lim, tol=a.ref_tol,
                                            max_iter=200000).pressure
                for k in its:
                    dry.EARLY_UPDATE_ITERATIONS = k
                    sol = dry.solve_dry_contact(gap0, hs, P, cycle.p_lim, tol=a.tol,
                                                max_iter=200000)
                    its[k].append(sol.iterations)
                    errs[k].append(float(np.linalg.norm(sol.pressure - ref) / np.linalg.norm(ref)))
    finally:
        dry.EARLY_UPDATE_ITERATIONS = default
    print(f"paper gear position {a.position}, {a.n}², {len(steps)} steps × φ {a.phi}: "
          f"{len(its[0])} cold solves to tol {a.tol:g}\n")
    print("| early updates every | iterations, sum | median | max | pressure error, median | max |")
    print("|---|---|---|---|---|---|")
    for k in its:
        i, e = np.array(its[k]), np.array(errs[k])
        print(f"| {k or 'none'} | {i.sum()} | {np.median(i):.0f} | {i.max()} | "
              f"{np.median(e):.2e} | {e.max():.2e} |")
    longer = np.array(its[a.early]) > np.array(its[0])
    print(f"\nsolves longer with early updates than without: {int(longer.sum())}")


if __name__ == "__main__":
    main()
