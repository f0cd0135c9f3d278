"""Where the load of a pitted asperity goes, and how the wear with pits depends on the grid
(issue 29, docs/performance.md §14, docs/life.md "Where the load of a pitted asperity
goes"): one block of one work item of the paper gear at several grids (the same window, one
realisation made on ``--ref``² and resampled, as bench_wear_convergence.py), with the block
record's ``pit_load`` (the share of the contact load the solves put on pitted columns, handed
to the film), the wear, A_p and Δq.

Two experiments that are not options of the code, each a one-line change made in this process:

* ``--fill-cells C``: the pit fill's Gaussian (``life.PIT_FILL_CELLS``, 2 cells) set to C
  cells;
* ``--load-to contacts``: the pitted columns' load handed to the intact columns in proportion
  to their pressure (the counterface settling onto the rest of the surface) instead of as a
  film's uniform pressure (``film``, the code's rule); where the intact contacts cannot carry
  it below p_lim the code's rule is kept.

    python benchmarks/bench_pit_load.py --position 5 --k-lub 5e-11 --grids 64 128 --cycles-M 0.3
    python benchmarks/bench_pit_load.py --grids 64 128 --cycles-M 1 --load-to contacts
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np
from bench_wear_convergence import item_run, reference_surfaces
from table import emit, write_csv

import micropit_hpc.life as life
from micropit_hpc.cycle import PositionCycle
from micropit_hpc.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
COLUMNS = ("position", "k_lub_s", "n", "cycles_M", "pit_contact", "load_to", "fill_cells",
           "pit_load",
           "wear_um", "Ap_1", "Ap_2", "dq_1", "dq_2", "phi", "wall_s")


def _scaled(p: np.ndarray, target: float, p_lim: float) -> np.ndarray:
    """min(c p, p_lim) with c such that the mean is ``target`` (bisection; the caller checks
    that the columns with p > 0 can carry it)."""
    lo, hi = 0.0, 2.0 * target / p.mean()
    while np.minimum(p * hi, p_lim).mean() < target:
        hi *= 2.0
    for _ in range(100):
        c = 0.5 * (lo + hi)
        lo, hi = (lo, c) if np.minimum(p * c, p_lim).mean() > target else (c, hi)
    return np.minimum(p * hi, p_lim)


def _to_contacts(film_rule):
    def unload(self, pressure, clearance, p_mean, t):
        mask = self.pit_mask(t)
        free = ~mask
        n, n_free = pressure.size, int(free.sum())
        if not mask.any() or not n_free or p_mean * n / n_free >= self.p_lim or \
                np.count_nonzero(pressure[free]) * self.p_lim <= 1.01 * p_mean * n:
            return film_rule(self, pressure, clearance, p_mean, t)
        moved = float(pressure[mask].sum() / pressure.sum())
        p = np.zeros_like(pressure)
        p[free] = _scaled(pressure[free], p_mean * n / n_free, self.p_lim)
        return p, np.where(mask, np.maximum(clearance, self.cond.hc), clearance), moved
    return unload


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "paper_gear_z23.toml"))
    ap.add_argument("--position", type=int, default=5)
    ap.add_argument("--k-lub", type=float, default=5e-11)
    ap.add_argument("--grids", type=int, nargs="+", default=[64, 128])
    ap.add_argument("--cycles-M", type=float, default=0.3, help="the one block's length")
    ap.add_argument("--ref", type=int, default=256, help="grid of the surface realisation")
    ap.add_argument("--fill-cells", type=float, default=life.PIT_FILL_CELLS)
    ap.add_argument("--load-to", choices=("film", "contacts"), default="film")
    ap.add_argument("--pit-contact", choices=("unloaded", "open"), default="unloaded",
                    help="life.pit_contact of the runs")
    ap.add_argument("--csv", default=None)
    a = ap.parse_args(argv)
    life.PIT_FILL_CELLS = a.fill_cells
    if a.load_to == "contacts":
        PositionCycle._unload_pits = _to_contacts(PositionCycle._unload_pits)
    base = load_scene(a.scene)
    base = dataclasses.replace(base, life=dataclasses.replace(base.life,
                                                              pit_contact=a.pit_contact))
    reference = reference_surfaces(base, a.ref)
    print(",".join(COLUMNS), flush=True)
    rows = []
    for n in a.grids:
        t0 = time.perf_counter()
        run = item_run(base, a.position, a.k_lub, n, a.cycles_M, reference)
        rec = run.run_block(a.cycles_M * 1e6)
        row = (a.position, a.k_lub, n, a.cycles_M, a.pit_contact, a.load_to, a.fill_cells,
               rec.pit_load,
               sum(rec.wear_mean) * 1e6, rec.Ap[0], rec.Ap[1], rec.slope[0], rec.slope[1],
               rec.phi, time.perf_counter() - t0)
        rows.append(row)
        emit(row)
    write_csv(a.csv, COLUMNS, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
