"""Time per convolution of the contact solver's plan (``RealFFT2.convolve``: one forward and one
inverse real 2-D transform and the product with the transfer function), ESTIMATE plans against
this machine's measured (wisdom) plans, and its growth against N² log N.

    .venv/bin/python -m micropit_hpc.spectral plan 256 512 1024 2048     # once per machine
    .venv/bin/python benchmarks/bench_fft_plans.py --sizes 256 512 1024 2048

Each planner runs in a process of its own (``MICROPIT_FFTW_PLANNER=estimate``, then ``auto``,
which takes the wisdom file's plans), twice in turn (estimate, auto, estimate, auto); per
size the median of 7 batches, the smaller of the two runs' (the one less disturbed by other
jobs). One core. Prints a markdown table. Timings, not tests.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time


def child(sizes) -> None:
    """In the child process: the time per convolution of each size, one line each."""
    import numpy as np

    from micropit_hpc.spectral import Grid, RealFFT2

    for n in sizes:
        g = Grid(n, n, 1.0, 1.0)
        plan = RealFFT2((n, n))
        transfer = plan.interleaved(1.0 / (1.0 + g.kappa))
        plan.real_input[...] = np.random.default_rng(1).standard_normal((n, n))
        reps = max(3, int(1e7 / n**2))
        times = []
        for _ in range(7):
            t0 = time.perf_counter()
            for _ in range(reps):
                plan.convolve(transfer)
            times.append((time.perf_counter() - t0) / reps)
        print(n, plan.from_wisdom, statistics.median(times), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 512, 1024, 2048])
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.sizes)
        return
    import math

    runs: dict[str, list[dict[int, tuple[bool, float]]]] = {"estimate": [], "auto": []}
    for _ in range(2):
        for planner in runs:
            out = subprocess.run(
                [sys.executable, __file__, "--child", "--sizes", *map(str, args.sizes)],
                env={**os.environ, "MICROPIT_FFTW_PLANNER": planner, "OMP_NUM_THREADS": "1"},
                check=True, capture_output=True, text=True).stdout.split("\n")
            runs[planner].append({int(a): (b == "True", float(c))
                                  for a, b, c in (line.split() for line in out if line)})
    print("| grid | ESTIMATE [ms] | measured (wisdom) [ms] | ratio | ESTIMATE per N² log₂ N² "
          "[ns] | measured per N² log₂ N² [ns] |")
    print("|---|---|---|---|---|---|")
    for n in args.sizes:
        e = min(r[n][1] for r in runs["estimate"])
        m = min(r[n][1] for r in runs["auto"])
        wise = all(r[n][0] for r in runs["auto"])
        unit = n * n * math.log2(n * n) * 1e-9
        print(f"| {n}² | {1e3 * e:.3f} | {1e3 * m:.3f}{'' if wise else ' (no wisdom)'} | "
              f"{m / e:.2f} | {e / unit:.3f} | {m / unit:.3f} |")


if __name__ == "__main__":
    main()
