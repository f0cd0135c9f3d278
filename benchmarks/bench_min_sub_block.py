"""The smallest sub-block (``life.min_sub_block_M``, docs/performance.md §14): one block of
1 M cycles of one work item with the smallest sub-block at several lengths — the combined mean
wear, A_p and Δq per body, the sub-blocks, the implicit wear's contact-only cycles and the wall
time. The scene's own surfaces and settings otherwise (the converged default). One rank.

    python benchmarks/bench_min_sub_block.py --position 5 --k-lub 5e-11 \\
        --floors 15625 3906 977 244 --csv benchmarks/results/min_sub_block.csv
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
from micropit_hpc.life import initial_state, run_block
from micropit_hpc.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
COLUMNS = ("position", "k_lub_s", "min_sub_block", "wear_um", "Ap_1", "Ap_2", "dq_1", "dq_2",
           "phi", "sub_blocks", "wear_cycles", "wall_s")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "paper_gear_z23.toml"))
    ap.add_argument("--position", type=int, default=5)
    ap.add_argument("--k-lub", type=float, default=5e-11)
    ap.add_argument("--floors", type=float, nargs="+", default=[15625, 3906, 977, 244],
                    help="smallest sub-blocks [cycles]")
    ap.add_argument("--csv", default=None)
    a = ap.parse_args(argv)
    base = load_scene(a.scene)
    rows = []
    print(",".join(COLUMNS), flush=True)
    for floor in a.floors:
        scene = dataclasses.replace(base, life=dataclasses.replace(
            base.life, block=1e6, min_sub_block=floor, max_splits=100000))
        cyc = PositionCycle(contact_study(scene), a.position, k_lub=a.k_lub)
        state = initial_state(cyc)
        t0 = time.perf_counter()
        r = run_block(cyc, state, scene.life)
        row = (a.position, a.k_lub, floor, sum(r.wear_mean) * 1e6, r.Ap[0], r.Ap[1],
               r.slope[0], r.slope[1], r.phi, r.sub_blocks, r.wear_cycles,
               time.perf_counter() - t0)
        rows.append(row)
        emit(row)
    write_csv(a.csv, COLUMNS, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
