"""Plots of a `micropit run` result: A_p against cycles of both bodies per item, and per item
the damage-risk maps (max over depth of the Miner damage, pits in red) and the final heights of
both bodies, like the paper's Fig. 6 and Fig. 9. Items are labelled by position (roll angle and
S for a gear, S for a rig), with the wear coefficient, roughness scale and patch where a study
varies them. The damage risk is on its fixed scale 0–1; each height map has a robust scale,
the 1st to 99th percentile of its intact (unpitted) points, with the colour bar extended at
both ends and the pits in red, so that deep pits or spikes do not wash out the roughness.

    python postprocess/plot_life.py RUN_DIR [--out RUN_DIR/life.png] [--body 1|2]
        [--max-items 6]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import ListedColormap

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from micropit_hpc.errors import MicropitError
from micropit_hpc.io.results import load_results


def item_labels(items) -> dict[int, str]:
    """{item id: label} naming each item by its position (and roll angle and S), plus the
    study dimensions that vary between items; ``items``: :attr:`Results.items
    <micropit_hpc.io.results.Results.items>`."""
    it = {k: items[k] for k in ("id", "position", "S", "k_lub", "roughness_scale", "patch",
                                "roll_angle")}
    varies = {k: len(set(np.asarray(it[k]).tolist())) > 1
              for k in ("k_lub", "roughness_scale", "patch")}
    out = {}
    for k, iid in enumerate(it["id"]):
        roll = float(it["roll_angle"][k])
        where = (f"pos {it['position'][k]} (φ1 {math.degrees(roll):.1f}°, S {it['S'][k]:+.2f})"
                 if math.isfinite(roll) else f"pos {it['position'][k]} (S {it['S'][k]:+.2f})")
        extra = []
        if varies["k_lub"]:
            extra.append(f"k {it['k_lub'][k]:.0e} s")
        if varies["roughness_scale"]:
            extra.append(f"R_q × {it['roughness_scale'][k]:g}")
        if varies["patch"]:
            extra.append(f"patch {it['patch'][k]}")
        out[int(iid)] = where + ("" if not extra else ", " + ", ".join(extra))
    return out


def shown_items(ids: np.ndarray, most: int) -> list[int]:
    """At most ``most`` item ids, spread evenly over the study."""
    if len(ids) <= most:
        return [int(i) for i in ids]
    pick = np.unique(np.round(np.linspace(0, len(ids) - 1, most)).astype(int))
    return [int(ids[k]) for k in pick]


def robust_limits(maps: list[np.ndarray], lo: float = 1.0, hi: float = 99.0) -> tuple[float,
                                                                                     float]:
    """The ``lo``–``hi`` percentile range of all values of ``maps`` (a colour scale that a
    few outliers, such as deep pits, do not swamp)."""
    values = np.concatenate([m.ravel() for m in maps])
    a, b = np.percentile(values, [lo, hi])
    return (float(a), float(b)) if b > a else (float(values.min()), float(values.max()) + 1e-12)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--body", type=int, default=None, choices=(1, 2),
                    help="one body only (default both)")
    ap.add_argument("--max-items", type=int, default=6,
                    help="maps of at most this many items, spread over the study (default 6)")
    a = ap.parse_args()
    out = a.out or a.run / "life.png"
    bodies = (a.body,) if a.body else (1, 2)
    try:
        res = load_results(a.run)
    except MicropitError as e:
        print(f"plot_life: {e}", file=sys.stderr)
        return 2
    ids = res.items["id"]
    labels = item_labels(res.items)
    dx, dy = res.grid.dx, res.grid.dy
    shown = shown_items(ids, a.max_items)
    n = len(shown)
    rows = 2 * len(bodies)
    fig = plt.figure(figsize=(5.5 + 2.5 * n, 2.3 * rows + 1.2))
    grid = fig.add_gridspec(rows, n + 1, width_ratios=[2.2] + [1] * n)
    colours = plt.cm.tab10(np.arange(len(ids)) % 10)
    cmap = ListedColormap(plt.cm.viridis(np.linspace(0, 0.9, 256)))
    heights = {(iid, b): res.maps(iid, b, "heights")["heights"] * 1e6
               for iid in shown for b in bodies}
    per_body = rows // len(bodies)
    for j, b in enumerate(bodies):
        ax = fig.add_subplot(grid[j * per_body:(j + 1) * per_body, 0])
        for k, iid in enumerate(ids):
            h = res.history[int(iid)]
            ax.plot(np.r_[0, h["cycles"]] / 1e6, np.r_[0, h["Ap"][:, b - 1]], "o-",
                    ms=3, color=colours[k], label=labels[int(iid)])
        ax.set_ylabel(f"A_p body {b} [%] ({'driver' if b == 1 else 'driven'})")
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        if j == 0:
            ax.set_title(Path(res.scene_file).stem)
            ax.legend(fontsize=6, loc="upper left")
        if j == len(bodies) - 1:
            ax.set_xlabel("load cycles [M]")
    for c, iid in enumerate(shown):
        for j, b in enumerate(bodies):
            m = res.maps(iid, b, "damage_risk", "pitted")
            risk = m["damage_risk"]
            pitted = m["pitted"].astype(bool)
            ext = [0, risk.shape[1] * dy * 1e6, 0, risk.shape[0] * dx * 1e6]
            for r, (img, kind) in enumerate(((risk, "risk"), (heights[(iid, b)], "h"))):
                axm = fig.add_subplot(grid[r * len(bodies) + j, c + 1])
                if kind == "risk":
                    im = axm.imshow(img, origin="lower", extent=ext, aspect="auto",
                                    cmap=cmap, vmin=0.0, vmax=1.0)
                    axm.imshow(np.ma.masked_where(~pitted, pitted), origin="lower",
                               extent=ext, aspect="auto", cmap=ListedColormap(["red"]),
                               alpha=0.85)
                    title = (f"body {b} damage max_z D, pits red\nA_p "
                             f"{100 * pitted.mean():.3g} %")
                    extend = "neither"
                else:
                    hlo, hhi = robust_limits([img[~pitted] if (~pitted).any() else img])
                    im = axm.imshow(img, origin="lower", extent=ext, aspect="auto",
                                    cmap="gray", vmin=hlo, vmax=hhi)
                    axm.imshow(np.ma.masked_where(~pitted, pitted), origin="lower",
                               extent=ext, aspect="auto", cmap=ListedColormap(["red"]),
                               alpha=0.6)
                    title = f"body {b} heights [µm], pits red"
                    extend = "both"
                if r == 0 and j == 0:
                    title = f"{labels[iid]}\n{title}"
                axm.set_title(title, fontsize=7)
                axm.set_xlabel("y [µm]", fontsize=6)
                axm.set_ylabel("x (rolling) [µm]", fontsize=6)
                axm.tick_params(labelsize=6)
                fig.colorbar(im, ax=axm, fraction=0.05, extend=extend
                             ).ax.tick_params(labelsize=6)
    if n < len(ids):
        fig.suptitle(f"maps of {n} of {len(ids)} items (--max-items)", fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
