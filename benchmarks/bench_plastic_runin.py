"""Plastic running-in of the asperity tips and the wear–fatigue competition (issue 29 item 6;
``life.running_in = "plastic"``, micropit_hpc/running_in.py; docs/life.md, "Plastic
running-in of the tips"; docs/performance.md §15). One work item of the paper gear, one
realisation made on ``--ref``² and resampled (as bench_wear_convergence.py), one block of
``--cycles-M`` M cycles, without running-in (``--passes 0``) and with it, at most P passes
each (``--passes P …``; ``--overlap`` the stop rule's ``life.running_in_overlap``, 0: every
pass), at each ``--k-lub``: the running-in's record, then the block's wear, A_p, Δq and φ.

    python benchmarks/bench_plastic_runin.py --position 5 --n 64 --k-lub 0 5e-11 \
        --passes 0 10 30 100 --overlap 0
    python benchmarks/bench_plastic_runin.py --position 5 --n 64 --k-lub 0 5e-11 --passes 100
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

from bench_wear_convergence import item_run, reference_surfaces
from table import emit, write_csv

from micropit_hpc.life import rms_slope
from micropit_hpc.running_in import run_in
from micropit_hpc.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
COLUMNS = ("position", "k_lub_s", "n", "cycles_M", "max_passes", "overlap_rule", "passes",
           "overlap_first_nm", "overlap_last_nm", "flattened_um_1", "flattened_um_2",
           "plastic_first", "plastic_last", "dq0_1", "dq0_2", "wear_um", "Ap_1", "Ap_2",
           "dq_1", "dq_2", "phi", "low_cycle_1", "wall_s")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "paper_gear_z23.toml"))
    ap.add_argument("--position", type=int, default=5)
    ap.add_argument("--k-lub", type=float, nargs="+", default=[0.0, 5e-11])
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--passes", type=int, nargs="+", default=[0, 100])
    ap.add_argument("--overlap", type=float, default=None,
                    help="life.running_in_overlap (default: the scene's; 0: every pass)")
    ap.add_argument("--cycles-M", type=float, default=1.0)
    ap.add_argument("--ref", type=int, default=256, help="grid of the surface realisation")
    ap.add_argument("--csv", default=None)
    a = ap.parse_args(argv)
    base = load_scene(a.scene)
    reference = reference_surfaces(base, a.ref)
    print(",".join(COLUMNS), flush=True)
    rows = []
    for k_lub in a.k_lub:
        for passes in a.passes:
            t0 = time.perf_counter()
            life = base.life if not passes else dataclasses.replace(
                base.life, running_in="plastic", running_in_passes=passes,
                running_in_overlap=(base.life.running_in_overlap if a.overlap is None
                                    else max(a.overlap, 1e-300)))
            run = item_run(dataclasses.replace(base, life=life), a.position, k_lub, a.n,
                           a.cycles_M, reference)
            if passes:      # what run_block would do first, here to see the run-in slopes
                run.running_in = run_in(run.cycle, run.state, life)
            ri = run.running_in
            dq0 = [rms_slope(b.heights, run.cycle.grid.dx) for b in run.state.bodies]
            rec = run.run_block(a.cycles_M * 1e6)
            row = (a.position, k_lub, a.n, a.cycles_M, passes, life.running_in_overlap,
                   0 if ri is None else ri.passes,
                   0.0 if ri is None else ri.overlap_first * 1e9,
                   0.0 if ri is None else ri.overlap_last * 1e9,
                   0.0 if ri is None else ri.depth_mean[0] * 1e6,
                   0.0 if ri is None else ri.depth_mean[1] * 1e6,
                   0.0 if ri is None else ri.plastic_first,
                   0.0 if ri is None else ri.plastic_last, dq0[0], dq0[1],
                   sum(rec.wear_mean) * 1e6, rec.Ap[0], rec.Ap[1], rec.slope[0], rec.slope[1],
                   rec.phi, rec.low_cycle_damage[0], time.perf_counter() - t0)
            rows.append(row)
            emit(row)
    write_csv(a.csv, COLUMNS, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
