"""The up-front estimate of scenes against their measured runs (docs/jobs.md, "The estimate"):
for each scene its items' time steps (fewest–most, mean), the estimate on ``--ranks`` ranks
with ``window.steps`` for every item (the estimate before 2026-12-03, at its constant
``--flat-constant``) and with each item's own steps (the one `micropit run` prints), and the
measured seconds when given as ``SCENE=SECONDS``. No run is made: only the plans and the
patches' surfaces.

    python benchmarks/bench_estimate.py scenes/quick.toml=25.4 study33.toml=521 \\
        scenes/gear_z30_45.toml --fit study33.toml scenes/quick.toml

``--fit`` prints the constant that makes the geometric mean of measured / estimated 1 over the
scenes named (each needs its measured seconds), as SECONDS_PER_POINT_LAYER_STEP was fitted."""
from __future__ import annotations

import argparse
import math

from micropit_hpc import estimate
from micropit_hpc.plan import life_blocks, make_plan
from micropit_hpc.scene import load_scene


def row(path: str, ranks: int, flat_constant: float) -> dict:
    """One scene's steps and both estimates [s], and its estimates at a constant of 1."""
    scene = load_scene(path)
    steps = estimate.item_steps(make_plan(scene))
    blocks = life_blocks(scene)
    flat = estimate.estimate(scene, ranks, 1, None, blocks, ranks)
    own = estimate.estimate(scene, ranks, 1, None, blocks, ranks, steps)
    per = estimate.SECONDS_PER_POINT_LAYER_STEP
    return {"steps": (min(steps), max(steps), sum(steps) / len(steps)),
            "flat_s": flat.total_s / per * flat_constant, "own_s": own.total_s,
            "own_raw": own.total_s / per, "per_rank_GiB": (flat.per_rank_bytes / estimate.GIB,
                                                           own.per_rank_bytes / estimate.GIB)}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="+", metavar="SCENE[=SECONDS]")
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--flat-constant", type=float, default=4.5e-6)
    ap.add_argument("--fit", nargs="*", default=[], metavar="SCENE")
    a = ap.parse_args(argv)
    measured, rows = {}, {}
    print("| scene | items' steps (fewest–most, mean) | window.steps | items' steps | "
          "GiB per rank (window.steps / items') | measured [s] |")
    print("|---|---|---|---|---|---|")
    for arg in a.scenes:
        path, _, secs = arg.partition("=")
        if secs:
            measured[path] = float(secs)
        r = rows[path] = row(path, a.ranks, a.flat_constant)
        lo, hi, mean = r["steps"]
        st = f"{lo}" if lo == hi else f"{lo}–{hi}, {mean:.1f}"
        print(f"| {path} | {st} | {r['flat_s']:.0f} s | {r['own_s']:.0f} s | "
              f"{r['per_rank_GiB'][0]:.3g} / {r['per_rank_GiB'][1]:.3g} | "
              f"{measured.get(path, '')} |")
    if a.fit:
        missing = [p for p in a.fit if p not in measured]
        if missing:
            raise SystemExit(f"--fit: no measured seconds for {', '.join(missing)} "
                             "(give them as SCENE=SECONDS)")
        c = math.exp(sum(math.log(measured[p] / rows[p]["own_raw"]) for p in a.fit) / len(a.fit))
        print(f"fitted SECONDS_PER_POINT_LAYER_STEP = {c:.3g} s")


if __name__ == "__main__":
    main()
