"""Time of the dry FFT contact solve (Polonsky–Keer with cap) on a random rough surface.

    .venv/bin/python benchmarks/bench_contact.py [--sizes 128 256 512] [--repeat 3]
    mpirun -n 2 .venv/bin/python benchmarks/bench_contact.py --sizes 256 512   # distributed

Gaussian transverse-lay surface (β_x = 30 µm, β_y = 300 µm, R_q = 1 µm) on a 0.4 mm window;
the mean pressure is set so that about 20 % of the window is in contact; relative tolerance
1e-8; cold start (no warm start); one core. Prints a markdown table with date and commit.

Under ``mpirun -n R`` (R > 1) the timed solve is the distributed one (docs/hpc.md §2): the
window's x rows split over the R ranks of ``COMM_WORLD`` (:class:`~micropit_hpc.parallel.slab.
Slab`, mpi4py-fft), one core per rank; the load is found by serial solves on every rank (not
timed), and the table also gives the largest difference from the serial solution relative to
its largest value.
"""

from __future__ import annotations

import argparse
import datetime
import statistics
import subprocess
import time

import numpy as np

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
    comm = _world()
    ranks = 1 if comm is None else comm.size
    say = print if comm is None or comm.rank == 0 else (lambda *a, **k: None)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    say(f"dry contact solve, {datetime.date.today()}, commit {commit}, {ranks} rank(s), one "
        "core each\n")
    say("| grid | ranks | contact area | iterations | time [s] | ms per iteration | "
        "vs serial |")
    say("|---|---|---|---|---|---|---|")
    for n in args.sizes:
        g = Grid(n, n, 4e-4, 4e-4)
        z = gaussian_surface(g, 1e-6, 30e-6, 300e-6, seed=1).heights
        gap0 = -z - (-z).min()
        hs = ElasticHalfSpaces(g, E_PRIME)
        P = load_for_area(gap0, hs)
        tol = LubricationSpec().tol
        if comm is None:
            timed_hs, rows = hs, slice(0, n)
        else:
            from micropit_hpc.parallel.slab import Slab

            slab = Slab(comm, g, 1)
            timed_hs, rows = ElasticHalfSpaces(g, E_PRIME, slab), slab.rows
        times = []
        for _ in range(args.repeat):
            if comm is not None:
                comm.Barrier()
            t0 = time.perf_counter()
            sol = solve_dry_contact(gap0[rows], timed_hs, P, tol=tol, max_iter=MAX_ITER)
            t1 = time.perf_counter() - t0
            times.append(t1 if comm is None else comm.allreduce(t1, op=_mpi_max()))
        t = statistics.median(times)
        p = sol.pressure
        diff = "—"
        if comm is not None:
            p = slab.allgather_rows(p)
            ref = solve_dry_contact(gap0, hs, P, tol=tol, max_iter=MAX_ITER)
            diff = f"{np.abs(p - ref.pressure).max() / ref.pressure.max():.1e}"
            if ref.iterations != sol.iterations:
                diff += f" ({ref.iterations} it. serial)"
        area = np.count_nonzero(p > 0.0) / p.size
        say(f"| {n}² | {ranks} | {100 * area:.1f} % | {sol.iterations} | {t:.3f} | "
            f"{1e3 * t / sol.iterations:.2f} | {diff} |")


def _world():
    """COMM_WORLD when run under mpirun with several ranks, else None (no MPI needed)."""
    import os

    if not any(k in os.environ for k in ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE")):
        return None
    from mpi4py import MPI

    return MPI.COMM_WORLD if MPI.COMM_WORLD.size > 1 else None


def _mpi_max():
    from mpi4py import MPI

    return MPI.MAX


if __name__ == "__main__":
    main()
