"""The validation report: our numbers beside the paper's and one PASS/FAIL line for each trend of
docs/model.md §7, from the runs of ``bash scripts/validate.sh``.

    python postprocess/validation_report.py [--runs runs] [--out docs/validation]

Reads RUNS/<scene>/ of the MPR scenes (paper_mpr, paper_mpr_table9 and their _beta30 variants)
and of the gear scenes (paper_gear_z23, paper_gear_z23_table5, paper_gear_z23_table8,
paper_gear_z18), each run as written (the converged default: adaptive blocks with the implicit
wear), which decides every trend, and RUNS/<scene>_paper/, its literal twin (the paper's
numerics, ``life.integration = "paper"``, scripts/paper-scene.sh), given beside each trend,
and RUNS/paper_gear_z23_beta<B>/ (scripts/slope-scene.sh), the gear trends' sensitivity to the
flanks' slope; writes OUT/README.md (the report), the figures (flank.png like the paper's Fig. 8,
damage_maps.png like its Fig. 9, the MPR life plots) and the side-by-side tables
(table4_ours_vs_paper.csv, table5_…, table8_…, mpr_…, table9_…; the twin's with ``_paper``).
A missing default run is reported as missing and its trends as FAIL; a missing twin run is
reported as missing, nothing more. Exit status 0 when every trend passes on the default runs,
1 otherwise.
"""

from __future__ import annotations

import argparse
import csv
import datetime as dt
import json
import math
import shutil
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import ListedColormap

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT))

import paper_mpr  # noqa: E402
import plot_flank  # noqa: E402

from micropit_hpc import describe_source  # noqa: E402
from micropit_hpc.errors import MicropitError  # noqa: E402
from micropit_hpc.io.results import load_results  # noqa: E402
from micropit_hpc.scene import scene_from_dict  # noqa: E402
from micropit_hpc.trends import (  # noqa: E402
    FlankPoint,
    Verdict,
    trend2,
    trend3,
    trend4,
    trend5,
    trend6,
)

VALIDATION = ROOT / "validation"
GEAR_SCENES = ("paper_gear_z23", "paper_gear_z23_table5", "paper_gear_z23_table8",
               "paper_gear_z18")
MPR_SCENES = ("paper_mpr", "paper_mpr_beta30", "paper_mpr_table9", "paper_mpr_table9_beta30")
K_LUB = (0.0, 1e-11, 5e-11)
#: β_x [µm] of the gear trends' sensitivity to the slope (scripts/validate.sh SLOPES, beside the
#: scene's own SCENE_BETA_UM).
SLOPE_BETAS_UM = (15.0, 30.0, 60.0, 120.0)
SCENE_BETA_UM = 30.0
#: The run folders' suffix of each scheme: the scene as written (the converged default, which
#: decides the trends) and its literal twin (scripts/paper-scene.sh), given beside it.
SCHEMES = {"": "converged default", "_paper": "the paper's literal numerics"}
TREND_WORDS = {
    1: "MPR rig, k_lub = 0: A_p rises with |S| at 6 M and 10 M; A_p(10 M) ≥ A_p(6 M)",
    2: "gear, k_lub = 0: A_p = 0 at the pitch, rising through the single-pair zone, no further "
       "rise in the double-pair zones",
    3: "gear, k_lub = 1e-11 s: below k_lub = 0 away from the pitch, largest in the single-pair "
       "zone next to the pitch, lower towards tip and root",
    4: "gear, k_lub = 5e-11 s: the lowest A_p everywhere, flat along the flank",
    5: "S fixed at ±0.044 (Table 5): single-pair zone above the double-pair zones",
    6: "z = 18 vs z = 23 at 0.7 m below the tip (Table 8): more A_p on z = 18 without wear, "
       "less with wear",
    7: "Λ scaling (Table 9): without wear A_p rises as Λ falls; with k_lub = 1e-11 s it rises "
       "and then falls",
}


def _read(name: str) -> list[dict]:
    with open(VALIDATION / name, newline="") as fh:
        return list(csv.DictReader(fh))


def _write_csv(path: Path, rows: list[dict]) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def _process_length_um(scene_json: str, recorded: float | None = None) -> str:
    """The Dang Van criterion's process length ℓ [µm] a run used (``fatigue.process_length_um``
    or its integration's default, docs/life.md): the ``process_length_m`` its results recorded,
    else (results older than that attribute) read from the scene document they carry."""
    if recorded is not None:
        return f"{float(recorded) * 1e6:.3g}"
    try:
        scene = scene_from_dict(json.loads(scene_json), "results.h5")
    except (ValueError, MicropitError):      # a run of older code whose scene no longer loads
        return "?"
    return f"{scene.fatigue.process_length * 1e6:.3g}"


def _run_info(run: Path) -> dict:
    res = load_results(run)
    a = res.attrs
    return {"wall_s": float(a.get("wall_s", math.nan)), "ranks": int(a.get("ranks", 0)),
            "ell_um": _process_length_um(str(a.get("scene", "{}")), a.get("process_length_m")),
            "status": str(a.get("status", "?")), "items": res.items.rows,
            "restarted": int(a.get("restarted_from_block", 0)),
            "created": str(a.get("created_utc", "?"))[:16].replace("T", " "),
            "commit": str(a.get("source_commit", "")) or "not recorded",
            "item_s": float(sum(np.nansum(res.history[int(i)]["wall_s"])
                                for i in res.items["id"]))}


def _points(rows: list[dict], k_lub: float, body: int) -> list[FlankPoint]:
    return [FlankPoint(r["position"], r["S"], r["region"] == "single", r[f"Ap{body}_pct"])
            for r in rows if abs(r["k_lub_s"] - k_lub) <= 1e-20]


def _spread(r: dict, body: int) -> str:
    lo, hi = r[f"Ap{body}_min"], r[f"Ap{body}_max"]
    return f"{r[f'Ap{body}_pct']:.3g}" + (f" ({lo:.3g}–{hi:.3g})" if hi > lo else "")


def _md_table(header: list[str], rows: list[list]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return out


def _roll_key(deg: float) -> float:
    return round(deg, 1)


def gear_flank(runs: Path, out: Path, md: list[str], suffix: str = "") -> list[Verdict]:
    """Table 4 and trends 2–4 from the paper_gear_z23 run; Fig. 8 and Fig. 9 style figures.
    ``suffix``: "" for the scene's run, "_paper" for its literal twin (files likewise)."""
    run = runs / f"paper_gear_z23{suffix}"
    if not (run / "results.h5").is_file():
        md.append(f"*Missing: {run}/results.h5.*")
        return [Verdict(t, False, "run missing") for t in (2, 3, 4)]
    rows = plot_flank.flank_table(run)
    cycles = max(r["cycles_M"] for r in rows)
    plot_flank.plot(rows, out / f"flank{suffix}.png", f"paper_gear_z23{suffix}: A_p after "
                    f"{cycles:g} M cycles (bars: range over roughness patches)")
    damage_maps(run, out / f"damage_maps{suffix}.png")
    paper = {_roll_key(float(p["roll_angle_deg"])): p for p in _read(
        "table4_Ap_along_flank_z23.csv")}
    side, table = [], []
    for r in rows:
        p = paper.get(_roll_key(r["roll_angle_deg"]))
        k = {0.0: "0", 1e-11: "1e-11", 5e-11: "5e-11"}.get(r["k_lub_s"])
        side.append({"position": r["position"], "roll_angle_deg": f"{r['roll_angle_deg']:.2f}",
                     "S": f"{r['S']:.3f}", "p0_GPa": f"{r['p0_GPa']:.3f}",
                     "Lambda": f"{r['Lambda']:.3f}", "lambda_GF": f"{r['lambda_GF']:.3f}",
                     "k_lub_s": f"{r['k_lub_s']:g}",
                     "Ap_driver_ours": f"{r['Ap1_pct']:.3g}",
                     "Ap_driver_paper": p[f"Ap_pct_klub{k}_driver"] if p and k else "",
                     "Ap_driven_ours": f"{r['Ap2_pct']:.3g}",
                     "Ap_driven_paper": p[f"Ap_pct_klub{k}_driven"] if p and k else "",
                     "Ap_driver_range": f"{r['Ap1_min']:.3g}-{r['Ap1_max']:.3g}",
                     "Ap_driven_range": f"{r['Ap2_min']:.3g}-{r['Ap2_max']:.3g}",
                     "patches": r["samples"]})
    _write_csv(out / f"table4_ours_vs_paper{suffix}.csv", side)
    md += ["", f"![A_p along the flank](flank{suffix}.png)", "",
           "Driver / driven A_p [%] after the last block: ours (mean over patches, range in "
           "brackets) against the paper's Table 4.", ""]
    by_pos: dict[int, dict] = {}
    for s in side:
        by_pos.setdefault(s["position"], {}).update({s["k_lub_s"]: s, "row": s})
    for pos, d in sorted(by_pos.items()):
        row = d["row"]
        line = [pos, row["roll_angle_deg"], row["S"], row["p0_GPa"], row["Lambda"],
                row["lambda_GF"]]
        for k in K_LUB:
            s = d.get(f"{k:g}")
            line.append("" if s is None else
                        f"{s['Ap_driver_ours']} / {s['Ap_driven_ours']} "
                        f"({s['Ap_driver_paper']} / {s['Ap_driven_paper']})")
        table.append(line)
    md += _md_table(["pos", "roll °", "S", "p0 GPa", "Λ", "λ_GF",
                     "k_lub 0: ours (paper)", "1e-11 s: ours (paper)", "5e-11 s: ours (paper)"],
                    table)
    md += ["", f"![damage-risk maps of the driver](damage_maps{suffix}.png)", ""]
    md += _flags_line(run)
    md += pair_slope_line(load_results(run))
    spread_lines = []
    for r in rows:
        if r["samples"] > 1 and r["position"] in (2, 4, 5, 8, 10):
            spread_lines.append(f"position {r['position']}, k_lub {r['k_lub_s']:g} s: driver "
                                f"{_spread(r, 1)}, driven {_spread(r, 2)}")
    if spread_lines:
        md += ["Roughness sampling (mean and range over the patches), a sample:", ""]
        md += [f"* {s}" for s in spread_lines[:8]]
    return flank_verdicts(rows)


def flank_verdicts(rows: list[dict]) -> list[Verdict]:
    """Trends 2–4 of a z = 23 flank study (rows of :func:`plot_flank.flank_table`), driver and
    driven, one verdict per trend."""
    verdicts = []
    for body in (1, 2):
        k0, k1, k5 = (_points(rows, k, body) for k in K_LUB)
        name = "driver" if body == 1 else "driven"
        for v in (trend2(k0), trend3(k0, k1), trend4(k1, k5)):
            verdicts.append(Verdict(v.trend, v.holds, f"{name}: {v.text}"))
    return _merge(verdicts)


def _merge(verdicts: list[Verdict]) -> list[Verdict]:
    """One verdict per trend: passes when every part passes."""
    out = []
    for t in sorted({v.trend for v in verdicts}):
        parts = [v for v in verdicts if v.trend == t]
        out.append(Verdict(t, all(v.holds for v in parts), " | ".join(v.text for v in parts)))
    return out


def damage_maps(run: Path, path: Path) -> None:
    """Damage risk (max over depth of D, pits red) of the driver at five positions and every
    wear coefficient, patch 0, like the paper's Fig. 9."""
    res = load_results(run)
    it = dict(res.items)
    pos = sorted(set(int(p) for p in it["position"]))
    show = [p for p in (2, 4, 6, 8, 10) if p in pos] or pos[:5]
    ks = sorted(set(float(k) for k in it["k_lub"]))
    fig, axes = plt.subplots(len(ks), len(show), figsize=(2.4 * len(show), 2.3 * len(ks)),
                             squeeze=False)
    dx, dy = res.grid.dx, res.grid.dy
    for i, k in enumerate(ks):
        for j, p in enumerate(show):
            ax = axes[i, j]
            sel = np.flatnonzero((it["position"] == p) & (it["k_lub"] == k)
                                 & (it["patch"] == 0))
            ax.set_xticks([])
            ax.set_yticks([])
            if not sel.size:
                continue
            m = res.maps(int(it["id"][sel[0]]), 1, "damage_risk", "pitted")
            risk, pitted = m["damage_risk"], m["pitted"].astype(bool)
            ext = (0, risk.shape[1] * dy * 1e6, 0, risk.shape[0] * dx * 1e6)
            im = ax.imshow(np.clip(risk, 0, 1), origin="lower", extent=ext, cmap="viridis",
                           vmin=0, vmax=1, aspect="auto")
            ax.imshow(np.ma.masked_where(~pitted, pitted), origin="lower", extent=ext,
                      cmap=ListedColormap(["red"]), aspect="auto")
            ax.set_title(f"pos {p}, S {float(it['S'][sel[0]]):+.2f}\nk_lub {k:g} s, A_p "
                         f"{100 * pitted.mean():.0f} %", fontsize=7)
    fig.colorbar(im, ax=axes, shrink=0.6, label="damage risk max_z D (pits red)")
    fig.suptitle("Driver: damage risk after the last block (rolling direction up)")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def gear_table5(runs: Path, out: Path, md: list[str], suffix: str = "") -> Verdict:
    run = runs / f"paper_gear_z23_table5{suffix}"
    if not (run / "results.h5").is_file():
        md.append(f"*Missing: {run}/results.h5.*")
        return Verdict(5, False, "run missing")
    rows = plot_flank.flank_table(run)
    paper = {_roll_key(float(p["roll_angle_deg_from_table3"])): p for p in _read(
        "table5_constant_SRR_z23.csv")}
    side = []
    for r in rows:
        p = paper.get(_roll_key(r["roll_angle_deg"]), {})
        side.append({"roll_angle_deg": f"{r['roll_angle_deg']:.2f}", "S": f"{r['S']:.3f}",
                     "p0_GPa": f"{r['p0_GPa']:.3f}", "region": r["region"],
                     "Ap_driver_ours": f"{r['Ap1_pct']:.3g}",
                     "Ap_driver_range": f"{r['Ap1_min']:.3g}-{r['Ap1_max']:.3g}",
                     "Ap_driver_paper": p.get("Ap_pct_klub1e-11_driver", "")})
    _write_csv(out / f"table5_ours_vs_paper{suffix}.csv", side)
    header = ["roll °", "S", "p0 GPa", "zone", "A_p driver ours", "range", "paper"]
    md += ["", *_md_table(header, [list(s.values()) for s in side])]
    return trend5(_points(rows, 1e-11, 1))


def gear_table8(runs: Path, out: Path, md: list[str], suffix: str = "") -> Verdict:
    res, side = {}, []
    paper = {(int(r["z"]), r["nominal_location_below_tip"]): r
             for r in _read("table8_Ap_z23_vs_z18.csv")}
    for z, name in ((23, "paper_gear_z23_table8"), (18, "paper_gear_z18")):
        run = runs / f"{name}{suffix}"
        if not (run / "results.h5").is_file():
            md.append(f"*Missing: {run}/results.h5.*")
            return Verdict(6, False, "run missing")
        rows = plot_flank.flank_table(run)
        for r in rows:
            where = "0.7m" if r["position"] == 1 else "0.25m"
            p = paper[(z, where)]
            k = "0" if r["k_lub_s"] == 0.0 else "1e-11"
            side.append({"z": z, "location": where, "k_lub_s": f"{r['k_lub_s']:g}",
                         "S": f"{r['S']:.3f}", "p0_GPa": f"{r['p0_GPa']:.3f}",
                         "Ap_driver_ours": f"{r['Ap1_pct']:.3g}",
                         "Ap_driver_range": f"{r['Ap1_min']:.3g}-{r['Ap1_max']:.3g}",
                         "Ap_driver_paper": p[f"Ap_pct_klub{k}_driver"]})
            if where == "0.7m":
                res.setdefault(z, {})[r["k_lub_s"]] = r["Ap1_pct"]
    _write_csv(out / f"table8_ours_vs_paper{suffix}.csv", side)
    header = ["z", "below tip", "k_lub s", "S", "p0 GPa", "A_p driver ours", "range", "paper"]
    md += ["", *_md_table(header, [list(s.values()) for s in side])]
    return trend6(res.get(23, {}), res.get(18, {}))


def mpr(runs: Path, out: Path, md: list[str], suffix: str = "") -> list[Verdict]:
    verdicts = []
    for base, which, trend in (("paper_mpr", "mpr", 1), ("paper_mpr_beta30", "mpr", 1),
                               ("paper_mpr_table9", "table9", 7),
                               ("paper_mpr_table9_beta30", "table9", 7)):
        name = base + suffix
        run = runs / name
        md += ["", f"**{name}**", ""]
        if not (run / "summary.csv").is_file():
            md.append(f"*Missing: {run}/summary.csv.*")
            verdicts.append(Verdict(trend, False, f"{name}: run missing"))
            continue
        lines: list[str] = []
        ok = getattr(paper_mpr, which)(run, say=lines.append)
        table = run / ("mpr_comparison.csv" if which == "mpr" else "table9_comparison.csv")
        shutil.copy(table, out / f"{name}_{table.name}")
        with open(table, newline="") as fh:
            rows = list(csv.reader(fh))
        md += _md_table(rows[0], rows[1:]) + [""] + [f"* {s}" for s in lines]
        if (run / "life.png").is_file():
            shutil.copy(run / "life.png", out / f"{name}_life.png")
            md += ["", f"![{name}]({name}_life.png)"]
        md += _flags_line(run)
        verdicts.append(Verdict(trend, ok, f"{name}: " + "; ".join(lines)))
    r15, r30 = runs / f"paper_mpr{suffix}", runs / f"paper_mpr_beta30{suffix}"
    md += ["", f"**The paper's model between the two surface variants ({SCHEMES[suffix]})**",
           ""]
    if (r15 / "summary.csv").is_file() and (r30 / "summary.csv").is_file():
        lines = []
        ok, table = paper_mpr.bracket(r15, r30, say=lines.append)
        md += [*_md_table(["|S|", "M cycles", "experiment %", "paper's model %",
                           "ours β_x 15 µm", "ours β_x 30 µm", "model inside"], table), ""]
        md += [f"* {s}" for s in lines]
        verdicts.append(Verdict(8, ok, "; ".join(lines)))
    else:
        md.append("*Missing: one of the two MPR runs.*")
        verdicts.append(Verdict(8, False, "MPR runs missing"))
    return verdicts


def pair_slope_ratio(h_end: np.ndarray, pitted: np.ndarray, h_start: np.ndarray,
                     where: np.ndarray | None = None) -> float:
    """How the wear changed the slope of the material that is left: Δq along x (axis 0) of
    ``h_end`` over the pairs of x-neighbours that are both intact (not ``pitted``) at the end,
    divided by Δq of ``h_start`` over the same pairs (periodic; NaN without such pairs);
    ``where``: only the pairs whose first column it marks.

    summary.csv's Δq fills the pits (life._around_pits), so it also counts the step between a
    filled pit and its worn neighbours; this ratio counts only surface that the life left in
    place: below 1 the wear polished it, above 1 it roughened it."""
    both = ~pitted & ~np.roll(pitted, -1, axis=0)
    if where is not None:
        both &= where
    if not both.any():
        return math.nan
    d_end = (np.roll(h_end, -1, axis=0) - h_end)[both]
    d_start = (np.roll(h_start, -1, axis=0) - h_start)[both]
    return float(np.sqrt(np.mean(d_end ** 2) / np.mean(d_start ** 2)))


def pair_slope_ratios(res) -> dict[tuple[float, int], float]:
    """{(k_lub, body): mean over the items of :func:`pair_slope_ratio`} of a run's results,
    each item against the surface it started from: the final heights plus pit depths of the
    item with the same position, patch and roughness scale and k_lub = 0 (nothing but the pits
    changes a surface without wear, and they are given back by their depths)."""
    it = dict(res.items)
    key = list(zip(it["position"], it["patch"], it["roughness_scale"], strict=True))
    start = {k: int(i) for k, i, kl in zip(key, it["id"], it["k_lub"], strict=True) if kl == 0}
    acc: dict[tuple[float, int], list[float]] = {}
    for k, i, kl in zip(key, it["id"], it["k_lub"], strict=True):
        if k not in start:
            continue
        for body in (1, 2):
            m = res.maps(int(i), body, "heights", "pitted")
            s = res.maps(start[k], body, "heights", "pit_depth")
            acc.setdefault((float(kl), body), []).append(pair_slope_ratio(
                m["heights"], m["pitted"].astype(bool), s["heights"] + s["pit_depth"]))
    return {k: float(np.nanmean(v)) for k, v in acc.items()}


def pair_slope_line(res) -> list[str]:
    """The report's line on whether the wear polished the flanks (:func:`pair_slope_ratios`)."""
    r = pair_slope_ratios(res)
    worn = [k for k in K_LUB if k > 0 and (k, 1) in r and (k, 2) in r]
    if not worn:
        return []
    parts = "; ".join(f"k_lub {k:g} s: {r[(k, 1)]:.3g} / {r[(k, 2)]:.3g}" for k in worn)
    return ["Did the wear polish the flanks? Δq of the surface left in place (pairs of "
            "x-neighbours both intact after the last block) against the same pairs at the "
            f"start, mean over positions and patches, driver / driven: {parts} (below 1: "
            "polished; summary.csv's Δq fills the pits and so also counts the steps at their "
            "edges).", ""]


def slope_runs(runs: Path) -> list[tuple[float, Path]]:
    """(β_x [µm], run folder) of the gear trends' sensitivity to the slope: the scene as written
    (β_x = 30 µm) and the variants of scripts/slope-scene.sh (``paper_gear_z23_beta<B>``)."""
    return [(b, runs / ("paper_gear_z23" if b == SCENE_BETA_UM else f"paper_gear_z23_beta{b:g}"))
            for b in SLOPE_BETAS_UM]


def slope_means(summary: list[dict]) -> dict[tuple[float, int], tuple[float, float]]:
    """{(k_lub, body): (mean Δq [rad], mean A_p [%])} over the positions and patches of a run's
    last block (summary.csv rows; Δq with the pits filled, ``slope_dq``)."""
    last = max(float(r["cycles"]) for r in summary)
    acc: dict[tuple[float, int], list[tuple[float, float]]] = {}
    for r in summary:
        if float(r["cycles"]) == last:
            acc.setdefault((float(r["k_lub_s"]), int(r["body"])), []).append(
                (float(r["slope_dq"]), float(r["Ap_pct"])))
    return {k: tuple(float(x) for x in np.mean(v, axis=0)) for k, v in acc.items()}


def _pair(means: dict, k_lub: float, i: int) -> str:
    """"driver / driven" of entry ``i`` (0: Δq, 1: A_p) of :func:`slope_means` at ``k_lub``."""
    a, b = means.get((k_lub, 1)), means.get((k_lub, 2))
    return "" if a is None or b is None else f"{a[i]:.3g} / {b[i]:.3g}"


def slope_table(entries: list[tuple[float, list[dict] | None, list[dict] | None,
                                  dict | None]]) -> list[str]:
    """The report's section on the gear trends' sensitivity to the surfaces' slope: for each
    (β_x, flank rows of :func:`plot_flank.flank_table` or None when the run is missing, its
    summary.csv rows, its :func:`pair_slope_ratios`) the Δq the surfaces have without wear
    (they keep it: the k_lub = 0 items), the Δq after the life at k_lub = 5e-11 s, and of the
    surface left in place against its start, the flank-mean A_p at each k_lub and the verdicts
    of trends 2–4."""
    table = []
    for beta, rows, summary, ratios in entries:
        if rows is None or summary is None or ratios is None:
            table.append([f"{beta:g}", "run missing", "", "", "", "", "", "", "", ""])
            continue
        verdicts = {v.trend: v for v in flank_verdicts(rows)}
        m = slope_means(summary)
        r1, r2 = ratios.get((5e-11, 1), math.nan), ratios.get((5e-11, 2), math.nan)
        table.append([f"{beta:g}" + (" (the scene's)" if beta == SCENE_BETA_UM else ""),
                      _pair(m, 0.0, 0), _pair(m, 5e-11, 0), f"{r1:.3g} / {r2:.3g}",
                      *(_pair(m, k, 1) for k in K_LUB),
                      *(_word(verdicts[t]) for t in (2, 3, 4))])
    md = ["", "### The gear trends' sensitivity to the slope of the flanks", "",
          "The paper does not publish its flanks' slope. `scenes/paper_gear_z23.toml` again with "
          "both surfaces' correlation length along rolling β_x set to 15, 60 and 120 µm beside "
          "its 30 µm (`scripts/slope-scene.sh`; the same R_q, so the RMS slope Δq scales with "
          "1/β_x; each β_x its own realisation), converged default. Δq is the mean over "
          "positions and patches with the pits filled (summary.csv `slope_dq`), driver / "
          "driven; \"intact Δq end / start\" is that of the surface left in place against "
          "its start (below 1: the wear polished it; the gear flank's line \"Did the wear "
          "polish the flanks?\"); A_p the flank mean after the last block. β_x above 51 µm "
          "does not fit 4 times in the 205 µm window: those runs are flagged `window`.", ""]
    md += _md_table(["β_x µm", "Δq without wear, rad", "Δq at k_lub 5e-11 s, rad",
                     "intact Δq end / start, 5e-11 s", "A_p k_lub 0, %", "A_p 1e-11 s, %",
                     "A_p 5e-11 s, %",
                     "trend 2", "trend 3", "trend 4"], table)
    return md


def slope_sensitivity(runs: Path) -> list[str]:
    """:func:`slope_table` from the runs of :func:`slope_runs`."""
    entries = []
    for beta, run in slope_runs(runs):
        if not (run / "results.h5").is_file() or not (run / "summary.csv").is_file():
            entries.append((beta, None, None, None))
            continue
        with open(run / "summary.csv", newline="") as fh:
            summary = list(csv.DictReader(fh))
        res = load_results(run)
        entries.append((beta, plot_flank.flank_table(res), summary, pair_slope_ratios(res)))
    return slope_table(entries)


def _flags_line(run: Path) -> list[str]:
    """How many of the run's last-block rows are outside the model's range, by flag."""
    if not (run / "summary.csv").is_file():
        return []
    with open(run / "summary.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    if not rows or "flags" not in rows[0]:
        return []
    last = max(float(r["cycles"]) for r in rows)
    end = [r for r in rows if float(r["cycles"]) == last]
    count: dict[str, int] = {}
    for r in end:
        for f in r["flags"].split(";"):
            if f != "none":
                count[f] = count.get(f, 0) + 1
    if not count:
        return ["", f"Model's range: all {len(end)} item-body rows of the last block inside it.",
                ""]
    counts = ", ".join(f"`{f}` {n}" for f, n in sorted(count.items()))
    return ["", f"Model's range (docs/life.md), last block, {len(end)} item-body rows: "
            f"{counts}.", ""]


def block_scheme_table(md: list[str]) -> None:
    """The A_p-against-ΔN table of benchmarks/bench_block_scheme.py, when it has been run: the
    converged default (``adaptive``) and the literal twin (``paper``) at each ΔN."""
    path = ROOT / "benchmarks" / "results" / "block_scheme.csv"
    md += ["", "## A_p against the block length ΔN, both schemes", ""]
    if not path.is_file():
        md.append("*Not run: `.venv/bin/python benchmarks/bench_block_scheme.py`.*")
        return
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    md += ["`benchmarks/bench_block_scheme.py` (window " + ", ".join(sorted({
        r["n"] + "²" for r in rows})) + "): A_p of body 1 / body 2 [%] at the end of the life.",
           ""]
    if rows and "wear" not in rows[0]:
        md += ["*These rows predate the implicit wear: both schemes wore by the relaxed update, "
               "so neither is the converged default nor the paper's literal numerics; re-run "
               "the benchmark (after moving the old file away).*", ""]
    blocks = sorted({float(r["block_M"]) for r in rows})
    table = []
    for case in sorted({r["case"] for r in rows}):
        for integ, label in (("adaptive", "adaptive (default)"), ("paper", "paper (twin)")):
            for k in sorted({float(r["k_lub_s"]) for r in rows}):
                line = [case, label, f"{k:g}"]
                for b in blocks:
                    r = next((r for r in rows if r["case"] == case and r["integration"] == integ
                              and float(r["k_lub_s"]) == k and float(r["block_M"]) == b), None)
                    line.append("" if r is None else f"{float(r['Ap1_pct']):.3g} / "
                                f"{float(r['Ap2_pct']):.3g}")
                table.append(line)
    md += _md_table(["case", "scheme", "k_lub s", *[f"ΔN {b:g} M" for b in blocks]], table)


def _tree(runs: Path, name: str) -> str:
    """The git tree of micropit_hpc/ that began the run (its stamp from scripts/validate-run.sh,
    runs/.validate/<name>.tree): runs resumed or written again under another commit of the same
    tree ran the same code."""
    stamp = runs / ".validate" / f"{name}.tree"
    return stamp.read_text().strip()[:7] if stamp.is_file() else "not recorded"


def _commit(out: Path) -> str:
    """HEAD, and whether tracked files other than the report's own (``out``) differ from it."""
    spec = (".",)
    if out.resolve().is_relative_to(ROOT):
        spec += (f":(exclude){out.resolve().relative_to(ROOT)}",)
    commit = describe_source(ROOT, spec)
    if not commit:
        return "unknown"
    return commit.removesuffix("-dirty") + (" (with uncommitted changes)"
                                             if commit.endswith("-dirty") else "")


def _sections(runs: Path, out: Path, suffix: str) -> tuple[list[Verdict], dict[str, list[str]]]:
    """Every comparison for the runs of one scheme (``suffix``: a key of :data:`SCHEMES`)."""
    md: dict[str, list[str]] = {k: [] for k in ("gear", "t5", "t8", "mpr")}
    verdicts = mpr(runs, out, md["mpr"], suffix)
    verdicts += gear_flank(runs, out, md["gear"], suffix)
    verdicts.append(gear_table5(runs, out, md["t5"], suffix))
    verdicts.append(gear_table8(runs, out, md["t8"], suffix))
    return verdicts, md


def _primary(verdicts: list[Verdict]) -> dict[int, Verdict]:
    """One verdict per trend of one scheme's runs: the scenes with β_x = 15 µm decide; the
    _beta30 variants are a sensitivity (trend 8 is the MPR bracket, which needs both)."""
    primary: dict[int, Verdict] = {}
    for v in verdicts:
        if v.trend in (1, 7) and "beta30" in v.text.split(":")[0]:
            continue
        primary.setdefault(v.trend, v)
    return primary


def _missing(v: Verdict) -> bool:
    """Whether a verdict is only that its runs are missing (the texts of :func:`mpr`,
    :func:`gear_flank`, :func:`gear_table5`, :func:`gear_table8`)."""
    return v.text.endswith("missing")


def _word(v: Verdict) -> str:
    """PASS or FAIL; a verdict whose runs are missing (default or twin) is said to be missing,
    not to fail (the validation as a whole still does not pass: :func:`trend_lines`)."""
    if _missing(v):
        return "missing"
    return "PASS" if v.holds else "FAIL"


def trend_lines(verdicts: list[Verdict], twins: list[Verdict]) -> tuple[list[str], bool]:
    """The report's trend lines: each trend's verdict decided on the converged default
    (``verdicts``, the runs as written), its literal twin's (``twins``, the ``_paper`` runs)
    beside it; and whether every trend passes on the default. The ``_beta30`` sensitivity of
    trends 1 and 7 follows, in both schemes."""
    primary, paper = _primary(verdicts), _primary(twins)
    md = []
    for t in range(1, 9):
        v = primary.get(t, Verdict(t, False, "not evaluated"))
        w = paper.get(t, Verdict(t, False, "run missing"))
        words = TREND_WORDS.get(t, "MPR rig: the paper's model A_p at 6 M lies between our "
                                   "β_x = 15 and 30 µm results at each |S|")
        md.append(f"* **trend {t}: {_word(v)}** (converged default; the paper's literal "
                  f"numerics: {_word(w)}) — {words}.  ")
        md.append(f"  Converged default: {v.text}  ")
        md.append(f"  Paper's literal numerics (`_paper` twin): "
                  f"{'run missing' if _missing(w) else w.text}")
    extra = [v for v in verdicts if v.trend in (1, 7) and "beta30" in v.text.split(":")[0]]
    extra_twin = {v.text.split(":")[0]: v for v in twins
                  if v.trend in (1, 7) and "beta30" in v.text.split(":")[0]}
    if extra:
        md += ["", "Sensitivity to the unknown correlation length along rolling (the `_beta30` "
               "scenes, β_x = 30 µm instead of 15 µm; not a fit), converged default, the "
               "literal twin beside it:", ""]
        for v in extra:
            w = extra_twin.get(v.text.split(":")[0] + "_paper")
            twin = "missing" if w is None else _word(w)
            md.append(f"* trend {v.trend}: {_word(v)} (the paper's literal numerics: {twin}) "
                      f"— {v.text}")
    return md, all(v.holds for v in primary.values()) and len(primary) == 8


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=Path, default=ROOT / "runs")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "validation")
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    commit = _commit(a.out)
    verdicts, md_default = _sections(a.runs, a.out, "")
    twins, md_paper = _sections(a.runs, a.out, "_paper")
    runs_info = []
    total, restarted = 0.0, False
    items_total = 0.0
    slopes = [run.name for b, run in slope_runs(a.runs) if b != SCENE_BETA_UM]
    for name in [n + sfx for sfx in SCHEMES for n in MPR_SCENES + GEAR_SCENES] + slopes:
        run = a.runs / name
        if (run / "results.h5").is_file():
            info = _run_info(run)
            total += info["wall_s"]
            items_total += info["item_s"] / max(info["ranks"], 1)
            status = info["status"]
            if info["restarted"]:
                restarted = True
                status += f" (restarted after block {info['restarted']}*)"
            runs_info.append([name, info["items"], info["ell_um"], info["ranks"],
                              f"{info['wall_s']:.0f}",
                              f"{info['item_s'] / max(info['ranks'], 1):.0f}",
                              status, info["created"], info["commit"], _tree(a.runs, name)])
        else:
            runs_info.append([name, "", "", "", "", "", "missing", "", "", ""])
    lines, passed = trend_lines(verdicts, twins)
    md = ["# Validation report", "",
          f"Written by `bash scripts/validate.sh` (`postprocess/validation_report.py`) on "
          f"{dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC at commit {commit}. The paper: "
          "Morales-Espejel, Rycerz & Kadiric, Wear 398–399 (2018); its tables are in "
          "`validation/`. The absolute A_p depends on the roughness patch, which is not public "
          "(the paper says so itself), so the validation targets are trends; the findings "
          "behind each FAIL, and which stage causes it, are in [findings.md](findings.md).", "",
          "Every paper scene runs as written, the converged default (`life.integration = "
          "\"adaptive\"`: blocks split until damage, pits and wear are resolved in time, with "
          "the implicit wear, and the Dang Van criterion over a process length of 5 µm, "
          "`fatigue.process_length_um`), which decides each trend. Its literal twin "
          "(`runs/<scene>_paper/`, from `scripts/paper-scene.sh`: `integration = \"paper\"`, the "
          "paper's numerics, fixed blocks of ΔN, one evaluation per block on its starting "
          "surfaces, explicit wear ΔN·Δh and damage over the block, then the pit check, and "
          "the paper's pointwise criterion) is given beside each trend; the runs table gives "
          "each run's ℓ (docs/life.md, \"Two time integrations\" and \"A process length for "
          "the criterion\"). Results outside the model's range are "
          "counted per run (docs/life.md, \"The model's range\").", "",
          "## Trends", "", *lines, *slope_sensitivity(a.runs)]
    md += ["", "## Runs", ""]
    md += _md_table(["scene", "items", "criterion's ℓ, µm", "ranks", "wall s",
                     "items' time / ranks, s", "status", "results written (UTC)", "commit",
                     "micropit_hpc tree"], runs_info)
    if restarted:
        md += ["", "\\* A restarted run records the wall time, time and commit of its last leg "
               "only; the blocks before the restart come from its checkpoint, and so do their "
               "items' times."]
    md += ["", f"Total wall time of the runs: {total / 60:.1f} min; their items' time (each "
           f"item's blocks, from the results, over every leg of a resumed run) divided by the "
           f"ranks: {items_total / 60:.1f} min (what the runs cost without idle ranks)."]
    block_scheme_table(md)
    for title, part in (("the converged default (the scenes as written)", md_default),
                        ("the paper's literal numerics (the `_paper` twins)", md_paper)):
        md += ["", f"# Results in {title}", "",
               "## Gear flank, z = 23 (Table 4, Fig. 8, Fig. 9)", "", *part["gear"]]
        md += ["", "## S fixed at ±0.044 (Table 5)", *part["t5"]]
        md += ["", "## z = 18 against z = 23 (Table 8)", *part["t8"]]
        md += ["", "## MPR triple-disc rig (paper §3.1, Fig. 5) and Λ scaling (Table 9)",
               *part["mpr"]]
    (a.out / "README.md").write_text("\n".join(md) + "\n")
    print("\n".join(md[:40]))
    print(f"wrote {a.out / 'README.md'}")
    return 0 if passed else 1


if __name__ == "__main__":
    raise SystemExit(main())
