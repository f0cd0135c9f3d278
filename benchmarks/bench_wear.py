"""The wear integrations side by side on one gear position (docs/life.md, "Implicit wear").

One work item of a scene (default: the paper gear z = 23 at position 3, k_lub = 5e-11 s, 64²),
run block by block with each of ``life.wear_integration`` = implicit, relaxed, explicit, on one
rank, and per block: mean wear per body, R_q, Δq of the surface the contact sees, A_p, φ, the
sub-blocks, the implicit wear's contact-only load cycles and the wall time. ``--no-fatigue``
switches the S–N line off (B = 10⁵ MPa) so that only wear acts. Rows go to stdout and to
``--csv``.

    python benchmarks/bench_wear.py --no-fatigue --blocks 2
    python benchmarks/bench_wear.py --k-lub 0 5e-11 --integrations implicit --blocks 3
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
COLUMNS = ("integration", "k_lub_s", "n", "block", "cycles", "sub_blocks", "wear_um_1",
           "wear_um_2", "Rq_um_1", "Rq_um_2", "dq_1", "dq_2", "Ap_1", "Ap_2", "phi",
           "wear_cycles", "wall_s")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "paper_gear_z23.toml"))
    ap.add_argument("--position", type=int, default=3)
    ap.add_argument("--k-lub", type=float, nargs="+", default=[5e-11])
    ap.add_argument("--n", type=int, default=64, help="grid points along each side")
    ap.add_argument("--blocks", type=int, default=2)
    ap.add_argument("--block-M", type=float, default=1.0)
    ap.add_argument("--integrations", nargs="+", default=["implicit", "relaxed", "explicit"])
    ap.add_argument("--no-fatigue", action="store_true", help="S–N intercept 1e5 MPa: no damage")
    ap.add_argument("--csv", default=None)
    a = ap.parse_args(argv)
    base = load_scene(a.scene)
    rows = []
    print(",".join(COLUMNS), flush=True)
    for how in a.integrations:
        for k in a.k_lub:
            scene = dataclasses.replace(
                base, window=dataclasses.replace(base.window, nx=a.n, ny=None),
                life=dataclasses.replace(base.life, integration="adaptive", wear_integration=how,
                                         block=a.block_M * 1e6))
            if a.no_fatigue:
                scene = dataclasses.replace(scene, fatigue=dataclasses.replace(scene.fatigue,
                                                                               B=1e11))
            cycle = PositionCycle(contact_study(scene), a.position, k_lub=k)
            state = initial_state(cycle)
            for _ in range(a.blocks):
                t0 = time.perf_counter()
                r = run_block(cycle, state, scene.life)
                row = (how, k, a.n, r.block, r.cycles, r.sub_blocks, r.wear_mean[0] * 1e6,
                       r.wear_mean[1] * 1e6, r.Rq[0] * 1e6, r.Rq[1] * 1e6, r.slope[0],
                       r.slope[1], r.Ap[0], r.Ap[1], r.phi, r.wear_cycles,
                       time.perf_counter() - t0)
                rows.append(row)
                emit(row)
    write_csv(a.csv, COLUMNS, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
