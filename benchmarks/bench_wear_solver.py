"""The implicit wear's solver on one run-in gear contact (docs/life.md, "Implicit wear"):
contact-only load cycles (iterations) to the tolerance of one backward-Euler step, for several
step lengths, plain Anderson against the spectral preconditioner at several shares θ.

The state: the paper gear z = 23 at position 3, k_lub = 5e-11 s, 64², fatigue off (S–N
intercept 1e5 MPa), worn by the default implicit wear over ``--pre-M`` million cycles (one
block). From it, one full load cycle gives the starting rates, then each solve starts from the
explicit step (no guess) with ``life.wear_tol`` × R_q. One rank. Rows to stdout and ``--csv``.

    python benchmarks/bench_wear_solver.py
    python benchmarks/bench_wear_solver.py --steps 7000 20000 --shares 0 0.25 1
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

from table import emit, write_csv

from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import PositionCycle
from micropit_hpc.implicit_wear import SpectralRelief, backward_euler
from micropit_hpc.life import _worn, contact_surfaces, initial_state, run_block
from micropit_hpc.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
COLUMNS = ("step_cycles", "share", "iterations", "converged", "residual_over_tol", "wall_s")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "paper_gear_z23.toml"))
    ap.add_argument("--position", type=int, default=3)
    ap.add_argument("--k-lub", type=float, default=5e-11)
    ap.add_argument("--pre-M", type=float, default=0.25, help="cycles worn first [M]")
    ap.add_argument("--steps", type=float, nargs="+", default=[7e3, 2e4, 5e4, 1e5])
    ap.add_argument("--shares", type=float, nargs="+", default=[0.0, 0.1, 0.25, 0.5, 1.0],
                    help="θ of the preconditioner; 0: plain Anderson")
    ap.add_argument("--max-iter", type=int, default=60)
    ap.add_argument("--csv", default=None)
    a = ap.parse_args(argv)
    base = load_scene(a.scene)
    scene = dataclasses.replace(
        base, life=dataclasses.replace(base.life, integration="adaptive",
                                       wear_integration="implicit", block=a.pre_M * 1e6),
        fatigue=dataclasses.replace(base.fatigue, B=1e11))
    cycle = PositionCycle(contact_study(scene), a.position, k_lub=a.k_lub)
    state = initial_state(cycle)
    t0 = time.perf_counter()
    run_block(cycle, state, scene.life)
    print(f"# worn {a.pre_M} M cycles in {time.perf_counter() - t0:.0f} s", flush=True)
    surfaces, pits = contact_surfaces(state, cycle.grid, scene.life.pit_contact)
    warm: dict = {}
    start = tuple(bc.wear for bc in cycle.evaluate(surfaces, pits, warm).bodies)
    tol = scene.life.wear_tol * min(b.rq0 for b in state.bodies)
    hs = cycle.half_spaces

    def rates(w):
        return cycle.wear_rates(_worn(surfaces, state, w), pits, warm)
    rows = []
    print(",".join(COLUMNS), flush=True)
    for n in a.steps:
        for share in a.shares:
            relief = (SpectralRelief(hs.stiffness, hs.self_compliance, cycle.grid.shape, share)
                      if share > 0 else None)
            t0 = time.perf_counter()
            sol = backward_euler(rates, start, n, tol, max_iter=a.max_iter, relief=relief)
            row = (n, share, sol.iterations, sol.converged, sol.residual / tol,
                   time.perf_counter() - t0)
            rows.append(row)
            emit(row)
    write_csv(a.csv, COLUMNS, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
