"""What one load cycle does at each stage, on the initial surfaces of a scene: the numbers behind a
saturated or a surprising A_p (docs/validation/findings.md).

    python postprocess/cycle_stages.py SCENE [--position K]... [--k-lub K] [--patch P]

Per position: the load fraction on solid contact φ and the solid area fraction (contact stage),
the largest rough and smooth Dang Van stress of body 1 (stress stage) against the S–N line's
one-cycle strength τ₁ = B/√3 (N(τ₁) = 1), the micro-cycles n_μ (counting stage), and the share
of columns of body 1 whose damage reaches 1 within one load cycle and within one million.
One rank; a 64² window takes seconds per position.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from micropit_hpc.conditions import contact_study
from micropit_hpc.plan import WorkItem
from micropit_hpc.scene import load_scene
from micropit_hpc.study import ItemRun


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("--position", type=int, action="append", help="(default: all)")
    ap.add_argument("--k-lub", type=float, default=0.0, help="wear coefficient [s]")
    ap.add_argument("--patch", type=int, default=0)
    a = ap.parse_args()
    scene = load_scene(a.scene)
    study = contact_study(scene)
    n_pos = len(study.conditions)
    tau_1 = scene.fatigue.B / math.sqrt(3.0)
    print(f"# {a.scene}: one load cycle on the initial surfaces (patch {a.patch}, k_lub "
          f"{a.k_lub:g} s); S–N one-cycle strength τ1 = B/√3 = {tau_1 / 1e6:.0f} MPa")
    print("position,S,p0_GPa,phi,solid_area,tau_dv_max_MPa,tau_dv_smooth_max_MPa,n_micro,"
          "fail_within_1_cycle_pct,fail_within_1M_pct")
    for pos in a.position or range(1, n_pos + 1):
        run = ItemRun(scene, WorkItem(0, pos, a.k_lub, 1.0, a.patch), base=study)
        res = run.cycle.evaluate(run.surfaces)             # the initial surfaces: no pits
        c, b = run.cycle.cond, res.bodies[0]
        worst = b.damage_rate.max(axis=0)                  # per column, over depth
        print(f"{pos},{c.S:.5f},{c.p0 / 1e9:.4f},{res.phi:.4f},{res.solid_fraction:.4f},"
              f"{b.tau_rough.max() / 1e6:.0f},{b.tau_smooth.max() / 1e6:.0f},{b.n_micro:.4g},"
              f"{100 * float((worst >= 1.0).mean()):.2f},"
              f"{100 * float((worst * 1e6 >= 1.0).mean()):.2f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
