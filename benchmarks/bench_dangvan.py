"""Dang Van timing (1 core): the NumPy reference against the compiled (Numba) kernel, on the
stress histories of real load cycles, and their largest differences.

Histories: body 1 of the MPR contact (scenes/paper_mpr.toml, |S| = 0.30, position 3) and of the
gear (scenes/paper_gear_z23.toml, position 3), 20 steps × 15 layers, on 64² and 128² windows
(the scene's window with ``window.n`` set). Each history is one load cycle's, as
PositionCycle.evaluate builds it. Also random 5-D clouds (the enclosing ball alone, NumPy).

    PYTHONPATH=. .venv/bin/python benchmarks/bench_dangvan.py [--sizes 64,128] [--repeat 3]

Prints, per case, the points, the best of ``--repeat`` wall times of both kernels as the load
cycle calls them (τ_DV alone), points/s and the speed-up; the times with the series
(keep_series=True, rainflow counting); and the largest relative differences of τ_DV and of the
series (relative to each point's largest |series|) between the kernels. The first call of the
compiled kernel in a fresh process (Numba import + loading the cached machine code, or
compiling it where no cache exists) is timed separately.
"""

import argparse
import time
import tomllib

import numpy as np

from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import PositionCycle
from micropit_hpc.scene import scene_from_dict


def history(path: str, position: int, n: int) -> np.ndarray:
    """Body 1's stress history (m, 6, Nz, nx, ny) of one load cycle on an n² window."""
    with open(path, "rb") as f:
        doc = tomllib.load(f)
    doc.setdefault("window", {})["n"] = n
    scene = scene_from_dict(doc, path)
    cyc = PositionCycle(contact_study(scene), position)
    fields, p_prev = [], None
    for j in range(cyc.steps):
        fields.append(cyc.solve_step(j, p_prev))
        p_prev = fields[-1].pressure
    return np.stack([cyc.stresses(f, 1) for f in fields])


def best_of(fn, repeat: int) -> tuple[float, object]:
    best, out = np.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="64,128")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    t = time.perf_counter()
    from micropit_hpc.fatigue.dangvan import dang_van, numba_kernel
    compiled = numba_kernel()
    t_import = time.perf_counter() - t
    if compiled is None:
        raise SystemExit("Numba is not importable: only the NumPy path exists here")
    one = np.zeros((20, 6, 1))
    one[:, 0, 0] = np.sin(np.linspace(0.0, 6.0, 20))
    t = time.perf_counter()
    dang_van(one, kernel="numba")
    t_first = time.perf_counter() - t
    print(f"compiled kernel, first call in this process: Numba import {t_import:.2f} s, "
          f"first call (cache load or compile) {t_first:.2f} s")

    cases = [("MPR, S 0.30", "scenes/paper_mpr.toml", 3),
             ("gear pos. 3", "scenes/paper_gear_z23.toml", 3)]
    print("| history | points (Nz × n²) | NumPy [s] | Numba [s] | NumPy [points/s] | "
          "Numba [points/s] | speed-up | with series: NumPy / Numba [s] | "
          "max rel. diff τ_DV | max rel. diff series |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for n in (int(s) for s in args.sizes.split(",")):
        for name, path, pos in cases:
            h = history(path, pos, n)
            pts = h[0, 0].size
            t_np, _ = best_of(lambda h=h: dang_van(h, kernel="numpy"), args.repeat)
            t_nb, _ = best_of(lambda h=h: dang_van(h, kernel="numba"), args.repeat)
            ts_np, ref = best_of(lambda h=h: dang_van(h, kernel="numpy", keep_series=True),
                                 args.repeat)
            ts_nb, new = best_of(lambda h=h: dang_van(h, kernel="numba", keep_series=True),
                                 args.repeat)
            d_tau = np.max(np.abs(new.tau_dv - ref.tau_dv) / np.abs(ref.tau_dv))
            s_ref = ref.series.reshape(h.shape[0], -1)
            s_new = new.series.reshape(h.shape[0], -1)
            d_ser = np.max(np.abs(s_new - s_ref).max(axis=0) / np.abs(s_ref).max(axis=0))
            print(f"| {name}, {n}² | {pts} | {t_np:.3f} | {t_nb:.3f} | {pts / t_np:,.0f} | "
                  f"{pts / t_nb:,.0f} | {t_np / t_nb:.1f}× | {ts_np:.3f} / {ts_nb:.3f} | "
                  f"{d_tau:.1e} | {d_ser:.1e} |", flush=True)


if __name__ == "__main__":
    main()
