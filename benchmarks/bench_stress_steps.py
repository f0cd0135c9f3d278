"""The stress layers of a load cycle over several ranks: shared by steps against over the slabs.

One gear position on an n x n window (default scenes/paper_gear_z23.toml, position 3), one
work item on all ranks. The contact of the middle time step is solved once and its fields
stand in for every step of the cycle (the stress stage's cost does not depend on the fields);
then, for each way of sharing (``PositionCycle.stress_by_steps``):

* ``slabs`` (``contact_parallel = "slabs"``): every step's six inverse transforms of a layer
  are distributed over the ranks' x rows (mpi4py-fft);
* ``steps`` (``"steps"``): rank r transforms the whole window of its steps j ≡ r (mod R)
  with the one-rank batch plan and sends every rank its rows;

the seconds per depth layer of the cycle's stress history of body 1 (``stress_history`` on one
layer: the m steps' micro field and the macro field), rank 0's clock after a barrier, the
median of ``--repeat`` passes over ``--layers`` layers, and the largest difference between the
two histories relative to their largest value (round-off: the slab transforms sum in another
order). The forward transforms of the tractions (``history_spectra``) are timed apart.

    mpirun -n 2 python benchmarks/bench_stress_steps.py --n 1024

Prints one line per mode and writes them to ``--csv``. Timings, not tests; docs/performance.md
§11 ("Fourth round") holds the measured table.
"""

from __future__ import annotations

import argparse
import csv
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from micropit_hpc.cycle import PositionCycle  # noqa: E402
from micropit_hpc.parallel import world  # noqa: E402
from micropit_hpc.plan import make_plan  # noqa: E402
from micropit_hpc.scene import load_scene  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "paper_gear_z23.toml"))
    ap.add_argument("--position", type=int, default=3)
    ap.add_argument("--n", type=int, default=1024)
    ap.add_argument("--layers", type=int, default=3, help="layers timed per pass")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--csv", default=None)
    args = ap.parse_args()
    comm = world()
    base = load_scene(args.scene)
    scene = replace(base, window=replace(base.window, nx=args.n, ny=None))
    plan = make_plan(scene, positions=[args.position])
    rows, hist = [], {}
    fields = None
    for mode in ("slabs", "steps"):
        cyc = PositionCycle(plan.study, args.position, comm=comm, window=plan.window,
                            parallel=mode)
        if fields is None:
            f = cyc.solve_step(cyc.steps // 2)
            fields = [f] * cyc.steps
        m, nz = cyc.steps, cyc.z.size
        comm.Barrier()
        t0 = time.perf_counter()
        spectra = cyc.history_spectra(fields, 1)
        comm.Barrier()
        t_spec = time.perf_counter() - t0
        macro = [cyc.macro_stress(f, 1) for f in fields]
        buf = np.empty((m, 6, 1, cyc.slab.nx_local, cyc.grid.ny))
        layers = [min(nz - 1, 1 + k * max(1, (nz - 1) // args.layers)) for k in range(args.layers)]
        times = []
        for _ in range(args.repeat):
            comm.Barrier()
            t0 = time.perf_counter()
            for k in layers:
                cyc.stress_history(spectra, macro, 1, slice(k, k + 1), out=buf)
            comm.Barrier()
            times.append((time.perf_counter() - t0) / len(layers))
        hist[mode] = buf.copy()
        rows.append({"n": args.n, "ranks": comm.size, "mode": mode, "steps": m,
                     "by_steps": cyc.stress_by_steps,
                     "layer_s": round(statistics.median(times), 4),
                     "per_step_ms": round(statistics.median(times) / m * 1e3, 2),
                     "spectra_s": round(t_spec, 3)})
        del spectra, buf
    scale = max(float(np.abs(hist["slabs"]).max()), 1e-300)
    diff = float(np.abs(hist["slabs"] - hist["steps"]).max()) / scale
    diff = max(comm.allgather(diff))
    for r in rows:
        r["vs_slabs"] = f"{diff:.1e}" if r["mode"] == "steps" else "0"
    if comm.rank == 0:
        for r in rows:
            print(" ".join(f"{k}={v}" for k, v in r.items()), flush=True)
        ratio = rows[1]["layer_s"] / rows[0]["layer_s"]
        print(f"steps / slabs per layer: {ratio:.2f}", flush=True)
        if args.csv:
            with open(args.csv, "w", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=list(rows[0]))
                w.writeheader()
                w.writerows(rows)
            print(f"# wrote {args.csv}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
