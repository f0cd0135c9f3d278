"""Dang Van timing (1 core): enclosing-ball iterations and wall time, on random 5-D clouds and
on the stress histories of the MPR contact (scenes/paper_mpr.toml, |S| = 0.30, 128² × 15
layers × 20 steps, body 1).

    .venv/bin/python benchmarks/bench_dangvan.py
"""

import time

import numpy as np

from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import PositionCycle
from micropit_hpc.fatigue.dangvan import dang_van, deviator_vectors, enclosing_ball
from micropit_hpc.scene import load_scene


def main() -> None:
    rng = np.random.default_rng(0)
    p = rng.normal(size=(5, 20, 200_000))
    t = time.perf_counter()
    _, _, it = enclosing_ball(p, tol=1e-10)
    print(f"random clouds, 200000 sets of 20 points in 5-D: {time.perf_counter() - t:.2f} s, "
          f"iterations median {np.median(it):.0f}, max {it.max()}")
    scene = load_scene("scenes/paper_mpr.toml")
    cyc = PositionCycle(contact_study(scene), 3)
    fields, p_prev = [], None
    for j in range(cyc.steps):
        fields.append(cyc.solve_step(j, p_prev))
        p_prev = fields[-1].pressure
    hist = np.stack([cyc.stresses(f, 1) for f in fields])
    n = hist[0, 0].size
    v = deviator_vectors(hist.reshape(hist.shape[0], 6, -1).transpose(1, 0, 2))
    t = time.perf_counter()
    _, _, it = enclosing_ball(v, tol=1e-10)
    t_ball = time.perf_counter() - t
    t = time.perf_counter()
    dang_van(hist)
    t_dv = time.perf_counter() - t
    print(f"MPR history, {n} points x 20 steps: enclosing ball {t_ball:.2f} s (iterations "
          f"median {np.median(it):.0f}, max {it.max()}); dang_van in all {t_dv:.2f} s")


if __name__ == "__main__":
    main()
