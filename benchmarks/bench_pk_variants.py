"""Why the contact solver keeps its conjugate directions and has no preconditioner: iterations
of four variants of the Polonsky–Keer iteration on the same elastic rough contacts.

    .venv/bin/python benchmarks/bench_pk_variants.py --sizes 128 256 512

A plain NumPy transcription of the elastic iteration of ``lubrication/dry.py``
(``_polonsky_keer``, no cap), written for the comparison only (the solver is not built on it):

* ``restart``: Polonsky & Keer (1999), steepest descent again whenever points enter;
* ``kept``: the directions stay conjugate through entries (dry.RESET_ON_ENTRY = False);
* ``... + FFT preconditioner``: the residual on the contact mapped through the inverse
  response p̂ = (E'|k|/4) û on the whole window, restricted to the contact and centred
  (the FFT-based preconditioner of Vollebregt, J. Comput. Phys. 257 (2014) 333–351),
  one more convolution per iteration.

Surface and load as bench_multilevel.py's ``random`` (2.75 GPa, 20 % contact at 256²); cold
start; stops at ε ≤ 1e-8 (the unscaled rule); the pressure error against bench_multilevel's
tight reference. Prints a markdown table of iterations, entries and errors (no timings: the
transcription uses numpy.fft, not the solver's plans).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_multilevel import random_problem, reference


def polonsky_keer(gap0, hs, P, tol, keep: bool, precondition: bool, max_iter=20000):
    """Elastic load-controlled Polonsky–Keer iteration, eqs. (13)–(22) of their paper, with
    the two options above; returns (pressure, iterations, iterations in which points
    entered)."""
    shape, N = gap0.shape, gap0.size
    scale = float(np.sqrt(((gap0 - gap0.mean()) ** 2).mean()))
    p = np.full(shape, P)
    t = np.zeros(shape)
    G_old, conjugate, entries = 1.0, False, 0
    for it in range(1, max_iter + 1):
        g = gap0 + hs.displacement(p)
        S = p > 0
        g -= g[S].mean()
        res = np.where(S, g, 0.0)
        if np.sqrt((res**2).sum() / S.sum()) / scale <= tol:
            return p, it, entries
        if precondition:
            z = np.fft.irfft2(np.fft.rfft2(res) * hs.stiffness, s=shape)
            z = np.where(S, z, 0.0)
            z[S] -= z[S].mean()
        else:
            z = res
        G = float((res * z).sum())
        t = np.where(S, z + (G / G_old if conjugate else 0.0) * t, 0.0)
        G_old = G
        r = hs.displacement(t)
        curvature = float((t * (r - r[S].mean())).sum())
        if curvature <= 0.0:
            return p, it, entries
        tau = float((res * t).sum()) / curvature
        p = np.maximum(p - tau * t, 0.0)
        enter = (p == 0.0) & (g < 0.0)
        p[enter] -= tau * g[enter]
        entries += bool(enter.any())
        conjugate = keep or not enter.any()
        p *= P * N / p.sum()
    raise RuntimeError("no convergence")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[128, 256, 512])
    ap.add_argument("--tol", type=float, default=1e-8)
    args = ap.parse_args()
    print("| grid | variant | iterations | iterations with entries | pressure error |")
    print("|---|---|---|---|---|")
    for n in args.sizes:
        problem = random_problem(n, 2.75e9)
        ref = reference(problem, 1e-13)
        for keep in (False, True):
            for pre in (False, True):
                p, it, entries = polonsky_keer(*problem[:3], args.tol, keep, pre)
                name = ("kept" if keep else "restart") + (" + FFT preconditioner" if pre else "")
                err = np.linalg.norm(p - ref) / np.linalg.norm(ref)
                print(f"| {n}² | {name} | {it} | {entries} | {err:.2e} |", flush=True)


if __name__ == "__main__":
    main()
