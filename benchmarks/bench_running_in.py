"""Time-step convergence of the life loop through the running-in: one work item of a scene,
block by block, with the window and the split settings given on the command line.

    .venv/bin/python benchmarks/bench_running_in.py scenes/paper_mpr_table9_beta30.toml \\
        --n 64 --k-lub 1e-11 --scale 1.0 --blocks 2 --max-splits 64 --max-wear-fraction 0.1

Per block it prints the sub-blocks, φ, A_p of both bodies, n_μ, the mean wear and the
counterface's λ_c, and the wall time on one rank (docs/life.md, "Resolving the running-in").
"""

from __future__ import annotations

import argparse
import datetime
import time
import tomllib

from micropit_hpc import source_commit
from micropit_hpc.plan import WorkItem
from micropit_hpc.scene import scene_from_dict
from micropit_hpc.study import ItemRun


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--n", type=int, default=None, help="window cells per side")
    ap.add_argument("--position", type=int, default=1)
    ap.add_argument("--k-lub", type=float, default=1e-11, help="k_lub [s]")
    ap.add_argument("--scale", type=float, default=1.0, help="roughness scale factor")
    ap.add_argument("--blocks", type=int, default=2)
    ap.add_argument("--max-splits", type=int, default=None)
    ap.add_argument("--max-wear-fraction", type=float, default=None)
    ap.add_argument("--max-pit-step", type=float, default=None)
    ap.add_argument("--wear-integration", choices=("relaxed", "explicit"), default=None)
    ap.add_argument("--peak-spacing-min-cells", type=float, default=None)
    args = ap.parse_args()
    with open(args.scene, "rb") as f:
        doc = tomllib.load(f)
    if args.n is not None:
        doc.setdefault("window", {})["n"] = args.n
    # command-line overrides of scene keys (the option is the key's name)
    for section, key in (("life", "max_splits"), ("life", "max_wear_fraction"),
                         ("life", "max_pit_step"), ("life", "wear_integration"),
                         ("fatigue", "peak_spacing_min_cells")):
        if getattr(args, key) is not None:
            doc.setdefault(section, {})[key] = getattr(args, key)
    scene = scene_from_dict(doc, args.scene)
    run = ItemRun(scene, WorkItem(0, args.position, args.k_lub, args.scale, 0))
    print(f"# {args.scene}, window {run.cycle.grid.nx}², position {args.position}, k_lub "
          f"{args.k_lub:g} s, roughness × {args.scale:g}, max_splits {scene.life.max_splits}, "
          f"max_wear_fraction {scene.life.max_wear_fraction:g}, "
          f"max_pit_step {scene.life.max_pit_step:g}, "
          f"wear {scene.life.wear_integration}, "
          f"peak_spacing_min_cells {scene.fatigue.peak_spacing_min_cells:g}; "
          f"{datetime.date.today()}, commit {source_commit()}, one rank")
    print("| block | sub-blocks | φ | A_p body 1 / 2 [%] | n_μ 1 / 2 | mean wear 1 / 2 [nm] "
          "| λ_c seen by 1 / 2 [µm] | wall [s] |")
    print("|---|---|---|---|---|---|---|---|")
    for _ in range(args.blocks):
        t0 = time.perf_counter()
        r = run.run_block()
        lam = " / ".join(_lam(run, i, r.n_micro[i - 1]) for i in (1, 2))
        print(f"| {r.block} | {r.sub_blocks} | {r.phi:.3f} | {r.Ap[0]:.2f} / {r.Ap[1]:.2f} | "
              f"{r.n_micro[0]:.2f} / {r.n_micro[1]:.2f} | {1e9 * r.wear_mean[0]:.0f} / "
              f"{1e9 * r.wear_mean[1]:.0f} | {lam} | {time.perf_counter() - t0:.0f} |",
              flush=True)


def _lam(run: ItemRun, body: int, n_micro: float) -> str:
    """The counterface's λ_c [µm] that gave body ``body`` its n_μ (n_μ = 2b|u1 − u2|/(u_i λ_c),
    docs/model.md §4.4)."""
    c = run.cycle.cond
    u_i = c.u1 if body == 1 else c.u2
    return "∞" if n_micro == 0 else f"{2e6 * c.b * abs(c.u1 - c.u2) / (u_i * n_micro):.1f}"


if __name__ == "__main__":
    main()
