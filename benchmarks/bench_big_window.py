"""Big windows, measured: one gear position on n x n windows, on the ranks it is started with.

For each n: the plan (scenes/gear_z23_2048.toml with window.n = n, position 3), the cycle of one
work item on all ranks (as ``--ranks-per-item`` = all ranks does; the contact shared as
``--parallel`` says, cycle.contact_parallel: "steps", every rank solves whole windows, its share
of a cycle's time steps; "slabs", each step split over the ranks' x rows), then

* ``step``: one contact solve (the middle time step) and the stresses of both bodies at it;
* ``cycle`` (with ``--cycle``): one whole load-cycle evaluation (every step's contact, the
  stress history through depth, Dang Van, damage and wear rates);

with the wall time of each (rank 0's clock, after a barrier) and the peak resident memory of
every rank (``ru_maxrss``, the high-water mark of the process so far; the sizes run in
increasing order, so each line is that size's peak). With ``--stages`` the cycle's wall time is
also split per rank into its stages (wall clocks around the cycle's own methods,
:class:`StageClock`): the contact of the rank's steps (``_contact_steps``, its broadcast
included), the stress history (the steps' spectra and the history chunks), the rest of the
streamed Dang Van (the kernel and its batching), and the remainder (macro Dang Van, damage and
wear rates).

    mpirun -n 2 python benchmarks/bench_big_window.py --sizes 512 1024 --cycle 512
    mpirun -n 2 python benchmarks/bench_big_window.py --sizes 256 --cycle 256 --stages
    mpirun -n 2 python benchmarks/bench_big_window.py --sizes 1024 --parallel slabs
    python benchmarks/bench_big_window.py --sizes 512 1024 2048

Prints one line per size and writes them to ``--csv`` (default
benchmarks/results/big_window_<ranks>r.csv). Timings, not tests; docs/scaling.md holds the
measured table.
"""

from __future__ import annotations

import argparse
import csv
import resource
import sys
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from micropit_hpc.cycle import PositionCycle  # noqa: E402
from micropit_hpc.parallel import world  # noqa: E402
from micropit_hpc.plan import make_plan  # noqa: E402
from micropit_hpc.scene import load_scene  # noqa: E402


def peak_mib() -> float:
    """This process's peak resident size so far [MiB] (Linux: ru_maxrss in KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


class StageClock:
    """Wall clocks around methods of one object: ``wrap(obj, name, stage)`` replaces the bound
    method ``obj.name`` by one that adds its wall time to ``seconds[stage]`` (nested stages
    count in both; the caller subtracts)."""

    def __init__(self):
        self.seconds: dict[str, float] = {}

    def wrap(self, obj, name: str, stage: str) -> None:
        inner = getattr(obj, name)
        self.seconds.setdefault(stage, 0.0)

        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return inner(*args, **kwargs)
            finally:
                self.seconds[stage] += time.perf_counter() - t0
        setattr(obj, name, timed)


def cycle_stages(cycle: PositionCycle) -> StageClock:
    """A :class:`StageClock` on ``cycle``'s stages (module docstring, ``--stages``)."""
    clock = StageClock()
    clock.wrap(cycle, "_contact_steps", "contact")
    clock.wrap(cycle, "_streamed_dang_van", "streamed")
    clock.wrap(cycle, "history_spectra", "stresses")
    clock.wrap(cycle, "stress_history", "stresses")
    return clock


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "gear_z23_2048.toml"))
    ap.add_argument("--position", type=int, default=3)
    ap.add_argument("--sizes", type=int, nargs="+", default=[512, 1024])
    ap.add_argument("--cycle", type=int, nargs="*", default=[],
                    help="sizes at which a whole load cycle is evaluated too")
    ap.add_argument("--steps", type=int, default=None, help="time steps (default the scene's)")
    ap.add_argument("--parallel", choices=("auto", "steps", "slabs"), default="auto",
                    help="how the ranks share the contact (cycle.contact_parallel)")
    ap.add_argument("--stages", action="store_true",
                    help="split each cycle's wall time into stages per rank (StageClock)")
    ap.add_argument("--csv", default=None)
    args = ap.parse_args()
    comm = world()
    base = load_scene(args.scene)
    rows = []
    for n in sorted(args.sizes):
        window = replace(base.window, nx=n, ny=None,
                         steps=args.steps if args.steps else base.window.steps)
        scene = replace(base, window=window)
        plan = make_plan(scene, positions=[args.position])
        comm.Barrier()
        t0 = time.perf_counter()
        cycle = PositionCycle(plan.study, args.position, comm=comm, window=plan.window,
                              parallel=args.parallel)
        comm.Barrier()
        t_setup = time.perf_counter() - t0
        j = cycle.steps // 2
        t0 = time.perf_counter()
        fields = cycle.solve_step(j)
        comm.Barrier()
        t_contact = time.perf_counter() - t0
        t0 = time.perf_counter()
        for body in (1, 2):
            cycle.stresses(fields, body)
        comm.Barrier()
        t_stress = time.perf_counter() - t0
        del fields
        t_cycle = float("nan")
        stages = None
        if n in args.cycle:
            clock = cycle_stages(cycle) if args.stages else None
            t0 = time.perf_counter()
            cycle.evaluate(cycle.surfaces)
            t_rank = time.perf_counter() - t0
            comm.Barrier()
            t_cycle = time.perf_counter() - t0
            if clock is not None:
                sec = clock.seconds
                mine = {"cycle": t_rank, "contact": sec["contact"], "stresses": sec["stresses"],
                        "dang_van": sec["streamed"] - sec["stresses"]}
                mine["rest"] = t_rank - mine["contact"] - sec["streamed"]
                stages = comm.gather(mine)
        peaks = comm.allgather(peak_mib())
        row = {"n": n, "ranks": comm.size, "contact": cycle.contact_parallel,
               "level": cycle.level, "steps": cycle.steps,
               "layers": int(cycle.z.size), "setup_s": round(t_setup, 2),
               "contact_step_s": round(t_contact, 2), "stresses_step_s": round(t_stress, 2),
               "cycle_s": round(t_cycle, 1), "peak_MiB_per_rank": round(max(peaks)),
               "peak_MiB_all": round(sum(peaks))}
        rows.append(row)
        if comm.rank == 0:
            print(" ".join(f"{k}={v}" for k, v in row.items()), flush=True)
            for r, st in enumerate(stages or []):
                print(f"#   rank {r}: " + ", ".join(f"{k} {v:.1f} s" for k, v in st.items()),
                      flush=True)
        del cycle
    if comm.rank == 0:
        out = Path(args.csv or ROOT / "benchmarks" / "results" / f"big_window_{comm.size}r.csv")
        out.parent.mkdir(parents=True, exist_ok=True)
        with open(out, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        print(f"# wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
