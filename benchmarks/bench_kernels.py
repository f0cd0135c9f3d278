"""The two FFT kernels against their floor: one Polonsky–Keer iteration of the dry contact and
one depth layer of the stresses, each beside the bare time of the transforms it must do.

* ``contact``: :func:`micropit_hpc.lubrication.dry._polonsky_keer` on the rough gap of
  ``bench_contact.py`` (Gaussian transverse lay, R_q 1 µm, about 20 % contact, cold start,
  tolerance 1e-8), time per iteration (median of ``--repeat`` solves); floor: two real 2-D
  round trips (the forward and the inverse plan's ``execute`` alone, no copies, no products).
* ``stresses``: :meth:`~micropit_hpc.mechanics.HalfSpaceStress.stresses`, 15 layers in one
  call and one layer per call (as the streamed load cycle calls it from 256² on), time per
  layer (median); floor: one execute of the batch-6 inverse plan (six inverse transforms).

Each kernel is timed with the compiled stages (Numba, where importable) and with the NumPy
reference. One core; the FFT plans as the code makes them (``MICROPIT_FFTW_PLANNER``,
default ``auto``: this machine's measured plans where its wisdom file holds the size,
FFTW_ESTIMATE otherwise; the header says which each size got). Prints a markdown table with
the date and the commit (docs/performance.md §10); timings, not tests.

    .venv/bin/python benchmarks/bench_kernels.py [--sizes 128 256 512] [--repeat 5]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")    # one core: before numpy is imported

import argparse  # noqa: E402
import datetime  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench_contact import E_PRIME, MAX_ITER, load_for_area  # noqa: E402

from micropit_hpc import compiled, source_commit  # noqa: E402
from micropit_hpc.lubrication.dry import (  # noqa: E402
    ElasticHalfSpaces,
    _polonsky_keer,
    iteration_stages,
)
from micropit_hpc.mechanics import HalfSpaceStress, depth_layers  # noqa: E402
from micropit_hpc.parallel.slab import Reductions  # noqa: E402
from micropit_hpc.spectral import Grid, planner_flag, rfft_plan  # noqa: E402
from micropit_hpc.surfaces import gaussian_surface  # noqa: E402


def per_call(fn, repeat: int, inner: int = 1) -> float:
    """Median over ``repeat`` of the time of ``inner`` calls of ``fn``, per call [s]."""
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(inner):
            fn()
        times.append((time.perf_counter() - t0) / inner)
    return statistics.median(times)


def contact_rows(n: int, kernels, repeat: int):
    grid = Grid(n, n, 4e-4, 4e-4)
    z = gaussian_surface(grid, 1e-6, 30e-6, 300e-6, seed=1).heights
    gap0 = z.max() - z
    hs = ElasticHalfSpaces(grid, E_PRIME)
    P = load_for_area(gap0, hs)
    scale = float(gap0.std())
    plan = rfft_plan(grid.shape)
    floor = 2 * per_call(lambda: (plan._fwd.execute(), plan._inv.execute()), repeat,
                         inner=max(5, 2 ** 22 // n ** 2))
    rows = []
    for kernel in kernels:
        stages = iteration_stages(grid.shape, kernel)
        box = {}

        def solve(stages=stages, box=box):
            p, _, it, err, _ = _polonsky_keer(gap0, hs, P, scale, 1e-8, MAX_ITER,
                                              np.full(grid.shape, P), None,
                                              grid.nx * grid.ny, Reductions(None), stages)
            box["it"] = it
        t = per_call(solve, repeat)
        rows.append(("contact iteration", n, kernel, box["it"], t / box["it"], floor))
    return rows


def stress_rows(n: int, kernels, repeat: int, layers: int = 15):
    b = 1e-4
    grid = Grid(n, n, 2 * b, 2 * b)
    hs = HalfSpaceStress(grid, depth_layers(layers, 0.25 * b), 0.3)
    rng = np.random.default_rng(0)
    spectra = [s.copy() for s in hs.spectra(*rng.standard_normal((3, n, n)))]
    out = np.empty(hs.shape)
    plan = rfft_plan(grid.shape, batch=6)
    floor = per_call(plan._inv.execute, repeat, inner=max(5, 2 ** 20 // n ** 2))
    one = np.empty((6, 1, n, n))

    def streamed(kernel):
        """One layer per call, as the streamed load cycle calls it from 256² on."""
        for k in range(layers):
            hs.stresses(*spectra, out=one, layers=[k], kernel=kernel)

    rows = []
    for kernel in kernels:
        t = per_call(lambda k=kernel: hs.stresses(*spectra, out=out, kernel=k), repeat)
        rows.append(("stress layer, 15 per call", n, kernel, layers, t / layers, floor))
        t = per_call(lambda k=kernel: streamed(k), repeat)
        rows.append(("stress layer, 1 per call", n, kernel, layers, t / layers, floor))
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[128, 256, 512])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    kernels = ["numpy"]
    if compiled.compiled_module("lubrication._dry_numba") is not None:
        kernels.insert(0, "numba")
    measured = [n for n in args.sizes if rfft_plan((n, n)).from_wisdom
                and rfft_plan((n, n), batch=6).from_wisdom]
    others = [n for n in args.sizes if n not in measured]
    plans = "; ".join(part for part in (
        "measured plans (wisdom) at " + ", ".join(f"{n}²" for n in measured) if measured else "",
        f"{planner_flag()} at " + ", ".join(f"{n}²" for n in others) if others else "") if part)
    print(f"FFT kernels against their floor, one core, median of {args.repeat} — "
          f"{datetime.date.today().isoformat()}, commit {source_commit()}, FFTW {plans}")
    print()
    print("| kernel | grid | stages | iterations / layers | ms per iteration / layer "
          "| floor [ms] | ratio |")
    print("|---|---|---|---|---|---|---|")
    for n in args.sizes:
        for what, size, kernel, count, t, floor in (contact_rows(n, kernels, args.repeat)
                                                    + stress_rows(n, kernels, args.repeat)):
            print(f"| {what} | {size}² | {kernel} | {count} | {1e3 * t:.3f} | "
                  f"{1e3 * floor:.3f} | {t / floor:.2f} |", flush=True)


if __name__ == "__main__":
    main()
