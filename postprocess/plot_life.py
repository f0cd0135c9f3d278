"""Plots of a `micropit run` result: A_p against cycles per item, and the damage-risk maps
(max over depth of the Miner damage, pits in red) of body 1 at the end, like the paper's Fig. 6
and Fig. 9.

    python postprocess/plot_life.py RUN_DIR [--out RUN_DIR/life.png] [--body 1]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import ListedColormap


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--body", type=int, default=1, choices=(1, 2))
    a = ap.parse_args()
    out = a.out or a.run / "life.png"
    with h5py.File(a.run / "results.h5", "r") as f:
        ids = f["items/id"][()]
        S, klub, lam = f["items/S"][()], f["items/k_lub"][()], f["items/Lambda"][()]
        dx, dy = float(f["grid/dx"][()]), float(f["grid/dy"][()])
        n = len(ids)
        fig = plt.figure(figsize=(4 + 2.6 * n, 6.5))
        grid = fig.add_gridspec(2, n + 1, width_ratios=[1.6] + [1] * n)
        ax = fig.add_subplot(grid[:, 0])
        cmap = ListedColormap(plt.cm.viridis(np.linspace(0, 0.9, 256)))
        for k, iid in enumerate(ids):
            h = f[f"history/item_{iid:05d}"]
            label = f"#{iid} S={S[k]:.3g} Λ={lam[k]:.3g} k={klub[k]:.0e}s"
            ax.plot(np.r_[0, h["cycles"][()]] / 1e6, np.r_[0, h["Ap"][:, a.body - 1]], "o-",
                    label=label)
            m = f[f"maps/item_{iid:05d}/body{a.body}"]
            risk, pitted = m["damage_risk"][()], m["pitted"][()].astype(bool)
            for row, (img, title) in enumerate(((risk, "damage risk max_z D"),
                                               (m["heights"][()] * 1e6, "heights [µm]"))):
                axm = fig.add_subplot(grid[row, k + 1])
                ext = [0, img.shape[1] * dy * 1e6, 0, img.shape[0] * dx * 1e6]
                im = axm.imshow(img, origin="lower", extent=ext, aspect="auto",
                                cmap=cmap if row == 0 else "gray",
                                vmin=0 if row == 0 else None, vmax=1 if row == 0 else None)
                if row == 0:
                    axm.imshow(np.ma.masked_where(~pitted, pitted), origin="lower", extent=ext,
                               aspect="auto", cmap=ListedColormap(["red"]), alpha=0.85)
                    axm.set_title(f"#{iid}: A_p {100 * pitted.mean():.3g} %", fontsize=8)
                axm.set_xlabel("y [µm]", fontsize=7)
                axm.set_ylabel("x (rolling) [µm]", fontsize=7)
                axm.tick_params(labelsize=6)
                fig.colorbar(im, ax=axm, fraction=0.05).ax.tick_params(labelsize=6)
                if row == 1:
                    axm.set_title(title, fontsize=8)
        ax.set_xlabel("load cycles [M]")
        ax.set_ylabel(f"A_p of body {a.body} [%]")
        ax.set_title(Path(str(f.attrs["scene_file"])).stem)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
