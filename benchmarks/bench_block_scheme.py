"""A_p against the block length ΔN in both time integrations, the converged default and the
paper's literal numerics (docs/life.md, "Two time integrations"; docs/performance.md, "Block
length and time integration").

    .venv/bin/python benchmarks/bench_block_scheme.py [--n 64] [--procs 2]
        [--blocks 0.1,0.25,0.5,1] [--cases gear3,mpr] [--out benchmarks/results]

Two work items, k_lub = 0 and 1e-11 s, each with ``life.integration = "adaptive"`` (the
converged default, which the paper scenes run: blocks split until damage, pits and wear are
resolved in time, the wear implicit) and ``"paper"`` (their literal twins': one evaluation per
block on the block's starting surfaces, explicit wear ΔN·Δh and damage over the whole block,
then the pit check), for every ΔN:

* ``gear3``: the paper's gear (scenes/paper_gear_z23.toml), position 3 (single-pair zone
  below the pitch point, S = −0.39), 3 M cycles, patch 0;
* ``mpr``: the MPR rig (scenes/paper_mpr.toml), |S| = 0.30, 6 M cycles (the first inspection).

Everything else is the scene's, except the window grid (``--n``, default 64: the MPR scene's
128² takes ~4× longer per evaluation). Rows (A_p of both bodies at the end, the wear
integration that ran, wear, evaluations, wall time) go to ``OUT/block_scheme.csv`` as they
finish; a re-run skips the rows already there, and refuses a file written with other columns
(rows from before the wear integration was recorded: move it away to re-measure). The runs are
spread over ``--procs`` processes (one core each).
"""

from __future__ import annotations

import argparse
import csv
import time
import tomllib
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CASES = {"gear3": ("paper_gear_z23", 3, 3.0), "mpr": ("paper_mpr", 3, 6.0)}
COLUMNS = ("case", "integration", "wear", "k_lub_s", "block_M", "n", "cycles_M", "Ap1_pct",
           "Ap2_pct", "wear1_um", "wear2_um", "evaluations", "wall_s", "flags")


def run_one(case: str, integration: str, k_lub: float, block: float, n: int) -> dict:
    """One item to its life; returns a row of :data:`COLUMNS`."""
    from micropit_hpc.plan import WorkItem
    from micropit_hpc.regime import block_flags
    from micropit_hpc.scene import scene_from_dict
    from micropit_hpc.study import ItemRun

    name, position, cycles = CASES[case]
    doc = tomllib.loads((ROOT / "scenes" / f"{name}.toml").read_text())
    doc.setdefault("window", {})["n"] = n
    doc["wear"] = {"k_lub_s": [k_lub]}
    doc["life"].update(cycles_M=cycles, block_M=block, integration=integration)
    scene = scene_from_dict(doc, f"{name}.toml")
    run = ItemRun(scene, WorkItem(0, position, k_lub, 1.0, 0))
    t0 = time.perf_counter()
    done, evals, rec = 0.0, 0, None
    while done < cycles * 1e6 * (1 - 1e-9):
        rec = run.run_block(min(block * 1e6, cycles * 1e6 - done))
        done = rec.cycles
        evals += rec.sub_blocks
    flags = ";".join(block_flags(rec, float(run.cycle.z[-1]))) or "none"
    # the paper's integration always wears explicitly (micropit_hpc.life.run_block)
    wear = "explicit" if integration == "paper" else scene.life.wear_integration
    return {"case": case, "integration": integration, "wear": wear, "k_lub_s": k_lub,
            "block_M": block,
            "n": n, "cycles_M": cycles, "Ap1_pct": round(rec.Ap[0], 3),
            "Ap2_pct": round(rec.Ap[1], 3), "wear1_um": round(rec.wear_mean[0] * 1e6, 4),
            "wear2_um": round(rec.wear_mean[1] * 1e6, 4), "evaluations": evals,
            "wall_s": round(time.perf_counter() - t0, 1), "flags": flags}


def _key(row) -> tuple:
    return (row["case"], row["integration"], float(row["k_lub_s"]), float(row["block_M"]),
            int(row["n"]))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--procs", type=int, default=2)
    ap.add_argument("--blocks", default="0.1,0.25,0.5,1")
    ap.add_argument("--cases", default="gear3,mpr")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results"))
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    table = out / "block_scheme.csv"
    have = {}
    if table.is_file():
        with open(table, newline="") as fh:
            rows = csv.DictReader(fh)
            if tuple(rows.fieldnames or ()) != COLUMNS:
                ap.error(f"{table} has the columns {','.join(rows.fieldnames or ())}, not "
                         f"{','.join(COLUMNS)}: rows of an earlier version; move it away to "
                         "re-measure")
            have = {_key(r): r for r in rows}
    jobs = [(c, i, k, float(b), args.n) for c in args.cases.split(",")
            for i in ("adaptive", "paper") for k in (0.0, 1e-11)
            for b in args.blocks.split(",")]
    todo = [j for j in jobs if (j[0], j[1], j[2], j[3], j[4]) not in have]
    # the paper's literal scheme first (one evaluation per block), then the converged default
    # from the longest blocks down (its cost grows as ΔN shrinks: its floor is
    # ΔN / life.max_splits)
    todo.sort(key=lambda j: (j[1] != "paper", -j[3], j[0]))
    new_file = not table.is_file()
    with open(table, "a", newline="") as fh, ProcessPoolExecutor(args.procs) as pool:
        w = csv.DictWriter(fh, COLUMNS)
        if new_file:
            w.writeheader()
        for fut in as_completed([pool.submit(run_one, *j) for j in todo]):
            row = fut.result()
            w.writerow(row)
            fh.flush()
            print(",".join(str(row[c]) for c in COLUMNS), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
