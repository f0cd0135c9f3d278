"""Time steps per load cycle: the old fixed m against the kinematic rule (docs/performance.md
§13, "Time steps"; docs/model.md §4).

    .venv/bin/python benchmarks/bench_steps.py [--positions 3,5] [--out benchmarks/results]
        [--table-only]

The paper's gear (scenes/paper_gear_z23.toml, 64², one patch) with k_lub = 0 (fatigue only,
no wear), at positions 3 (|S| = 0.39, 2b|S| = 78 µm = 24 cells = 1.6 λ_c) and 5 (|S| = 0.046,
2b|S| = 9.4 µm = 2.9 cells): 1 M cycles of the life loop (the scene's paper scheme: one
load-cycle evaluation on the fresh surfaces, then the pits), A_p of both bodies at the end.
Rows, each rule row with a partner at twice the steps it chose:

* ``uniform, fixed``: the paper's spacing t_j = (j + ½) t_f/m at m = 20 … 320 (the kinematic
  rule off);
* ``uniform, λ_c/16``: uniform spacing, m raised so that the relative slip per step is at
  most λ_c/16 (``window.steps_per_peak_spacing``), floor 20;
* ``cosine, λ_c/n``: cosine spacing (``window.step_spacing``, the default) with that rule for
  n = 16 (floors 20 and 40), 24 (the default) and 32 (floor 40, the default
  ``window.steps``);
* position 3 on 128² (its own roughness realisation) with λ_c/16 and λ_c/24: the rule asks
  about as many steps as on 64² (a one-cell rule would ask twice as many).

ΔA_p: each rule row against its 2× row (the target: within 1 point), each fixed row against
the next finer one. Wall: one load-cycle evaluation (the contact at every step, stresses,
Dang Van, damage), one core, one process, after a warm-up evaluation (the compiled kernels).
Rows go to ``OUT/steps.csv``; a re-run skips the rows there.
"""

from __future__ import annotations

import argparse
import csv
import time
import tomllib
from pathlib import Path

from micropit_hpc import source_commit
from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import counterface_spacing
from micropit_hpc.plan import WorkItem
from micropit_hpc.scene import scene_from_dict
from micropit_hpc.study import ItemRun

ROOT = Path(__file__).resolve().parent.parent
SCENE = "scenes/paper_gear_z23.toml"
FIELDS = ("position", "n", "spacing", "rule", "floor", "twice", "steps", "wall_s", "Ap1_pct",
          "Ap2_pct", "slip_per_step_um", "lam_c_um", "dx_um", "commit")
OFF = 1e-6           # steps_per_peak_spacing that never raises m
DEFAULT_PER = 24.0   # window.steps_per_peak_spacing's default


def _scene(n: int, spacing: str, floor: int, per: float):
    with open(ROOT / SCENE, "rb") as f:
        doc = tomllib.load(f)
    doc["wear"]["k_lub_s"] = [0.0]
    doc["study"]["patches"] = 1
    doc["window"].update(n=n, steps=floor, step_spacing=spacing, steps_per_peak_spacing=per)
    scene = scene_from_dict(doc, f"{SCENE} ({n}², {spacing}, floor {floor}, λ_c/{per:g})")
    return scene, contact_study(scene)


def measure(position: int, n: int, spacing: str, floor: int, per: float) -> dict:
    """1 M cycles at ``position`` (A_p of both bodies) and the wall time of one evaluation."""
    scene, study = _scene(n, spacing, floor, per)
    run = ItemRun(scene, WorkItem(0, position, 0.0, 1.0, 0), base=study)
    t0 = time.perf_counter()
    run.cycle.evaluate(run.surfaces)
    wall = time.perf_counter() - t0
    rec = run.run_block(1e6)
    cyc = run.cycle
    c = cyc.cond
    slip = 2.0 * c.b * abs(c.S) * float(cyc.weights.max())
    lam = counterface_spacing(scene, run.surfaces, cyc.grid.dx)
    return dict(steps=cyc.steps, wall_s=wall, Ap1_pct=rec.Ap[0], Ap2_pct=rec.Ap[1],
                slip_per_step_um=slip * 1e6, lam_c_um=lam * 1e6, dx_um=cyc.grid.dx * 1e6)


def plan(positions):
    """(position, n, spacing, rule, floor, twice, steps_per_peak_spacing) of every row."""
    rows = []
    for pos in positions:
        for m in (20, 40, 80, 160, 320):
            rows.append((pos, 64, "uniform", "fixed", m, 0, OFF))
        for spacing, floor, per in (("uniform", 20, 16.0), ("cosine", 20, 16.0),
                                    ("cosine", 40, 16.0), ("cosine", 40, 24.0),
                                    ("cosine", 40, 32.0)):
            for twice in (0, 1):
                rows.append((pos, 64, spacing, f"λ_c/{per:g}", floor, twice, per))
    if 3 in positions:
        for per in (16.0, DEFAULT_PER):
            for twice in (0, 1):
                rows.append((3, 128, "cosine", f"λ_c/{per:g}", 40, twice, per))
    return rows


def run(positions, out: Path) -> Path:
    out.mkdir(parents=True, exist_ok=True)
    path = out / "steps.csv"
    done, chosen = set(), {}          # chosen: the steps of each rule row, for its 2× row
    if path.exists():
        with open(path) as f:
            for r in csv.DictReader(f):
                key = (int(r["position"]), int(r["n"]), r["spacing"], r["rule"], int(r["floor"]))
                done.add((*key, int(r["twice"])))
                if r["twice"] == "0":
                    chosen[key] = int(r["steps"])
    new = not path.exists()
    commit = source_commit() or ""
    measure(3, 64, "cosine", 4, OFF)          # warm-up: the compiled kernels
    with open(path, "a", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        if new:
            w.writeheader()
        for pos, n, spacing, rule, floor, twice, per in plan(positions):
            key = (pos, n, spacing, rule, floor)
            if (*key, twice) in done:
                continue
            if twice:      # twice the steps the rule chose: that many as the floor
                r = measure(pos, n, spacing, 2 * chosen[key], per)
            else:
                r = measure(pos, n, spacing, floor, per)
                chosen[key] = r["steps"]
            r.update(position=pos, n=n, spacing=spacing, rule=rule, floor=floor, twice=twice,
                     commit=commit)
            w.writerow(r)
            f.flush()
            print(f"pos {pos} {n}² {spacing:8s} {rule:7s} floor {floor:3d} "
                  f"{'2×' if twice else '  '} m {r['steps']:4d}  {r['wall_s']:6.2f} s  "
                  f"A_p {r['Ap1_pct']:6.2f} / {r['Ap2_pct']:6.2f} %  slip/step "
                  f"{r['slip_per_step_um']:.2f} µm (λ_c {r['lam_c_um']:.3g} µm, Δx "
                  f"{r['dx_um']:.3g} µm)", flush=True)
    return path


def table(path: Path) -> str:
    """The Markdown table of docs/performance.md: each rule row beside its 2× row, each fixed
    row beside the next finer fixed row."""
    with open(path) as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k in ("wall_s", "Ap1_pct", "Ap2_pct", "slip_per_step_um", "lam_c_um", "dx_um"):
            r[k] = float(r[k])
        for k in ("position", "n", "floor", "twice", "steps"):
            r[k] = int(r[k])
    rows.sort(key=lambda r: (r["position"], r["n"], r["rule"] != "fixed",
                             r["spacing"] != "uniform", r["floor"], r["rule"], r["twice"]))
    lines = ["| pos. | grid | spacing | m from | m | slip/step [µm] | wall/cycle [s] | "
             "A_p body 1 / 2 [%] | against | ΔA_p [pt] |", "|" + "---|" * 10]
    for r in rows:
        if r["twice"]:
            continue
        same = [q for q in rows if (q["position"], q["n"]) == (r["position"], r["n"])]
        if r["rule"] == "fixed":
            ref = next((q for q in same if q["rule"] == "fixed"
                        and q["floor"] == 2 * r["floor"]), None)
            what = f"fixed {r['floor']}"
        else:
            ref = next((q for q in same if q["twice"] and (q["spacing"], q["rule"], q["floor"])
                        == (r["spacing"], r["rule"], r["floor"])), None)
            what = f"{r['rule']}, floor {r['floor']}"
            if (r["spacing"], r["floor"], r["rule"]) == ("cosine", 40, f"λ_c/{DEFAULT_PER:g}"):
                what += " **(default)**"
        against = (f"{ref['steps']} steps: {ref['Ap1_pct']:.2f} / {ref['Ap2_pct']:.2f}"
                   if ref else "")
        delta = (f"{r['Ap1_pct'] - ref['Ap1_pct']:+.2f} / {r['Ap2_pct'] - ref['Ap2_pct']:+.2f}"
                 if ref else "")
        lines.append(f"| {r['position']} | {r['n']}² | {r['spacing']} | {what} | {r['steps']} | "
                     f"{r['slip_per_step_um']:.2f} | {r['wall_s']:.2f} | "
                     f"{r['Ap1_pct']:.2f} / {r['Ap2_pct']:.2f} | {against} | {delta} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--positions", default="3,5")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    ap.add_argument("--table-only", action="store_true")
    a = ap.parse_args(argv)
    path = a.out / "steps.csv"
    if not a.table_only:
        path = run([int(p) for p in a.positions.split(",")], a.out)
    print(table(path))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
