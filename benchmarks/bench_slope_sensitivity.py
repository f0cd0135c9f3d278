"""How the wear–fatigue competition on the gear depends on the unknown slope of the paper's
surfaces (issue 29, item 6; docs/life.md "Does wear protect?"): one work item of the paper
gear z = 23 at each β_x (the correlation length along rolling, the same R_q, so Δq ∝ R_q/β_x)
and k_lub, the converged default otherwise, the scene's window and grid: A_p, the combined
wear, Δq before and after, φ and the share of the load on pitted columns (``pit_load``) after
each block, with the block's flags (``window`` where the window does not hold 4 β_x).

    python benchmarks/bench_slope_sensitivity.py --position 5 --corr-x-um 15 30 60 120 \\
        --k-lub 0 5e-11 --cycles-M 1
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

from table import emit, write_csv

from micropit_hpc.conditions import contact_study
from micropit_hpc.life import rms_slope
from micropit_hpc.plan import Window, WorkItem
from micropit_hpc.regime import block_flags, window_problems
from micropit_hpc.scene import load_scene
from micropit_hpc.study import ItemRun

ROOT = Path(__file__).resolve().parents[1]
COLUMNS = ("position", "corr_x_um", "k_lub_s", "n", "cycles_M", "dq0_1", "dq0_2", "dq_1",
           "dq_2", "Ap_1", "Ap_2", "wear_um", "phi", "pit_load", "flags", "wall_s")


def _with_corr_x(scene, corr_x: float):
    bodies = {}
    for name in ("body1", "body2"):
        body = getattr(scene, name)
        bodies[name] = dataclasses.replace(
            body, surface=dataclasses.replace(body.surface, corr_x=corr_x))
    return dataclasses.replace(scene, **bodies)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "paper_gear_z23.toml"))
    ap.add_argument("--position", type=int, default=5)
    ap.add_argument("--corr-x-um", type=float, nargs="+", default=[15, 30, 60, 120])
    ap.add_argument("--k-lub", type=float, nargs="+", default=[0.0, 5e-11])
    ap.add_argument("--cycles-M", type=float, default=1.0)
    ap.add_argument("--csv", default=None)
    a = ap.parse_args(argv)
    base = load_scene(a.scene)
    print(",".join(COLUMNS), flush=True)
    rows = []
    for beta in a.corr_x_um:
        scene = _with_corr_x(base, beta * 1e-6)
        study = contact_study(scene)
        window = Window.of(study)
        window_ok = not window_problems(scene, window.grid)
        for k in a.k_lub:
            t0 = time.perf_counter()
            run = ItemRun(scene, WorkItem(0, a.position, k, 1.0, 0), base=study)
            dx = run.cycle.grid.dx
            dq0 = [rms_slope(s.heights, dx) for s in run.surfaces]
            while run.state.cycles < a.cycles_M * 1e6 * (1 - 1e-9):
                rec = run.run_block(min(run.life.block, a.cycles_M * 1e6 - run.state.cycles))
                flags = ";".join(block_flags(rec, window.z_max, window_ok)) or "none"
                row = (a.position, beta, k, run.cycle.grid.nx, run.state.cycles / 1e6,
                       dq0[0], dq0[1], rec.slope[0], rec.slope[1], rec.Ap[0], rec.Ap[1],
                       sum(rec.wear_mean) * 1e6, rec.phi, rec.pit_load, flags,
                       time.perf_counter() - t0)
                rows.append(row)
                emit(row)
    write_csv(a.csv, COLUMNS, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
