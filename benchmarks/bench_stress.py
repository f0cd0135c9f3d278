"""Benchmark of the micro stress field: ``HalfSpaceStress.stresses`` (docs/model.md §4.2).

Times one call (6·N_z inverse real 2-D FFTs plus the kernel build; the 3 forward FFTs of the
tractions are not included; "ms per inverse FFT" is the call's time / (6·N_z), kernel build
included) after planning, as the median of several runs, on one core, for
grids 128², 256², 512² and 15 and 32 depth layers, and prints a markdown table with the date
and the git commit. Target (benchmarks/README.md): 256² × 32 layers under 0.15 s.

    .venv/bin/python benchmarks/bench_stress.py [--repeat 7]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")    # one core: before numpy is imported

import argparse  # noqa: E402
import datetime  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from micropit_hpc.mechanics import HalfSpaceStress, depth_layers  # noqa: E402
from micropit_hpc.spectral import Grid, have_pyfftw, planner_flag  # noqa: E402

CASES = [(n, nz) for n in (128, 256, 512) for nz in (15, 32)]


def git_commit() -> str:
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, check=True, cwd=Path(__file__).resolve().parent)
        return out.stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def time_case(n: int, nz: int, repeat: int) -> float:
    b = 1e-4
    grid = Grid(n, n, 2 * b, 2 * b)
    hs = HalfSpaceStress(grid, depth_layers(nz, 0.25 * b), 0.3)   # plans here
    rng = np.random.default_rng(0)
    p, qx, qy = rng.standard_normal((3, n, n))
    P, Tx, Ty = (s.copy() for s in hs.spectra(p, qx, qy))
    out = np.empty(hs.shape)
    hs.stresses(P, Tx, Ty, out=out)                                 # warm-up
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        hs.stresses(P, Tx, Ty, out=out)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7, help="timed runs per case (median)")
    args = ap.parse_args(argv)
    print(f"HalfSpaceStress.stresses, one core, median of {args.repeat} runs — "
          f"{datetime.date.today().isoformat()}, commit {git_commit()}, "
          f"{platform.processor() or platform.machine()}, pyFFTW: {have_pyfftw()} "
          f"({planner_flag()})")
    print()
    print("| grid | layers | time [s] | ms per inverse FFT |")
    print("|---|---|---|---|")
    for n, nz in CASES:
        t = time_case(n, nz, args.repeat)
        print(f"| {n}² | {nz} | {t:.4f} | {1e3 * t / (6 * nz):.3f} |", flush=True)


if __name__ == "__main__":
    main()
