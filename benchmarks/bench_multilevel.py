"""Cold dry contact solves across grid sizes: iterations, time and pressure error, before and
after the coarse-to-fine start and the size-scaled stopping rule (docs/performance.md,
"Contact iterations that do not grow with the grid").

    .venv/bin/python benchmarks/bench_multilevel.py --surface random --sizes 256 512 1024
    .venv/bin/python benchmarks/bench_multilevel.py --surface gear --sizes 256 512 1024
    .venv/bin/python benchmarks/bench_multilevel.py --surface random --tols 1e-6 1e-8 1e-10

Surfaces:

* ``random``: the Gaussian transverse-lay surface of ``bench_contact.py`` (β_x 30 µm, β_y
  300 µm, R_q 1 µm, 0.4 mm window, seed 1; the heights of each size are their own draw),
  elastic (no cap, as Tamaas's solver), mean pressure ``--pressure`` (2.75 GPa: 20 % contact
  at 256²).
* ``gear``: the paper gear at position 3 (``scenes/paper_gear_z23.toml`` with window.n = n,
  R_q 2.9 µm per flank), the middle time step's rough gap (both flanks, slid into place), its
  mean pressure and its cap p_lim: the dry solve that the mixed level does at solid-load
  fraction φ = 1, elastic–perfectly plastic.

For each size: a tight reference (ε ≤ ``--ref-tol`` on every grid, the new solver; a
reference whose residual stalls above it fails within 4000 iterations and the next looser of
3×, 10× is taken), then for each tolerance of ``--tols`` the cold solve "before" (:data:`BEFORE`:
the solver as it was) and "after" (the defaults), each timed as the median of ``--repeat``
solves, with its iterations (all levels; the finest grid's in brackets) and the relative L2
pressure error ‖p − p_ref‖/‖p_ref‖, the fine-equivalent iterations (each coarse level's
iterations times its share of the fine grid's points, added to the fine grid's: the solve's
cost in fine iterations) and each coarse level's iterations. One core. Prints a markdown table
with date and commit. ``--coarse-tol`` and ``--coarsest`` set ``dry.COARSE_TOL`` and
``dry.COARSEST`` for "after" (the variants of the coarse-to-fine start compared in
docs/performance.md §11), ``--early-update-iterations`` ``dry.EARLY_UPDATE_ITERATIONS`` (0:
the yielded set's search without early updates), ``--no-precondition`` ``dry.PRECONDITION =
False`` (the plain CG).
Run "before" with ``MICROPIT_FFTW_PLANNER=estimate`` and ``--only before`` for the plans as
they were, "after" with ``--only after`` once ``python -m micropit_hpc.spectral plan …`` has
measured this machine's plans. Timings, not tests.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")    # one core: before numpy is imported

import argparse  # noqa: E402
import datetime  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from micropit_hpc import source_commit  # noqa: E402
from micropit_hpc.lubrication import dry  # noqa: E402
from micropit_hpc.lubrication.dry import ElasticHalfSpaces, solve_dry_contact  # noqa: E402
from micropit_hpc.spectral import Grid  # noqa: E402

E_PRIME = 210e9 / (1 - 0.3**2)
MAX_ITER = 200000


def random_problem(n: int, pressure: float):
    """(gap0, half-spaces, mean pressure, p_lim) of the random surface on n × n."""
    from micropit_hpc.surfaces import gaussian_surface

    g = Grid(n, n, 4e-4, 4e-4)
    z = gaussian_surface(g, 1e-6, 30e-6, 300e-6, seed=1).heights
    return z.max() - z, ElasticHalfSpaces(g, E_PRIME), pressure, np.inf


def gear_problem(n: int, position: int = 3):
    """(gap0, half-spaces, mean pressure, p_lim) of the paper gear's middle step on n × n."""
    from bench_early_updates import position_cycle

    cycle = position_cycle(n, position)
    middle = (cycle.steps + 1) // 2 - 1
    gap0 = cycle.rough_gap(middle)
    p_mean = cycle.mean_pressure(cycle.centre(cycle.time(middle)))
    return gap0, ElasticHalfSpaces(cycle.grid, cycle.study.E_prime), p_mean, cycle.p_lim


#: The module switches that restore the solver as it was before issue 31: ε ≤ tol on every
#: grid, Polonsky & Keer's restart whenever points enter, no coarse-to-fine start, no
#: preconditioner.
BEFORE = {"TOLERANCE_POINTS": 0, "RESET_ON_ENTRY": True, "COARSEST": 0, "PRECONDITION": False}


#: (points per side, iterations) of each coarse level of the last :func:`solve`, coarsest first
LEVELS: list[tuple[int, int]] = []


def _logged(gap0, hs, *args, **kwargs):
    """dry.solve_dry_contact, recording the coarse levels' solves (those of
    ``dry._coarse_start``, called with ``coarsest=0``) in :data:`LEVELS`."""
    sol = solve_dry_contact(gap0, hs, *args, **kwargs)
    if kwargs.get("coarsest") == 0:
        LEVELS.append((hs.grid.nx, sol.iterations))
    return sol


def solve(problem, tol, before: bool):
    """One cold solve, the old way (``before``) or the new one."""
    gap0, hs, P, p_lim = problem
    saved = {k: getattr(dry, k) for k in BEFORE}
    saved["solve_dry_contact"] = dry.solve_dry_contact
    dry.solve_dry_contact = _logged
    LEVELS.clear()
    if before:
        for k, v in BEFORE.items():
            setattr(dry, k, v)
    try:
        return solve_dry_contact(gap0, hs, P, p_lim, tol=tol, max_iter=MAX_ITER)
    finally:
        for k, v in saved.items():
            setattr(dry, k, v)


def fine_equivalent(sol, n: int) -> float:
    """The solve's iterations weighted by their cost: the fine grid's, plus each coarse
    level's times (its points / the fine grid's), from :data:`LEVELS`."""
    return (sol.iterations - sol.coarse_iterations
            + sum(it * (m / n) ** 2 for m, it in LEVELS))


def reference(problem, tol):
    """The tight reference pressure: ε ≤ tol on every grid (no size scaling), or 3×, 10×, 30×
    looser where the residual stalls above tol at round-off (4000 iterations at most)."""
    from micropit_hpc.lubrication.dry import ContactError

    saved = dry.TOLERANCE_POINTS
    dry.TOLERANCE_POINTS = 0
    try:
        for factor in (1, 3, 10, 30):
            try:
                return solve_dry_contact(*problem[:3], problem[3], tol=tol * factor,
                                         max_iter=4000).pressure
            except ContactError:
                continue
        raise ContactError(f"no reference down to {30 * tol:.0e}")
    finally:
        dry.TOLERANCE_POINTS = saved


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--surface", choices=("random", "gear"), default="random")
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 512, 1024])
    ap.add_argument("--tols", type=float, nargs="+", default=[1e-8])
    ap.add_argument("--ref-tol", type=float, default=1e-13)
    ap.add_argument("--pressure", type=float, default=2.75e9)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", choices=("before", "after"), default=None)
    ap.add_argument("--unscaled", action="store_true",
                    help="'after' stops at ε ≤ tol on every grid (dry.TOLERANCE_POINTS = 0): "
                         "the error per unit residual, from which the rule's exponent comes")
    ap.add_argument("--coarse-tol", type=float, default=None,
                    help="'after' with this dry.COARSE_TOL (the coarse levels' tolerance)")
    ap.add_argument("--coarsest", type=int, default=None,
                    help="'after' with this dry.COARSEST (points per side of the coarsest level)")
    ap.add_argument("--early-update-iterations", type=int, default=None,
                    help="'after' with this dry.EARLY_UPDATE_ITERATIONS (0: no early updates "
                         "of the yielded set, the search as before commit 67a2396)")
    ap.add_argument("--cold-rungs", type=int, default=None,
                    help="'after' with this dry.COLD_RUNGS (the inexact tolerances of a "
                         "solve started from a coarser grid, before tol)")
    ap.add_argument("--no-early-every-rung", action="store_true",
                    help="'after' with dry.EARLY_EVERY_RUNG = False: early updates in the "
                         "first rung only")
    ap.add_argument("--no-precondition", action="store_true",
                    help="'after' with dry.PRECONDITION = False: the plain CG throughout (the "
                         "solver before the FFT preconditioner)")
    args = ap.parse_args()
    if args.no_precondition:
        dry.PRECONDITION = False
    if args.cold_rungs is not None:
        dry.COLD_RUNGS = args.cold_rungs
    if args.no_early_every_rung:
        dry.EARLY_EVERY_RUNG = False
    if args.unscaled:
        dry.TOLERANCE_POINTS = 0
    if args.coarse_tol is not None:
        dry.COARSE_TOL = args.coarse_tol
    if args.coarsest is not None:
        dry.COARSEST = args.coarsest
    if args.early_update_iterations is not None:
        dry.EARLY_UPDATE_ITERATIONS = args.early_update_iterations
    print(f"cold dry contact solves, {args.surface} surface, {datetime.date.today()}, commit "
          f"{source_commit()}, one core, median of {args.repeat}\n")
    print(f"dry.COARSEST = {dry.COARSEST}, dry.COARSE_TOL = {dry.COARSE_TOL}, "
          f"dry.EARLY_UPDATE_ITERATIONS = {dry.EARLY_UPDATE_ITERATIONS}, dry.COLD_RUNGS = "
          f"{dry.COLD_RUNGS}, dry.EARLY_EVERY_RUNG = {dry.EARLY_EVERY_RUNG}, dry.PRECONDITION = "
          f"{dry.PRECONDITION} ('after')\n")
    print("| grid | solver | tol | iterations (fine) | fine-equivalent | coarse levels | "
          "time [s] | ms per fine it. | pressure error | contact area | plastic |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for n in args.sizes:
        problem = (random_problem(n, args.pressure) if args.surface == "random"
                   else gear_problem(n))
        ref = reference(problem, args.ref_tol)
        norm = float(np.linalg.norm(ref))
        for tol in args.tols:
            for before in (True, False):
                name = "before" if before else "after"
                if args.only and args.only != name:
                    continue
                times = []
                for _ in range(args.repeat):
                    t0 = time.perf_counter()
                    sol = solve(problem, tol, before)
                    times.append(time.perf_counter() - t0)
                t = statistics.median(times)
                fine = sol.iterations - sol.coarse_iterations
                err = float(np.linalg.norm(sol.pressure - ref)) / norm
                plastic = float(np.mean(sol.pressure >= problem[3]))
                levels = " ".join(f"{m}²:{it}" for m, it in LEVELS) or "none"
                print(f"| {n}² | {name} | {tol:.0e} | {sol.iterations} ({fine}) | "
                      f"{fine_equivalent(sol, n):.1f} | {levels} | {t:.3f} | "
                      f"{1e3 * t / max(fine, 1):.2f} | {err:.2e} | "
                      f"{100 * sol.area_fraction:.1f} % | {100 * plastic:.1f} % |", flush=True)


if __name__ == "__main__":
    main()
