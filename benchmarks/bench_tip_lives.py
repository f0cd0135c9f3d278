"""Why the asperities fail before the wear reaches them (issue 29 item 6, docs/life.md "Why
the tips fail before the wear reaches them"): one load cycle of one work item of the paper
gear on its fresh surfaces (one realisation made on ``--ref``² and resampled, as
bench_wear_convergence.py), and for every column that this cycle's rates would fail within
``--horizon-M`` M cycles: its life N_f = 1/max_z(damage per cycle), the depth z_f of that
most damaged point, the largest pressure the column carries in the cycle, its Dang Van
stress there, and the wear that the fresh Archard rate (no relief: an upper bound of what the
implicit wear removes) takes off the column within N_f, against z_f, the depth the wear would
have to remove before the point fails. The Archard rate is linear in k_lub (both its film
and its solid part), so one evaluation serves every ``--k-lub`` (the first one's, scaled).

    python benchmarks/bench_tip_lives.py --position 5 --n 64 --csv results/tip_lives_p5_64.csv

Each row names the scene (its file stem) and the criterion's process length ℓ [µm] the run
used (``fatigue.process_length_um`` or its integration's default), so rows of several scenes
and lengths can share a file: ``--csv`` appends to an existing file with these columns and
refuses one with other columns, naming it (older files of this benchmark have only one of the
two: write the new rows elsewhere).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from bench_wear_convergence import item_run, reference_surfaces, scene_name
from table import append_csv, emit

from micropit_hpc.life import contact_surfaces
from micropit_hpc.scene import load_scene
from micropit_hpc.wear import to_material_frame

ROOT = Path(__file__).resolve().parents[1]
COLUMNS = ("scene", "process_length_um", "position", "k_lub_s", "n", "body", "columns_failing",
           "share_pct",
           "share_below_n_min_pct", "share_at_surface_pct", "N_f_p10", "N_f_p50", "N_f_p90",
           "z_f_um_p50",
           "p_max_over_p_lim_p50", "tau_dv_MPa_p50", "wear_in_N_f_nm_p50",
           "wear_in_N_f_nm_p90", "wear_over_z_f_p50", "wear_over_z_f_p90",
           "cycles_to_wear_z_f_p50")


def append_rows(path: str | None, rows) -> None:
    """``rows`` appended to the CSV ``path`` under :data:`COLUMNS` (:func:`table.append_csv`:
    a file of other columns refused, naming it, before anything is written)."""
    append_csv(path, COLUMNS, rows, "bench_tip_lives")


def _q(a, f):
    return float(np.quantile(a, f)) if a.size else float("nan")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "paper_gear_z23.toml"))
    ap.add_argument("--position", type=int, default=5)
    ap.add_argument("--k-lub", type=float, nargs="+", default=[5e-11, 1e-11])
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--ref", type=int, default=256, help="grid of the surface realisation")
    ap.add_argument("--horizon-M", type=float, default=1.0,
                    help="columns whose fresh life is below this many M cycles")
    ap.add_argument("--csv", default=None)
    a = ap.parse_args(argv)
    base = load_scene(a.scene)
    append_rows(a.csv, [])            # a file of other columns refused before the run
    k0 = a.k_lub[0]
    ell = base.fatigue.process_length * 1e6
    run = item_run(base, a.position, k0, a.n, 1.0, reference_surfaces(base, a.ref))
    cycle, state = run.cycle, run.state
    surfaces, pits = contact_surfaces(state, cycle.grid, run.life.pit_contact)
    result = cycle.evaluate(surfaces, pits, {}, None)
    dx = cycle.grid.dx
    p_max = [np.zeros(cycle.grid.shape), np.zeros(cycle.grid.shape)]
    for j in range(cycle.steps):          # the pressure each body's columns carry
        f = cycle.solve_step(j)
        for i in (0, 1):
            np.maximum(p_max[i], to_material_frame(f.pressure, cycle.slip(i + 1, f.t), dx),
                       out=p_max[i])
    n_min = cycle.woehler.n_min
    print(",".join(COLUMNS), flush=True)
    rows = []
    for i, bc in enumerate(result.bodies):
        rate = bc.damage_rate
        top = rate.max(axis=0)
        k = np.argmax(rate, axis=0)
        with np.errstate(divide="ignore"):
            life = np.where(top > 0, 1.0 / np.where(top > 0, top, 1.0), np.inf)
        fail = life <= a.horizon_M * 1e6
        z_f = cycle.z[k][fail]
        n_f = life[fail]
        tau = np.take_along_axis(bc.tau_rough, k[None], 0)[0][fail]
        deep = z_f > 0
        for k_lub in a.k_lub:
            wear = bc.wear.rate[fail] * (k_lub / k0)
            worn = wear * n_f
            ratio = worn[deep] / z_f[deep]
            with np.errstate(divide="ignore"):
                to_z = np.where(wear[deep] > 0, z_f[deep] / np.where(wear[deep] > 0,
                                                                     wear[deep], 1.0), np.inf)
            row = (scene_name(base), ell, a.position, k_lub, a.n, i + 1, int(fail.sum()),
                   100.0 * fail.mean(),
                   100.0 * float((n_f < n_min).mean()) if n_f.size else 0.0,
                   100.0 * float((~deep).mean()) if n_f.size else 0.0,
                   _q(n_f, 0.1), _q(n_f, 0.5), _q(n_f, 0.9), _q(z_f, 0.5) * 1e6,
                   _q(p_max[i][fail] / cycle.p_lim, 0.5), _q(tau, 0.5) / 1e6,
                   _q(worn, 0.5) * 1e9, _q(worn, 0.9) * 1e9, _q(ratio, 0.5), _q(ratio, 0.9),
                   _q(to_z, 0.5))
            rows.append(row)
            emit(row)
    append_rows(a.csv, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
