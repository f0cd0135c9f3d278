"""The MPR rig's film share φ against the grid (docs/performance.md, "The MPR rig's film share").

    .venv/bin/python benchmarks/bench_film_share.py [--runs old:256:128,256 old:512:128,256,384,512
        new:512:128,256,384,512] [--out benchmarks/results]

Each run ``ACF:REF:GRIDS`` makes one realisation of both surfaces of the MPR case of
bench_speed_error.py (scenes/paper_mpr_beta30.toml, position 3, |S| = 0.30, k_lub = 1e-11 s)
on a REF² grid over the scene's window and resamples it (antialiased) to each grid n of GRIDS;
ACF ``old`` is the Gaussian-ACF generator before the fix (R sampled at the minimum-image lags,
``gaussian_surface(..., periodic_acf=False)``), ``new`` the periodic ACF (the default now).
Per grid, one load-cycle evaluation on the fresh surfaces (bench_speed_error.cycle_row):
φ (the solids' load share, load-weighted over the steps), A_p1M [%] and D_max,1M at its rates,
the solid-contact share of the window (clearance ≤ h_min, mean over the steps), and ``tail_nm``:
the rms height of both surfaces together at wavenumbers above half the 128² grid's Nyquist
(|k_x| or |k_y| > π/(2 Δx₁₂₈)), the roughness a coarse grid cannot see.

Rows go to ``OUT/film_share.csv`` as they finish (a re-run skips the rows there). One core, one
process; the defaults take about 15 min on a busy 2-core machine (512²: about 4 min a row).
"""

from __future__ import annotations

import argparse
import csv
import functools
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_speed_error as bse

import micropit_hpc.surfaces.bodies as bodies
from micropit_hpc import source_commit
from micropit_hpc.plan import reference_half_width, window_grid
from micropit_hpc.surfaces.synthetic import gaussian_surface

FIELDS = ("acf", "ref_n", "n", "dx_um", "phi", "Ap_pct", "D_max", "solid", "tail_nm", "wall_s",
          "commit")
DEFAULT_RUNS = ("old:256:128,256", "old:512:128,256,384,512", "new:512:128,256,384,512")
TAIL_N = 128


def reference(acf: str, ref_n: int):
    """Both surfaces of the MPR case made on a ref_n² grid, with the old or the new ACF."""
    case = bse.CASES["mpr"]
    scene, study = bse._scene(bse._doc(case), case, {("window", "n"): ref_n})
    grid = window_grid(scene, reference_half_width(study))
    saved = bodies.gaussian_surface
    bodies.gaussian_surface = functools.partial(gaussian_surface, periodic_acf=(acf == "new"))
    try:
        return tuple(bodies.body_surface(scene, i, grid) for i in (1, 2))
    finally:
        bodies.gaussian_surface = saved


def tail_rms(surfaces, dx_coarse: float) -> float:
    """rms [m] of the summed heights at |k_x| or |k_y| above π/(2 dx_coarse)."""
    h = sum(s.heights for s in surfaces)
    nx, ny = h.shape
    kx = 2 * np.pi * np.fft.fftfreq(nx, surfaces[0].dx)[:, None]
    ky = 2 * np.pi * np.fft.fftfreq(ny, surfaces[0].dy)[None, :]
    cut = np.pi / (2 * dx_coarse)
    H = np.fft.fft2(h)
    tail = np.where((np.abs(kx) > cut) | (np.abs(ky) > cut), H, 0.0)
    return float(np.sqrt(np.mean(np.fft.ifft2(tail).real ** 2)))


def row(acf: str, ref_n: int, n: int, ref) -> dict:
    case = bse.CASES["mpr"]
    doc = bse._doc(case)
    scene, study = bse._scene(doc, case, {("window", "n"): n})
    coarse, coarse_study = bse._scene(doc, case, {("window", "n"): TAIL_N})
    dx128 = window_grid(coarse, reference_half_width(coarse_study)).dx
    t0 = time.perf_counter()
    run = bse._item(case, scene, study, ref)
    res = run.cycle.evaluate(run.surfaces)
    wall = time.perf_counter() - t0
    n_cyc = 1e6
    ap = max(100.0 * float(((n_cyc * b.damage_rate) >= 1.0).any(axis=0).mean())
             for b in res.bodies)
    dmax = max(float(n_cyc * b.damage_rate.max()) for b in res.bodies)
    return dict(acf=acf, ref_n=ref_n, n=n, dx_um=f"{run.cycle.grid.dx * 1e6:.4g}",
                phi=f"{res.phi:.4f}", Ap_pct=f"{ap:.3f}", D_max=f"{dmax:.4g}",
                solid=f"{res.solid_fraction:.4f}",
                tail_nm=f"{tail_rms(run.surfaces, dx128) * 1e9:.3f}", wall_s=f"{wall:.1f}",
                commit=source_commit())


def main(argv=None) -> Path:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", nargs="+", default=list(DEFAULT_RUNS))
    ap.add_argument("--out", type=Path, default=bse.ROOT / "benchmarks" / "results")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "film_share.csv"
    done = set()
    if path.exists():
        with open(path) as f:
            done = {(r["acf"], r["ref_n"], r["n"]) for r in csv.DictReader(f)}
    new = not path.exists()
    with open(path, "a", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        if new:
            w.writeheader()
        for spec in args.runs:
            acf, ref_n, grids = spec.split(":")
            if acf not in ("old", "new"):
                raise SystemExit(f"--runs {spec}: the ACF is 'old' or 'new'")
            ref = reference(acf, int(ref_n))
            for n in (int(x) for x in grids.split(",")):
                if (acf, ref_n, str(n)) in done:
                    continue
                r = row(acf, int(ref_n), n, ref)
                w.writerow(r)
                f.flush()
                print("  ".join(f"{k}={r[k]}" for k in FIELDS if k != "commit"), flush=True)
    return path


if __name__ == "__main__":
    main()
