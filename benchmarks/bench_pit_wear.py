"""Why the wear roughens a pitted flank (issue 29, items 1 and 6; docs/life.md, "Wear on a
pitted flank"): one gear work item run for some blocks at the scene's defaults, then

* the slope of the surface left in place, Δq over the pairs of x-neighbours both intact at the
  end against the same pairs at the start (postprocess/validation_report.py's
  ``pair_slope_ratio``), within 2 cells of a pit and farther;
* the correlation of the wear with the starting heights (polishing wears the tops: > 0);
* one more load cycle on the final surfaces: the wear rate split into its solid-contact and film
  parts, the share of each step's load that the contact solve put on pitted columns (handed
  back to the intact columns as one added pressure, ``life.pit_contact = "unloaded"``), and the
  correlation of the film part with the share of the cycle each material point spends free of
  pits, its own and the counterface's passing over it.

``--fill`` tries other fills of the pitted columns in the contact's surface (a scratch patch of
``micropit_hpc.life``, not an option of the code): ``mean`` (the code: the pre-pit height lowered
by the intact neighbours' mean wear), ``max`` (by the most-worn intact neighbour's, 5 × 5 cells)
and ``flat`` (the intact neighbours' mean height: no tip left). ``--no-fatigue`` runs without
pits (S–N intercept 1e5 MPa). ``--running-in`` flattens the tips first (``life.running_in =
"plastic"``, docs/life.md, "Plastic running-in of the tips"); the slopes and the correlation
with the start heights are then measured from the run-in surfaces, the state the wear starts
from. ``--pit-contact open`` (or ``geometric``) sets ``life.pit_contact`` (default: the
scene's). One rank, one process; one row per run to ``--csv``.

    python benchmarks/bench_pit_wear.py --position 4 --k-lub 5e-11 --blocks 2 --fill mean max flat
    python benchmarks/bench_pit_wear.py --position 4 --k-lub 5e-11 --blocks 2 --no-fatigue
    python benchmarks/bench_pit_wear.py --position 4 --k-lub 5e-11 --blocks 2 --running-in
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np
from scipy import ndimage
from table import emit, write_csv

from micropit_hpc import cycle as cycle_module
from micropit_hpc import life
from micropit_hpc.plan import WorkItem
from micropit_hpc.running_in import run_in
from micropit_hpc.scene import load_scene
from micropit_hpc.spectral import to_material_frame
from micropit_hpc.study import ItemRun

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "postprocess"))
from validation_report import pair_slope_ratio  # noqa: E402

COLUMNS = ("position", "k_lub_s", "patch", "fill", "fatigue", "running_in", "pit_contact",
           "cycles_M", "body", "Ap_pct", "wear_um", "pitted", "pair_dq_ratio",
           "pair_dq_ratio_near", "pair_dq_ratio_far", "corr_wear_start_height",
           "solid_rate_share", "pit_load_median", "free_share_mean", "free_share_sd",
           "corr_film_rate_free_share", "wall_s")
NEAR_CELLS = 2
_AROUND, _AROUND_PITS = life._around, life._around_pits


def _around_max(values: np.ndarray, pitted: np.ndarray) -> np.ndarray:
    """The pitted columns at the largest value of the intact columns within 5 × 5 cells (the
    code's Gaussian mean where there is none)."""
    if not pitted.any() or pitted.all():
        return values
    mx = ndimage.maximum_filter(np.where(pitted, -np.inf, values), size=5, mode="wrap")
    return np.where(pitted, np.where(np.isfinite(mx), mx, _AROUND(values, pitted)), values)


def _around_pits_flat(bs) -> np.ndarray:
    """The pitted columns at the mean height of the intact columns around them."""
    if not bs.pitted.any() or bs.pitted.all():
        return bs.heights + bs.pit_depth
    return _AROUND(bs.heights, bs.pitted.astype(bool))


def _fill(name: str) -> None:
    """Patch micropit_hpc.life with the pit fill ``name`` (``mean``: the code's own)."""
    life._around, life._around_pits = _AROUND, _AROUND_PITS
    if name == "max":
        life._around = _around_max
    elif name == "flat":
        life._around_pits = _around_pits_flat


def _one_cycle(run: ItemRun, scene) -> tuple:
    """One load cycle on the run's final surfaces: its result and, per time step whose pits were
    unloaded, its time, the pit mask and the share of the load moved off the pits."""
    steps: list = []
    unload = cycle_module.PositionCycle._unload_pits

    def spy(self, pressure, clearance, p_mean, t):
        out = unload(self, pressure, clearance, p_mean, t)
        steps.append((t, self.pit_mask(t), out[2]))
        return out

    cycle_module.PositionCycle._unload_pits = spy
    try:
        surfaces, pits = life.contact_surfaces(run.state, run.cycle.grid, scene.life.pit_contact)
        result = run.cycle.evaluate(surfaces, pits)
    finally:
        cycle_module.PositionCycle._unload_pits = unload
    return result, steps


def measure(position: int, k_lub: float, patch: int, blocks: int, fill: str, fatigue: bool,
            scene_path: Path, running_in: bool = False,
            pit_contact: str | None = None) -> list[tuple]:
    _fill(fill)
    try:
        scene = load_scene(scene_path)
        if not fatigue:
            scene = dataclasses.replace(scene, fatigue=dataclasses.replace(scene.fatigue,
                                                                           B=1e11))
        life_keys = {"running_in": "plastic"} if running_in else {}
        if pit_contact is not None:
            life_keys["pit_contact"] = pit_contact
        scene = dataclasses.replace(scene, life=dataclasses.replace(scene.life, **life_keys))
        run = ItemRun(scene, WorkItem(0, position, k_lub, 1.0, patch))
        t0 = time.perf_counter()
        if running_in:          # here, so that the slopes are measured from the run-in surfaces
            run.running_in = run_in(run.cycle, run.state, run.life)
        start = [b.heights.copy() for b in run.state.bodies]
        for _ in range(blocks):
            rec = run.run_block()
        wall = time.perf_counter() - t0
        result, steps = _one_cycle(run, scene)
    finally:
        _fill("mean")
    rows = []
    grid, w = run.cycle.grid, np.asarray(run.cycle.weights)
    for i, bs in enumerate(run.state.bodies):
        pitted = bs.pitted.astype(bool)
        intact = ~pitted
        near = ndimage.binary_dilation(pitted, iterations=NEAR_CELLS, structure=np.ones((3, 3)))
        rate = result.bodies[i].wear
        total = float(rate.rate[intact].sum())
        free = np.zeros(grid.shape) if steps else np.ones(grid.shape)    # no pits: all free
        for (t, mask, _moved), wj in zip(steps, w, strict=bool(steps)):
            free += wj * to_material_frame((~mask).astype(float), run.cycle.slip(i + 1, t),
                                           grid.dx)
        film = rate.fluid[intact]
        corr_free = (float(np.corrcoef(film, free[intact])[0, 1])
                     if film.std() > 0 and free[intact].std() > 0 else float("nan"))
        wear = bs.wear[intact]
        corr_h = (float(np.corrcoef(wear, start[i][intact])[0, 1]) if wear.std() > 0
                  else float("nan"))
        rows.append((position, k_lub, patch, fill, "on" if fatigue else "off",
                     "plastic" if running_in else "none", scene.life.pit_contact,
                     run.state.cycles / 1e6, i + 1, rec.Ap[i], float(bs.wear.mean()) * 1e6,
                     float(pitted.mean()), pair_slope_ratio(bs.heights, pitted, start[i]),
                     pair_slope_ratio(bs.heights, pitted, start[i], where=near),
                     pair_slope_ratio(bs.heights, pitted, start[i], where=~near), corr_h,
                     float(rate.solid[intact].sum()) / total if total > 0 else float("nan"),
                     float(np.median([s[2] for s in steps])) if steps else 0.0,
                     float(free[intact].mean()), float(free[intact].std()), corr_free, wall))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", type=Path, default=ROOT / "scenes" / "paper_gear_z23.toml")
    ap.add_argument("--position", type=int, default=4)
    ap.add_argument("--k-lub", type=float, default=5e-11)
    ap.add_argument("--patch", type=int, default=0)
    ap.add_argument("--blocks", type=int, default=2)
    ap.add_argument("--fill", nargs="+", default=["mean"], choices=("mean", "max", "flat"))
    ap.add_argument("--no-fatigue", action="store_true")
    ap.add_argument("--running-in", action="store_true",
                    help="flatten the tips first (life.running_in = \"plastic\")")
    ap.add_argument("--pit-contact", choices=("unloaded", "open", "geometric"),
                    help="life.pit_contact (default: the scene's)")
    ap.add_argument("--csv")
    a = ap.parse_args(argv)
    print(",".join(COLUMNS), flush=True)
    rows = []
    for fill in a.fill:
        for row in measure(a.position, a.k_lub, a.patch, a.blocks, fill, not a.no_fatigue,
                           a.scene, a.running_in, a.pit_contact):
            emit(row)
            rows.append(row)
    write_csv(a.csv, COLUMNS, rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
