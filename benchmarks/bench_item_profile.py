"""Where one work item's block spends its time: a ``cProfile`` of one block of one item of a
scene (the converged default unless the scene says otherwise), one rank, one process, on one
256² roughness realisation resampled to the grid (as ``bench_wear_convergence.py``). Prints the
block's wall time and its numbers (sub-blocks, contact-only load cycles, A_p and wear, to
compare two versions of the code for equality), then the profile's lines by cumulative and by
own time.

    python benchmarks/bench_item_profile.py --position 5 --k-lub 5e-11 --n 64 --cycles-M 0.3

Timings, not tests: the profiler itself adds about a third to a contact-bound block.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import sys
import time
from pathlib import Path

from bench_wear_convergence import item_run, reference_surfaces

from micropit_hpc.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "paper_gear_z23.toml"))
    ap.add_argument("--position", type=int, default=5)
    ap.add_argument("--k-lub", type=float, default=5e-11)
    ap.add_argument("--n", type=int, default=64, help="grid points per side")
    ap.add_argument("--cycles-M", type=float, default=0.3, help="the block's cycles [M]")
    ap.add_argument("--ref", type=int, default=256, help="grid of the surface realisation")
    ap.add_argument("--lines", type=int, default=40, help="profile lines per listing")
    a = ap.parse_args(argv)
    base = load_scene(a.scene)
    run = item_run(base, a.position, a.k_lub, a.n, max(a.cycles_M, base.life.block / 1e6),
                   reference_surfaces(base, a.ref))
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    rec = run.run_block(a.cycles_M * 1e6)
    prof.disable()
    wall = time.perf_counter() - t0
    print(f"wall {wall:.1f} s under the profiler; sub-blocks {rec.sub_blocks}, contact-only "
          f"cycles {rec.wear_cycles}; A_p {rec.Ap[0]!r} / {rec.Ap[1]!r} %; wear "
          f"{sum(rec.wear_mean)!r} m")
    for key in ("cumulative", "tottime"):
        pstats.Stats(prof, stream=sys.stdout).sort_stats(key).print_stats(a.lines)
    return 0


if __name__ == "__main__":
    sys.exit(main())
