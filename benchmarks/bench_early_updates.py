"""Cold dry solves of every time step of a paper gear position, with and without the early
updates of the yielded set (``dry.EARLY_UPDATE_ITERATIONS``; docs/performance.md §11, "Early
updates of the yielded set"), or at several values of another of ``dry``'s constants
(``--vary``): iterations, pressure error against a tight reference, and how many solves take
more iterations than with the first value.

    .venv/bin/python benchmarks/bench_early_updates.py --n 64 --position 3 --phi 0.25 0.5 0.75 1
    .venv/bin/python benchmarks/bench_early_updates.py --n 256 --vary COLD_RUNGS --values 1 2

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


def position_cycle(n: int, position: int,
                   scene_path: str = str(ROOT / "scenes" / "paper_gear_z23.toml")):
    """The PositionCycle of ``position`` of the scene (default the paper gear) on its window
    sampled n × n."""
    base = load_scene(scene_path)
    scene = replace(base, window=replace(base.window, nx=n, ny=None))
    plan = make_plan(scene, positions=[position], life=False)
    return PositionCycle(plan.study, position, window=plan.window)


def step_gaps(n: int, position: int):
    """(cycle, [(step, gap0, mean pressure)]) of the paper gear's ``position`` on n × n."""
    cycle = position_cycle(n, position)
    return cycle, [(j, cycle.rough_gap(j), cycle.mean_pressure(cycle.centre(cycle.time(j))))
                   for j in range(cycle.steps)]


def parse_value(text: str):
    """A module constant's value from the command line: int, float or True/False."""
    if text in ("True", "False"):
        return text == "True"
    try:
        return int(text)
    except ValueError:
        return float(text)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--position", type=int, default=3)
    ap.add_argument("--phi", type=float, nargs="+", default=[0.25, 0.5, 0.75, 1.0])
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--ref-tol", type=float, default=1e-12)
    ap.add_argument("--early", type=int, default=dry.EARLY_UPDATE_ITERATIONS,
                    help="dry.EARLY_UPDATE_ITERATIONS of the 'with' column")
    ap.add_argument("--vary", default="EARLY_UPDATE_ITERATIONS",
                    help="the dry.* constant the columns differ in (default: the early updates)")
    ap.add_argument("--values", nargs="+", default=None,
                    help="its value in each column (default for the early updates: 0 and "
                         "--early; int, float, True or False), the first the baseline")
    a = ap.parse_args(argv)
    if a.vary == "EARLY_UPDATE_ITERATIONS" and a.values is None:
        values = [0, a.early]
    elif a.values is None or len(a.values) < 2:
        ap.error("--vary needs two --values at least")
    else:
        values = [parse_value(v) for v in a.values]
    if not hasattr(dry, a.vary):
        ap.error(f"dry has no constant {a.vary}")
    cycle, steps = step_gaps(a.n, a.position)
    hs = dry.ElasticHalfSpaces(cycle.grid, cycle.study.E_prime)
    saved = {k: getattr(dry, k) for k in ("EARLY_UPDATE_ITERATIONS", a.vary)}
    its = {v: [] for v in values}
    errs = {v: [] for v in values}
    try:
        for _, gap0, p_mean in steps:
            for phi in a.phi:
                P = phi * p_mean
                if P <= 0.0:
                    continue
                dry.EARLY_UPDATE_ITERATIONS = 0
                ref = dry.solve_dry_contact(gap0, hs, P, cycle.p_lim, tol=a.ref_tol,
                                            max_iter=200000).pressure
                dry.EARLY_UPDATE_ITERATIONS = saved["EARLY_UPDATE_ITERATIONS"]
                for v in values:
                    setattr(dry, a.vary, v)
                    sol = dry.solve_dry_contact(gap0, hs, P, cycle.p_lim, tol=a.tol,
                                                max_iter=200000)
                    its[v].append(sol.iterations)
                    errs[v].append(float(np.linalg.norm(sol.pressure - ref) / np.linalg.norm(ref)))
                setattr(dry, a.vary, saved[a.vary])
    finally:
        for k, v in saved.items():
            setattr(dry, k, v)
    print(f"paper gear position {a.position}, {a.n}², {len(steps)} steps × φ {a.phi}: "
          f"{len(its[values[0]])} cold solves to tol {a.tol:g}\n")
    print(f"| dry.{a.vary} | iterations, sum | median | max | pressure error, median | max |")
    print("|---|---|---|---|---|---|")
    for v in values:
        i, e = np.array(its[v]), np.array(errs[v])
        print(f"| {v} | {i.sum()} | {np.median(i):.0f} | {i.max()} | "
              f"{np.median(e):.2e} | {e.max():.2e} |")
    for v in values[1:]:
        longer = np.array(its[v]) > np.array(its[values[0]])
        print(f"\nsolves longer with {a.vary} = {v} than with {values[0]}: {int(longer.sum())}")


if __name__ == "__main__":
    main()
