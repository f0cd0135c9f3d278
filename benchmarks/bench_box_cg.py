"""The elastic–perfectly-plastic dry contact as one bound-constrained CG: iterations against the
solver's search of the yielded set (issue 31; docs/performance.md §11, "One CG for both
bounds").

    .venv/bin/python benchmarks/bench_box_cg.py --surface gear --sizes 256 512 1024

The solver (``lubrication/dry.py``) caps the pressure at p_lim by an outer search of the
yielded set: each update fixes the yielded points at p_lim and restarts an elastic
Polonsky–Keer CG on the others. Here the same problem — minimise the elastic energy with
0 ≤ p ≤ p_lim and Σ p = P N — is solved by one CG whose active set has both bounds, its
directions kept conjugate through every change of the set (as the bound-constrained CG of
Vollebregt, J. Optim. Theory Appl. 162 (2014) 931–953, does for contact without a cap):

* the free points are 0 < p < p_lim; the rigid approach α is the mean gap over them;
* the direction is the centred gap on the free points (plus β times the last one, Fletcher–
  Reeves as in the solver; steepest descent where it would not descend);
* the step is the exact line minimiser; points crossing a bound are truncated to it, points
  at 0 whose gap is below α enter at −τ(g − α), points at p_lim whose gap is above α leave at
  p_lim − τ(g − α) (Polonsky & Keer's entry rule, applied to the cap as well);
* the load is restored by a uniform shift of the points below the cap (bisection), where the
  solver rescales the contact's pressure;
* it stops at the solver's rule (ε ≤ ``dry.residual_threshold``) with no point at either
  bound violating its condition by more than the residual.

A plain serial NumPy transcription, written for the comparison only: the solver is not built
on it (no slabs, no compiled stages; the coarse-to-fine start of :func:`box_cg_levels` repeats
the solver's with dry's own restriction and prolongation). Each iteration takes the same
two convolutions as one of the solver's, plus the load's bisection. For each size: the
solver's cold solve as it is (iterations over all levels, the fine grid's in brackets, the
fine-equivalent count of bench_multilevel.py), the solver on one level (``coarsest=0``) and
the box CG, both from uniform pressure, and the box CG after the coarse-to-fine start
(:func:`box_cg_levels`), each with its relative L2 pressure error against
bench_multilevel's tight reference. Prints a markdown table; no timings. With ``--steps N``
instead: every time step of a gear position at N², cold and warm, iterations summed
(:func:`step_totals`).

    .venv/bin/python benchmarks/bench_box_cg.py --steps 64 --position 3
"""

from __future__ import annotations

import argparse
import datetime
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_multilevel import (
    LEVELS,
    MAX_ITER,
    fine_equivalent,
    gear_problem,
    random_problem,
    reference,
    solve,
)

from micropit_hpc import source_commit
from micropit_hpc.lubrication import dry


def shift_to_load(q: np.ndarray, movable: np.ndarray, target: float,
                  p_lim: float) -> np.ndarray | None:
    """q with its ``movable`` points replaced by clip(q + d, 0, p_lim), d (by bisection) such
    that the sum is ``target``; None where no shift reaches it."""
    qs = q[movable]
    fixed = float(q.sum() - qs.sum())
    top = p_lim if math.isfinite(p_lim) else float(qs.max(initial=0.0)) + target

    def excess(d: float) -> float:
        return float(np.clip(qs + d, 0.0, p_lim).sum()) + fixed - target

    lo, hi = -top, top
    if excess(lo) > 0.0 or excess(hi) < 0.0:
        return None
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if excess(mid) > 0.0:
            hi = mid
        else:
            lo = mid
    out = q.copy()
    out[movable] = np.clip(qs + 0.5 * (lo + hi), 0.0, p_lim)
    return out


def box_cg(gap0, hs, P: float, p_lim: float, tol: float, max_iter: int = 20000,
           p_init: np.ndarray | None = None):
    """The box-constrained CG of the module docstring from ``p_init`` (None: uniform
    pressure; else clipped to the bounds and shifted to the load); returns (pressure,
    iterations)."""
    N = gap0.size
    scale = float(gap0.std())
    thr = dry.residual_threshold(tol, hs.grid)
    p = np.full_like(gap0, P)
    if p_init is not None:
        q = np.clip(p_init, 0.0, p_lim)
        start = shift_to_load(q, (q > 0.0) & (q < p_lim), P * N, p_lim)
        p = start if start is not None else shift_to_load(q, q >= 0.0, P * N, p_lim)
    t = np.zeros_like(gap0)
    G_old, conjugate = 1.0, False
    for it in range(1, max_iter + 1):
        g = gap0 + hs.displacement(p)
        free = (p > 0.0) & (p < p_lim)
        n_free = np.count_nonzero(free)
        if n_free:
            alpha = float(g[free].mean())
        else:               # every point at a bound: between the capped and the open gaps
            capped, open_ = g[p >= p_lim], g[p <= 0.0]
            alpha = (0.5 * (capped.max() + open_.min()) if capped.size and open_.size
                     else capped.max() if capped.size else open_.min())
        g -= alpha
        G = float(np.sum(g[free] ** 2))
        error = math.sqrt(G / max(n_free, 1)) / scale
        wrong = (np.count_nonzero((p <= 0.0) & (g < -thr * scale))
                 + np.count_nonzero((p >= p_lim) & (g > thr * scale)))
        if error <= thr and not wrong:
            return p, it
        t = np.where(free, g + (G / G_old if conjugate else 0.0) * t, 0.0)
        gt = float(np.sum(g * t))
        if conjugate and gt <= 0.0:
            t = np.where(free, g, 0.0)
            gt = G
        G_old = G
        tau = 0.0
        if n_free and gt > 0.0:
            r = hs.displacement(t)
            curvature = float(np.sum((r - r[free].mean()) * t))
            if curvature > 0.0:
                tau = gt / curvature
        q = p - tau * t
        step = tau if tau > 0.0 else hs.grid.dx / hs.E_prime    # no free point: a cell's
        enter = (p <= 0.0) & (g < 0.0)
        leave = (p >= p_lim) & (g > 0.0)
        q[enter] = -step * g[enter]
        q[leave] = p_lim - step * g[leave]
        np.clip(q, 0.0, p_lim, out=q)
        movable = ((q > 0.0) & (q < p_lim)) | enter | leave | free
        shifted = shift_to_load(q, movable, P * N, p_lim)
        p = shifted if shifted is not None else shift_to_load(
            q, np.ones_like(movable), P * N, p_lim)
        conjugate = True
    raise RuntimeError(f"box CG: no convergence in {max_iter} iterations")


def box_cg_levels(gap0, hs, P: float, p_lim: float, tol: float, coarsest: int = 64,
                  coarse_tol: float = 1e-4):
    """:func:`box_cg` after the solver's coarse-to-fine start (``dry._coarse_start``'s
    scheme: the gap restricted by full weighting down to ≥ ``coarsest`` points per side, each
    level solved to max(tol, ``coarse_tol``) from the prolongated pressure of the level below,
    the coarsest from uniform pressure); returns (pressure, fine iterations, fine-equivalent
    iterations)."""
    levels = dry.coarse_levels(hs.grid, coarsest)
    gaps = [gap0]
    for _ in range(levels):
        gaps.append(dry.restrict(gaps[-1]))
    n = gap0.shape[0]
    p, equivalent = None, 0.0
    for level in range(levels, 0, -1):
        g = gaps[level]
        grid = dry.Grid(g.shape[0], g.shape[1], hs.grid.lx, hs.grid.ly)
        pc, it = box_cg(g, dry.ElasticHalfSpaces(grid, hs.E_prime), P, p_lim,
                        max(tol, coarse_tol), p_init=p)
        equivalent += it * (g.shape[0] / n) ** 2
        p = dry.prolong(pc)
    p, it = box_cg(gap0, hs, P, p_lim, tol, p_init=p)
    return p, it, equivalent + it


def step_totals(n: int, position: int, tol: float, moved_rms: float) -> dict:
    """Iterations summed over every time step of the paper gear's ``position`` at n² (the dry
    solve at each step's mean pressure): each cold, and each warm from the same step's
    answer after its gap moved by a smooth random field of RMS ``moved_rms`` [m] (a
    Gaussian surface of bench_contact's correlation lengths, one seed per step: what a warm
    start meets in a life, the surfaces worn a little between two evaluations), by the solver
    and by the box CG; with the largest relative L2 difference between the two answers."""
    from bench_early_updates import step_gaps

    from micropit_hpc.surfaces import gaussian_surface

    cycle, steps = step_gaps(n, position)
    hs = dry.ElasticHalfSpaces(cycle.grid, cycle.study.E_prime)
    out = {"steps": 0, "solver cold": 0, "box CG cold": 0, "solver warm": 0, "box CG warm": 0,
           "largest difference": 0.0}
    for j, gap0, P in steps:
        if P <= 0.0:
            continue
        moved = gap0 + gaussian_surface(cycle.grid, moved_rms, 30e-6, 300e-6, seed=j).heights
        cold = dry.solve_dry_contact(gap0, hs, P, cycle.p_lim, tol=tol, max_iter=MAX_ITER)
        p_box, it_box = box_cg(gap0, hs, P, cycle.p_lim, tol)
        warm = dry.solve_dry_contact(moved, hs, P, cycle.p_lim, tol=tol, max_iter=MAX_ITER,
                                     p_init=cold.pressure)
        p_warm, it_warm = box_cg(moved, hs, P, cycle.p_lim, tol, p_init=cold.pressure)
        out["steps"] += 1
        out["solver cold"] += cold.iterations
        out["box CG cold"] += it_box
        out["solver warm"] += warm.iterations
        out["box CG warm"] += it_warm
        for a, b in ((cold.pressure, p_box), (warm.pressure, p_warm)):
            out["largest difference"] = max(out["largest difference"],
                                            float(np.linalg.norm(a - b) / np.linalg.norm(a)))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--surface", choices=("random", "gear"), default="gear")
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 512, 1024])
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--ref-tol", type=float, default=1e-12)
    ap.add_argument("--pressure", type=float, default=2.75e9, help="random surface [Pa]")
    ap.add_argument("--steps", type=int, default=None, metavar="N",
                    help="instead: every step of a gear position at N², cold and warm")
    ap.add_argument("--position", type=int, default=3)
    ap.add_argument("--moved", type=float, default=20e-9,
                    help="RMS of the gap's change before a warm solve [m] (--steps)")
    args = ap.parse_args()
    if args.steps:
        totals = step_totals(args.steps, args.position, args.tol, args.moved)
        print(f"Every step of the paper gear's position {args.position} at {args.steps}², tol "
              f"{args.tol:g}, gap moved by {args.moved:g} m RMS before the warm solves — "
              f"{datetime.date.today().isoformat()}, commit {source_commit()}")
        print(", ".join(f"{k}: {v:.2e}" if isinstance(v, float) else f"{k}: {v}"
                        for k, v in totals.items()))
        return
    print(f"One CG for both bounds against the yielded set's search — {args.surface}, tol "
          f"{args.tol:g}, {datetime.date.today().isoformat()}, commit {source_commit()}")
    print()
    print("| grid | solver: iterations (fine) | fine-equivalent | error | one level: iterations "
          "| error | box CG: iterations | error | box CG, coarse to fine: fine iterations "
          "| fine-equivalent | error | yielded share |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for n in args.sizes:
        problem = (gear_problem(n) if args.surface == "gear"
                   else random_problem(n, args.pressure))
        gap0, hs, P, p_lim = problem
        ref = reference(problem, args.ref_tol)

        def err(p, ref=ref):
            return float(np.linalg.norm(p - ref) / np.linalg.norm(ref))
        sol = solve(problem, args.tol, before=False)
        fine_eq = fine_equivalent(sol, n)
        LEVELS.clear()
        one = dry.solve_dry_contact(gap0, hs, P, p_lim, tol=args.tol, max_iter=MAX_ITER,
                                    coarsest=0)
        p_box, it_box = box_cg(gap0, hs, P, p_lim, args.tol)
        p_lev, it_lev, eq_lev = box_cg_levels(gap0, hs, P, p_lim, args.tol)
        yielded = float(np.mean(ref >= (1 - 1e-9) * p_lim)) if math.isfinite(p_lim) else 0.0
        print(f"| {n}² | {sol.iterations} ({sol.iterations - sol.coarse_iterations}) | "
              f"{fine_eq:.1f} | {err(sol.pressure):.2e} | {one.iterations} | "
              f"{err(one.pressure):.2e} | {it_box} | {err(p_box):.2e} | {it_lev} | "
              f"{eq_lev:.1f} | {err(p_lev):.2e} | {100 * yielded:.1f} % |",
              flush=True)


if __name__ == "__main__":
    main()
