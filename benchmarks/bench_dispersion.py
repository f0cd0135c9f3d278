"""The dispersion relation of the mixed model's complementary wave (``mixed.solve_dispersion``):
the NumPy reference against the compiled kernel (``lubrication/_mixed_numba.py``) on one half
spectrum, one core, gear-like numbers (h̄ = 0.37 µm, ū = 7.6 m/s, E' = 230 GPa, B = 17 GPa)
at four pairs of Eyring viscosities from viscous to inviscid.

    python benchmarks/bench_dispersion.py --n 1024

Prints per row the two times (the compiled one after a call that compiles it), their ratio, the
largest difference of ψ relative to max(|ψ|, |a|), both residuals and the compiled kernel's
Newton steps per mode (64 in the reference). Timings, not tests: docs/performance.md §11.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from micropit_hpc.lubrication import _mixed_numba  # noqa: E402
from micropit_hpc.lubrication.mixed import (  # noqa: E402
    DISPERSION_STAGE_TOL,
    DISPERSION_STEP_TOL,
    solve_dispersion_rows,
)
from micropit_hpc.spectral import Grid  # noqa: E402

CASES = ((9.8, 7.5, 130.0), (5.4, 30.0, 300.0), (9.8, 1e-3, 1e-3), (9.8, 1e8, 1e8))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=1024, help="grid points per side")
    ap.add_argument("--window", type=float, default=2.05e-4, help="window side [m]")
    a = ap.parse_args(argv)
    g = Grid(a.n, a.n, a.window, a.window)
    kx, ky = g.kx + 0 * g.ky, g.ky + 0 * g.kx
    ub, h, Ep, B = 7.6, 0.37e-6, 2.3e11, 17e9
    m = a.n // 2 + 1
    print("u_i eta_x eta_y numpy_s numba_s ratio max_rel_diff res_numpy res_numba newton_per_mode")
    for ui, ex, ey in CASES:
        args = (kx * ui / ub, Ep * h**3 / (48 * ub), h * Ep / (4 * B), ky, ex, ey)
        solve_dispersion_rows(*args, kernel="numba")
        t0 = time.perf_counter()
        ref, r0 = solve_dispersion_rows(*args, kernel="numpy")
        t1 = time.perf_counter()
        new, r1 = solve_dispersion_rows(*args, kernel="numba")
        t2 = time.perf_counter()
        scale = np.maximum(np.abs(ref), np.abs(args[0]))
        diff = float((np.abs(new - ref) / np.where(scale > 0, scale, 1.0)).max())
        half = np.ascontiguousarray(args[0][:m], dtype=complex).ravel()
        _, steps = _mixed_numba.dispersion(
            half, np.ascontiguousarray(ky[:m] ** 2).ravel(), args[1], args[2], ex, ey,
            np.geomspace(1 / 128, 1, 8), 8, DISPERSION_STEP_TOL, DISPERSION_STAGE_TOL,
            np.empty_like(half))
        print(f"{ui} {ex:g} {ey:g} {t1 - t0:.3f} {t2 - t1:.3f} {(t1 - t0) / (t2 - t1):.1f} "
              f"{diff:.2e} {r0:.1e} {r1:.1e} {steps / half.size:.1f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
