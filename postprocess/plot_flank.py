"""A flank study at a glance, like the paper's Fig. 8: A_p of the driver (body 1) and the driven
gear (body 2) at the end of the life against the roll angle of the driver, one line per wear
coefficient; below, the maximum Hertz pressure p0 on its own axis, and the ratios S, Λ and the
ISO/TS 6336-22 Method B λ_GF (along the whole path, with λ_GF,min and the permissible λ_GFP
when the oil's rating is given) on another. Every panel marks the points A–E of the path of
contact and shades the single-pair zone B–D.
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

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from micropit_hpc.errors import MicropitError
from micropit_hpc.io.results import Results, load_results


def path_data(run: Path | Results) -> dict:
    """The path of contact and Method B of a run: roll angles of A–E [deg] (empty for older
    results), λ_GF along the path, λ_GF,min, λ_GFP and S_λ (NaN when not known)."""
    out = {"points": {}, "roll_deg": np.array([]), "lambda_GF": np.array([]),
           "lambda_GF_min": math.nan, "lambda_GFP": math.nan, "S_lambda": math.nan}
    res = run if isinstance(run, Results) else load_results(run)
    if res.path_points:
        out["points"] = {k: math.degrees(v) for k, v in res.path_points.items()}
    iso = res.iso6336_22
    if iso is not None:
        out["roll_deg"] = np.degrees(iso.roll_angle)
        out["lambda_GF"] = iso.lambda_GF
        for k in ("lambda_GF_min", "lambda_GFP", "S_lambda"):
            out[k] = float(getattr(iso, k))
    return out


def flank_table(run: Path | Results) -> list[dict]:
    """One row per (position, k_lub): roll angle, S, p0, Λ, λ_GF (mean over patches), λ_GFP
    and λ_GF/λ_GFP, the pair zone, A_p of each body (mean, min, max over patches and
    roughness scales) at the last block. ``run``: a run folder or its loaded results."""
    res = run if isinstance(run, Results) else load_results(run)
    it = dict(res.items)
    gfp = res.iso6336_22.lambda_GFP if res.iso6336_22 is not None else math.nan
    if "roll_angle" not in it or np.all(np.isnan(it["roll_angle"])):
        raise SystemExit(f"{res.file} is not a gear flank study (no roll angles); "
                         "use postprocess/plot_life.py")
    final = {int(i): res.history[int(i)]["Ap"][-1] for i in it["id"]}
    cycles = {int(i): res.history[int(i)]["cycles"][-1] for i in it["id"]}
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
            "lambda_GFP": gfp,
            "S_lambda": float(np.mean([it["lambda_GF"][k] for k in ks])) / gfp
            if "lambda_GF" in it else math.nan,
            "region": ("single" if it["single_pair"][k0] else "double")
            if "single_pair" in it else "",
            "k_lub_s": klub, "samples": len(ks),
            "cycles_M": float(cycles[int(it["id"][k0])]) / 1e6,
            "Ap1_pct": float(ap[:, 0].mean()), "Ap1_min": float(ap[:, 0].min()),
            "Ap1_max": float(ap[:, 0].max()), "Ap2_pct": float(ap[:, 1].mean()),
            "Ap2_min": float(ap[:, 1].min()), "Ap2_max": float(ap[:, 1].max())})
    return rows


def mark_path(ax, points: dict, labels: bool = False) -> None:
    """A–E as thin vertical lines (named along the top when ``labels``) and the single-pair
    zone B–D shaded."""
    if not points:
        return
    ax.axvspan(points["B"], points["D"], color="0.9", zorder=0,
               label="single-pair zone B–D" if labels else None)
    for k, x in points.items():
        ax.axvline(x, color="0.55", lw=0.7, zorder=1)
        if labels:
            ax.annotate(k, (x, 1.0), xycoords=("data", "axes fraction"), xytext=(0, 2),
                        textcoords="offset points", ha="center", va="bottom", fontsize=9,
                        fontweight="bold")


def plot(rows: list[dict], out: Path, title: str, path: dict | None = None) -> None:
    path = path or {"points": {}, "roll_deg": np.array([]), "lambda_GF": np.array([]),
                    "lambda_GF_min": math.nan, "lambda_GFP": math.nan, "S_lambda": math.nan}
    fig, axes = plt.subplots(4, 1, figsize=(8.5, 11.5), sharex=True,
                             gridspec_kw={"height_ratios": [1.3, 1.3, 0.8, 1.2]})
    a1, a2, ap0, arat = axes
    pts = path["points"]
    by_k: dict[float, list[dict]] = defaultdict(list)
    for r in rows:
        by_k[r["k_lub_s"]].append(r)
    for body, ax in ((1, a1), (2, a2)):
        mark_path(ax, pts, labels=body == 1)
        for klub, rs in sorted(by_k.items()):
            x = [r["roll_angle_deg"] for r in rs]
            y = np.array([r[f"Ap{body}_pct"] for r in rs])
            lo = y - np.array([r[f"Ap{body}_min"] for r in rs])
            hi = np.array([r[f"Ap{body}_max"] for r in rs]) - y
            ax.errorbar(x, y, yerr=[lo, hi], marker="o", capsize=3, zorder=3,
                        label=f"k_lub = {klub:g} s")
        ax.set_ylabel(f"A_p body {body} [%]\n({'driver' if body == 1 else 'driven'})")
        top = max((r[f"Ap{body}_max"] for r in rows), default=0.0)
        ax.set_ylim(0, 1.12 * top if top > 0 else 1.0)     # room above the highest mark
        ax.grid(alpha=0.3)
    a1.legend(fontsize=8, loc="best")
    xs = [r["roll_angle_deg"] for r in rows]
    mark_path(ap0, pts)
    ap0.plot(xs, [r["p0_GPa"] for r in rows], "ko-", lw=1, ms=4, label="p0")
    ap0.set_ylabel("p0 [GPa]")
    ap0.set_ylim(bottom=0)
    ap0.grid(alpha=0.3)
    mark_path(arat, pts)
    arat.axhline(0.0, color="k", lw=0.6)
    arat.plot(xs, [r["S"] for r in rows], "s:", color="tab:gray", ms=4, label="S (slide-roll)")
    arat.plot(xs, [r["Lambda"] for r in rows], "^-.", color="tab:cyan", ms=4,
              label="Λ = h_c/R_q")
    if path["roll_deg"].size:
        ok = np.isfinite(path["lambda_GF"])
        arat.plot(path["roll_deg"][ok], path["lambda_GF"][ok], "-", color="tab:purple", lw=1.2,
                  label="λ_GF along the path (ISO/TS 6336-22 B)")
    arat.plot(xs, [r["lambda_GF"] for r in rows], "o", color="tab:purple", ms=4,
              label="λ_GF of the items (their surfaces' R_a)")
    if math.isfinite(path["lambda_GF_min"]):
        k = int(np.nanargmin(np.where(np.isfinite(path["lambda_GF"]), path["lambda_GF"],
                                      np.inf)))
        arat.plot(path["roll_deg"][k], path["lambda_GF_min"], "v", color="tab:purple", ms=8,
                  label=f"λ_GF,min = {path['lambda_GF_min']:.3g}")
    if math.isfinite(path["lambda_GFP"]):
        arat.axhline(path["lambda_GFP"], color="tab:red", ls="--", lw=1.2,
                     label=f"λ_GFP = {path['lambda_GFP']:.3g} (S_λ = "
                           f"{path['S_lambda']:.3g})")
    finite = [v for r in rows for v in (r["S"], r["Lambda"], r["lambda_GF"])
              if math.isfinite(v)]
    finite += [v for v in (path["lambda_GFP"], path["lambda_GF_min"]) if math.isfinite(v)]
    if finite:                                   # the film is infinite where the load is zero
        top = 1.15 * max(np.percentile(np.abs(finite), 95), path["lambda_GFP"]
                         if math.isfinite(path["lambda_GFP"]) else 0)
        arat.set_ylim(min(-0.05, 1.15 * min(finite)), top)
    arat.set_ylabel("S, Λ, λ_GF [-]")
    arat.grid(alpha=0.3)
    arat.set_xlabel("roll angle of the driver [deg]")
    arat.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.28), ncol=3,
                frameon=False)
    a1.set_title(title, pad=16)
    if pts:
        fig.text(0.5, 0.005, "A start of active profile · B lowest / D highest point of single "
                 "contact · C pitch point · E tip of the driver", ha="center", fontsize=7)
    fig.tight_layout(rect=(0, 0.015, 1, 1))
    fig.subplots_adjust(bottom=0.11)
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
    try:
        res = load_results(a.run)
    except MicropitError as e:
        print(f"plot_flank: {e}", file=sys.stderr)
        return 2
    rows = flank_table(res)
    out = a.out or a.run / "flank.png"
    cycles = max(r["cycles_M"] for r in rows)
    plot(rows, out, f"{a.run.name}: micropitted area after {cycles:g} M cycles",
         path_data(res))
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
