"""Speed against error of the numerical knobs (docs/performance.md).

    .venv/bin/python benchmarks/bench_speed_error.py [--cases mpr,gear3,gear5] [--levels cycle,life]
        [--out benchmarks/results] [--plot docs/performance_speed_error.png] [--table-only]
        [--knobs n] [--grid 64,128,256,512,1024]

``--knobs`` runs only the knobs named; ``--grid`` replaces the cycle level's grid values (the
big-window line of docs/performance.md §10: ``--cases gear3 --levels cycle --knobs n --grid
64,128,256,512,1024 --out benchmarks/results/big --plot docs/performance_grid_big.png``; grids
above the 256² realisation's own resolve no new roughness, so that line measures the
discretisation of one band-limited surface).

Three work items, k_lub = 1e-11 s: the MPR rig at |S| = 0.30 (scenes/paper_mpr_beta30.toml,
position 3, default window 128²) and the paper's gear at positions 3 and 5
(scenes/paper_gear_z23.toml, default window 64²). One knob at a time moves away from the
scene's value; the reference is that knob's finest value, every other knob at the scene's.

* ``cycle`` level: one load-cycle evaluation on the fresh surfaces (contact at every step,
  stresses, Dang Van, damage and wear rates). Reported as what 1 M cycles at these rates
  would do: A_p1M [%] (columns with D ≥ 1 somewhere in depth), D_max,1M (largest damage) and
  the mean wear depth [nm] (relaxed integration), each the larger of the two bodies.
  Knobs: grid n, window length (at the scene's cell size), depth layers, time steps,
  contact tolerance, film-balance tolerance.
* ``life`` level: 1 M cycles of the life loop with its adaptive sub-blocks; A_p, the largest
  damage of the intact material and the mean wear at the end. Knobs: grid n, block ΔN (the
  MPR item's block sweep on 64², to keep the whole run near half an hour).

The surfaces of the grid and layer/step/tolerance sweeps are one realisation made on the finest
grid (256²) and resampled (antialiased) to each grid, so a grid's error is its
discretisation, not another roughness sample. A longer window needs more surface: each
window length draws its own (the window rows then measure roughness sampling too).

Rows go to ``OUT/speed_error.csv`` as they finish; a re-run skips the rows already there
(delete the file to time everything again). Wall time: one core, one process.
"""

from __future__ import annotations

import argparse
import csv
import math
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

from micropit_hpc import source_commit
from micropit_hpc.conditions import contact_study
from micropit_hpc.errors import MicropitError
from micropit_hpc.plan import WorkItem, reference_half_width, window_grid
from micropit_hpc.scene import scene_from_dict
from micropit_hpc.study import ItemRun
from micropit_hpc.surfaces.bodies import body_surface

ROOT = Path(__file__).resolve().parent.parent
REF_N = 256


@dataclass(frozen=True)
class Case:
    """A work item of the study; ``life_n``: the grid of the life-level block sweep (None:
    the scene's)."""

    name: str
    scene: str
    position: int
    life_n: int | None = None


CASES = {
    "mpr": Case("mpr", "scenes/paper_mpr_beta30.toml", 3, life_n=64),
    "gear3": Case("gear3", "scenes/paper_gear_z23.toml", 3),
    "gear5": Case("gear5", "scenes/paper_gear_z23.toml", 5),
}

#: knob -> (scene section, key, values finest last); "window" is a length factor at the
#: scene's cell size
CYCLE_KNOBS = {
    "n": ("window", "n", [32, 48, 64, 96, 128, 192, 256]),
    "window": ("window", "length_x_um", [0.5, 1.0, 2.0]),
    "layers": ("stress", "layers", [5, 10, 15, 20, 30]),
    "steps": ("window", "steps", [5, 10, 20, 40]),
    "tol": ("lubrication", "tolerance", [1e-4, 1e-6, 1e-8, 1e-10]),
    "film_tol": ("lubrication", "film_tolerance", [1e-2, 1e-3, 1e-4, 1e-6]),
}
LIFE_KNOBS = {
    "n": ("window", "n", [32, 64, 128]),
    "block_M": ("life", "block_M", [1.0, 0.5, 0.25, 0.1]),
}
FIELDS = ("case", "level", "knob", "value", "default", "wall_s", "Ap_pct", "D_max", "wear_nm",
          "phi", "sub_blocks", "error")
K_LUB = 1e-11


def _doc(case: Case) -> dict:
    with open(ROOT / case.scene, "rb") as f:
        doc = tomllib.load(f)
    doc.setdefault("wear", {})["k_lub_s"] = [K_LUB]
    doc.setdefault("study", {})["patches"] = 1
    return doc


def _scene(doc: dict, case: Case, overrides: dict):
    d = {k: (dict(v) if isinstance(v, dict) else v) for k, v in doc.items()}
    for (section, key), value in overrides.items():
        d.setdefault(section, {})[key] = value
    scene = scene_from_dict(d, f"{case.scene} ({case.name} {overrides})")
    return scene, contact_study(scene)


def _surfaces(scene, study, reference):
    """The surfaces on this scene's grid: the reference realisation resampled, or (window
    sweep, ``reference`` None) the scene's own."""
    grid = window_grid(scene, reference_half_width(study))
    if reference is None:
        return tuple(body_surface(scene, i, grid) for i in (1, 2))
    return tuple(s.resampled(grid) for s in reference)


def _item(case, scene, study, reference) -> ItemRun:
    return ItemRun(scene, WorkItem(0, case.position, K_LUB, 1.0, 0), base=study,
                   surfaces=_surfaces(scene, study, reference))


def cycle_row(case, scene, study, reference) -> dict:
    """One load-cycle evaluation, reported as 1 M cycles at its rates (module docstring)."""
    t0 = time.perf_counter()
    run = _item(case, scene, study, reference)
    res = run.cycle.evaluate(run.surfaces)          # the initial surfaces: no pits yet
    wall = time.perf_counter() - t0
    n = 1e6
    ap = max(100.0 * float(((n * b.damage_rate) >= 1.0).any(axis=0).mean()) for b in res.bodies)
    dmax = max(float(n * b.damage_rate.max()) for b in res.bodies)
    # the relaxed integration of the rates (module docstring): the default implicit wear is
    # no function of one evaluation's rates (WearRate.depth refuses it)
    wear = max(float(b.wear.depth(n, "relaxed").mean()) for b in res.bodies)
    return dict(wall_s=wall, Ap_pct=ap, D_max=dmax, wear_nm=wear * 1e9, phi=res.phi,
                sub_blocks=1)


def life_row(case, scene, study, reference) -> dict:
    """1 M cycles of the life loop in blocks of the scene's ΔN."""
    t0 = time.perf_counter()
    run = _item(case, scene, study, reference)
    subs, phi = 0, 0.0
    while run.state.cycles < 1e6 * (1 - 1e-9):
        rec = run.run_block(min(run.life.block, 1e6 - run.state.cycles))
        subs += rec.sub_blocks
        phi = rec.phi
    wall = time.perf_counter() - t0
    return dict(wall_s=wall, Ap_pct=max(rec.Ap), D_max=max(rec.max_damage),
                wear_nm=max(rec.wear_mean) * 1e9, phi=phi, sub_blocks=subs)


def _done(path: Path) -> set:
    """The rows already in the CSV (a file of an older column set is rewritten with the
    current columns, the new ones empty)."""
    if not path.exists():
        return set()
    with open(path) as f:
        reader = csv.DictReader(f)
        rows, columns = list(reader), tuple(reader.fieldnames or ())
    if columns != FIELDS:
        with open(path, "w", newline="") as f:
            w = csv.DictWriter(f, FIELDS)
            w.writeheader()
            w.writerows({k: r.get(k, "") for k in FIELDS} for r in rows)
    return {(r["case"], r["level"], r["knob"], r["value"]) for r in rows}


def run(cases, levels, out: Path, knobs=None, grid_values=None) -> Path:
    """Run the rows of ``cases`` × ``levels`` not yet in OUT/speed_error.csv: every knob, or
    those named in ``knobs``; ``grid_values``: the cycle level's window.n values instead of
    CYCLE_KNOBS' (e.g. 64 … 1024 for the big-window line, docs/performance.md §10)."""
    out.mkdir(parents=True, exist_ok=True)
    path = out / "speed_error.csv"
    done = _done(path)
    new = not path.exists()
    with open(path, "a", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        if new:
            w.writeheader()
        for name in cases:
            case = CASES[name]
            doc = _doc(case)
            base, base_study = _scene(doc, case, {})
            ref_scene, ref_study = _scene(doc, case, {("window", "n"): REF_N})
            grid = window_grid(ref_scene, reference_half_width(ref_study))
            reference = tuple(body_surface(ref_scene, i, grid) for i in (1, 2))
            defaults = {"n": base.window.nx, "window": 1.0, "layers": base.stress.layers,
                        "steps": base.window.steps, "tol": base.lubrication.tol,
                        "film_tol": base.lubrication.film_tol, "block_M": base.life.block / 1e6}
            lx0 = window_grid(base, reference_half_width(base_study)).lx
            for level in levels:
                table_, row_fn = ((CYCLE_KNOBS, cycle_row) if level == "cycle"
                                  else (LIFE_KNOBS, life_row))
                if level == "cycle" and grid_values:
                    table_ = {**table_, "n": ("window", "n", list(grid_values))}
                for knob, (section, key, values) in table_.items():
                    if knobs and knob not in knobs:
                        continue
                    for v in values:
                        if (name, level, knob, str(v)) in done:
                            continue
                        over, ref = {(section, key): v}, reference
                        if level == "life" and knob != "n" and case.life_n is not None:
                            over[("window", "n")] = case.life_n
                        if knob == "window":
                            over = {(section, key): v * lx0 * 1e6,
                                    ("window", "n"): int(round(v * defaults["n"]))}
                            ref = None
                        scene, study = _scene(doc, case, over)
                        t0 = time.perf_counter()
                        try:
                            row = row_fn(case, scene, study, ref)
                        except MicropitError as e:     # a setting that does not work
                            row = dict(wall_s=time.perf_counter() - t0, Ap_pct=math.nan,
                                       D_max=math.nan, wear_nm=math.nan, phi=math.nan,
                                       sub_blocks=0, error=str(e).splitlines()[0][:200])
                        row.update(case=name, level=level, knob=knob, value=v,
                                   default=int(math.isclose(v, defaults[knob])))
                        w.writerow(row)
                        f.flush()
                        print(f"{name:6s} {level:5s} {knob:8s} {v!s:>7s}  {row['wall_s']:7.1f} s"
                              f"  A_p {row['Ap_pct']:6.2f} %  D_max {row['D_max']:.4g}"
                              f"  wear {row['wear_nm']:.4g} nm  φ {row['phi']:.3f}"
                              f"  subs {row['sub_blocks']}  {row.get('error', '')}", flush=True)
    return path


def _rows(path: Path) -> list[dict]:
    with open(path) as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k in ("wall_s", "Ap_pct", "D_max", "wear_nm", "phi"):
            r[k] = float(r[k])
        r["default"] = r["default"] == "1"
    return rows


def errors(rows: list[dict]) -> list[dict]:
    """Each row with its errors against its knob's finest value (the last in the knob list):
    A_p in points, D_max in decades (log10 of the ratio: the S–N line is exponential in the
    stress, so a 1 % stress error moves the damage by tens of per cent), wear relative."""
    out = []
    knob_lists = {("cycle", k): v[2] for k, v in CYCLE_KNOBS.items()}
    knob_lists.update({("life", k): v[2] for k, v in LIFE_KNOBS.items()})
    largest_n = {}      # the grid: its finest is the largest n run (--grid may extend it)
    for q in rows:
        if q["knob"] == "n":
            key = (q["case"], q["level"])
            largest_n[key] = max(largest_n.get(key, 0), int(float(q["value"])))
    for r in rows:
        finest = (str(largest_n[(r["case"], r["level"])]) if r["knob"] == "n"
                  else str(knob_lists[(r["level"], r["knob"])][-1]))
        ref = next((q for q in rows if (q["case"], q["level"], q["knob"], q["value"])
                    == (r["case"], r["level"], r["knob"], finest)), None)
        if ref is None:
            continue
        e = dict(r)
        e["err_Ap"] = r["Ap_pct"] - ref["Ap_pct"]
        e["err_D"] = (math.log10(r["D_max"] / ref["D_max"])
                      if r["D_max"] > 0 and ref["D_max"] > 0 else math.nan)
        e["err_wear"] = (r["wear_nm"] / ref["wear_nm"] - 1.0) if ref["wear_nm"] > 0 else math.nan
        e["ref_wall"] = ref["wall_s"]
        out.append(e)
    return out


def table(rows: list[dict]) -> str:
    """A Markdown table of every row with its errors (docs/performance.md)."""
    lines = ["| case | level | knob | value | wall [s] | A_p [%] | ΔA_p [pt] | D_max | "
             "ΔD_max [dec] | wear [nm] | Δwear |", "|" + "---|" * 11]
    for e in errors(rows):
        mark = " **(default)**" if e["default"] else ""
        if e.get("error"):
            lines.append(f"| {e['case']} | {e['level']} | {e['knob']} | {e['value']}{mark} | "
                         f"{e['wall_s']:.1f} | fails: {e['error']} |||||||")
            continue
        lines.append(f"| {e['case']} | {e['level']} | {e['knob']} | {e['value']}{mark} | "
                     f"{e['wall_s']:.1f} | {e['Ap_pct']:.2f} | {e['err_Ap']:+.2f} | "
                     f"{e['D_max']:.3g} | {e['err_D']:+.2f} | {e['wear_nm']:.3g} | "
                     f"{e['err_wear']:+.1%} |")
    return "\n".join(lines)


def plot(rows: list[dict], path: Path) -> None:
    """Error in A_p (points) against wall time, one panel per case and level, one line per
    knob (docs/performance.md)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    errs = errors(rows)
    cases = list(dict.fromkeys(e["case"] for e in errs))
    levels = list(dict.fromkeys(e["level"] for e in errs))
    fig, axes = plt.subplots(len(cases), len(levels), figsize=(5.0 * len(levels),
                                                             3.6 * len(cases)), squeeze=False)
    for ax, (case, level) in zip(axes.flat, [(c, lv) for c in cases for lv in levels],
                                 strict=True):
        for knob in dict.fromkeys(e["knob"] for e in errs
                                  if (e["case"], e["level"]) == (case, level)):
            es = [e for e in errs if (e["case"], e["level"], e["knob"]) == (case, level, knob)]
            x = [e["wall_s"] for e in es]
            y = [abs(e["err_Ap"]) + 1e-3 for e in es]
            ax.plot(x, y, "o-", label=knob)
            for e, xi, yi in zip(es, x, y, strict=True):
                ax.annotate(str(e["value"]), (xi, yi), fontsize=6,
                            fontweight="bold" if e["default"] else "normal")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time, one core [s]")
        ax.set_ylabel("|A_p − A_p,finest| + 0.001 [points]")
        ax.set_title(f"{case}, {level} level", fontsize=9)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="mpr,gear3,gear5")
    ap.add_argument("--levels", default="cycle,life")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    ap.add_argument("--plot", type=Path, default=ROOT / "docs" / "performance_speed_error.png")
    ap.add_argument("--knobs", default="", help="only these knobs (comma-separated)")
    ap.add_argument("--grid", default="",
                    help="the cycle level's window.n values, finest last (comma-separated)")
    ap.add_argument("--table-only", action="store_true",
                    help="run nothing: the table and plot of OUT/speed_error.csv as it is")
    args = ap.parse_args()
    cases = [c for c in args.cases.split(",") if c]
    for c in cases:
        if c not in CASES:
            ap.error(f"--cases: {c!r} is not one of {', '.join(CASES)}")
    levels = [lv for lv in args.levels.split(",") if lv]
    for lv in levels:
        if lv not in ("cycle", "life"):
            ap.error(f"--levels: {lv!r} is not one of cycle, life")
    print(f"# speed against error, commit {source_commit()}, one core; "
          f"{time.strftime('%Y-%m-%d')}", flush=True)
    knobs = [k for k in args.knobs.split(",") if k]
    grid = [int(v) for v in args.grid.split(",") if v]
    path = (args.out / "speed_error.csv" if args.table_only
            else run(cases, levels, args.out, knobs, grid))
    rows = _rows(path)
    print(table(rows))
    plot(rows, args.plot)
    print(f"wrote {path} and {args.plot}")


if __name__ == "__main__":
    main()
