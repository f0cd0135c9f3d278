"""Where one work item's block spends its time: a ``cProfile`` of one block of one item of a
scene (the converged default unless the scene says otherwise), one rank, one process, on one
256² roughness realisation resampled to the grid (as ``bench_wear_convergence.py``). Prints the
block's wall time and its numbers (sub-blocks, contact-only load cycles, A_p and wear, to
compare two versions of the code for equality), then the profile's lines by cumulative and by
own time.

    python benchmarks/bench_item_profile.py --position 5 --k-lub 5e-11 --n 64 --cycles-M 0.3

``--scan`` instead of the profile: the mixed solves' load-fraction scans (docs/performance.md
§3, "Where a rough item's time goes"): how many steps end at φ = 1, how many of their scans
have a film balance f(φ) that is not falling through the trials, the smallest f(φ_k)/f(1) over
their trials (of the scans that solved every trial), how many trials the scans started at
φ = 1 proved above the film and did not solve (``mixed.SCAN_CERTIFY``), and the dry solves'
count, time and iterations: at no load (φ = 0), the loose trials, and the solves at the
scene's tolerance.

``--wear-steps`` instead of the profile: the implicit wear's contact-only load cycles and how
many of them went to solves thrown away (cut after their solve by the accuracy or the shape
limit, or not converged; docs/life.md, "Steps cut at the shape limit"), then the block's
numbers.

``--time`` instead of the profile: the block's wall time without the profiler and its dry
solves, then its numbers; ``--plain-scan`` (with any mode): every trial of the load-fraction
scan solved in order, as before the scan started at φ = 1 where the last evaluation found no
root (``mixed.SCAN_CERTIFY``; docs/performance.md §11, "Trials proved above the film").

Timings, not tests: the profiler itself adds about a third to a contact-bound block.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import sys
import time
from collections import Counter
from itertools import pairwise
from pathlib import Path

from bench_wear_convergence import item_run, reference_surfaces

from micropit_hpc import life
from micropit_hpc.lubrication import mixed
from micropit_hpc.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]


def add_item_arguments(ap, position: int, cycles_M: float) -> None:
    """The options that choose the work item and its block (these defaults for ``--position``
    and ``--cycles-M``); :func:`item_from_arguments` makes it."""
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "paper_gear_z23.toml"))
    ap.add_argument("--position", type=int, default=position)
    ap.add_argument("--k-lub", type=float, default=5e-11)
    ap.add_argument("--n", type=int, default=64, help="grid points per side")
    ap.add_argument("--cycles-M", type=float, default=cycles_M, help="the block's cycles [M]")
    ap.add_argument("--ref", type=int, default=256, help="grid of the surface realisation")


def item_from_arguments(a):
    """The work item of :func:`add_item_arguments`' options, ready for ``run_block``."""
    base = load_scene(a.scene)
    return item_run(base, a.position, a.k_lub, a.n, max(a.cycles_M, base.life.block / 1e6),
                    reference_surfaces(base, a.ref))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_item_arguments(ap, position=5, cycles_M=0.3)
    ap.add_argument("--lines", type=int, default=40, help="profile lines per listing")
    ap.add_argument("--scan", action="store_true",
                    help="the load-fraction scans' statistics instead of the profile")
    ap.add_argument("--wear-steps", action="store_true",
                    help="the implicit wear's accepted and thrown-away solves instead of the "
                    "profile")
    ap.add_argument("--time", action="store_true",
                    help="the block's wall time and dry solves without the profiler instead "
                    "of the profile")
    ap.add_argument("--plain-scan", action="store_true",
                    help="every trial of the load-fraction scan solved, in order "
                    "(mixed.SCAN_CERTIFY off)")
    a = ap.parse_args(argv)
    run = item_from_arguments(a)
    if a.plain_scan:
        mixed.SCAN_CERTIFY = False
    if a.scan:
        return scan_statistics(run, a.cycles_M * 1e6)
    if a.time:
        return timed(run, a.cycles_M * 1e6)
    if a.wear_steps:
        return wear_step_statistics(run, a.cycles_M * 1e6)
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    rec = run.run_block(a.cycles_M * 1e6)
    prof.disable()
    print(f"wall {time.perf_counter() - t0:.1f} s under the profiler; {block_numbers(rec)}")
    for key in ("cumulative", "tottime"):
        pstats.Stats(prof, stream=sys.stdout).sort_stats(key).print_stats(a.lines)
    return 0


def block_numbers(rec) -> str:
    """The block's sub-blocks, contact-only cycles, A_p and wear, for comparing two codes."""
    return (f"sub-blocks {rec.sub_blocks}, contact-only cycles {rec.wear_cycles}; A_p "
            f"{rec.Ap[0]!r} / {rec.Ap[1]!r} %; wear {sum(rec.wear_mean)!r} m")


def timed(run, cycles: float) -> int:
    """One block of ``run`` without the profiler, its dry solves counted: ``--time``."""
    orig, solves = mixed.solve_dry_contact, [0]

    def dry(*args, **kw):
        solves[0] += 1
        return orig(*args, **kw)

    mixed.solve_dry_contact = dry
    try:
        t0 = time.perf_counter()
        rec = run.run_block(cycles)
        wall = time.perf_counter() - t0
    finally:
        mixed.solve_dry_contact = orig
    print(f"wall {wall:.1f} s, dry solves {solves[0]} (scan certified: {mixed.SCAN_CERTIFY}); "
          f"{block_numbers(rec)}")
    return 0


def wear_step_statistics(run, cycles: float) -> int:
    """One block of ``run`` with ``life.implicit_sub_block`` wrapped: its solves, contact-only
    cycles and thrown-away solves (:class:`~micropit_hpc.life.WearSteps`) summed, the
    statistics of ``--wear-steps`` (module docstring)."""
    steps = []

    def sub_block(*args, **kw):
        steps.append(orig(*args, **kw))
        return steps[-1]

    orig = life.implicit_sub_block
    life.implicit_sub_block = sub_block
    try:
        rec = run.run_block(cycles)
    finally:
        life.implicit_sub_block = orig
    lost = sum(w.thrown[0] for w in steps)
    lost_cycles = sum(w.thrown[1] for w in steps)
    spent = sum(w.contact_cycles for w in steps)
    print(f"wear sub-blocks {len(steps)}: {spent} contact-only cycles, of which {lost_cycles} "
          f"in {lost} solves thrown away")
    print(block_numbers(rec))
    return 0


def scan_statistics(run, cycles: float) -> int:
    """One block of ``run`` with ``MixedLubrication.solve`` and the dry solves it calls
    wrapped: the statistics of ``--scan`` (module docstring)."""
    orig_solve, orig_dry = mixed.MixedLubrication.solve, mixed.solve_dry_contact
    count, wall, iters = Counter(), Counter(), Counter()
    ratios = []

    def dry(*args, **kw):
        kind = ("no load" if args[2] == 0.0 else
                "loose trial" if kw.get("tol", 0.0) > base_tol else "scene's tolerance")
        t = time.perf_counter()
        sol = orig_dry(*args, **kw)
        count[kind] += 1
        wall[kind] += time.perf_counter() - t
        iters[kind] += sol.iterations
        return sol

    def solve(self, *args, **kw):
        sol = orig_solve(self, *args, **kw)
        f = [v for phi, level, v in self.last_scan if level == 0 and phi in mixed.PHI_SCAN]
        count["step"] += 1
        if sol.phi == 1.0 and f:
            count["phi = 1"] += 1
            count["proved"] += len(mixed.PHI_SCAN) - len(f)
            if len(f) == len(mixed.PHI_SCAN):       # every trial solved, in order
                count["not falling"] += any(a <= b for a, b in pairwise(f))
                ratios.append(min(f) / f[-1])
        return sol

    base_tol = run.cycle.scene.lubrication.tol
    mixed.MixedLubrication.solve, mixed.solve_dry_contact = solve, dry
    try:
        run.run_block(cycles)
    finally:
        mixed.MixedLubrication.solve, mixed.solve_dry_contact = orig_solve, orig_dry
    print(f"steps {count['step']}, at phi = 1 {count['phi = 1']}, of these with every trial "
          f"solved {len(ratios)}, with f(phi) not falling through the trials "
          f"{count['not falling']}; smallest f(phi_k)/f(1) "
          f"{min(ratios) if ratios else float('nan'):.4f}; trials proved above the film and "
          f"not solved {count['proved']} (mixed.SCAN_CERTIFY)")
    for kind in ("no load", "loose trial", "scene's tolerance"):
        n = max(count[kind], 1)
        print(f"dry solves at the {kind}: {count[kind]}, {1e3 * wall[kind] / n:.3f} ms and "
              f"{iters[kind] / n:.2f} iterations each")
    return 0


if __name__ == "__main__":
    sys.exit(main())
