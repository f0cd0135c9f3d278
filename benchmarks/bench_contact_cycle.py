"""Contact-only load cycles of a paper gear position, cold and then warm, at several values of
one of ``dry``'s constants: the dry solves' iterations (all levels, the φ scan's included) and
the wall time of each cycle (docs/performance.md §11, "The preconditioner on a set that holds").

    .venv/bin/python benchmarks/bench_contact_cycle.py --n 64 128 256 --vary PRECONDITION \\
        --values False True

Each row is one grid and value: ``PositionCycle.contact_fields`` on the fresh surfaces with an
empty warm dict (every step cold: coarse to fine), then again on the same pair with the
asperity tops shaved by ``--shave-nm`` (each body's heights capped at its maximum less that),
warm-started from the first cycle's solutions, as the implicit wear's contact-only evaluations
of the next sub-block are. The pressures of each row are compared with the first value's (the
relative L2 distance of all steps' pressures). One core, one process; a warm-up cycle runs
before the timed ones so that plans and compiled kernels are made; the times are rough
(``farm-bench`` for claims), the iterations deterministic.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")    # one core: before numpy is imported

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench_early_updates import parse_value, position_cycle  # noqa: E402

from micropit_hpc import cycle as cycle_module  # noqa: E402
from micropit_hpc import source_commit  # noqa: E402
from micropit_hpc.lubrication import dry, mixed  # noqa: E402

#: iterations of each top-level dry solve of the current cycle (not the coarse levels')
ITERATIONS: list[int] = []


def _counted(*args, **kwargs):
    sol = dry.solve_dry_contact(*args, **kwargs)
    ITERATIONS.append(sol.iterations)
    return sol


def shaved(surfaces, depth: float):
    """Each surface with its heights capped ``depth`` below its highest point."""
    return tuple(dataclasses.replace(s, heights=np.minimum(s.heights, s.heights.max() - depth))
                 for s in surfaces)


def run(cyc, surfaces, worn):
    """(iterations, solves, wall, pressures) of the cold cycle and of the warm one."""
    warm, out = {}, []
    for surf in (surfaces, worn):
        ITERATIONS.clear()
        t0 = time.perf_counter()
        fields = cyc.contact_fields(surf, None, warm)
        wall = time.perf_counter() - t0
        out.append((sum(ITERATIONS), len(ITERATIONS), wall,
                    np.array([f.pressure for f in fields])))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "paper_gear_z23.toml"))
    ap.add_argument("--position", type=int, default=3)
    ap.add_argument("--n", type=int, nargs="+", default=[64, 128, 256])
    ap.add_argument("--vary", default="PRECONDITION", help="the dry.* constant the rows differ in")
    ap.add_argument("--values", nargs="+", default=["False", "True"],
                    help="its value in each row (int, float, True or False), the first the "
                         "baseline")
    ap.add_argument("--shave-nm", type=float, default=20.0)
    args = ap.parse_args()
    if not hasattr(dry, args.vary):
        ap.error(f"--vary {args.vary}: dry has no such constant")
    values = [parse_value(v) for v in args.values]
    mixed.solve_dry_contact = _counted
    cycle_module.solve_dry_contact = _counted
    print(f"contact-only cycles, {Path(args.scene).name} position {args.position}, commit "
          f"{source_commit()}, one core; warm: tops shaved by {args.shave_nm:g} nm\n")
    print(f"| grid | dry.{args.vary} | cycle | dry solves | iterations | against the first "
          "| wall [s] | pressures against the first |")
    print("|---|---|---|---|---|---|---|---|")
    saved = getattr(dry, args.vary)
    try:
        for n in args.n:
            cyc = position_cycle(n, args.position, args.scene)
            fresh = cyc.surfaces
            worn = shaved(fresh, args.shave_nm * 1e-9)
            run(cyc, fresh, worn)            # warm-up: plans, compiled kernels
            base = None
            for v in values:
                setattr(dry, args.vary, v)
                rows = run(cyc, fresh, worn)
                base = rows if base is None else base
                for name, row, ref in zip(("cold", "warm"), rows, base, strict=True):
                    d = np.linalg.norm(row[3] - ref[3]) / np.linalg.norm(ref[3])
                    print(f"| {n}² | {v} | {name} | {row[1]} | {row[0]} | {row[0] / ref[0]:.3f} "
                          f"| {row[2]:.2f} | {d:.2e} |", flush=True)
    finally:
        setattr(dry, args.vary, saved)


if __name__ == "__main__":
    main()
