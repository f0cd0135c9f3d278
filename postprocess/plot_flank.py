"""A flank study at a glance, like the paper's Fig. 8: A_p of the driver (body 1) and the driven
gear (body 2) at the end of the life against the roll angle of the driver, one line per wear
coefficient, with the maximum Hertz pressure p0, the slide-roll ratio S, Λ and the ISO/TS
6336-22 Method B style λ_GF on a second axis.
Where a position has several roughness patches (or scales), the mark is their mean and the bar
their range. Also writes the table of the plot (flank.csv) and prints it.

    python postprocess/plot_flank.py RUN_DIR [--out RUN_DIR/flank.png]
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from collections import defaultdict
from pathlib import Path

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np


def flank_table(run: Path) -> list[dict]:
    """One row per (position, k_lub): roll angle, S, p0, Λ, λ_GF (mean over patches), the
    pair zone, A_p of each body (mean, min, max over patches and roughness scales) at the
    last block."""
    with h5py.File(run / "results.h5", "r") as f:
        it = {k: f[f"items/{k}"][()] for k in f["items"]}
        if "roll_angle" not in it or np.all(np.isnan(it["roll_angle"])):
            raise SystemExit(f"{run}/results.h5 is not a gear flank study (no roll angles); "
                             "use postprocess/plot_life.py")
        final = {int(i): f[f"history/item_{int(i):05d}/Ap"][-1] for i in it["id"]}
        cycles = {int(i): f[f"history/item_{int(i):05d}/cycles"][-1] for i in it["id"]}
    groups: dict[tuple, list[int]] = defaultdict(list)
    for k in range(len(it["id"])):
        groups[(int(it["position"][k]), float(it["k_lub"][k]))].append(k)
    rows = []
    for (pos, klub), ks in sorted(groups.items()):
        k0 = ks[0]
        ap = np.array([final[int(it["id"][k])] for k in ks])          # (n, 2 bodies)
        rows.append({
            "position": pos, "roll_angle_deg": math.degrees(float(it["roll_angle"][k0])),
            "S": float(it["S"][k0]), "p0_GPa": float(it["p0"][k0]) / 1e9,
            "Lambda": float(it["Lambda"][k0]),
            "lambda_GF": float(np.mean([it["lambda_GF"][k] for k in ks]))
            if "lambda_GF" in it else math.nan,
            "region": ("single" if it["single_pair"][k0] else "double")
            if "single_pair" in it else "",
            "k_lub_s": klub, "samples": len(ks),
            "cycles_M": float(cycles[int(it["id"][k0])]) / 1e6,
            "Ap1_pct": float(ap[:, 0].mean()), "Ap1_min": float(ap[:, 0].min()),
            "Ap1_max": float(ap[:, 0].max()), "Ap2_pct": float(ap[:, 1].mean()),
            "Ap2_min": float(ap[:, 1].min()), "Ap2_max": float(ap[:, 1].max())})
    return rows


def plot(rows: list[dict], out: Path, title: str) -> None:
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 7.5), sharex=True)
    by_k: dict[float, list[dict]] = defaultdict(list)
    for r in rows:
        by_k[r["k_lub_s"]].append(r)
    for body, ax in ((1, a1), (2, a2)):
        for klub, rs in sorted(by_k.items()):
            x = [r["roll_angle_deg"] for r in rs]
            y = np.array([r[f"Ap{body}_pct"] for r in rs])
            lo = y - np.array([r[f"Ap{body}_min"] for r in rs])
            hi = np.array([r[f"Ap{body}_max"] for r in rs]) - y
            ax.errorbar(x, y, yerr=[lo, hi], marker="o", capsize=3,
                        label=f"k_lub = {klub:g} s")
        ax.set_ylabel(f"A_p body {body} [%]  ({'driver' if body == 1 else 'driven'})")
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        tw = ax.twinx()
        xs = [r["roll_angle_deg"] for r in rows]
        tw.plot(xs, [r["p0_GPa"] for r in rows], "k--", lw=1, label="p0 [GPa]")
        tw.plot(xs, [r["S"] for r in rows], "k:", lw=1, label="S")
        tw.plot(xs, [r["Lambda"] for r in rows], "c-.", lw=1, label="Λ")
        tw.plot(xs, [r["lambda_GF"] for r in rows], "m-.", lw=1, label="λ_GF (ISO/TS 6336-22 B)")
        tw.set_ylabel("p0 [GPa], S, Λ, λ_GF")
        if body == 1:
            h1, l1 = ax.get_legend_handles_labels()
            h2, l2 = tw.get_legend_handles_labels()
            fig.legend(h1 + h2, l1 + l2, fontsize=8, loc="lower center", ncol=4)
    a2.set_xlabel("roll angle of the driver [deg]")
    a1.set_title(title)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    fig.savefig(out, dpi=120)
    plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path, help="the --out folder of `micropit run`")
    ap.add_argument("--out", type=Path, default=None, help="figure (default RUN/flank.png)")
    a = ap.parse_args()
    if not (a.run / "results.h5").is_file():
        print(f"plot_flank: no {a.run}/results.h5 (run `micropit run SCENE --out {a.run}`)",
              file=sys.stderr)
        return 2
    rows = flank_table(a.run)
    out = a.out or a.run / "flank.png"
    cycles = max(r["cycles_M"] for r in rows)
    plot(rows, out, f"{a.run.name}: micropitted area after {cycles:g} M cycles")
    table = a.run / "flank.csv"
    with open(table, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"{'pos':>3} {'roll°':>6} {'S':>7} {'p0 GPa':>6} {'Λ':>5} {'λ_GF':>5} {'k_lub s':>8} "
          f"{'A_p1 %':>7} {'A_p2 %':>7}")
    for r in rows:
        print(f"{r['position']:>3} {r['roll_angle_deg']:6.2f} {r['S']:7.3f} {r['p0_GPa']:6.3f} "
              f"{r['Lambda']:5.3f} {r['lambda_GF']:5.3f} {r['k_lub_s']:8.2g} "
              f"{r['Ap1_pct']:7.2f} {r['Ap2_pct']:7.2f}")
    print(f"wrote {out} and {table}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
