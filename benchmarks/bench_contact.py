"""Time of the dry FFT contact solve (Polonsky–Keer with cap) on a random rough surface.

    .venv/bin/python benchmarks/bench_contact.py [--sizes 128 256 512] [--repeat 3]

Gaussian transverse-lay surface (β_x = 30 µm, β_y = 300 µm, R_q = 1 µm) on a 0.4 mm window;
the mean pressure is set so that about 20 % of the window is in contact; relative tolerance
1e-8; cold start (no warm start); one core. Prints a markdown table with date and commit.
"""

from __future__ import annotations

import argparse
import datetime
import statistics
import subprocess
import time

from micropit_hpc.lubrication.dry import ElasticHalfSpaces, solve_dry_contact
from micropit_hpc.scene import LubricationSpec
from micropit_hpc.spectral import Grid
from micropit_hpc.surfaces import gaussian_surface

E_PRIME = 210e9 / (1 - 0.3**2)
#: The scene's iteration limit of one contact solve (lubrication.max_iterations).
MAX_ITER = LubricationSpec().max_iter


def load_for_area(gap0, hs, target=0.2):
    """Mean pressure giving about ``target`` contact area (secant on log P)."""
    P, lo, hi = 1e9, None, None
    for _ in range(30):
        frac = solve_dry_contact(gap0, hs, P, tol=1e-5, max_iter=MAX_ITER).area_fraction
        if abs(frac - target) < 0.01:
            return P
        if frac < target:
            lo = P
            P = P * 2 if hi is None else (P + hi) / 2
        else:
            hi = P
            P = P / 2 if lo is None else (P + lo) / 2
    return P


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[128, 256, 512])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    print(f"dry contact solve, {datetime.date.today()}, commit {commit}, 1 core\n")
    print("| grid | contact area | iterations | time [s] | ms per iteration |")
    print("|---|---|---|---|---|")
    for n in args.sizes:
        g = Grid(n, n, 4e-4, 4e-4)
        z = gaussian_surface(g, 1e-6, 30e-6, 300e-6, seed=1).heights
        gap0 = -z - (-z).min()
        hs = ElasticHalfSpaces(g, E_PRIME)
        P = load_for_area(gap0, hs)
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            sol = solve_dry_contact(gap0, hs, P, tol=LubricationSpec().tol, max_iter=MAX_ITER)
            times.append(time.perf_counter() - t0)
        t = statistics.median(times)
        print(f"| {n}² | {100 * sol.area_fraction:.1f} % | {sol.iterations} | {t:.3f} | "
              f"{1e3 * t / sol.iterations:.2f} |")


if __name__ == "__main__":
    main()
