"""Compare `micropit run` results of the MPR scenes with the paper (docs/model.md §7, trends 1, 7).

    python postprocess/paper_mpr.py mpr RUN_DIR      # scenes/paper_mpr.toml: A_p vs |S|
    python postprocess/paper_mpr.py table9 RUN_DIR   # scenes/paper_mpr_table9.toml: Λ scaling

Reads RUN_DIR/summary.csv (body 1 = the test roller, where the paper measures A_p), writes the
side-by-side table RUN_DIR/mpr_comparison.csv or RUN_DIR/table9_comparison.csv with the paper's
validation/ numbers, prints it and the trend verdicts. Exit status 0 when every trend holds,
1 otherwise (the table is written either way).
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _rows(run: Path) -> list[dict]:
    with open(run / "summary.csv", newline="") as fh:
        return [r for r in csv.DictReader(fh) if r["body"] == "1"]


def _ap(rows, **match) -> float | None:
    for r in rows:
        if all(abs(float(r[k]) - v) <= 1e-9 * max(1.0, abs(v)) for k, v in match.items()):
            return float(r["Ap_pct"])
    return None


def _r(values, digits: int = 4) -> str:
    """A list of A_p (or Λ) values for a verdict line."""
    return "[" + ", ".join("—" if v is None else f"{v:.{digits}g}" for v in values) + "]"


def _write(path: Path, header, table) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows(table)
    print(",".join(header))
    for t in table:
        print(",".join(str(x) for x in t))


def mpr(run: Path, say=print) -> bool:
    """Trend 1 on the run of scenes/paper_mpr*.toml; ``say`` gets each verdict line."""
    rows = _rows(run)
    paper = list(csv.DictReader(open(ROOT / "validation" / "mpr_triple_disc_Ap.csv")))
    table, ours = [], {}
    for p in paper:
        s, n = float(p["abs_S"]), float(p["cycles_million"]) * 1e6
        ap = next((float(r["Ap_pct"]) for r in rows if abs(abs(float(r["S"])) - s) < 1e-9
                   and abs(float(r["cycles"]) - n) < 1.0), None)
        ours[(s, n)] = ap
        table.append([s, p["cycles_million"], p["Ap_experiment_pct"], p["Ap_model_pct"],
                      "" if ap is None else f"{ap:.4g}"])
    _write(run / "mpr_comparison.csv",
           ["abs_S", "cycles_million", "Ap_experiment_pct", "Ap_paper_model_pct", "Ap_ours_pct"],
           table)
    ok = True
    for n in (6e6, 10e6):
        a = [ours.get((s, n)) for s in (0.05, 0.15, 0.3)]
        holds = None not in a and a[0] < a[1] < a[2]
        ok &= holds
        say(f"trend 1 at {n / 1e6:g} M: A_p(0.05) < A_p(0.15) < A_p(0.30): {_r(a)} -> "
            f"{'holds' if holds else 'FAILS'}")
    for s in (0.05, 0.15, 0.3):
        a6, a10 = ours.get((s, 6e6)), ours.get((s, 10e6))
        holds = None not in (a6, a10) and a10 >= a6
        ok &= holds
        say(f"trend 1: A_p(10 M) >= A_p(6 M) at |S| = {s}: {_r([a6])} -> {_r([a10])}: "
            f"{'holds' if holds else 'FAILS'}")
    return ok


def bracket(run15: Path, run30: Path, say=print) -> tuple[bool, list[list]]:
    """Whether the paper's model A_p at 6 M (and 10 M) lies between our results of the two
    surface variants (β_x = 15 and 30 µm) at each |S| (docs/validation/README.md); returns the
    verdict and the table rows (|S|, cycles, experiment, paper's model, ours β15, ours β30,
    inside?)."""
    paper = list(csv.DictReader(open(ROOT / "validation" / "mpr_triple_disc_Ap.csv")))
    r15, r30 = _rows(run15), _rows(run30)
    table, ok = [], True
    for p in paper:
        s, n = float(p["abs_S"]), float(p["cycles_million"]) * 1e6
        a, b = (next((float(r["Ap_pct"]) for r in rows if abs(abs(float(r["S"])) - s) < 1e-9
                      and abs(float(r["cycles"]) - n) < 1.0), None) for rows in (r15, r30))
        model = float(p["Ap_model_pct"])
        inside = None not in (a, b) and min(a, b) <= model <= max(a, b)
        if n == 6e6:
            ok &= inside
        table.append([s, p["cycles_million"], p["Ap_experiment_pct"], p["Ap_model_pct"],
                      "" if a is None else f"{a:.4g}", "" if b is None else f"{b:.4g}",
                      "yes" if inside else "no"])
    six = [t for t in table if t[1] == "6"]
    say("the paper's model between β_x = 15 and 30 µm at 6 M: " + ", ".join(
        f"|S| {t[0]}: {t[3]} in [{t[4] or '—'}, {t[5] or '—'}] {t[6]}" for t in six)
        + f" -> {'holds' if ok else 'FAILS'}")
    return ok, table


def table9(run: Path, say=print) -> bool:
    """Trend 7 on the run of scenes/paper_mpr_table9*.toml; ``say`` gets each verdict line."""
    rows = _rows(run)
    n_end = max(float(r["cycles"]) for r in rows)
    end = [r for r in rows if float(r["cycles"]) == n_end]
    paper = list(csv.DictReader(open(ROOT / "validation" / "table9_Lambda_scaling_MPR.csv")))
    lams = sorted({float(r["Lambda"]) for r in end})
    table, res = [], {0.0: [], 1e-11: []}
    for p, lam in zip(paper, lams, strict=False):
        a0 = next(float(r["Ap_pct"]) for r in end
                  if float(r["Lambda"]) == lam and float(r["k_lub_s"]) == 0.0)
        a1 = next((float(r["Ap_pct"]) for r in end
                   if float(r["Lambda"]) == lam and float(r["k_lub_s"]) == 1e-11), None)
        res[0.0].append(a0)
        res[1e-11].append(a1)
        table.append([p["Lambda"], f"{lam:.4g}", p["Ap_pct_klub0"], f"{a0:.4g}",
                      p["Ap_pct_klub1e-11"], "" if a1 is None else f"{a1:.4g}"])
    _write(run / "table9_comparison.csv",
           ["Lambda_paper", "Lambda_ours", "Ap_paper_klub0_pct", "Ap_ours_klub0_pct",
            "Ap_paper_klub1e-11_pct", "Ap_ours_klub1e-11_pct"], table)
    a = res[0.0]
    t0 = a[0] > a[1] > a[2]
    say(f"trend 7 at {n_end / 1e6:g} M, k_lub = 0: A_p rises as Λ falls (Λ = "
        f"{_r(lams, 3)}): {_r(a)} -> {'holds' if t0 else 'FAILS'}")
    b = res[1e-11]
    t1 = None not in b and b[1] > b[0] and b[1] > b[2]
    say(f"trend 7 at {n_end / 1e6:g} M, k_lub = 1e-11 s: A_p rises then falls as Λ falls "
        f"(largest at the middle Λ): {_r(b)} -> {'holds' if t1 else 'FAILS'}")
    say(f"wear cuts A_p by {_cuts(a, b)} at Λ = {_r(lams, 3)} (paper: "
        f"{_cuts(*([float(p[c]) for p in paper] for c in ('Ap_pct_klub0', 'Ap_pct_klub1e-11')))})")
    return t0 and t1


def _cuts(without, with_wear) -> str:
    """A_p without wear over A_p with wear, per Λ (informative; not a trend of docs/model.md §7)."""
    def cut(a, b):
        if a is None or b is None:
            return "—"
        return "∞" if b == 0 else f"{a / b:.3g}×"
    return "[" + ", ".join(cut(a, b) for a, b in zip(without, with_wear, strict=True)) + "]"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("which", choices=("mpr", "table9"))
    ap.add_argument("run", type=Path, help="the run folder with summary.csv")
    a = ap.parse_args()
    ok = mpr(a.run) if a.which == "mpr" else table9(a.run)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
